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
    "pair_interpolate",
    "tooth_loads",
    "dynamic_contact_pressure",
    "dynamic_root_strain",
    "dynamic_mesh_stiffness",
    "static_mesh_stiffness",
    "static_root_strain",
    "strain_dynamic_factor",
    "static_strain_max",
]


def _grid(table):
    """(Np, Nd, x0, 1/dx) from the table's grids without re-validating the FDF (hot path)."""
    xd = np.asarray(table.deflection_m, dtype=float)
    return len(table.position), xd.size, float(xd[0]), float((xd.size - 1) / (xd[-1] - xd[0]))


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
        Mesh deflections [m]; above the grid: linear extrapolation from the last two columns; below
        the grid start (teeth apart): the first column (no extrapolation into negative loads).

    Returns
    -------
    array (n, ...)

    Use this for quantities of the whole mesh (force, peak pressure).  Quantities of one tooth pair
    (tooth load, root strain) are not periodic in position per offset; use :func:`pair_interpolate`.
    """
    npos, nd, x0, inv_dx = _grid(table)
    vals = np.asarray(values, dtype=float)
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
    r = np.maximum((x - x0) * inv_dx, 0.0)
    j = np.clip(np.floor(r).astype(int), 0, nd - 2)
    b = r - j
    ex = (slice(None),) + (None,) * (vals.ndim - 2)
    a, b = a[ex], b[ex]
    v0 = vals[i, j] + b * (vals[i, j + 1] - vals[i, j])
    v1 = vals[i1, j] + b * (vals[i1, j + 1] - vals[i1, j])
    return v0 + a * (v1 - v0)


def pair_interpolate(table, values, phase, x) -> np.ndarray:
    """Interpolate a per-tooth-pair quantity ``values`` (Np, Nd, Nw) at pair phase ``phase`` (n,)
    [cycles] and deflection ``x`` (n,) [m].

    Pair ``k`` at mesh position ``p`` has phase ``p - k`` (0 at its pitch-point contact) and its
    state depends on the phase only (``X_k(p + 1) = X_{k-1}(p)``), so the columns of all offsets
    unroll into one function of the phase over ``[-max k, 1 - min k)``; outside that range the pair
    is out of mesh and the value is 0.  Deflection axis as in :func:`interpolate_table`.
    """
    npos, nd, x0, inv_dx = _grid(table)
    vals = np.asarray(values, dtype=float)
    offs = np.asarray(table.tooth_offsets).astype(int)
    if vals.shape != (npos, nd, offs.size):
        raise TableError(f"per-pair quantity has shape {vals.shape}, expected ({npos}, {nd}, {offs.size})")
    order = np.argsort(offs)[::-1]  # phase ascending: largest offset first
    if not np.array_equal(np.diff(offs[order]), -np.ones(offs.size - 1, dtype=int)):
        raise TableError(f"tooth_offsets must be consecutive integers, got {offs.tolist()}")
    unrolled = np.concatenate([vals[:, :, w] for w in order], axis=0)  # (Nw*Np, Nd)
    phase = np.asarray(phase, dtype=float).ravel()
    x = np.asarray(x, dtype=float).ravel()
    rows = (phase + offs.max()) * npos
    n_rows = unrolled.shape[0]
    inside = (rows >= 0) & (rows <= n_rows - 1)
    rr = np.clip(rows, 0, n_rows - 1)
    i = np.minimum(np.floor(rr).astype(int), n_rows - 2)
    a = rr - i
    r = np.maximum((x - x0) * inv_dx, 0.0)
    j = np.clip(np.floor(r).astype(int), 0, nd - 2)
    b = r - j
    v0 = unrolled[i, j] + b * (unrolled[i, j + 1] - unrolled[i, j])
    v1 = unrolled[i + 1, j] + b * (unrolled[i + 1, j + 1] - unrolled[i + 1, j])
    return np.where(inside, v0 + a * (v1 - v0), 0.0)


def _per_offset(table, values, tau, x) -> np.ndarray:
    """(n, Nw): the per-pair quantity of every offset at mesh positions ``tau`` (one vectorised call)."""
    tau = np.asarray(tau, dtype=float).ravel()
    x = np.asarray(x, dtype=float).ravel()
    frac = tau - np.floor(tau)
    offs = np.asarray(table.tooth_offsets).astype(int)
    ph = (frac[None, :] - offs[:, None]).ravel()
    v = pair_interpolate(table, values, ph, np.tile(x, offs.size))
    return v.reshape(offs.size, tau.size).T


def tooth_loads(table, tau, x) -> np.ndarray:
    """Load per tooth pair (n, Nw) [N] along the trajectory, columns = ``table.tooth_offsets``
    (offsets relative to the reference pair at each instant)."""
    return np.maximum(_per_offset(table, table.tooth_load_N, tau, x), 0.0)


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
    tau = np.asarray(tau, dtype=float).ravel()
    return pair_interpolate(table, _gauge(table, gauge), tau - tooth, x)


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
    return _per_offset(table, _gauge(table, gauge), np.asarray(table.position, float), xs)


def strain_dynamic_factor(table, tau, x, force_N: float, static_max: dict | None = None) -> dict:
    """Strain dynamic factor per gauge: max tensile dynamic root strain over all teeth along the
    trajectory divided by the max static root strain at ``force_N`` [N] over the cycle.
    ``static_max``: precomputed {gauge: max static strain} (see :func:`static_strain_max`)."""
    sm = static_strain_max(table, force_N) if static_max is None else static_max
    out = {}
    for g, smax in sm.items():
        if smax <= 0:
            continue
        dyn = _per_offset(table, _gauge(table, g), tau, x)
        out[g] = float(np.max(dyn)) / smax
    return out


def static_strain_max(table, force_N: float) -> dict:
    """{gauge: max static root strain over the cycle and all teeth} at ``force_N`` [N]."""
    return {g: float(np.max(static_root_strain(table, g, force_N)))
            for g in sorted(getattr(table, "strain", None) or {})}
