"""Direct dynamic contact model, level 1: the lumped equations with every mesh force solved at every RK4 stage.

The HAC model looks the mesh force up in tables of static contact solutions (:mod:`hacgear_core.tables`).  The
direct model integrates *the same* constant-speed equations of a :class:`~hacgear_core.dynamics.system.LumpedSystem`
(:mod:`hacgear_core.dynamics.kernels` module docstring)::

    M q'' + (C + W_c G) q' + (K - W_c^2 K_W) q + g(tau_ref, q) = f_ext,   tau_ref(t) = tau_ref(0) + f_m t

with plain fixed-step RK4 in Python, the generalized mesh load ``g`` evaluated at each of the four stages by a
*callable*.  Level 1 (:func:`contact_load`) forms ``g = sum_k F_k v_k + Fc_k vc_k`` with ``F_k`` the static contact
solver's force at the stage's mesh position ``tau_k = tau_ref + phase_k + w_k . q`` and deflection
``x_k = v_k . q`` (and the coast flanks' at the coast approach ``xc_k = vc_k . q``): it differs from HAC only by
the tables' interpolation and grid.  The solver must be built with the settings the tables were built with
(:func:`level1_mesh_forces` uses :func:`hacgear_core.statics.helical.make_solver` and
:func:`hacgear_core.statics.coast.make_coast_solver` with the model's defaults, as ``statics/grid.py`` does).

Interfaces (for other direct models, e.g. elastic bodies in motion)
-------------------------------------------------------------------
``MeshForceFn``: ``mesh_force(position, deflection) -> (force_N, extra)`` — one side of one mesh: force [N]
    (>= 0) at mesh position [cycles] and deflection (or coast approach) [m]; ``extra`` is anything the caller
    wants back (level 1: the solver's :class:`~hacgear_core.statics.contact.ContactState`, None where the flanks
    are apart).  :class:`SolverMeshForce` and :class:`CoastSolverMeshForce` wrap the static solver with a warm
    start from the previous stage.
``GeneralizedLoad``: ``load(tau_ref, q, qd) -> StageLoad`` — the generalized mesh load (n,) at one stage and the
    per-mesh forces; :func:`contact_load` builds it from ``MeshForceFn`` per mesh and side.  A model with more
    DOFs than the lumped system (e.g. body modes) builds a :class:`DirectEquations` of its own size and passes its
    own ``load``; :func:`integrate_direct` does not care where the load comes from.
:func:`integrate_direct` runs the RK4 loop and records at the start of every ``rec_every``-th step (stage 1 of
    that step: the state and the load it was evaluated with, so nothing is solved twice).
:func:`run_level1` starts from a state (e.g. the HAC steady-state orbit, :func:`hacgear_core.dynamics.steady.steady_state`),
    integrates whole mesh cycles (each next start improved by a defect correction with the HAC map) until the
    measured level-1 Poincaré change per cycle is below a tolerance (or a cycle cap), then records one cycle with
    its metrics and root strains.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from hacgear_core.dynamics.steady import trace_metrics
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError, SolverError
from hacgear_core.statics.coast import make_coast_solver
from hacgear_core.statics.helical import make_solver

__all__ = [
    "MeshForceFn",
    "GeneralizedLoad",
    "StageLoad",
    "DirectEquations",
    "DirectTrace",
    "SolverMeshForce",
    "CoastSolverMeshForce",
    "contact_load",
    "integrate_direct",
    "level1_mesh_forces",
    "Level1Options",
    "Level1Result",
    "run_level1",
    "solver_root_strain",
]

#: one side of one mesh: (position [cycles], deflection [m]) -> (force [N] >= 0, extra)
MeshForceFn = Callable[[float, float], tuple[float, Any]]


@dataclass
class StageLoad:
    """The mesh load at one RK4 stage: ``generalized_N`` (n,) the generalized force the meshes put on the DOFs
    (``sum F_k v_k + Fc_k vc_k`` for level 1; enters the equations with a minus sign), ``drive_force_N`` and
    ``coast_force_N`` (m,) [N], ``position`` (m,) [cycles], ``deflection_m`` and ``coast_approach_m`` (m,) [m],
    ``extra`` (per mesh: (drive extra, coast extra))."""

    generalized_N: np.ndarray
    drive_force_N: np.ndarray
    coast_force_N: np.ndarray
    position: np.ndarray
    deflection_m: np.ndarray
    coast_approach_m: np.ndarray
    extra: tuple = ()


#: (tau_ref [cycles], q (n,), qd (n,)) -> StageLoad
GeneralizedLoad = Callable[[float, np.ndarray, np.ndarray], StageLoad]


@dataclass(frozen=True, eq=False)
class DirectEquations:
    """Constant-speed equations of motion of a lumped system with the mesh load left open (SI).

    Attributes
    ----------
    M, C, K : (n, n) arrays
        Mass, damping and stiffness matrices [kg, kg m^2; N s/m; N/m] (supports; the meshes are in the load).
    G, K_W : (n, n) arrays
        Gyroscopic and centripetal matrices per unit carrier speed (zero for fixed-axis trains).
    carrier_ratio : float
        Carrier speed over the reference speed.
    fext : (n,) array
        External generalized forces of the constant-speed experiment.
    V, Vc, W, V_rot : (m, n) arrays
        Mesh deflection, coast approach, mesh position [cycles per unit q] and dynamic-transmission-error vectors.
    phase : (m,) array
        Mesh phases [cycles].
    zref_2pi : float
        Mesh cycles per radian of the reference gear.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    G: np.ndarray
    K_W: np.ndarray
    carrier_ratio: float
    fext: np.ndarray
    V: np.ndarray
    Vc: np.ndarray
    W: np.ndarray
    V_rot: np.ndarray
    phase: np.ndarray
    zref_2pi: float

    def __post_init__(self) -> None:
        n = np.shape(self.M)[0]
        for name in ("M", "C", "K", "G", "K_W"):
            if np.shape(getattr(self, name)) != (n, n):
                raise ModelError(f"DirectEquations.{name} must be ({n}, {n}), got {np.shape(getattr(self, name))}")
        m = np.shape(self.V)[0]
        for name in ("Vc", "W", "V_rot"):
            if np.shape(getattr(self, name)) != (m, n):
                raise ModelError(f"DirectEquations.{name} must be ({m}, {n}), got {np.shape(getattr(self, name))}")
        if np.shape(self.fext) != (n,) or np.shape(self.phase) != (m,):
            raise ModelError(f"DirectEquations.fext must be ({n},) [N, N m] and phase ({m},) [cycles]")
        if not (math.isfinite(self.zref_2pi) and self.zref_2pi > 0):
            raise ModelError(f"DirectEquations.zref_2pi [cycles/rad] must be > 0, got {self.zref_2pi!r}")

    @property
    def n(self) -> int:
        return int(np.shape(self.M)[0])

    @property
    def m(self) -> int:
        return int(np.shape(self.V)[0])

    @classmethod
    def from_system(cls, system: LumpedSystem, torque_Nm: float | None = None) -> "DirectEquations":
        """The equations the HAC kernel integrates for ``system`` at ``torque_Nm`` (default nominal): its M, C, K,
        G, K_W, mesh vectors, phases and the loads of :meth:`LumpedSystem.fext_speed`."""
        sy = system
        return cls(M=sy.M, C=sy.C, K=sy.K, G=sy.G, K_W=sy.K_W, carrier_ratio=sy.carrier_ratio,
                   fext=sy.fext_speed(torque_Nm), V=sy.V, Vc=sy.Vc, W=sy.W, V_rot=sy.V_rot, phase=sy.phase,
                   zref_2pi=sy.zref_2pi)


