"""Post-processing of dynamic results through the static tables (dissertation Section 3.3).

The HAC assumption: the elastic state of the gears is fixed by the mesh position ``tau`` and the
mesh deflection ``x``, dynamic or not.  So any tabulated static quantity ``Q(tau, x)`` (tooth loads,
root strains at gauges, maximum contact pressure) becomes a dynamic history by interpolating the
table along the dynamic trajectory ``(tau(t), x(t))``.

Tooth-following convention: a physical tooth that belongs to the reference pair (offset 0) at mesh
position ``tau`` in [0, 1) belongs to offset ``-n`` at ``tau + n`` (pair ``+1`` becomes the
reference pair one mesh cycle later).  Outside the table's offsets a tooth is out of mesh and its
tabulated quantities are taken as 0.

All functions take a mesh table with the tables-contract attributes (duck-typed).
"""
from __future__ import annotations

import numpy as np

from hacgear_core.dynamics import kernels
from hacgear_core.dynamics.fdf import StaticStiffness, static_deflection, static_stiffness, table_arrays
from hacgear_core.errors import TableError

__all__ = [
    "interpolate_table",
    "tooth_loads",
    "dynamic_contact_pressure",
    "dynamic_root_strain",
    "dynamic_mesh_stiffness",
    "static_mesh_stiffness",
    "static_root_strain",
    "strain_dynamic_factor",
]


def interpolate_table(table, values, tau, x) -> np.ndarray:
    """Bilinear interpolation of a tabulated quantity along a trajectory.

    Parameters
    ----------
    table : mesh table
    values : array (Np, Nd, ...)
        Quantity on the table's (position, deflection) grid; trailing axes are carried along.
    tau : array (n,)
        Mesh positions [cycles] (any real; periodic with period 1).
    x : array (n,)
        Mesh deflections [m]; beyond the grid: linear extrapolation from the outermost columns.

    Returns
    -------
    array (n, ...)
    """
    ta = table_arrays(table)
    vals = np.asarray(values, dtype=float)
    npos, nd = ta.ftab.shape
    if vals.shape[:2] != (npos, nd):
        raise TableError(f"table quantity has shape {vals.shape}, expected ({npos}, {nd}, ...)")
    tau = np.asarray(tau, dtype=float).ravel()
    x = np.asarray(x, dtype=float).ravel()
    if tau.shape != x.shape:
        raise TableError(f"tau and x must have equal lengths, got {tau.shape} and {x.shape}")
    p = (tau - np.floor(tau)) * npos
    i = np.minimum(p.astype(int), npos - 1)
    a = p - i
    i1 = (i + 1) % npos
    r = (x - ta.x0) * ta.inv_dx
    j = np.clip(np.floor(r).astype(int), 0, nd - 2)
    b = r - j
    ex = (slice(None),) + (None,) * (vals.ndim - 2)
    a, b = a[ex], b[ex]
    v0 = vals[i, j] + b * (vals[i, j + 1] - vals[i, j])
    v1 = vals[i1, j] + b * (vals[i1, j + 1] - vals[i1, j])
    return v0 + a * (v1 - v0)


def tooth_loads(table, tau, x) -> np.ndarray:
    """Load per tooth pair (n, Nw) [N] along the trajectory, columns = ``table.tooth_offsets``."""
    return np.maximum(interpolate_table(table, table.tooth_load_N, tau, x), 0.0)


def dynamic_contact_pressure(table, tau, x) -> np.ndarray:
    """Maximum contact pressure over all teeth (n,) [Pa] along the trajectory."""
    return np.maximum(interpolate_table(table, table.peak_pressure_Pa, tau, x), 0.0)


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
    arr = _gauge(table, gauge)
    tau = np.asarray(tau, dtype=float).ravel()
    offs = list(np.asarray(table.tooth_offsets).astype(int))
    all_w = interpolate_table(table, arr, tau, x)  # (n, Nw)
    k = tooth - np.floor(tau).astype(int)
    out = np.zeros(tau.size)
    for w, off in enumerate(offs):
        sel = k == off
        out[sel] = all_w[sel, w]
    return out


def dynamic_mesh_stiffness(table, tau, x) -> np.ndarray:
    """Dynamic mesh stiffness (n,) [N/m]: local slope dF/dx of the FDF at the dynamic state
    (dissertation Fig. 3.12); 0 where the teeth are out of contact."""
    ta = table_arrays(table)
    tau = np.ascontiguousarray(np.asarray(tau, dtype=float).ravel())
    x = np.ascontiguousarray(np.asarray(x, dtype=float).ravel())
    out = np.empty(tau.size)
    kernels.table_slope_many(ta.ftab, ta.x0, ta.inv_dx, tau, x, out)
    return out


def static_mesh_stiffness(table, torque_Nm: float) -> StaticStiffness:
    """Static deflection, local-slope and average-slope mesh stiffness over the cycle at torque
    ``torque_Nm`` [N m] on gear a (means via the result's properties)."""
    return static_stiffness(table, torque_Nm / float(table.base_radius_m[0]))


def static_root_strain(table, gauge: str, force_N: float) -> np.ndarray:
    """Static root strain (Np, Nw) [-] at ``gauge`` at the static mesh force ``force_N`` [N]."""
    ta = table_arrays(table)
    xs = static_deflection(ta, force_N)
    return interpolate_table(table, _gauge(table, gauge), np.asarray(table.position, float), xs)


def strain_dynamic_factor(table, tau, x, force_N: float) -> dict:
    """Strain dynamic factor per gauge: max tensile dynamic root strain over all teeth along the
    trajectory divided by the max static root strain at ``force_N`` [N] over the cycle."""
    out = {}
    for g in sorted(getattr(table, "strain", None) or {}):
        st = static_root_strain(table, g, force_N)
        smax = float(np.max(st))
        if smax <= 0:
            continue
        dyn = interpolate_table(table, _gauge(table, g), tau, x)
        out[g] = float(np.max(dyn)) / smax
    return out
