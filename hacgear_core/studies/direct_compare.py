"""HAC against the level-1 direct model at one mesh frequency: steady states, errors, wall time per mesh cycle."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from hacgear_core.studies.direct import Level1Options, level1_mesh_forces, run_level1
from hacgear_core.dynamics.steady import SteadyStateOptions, steady_state
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError
from hacgear_core.response import static_strain_max

__all__ = ["loaded_gauge", "hac_root_strain", "hac_wall_per_cycle", "SpeedComparison", "compare_at_speed",
           "hac_at_speed"]


def loaded_gauge(system: LumpedSystem, mesh: int = 0) -> str:
    """The gauge (``"<gear>/<gauge>"``) of mesh ``mesh``'s table with the largest static root strain over the
    cycle at the nominal force (:func:`hacgear_core.response.static_strain_max`): the loaded-flank gauge."""
    c = system.meshes[mesh]
    sm = static_strain_max(c.table, float(system.nominal_forces_N()[mesh]))
    if not sm:
        raise ModelError(f"mesh '{c.name}' of {system.name}: its table has no strain gauges")
    return max(sm, key=sm.get)


def hac_root_strain(table: Any, gauge: str, tau: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Root strain [-] at ``gauge`` on the teeth of every pair offset of ``table`` (its ``tooth_offsets``) along a
    HAC trajectory (``tau`` unwrapped positions [cycles], ``x`` deflections [m], (nr,)) → (nr, n_offsets), by the
    table's strain-deflection functions (:meth:`MeshTable.strain_at`)."""
    return np.stack([table.strain_at(gauge, tau, x, int(o)) for o in table.tooth_offsets], axis=1)


def hac_wall_per_cycle(system: LumpedSystem, mesh_frequency_Hz: float, steps_per_cycle: int, state: np.ndarray,
                       cycles: int = 2000, repeats: int = 3) -> float:
    """Wall time [s] per mesh cycle of the compiled HAC kernel (``system.integrate``) at ``steps_per_cycle`` RK4
    steps per cycle from ``state``: best of ``repeats`` runs of ``cycles`` cycles (the machine may be shared)."""
    fm = float(mesh_frequency_Hz)
    h = 1.0 / (fm * steps_per_cycle)
    fext = system.fext_speed()
    best = math.inf
    kin = np.zeros(3)
    s = np.array(state, float)
    kin[:] = (0.0, 0.0, system.reference_speed(fm))
    system.integrate(s, kin, steps_per_cycle, h, fext)       # compiled, caches warm
    for _ in range(repeats):
        s = np.array(state, float)
        kin[:] = (0.0, 0.0, system.reference_speed(fm))
        t0 = time.perf_counter()
        system.integrate(s, kin, cycles * steps_per_cycle, h, fext)
        best = min(best, time.perf_counter() - t0)
    return best / cycles


@dataclass
class SpeedComparison:
    """HAC and level 1 at one mesh frequency.  ``hac`` / ``level1``: ``dte_rms_m``, ``peak_force_N``,
    ``max_root_strain`` (largest over the period and the teeth in mesh, at ``gauge``), ``contact_loss_fraction``,
    ``wall_s_per_cycle``; ``errors``: HAC relative to level 1 [-] of the first three; ``speed_ratio``: level-1 over
    HAC wall time per mesh cycle; ``traces``: the recorded period of both (positions [cycles] in the frame of the
    table / solver, i.e. about [0, 1], deflections, forces, DTE, root strain per offset)."""

    success: bool
    message: str
    pair: str
    mesh_frequency_Hz: float
    fm_over_fn: float
    gauge: str
    steps_per_cycle: int
    hac: dict
    level1: dict
    errors: dict
    speed_ratio: float
    traces: dict = field(default_factory=dict)


