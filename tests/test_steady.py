"""Tests of hacgear_core.dynamics.steady: closed-form forced response, period detection, DOF models agree."""
from __future__ import annotations

import math

import numpy as np
import pytest

from _dyn import K, first_harmonic, fn_rot, m_eff, params, system
from hacgear_core.dynamics.steady import SteadyStateOptions, steady_state
from hacgear_core.dynamics.synthetic import linear_fdf_table, spur_fdf_table, synthetic_28t_parameters


@pytest.mark.parametrize("ratio", [0.6, 1.4])
def test_linear_fdf_forced_response_matches_closed_form(ratio):
    a = 2e-6
    tab = linear_fdf_table(K, offset_amplitude_m=a)
    p = params(modal_damping_ratio=0.05)
    sy = system(p, tab)
    fm = ratio * fn_rot()
    r = steady_state(sy, fm, keep_trace=True)
    assert r.converged and r.period_cycles == 1
    x = r.trace["mesh_deflection_m"][:, 0]
    w = 2 * math.pi * fm
    me = m_eff()
    c = 2 * 0.05 * math.sqrt(K * me)
    amp = K * a / abs(K - me * w**2 + 1j * c * w)
    assert first_harmonic(x) == pytest.approx(amp, rel=2e-3)
    # mean: F_s = k (x_mean - e_mean) (to 1e-5: tau follows the actual rotation, a 2nd-order effect)
    assert np.mean(x) == pytest.approx(p.static_force_N / K, rel=1e-5)


def test_period_one_steady_state_detected():
    tab = linear_fdf_table(K, offset_amplitude_m=1e-6)
    sy = system(params(), tab)
    r = steady_state(sy, 0.8 * fn_rot())
    assert r.converged and r.status == "period-1" and r.period_cycles == 1
    assert r.cycles_run < 1000
    # continuation from the steady state is immediately steady
    r2 = steady_state(sy, 0.8 * fn_rot(), r.state)
    assert r2.cycles_run <= SteadyStateOptions().min_cycles + SteadyStateOptions().chunk_cycles + 1
    # a cap that is too small is reported, not hidden
    r3 = steady_state(sy, 0.8 * fn_rot(), options=SteadyStateOptions(max_cycles=3, min_cycles=1, chunk_cycles=1))
    assert not r3.converged and r3.status == "cap"
    # at the cap the metrics come from cap_record_cycles cycles (a quasi-periodic response needs a long window)
    r4 = steady_state(sy, 0.8 * fn_rot(), options=SteadyStateOptions(max_cycles=3, min_cycles=1, chunk_cycles=1,
                                                                     cap_record_cycles=7), keep_trace=True)
    assert not r4.converged and r4.trace["state"].shape[0] == 7 * r4.steps_per_cycle
    assert r3.cycles_run == 3 + 4 and r4.cycles_run == 3 + 7


def test_two_dof_and_stiff_four_dof_agree():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    p2 = synthetic_28t_parameters(tab)
    p4 = synthetic_28t_parameters(tab, bearing_stiffness_N_per_m=1e11)
    for fm in (1200.0, 2000.0):
        r2 = steady_state(system(p2, tab), fm)
        r4 = steady_state(system(p4, tab), fm)
        for k in ("rms_deflection_m", "mean_deflection_m", "peak_force_N"):
            assert r4.metrics[k][0] == pytest.approx(r2.metrics[k][0], rel=0.01), k