@dataclass
class DirectTrace:
    """Records of :func:`integrate_direct` (taken at the start of a step, stage 1): ``time_s`` (nr,), per mesh
    (nr, m) ``mesh_position`` (unwrapped) [cycles], ``mesh_deflection_m``, ``mesh_force_N``,
    ``dynamic_transmission_error_m``, ``coast_approach_m``, ``coast_force_N``; ``state`` (nr, 2n); ``extra``
    (stage-1 ``StageLoad.extra`` per record when kept); ``steps`` and ``load_calls`` (stage evaluations) run;
    ``wall_s`` the wall time of the loop."""

    time_s: np.ndarray
    mesh_position: np.ndarray
    mesh_deflection_m: np.ndarray
    mesh_force_N: np.ndarray
    dynamic_transmission_error_m: np.ndarray
    coast_approach_m: np.ndarray
    coast_force_N: np.ndarray
    state: np.ndarray
    extra: list = field(default_factory=list)
    steps: int = 0
    load_calls: int = 0
    wall_s: float = 0.0


def integrate_direct(eqs: DirectEquations, load: GeneralizedLoad, state: np.ndarray, *, mesh_frequency_Hz: float,
                     n_steps: int, h: float, tau_ref0: float = 0.0, cycles0: int = 0, rec_every: int = 1,
                     keep_extra: bool = False) -> tuple[np.ndarray, float, DirectTrace]:
    """Fixed-step RK4 of the constant-speed equations with the mesh load from ``load`` at every stage.

    Parameters
    ----------
    eqs : DirectEquations
    load : GeneralizedLoad
        ``load(tau_ref, q, qd) -> StageLoad`` (see the module docstring).
    state : (2n,) array
        ``[q, q']`` at the start (not modified).
    mesh_frequency_Hz : float
        Reference mesh frequency [Hz] (> 0): ``tau_ref`` grows by ``f_m h`` per step.
    n_steps : int
        Steps to take (>= 1).
    h : float
        Step [s] (> 0).
    tau_ref0 : float
        Reference mesh position at the start [cycles], in [0, 1).
    cycles0 : int
        Completed reference cycles at the start (only shifts the recorded unwrapped positions).
    rec_every : int
        Record every ``rec_every``-th step (its start), from the first.
    keep_extra : bool
        Keep the stage-1 ``extra`` of every record.

    Returns
    -------
    (state (2n,), tau_ref [cycles], DirectTrace)
        The state and reference mesh position (as ``cycles0 + tau_ref``, unwrapped) after the last step, and the
        records.
    """
    fm = float(mesh_frequency_Hz)
    if not (math.isfinite(fm) and fm > 0):
        raise ModelError(f"mesh_frequency_Hz [Hz] must be finite and > 0, got {mesh_frequency_Hz!r}")
    if not (isinstance(n_steps, (int, np.integer)) and n_steps >= 1):
        raise ModelError(f"n_steps [-] must be an integer >= 1, got {n_steps!r}")
    if not (math.isfinite(h) and h > 0):
        raise ModelError(f"h [s] must be finite and > 0, got {h!r}")
    if not (isinstance(rec_every, (int, np.integer)) and rec_every >= 1):
        raise ModelError(f"rec_every [steps] must be an integer >= 1, got {rec_every!r}")
    n, m = eqs.n, eqs.m
    s = np.array(state, dtype=float)
    if s.shape != (2 * n,):
        raise ModelError(f"state must have shape ({2 * n},), got {s.shape}")
    omega = fm / eqs.zref_2pi
    wc = eqs.carrier_ratio * omega
    minv = np.linalg.inv(eqs.M)
    a_k = minv @ (eqs.K - wc * wc * eqs.K_W)
    a_c = minv @ (eqs.C + wc * eqs.G)
    a_f = minv @ eqs.fext
    nr = (int(n_steps) + rec_every - 1) // rec_every
    rec = {k: np.zeros((nr, m)) for k in ("mesh_position", "mesh_deflection_m", "mesh_force_N",
                                           "dynamic_transmission_error_m", "coast_approach_m", "coast_force_N")}
    rstate = np.zeros((nr, 2 * n))
    rtime = np.zeros(nr)
    extras: list = []
    calls = 0

    def accel(tau: float, q: np.ndarray, qd: np.ndarray):
        nonlocal calls
        sl = load(tau, q, qd)
        calls += 1
        return a_f - a_k @ q - a_c @ qd - minv @ sl.generalized_N, sl

    tau = float(tau_ref0)
    dtau = fm * h
    hh = 0.5 * h
    ir = 0
    t0 = time.perf_counter()
    for step in range(int(n_steps)):
        q, qd = s[:n], s[n:]
        a1, sl1 = accel(tau, q, qd)
        if step % rec_every == 0:
            rec["mesh_position"][ir] = cycles0 + tau + eqs.phase + eqs.W @ q
            rec["mesh_deflection_m"][ir] = sl1.deflection_m
            rec["mesh_force_N"][ir] = sl1.drive_force_N
            rec["dynamic_transmission_error_m"][ir] = eqs.V_rot @ q
            rec["coast_approach_m"][ir] = sl1.coast_approach_m
            rec["coast_force_N"][ir] = sl1.coast_force_N
            rstate[ir] = s
            rtime[ir] = step * h
            if keep_extra:
                extras.append(sl1.extra)
            ir += 1
        q2, qd2 = q + hh * qd, qd + hh * a1
        a2, _ = accel(tau + 0.5 * dtau, q2, qd2)
        q3, qd3 = q + hh * qd2, qd + hh * a2
        a3, _ = accel(tau + 0.5 * dtau, q3, qd3)
        q4, qd4 = q + h * qd3, qd + h * a3
        a4, _ = accel(tau + dtau, q4, qd4)
        s = np.concatenate([q + (h / 6.0) * (qd + 2 * qd2 + 2 * qd3 + qd4),
                            qd + (h / 6.0) * (a1 + 2 * a2 + 2 * a3 + a4)])
        if not np.all(np.isfinite(s)):
            raise SolverError(f"direct integration diverged at step {step} (state not finite)")
        tau += dtau
    wall = time.perf_counter() - t0
    tr = DirectTrace(time_s=rtime, state=rstate, extra=extras, steps=int(n_steps), load_calls=calls, wall_s=wall,
                     **rec)
    return s, tau, tr