def hac_at_speed(system: LumpedSystem, mesh_frequency_Hz: float, gauge: str, state0: np.ndarray | None = None,
                 options: SteadyStateOptions | None = None) -> tuple[Any, dict, dict]:
    """HAC steady state at ``mesh_frequency_Hz`` [Hz] (:func:`~hacgear_core.dynamics.steady.steady_state`, trace
    kept) → (result, numbers, trace) with the numbers of :class:`SpeedComparison` (wall time not included)."""
    res = steady_state(system, mesh_frequency_Hz, state0=state0, options=options, keep_trace=True)
    tr = res.trace
    tau, x = tr["mesh_position"][:, 0], tr["mesh_deflection_m"][:, 0]
    eps = hac_root_strain(system.meshes[0].table, gauge, tau, x)
    num = dict(dte_rms_m=float(res.metrics["dte_rms_m"][0]), peak_force_N=float(res.metrics["peak_force_N"][0]),
               max_root_strain=float(eps.max()), contact_loss_fraction=float(res.metrics["contact_loss_fraction"][0]),
               converged=bool(res.converged), cycles=int(res.cycles_run), steps_per_cycle=int(res.steps_per_cycle))
    trace = dict(position=tau, deflection_m=x, force_N=tr["mesh_force_N"][:, 0],
                 dte_m=tr["dynamic_transmission_error_m"][:, 0], root_strain=eps)
    return res, num, trace


def compare_at_speed(model: Any, system: LumpedSystem, mesh_frequency_Hz: float, *, drive: Sequence[Any] | None = None,
                     coast: Sequence[Any] | None = None, options: Level1Options | None = None,
                     hac_cycles: int = 2000) -> SpeedComparison:
    """HAC (``system``'s tables) against level 1 (the static solvers of ``model``; ``drive``/``coast`` force
    callables of :func:`~hacgear_core.studies.direct.level1_mesh_forces` may be passed to reuse them) at
    ``mesh_frequency_Hz`` [Hz]: the HAC steady state, then level 1 started from it at the same step
    (:func:`~hacgear_core.studies.direct.run_level1`), the metrics of both over the final period, and the wall
    time per mesh cycle of each (HAC: :func:`hac_wall_per_cycle` over ``hac_cycles`` cycles)."""
    fm = float(mesh_frequency_Hz)
    fn = float(system.natural_frequencies_Hz()[0])
    gauge = loaded_gauge(system)
    res, hac, htr = hac_at_speed(system, fm, gauge)
    hac["wall_s_per_cycle"] = hac_wall_per_cycle(system, fm, res.steps_per_cycle, res.state, cycles=hac_cycles)
    if drive is None:
        drive, coast = level1_mesh_forces(model, system)
    l1 = run_level1(system, drive, coast, fm, res.state, steps_per_cycle=res.steps_per_cycle, options=options,
                    gauges=[gauge])
    tr = l1.trace
    eps1 = l1.root_strain[gauge]
    lv = dict(dte_rms_m=float(l1.metrics["dte_rms_m"][0]), peak_force_N=float(l1.metrics["peak_force_N"][0]),
              max_root_strain=float(eps1.max()), contact_loss_fraction=float(l1.metrics["contact_loss_fraction"][0]),
              wall_s_per_cycle=float(l1.wall_s_per_cycle), converged=bool(l1.success), cycles=int(l1.cycles),
              changes=[float(c) for c in l1.changes], load_calls=int(l1.load_calls), message=l1.message,
              coast_solves=int(sum(getattr(c, "calls", 0) for c in (coast or []) if c is not None)))
    err = {k: hac[k] / lv[k] - 1.0 for k in ("dte_rms_m", "peak_force_N", "max_root_strain")}
    # positions as the solver saw them (the recorded cycle is numbered after the cycles before it)
    traces = dict(hac=htr, level1=dict(position=tr.mesh_position[:, 0] - l1.cycles,
                                       deflection_m=tr.mesh_deflection_m[:, 0],
                                       force_N=tr.mesh_force_N[:, 0], dte_m=tr.dynamic_transmission_error_m[:, 0],
                                       root_strain=eps1),
                  tooth_offsets=np.asarray(system.meshes[0].table.tooth_offsets))
    ok = bool(res.converged and l1.success)
    msg = "HAC and level 1 converged" if ok else (
        f"HAC steady state {res.status}; level 1: {l1.message}")
    return SpeedComparison(success=ok, message=msg, pair=system.name, mesh_frequency_Hz=fm, fm_over_fn=fm / fn,
                           gauge=gauge, steps_per_cycle=int(res.steps_per_cycle), hac=hac, level1=lv, errors=err,
                           speed_ratio=lv["wall_s_per_cycle"] / hac["wall_s_per_cycle"], traces=traces)
