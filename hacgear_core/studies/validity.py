"""Validity map of the quasi-static body assumption: level-2 runs (elastic bodies) from the HAC steady state.

The study (``examples/validity_map.py``, docs/hac_vs_direct.md) compares, at one mesh frequency, level 2 with the
lowest ``n`` fixed-hub body modes of each gear (:mod:`hacgear_core.studies.direct_elastic`) against level 1 (the
same solver, RK4 and step with no modes: the quasi-static assumption alone) and against HAC.  Every run starts
from the HAC steady state at that speed (:func:`~hacgear_core.dynamics.steady.steady_state`).
"""
from __future__ import annotations

import time

import numpy as np

from hacgear_core.dynamics.steady import steady_state
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.studies.direct_elastic import Level2Options, elastic_mesh, run_level2

__all__ = ["modes_to_keep", "level2_run"]


def modes_to_keep(body_modes, mesh_frequency_Hz: float, resonance_Hz: float, mode_factor: float) -> int:
    """Body modes per gear a level-2 run keeps at mesh frequency ``mesh_frequency_Hz`` [Hz]: every mode below
    ``mode_factor`` x max(f_m, f_n) (``resonance_Hz`` = f_n, the lumped mesh resonance [Hz]), at least the first
    complete degenerate set of ``body_modes`` (:class:`~hacgear_core.statics.bodymodes.BodyModes`)."""
    return max(body_modes.count_below(mode_factor * max(mesh_frequency_Hz, resonance_Hz)),
               int(body_modes.complete_counts()[1]))


def level2_run(system: LumpedSystem, model, mesh_frequency_Hz: float, n_modes: int, *, steps: int, cycles: int,
               rtol: float, gauge: str, mesh: str, max_frequency_Hz: float = 40e3, traces: dict | None = None
               ) -> dict:
    """One level-2 run with ``n_modes`` body modes per gear (0 = level 1) of mesh ``mesh`` of ``model`` from the
    HAC steady state of ``system`` at ``mesh_frequency_Hz`` [Hz]: ``steps`` RK4 steps per mesh cycle, at most
    ``cycles`` mesh cycles, Poincaré change below ``rtol``; root strain at ``gauge`` (``"<gear>/<gauge>"``).

    Returns
    -------
    dict
        ``n_modes``, ``highest_mode_Hz`` [Hz], ``success``, ``message``, ``cycles``, ``changes``, ``dte_rms_m`` [m],
        ``peak_force_N`` [N], ``contact_loss_fraction``, ``max_root_strain`` [-], ``wall_s_per_cycle`` [s],
        ``wall_s`` [s], ``steps_per_cycle`` and ``hac`` (the steady state's ``dte_rms_m``, ``peak_force_N``).
        With ``traces`` (a dict) the recorded cycle's ``dte_m``, ``force_N``, ``root_strain_max`` and ``time_s``
        are put into it.
    """
    ss = steady_state(system, mesh_frequency_Hz)
    em = elastic_mesh(model, mesh, damping_ratio=system.modal_damping_ratio, max_frequency_Hz=max_frequency_Hz,
                      n_modes=(n_modes, n_modes))
    t0 = time.perf_counter()
    r = run_level2(system, em, mesh_frequency_Hz, ss.state, gauges=(gauge,),
                   options=Level2Options(rtol=rtol, min_cycles=2, max_cycles=cycles, steps_per_cycle=steps))
    if traces is not None:
        traces.update(dte_m=r.trace.dynamic_transmission_error_m[:, 0], force_N=r.trace.mesh_force_N[:, 0],
                      root_strain_max=r.root_strain[gauge], time_s=r.trace.time_s)
    return dict(n_modes=int(em.n_modes[0]), highest_mode_Hz=float(em.modes[0].frequency_Hz[-1]) if em.n_total else 0.0,
                success=bool(r.success), message=r.message, cycles=r.cycles, changes=r.changes,
                dte_rms_m=float(r.metrics["dte_rms_m"][0]), peak_force_N=float(r.metrics["peak_force_N"][0]),
                contact_loss_fraction=float(r.metrics["contact_loss_fraction"][0]),
                max_root_strain=float(np.max(r.root_strain[gauge])), wall_s_per_cycle=r.wall_s_per_cycle,
                wall_s=time.perf_counter() - t0, steps_per_cycle=r.steps_per_cycle,
                hac=dict(dte_rms_m=float(ss.metrics["dte_rms_m"][0]), peak_force_N=float(ss.metrics["peak_force_N"][0])))