# =============================================================================================
# Level 1: the static contact solver as the force law
# =============================================================================================
class SolverMeshForce:
    """``MeshForceFn`` of the drive flanks of one mesh from a static contact solver
    (:class:`~hacgear_core.statics.contact.MeshContactSolver`): ``state_deflection(position, deflection)`` warm
    started from the previous call's contact forces when the candidate pairs are the same.  Returns
    ``(mesh force [N], ContactState)``; counts its solves (``calls``) and failed ones (``failures``, raised)."""

    def __init__(self, solver: Any) -> None:
        if not hasattr(solver, "state_deflection"):
            raise ModelError(f"{type(solver).__name__} has no state_deflection(position, deflection, warm): level 1 "
                             "needs a MeshContactSolver")
        self.solver = solver
        self.calls = 0
        self._warm: tuple[np.ndarray, np.ndarray] | None = None

    def _warm_for(self, position: float) -> np.ndarray | None:
        if self._warm is None:
            return None
        pairs, f = self._warm
        su = self.solver.setup(position)
        return f if np.array_equal(su.pairs, pairs) else None

    def __call__(self, position: float, deflection: float) -> tuple[float, Any]:
        st = self.solver.state_deflection(position, deflection, warm=self._warm_for(position))
        self.calls += 1
        if not st.success:
            raise SolverError(f"level 1: static solve failed at position {position:.9g}, deflection "
                              f"{deflection:.6g} m: {st.message}")
        if np.any(st.force_N > 0):
            self._warm = (st.setup.pairs, st.force_N)
        return max(float(st.mesh_force_N), 0.0), st


