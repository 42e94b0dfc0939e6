"""Dynamic response through the static tables: tooth loads, root strains, contact pressure, dynamic factors.

The HAC assumption (dissertation Section 3.3): the elastic state of the gears is fixed by the mesh position
``tau`` and the mesh deflection ``x``, dynamic or not.  So any tabulated static quantity ``Q(tau, x)`` (tooth
loads, root strains at gauges, maximum contact pressure) becomes a dynamic history by interpolating the table
along the dynamic trajectory ``(tau(t), x(t))`` (the one interpolation, :mod:`hacgear_core.tables.interp`).

Tooth-following convention: a physical tooth that belongs to the reference pair (offset 0) at mesh position
``tau`` in [0, 1) belongs to offset ``-n`` at ``tau + n`` (pair ``+1`` becomes the reference pair one mesh cycle
later).  Outside the table's offsets a tooth is out of mesh and its tabulated quantities are 0.

All functions take a :class:`~hacgear_core.tables.MeshTable`.
"""
from __future__ import annotations

import math

import numpy as np

from hacgear_core.errors import TableError
from hacgear_core.tables.fdf import (StaticStiffness, generalized_slopes, static_deflection, static_stiffness,
                                     table_arrays)
from hacgear_core.tables.interp import slope_many

__all__ = [
    "skipped_tooth_fraction",
    "tooth_loads",
    "dynamic_contact_pressure",
    "dynamic_root_strain",
    "dynamic_mesh_stiffness",
    "static_mesh_stiffness",
    "static_root_strain",
    "strain_dynamic_factor",
    "static_strain_max",
]


def _per_offset(table, values, tau, x) -> np.ndarray:
    """(n, Nw): the per-pair quantity of every offset at mesh positions ``tau`` (one vectorised call)."""
    tau = np.asarray(tau, dtype=float).ravel()
    x = np.asarray(x, dtype=float).ravel()
    frac = tau - np.floor(tau)
    offs = np.asarray(table.tooth_offsets).astype(int)
    ph = (frac[None, :] - offs[:, None]).ravel()
    v = table.interpolate_pair(values, ph, np.tile(x, offs.size))
    return v.reshape(offs.size, tau.size).T


def tooth_loads(table, tau, x) -> np.ndarray:
    """Load per tooth pair (n, Nw) [N] along the trajectory, columns = ``table.tooth_offsets``
    (offsets relative to the reference pair at each instant)."""
    return np.maximum(_per_offset(table, table.tooth_load_N, tau, x), 0.0)


def _at_twist(table, twist) -> bool:
    """Whether ``table`` is read at a mesh twist: the twist is given and the table has a twist axis."""
    return twist is not None and getattr(table, "twist", None) is not None


def dynamic_contact_pressure(table, tau, x, twist=None, part: str = "peak") -> np.ndarray:
    """Maximum contact pressure over all teeth (n,) [Pa] along the trajectory; for a helical mesh table (twist
    axis) at the mesh twist ``twist`` (n,) [rad] when given (trilinear lookup of the twist-resolved pressure).
    ``part``: "peak" over every contact, "flank" over the flank (Hertzian) contacts, "edge" over the tip-edge
    contacts (NaN for a table that does not tell them apart)."""
    tau = np.asarray(tau, float).ravel()
    x = np.asarray(x, float).ravel()
    if _at_twist(table, twist):
        g = np.asarray(twist, float).ravel()
        data = table.pressure_data(part, twist=True)
        if data is None:
            return np.full(tau.shape, np.nan)
        return np.maximum(table.twist_quantity(data, tau, x, g), 0.0)
    return table.pressure(tau, x, part)


def _gauge(table, gauge: str) -> np.ndarray:
    strain = getattr(table, "strain", None) or {}
    if gauge not in strain:
        raise TableError(f"no strain gauge {gauge!r} in the table; gauges: {sorted(strain)}")
    return np.asarray(strain[gauge], dtype=float)


def dynamic_root_strain(table, gauge: str, tau, x, tooth: int = 0) -> np.ndarray:
    """Root strain history (n,) [-] at ``gauge`` on one physical tooth along the trajectory.

    ``tau`` must be the *unwrapped* mesh position (cycles since the start); ``tooth`` is the offset
    of the followed tooth at ``tau`` in [0, 1) (see the module's tooth-following convention).
    """
    tau = np.asarray(tau, dtype=float).ravel()
    return table.interpolate_pair(_gauge(table, gauge), tau - tooth, np.asarray(x, dtype=float).ravel())


