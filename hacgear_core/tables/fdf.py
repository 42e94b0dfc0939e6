"""Static quantities of a mesh from its force-deflection function (FDF): static deflection, stiffnesses, STE.

A mesh table is a :class:`hacgear_core.tables.MeshTable` (or any object with its ``position`` (Np,),
``deflection_m`` (Nd,), ``force_N`` (Np, Nd), ``no_load_deflection_m`` (Np,) and optionally ``tooth_load_N``).

Static quantities at a mesh force ``Fs`` are derived from the FDF itself (not from the separate
load-controlled ``static_deflection_m`` grid), so the conventional laws and the HAC law share one
static equilibrium: ``x_s(tau)`` solves ``F(tau, x_s) = Fs`` on each table row.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from hacgear_core.errors import TableError
from hacgear_core.tables.interp import bilinear_many, deflection_at_force

__all__ = [
    "TableArrays",
    "table_arrays",
    "row_force",
    "static_deflection",
    "local_slope",
    "StaticStiffness",
    "static_stiffness",
    "contact_count",
    "GeneralizedStiffness",
    "generalized_slopes",
    "generalized_stiffness",
]


@dataclass(frozen=True)
class TableArrays:
    """Plain arrays of the FDF for the kernels: ``ftab`` (Np, Nd) C-contiguous float64 [N],
    ``x0`` first deflection [m], ``dx`` deflection step [m], ``inv_dx`` [1/m]."""

    ftab: np.ndarray
    x0: float
    dx: float
    inv_dx: float

    @property
    def n_positions(self) -> int:
        return self.ftab.shape[0]

    @property
    def deflection_m(self) -> np.ndarray:
        return self.x0 + self.dx * np.arange(self.ftab.shape[1])


def table_arrays(table) -> TableArrays:
    """Validate a mesh table's FDF and return the arrays the kernels take.

    Raises
    ------
    TableError
        Missing attributes, wrong shapes, non-uniform grids, NaN or negative forces.
    """
    name = getattr(table, "name", "?")
    for attr in ("position", "deflection_m", "force_N", "no_load_deflection_m"):
        if not hasattr(table, attr):
            raise TableError(f"mesh table '{name}': attribute '{attr}' missing (tables contract)")
    pos = np.asarray(table.position, dtype=float)
    xd = np.asarray(table.deflection_m, dtype=float)
    f = np.ascontiguousarray(np.asarray(table.force_N, dtype=np.float64))
    npos, nd = pos.size, xd.size
    if npos < 2 or nd < 2:
        raise TableError(f"mesh table '{name}': need >= 2 positions and >= 2 deflections, got {npos}, {nd}")
    if f.shape != (npos, nd):
        raise TableError(f"mesh table '{name}': force_N [N] has shape {f.shape}, expected ({npos}, {nd})")
    if not np.allclose(pos, np.arange(npos) / npos, atol=1e-9):
        raise TableError(f"mesh table '{name}': position [-] must be uniform k/Np in [0, 1) (periodic)")
    dx = (xd[-1] - xd[0]) / (nd - 1)
    if not dx > 0 or not np.allclose(np.diff(xd), dx, rtol=1e-6, atol=1e-15):
        raise TableError(f"mesh table '{name}': deflection_m [m] must be a uniform increasing grid")
    if not np.all(np.isfinite(f)):
        raise TableError(f"mesh table '{name}': force_N [N] contains NaN/inf")
    if np.any(f < 0):
        raise TableError(f"mesh table '{name}': force_N [N] must be >= 0, min {f.min():g}")
    return TableArrays(ftab=f, x0=float(xd[0]), dx=float(dx), inv_dx=float(1.0 / dx))


def row_force(ta: TableArrays, x: np.ndarray) -> np.ndarray:
    """Force on every table row at deflections ``x`` (Np,) or scalar [m] -> (Np,) [N] (the one interpolation,
    clipped at 0)."""
    npos = ta.ftab.shape[0]
    x = np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (npos,)))
    out = np.empty(npos)
    bilinear_many(ta.ftab, ta.x0, ta.inv_dx, np.arange(npos) / npos, x, out)
    return np.maximum(out, 0.0)


def static_deflection(ta: TableArrays, force_N: float) -> np.ndarray:
    """Static mesh deflection x_s (Np,) [m] solving F(tau_k, x_s) = force_N on each table row
    (:func:`~hacgear_core.tables.interp.deflection_at_force`, the one FDF inversion).

    Raises
    ------
    TableError
        If ``force_N`` <= 0 or a row never reaches the force (flat row).
    """
    if not force_N > 0:
        raise TableError(f"static mesh force [N] must be > 0, got {force_N!r}")
    npos = ta.ftab.shape[0]
    out = np.array([deflection_at_force(ta.ftab, ta.x0, ta.dx, k / npos, float(force_N)) for k in range(npos)])
    bad = np.flatnonzero(~np.isfinite(out))
    if bad.size:
        k = int(bad[0])
        raise TableError(
            f"mesh table: force_N row {k} (position {k / npos:.4f}) is flat at the static force "
            f"{force_N:g} N; cannot invert the FDF"
        )
    return out


def local_slope(ta: TableArrays, x: np.ndarray) -> np.ndarray:
    """Local slope dF/dx (Np,) [N/m] of each table row at deflections ``x`` (central difference
    over one grid step each side)."""
    return (row_force(ta, x + ta.dx) - row_force(ta, x - ta.dx)) / (2.0 * ta.dx)


@dataclass(frozen=True)
class StaticStiffness:
    """Static mesh quantities at one mesh force, on the table's position grid (all SI).

    ``deflection_m`` x_s(tau); ``no_load_deflection_m`` eps(tau); ``local_slope_N_per_m`` k_l(tau)
    = dF/dx at x_s; ``average_slope_N_per_m`` k_a(tau) = Fs / (x_s - eps); means over the cycle;
    ``ste_peak_to_peak_m`` peak-to-peak static transmission error."""

    force_N: float
    position: np.ndarray
    deflection_m: np.ndarray
    no_load_deflection_m: np.ndarray
    local_slope_N_per_m: np.ndarray
    average_slope_N_per_m: np.ndarray

    @property
    def mean_local_slope_N_per_m(self) -> float:
        return float(np.mean(self.local_slope_N_per_m))

    @property
    def mean_average_slope_N_per_m(self) -> float:
        return float(np.mean(self.average_slope_N_per_m))

    @property
    def mean_deflection_m(self) -> float:
        return float(np.mean(self.deflection_m))

    @property
    def ste_peak_to_peak_m(self) -> float:
        return float(np.ptp(self.deflection_m))


def static_stiffness(table, force_N: float) -> StaticStiffness:
    """Static deflection and stiffnesses of a mesh table at mesh force ``force_N`` [N]."""
    ta = table_arrays(table)
    xs = static_deflection(ta, force_N)
    eps = np.asarray(table.no_load_deflection_m, dtype=float)
    kl = local_slope(ta, xs)
    gap = xs - eps
    if np.any(gap <= 0):
        raise TableError("static deflection below the no-load deflection: inconsistent table")
    ka = force_N / gap
    return StaticStiffness(
        force_N=float(force_N), position=np.asarray(table.position, dtype=float), deflection_m=xs,
        no_load_deflection_m=eps, local_slope_N_per_m=kl, average_slope_N_per_m=ka,
    )


def contact_count(table, force_N: float, rel_threshold: float = 1e-3) -> np.ndarray | None:
    """Number of loaded tooth pairs (Np,) at the static force, from ``tooth_load_N`` when the table
    has it (a pair counts when it carries > ``rel_threshold`` x ``force_N``); None otherwise."""
    tl = getattr(table, "tooth_load_N", None)
    if tl is None:
        return None
    tl = np.asarray(tl, dtype=float)
    if tl.ndim != 3 or tl.size == 0:
        return None
    xs = static_deflection(table_arrays(table), force_N)
    loads = table.interpolate(tl, table.position, xs, count=False)
    return np.sum(loads > rel_threshold * force_N, axis=1)


@dataclass(frozen=True)
class GeneralizedStiffness:
    """The generalized FDF of a helical mesh linearised about its static state at zero twist, per position (Np,):
    ``k_xx_N_per_m`` = dW/dx, ``k_xg_N_per_rad`` = dW/dgamma, ``k_gx_Nm_per_m`` = dM/dx, ``k_gg_Nm_per_rad`` =
    dM/dgamma (W mesh force, M twist moment, x mesh deflection, gamma mesh twist), at ``deflection_m`` (Np,)."""

    force_N: float
    position: np.ndarray
    deflection_m: np.ndarray
    k_xx_N_per_m: np.ndarray
    k_xg_N_per_rad: np.ndarray
    k_gx_Nm_per_m: np.ndarray
    k_gg_Nm_per_rad: np.ndarray

    def means(self) -> dict[str, float]:
        """Mesh-cycle means of the four stiffnesses, keyed by name."""
        return {k: float(np.mean(getattr(self, k))) for k in
                ("k_xx_N_per_m", "k_xg_N_per_rad", "k_gx_Nm_per_m", "k_gg_Nm_per_rad")}


def generalized_slopes(table, position: Any, deflection: Any, twist: Any) -> np.ndarray:
    """Derivatives of the trilinear generalized FDF of a helical mesh ``table`` (twist axis) at (position
    [cycles], deflection [m], twist [rad]) (n,) each → (n, 2, 2): ``[[dW/dx, dW/dgamma], [dM/dx, dM/dgamma]]``
    [N/m, N/rad; N m/m, N m/rad].  Central differences of 1e-3 of a grid step: inside a cell the cell's slope,
    on a grid line the mean of the two neighbouring cells' slopes."""
    if getattr(table, "twist", None) is None:
        raise TableError("generalized_slopes needs a table with a twist axis (helical mesh, format 2+)")
    p, x, g = np.broadcast_arrays(*(np.asarray(v, dtype=float).ravel() for v in (position, deflection, twist)))
    hx, hg = 1e-3 / table.inv_dx, 1e-3 * float(np.min(np.diff(table.twist.twist_rad)))
    gfdf = table.twist.generalized_fdf

    def wm(dx, dg):
        return table.twist_quantity(gfdf, p, x + dx, g + dg)

    dx_ = (wm(hx, 0.0) - wm(-hx, 0.0)) / (2 * hx)                         # (n, 2): dW/dx, dM/dx
    dg_ = (wm(0.0, hg) - wm(0.0, -hg)) / (2 * hg)                         # (n, 2): dW/dgamma, dM/dgamma
    return np.stack([dx_, dg_], axis=2)


def generalized_stiffness(table, force_N: float) -> GeneralizedStiffness:
    """Linearised generalized force law of a helical mesh ``table`` (with a twist axis) at mesh force ``force_N``
    [N] and zero twist: the derivatives of the table's trilinear rule (:func:`generalized_slopes`) at the static
    deflection of each position row (across gamma = 0, a grid point, the twist slopes are the mean of the two
    neighbouring cells' slopes, the twist-grid resolution of the law)."""
    if getattr(table, "twist", None) is None:
        raise TableError("generalized_stiffness needs a table with a twist axis (helical mesh, format 2+)")
    xs = static_deflection(table_arrays(table), force_N)
    pos = np.asarray(table.position, dtype=float)
    k = generalized_slopes(table, pos, xs, np.zeros(pos.size))
    return GeneralizedStiffness(
        force_N=float(force_N), position=pos, deflection_m=xs, k_xx_N_per_m=k[:, 0, 0], k_xg_N_per_rad=k[:, 0, 1],
        k_gx_Nm_per_m=k[:, 1, 0], k_gg_Nm_per_rad=k[:, 1, 1])