class CoastSolverMeshForce(SolverMeshForce):
    """``MeshForceFn`` of the coast flanks of one mesh from a
    :class:`~hacgear_core.statics.coast.CoastSideSolver`: position = drive-side position, deflection = coast
    approach ``xc`` [m].  Below the normal backlash ``j_n`` (ideal coast involutes touch at ``xc = j_n``; profile
    modifications and crowning only remove material) the flanks are apart: ``(0.0, None)`` without a solve."""

    def __init__(self, coast_solver: Any) -> None:
        super().__init__(coast_solver.inner)
        self.coast = coast_solver
        self.backlash_m = float(coast_solver.backlash_normal_m)

    def __call__(self, position: float, deflection: float) -> tuple[float, Any]:
        if deflection < self.backlash_m:
            return 0.0, None
        return super().__call__(self.coast.inner_position(position), deflection - self.backlash_m)


def contact_load(eqs: DirectEquations, drive: Sequence[MeshForceFn],
                 coast: Sequence[MeshForceFn | None] | None = None) -> GeneralizedLoad:
    """``GeneralizedLoad`` of level 1: per mesh ``k`` the drive force ``drive[k](tau_k, x_k)`` and the coast force
    ``coast[k](tau_k, xc_k)`` (None: one-sided) with ``tau_k = tau_ref + phase_k + w_k . q``, ``x_k = v_k . q``,
    ``xc_k = vc_k . q``; ``g = sum_k F_k v_k + Fc_k vc_k``."""
    m = eqs.m
    if len(drive) != m:
        raise ModelError(f"contact_load needs one drive MeshForceFn per mesh ({m}), got {len(drive)}")
    coast = [None] * m if coast is None else list(coast)
    if len(coast) != m:
        raise ModelError(f"contact_load needs one coast MeshForceFn (or None) per mesh ({m}), got {len(coast)}")

    def load(tau_ref: float, q: np.ndarray, qd: np.ndarray) -> StageLoad:
        tau = tau_ref + eqs.phase + eqs.W @ q
        x = eqs.V @ q
        xc = eqs.Vc @ q
        f = np.zeros(m)
        fc = np.zeros(m)
        extra = []
        for k in range(m):
            f[k], e = drive[k](float(tau[k]), float(x[k]))
            ec = None
            if coast[k] is not None:
                fc[k], ec = coast[k](float(tau[k]), float(xc[k]))
            extra.append((e, ec))
        g = eqs.V.T @ f + eqs.Vc.T @ fc
        return StageLoad(generalized_N=g, drive_force_N=f, coast_force_N=fc, position=tau, deflection_m=x,
                         coast_approach_m=xc, extra=tuple(extra))

    return load


