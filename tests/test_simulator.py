"""Tests of hacgear_core.dynamics.simulator: both experiments, invariants, bad input, outputs, snapshots."""
from __future__ import annotations

import numpy as np
import pytest

from _dyn import K, params, simulator
from hacgear_core.dynamics.synthetic import linear_fdf_table, spur_fdf_table, synthetic_28t_parameters
from hacgear_core.errors import ModelError


def test_torque_mode_matches_speed_mode_and_conserves_momentum():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    p = synthetic_28t_parameters(tab)
    a = simulator(p, tab)
    b = simulator(p, tab)
    assert a.ports == ("pinion", "wheel")
    w = 1500.0 / a.system.zref_2pi
    a.set_speed_input(speed_rad_s=w)
    b.reset(speed_rad_s=w)
    rb1, rb2 = p.base_radius_m
    b.set_torque_inputs({"pinion": p.torque_Nm, "wheel": -p.torque_Nm * rb2 / rb1})
    for dt in (1e-4, 3.7e-4, 2e-3):
        assert a.advance(dt).success and b.advance(dt).success
    assert b.mesh_deflection_m[0] == pytest.approx(a.mesh_deflection_m[0], rel=1e-6)
    assert b.speed_rad_s[0] == pytest.approx(a.speed_rad_s[0], rel=1e-8)
    assert b.angle_rad[0] == pytest.approx(a.angle_rad[0], rel=1e-9)
    # net torque: I1 dw1 + (rb1/rb2) I2 dw2 = (T1 + (rb1/rb2) T2) t  (linear invariant: exact in RK4)
    c = simulator(p, tab)
    c.reset(speed_rad_s=w)
    c.set_torque_inputs({"pinion": 400.0, "wheel": -250.0})
    w1, w2, t0 = c.speed_rad_s[0], c.speed_rad_s[1], c.time_s
    for _ in range(20):
        assert c.advance(1e-3).success
    ratio = rb1 / rb2
    lhs = p.inertia_kg_m2[0] * (c.speed_rad_s[0] - w1) + ratio * p.inertia_kg_m2[1] * (c.speed_rad_s[1] - w2)
    assert lhs == pytest.approx((400.0 - ratio * 250.0) * (c.time_s - t0), rel=1e-9)
    assert c.speed_rad_s[0] > w1


def test_simulator_rejects_bad_input_without_changing_state():
    tab = linear_fdf_table(K)
    sim = simulator(params(), tab)
    s0 = sim.s.copy()
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        r = sim.advance(bad)
        assert not r.success and "dt" in r.message
    np.testing.assert_array_equal(sim.s, s0)
    with pytest.raises(ModelError, match="torque"):
        sim.set_torque_inputs({"gear1": float("nan")})
    with pytest.raises(ModelError, match="not a port gear"):
        sim.set_torque_inputs({"nope": 1.0})
    with pytest.raises(ModelError, match="speed"):
        sim.set_speed_input(speed_rad_s=float("nan"))
    r = sim.advance(1e-3)
    assert r.success and r.n_substeps >= 1
    assert sim.in_contact[0] and sim.mesh_force_N[0] > 0
    # rigid bearings: the gears put the mesh force on them (-F n on gear 1, +F n on gear 2)
    n = np.asarray(sim.system.meshes[0].line_of_action)
    np.testing.assert_allclose(sim.bearing_force_N("gear1"), -sim.mesh_force_N[0] * n, rtol=1e-12)
    np.testing.assert_allclose(sim.bearing_force_N("gear2"), sim.mesh_force_N[0] * n, rtol=1e-12)


def test_torque_inputs_need_a_free_train():
    tab = linear_fdf_table(K)
    sim = simulator(params(rotational_stiffness_Nm_per_rad=(5e4, 0.0)), tab)
    with pytest.raises(ModelError, match="turns freely"):
        sim.set_torque_inputs({"gear1": 300.0})


def test_simulator_post_processed_outputs():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    sim = simulator(synthetic_28t_parameters(tab), tab)
    sim.set_speed_input(mesh_frequency_Hz=1000.0)
    strains, press = [], []
    for _ in range(3 * 28 * 8):  # three revolutions of gear 2, 8 samples per mesh cycle
        assert sim.advance(1.0 / 8000.0).success
        strains.append(sim.strain("wheel/SG"))
        press.append(sim.peak_pressure_Pa(0))
    strains = np.array(strains)
    # the gauge tooth of the wheel is loaded once per revolution of the wheel (every 28 mesh cycles)
    idx = np.nonzero(strains > 0.2 * strains.max())[0]
    gaps = np.nonzero(np.diff(idx) > 8 * 8)[0]  # passages separated by > 8 mesh cycles unloaded
    starts = idx[gaps + 1]  # full passages (the first, at t = 0, starts mid-mesh)
    assert idx[0] == 0 and len(starts) == 3
    np.testing.assert_array_equal(np.diff(starts), 28 * 8)
    assert 100e-6 < strains.max() < 2e-3
    assert min(press) > 0  # no contact loss at 1000 Hz, 300 N m
    with pytest.raises(ModelError, match="gauge"):
        sim.strain("wheel/nope")


def test_simulator_state_snapshot_restores_exactly():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    sim = simulator(synthetic_28t_parameters(tab), tab)
    sim.set_speed_input(mesh_frequency_Hz=1800.0)
    sim.advance(3e-3)
    snap = sim.get_state()
    sim.advance(2e-3)
    x1, a1 = sim.mesh_deflection_m[0], sim.angle_rad[0]
    sim.set_torque_inputs({"pinion": 500.0, "wheel": -100.0})
    sim.advance(1e-3)
    sim.set_state(snap)
    assert sim.mode == "speed"
    sim.advance(2e-3)
    assert sim.mesh_deflection_m[0] == x1 and sim.angle_rad[0] == a1
