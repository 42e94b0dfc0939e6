"""The contact complementarity problem (a strictly convex QP) and its Hertz check on discretised cylinders.

    g_i = g0_i - lambda_i x + sum_j C_ij F_j  >= 0,   F_i >= 0,   F_i g_i = 0

solved exactly by a primal active-set method (finite termination, warm starts) under deflection control
(given ``x``) or load control (given ``W = sum lambda_i F_i``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hacgear_core.errors import ModelError, SolverError
from hacgear_core.statics.nearfield import halfspace_strip_kernel, hertz_line_contact

__all__ = ["LCPResult", "solve_contact_lcp", "StripContact", "solve_strip_contact"]

@dataclass(frozen=True)
class LCPResult:
    """Solution of one contact complementarity problem.

    Attributes
    ----------
    success : bool
    message : str
    iterations : int
        Active-set changes.
    force_N : ndarray (n,)
        Candidate loads ``F >= 0`` [N].
    gap_m : ndarray (n,)
        Loaded separations ``g = g0 - lambda x + C F >= 0`` [m] (0 where loaded).
    mesh_deflection_m : float
        ``x`` [m] (given under deflection control).
    mesh_force_N : float
        ``W = lambda . F`` [N] (given under load control).
    active : ndarray (n,) bool
        Loaded candidates.
    """

    success: bool
    message: str
    iterations: int
    force_N: np.ndarray
    gap_m: np.ndarray
    mesh_deflection_m: float
    mesh_force_N: float
    active: np.ndarray


def solve_contact_lcp(C: np.ndarray, g0: np.ndarray, lam: np.ndarray, *, mesh_deflection_m: float | None = None,
                      mesh_force_N: float | None = None, warm_start: np.ndarray | None = None,
                      tol_m: float = 1e-13, max_iter: int | None = None) -> LCPResult:
    """Solve the contact complementarity problem by a primal active-set method.

    Find ``F >= 0`` with ``g = g0 - lam x + C F >= 0`` and ``F . g = 0`` — the KKT conditions of
    ``min ½ FᵀCF + (g0 - lam x)ᵀF`` over ``F >= 0`` (deflection control, ``x`` given) or of
    ``min ½ FᵀCF + g0ᵀF`` over ``F >= 0, lamᵀF = W`` (load control; ``x`` is the multiplier).

    Parameters
    ----------
    C : ndarray (n, n)
        Symmetric positive definite compliance [m/N].
    g0 : ndarray (n,)
        Initial separations [m] (``inf``: never in contact).
    lam : ndarray (n,)
        Rigid approach per unit mesh deflection [-] (> 0).
    mesh_deflection_m, mesh_force_N : float
        Exactly one: deflection control (``x`` [m]) or load control (``W`` [N] >= 0).
    warm_start : ndarray (n,), optional
        Previous loads [N]; their support seeds the active set (scaled to ``W`` under load control).
    tol_m : float
        Gap tolerance [m] of the optimality test.
    max_iter : int, optional
        Default ``20 n + 50``.

    Returns
    -------
    LCPResult
    """
    C = np.asarray(C, dtype=float)
    g0 = np.asarray(g0, dtype=float)
    lam = np.asarray(lam, dtype=float)
    n = g0.size
    if C.shape != (n, n) or lam.shape != (n,):
        raise SolverError(f"solve_contact_lcp: shapes C {C.shape}, g0 {g0.shape}, lam {lam.shape} do not match")
    if (mesh_deflection_m is None) == (mesh_force_N is None):
        raise SolverError("solve_contact_lcp: give exactly one of mesh_deflection_m [m] or mesh_force_N [N]")
    load_control = mesh_force_N is not None
    finite = np.isfinite(g0)
    if max_iter is None:
        max_iter = 20 * n + 50
    if np.any(lam[finite] <= 0):
        raise SolverError("solve_contact_lcp: lam must be > 0 for every finite-gap candidate")
    F = np.zeros(n)
    if load_control:
        W = float(mesh_force_N)
        if not (math.isfinite(W) and W >= 0):
            raise SolverError(f"mesh_force_N must be finite and >= 0 N, got {mesh_force_N!r}")
        if not np.any(finite):
            return LCPResult(False, "no candidate contact can close", 0, F, g0.copy(), math.nan, W,
                             np.zeros(n, bool))
        ratio = np.where(finite, g0 / np.where(finite, lam, 1.0), np.inf)
        if W == 0.0:
            x0 = float(ratio.min())
            return LCPResult(True, "zero load: no-load mesh deflection", 0, F, g0 - lam * x0, x0, 0.0,
                             np.zeros(n, bool))
        if warm_start is not None and np.sum(lam * np.clip(warm_start, 0, None)) > 0:
            Fw = np.where(finite, np.clip(np.asarray(warm_start, float), 0, None), 0.0)
            F = Fw * (W / float(lam @ Fw))
        else:
            j = int(np.argmin(ratio))
            F[j] = W / lam[j]
        P = F > 0
        x = float(ratio.min())
    else:
        x = float(mesh_deflection_m)
        if not math.isfinite(x):
            raise SolverError(f"mesh_deflection_m must be finite, got {mesh_deflection_m!r}")
        q = np.where(finite, g0 - lam * x, np.inf)
        P = np.zeros(n, bool)
        if warm_start is not None:
            P = (np.asarray(warm_start) > 0) & finite
        W = 0.0
    g0f = np.where(finite, g0, 0.0)
    it = 0
    while it < max_iter:
        it += 1
        idx = np.flatnonzero(P)
        # --- equality-constrained subproblem on the free set
        if load_control:
            m = idx.size
            K = np.zeros((m + 1, m + 1))
            K[:m, :m] = C[np.ix_(idx, idx)]
            K[:m, m] = -lam[idx]
            K[m, :m] = lam[idx]
            rhs = np.concatenate([-g0f[idx], [W]])
            try:
                sol = np.linalg.solve(K, rhs)
            except np.linalg.LinAlgError:
                return LCPResult(False, "singular active-set system", it, F, g0.copy(), math.nan, W, P)
            Fp, x_new = sol[:m], float(sol[m])
        else:
            if idx.size:
                try:
                    Fp = np.linalg.solve(C[np.ix_(idx, idx)], -q[idx])
                except np.linalg.LinAlgError:
                    return LCPResult(False, "singular active-set system", it, F, g0.copy(), x, math.nan, P)
            else:
                Fp = np.zeros(0)
            x_new = x
        neg = Fp < 0
        if np.any(neg):
            # step towards the subproblem solution until the first load reaches zero
            Fi = F[idx]
            d = Fp - Fi
            with np.errstate(divide="ignore", invalid="ignore"):
                steps = np.where(neg, Fi / (Fi - Fp), np.inf)
            a = float(np.clip(steps.min(), 0.0, 1.0))
            F[idx] = Fi + a * d
            block = idx[neg & (steps <= a * (1 + 1e-12) + 1e-300)]
            F[block] = 0.0
            P[block] = False
            F[F < 0] = 0.0
            continue
        F[idx] = Fp
        x = x_new
        gap = np.where(finite, g0f - lam * x + C @ F, np.inf)
        gap_free = np.where(P, np.inf, gap)
        j = int(np.argmin(gap_free))
        if gap_free[j] >= -tol_m:
            gap[P] = 0.0
            W_out = float(lam @ F) if not load_control else W
            return LCPResult(True, "converged", it, F.copy(), gap, float(x), W_out, P.copy())
        P[j] = True
    return LCPResult(False, f"active-set iteration limit ({max_iter}) reached", it, F, g0.copy(), float(x),
                     float(lam @ F), P)


# =============================================================================================
# Discretized Hertz check: two elastic cylinders pressed together (strip pressure elements)
# =============================================================================================
@dataclass(frozen=True)
class StripContact:
    """Discrete line contact of two cylinders (validation of the contact solve against Hertz).

    Attributes: ``x_m`` (n,) strip centres, ``pressure_Pa`` (n,), ``peak_pressure_Pa``,
    ``half_width_m`` (edge of the loaded zone, interpolated), ``approach_m``, ``lcp`` (LCPResult).
    """

    x_m: np.ndarray
    pressure_Pa: np.ndarray
    peak_pressure_Pa: float
    half_width_m: float
    approach_m: float
    lcp: LCPResult


def solve_strip_contact(load_per_width_N_m: float, R1_m: float, R2_m: float, youngs_modulus_Pa: float,
                        poisson_ratio: float, *, n_strips: int = 201, span_m: float | None = None,
                        plane: str = "stress") -> StripContact:
    """Contact of two cylinders by the same complementarity solver, with the elastic half-space
    discretized into uniform pressure strips (:func:`hacgear_core.statics.nearfield.halfspace_strip_kernel`).

    The load per width ``w`` [N/m] is prescribed (load control: ``lambda = strip width``), the
    separation is ``x²/(2R)``; the result converges to the Hertz closed form as strips shrink.
    ``span_m`` defaults to 3 Hertz half-widths.
    """
    if not (load_per_width_N_m > 0 and math.isfinite(load_per_width_N_m)):
        raise ModelError(f"load_per_width_N_m must be finite and > 0 N/m, got {load_per_width_N_m!r}")
    if n_strips < 5:
        raise ModelError(f"n_strips must be >= 5, got {n_strips!r}")
    h = hertz_line_contact(load_per_width_N_m, R1_m, R2_m, youngs_modulus_Pa, poisson_ratio, plane=plane)
    span = 3.0 * h.half_width_m if span_m is None else float(span_m)
    x = np.linspace(-span / 2, span / 2, n_strips)
    dx = x[1] - x[0]
    # both bodies: same kernel (same material) → compliance doubles; unknowns are strip forces dx*p
    K = 2.0 * halfspace_strip_kernel(x, x, 0.5 * dx, youngs_modulus_Pa, poisson_ratio, plane) / dx
    # the 2D half-space kernel is defined up to a constant: shift it so C is positive definite
    # (a constant adds the same rigid offset to every gap, absorbed by the approach x)
    K = K - K.min() + 1e-3 * abs(K.max() - K.min())
    g0 = x * x / (2.0 * h.effective_radius_m)
    lam = np.ones(n_strips)
    res = solve_contact_lcp(K, g0, lam, mesh_force_N=load_per_width_N_m)
    p = res.force_N / dx
    loaded = np.flatnonzero(p > 0)
    # edge of the loaded zone: fit of the Hertz ellipse p² = p0²(1 - x²/a²) to the loaded strips
    A = np.stack([np.ones(loaded.size), -x[loaded] ** 2], axis=1)
    coef, *_ = np.linalg.lstsq(A, p[loaded] ** 2, rcond=None)
    p0 = math.sqrt(max(coef[0], 0.0))
    a = math.sqrt(coef[0] / coef[1]) if coef[1] > 0 else math.nan
    return StripContact(x, p, p0, a, res.mesh_deflection_m, res)