def level1_mesh_forces(model: Any, system: LumpedSystem, *, coast: bool = True
                       ) -> tuple[list[SolverMeshForce], list[CoastSolverMeshForce | None]]:
    """Level-1 force callables of every mesh of ``system`` built from ``model`` with the static solvers the tables
    are built with (``statics/grid.py``: :func:`~hacgear_core.statics.helical.make_solver` and
    :func:`~hacgear_core.statics.coast.make_coast_solver`, the model's ``[statics]`` options).  ``coast`` False:
    one-sided (the coast flanks never load)."""
    drive, cst = [], []
    for c in system.meshes:
        drive.append(SolverMeshForce(make_solver(model, c.name)))
        cst.append(CoastSolverMeshForce(make_coast_solver(model, c.name))
                   if coast and c.coast_table is not None else None)
    return drive, cst


def solver_root_strain(solver: Any, states: Sequence[Any], gauge: str) -> np.ndarray:
    """Root strain [-] at ``gauge`` on every tooth of the solver's window (its ``tooth_offsets``) for each contact
    state (None: flanks apart, strain 0) → (len(states), n_offsets)."""
    nw = len(solver.tooth_offsets)
    out = np.zeros((len(states), nw))
    for i, st in enumerate(states):
        if st is not None:
            out[i] = solver.strains(st)[gauge]
    return out


