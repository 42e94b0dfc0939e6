"""Floquet stability of a periodic steady state: the orbit refined by shooting, its multipliers and their modes.

A periodic steady state of the constant-speed experiment (``p`` mesh cycles long, sampled at reference mesh
position 0, as :func:`~hacgear_core.dynamics.steady.steady_state` returns it) is a fixed point of the
``p``-cycle map ``P`` of the compiled RK4 loop.  Newton's method on ``P(s) - s = 0`` refines it (it converges to
unstable orbits too, which time integration cannot reach), and the eigenvalues of the monodromy matrix
``dP/ds`` (central differences over every state coordinate) are its Floquet multipliers: the orbit is stable when
every elastic multiplier lies inside the unit circle.  A multiplier leaving the circle at +1 is a fold (the end
of a branch: a jump), at -1 a period doubling, as a complex pair a secondary Hopf (torus) bifurcation.

The displacement part of each multiplier's eigenvector is split over the linearised modes of the system
(``phi^T M q``, mass-normalised shapes): that names the mode a growing perturbation is made of (for a planetary
set with identical planets, for instance, a planet mode breaking the planets' identical response).
Where the train can turn freely (``system.rigid_mode``) the two multipliers of that rotation (1, 1) are set
apart (``rigid``) and take no part in the stability verdict.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError

__all__ = ["FloquetResult", "floquet"]


@dataclass
class FloquetResult:
    """Floquet analysis of one periodic orbit.

    Attributes
    ----------
    mesh_frequency_Hz : float
    period_cycles : int
        Period of the orbit [mesh cycles].
    success : bool
        The shooting residual fell below the tolerance.
    message : str
    state : (2n,) array
        The refined orbit's state at reference mesh position 0.
    residual : float
        ``|P(s) - s|`` (infinity norm, scaled like the state: positions by the largest mean static mesh
        deflection, rates by that times ``2 pi f_m``).
    iterations : int
        Newton iterations.
    integrations : int
        ``p``-cycle integrations run (each finite difference is two).
    multipliers : (2n,) complex array
        Floquet multipliers, by descending modulus, the rigid rotation's excluded (those are in ``rigid``).
    vectors : (2n, 2n) complex array
        Their eigenvectors (columns, state coordinates).
    rigid : (r,) complex array
        Multipliers of the free rotation of the train (empty when the supports hold it).
    modal_shares : (2n, nmodes) array
        Per multiplier, the share of each linearised mode (``system.modal_omega`` order) in its eigenvector's
        displacement part (rows sum to 1).
    mode_frequencies_Hz : (nmodes,) array
        Natural frequency of each ``modal_shares`` column [Hz] (0 for a rigid-body mode).
    """

    mesh_frequency_Hz: float
    period_cycles: int
    success: bool
    message: str
    state: np.ndarray
    residual: float
    iterations: int
    integrations: int
    multipliers: np.ndarray
    vectors: np.ndarray
    rigid: np.ndarray
    modal_shares: np.ndarray
    mode_frequencies_Hz: np.ndarray

    @property
    def max_multiplier(self) -> float:
        """Largest modulus of an elastic multiplier (< 1: stable)."""
        return float(np.abs(self.multipliers[0])) if self.multipliers.size else 0.0

    @property
    def stable(self) -> bool:
        return self.max_multiplier < 1.0

    def dominant_modes(self, index: int = 0, count: int = 3) -> list[tuple[float, float]]:
        """``count`` (natural frequency [Hz], share) pairs of the modes that make up multiplier ``index``'s
        eigenvector, largest share first."""
        sh = self.modal_shares[index]
        order = np.argsort(sh)[::-1][:count]
        return [(float(self.mode_frequencies_Hz[j]), float(sh[j])) for j in order]


def _scales(system: LumpedSystem, fm: float, torque_Nm: float | None) -> np.ndarray:
    """Per state coordinate: the size of a typical elastic motion (positions [m or rad], rates [per s])."""
    xs = max(float(np.max(np.abs(system.mean_static_deflections_m(torque_Nm)))), 1e-7)
    pos = np.full(system.n, xs)
    for g in system.gears.values():
        if g.rotation >= 0:
            pos[g.rotation] = xs / g.radius_m
    return np.concatenate([pos, 2 * math.pi * fm * pos])


def floquet(system: LumpedSystem, mesh_frequency_Hz: float, state: np.ndarray, period_cycles: int = 1, *,
            torque_Nm: float | None = None, steps_per_cycle: int | None = None, refine: bool = True,
            tol: float = 1e-9, max_iterations: int = 10, step: float = 1e-6) -> FloquetResult:
    """Refine a periodic orbit of the constant-speed experiment and compute its Floquet multipliers.

    Parameters
    ----------
    system : LumpedSystem
    mesh_frequency_Hz : float
        Mesh frequency [Hz], > 0.
    state : (2n,) array
        A state on (or near) the orbit at reference mesh position 0 (``SteadyStateResult.state``).
    period_cycles : int
        Period of the orbit [mesh cycles] (``SteadyStateResult.period_cycles``), 1-16.
    torque_Nm : float, optional
        Torque on the input gear [N m] (default: the system's nominal torque).
    steps_per_cycle : int, optional
        RK4 steps per mesh cycle (default: the steady-state rule, ``system.steps_per_cycle``).
    refine : bool
        Newton-refine the orbit first (False: multipliers at ``state`` as given).
    tol : float
        Scaled residual at which the orbit counts as found.
    max_iterations : int
        Newton iterations at most.
    step : float
        Finite-difference step, relative to the coordinate scales.
    """
    fm = float(mesh_frequency_Hz)
    if not (math.isfinite(fm) and fm > 0):
        raise ModelError(f"mesh frequency [Hz] must be finite and > 0, got {mesh_frequency_Hz!r}")
    p = int(period_cycles)
    top = 16 * system.period_cycles
    if not (1 <= p <= top and p % system.period_cycles == 0):
        raise ModelError(f"period_cycles [mesh cycles] must be a multiple of the system's period "
                         f"({system.period_cycles} mesh cycles) in [1, {top}], got {period_cycles!r}")
    n2 = 2 * system.n
    s = np.array(state, dtype=float)
    if s.shape != (n2,) or not np.all(np.isfinite(s)):
        raise ModelError(f"state must be a finite array of shape ({n2},), got shape {s.shape}")
    nsp = int(steps_per_cycle) if steps_per_cycle else system.steps_per_cycle(fm)
    h = 1.0 / (fm * nsp)
    omega = system.reference_speed(fm)
    fext = system.fext_speed(torque_Nm)
    sc = _scales(system, fm, torque_Nm)
    count = [0]

    def pmap(x: np.ndarray) -> np.ndarray:
        y = x.copy()
        system.integrate(y, np.array([0.0, 0.0, omega]), p * nsp, h, fext)
        count[0] += 1
        return y

    def jacobian(x: np.ndarray) -> np.ndarray:
        jac = np.empty((n2, n2))
        for j in range(n2):
            d = step * sc[j]
            e = np.zeros(n2)
            e[j] = d
            jac[:, j] = (pmap(x + e) - pmap(x - e)) / (2 * d)
        return jac

    def residual(x: np.ndarray) -> tuple[np.ndarray, float]:
        r = pmap(x) - x
        return r, float(np.max(np.abs(r / sc)))

    r, res = residual(s)
    it = 0
    jac = None
    while refine and res > tol and it < max_iterations:
        jac = jacobian(s)
        a = (jac - np.eye(n2)) * (1.0 / sc)[:, None] * sc[None, :]  # scaled coordinates
        ds = np.linalg.lstsq(a, -r / sc, rcond=1e-12)[0] * sc
        s = s + ds
        it += 1
        if not np.all(np.isfinite(s)):
            raise ModelError(f"shooting diverged at f_m = {fm:g} Hz (state not finite)")
        r, res = residual(s)
        jac = None
    success = res <= tol or not refine
    if refine:
        message = (f"orbit found: residual {res:.2e} after {it} Newton iterations" if res <= tol
                   else f"residual {res:.2e} above {tol:g} after {it} Newton iterations")
    else:
        message = f"multipliers at the given state (residual {res:.2e})"
    if jac is None:
        jac = jacobian(s)
    mu, vec = np.linalg.eig(jac)
    rigid_idx = np.array([], dtype=int)
    if system.rigid_mode is not None:
        rigid_idx = np.argsort(np.abs(mu - 1.0))[:2]
    keep = np.setdiff1d(np.arange(n2), rigid_idx)
    order = keep[np.argsort(-np.abs(mu[keep]), kind="stable")]
    phi, mass = system.modal_shapes, system.M
    q = vec[: system.n, order]
    c = phi.T @ mass @ q
    shares = np.abs(c.T) ** 2
    tot = shares.sum(axis=1, keepdims=True)
    shares = np.divide(shares, tot, out=np.zeros_like(shares), where=tot > 0)
    return FloquetResult(fm, p, bool(success), message, s, res, it, count[0], mu[order], vec[:, order],
                         mu[rigid_idx], shares, system.modal_omega / (2 * math.pi))