def dynamic_mesh_stiffness(table, tau, x, twist=None) -> np.ndarray:
    """Dynamic mesh stiffness (n,) [N/m]: local slope dF/dx of the FDF at the dynamic state
    (dissertation Fig. 3.12); 0 where the teeth are out of contact.  For a helical mesh table (twist axis) with
    the mesh twist ``twist`` (n,) [rad]: dW/dx of the trilinear generalized FDF at that twist
    (:func:`~hacgear_core.tables.fdf.generalized_slopes`: the slope of the deflection cell that holds x)."""
    tau = np.ascontiguousarray(np.asarray(tau, dtype=float).ravel())
    x = np.ascontiguousarray(np.asarray(x, dtype=float).ravel())
    if _at_twist(table, twist):
        g = np.asarray(twist, float).ravel()
        w = table.twist_quantity(table.twist.generalized_fdf, tau, x, g)[:, 0]
        return np.where(w > 0.0, generalized_slopes(table, tau, x, g)[:, 0, 0], 0.0)
    ta = table_arrays(table)
    out = np.empty(tau.size)
    slope_many(ta.ftab, ta.x0, ta.inv_dx, tau, x, out)
    return out


def static_mesh_stiffness(table, torque_Nm: float) -> StaticStiffness:
    """Static deflection, local-slope and average-slope mesh stiffness over the cycle at torque
    ``torque_Nm`` [N m] on gear a (means via the result's properties)."""
    return static_stiffness(table, torque_Nm / float(table.base_radius_m[0]))


def static_root_strain(table, gauge: str, force_N: float) -> np.ndarray:
    """Static root strain (Np, Nw) [-] at ``gauge`` at the static mesh force ``force_N`` [N]."""
    ta = table_arrays(table)
    xs = static_deflection(ta, force_N)
    return _per_offset(table, _gauge(table, gauge), np.asarray(table.position, float), xs)


def strain_dynamic_factor(table, tau, x, force_N: float, static_max: dict | None = None) -> dict:
    """Strain dynamic factor per gauge: max tensile dynamic root strain over all teeth along the
    trajectory divided by the max static root strain at ``force_N`` [N] over the cycle.
    ``static_max``: precomputed {gauge: max static strain} (see :func:`static_strain_max`).  Gauges on the
    unloaded side of the root (static tension below a tenth of the largest gauge's) are left out: their ratio of
    two small numbers is no dynamic factor."""
    sm = static_strain_max(table, force_N) if static_max is None else static_max
    top = max(sm.values(), default=0.0)
    out = {}
    for g, smax in sm.items():
        if smax <= 0 or smax < 0.1 * top:
            continue
        dyn = _per_offset(table, _gauge(table, g), tau, x)
        out[g] = float(np.max(dyn)) / smax
    return out


def skipped_tooth_fraction(table, tau, x, cycles: int, threshold: float = 0.01) -> float:
    """Fraction of the teeth that take (almost) no load during their whole pass through the mesh — tooth skipping
    (dissertation Section 2.4.2, Fig. 2.12) — along a periodic steady state of ``cycles`` mesh cycles (``tau``
    unwrapped mesh positions [cycles], ``x`` deflections [m], one period).  The period is repeated so that every
    tooth entering during it is followed through its whole window; a tooth is skipped when its largest load stays
    below ``threshold`` times the largest tooth load of the period."""
    tau = np.asarray(tau, float)
    x = np.asarray(x, float)
    offs = np.asarray(table.tooth_offsets)
    lo, hi = -int(offs.max()), 1 - int(offs.min())       # a tooth's window in its own pair phase
    cycles = max(int(cycles), 1)
    reps = 3 + int(math.ceil((hi - lo) / cycles))
    tt = np.concatenate([tau + r * cycles for r in range(reps)])
    xx = np.tile(x, reps)
    first, last = int(np.ceil(tt[0] - lo)), int(np.floor(tt[-1] - hi))
    teeth = np.arange(first, first + cycles)            # one period's worth of teeth, all inside the trace
    if teeth.size == 0 or teeth[-1] > last:
        return math.nan
    peak = np.array([float(np.max(np.maximum(table.tooth_load(tt, xx, int(i)), 0.0))) for i in teeth])
    ref = float(np.max(peak))
    if not ref > 0:
        return math.nan
    return float(np.mean(peak < threshold * ref))


def static_strain_max(table, force_N: float) -> dict:
    """{gauge: max static root strain over the cycle and all teeth} at ``force_N`` [N]."""
    return {g: float(np.max(static_root_strain(table, g, force_N)))
            for g in sorted(getattr(table, "strain", None) or {})}
