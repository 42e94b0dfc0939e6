"""Static equilibrium of a lumped gear system at a mesh position:
``K q + sum_k [F_k(tau_k, v_k.q) v_k + Fc_k(tau_k, vc_k.q) vc_k] = f_ext`` (drive and coast flanks);
static load sharing among meshes that share the load (the planets of a planetary set) over a mesh cycle.

The mesh forces are piecewise linear in the deflection (the interpolated FDF), so Newton's method with each
mesh's local slope as tangent stiffness converges in a few steps; a step that does not reduce the residual is
halved.  A free rotation of the train (the rigid-body mode ``u``) is fixed by holding the reference gear's
rotation at 0 (the loads of the constant-speed experiment are balanced, so the equilibrium exists).  The start
is the linear estimate from each mesh's mean stiffness around its static deflection at its nominal force, on the
flanks the loads press together (the coast flanks for a negative torque).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import SolverError
from hacgear_core.tables.interp import deflection_at_force

__all__ = ["EquilibriumResult", "static_equilibrium", "static_state", "LoadSharing", "load_sharing"]


@dataclass(frozen=True)
class EquilibriumResult:
    """``q`` (n,) static deviations; ``mesh_forces_N``, ``mesh_deflections_m`` (m,) of the drive flanks,
    ``coast_forces_N``, ``coast_approach_m`` (m,) of the coast flanks; helical meshes: ``twist_rad`` and
    ``twist_moment_Nm`` (m,) (None for other systems); solver outcome."""

    q: np.ndarray
    mesh_forces_N: np.ndarray
    mesh_deflections_m: np.ndarray
    success: bool
    message: str
    iterations: int
    coast_forces_N: np.ndarray | None = None
    coast_approach_m: np.ndarray | None = None
    twist_rad: np.ndarray | None = None
    twist_moment_Nm: np.ndarray | None = None


def _positions(system: LumpedSystem, tau_ref: float, q: np.ndarray) -> np.ndarray:
    return system.unwrapped_positions(tau_ref) + system.phase + system.W @ q


def static_equilibrium(system: LumpedSystem, tau_ref: float = 0.0, fext: np.ndarray | None = None, *,
                       carrier_speed_rad_s: float = 0.0, tol: float = 1e-10, max_iter: int = 100) -> EquilibriumResult:
    """Static equilibrium at reference mesh position ``tau_ref`` [cycles] (over the system's
    ``period_cycles``: meshes at other rates are at ``rate tau_ref``) under ``fext`` (n,) (default: the
    constant-speed experiment's loads at the nominal torque).

    ``carrier_speed_rad_s``: rotating frames are in equilibrium with their centripetal stiffness
    ``K - W_c^2 K_W``.

    Raises
    ------
    SolverError
        No equilibrium (a load no mesh can carry) or no convergence.
    """
    n, m = system.n, system.m
    fe = system.fext_speed() if fext is None else np.asarray(fext, dtype=float)
    keff = system.K - carrier_speed_rad_s ** 2 * system.K_W
    free = system.rigid_mode is not None
    scale = max(float(np.max(np.abs(fe))), float(np.max(np.abs(system.nominal_forces_N(abs(system.torque_Nm))))),
                1.0)

    two = system.two_sided
    coast_loaded = two and _presses_coast(system, fe)
    vl = system.Vc if coast_loaded else system.V

    law = system.mesh_law

    def residual(q):
        tau = _positions(system, tau_ref, q)
        terms, fields = law.static_forces(system, q, tau)
        r = fe - keff @ q
        for t in terms:
            r = r - t
        return r, tau, fields

    def tangent(tau, fields, kbar_floor):
        return law.tangent(system, keff, tau, fields, kbar_floor, coast_loaded)

    def solve(a, r):
        if free:
            e = np.zeros(n)
            e[system.iref] = 1.0
            big = np.block([[a, e[:, None]], [e[None, :], np.zeros((1, 1))]])
            sol = np.linalg.solve(big, np.concatenate([r, [0.0]]))
            return sol[:n]
        return np.linalg.solve(a, r)

    kbar = system.mesh_stiffness_N_per_m
    floor = 1e-6 * kbar
    # start: the linear estimate around each mesh's static deflection at its nominal force
    if coast_loaded:
        fn = system.nominal_coast_forces_N(-abs(system.torque_Nm))
        arrays = system.coast_arrays
    else:
        fn = system.nominal_forces_N(abs(system.torque_Nm))
        arrays = system.table_arrays
    tau0 = system.unwrapped_positions(tau_ref) + system.phase
    xs = np.array([deflection_at_force(ta.ftab, ta.x0, ta.dx, float(t), float(f))
                   for ta, t, f in zip(arrays, tau0, fn)])
    xs = np.where(np.isfinite(xs), xs, 0.0)
    a_lin = keff + (vl.T * kbar) @ vl
    q = solve(a_lin, fe - vl.T @ (fn - kbar * xs))
    r, tau, fields = residual(q)
    norm = float(np.max(np.abs(r)))
    it = 0
    while norm > tol * scale and it < max_iter:
        it += 1
        dq = solve(tangent(tau, fields, floor), r)
        step = 1.0
        while True:
            qn = q + step * dq
            rn, taun, fieldsn = residual(qn)
            nn = float(np.max(np.abs(rn)))
            if nn < norm or step < 1e-6:
                break
            step *= 0.5
        q, r, tau, fields, norm = qn, rn, taun, fieldsn, nn
    ok = norm <= tol * scale
    if not ok:
        raise SolverError(f"{system.name}: no static equilibrium at mesh position {tau_ref:g} (residual "
                          f"{norm:.3g} N after {it} Newton steps); is the load beyond the tables?")
    return EquilibriumResult(q=q, mesh_forces_N=fields["mesh_force_N"], mesh_deflections_m=fields["mesh_deflection_m"],
                             success=True, message=f"converged in {it} Newton steps", iterations=it,
                             coast_forces_N=fields["coast_force_N"], coast_approach_m=fields["coast_approach_m"],
                             twist_rad=fields.get("mesh_twist_rad"), twist_moment_Nm=fields.get("twist_moment_Nm"))


def _presses_coast(system: LumpedSystem, fe: np.ndarray) -> bool:
    """Whether the loads ``fe`` press the coast flanks together: their work on a small closing of every coast gap
    (along vc, rotations only) is positive."""
    rot = np.zeros(system.n, dtype=bool)
    for g in system.gears.values():
        if g.rotation >= 0:
            rot[g.rotation] = True
    return float(np.sum((system.Vc[:, rot] @ fe[rot]))) > 0.0


def static_state(system: LumpedSystem, tau_ref: float = 0.0, fext: np.ndarray | None = None) -> np.ndarray:
    """The kernel state (2n,) of the static equilibrium at ``tau_ref`` (:func:`static_equilibrium`, zero rates)."""
    return np.concatenate([static_equilibrium(system, tau_ref, fext).q, np.zeros(system.n)])


@dataclass(frozen=True)
class LoadSharing:
    """Static load sharing over a mesh cycle.

    ``positions`` (Np,) reference mesh positions [cycles]; ``forces_N`` (Np, m) static mesh forces on the flanks
    the torque loads (the coast forces for a negative torque); ``groups``
    {group: mesh indices} (meshes of one table kind); ``factor`` (m,) cycle-mean force of each mesh over the mean
    of its group's cycle-mean forces (1 = equal sharing); ``peak_factor`` (m,) largest instantaneous factor
    ``F_k / mean_group(F)`` over the cycle."""

    positions: np.ndarray
    forces_N: np.ndarray
    groups: dict
    factor: np.ndarray
    peak_factor: np.ndarray
    mesh_names: tuple


def load_sharing(system: LumpedSystem, n_positions: int = 32, fext: np.ndarray | None = None) -> LoadSharing:
    """Static load sharing of the meshes of each group (:attr:`MeshCoupling.group`) at ``n_positions`` reference
    mesh positions over one cycle under ``fext`` (default: the constant-speed experiment's loads, pin-error
    preloads included), on the flanks the nominal torque loads (the coast flanks for a negative torque)."""
    if n_positions < 1:
        raise SolverError(f"n_positions [-] must be >= 1, got {n_positions}")
    pos = np.arange(n_positions) / n_positions
    eqs = [static_equilibrium(system, float(t), fext) for t in pos]
    f = np.array([e.coast_forces_N if system.torque_Nm < 0 else e.mesh_forces_N for e in eqs])
    groups: dict[str, list[int]] = {}
    for k, c in enumerate(system.meshes):
        groups.setdefault(c.group or c.name, []).append(k)
    mean = f.mean(axis=0)
    factor = np.ones(system.m)
    peak = np.ones(system.m)
    for idx in groups.values():
        ref = mean[idx].mean()
        inst = f[:, idx].mean(axis=1)
        for k in idx:
            factor[k] = mean[k] / ref if ref > 0 else np.nan
            peak[k] = float(np.max(f[:, k] / np.where(inst > 0, inst, np.nan)))
    return LoadSharing(pos, f, {g: tuple(i) for g, i in groups.items()}, factor, peak, system.mesh_names)