@dataclass(frozen=True)
class Level1Options:
    """Settings of :func:`run_level1`.

    Attributes
    ----------
    rtol : float
        Poincaré change per mesh cycle that ends the run: ``max(|dx|, |dx'| / (2 pi f_m))`` over the meshes, over
        the largest mean static mesh deflection [-].
    min_cycles, max_cycles : int
        Mesh cycles integrated before the recorded one (at least / at most).
    correct : bool
        Start each level-1 cycle after the first from a corrected state (defect correction with the HAC map, see
        :func:`run_level1`) instead of the end of the previous cycle.  Only the start guesses change: the result is
        a level-1 orbit whose measured Poincaré change is below ``rtol``.
    correct_cycles : int
        HAC cycles allowed per correction (the fast kernel).
    """

    rtol: float = 1e-4
    min_cycles: int = 1
    max_cycles: int = 40
    correct: bool = True
    correct_cycles: int = 4000

    def __post_init__(self) -> None:
        if not (isinstance(self.correct_cycles, (int, np.integer)) and self.correct_cycles >= 1):
            raise ModelError(f"Level1Options.correct_cycles [cycles] must be an integer >= 1, got "
                             f"{self.correct_cycles!r}")
        if not (0 < self.rtol < 1):
            raise ModelError(f"Level1Options.rtol [-] must be in (0, 1), got {self.rtol!r}")
        if not (0 <= self.min_cycles <= self.max_cycles):
            raise ModelError(f"Level1Options needs 0 <= min_cycles <= max_cycles [cycles], got {self.min_cycles}, "
                             f"{self.max_cycles}")


@dataclass
class Level1Result:
    """Outcome of :func:`run_level1`: ``success`` (converged below ``rtol``), ``message``, ``cycles`` run before the
    recorded cycle, ``changes`` (Poincaré change per cycle, see :class:`Level1Options`), ``steps_per_cycle``,
    ``load_calls`` (stage evaluations, all cycles), ``wall_s_per_cycle`` [s], ``state`` (2n,) at the end,
    ``trace`` (the recorded cycle, :class:`DirectTrace`), ``metrics`` (:func:`~hacgear_core.dynamics.steady.trace_metrics`)
    and ``root_strain`` {gauge: (nr, n_offsets)} of the drive flanks along the recorded cycle."""

    success: bool
    message: str
    cycles: int
    changes: list
    steps_per_cycle: int
    load_calls: int
    wall_s_per_cycle: float
    state: np.ndarray
    trace: DirectTrace
    metrics: dict
    root_strain: dict


