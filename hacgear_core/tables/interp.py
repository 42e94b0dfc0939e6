"""The one interpolation of tabulated mesh quantities over (mesh position, mesh deflection), compiled.

Every lookup in hacgear — the FDF inside the integration kernels, the tables' query methods, dynamic
strain, pressure and tooth loads in post-processing, the static quantities of the force laws — goes
through the functions of this module, so one rule holds everywhere:

* **position axis** (rows): linear between rows.  For quantities of the whole mesh (force, peak
  pressure) the rows are the positions ``k/Np`` of one mesh cycle and the axis is periodic with period
  1.  For quantities of one tooth pair (tooth load, root strain) the caller passes a row index over the
  pair phase (:func:`pair_rows`); outside ``[0, N-1]`` the pair is out of mesh and the value is 0.
* **deflection axis** (columns): a regular grid ``x_j = x0 + j dx``; linear within the grid and linear
  extrapolation from the outermost two columns beyond it (the cell index is clamped to ``[0, Nd-2]``).
  Callers that must know when a state leaves the grid count it (:class:`~hacgear_core.tables.table.MeshTable`).
* NaN in a position or deflection gives NaN.

* **twist axis** (helical meshes, third axis of ``(Np, Nd, Nt, ...)`` tables): a regular grid
  ``g_k = g0 + k dg``, the same rule as the deflection axis (linear inside, linear extrapolation from the
  outermost two points beyond it): :func:`trilinear_vec` returns every trailing component of one cell at
  once (the mesh force and the twist moment of the generalized FDF from one lookup).

Force tables are non-negative on the grid and zero in their first two columns (teeth apart), so the
extrapolated force below the grid is zero and above it grows with the last cell's slope.

Functions are plain (compiled) functions over arrays, without I/O or allocation in the scalar ones.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "periodic_cell",
    "deflection_cell",
    "bilinear",
    "bilinear_many",
    "slope_many",
    "interp_rows",
    "pair_rows",
    "deflection_at_force",
    "trilinear_flat",
    "trilinear_vec",
    "trilinear_many",
]

# only floating-point contraction (fused multiply-add): NaN/inf semantics are kept
_FM = {"contract"}


@njit(cache=True, inline="always", fastmath=_FM)
def periodic_cell(npos, tau):
    """Cell of the periodic position grid ``k/npos``: ``(i, i+1 mod npos, fraction)`` for any real ``tau``."""
    p = tau * npos
    if p < 0.0 or p >= npos:  # tau outside [0, 1): wrap (the usual case skips the floor)
        p -= npos * math.floor(tau)
    i = int(p)
    if i >= npos:
        i = npos - 1
    a = p - i
    i1 = i + 1
    if i1 == npos:
        i1 = 0
    return i, i1, a


@njit(cache=True, inline="always", fastmath=_FM)
def deflection_cell(nd, x0, inv_dx, x):
    """Cell ``(j, fraction)`` of the regular deflection grid; the cell is clamped to ``[0, nd-2]`` so that
    the fraction extrapolates linearly beyond the grid."""
    r = (x - x0) * inv_dx
    j = int(r)  # truncation; r < 0 is clamped to cell 0 below (extrapolation either way)
    if j < 0:
        j = 0
    elif j > nd - 2:
        j = nd - 2
    return j, r - j


@njit(cache=True, inline="always", fastmath=_FM)
def bilinear(tab, x0, inv_dx, tau, x):
    """Value of the 2-D periodic table ``tab`` (Np, Nd) at mesh position ``tau`` [cycles] and deflection
    ``x`` [m] (module rule)."""
    i, i1, a = periodic_cell(tab.shape[0], tau)
    j, b = deflection_cell(tab.shape[1], x0, inv_dx, x)
    v0 = tab[i, j] + b * (tab[i, j + 1] - tab[i, j])
    v1 = tab[i1, j] + b * (tab[i1, j + 1] - tab[i1, j])
    return v0 + a * (v1 - v0)


@njit(cache=True, fastmath=_FM)
def bilinear_many(tab, x0, inv_dx, tau, x, out):
    """:func:`bilinear` over equal-length arrays ``tau``, ``x``; writes ``out``."""
    for k in range(tau.shape[0]):
        if math.isnan(tau[k]) or math.isnan(x[k]):
            out[k] = math.nan
        else:
            out[k] = bilinear(tab, x0, inv_dx, tau[k], x[k])


@njit(cache=True, fastmath=_FM)
def slope_many(tab, x0, inv_dx, tau, x, out):
    """Slope d(tab)/dx [per m] of the interpolant at (tau, x) (the slope of the cell that holds x);
    0 where the interpolated value is <= 0 (teeth apart in a force table)."""
    npos = tab.shape[0]
    nd = tab.shape[1]
    for k in range(tau.shape[0]):
        i, i1, a = periodic_cell(npos, tau[k])
        j, b = deflection_cell(nd, x0, inv_dx, x[k])
        s0 = tab[i, j + 1] - tab[i, j]
        s1 = tab[i1, j + 1] - tab[i1, j]
        if bilinear(tab, x0, inv_dx, tau[k], x[k]) <= 0.0:
            out[k] = 0.0
        else:
            out[k] = (s0 + a * (s1 - s0)) * inv_dx


@njit(cache=True, fastmath=_FM)
def interp_rows(values, periodic, x0, inv_dx, rows, x, out):
    """Interpolate ``values`` (N, Nd, K) at fractional row indices ``rows`` (n,) and deflections ``x`` (n,)
    into ``out`` (n, K).

    ``periodic``: the row axis wraps with period N (a mesh cycle of N positions: row = tau * N); otherwise
    a row outside ``[0, N-1]`` gives 0 (a tooth pair out of mesh; see :func:`pair_rows`).
    """
    n_rows = values.shape[0]
    nd = values.shape[1]
    kk = values.shape[2]
    for k in range(rows.shape[0]):
        r = rows[k]
        xk = x[k]
        if math.isnan(r) or math.isnan(xk):
            for c in range(kk):
                out[k, c] = math.nan
            continue
        if periodic:
            i, i1, a = periodic_cell(n_rows, r / n_rows)
        else:
            if r < 0.0 or r > n_rows - 1:
                for c in range(kk):
                    out[k, c] = 0.0
                continue
            i = int(r)
            if i > n_rows - 2:
                i = n_rows - 2
            i1 = i + 1
            a = r - i
        j, b = deflection_cell(nd, x0, inv_dx, xk)
        for c in range(kk):
            v0 = values[i, j, c] + b * (values[i, j + 1, c] - values[i, j, c])
            v1 = values[i1, j, c] + b * (values[i1, j + 1, c] - values[i1, j, c])
            out[k, c] = v0 + a * (v1 - v0)


def pair_rows(n_positions: int, tooth_offsets, phase) -> np.ndarray:
    """Fractional row index into the *unrolled* per-pair array (see
    :meth:`~hacgear_core.tables.table.MeshTable.unrolled`) of a tooth pair at pair phase ``phase``
    [mesh cycles] (0 at the pair's pitch-point contact; phase = mesh position − tooth offset).

    Pair ``k`` at mesh position ``p`` has phase ``p − k`` and its state depends on the phase only
    (``X_k(p + 1) = X_{k−1}(p)``), so the columns of all offsets, largest offset first, form one function
    of the phase over ``[−max k, 1 − min k)``.
    """
    offs = np.asarray(tooth_offsets, dtype=np.int64)
    return (np.asarray(phase, dtype=float) + float(offs.max())) * n_positions


@njit(cache=True)
def deflection_at_force(tab, x0, dx, tau, force):
    """Mesh deflection [m] at which the interpolated FDF ``tab`` (Np, Nd) reaches ``force`` [N] at mesh
    position ``tau`` [cycles] — the exact inverse of :func:`bilinear` along the deflection axis (the
    interpolant is piecewise linear and non-decreasing in x at fixed tau).  Beyond the grid the last cell
    is extrapolated.  NaN when the row never reaches ``force`` (flat or decreasing last cell) or
    ``force`` <= 0."""
    if not force > 0.0:
        return math.nan
    i, i1, a = periodic_cell(tab.shape[0], tau)
    nd = tab.shape[1]
    lo = tab[i, 0] + a * (tab[i1, 0] - tab[i, 0])
    for j in range(1, nd):
        hi = tab[i, j] + a * (tab[i1, j] - tab[i, j])
        if hi >= force:
            if hi > lo:
                return x0 + dx * ((j - 1) + (force - lo) / (hi - lo))
            return x0 + dx * (j - 1)
        if j < nd - 1:
            lo = hi
    # extrapolate the last cell
    if hi > lo:
        return x0 + dx * ((nd - 2) + (force - lo) / (hi - lo))
    return math.nan


@njit(cache=True, inline="always", fastmath=_FM)
def trilinear_flat(tab, off, nd, nt, kk, c, i, i1, a, j, b, m, t):
    """Component ``c`` of the trilinear rule on a C-ordered (Np, Nd, Nt, kk) table stored flat in ``tab`` from
    ``off``, in the cell ``(i, i1, a)`` (:func:`periodic_cell`), ``(j, b)``, ``(m, t)`` (:func:`deflection_cell`
    of the deflection and the twist axis).  The one trilinear sum: :func:`trilinear_vec` and the kernels' helical
    force law call it."""
    sj = nt * kk
    si = nd * sj
    r00 = off + i * si + j * sj + m * kk + c
    r10 = off + i1 * si + j * sj + m * kk + c
    v00 = tab[r00] + b * (tab[r00 + sj] - tab[r00])
    v01 = tab[r00 + kk] + b * (tab[r00 + sj + kk] - tab[r00 + kk])
    v10 = tab[r10] + b * (tab[r10 + sj] - tab[r10])
    v11 = tab[r10 + kk] + b * (tab[r10 + sj + kk] - tab[r10 + kk])
    v0 = v00 + t * (v01 - v00)
    v1 = v10 + t * (v11 - v10)
    return v0 + a * (v1 - v0)


@njit(cache=True, fastmath=_FM)
def trilinear_vec(tab, x0, inv_dx, g0, inv_dg, tau, x, g, out):
    """Trilinear value of ``tab`` (Np, Nd, Nt, K) (C-contiguous) at mesh position ``tau`` [cycles] (periodic),
    deflection ``x`` [m] and twist ``g`` [rad] (both regular grids, linear extrapolation beyond them) for all K
    trailing components at once → ``out`` (K,).  NaN in any argument gives NaN."""
    kk = tab.shape[3]
    if math.isnan(tau) or math.isnan(x) or math.isnan(g):
        for c in range(kk):
            out[c] = math.nan
        return
    i, i1, a = periodic_cell(tab.shape[0], tau)
    j, b = deflection_cell(tab.shape[1], x0, inv_dx, x)
    m, t = deflection_cell(tab.shape[2], g0, inv_dg, g)
    flat = tab.reshape(tab.size)
    for c in range(kk):
        out[c] = trilinear_flat(flat, 0, tab.shape[1], tab.shape[2], kk, c, i, i1, a, j, b, m, t)


@njit(cache=True, fastmath=_FM)
def trilinear_many(tab, x0, inv_dx, g0, inv_dg, tau, x, g, out):
    """:func:`trilinear_vec` over equal-length arrays ``tau``, ``x``, ``g`` → ``out`` (n, K)."""
    for k in range(tau.shape[0]):
        trilinear_vec(tab, x0, inv_dx, g0, inv_dg, tau[k], x[k], g[k], out[k])
