"""Direct dynamic contact model, level 2: elastic gear bodies in motion (fixed-hub modes + residual flexibility).

Level 1 (:mod:`hacgear_core.studies.direct`) solves the static contact at every RK4 stage: the bodies are
quasi-static.  Level 2 keeps the ``n`` lowest fixed-hub modes of each gear body
(:func:`hacgear_core.statics.bodymodes.gear_body_modes`, the finite-element model the contact solver's compliance
comes from, plus its consistent mass) as dynamic coordinates and the rest quasi-static (mode-acceleration /
residual flexibility).  At the contact candidates ``c`` of a stage (pairs x face slices of
:class:`~hacgear_core.statics.contact.MeshContactSolver`) the normal approach of the bodies is::

    u = (C - sum_g sum_k phi_gk phi_gk^T / omega_gk^2) F + sum_g sum_k phi_gk q_gk

with ``C`` the static solver's linear compliance (far field + near field), ``phi_gk`` the inward-normal
displacement of mode ``k`` of gear ``g`` at the candidates (physical normalisation: face width ``b``,
``phi = phi_unit / sqrt(b)``; the plane body acts over the whole face, so ``face_coupling = "rigid"`` is required)
and ``q_gk`` its modal coordinate.  The stage's contact is the static solver's complementarity problem with the
compliance offset ``-sum phi phi^T / omega^2`` and the gap offset ``sum phi q``
(:meth:`MeshContactSolver.state_deflection` hooks).  The modal equations (Craig-Bampton, hub as interface)::

    q_gk'' + 2 zeta omega_gk q_gk' + omega_gk^2 q_gk + L_gk theta_g'' = phi_gk^T F
    J_g theta_g'' + sum_k L_gk q_gk'' + ...  = (the lumped equation of gear g)

``L_gk = phi^T M rho`` the participation of the hub rotation ``theta_g`` (closing sense).  The lumped part is
:class:`~hacgear_core.studies.direct.DirectEquations` of the system (its mass, damping, loads, mesh vectors),
extended by the modal DOFs; :func:`~hacgear_core.studies.direct.integrate_direct` integrates it.  With
``q_gk = phi_gk^T F / omega_gk^2`` (zero speed) ``u = C F`` exactly: the static solver.  With no modes it *is*
level 1 (same solver calls, same RK4).

Neglected, and why: the body's rotation terms (spin softening and Coriolis coupling of the modes, relative size
``(Omega / omega_1)^2`` and ``2 Omega / omega_1``, 0.02 % and 3.1 % for the 28-tooth pair at its mesh
resonance) and hub translations (the spur-pair systems served here have rigid bearings: rotation DOFs only; a
system with translation DOFs is refused).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import scipy.linalg

from hacgear_core.studies.direct import DirectEquations, Level1Result, StageLoad, integrate_direct
from hacgear_core.dynamics.steady import trace_metrics
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError, SolverError
from hacgear_core.geometry import gear_geometry
from hacgear_core.model import Model
from hacgear_core.kinds import load_model
from hacgear_core.statics.bodymodes import BodyModeOptions, BodyModes, gear_body_modes
from hacgear_core.statics.helical import make_solver

__all__ = ["ElasticMesh", "Level2Options", "Level2Result", "elastic_equations", "elastic_mesh", "highest_frequency_Hz",
           "initial_state", "run_level2"]


class ElasticMesh:
    """Contact of one spur mesh between two modal gear bodies: the stage load of level 2.

    Parameters
    ----------
    solver : MeshContactSolver
        Static contact solver of the mesh (``face_coupling = "rigid"``).
    modes : (BodyModes, BodyModes)
        Modes of gear_a and gear_b, read at the samples of the solver's compliances (same flanks); possibly
        truncated (:meth:`BodyModes.truncated`); ``n_modes = 0`` gives level 1.
    damping_ratio : float
        Modal damping ratio of the body modes [-], in [0, 1).

    Attributes
    ----------
    n_modes : (int, int)
    calls : int
        Contact solves made.
    """

    def __init__(self, solver: Any, modes: tuple[BodyModes, BodyModes], damping_ratio: float):
        if solver.options.face_coupling != "rigid":
            raise ModelError("level 2 needs face_coupling = 'rigid' (a plane body acting over the whole face), got "
                             f"{solver.options.face_coupling!r}")
        if not (0.0 <= damping_ratio < 1.0):
            raise ModelError(f"damping_ratio [-] must be in [0, 1), got {damping_ratio!r}")
        for g, (bm, fc) in enumerate(zip(modes, solver.compliance)):
            if bm.z != fc.z or bm.side != fc.side or bm.s_m.shape != fc.s_m.shape or not np.allclose(bm.s_m, fc.s_m):
                raise ModelError(f"modes of gear {g} were not read at the samples of the solver's compliance "
                                 f"(z {bm.z}/{fc.z}, side {bm.side}/{fc.side})")
        self.solver = solver
        self.modes = tuple(modes)
        self.n_modes = tuple(int(m.n_modes) for m in modes)
        self.damping_ratio = float(damping_ratio)
        b = solver.face_width_m
        self._scale = 1.0 / math.sqrt(b)
        self._omega = [m.omega_rad_s for m in modes]
        self.calls = 0
        self._warm: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def n_total(self) -> int:
        return sum(self.n_modes)

    def pair_modes(self, setup) -> list[np.ndarray]:
        """Per gear ``(n_g, n_pairs)`` physical inward-normal modal displacements at the contact of each tooth
        pair of ``setup`` [m per modal unit] (every face slice of a pair shares them: the plane body acts over the
        whole face)."""
        out = []
        for bm, teeth, s in zip(self.modes, (setup.tooth_a, setup.tooth_b), (setup.s_a, setup.s_b)):
            out.append(bm.at(teeth, s) * self._scale if bm.n_modes else np.zeros((0, len(setup.pairs))))
        return out

    def candidate_modes(self, setup) -> list[np.ndarray]:
        """Per gear ``(n_g, n_candidates)`` physical inward-normal modal displacements at the candidates of
        ``setup`` [m per modal unit]."""
        return [P[:, setup.pair_index] for P in self.pair_modes(setup)]

    def contact(self, position: float, deflection_m: float, q_modal: np.ndarray):
        """Contact state at ``position`` [cycles, unwrapped: the body's teeth], mesh ``deflection_m`` [m] and modal
        coordinates ``q_modal`` (n_total,) → (ContactState, modal forces (n_total,), per-gear pair modes)."""
        sol = self.solver
        setup = sol.setup(position)
        Ps = self.pair_modes(setup)
        npair = len(setup.pairs)
        gap_p = np.zeros(npair)
        dC_p = np.zeros((npair, npair))
        i = 0
        for P, om in zip(Ps, self._omega):
            k = P.shape[0]
            if k:
                gap_p += P.T @ q_modal[i:i + k]
                dC_p -= (P / om[:, None] ** 2).T @ P
            i += k
        warm = None
        if self._warm is not None and np.array_equal(self._warm[0], setup.pairs):
            warm = self._warm[1]
        if self.n_total:
            pi = setup.pair_index
            st = sol.state_deflection(position, deflection_m, warm=warm, gap_offset_m=gap_p[pi],
                                      compliance_offset_m_N=dC_p[np.ix_(pi, pi)])
        else:
            st = sol.state_deflection(position, deflection_m, warm=warm)
        self.calls += 1
        if not st.success:
            raise SolverError(f"level 2: contact solve failed at position {position:.9g}, deflection "
                              f"{deflection_m:.6g} m: {st.message}")
        if np.any(st.force_N > 0):
            self._warm = (setup.pairs, st.force_N)
        Fp = np.bincount(setup.pair_index, weights=st.force_N, minlength=npair)
        Q = np.concatenate([P @ Fp for P in Ps]) if self.n_total else np.zeros(0)
        return st, Q, Ps

    def root_strain(self, st, q_modal: np.ndarray, Q: np.ndarray, gauge: str) -> float:
        """Largest root strain [-] at ``gauge`` (``"<gear>/<gauge>"``) over the teeth of the state's window:
        the static solver's strain of the contact forces plus ``sum_k psi_k (q_k - Q_k / omega_k^2)`` of that gear's
        modes (``psi`` the modal gauge strain)."""
        sol = self.solver
        s = st.setup
        offs = s.pairs[1:-1]
        eps = np.asarray(sol.strains(st, offs)[gauge], float)
        for gear, gi, name in sol.gauges:
            if name != gauge:
                continue
            bm = self.modes[gear]
            if bm.n_modes:
                i0 = sum(self.n_modes[:gear])
                k = bm.n_modes
                dyn = q_modal[i0:i0 + k] - Q[i0:i0 + k] / self._omega[gear] ** 2
                teeth = (s.tooth_a if gear == 0 else s.tooth_b)[1:-1] % bm.z
                eps = eps + (bm.gauge_strain[:, gi, teeth] * self._scale).T @ dyn
        return float(np.max(eps))


def elastic_equations(system: LumpedSystem, emesh: ElasticMesh, torque_Nm: float | None = None
                      ) -> tuple[DirectEquations, np.ndarray]:
    """Lumped equations of ``system`` extended by the modal DOFs of ``emesh`` (appended after the lumped DOFs):
    returns (DirectEquations, ``rot`` (2,) index of each gear's rotation DOF).  The coupling mass ``L_gk`` sits
    between mode ``k`` of gear ``g`` and ``g``'s rotation (closing sense = the sign of its entry in the mesh
    deflection vector)."""
    eqs = DirectEquations.from_system(system, torque_Nm)
    if eqs.m != 1:
        raise ModelError(f"level 2 serves single-mesh systems (spur pairs), got {eqs.m} meshes")
    gears = [system.gears[nm] for nm in emesh.solver.gear_names]
    if any(g.translations for g in gears):
        raise ModelError("level 2 models hub rotation only: the gears must have rigid bearings (no translation DOFs)")
    rot = np.array([g.rotation for g in gears])
    n0, nm = eqs.n, emesh.n_total
    N = n0 + nm
    M = np.zeros((N, N))
    M[:n0, :n0] = eqs.M
    C = np.zeros((N, N))
    C[:n0, :n0] = eqs.C
    K = np.zeros((N, N))
    K[:n0, :n0] = eqs.K
    i = n0
    for g, bm in enumerate(emesh.modes):
        k = bm.n_modes
        if not k:
            continue
        sense = float(np.sign(eqs.V[0, rot[g]]))
        if sense == 0:
            raise ModelError(f"gear {g}'s rotation does not enter the mesh deflection")
        L = sense * bm.rotation_participation * math.sqrt(emesh.solver.face_width_m)   # physical [kg^0.5 m]
        idx = np.arange(i, i + k)
        M[idx, idx] = 1.0
        M[idx, rot[g]] = L
        M[rot[g], idx] = L
        C[idx, idx] = 2.0 * emesh.damping_ratio * bm.omega_rad_s
        K[idx, idx] = bm.omega_rad_s ** 2
        i += k
    if np.min(np.linalg.eigvalsh(M)) <= 0:
        raise ModelError("coupled mass matrix is not positive definite: the lumped inertia of a gear is below the "
                         "modal participation of its body (sum L_k^2)")

    def pad(a):
        """``a`` (..., n0) with zero columns for the modal DOFs → (..., N)."""
        a = np.asarray(a, float)
        out = np.zeros(a.shape[:-1] + (N,))
        out[..., :n0] = a
        return out

    Z = np.zeros((N, N))
    Z[:n0, :n0] = eqs.G
    ZW = np.zeros((N, N))
    ZW[:n0, :n0] = eqs.K_W
    out = DirectEquations(M=M, C=C, K=K, G=Z, K_W=ZW, carrier_ratio=eqs.carrier_ratio, fext=pad(eqs.fext),
                          V=pad(eqs.V), Vc=pad(eqs.Vc), W=pad(eqs.W), V_rot=pad(eqs.V_rot), phase=eqs.phase,
                          zref_2pi=eqs.zref_2pi)
    return out, rot


@dataclass(frozen=True)
class Level2Options:
    """Settings of :func:`run_level2`.

    Attributes
    ----------
    rtol : float
        Poincaré change per mesh cycle that ends the run (as :class:`~hacgear_core.studies.direct.Level1Options`).
    min_cycles, max_cycles : int
        Mesh cycles integrated before the recorded one (at least / at most).
    steps_per_cycle : int
        Fewest RK4 steps per mesh cycle (>= 8).
    max_omega_h : float
        Largest ``omega h`` allowed for the highest natural frequency of the lumped + modal equations without the
        meshes (free hubs: the hub keeps only the inertia of the modes left out, so a hub-against-body mode lies
        far above the kept modes, 62 kHz for the 28-tooth gear); more steps are taken when needed.  RK4 is
        stable up to 2.78; the default leaves room for the stiffness the contact adds.
    """

    rtol: float = 1e-3
    min_cycles: int = 2
    max_cycles: int = 40
    steps_per_cycle: int = 128
    max_omega_h: float = 1.4

    def __post_init__(self) -> None:
        if not (0 < self.rtol < 1):
            raise ModelError(f"Level2Options.rtol [-] must be in (0, 1), got {self.rtol!r}")
        if not (0 <= self.min_cycles <= self.max_cycles):
            raise ModelError(f"Level2Options needs 0 <= min_cycles <= max_cycles [cycles], got {self.min_cycles}, "
                             f"{self.max_cycles}")
        if not (isinstance(self.steps_per_cycle, int) and self.steps_per_cycle >= 8):
            raise ModelError(f"Level2Options.steps_per_cycle [-] must be an integer >= 8, got {self.steps_per_cycle!r}")
        if not (0.05 <= self.max_omega_h <= 2.5):
            raise ModelError(f"Level2Options.max_omega_h [-] must be in [0.05, 2.5], got {self.max_omega_h!r}")


@dataclass
class Level2Result(Level1Result):
    """Outcome of :func:`run_level2`: the fields of :class:`~hacgear_core.studies.direct.Level1Result` (``state``
    (2N,) with the modal coordinates, ``root_strain`` {gauge: (nr,) largest over the window}), ``n_modes`` (per
    gear) and ``modal`` (nr, n_total) modal coordinates along the recorded cycle."""

    n_modes: tuple
    modal: np.ndarray


def _load(eqs: DirectEquations, emesh: ElasticMesh, n0: int, cycle_offset: list):
    def load(tau_ref: float, q: np.ndarray, qd: np.ndarray) -> StageLoad:
        tau = tau_ref + eqs.phase + eqs.W @ q
        x = eqs.V @ q
        st, Q, _ = emesh.contact(float(tau[0]) + cycle_offset[0], float(x[0]), q[n0:])
        f = max(float(st.mesh_force_N), 0.0)
        g = eqs.V[0] * f
        g[n0:] = -Q
        return StageLoad(generalized_N=g, drive_force_N=np.array([f]), coast_force_N=np.zeros(1), position=tau,
                         deflection_m=x, coast_approach_m=eqs.Vc @ q, extra=((st, Q),))

    return load


def highest_frequency_Hz(eqs: DirectEquations) -> float:
    """Highest natural frequency [Hz] of ``K q = omega^2 M q`` of the equations (supports and body modes, the
    meshes left out)."""
    w2 = scipy.linalg.eigh(eqs.K, eqs.M, eigvals_only=True)
    return float(np.sqrt(max(float(np.max(w2)), 0.0)) / (2 * math.pi))


def initial_state(eqs: DirectEquations, emesh: ElasticMesh, lumped_state: np.ndarray, n0: int) -> np.ndarray:
    """Level-2 state from a lumped state ``[q, q']`` (2 n0,) at reference position 0: the modes in their
    quasi-static position under the static contact forces there (``q_k = phi_k^T F / omega_k^2``), at rest."""
    s = np.asarray(lumped_state, float)
    q, qd = s[:n0], s[n0:]
    N = eqs.n
    out = np.zeros(2 * N)
    out[:n0], out[N:N + n0] = q, qd
    if emesh.n_total:
        tau = eqs.phase[0] + float(eqs.W[0, :n0] @ q)
        st = emesh.solver.state_deflection(tau, float(eqs.V[0, :n0] @ q))
        Ps = emesh.candidate_modes(emesh.solver.setup(tau))
        out[n0:N] = np.concatenate([(P @ st.force_N) / om ** 2 for P, om in zip(Ps, emesh._omega)])
    return out


def run_level2(system: LumpedSystem, emesh: ElasticMesh, mesh_frequency_Hz: float, lumped_state0: np.ndarray, *,
               options: Level2Options | None = None, gauges: Sequence[str] = (),
               torque_Nm: float | None = None) -> Level2Result:
    """Level-2 steady state: from a lumped state ``lumped_state0`` (2n,) at reference mesh position 0 (e.g. the HAC
    steady state's ``state``; the modes start quasi-static, :func:`initial_state`) integrate whole mesh cycles
    until the Poincaré change per cycle of the mesh deflection and the modal coordinates is below
    ``options.rtol`` (after ``min_cycles``; at most ``max_cycles``), then record one cycle at every step with its
    metrics and root strains at ``gauges`` (``"<gear>/<gauge>"`` of the solver)."""
    opt = options or Level2Options()
    fm = float(mesh_frequency_Hz)
    if not (math.isfinite(fm) and fm > 0):
        raise ModelError(f"mesh_frequency_Hz [Hz] must be finite and > 0, got {mesh_frequency_Hz!r}")
    eqs, _ = elastic_equations(system, emesh, torque_Nm)
    n0 = system.n
    N = eqs.n
    cyc = [0]
    load = _load(eqs, emesh, n0, cyc)
    nsp = max(opt.steps_per_cycle, int(math.ceil(highest_frequency_Hz(eqs) * 2 * math.pi / (opt.max_omega_h * fm))))
    h = 1.0 / (fm * nsp)
    xs = max(float(np.max(np.abs(system.mean_static_deflections_m(torque_Nm)))), 1e-9)
    s = initial_state(eqs, emesh, lumped_state0, n0)
    # a modal coordinate counts by the largest flank displacement it makes [m] (scaled like the mesh deflection)
    amp = np.concatenate([np.max(np.abs(bm.flank_normal), axis=(1, 2)) / math.sqrt(emesh.solver.face_width_m)
                          for bm in emesh.modes]) if N > n0 else np.zeros(0)

    def sample(st: np.ndarray) -> np.ndarray:
        w = 2 * math.pi * fm
        parts = [eqs.V @ st[:N] / xs, eqs.V @ st[N:] / (w * xs)]
        if N > n0:
            parts += [st[n0:N] * amp / xs, st[N + n0:] * amp / (w * xs)]
        return np.concatenate(parts)

    changes: list[float] = []
    calls = 0
    wall = 0.0
    converged = False
    while cyc[0] < opt.max_cycles:
        p0 = sample(s)
        s, _, tr = integrate_direct(eqs, load, s, mesh_frequency_Hz=fm, n_steps=nsp, h=h, cycles0=cyc[0],
                                    rec_every=nsp)
        calls += tr.load_calls
        wall += tr.wall_s
        cyc[0] += 1
        changes.append(float(np.max(np.abs(sample(s) - p0))))
        if cyc[0] >= opt.min_cycles and changes[-1] < opt.rtol:
            converged = True
            break
    s_end, _, tr = integrate_direct(eqs, load, s, mesh_frequency_Hz=fm, n_steps=nsp, h=h, cycles0=cyc[0],
                                    rec_every=1, keep_extra=True)
    calls += tr.load_calls
    wall += tr.wall_s
    met = trace_metrics(system, tr.mesh_deflection_m, tr.mesh_force_N, tr.dynamic_transmission_error_m,
                        static_forces_N=system.nominal_forces_N(torque_Nm), fc=tr.coast_force_N, cycles=1,
                        coast_static_forces_N=system.nominal_coast_forces_N(torque_Nm), xc=tr.coast_approach_m)
    modal = tr.state[:, n0:N]
    strains = {}
    for gname in gauges:
        strains[gname] = np.array([emesh.root_strain(e[0][0], tr.state[i, n0:N], e[0][1], gname)
                                   for i, e in enumerate(tr.extra)])
    tr.extra = []
    msg = (f"Poincaré change {changes[-1]:.3g} < {opt.rtol:g} after {cyc[0]} cycles" if converged else
           f"cap: Poincaré change {changes[-1] if changes else math.nan:.3g} >= {opt.rtol:g} after {cyc[0]} cycles")
    return Level2Result(success=converged, message=msg, cycles=cyc[0], changes=changes, n_modes=emesh.n_modes,
                        load_calls=calls, wall_s_per_cycle=wall / (cyc[0] + 1), state=s_end, trace=tr, metrics=met,
                        root_strain=strains, modal=modal, steps_per_cycle=nsp)


def elastic_mesh(model: Any, mesh_name: str, *, damping_ratio: float, max_frequency_Hz: float = 40e3,
                 n_modes: tuple[int | None, int | None] = (None, None), cache: bool = True) -> ElasticMesh:
    """Level-2 mesh of spur mesh ``mesh_name`` of ``model`` (a Model or a path): its static contact solver (the one
    the tables are built with, :func:`hacgear_core.statics.helical.make_solver`) and the fixed-hub modes of both
    gears up to ``max_frequency_Hz`` [Hz] read at that solver's compliance samples, truncated to ``n_modes``
    (per gear; None keeps all; 0 gives level 1)."""
    if not isinstance(model, Model):
        model = load_model(model)
    solver = make_solver(model, mesh_name)
    gears = {g.name: g for g in model.gears}
    modes = []
    for g, (name, fc) in enumerate(zip(solver.gear_names, solver.compliance)):
        gm = gears[name]
        bm = gear_body_modes(gear_geometry(gm), gm.material, gm.material.density_kg_per_m3, fc,
                             BodyModeOptions(max_frequency_Hz=max_frequency_Hz), cache=cache)
        if n_modes[g] is not None:
            bm = bm.truncated(n_modes[g])
        modes.append(bm)
    return ElasticMesh(solver, (modes[0], modes[1]), damping_ratio)