def run_level1(system: LumpedSystem, drive: Sequence[SolverMeshForce], coast: Sequence[Any] | None,
               mesh_frequency_Hz: float, state0: np.ndarray, *, steps_per_cycle: int,
               options: Level1Options | None = None, gauges: Sequence[str] = (),
               torque_Nm: float | None = None) -> Level1Result:
    """Level-1 steady state: from ``state0`` (at reference mesh position 0, e.g. the HAC steady state's
    ``state``) integrate whole mesh cycles of ``steps_per_cycle`` RK4 steps until the Poincaré change per cycle
    is below ``options.rtol`` (after ``min_cycles``; at most ``max_cycles``), then record one more cycle at every
    step with its steady-state metrics (:func:`~hacgear_core.dynamics.steady.trace_metrics`, on the level-1 forces)
    and the drive flanks' root strains at ``gauges`` (``"<gear>/<gauge>"`` of mesh 0's solver).

    Start guesses (``options.correct``): a transient near resonance decays by only ``exp(-2 pi zeta f_n / f_m)``
    per cycle, so instead of integrating it away each level-1 cycle from ``s`` is followed by a defect correction:
    with ``d`` the elastic part (mass-normalised elastic modes of the system) of ``P_1(s) - P_hac(s)`` (one level-1
    cycle against one cycle of the compiled HAC kernel from the same state), the next start is the fixed point of
    ``s <- P_hac(s) + d``, iterated with the HAC kernel.  The level-1 map converges to its own fixed point however
    it is started; the correction only makes the starts better, and the run stops on the *measured* level-1
    change."""
    opt = options or Level1Options()
    fm = float(mesh_frequency_Hz)
    eqs = DirectEquations.from_system(system, torque_Nm)
    load = contact_load(eqs, drive, coast)
    nsp = int(steps_per_cycle)
    if nsp < 8:
        raise ModelError(f"steps_per_cycle [-] must be >= 8, got {steps_per_cycle!r}")
    h = 1.0 / (fm * nsp)
    n = system.n
    xs = max(float(np.max(np.abs(system.mean_static_deflections_m(torque_Nm)))), 1e-9)
    s = np.array(state0, dtype=float)
    changes: list[float] = []
    calls = 0
    wall = 0.0
    cycles = 0
    converged = False

    def sample(st: np.ndarray) -> np.ndarray:
        return np.concatenate([eqs.V @ st[:n], eqs.V @ st[n:] / (2 * math.pi * fm)]) / xs

    fext = system.fext_speed(torque_Nm)
    omega = system.reference_speed(fm)
    el = system.modal_shapes[:, ~system.rigid_modes]
    proj_el = el @ el.T @ system.M          # q -> its elastic part (mass-normalised modes)

    def hac_map(st: np.ndarray, jump: np.ndarray | None = None, ncyc: int = 1) -> tuple[np.ndarray, float]:
        """``ncyc`` cycles of ``s <- P_hac(s) + jump`` with the compiled kernel; returns the state and the last
        Poincaré change."""
        st = st.copy()
        kin = np.zeros(3)
        ch = math.inf
        for _ in range(ncyc):
            p0 = sample(st)
            kin[:] = (0.0, 0.0, omega)
            system.integrate(st, kin, nsp, h, fext)
            if jump is not None:
                st += jump
            ch = float(np.max(np.abs(sample(st) - p0)))
            if ch < 1e-3 * opt.rtol:
                break
        return st, ch

    corrections = 0
    while cycles < opt.max_cycles:
        p0 = sample(s)
        s1, _, tr = integrate_direct(eqs, load, s, mesh_frequency_Hz=fm, n_steps=nsp, h=h, cycles0=cycles,
                                     rec_every=nsp)
        calls += tr.load_calls
        wall += tr.wall_s
        cycles += 1
        changes.append(float(np.max(np.abs(sample(s1) - p0))))
        if cycles >= opt.min_cycles and changes[-1] < opt.rtol:
            s = s1
            converged = True
            break
        if opt.correct:
            # defect correction: the level-1 map differs from the HAC map by d = P_1(s) - P_hac(s) (elastic part);
            # the fixed point of s <- P_hac(s) + d (cheap) is the next start
            sh, _ = hac_map(s)
            d = s1 - sh
            d = np.concatenate([proj_el @ d[:n], proj_el @ d[n:]])
            s, _ = hac_map(s1, d, opt.correct_cycles)
            corrections += 1
        else:
            s = s1
    s_end, _, tr = integrate_direct(eqs, load, s, mesh_frequency_Hz=fm, n_steps=nsp, h=h, cycles0=cycles,
                                    rec_every=1, keep_extra=bool(gauges))
    calls += tr.load_calls
    wall += tr.wall_s
    met = trace_metrics(system, tr.mesh_deflection_m, tr.mesh_force_N, tr.dynamic_transmission_error_m,
                        static_forces_N=system.nominal_forces_N(torque_Nm),
                        fc=tr.coast_force_N, cycles=1, coast_static_forces_N=system.nominal_coast_forces_N(torque_Nm),
                        xc=tr.coast_approach_m)
    strains = {}
    if gauges:
        solver = drive[0].solver
        states = [e[0][0] for e in tr.extra]
        for g in gauges:
            strains[g] = solver_root_strain(solver, states, g)
    msg = (f"Poincaré change {changes[-1]:.3g} < {opt.rtol:g} after {cycles} cycles" if converged else
           f"cap: Poincaré change {changes[-1] if changes else math.nan:.3g} >= {opt.rtol:g} after {cycles} cycles")
    msg += f" ({corrections} HAC defect corrections)"
    return Level1Result(success=converged, message=msg, cycles=cycles, changes=changes, steps_per_cycle=nsp,
                        load_calls=calls, wall_s_per_cycle=wall / (cycles + 1), state=s_end, trace=tr, metrics=met,
                        root_strain=strains)
