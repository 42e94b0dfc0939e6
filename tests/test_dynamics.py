"""Tests of hacgear_core.dynamics: closed forms, conservation, convergence, steady state, sweeps."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hacgear_core.dynamics import kernels
from hacgear_core.dynamics.modes import contact_positions, impulse_test, modal_analysis
from hacgear_core.dynamics.spur import SpurPairParameters, SpurPairSimulator, SpurPairSystem
from hacgear_core.dynamics.steady import SteadyStateOptions, steady_state
from hacgear_core.dynamics.sweep import SweepSpec, detect_jumps, run_sweep
from hacgear_core.dynamics.synthetic import linear_fdf_table, spur_fdf_table, synthetic_28t_parameters
from hacgear_core.errors import ModelError

K = 150e6
RB = 0.0634
I1, I2 = 0.0044, 0.0061
M1, M2 = 1.6, 2.1


def params(**kw):
    base = dict(mass_kg=(M1, M2), inertia_kg_m2=(I1, I2), base_radius_m=(RB, RB), teeth=(28, 28),
                modal_damping_ratio=0.02, torque_Nm=300.0)
    base.update(kw)
    return SpurPairParameters(**base)


def m_eff():
    return 1.0 / (RB**2 / I1 + RB**2 / I2)


def fn_rot():
    return math.sqrt(K / m_eff()) / (2 * math.pi)


def first_harmonic(x):
    n = x.size
    return 2 * abs(np.sum(x * np.exp(-2j * np.pi * np.arange(1, n + 1) / n))) / n


# ---------------------------------------------------------------- closed forms (linear FDF)
def test_linear_fdf_natural_frequency_modal_and_impulse():
    tab = linear_fdf_table(K)
    sy = SpurPairSystem(params(), tab)
    mr = modal_analysis(sy)
    assert mr.rigid_body_modes == 1
    assert mr.natural_frequencies_Hz == pytest.approx([fn_rot()], rel=1e-9)
    it = impulse_test(sy, positions=(0.0, 0.5))
    assert it.single_contact_Hz[0] == pytest.approx(fn_rot(), rel=2e-3)
    assert it.double_contact_Hz[0] == pytest.approx(fn_rot(), rel=2e-3)


def test_identical_pair_mass_properties_inverts_the_modal_analysis():
    """Mass and inertia of identical gears read back from the rigid-support and supported natural frequencies
    of the linearised 4-DOF model (closed-form inversion vs. the numerical eigenproblem)."""
    from hacgear_core.dynamics.modes import identical_pair_mass_properties

    m, j, ky = 1.3, 0.0041, 200e6
    tab = linear_fdf_table(K)
    base = dict(mass_kg=(m, m), inertia_kg_m2=(j, j))
    f_rigid = modal_analysis(SpurPairSystem(params(**base), tab)).natural_frequencies_Hz[-1]
    f_sup = modal_analysis(SpurPairSystem(params(**base, bearing_stiffness_N_per_m=(ky, ky)), tab)).natural_frequencies_Hz[-1]
    assert f_sup > f_rigid
    r = identical_pair_mass_properties(K, f_rigid, f_sup, ky, RB)
    assert r["mass_kg"] == pytest.approx(m, rel=1e-9)
    assert r["inertia_kgm2"] == pytest.approx(j, rel=1e-9)
    assert r["mass_ratio"] == pytest.approx(m * RB**2 / j, rel=1e-9)
    with pytest.raises(ModelError, match="f_supported_Hz"):
        identical_pair_mass_properties(K, f_rigid, 0.9 * f_rigid, ky, RB)
    with pytest.raises(ModelError, match="support_stiffness_N_per_m"):
        identical_pair_mass_properties(K, f_rigid, f_sup, float("nan"), RB)


@pytest.mark.parametrize("ratio", [0.6, 1.4])
def test_linear_fdf_forced_response_matches_closed_form(ratio):
    a = 2e-6
    tab = linear_fdf_table(K, offset_amplitude_m=a)
    p = params(modal_damping_ratio=0.05)
    sy = SpurPairSystem(p, tab)
    fm = ratio * fn_rot()
    r = steady_state(sy, fm, keep_trace=True)
    assert r.converged and r.period_cycles == 1
    x = r.trace["mesh_deflection_m"]
    w = 2 * math.pi * fm
    me = m_eff()
    c = 2 * 0.05 * math.sqrt(K * me)
    amp = K * a / abs(K - me * w**2 + 1j * c * w)
    assert first_harmonic(x) == pytest.approx(amp, rel=2e-3)
    # mean: F_s = k (x_mean - e_mean) (to 1e-5: tau follows the actual rotation, a 2nd-order effect)
    assert np.mean(x) == pytest.approx(p.static_force_N / K, rel=1e-5)


def test_undamped_energy_conserved_to_rk4_order():
    tab = linear_fdf_table(K)
    p = params(modal_damping_ratio=0.0, bearing_stiffness_N_per_m=(300e6, 250e6))
    drift = []
    for spc in (32, 64):
        sy = SpurPairSystem(p, tab)
        s = sy.static_state(0.0)
        n = sy.n
        s[n + sy.ith1] += 0.05  # rad/s
        s[n + 0] += 0.02  # y1 rate m/s
        fext = sy.fext_speed()

        def energy(s):
            q, qd = s[:n], s[n:]
            x = sy.v @ q
            f_pot = 0.5 * K * x**2
            return 0.5 * np.sum(sy.m * qd**2) + 0.5 * np.sum(sy.kd * q**2) + f_pot - fext @ q

        e0 = energy(s)
        fmax = sy.max_frequency_Hz
        h = 1.0 / (spc * fmax)
        kin = np.array([0.0, 0.0, 500.0])
        sy.integrate(s, kin, int(300 * spc), h, fext)
        drift.append(abs(energy(s) - e0) / abs(e0 - energy(sy.static_state(0.0))))
    assert drift[0] < 1e-2
    assert drift[0] / drift[1] > 16  # RK4 energy error per step ~ (w h)^6 -> global ~ h^5


def test_rk4_fourth_order_convergence():
    tab = linear_fdf_table(K)
    p = params(bearing_stiffness_N_per_m=(300e6, 300e6))
    out = []
    for h in (4e-6, 2e-6, 1e-6):  # below the default internal step (1/32 of the shortest period)
        sim = SpurPairSimulator(p, tab, internal_step_s=h)
        sim.s[sim.system.n + sim.system.ith1] += 0.1
        sim.set_speed_input(mesh_frequency_Hz=1000.0)
        assert sim.advance(0.004).success
        out.append(sim.s.copy())
    e1 = np.linalg.norm(out[0] - out[1])
    e2 = np.linalg.norm(out[1] - out[2])
    assert 12 < e1 / e2 < 20


# ---------------------------------------------------------------- nonlinearity, steady state
def test_contact_loss_gives_zero_force():
    tab = spur_fdf_table(tip_relief_m=20e-6, stiffness_variation=0.1)
    ta_f = np.ascontiguousarray(tab.force_N)
    dx = tab.deflection_m[1] - tab.deflection_m[0]
    tau = np.linspace(0, 1, 500, endpoint=False)
    nl = np.interp(tau, np.append(tab.position, 1.0), np.append(tab.no_load_deflection_m, tab.no_load_deflection_m[0]))
    out = np.empty(tau.size)
    kernels.table_force_many(ta_f, tab.deflection_m[0], 1 / dx, tau, nl - 2 * dx, out)
    assert np.all(out == 0.0)
    kernels.table_force_many(ta_f, tab.deflection_m[0], 1 / dx, tau, np.full(tau.size, -1e-3), out)
    assert np.all(out == 0.0)
    # a resonant steady state with contact loss: zero force exactly where the teeth separate
    p = synthetic_28t_parameters(tab, torque_Nm=100.0)
    sy = SpurPairSystem(p, tab)
    r = steady_state(sy, 2300.0, keep_trace=True)
    f = r.trace["mesh_force_N"]
    assert r.metrics["contact_loss_fraction"] > 0.1
    x = r.trace["mesh_deflection_m"]
    t = r.trace["mesh_position"] % 1.0
    nl_t = np.interp(t, np.append(tab.position, 1.0), np.append(tab.no_load_deflection_m, tab.no_load_deflection_m[0]))
    assert np.all(f[x < nl_t - 2 * dx] == 0.0)
    assert np.all(f[x > tab.no_load_deflection_m.max() + 2 * dx] > 0.0)


def test_period_one_steady_state_detected():
    tab = linear_fdf_table(K, offset_amplitude_m=1e-6)
    sy = SpurPairSystem(params(), tab)
    r = steady_state(sy, 0.8 * fn_rot())
    assert r.converged and r.status == "period-1" and r.period_cycles == 1
    assert r.cycles_run < 1000
    # continuation from the steady state is immediately steady
    r2 = steady_state(sy, 0.8 * fn_rot(), r.state)
    assert r2.cycles_run <= SteadyStateOptions().min_cycles + SteadyStateOptions().chunk_cycles + 1
    # a cap that is too small is reported, not hidden
    r3 = steady_state(sy, 0.8 * fn_rot(), options=SteadyStateOptions(max_cycles=3, min_cycles=1, chunk_cycles=1))
    assert not r3.converged and r3.status == "cap"


def test_two_dof_and_stiff_four_dof_agree():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    p2 = synthetic_28t_parameters(tab)
    p4 = synthetic_28t_parameters(tab, bearing_stiffness_N_per_m=1e11)
    for fm in (1200.0, 2000.0):
        r2 = steady_state(SpurPairSystem(p2, tab), fm)
        r4 = steady_state(SpurPairSystem(p4, tab), fm)
        for k in ("rms_deflection_m", "mean_deflection_m", "peak_force_N"):
            assert r4.metrics[k] == pytest.approx(r2.metrics[k], rel=0.01), k


def test_four_dof_translation_mode_closed_form():
    tab = linear_fdf_table(K)
    ky = 200e6
    p = params(mass_kg=(1.7, 1.7), bearing_stiffness_N_per_m=(ky, ky))
    f = modal_analysis(SpurPairSystem(p, tab)).natural_frequencies_Hz
    # both gears translating together (y1 = y2) do not strain the mesh: sqrt(k_y / m)
    assert np.min(np.abs(f - math.sqrt(ky / 1.7) / (2 * math.pi))) < 1e-6 * f.max()
    assert f.size == 3


def test_conventional_laws_equal_hac_for_constant_stiffness():
    tab = linear_fdf_table(K)
    res = {}
    for law in ("hac", "ste", "average_slope", "local_slope"):
        sy = SpurPairSystem(params(), tab, law)
        assert sy.law.mean_stiffness_N_per_m == pytest.approx(K, rel=1e-9)
        s = sy.static_state(0.0)
        s[sy.n + sy.ith1] += 0.2
        kin = np.array([0.0, 0.0, 300.0])
        sy.integrate(s, kin, 5000, 2e-6, sy.fext_speed())
        res[law] = s
    for law in ("ste", "average_slope", "local_slope"):
        np.testing.assert_allclose(res[law], res["hac"], rtol=1e-9, atol=1e-15)


def test_conventional_laws_differ_on_nonlinear_table():
    tab = spur_fdf_table(tip_relief_m=30e-6)
    p = synthetic_28t_parameters(tab)
    ks = {law: SpurPairSystem(p, tab, law).law.mean_stiffness_N_per_m for law in ("hac", "ste", "local_slope")}
    assert ks["hac"] == ks["local_slope"]
    assert ks["ste"] < ks["local_slope"]  # secant (average slope) below the local slope with tip relief


# ---------------------------------------------------------------- sweeps, jumps, resume
def _softening():
    xs = 100.0 / RB / K
    tab = linear_fdf_table(K, offset_amplitude_m=0.2 * xs, x_max_m=6 * xs)
    p = params(modal_damping_ratio=0.03, torque_Nm=100.0)
    return p, tab


def test_jump_up_and_down_detected_on_softening_fdf():
    p, tab = _softening()
    fn = fn_rot()
    fm = np.linspace(0.6 * fn, 1.2 * fn, 25)
    r = run_sweep(SweepSpec(p, tab, tuple(fm), "both"), progress=False)
    conf = [j for j in r.jumps if j.confirmed]
    kinds = sorted((j.kind, j.branch) for j in conf)
    assert kinds == [("jump-down", "down"), ("jump-up", "up")]
    ju = next(j for j in conf if j.kind == "jump-up").frequency_Hz
    jd = next(j for j in conf if j.kind == "jump-down").frequency_Hz
    assert jd < ju < fn  # softening: multi-valued region below the linear natural frequency
    up, down = r.branches["up"], r.branches["down"]
    assert np.all(up.converged) and np.all(down.converged)
    # inside the multi-valued region the down sweep is on the large-amplitude branch with contact loss
    f_mid = up.mesh_frequency_Hz[(up.mesh_frequency_Hz > jd) & (up.mesh_frequency_Hz < ju)]
    assert f_mid.size >= 1
    i_up = np.searchsorted(up.mesh_frequency_Hz, f_mid[0])
    i_dn = list(down.mesh_frequency_Hz).index(f_mid[0])
    assert down.metrics["rms_deflection_m"][i_dn] > 1.5 * up.metrics["rms_deflection_m"][i_up]
    assert down.metrics["contact_loss_fraction"][i_dn] > 0


def test_detect_jumps_ignores_monotone_and_flags_unconfirmed():
    from hacgear_core.dynamics.sweep import BranchResult

    f = np.arange(5.0)
    b = BranchResult("up", f, {"rms_deflection_m": np.array([1.0, 1.1, 1.2, 1.3, 1.4])}, *[None] * 4)
    assert detect_jumps({"up": b}) == []
    b2 = BranchResult("up", f, {"rms_deflection_m": np.array([1.0, 1.0, 3.0, 3.0, 3.0])}, *[None] * 4)
    j = detect_jumps({"up": b2})
    assert len(j) == 1 and j[0].kind == "jump-up" and not j[0].confirmed and j[0].interval_Hz == (1.0, 2.0)


def test_resume_of_interrupted_sweep_is_identical(tmp_path, monkeypatch):
    import hacgear_core.dynamics.sweep as sw

    p, tab = _softening()
    fm = tuple(np.linspace(0.7 * fn_rot(), 1.0 * fn_rot(), 8))
    spec = SweepSpec(p, tab, fm, "up")
    ref = run_sweep(spec, out=tmp_path / "ref.h5", progress=False).branches["up"]
    real = sw.steady_state
    calls = {"n": 0}

    def dying(*a, **k):
        calls["n"] += 1
        if calls["n"] > 3:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(sw, "steady_state", dying)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(spec, out=tmp_path / "res.h5", progress=False)
    monkeypatch.setattr(sw, "steady_state", real)
    # a kill in the middle of writing a row leaves uncommitted data beyond attrs["rows"]: dropped
    import h5py

    part = next((tmp_path / "res.h5.parts").glob("*.h5"))
    with h5py.File(part, "a") as f:
        assert f.attrs["rows"] == 3
        for name in f.keys():
            f[name].resize(4, axis=0)
        f["rms_deflection_m"][3] = 123.0
    res = run_sweep(spec, out=tmp_path / "res.h5", progress=False).branches["up"]
    assert res.recomputed == 5
    for k in ref.metrics:
        np.testing.assert_array_equal(res.metrics[k], ref.metrics[k])
    np.testing.assert_array_equal(res.state, ref.state)
    again = run_sweep(spec, out=tmp_path / "res.h5", progress=False).branches["up"]
    assert again.recomputed == 0
    assert not (tmp_path / "res.h5.parts").exists()
    # an unreadable part file (killed while the file itself was being written) is moved aside
    parts = tmp_path / "bad.h5.parts"
    parts.mkdir()
    (parts / f"{spec.run_id()}_up.h5").write_bytes(b"not hdf5")
    with pytest.warns(RuntimeWarning, match="unreadable"):
        bad = run_sweep(spec, out=tmp_path / "bad.h5", progress=False).branches["up"]
    assert bad.recomputed == 8
    np.testing.assert_array_equal(bad.metrics["rms_deflection_m"], ref.metrics["rms_deflection_m"])


def test_sweeps_in_parallel_through_an_executor(tmp_path):
    from concurrent.futures import ThreadPoolExecutor

    p, tab = _softening()
    fm = tuple(np.linspace(0.7 * fn_rot(), 1.0 * fn_rot(), 4))
    specs = [SweepSpec(p, tab, fm, "both", torque_Nm=t) for t in (80.0, 120.0)]
    with ThreadPoolExecutor(2) as ex:
        par = sw_run(specs, tmp_path / "p.h5", ex)
    ser = sw_run(specs, None, None)
    for a, b in zip(par, ser):
        assert a.spec.params.torque_Nm in (80.0, 120.0)
        for br in ("up", "down"):
            np.testing.assert_array_equal(a.branches[br].metrics["rms_deflection_m"],
                                          b.branches[br].metrics["rms_deflection_m"])


def sw_run(specs, out, ex):
    from hacgear_core.dynamics.sweep import run_sweeps

    return run_sweeps(specs, out=out, executor=ex, progress=False)


# ---------------------------------------------------------------- simulator (FMU object)
def test_torque_mode_matches_speed_mode_and_conserves_momentum():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    p = synthetic_28t_parameters(tab)
    a = SpurPairSimulator(p, tab)
    b = SpurPairSimulator(p, tab)
    w = 1500.0 / a.system.z1_2pi
    a.set_speed_input(speed_rad_s=w)
    b.reset(speed_rad_s=w)
    rb1, rb2 = p.base_radius_m
    b.set_torque_inputs(p.torque_Nm, -p.torque_Nm * rb2 / rb1)
    for dt in (1e-4, 3.7e-4, 2e-3):
        assert a.advance(dt).success and b.advance(dt).success
    assert b.mesh_deflection_m == pytest.approx(a.mesh_deflection_m, rel=1e-6)
    assert b.speed1_rad_s == pytest.approx(a.speed1_rad_s, rel=1e-8)
    assert b.angle1_rad == pytest.approx(a.angle1_rad, rel=1e-9)
    # net torque: I1 dw1 + (rb1/rb2) I2 dw2 = (T1 + (rb1/rb2) T2) t  (linear invariant: exact in RK4)
    c = SpurPairSimulator(p, tab)
    c.reset(speed_rad_s=w)
    c.set_torque_inputs(400.0, -250.0)
    w1, w2, t0 = c.speed1_rad_s, c.speed2_rad_s, c.time_s
    for _ in range(20):
        assert c.advance(1e-3).success
    ratio = rb1 / rb2
    lhs = p.inertia_kg_m2[0] * (c.speed1_rad_s - w1) + ratio * p.inertia_kg_m2[1] * (c.speed2_rad_s - w2)
    assert lhs == pytest.approx((400.0 - ratio * 250.0) * (c.time_s - t0), rel=1e-9)
    assert c.speed1_rad_s > w1


def test_simulator_rejects_bad_input_without_changing_state():
    tab = linear_fdf_table(K)
    sim = SpurPairSimulator(params(), tab)
    s0 = sim.s.copy()
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        r = sim.advance(bad)
        assert not r.success and "dt" in r.message
    np.testing.assert_array_equal(sim.s, s0)
    with pytest.raises(ModelError, match="torque"):
        sim.set_torque_inputs(float("nan"), 0.0)
    with pytest.raises(ModelError, match="speed"):
        sim.set_speed_input(speed_rad_s=float("nan"))
    r = sim.advance(1e-3)
    assert r.success and r.n_substeps >= 1
    assert sim.in_contact and sim.mesh_force_N > 0
    assert sim.bearing_force_N == pytest.approx((-sim.mesh_force_N, sim.mesh_force_N))


@pytest.mark.parametrize("field,value,match", [
    ("mass_kg", (-1.0, 1.0), "mass_kg \\[kg\\]"),
    ("inertia_kg_m2", (0.01, float("nan")), "inertia_kg_m2"),
    ("teeth", (28, 2.5), "teeth"),
    ("bearing_stiffness_N_per_m", (0.0, 1e8), "bearing_stiffness_N_per_m \\[N/m\\]"),
    ("modal_damping_ratio", 1.5, "modal_damping_ratio"),
    ("torque_Nm", 0.0, "torque_Nm \\[N\\*m\\]"),
])
def test_parameters_validated_with_field_unit_range(field, value, match):
    with pytest.raises(ModelError, match=match):
        params(**{field: value})


def test_table_teeth_mismatch_is_reported():
    with pytest.raises(ModelError, match="teeth"):
        SpurPairSystem(params(teeth=(28, 30)), linear_fdf_table(K))


# ---------------------------------------------------------------- synthetic 28-tooth pair (labelled synthetic)
def test_synthetic_28t_impulse_test_brackets_and_weights():
    tab = spur_fdf_table(tip_relief_m=20e-6, contact_ratio=1.45)
    sy = SpurPairSystem(synthetic_28t_parameters(tab), tab)
    ps, pd, eps = contact_positions(sy)
    assert eps == pytest.approx(1.45, abs=2.0 / tab.position.size + 0.03)
    it = impulse_test(sy)
    fs_, fd_ = it.single_contact_Hz[0], it.double_contact_Hz[0]
    assert fs_ < fd_
    assert it.weighted_mean_Hz[0] == pytest.approx((2 - eps) * fs_ + (eps - 1) * fd_)
    # magnitude check only (synthetic table, mean stiffness 150 N/um): dissertation HAC 2775 Hz
    assert 2000 < it.weighted_mean_Hz[0] < 3500


# ---------------------------------------------------------------- model adapter, simulator outputs, CLI
def test_from_model_maps_the_28_tooth_model():
    from pathlib import Path

    from hacgear_core.dynamics.spur import from_model
    from hacgear_core.model import load_model

    path = Path(__file__).resolve().parents[1] / "models" / "spur_28t_asym" / "model.toml"
    if not path.exists():
        pytest.skip("model file not present")
    p = from_model(load_model(path))
    rb = 0.5 * 5e-3 * 28 * math.cos(math.radians(25.0))  # the 25 deg flank is loaded
    assert p.base_radius_m == pytest.approx((rb, rb), rel=1e-12)
    assert p.teeth == (28, 28)
    assert p.torque_Nm == 300.0 and p.modal_damping_ratio == 0.02
    assert p.rigid_supports and p.rotational_stiffness_Nm_per_rad == (0.0, 0.0)
    # blank: the generated gear (annulus 40..126.4 mm plus the real teeth), as `hacgear info` reports;
    # the teeth fill roughly half of the tooth ring
    from hacgear_core.geometry import gear_geometry

    gg = gear_geometry(load_model(path).gear("pinion"))
    assert p.mass_kg == (gg.mass_kg, gg.mass_kg) and p.inertia_kg_m2 == (gg.inertia_kgm2, gg.inertia_kgm2)
    m_disk = 7850 * math.pi / 4 * (0.1264**2 - 0.04**2) * 0.015
    m_ring = 7850 * math.pi / 4 * (0.1499**2 - 0.1264**2) * 0.015
    assert m_disk + 0.3 * m_ring < p.mass_kg[0] < m_disk + 0.7 * m_ring
    # a webbed blank reaches the lumped model: the web annulus (60..110 mm) loses (1 - 8/15) of its mass
    import dataclasses

    from hacgear_core.model import Web

    base = load_model(path)
    web = Web(8e-3, 0.060, 0.110)
    pw = from_model(dataclasses.replace(base, gears=tuple(dataclasses.replace(g, web=web) for g in base.gears)))
    dm = 7850 * math.pi / 4 * (0.110**2 - 0.060**2) * (0.015 - 0.008)
    dj = 7850 * math.pi / 32 * (0.110**4 - 0.060**4) * (0.015 - 0.008)
    assert pw.mass_kg[0] == pytest.approx(p.mass_kg[0] - dm, rel=1e-9)
    assert pw.inertia_kg_m2[1] == pytest.approx(p.inertia_kg_m2[1] - dj, rel=1e-9)


def test_simulator_post_processed_outputs():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    sim = SpurPairSimulator(synthetic_28t_parameters(tab), tab)
    sim.set_speed_input(mesh_frequency_Hz=1000.0)
    strains, press = [], []
    for _ in range(3 * 28 * 8):  # three revolutions of gear 2, 8 samples per mesh cycle
        assert sim.advance(1.0 / 8000.0).success
        strains.append(sim.strain("wheel/SG"))
        press.append(sim.peak_pressure_Pa)
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
        sim.strain("nope")


def _cli(argv, capsys):
    import json

    from hacgear_core.cli import main

    rc = main(argv)
    out = capsys.readouterr().out
    return rc, (json.loads(out) if "--json" in argv and rc == 0 else out)


def test_cli_modes_and_sweep_json(capsys, tmp_path):
    rc, d = _cli(["modes", "synthetic:28t", "--torque", "300", "--json", "--no-impulse"], capsys)
    assert rc == 0 and d["synthetic_table"] is True
    f = d["natural_frequencies_Hz"]
    assert f == sorted(f) and len(f) == 1 and 2000 < f[0] < 3500
    assert d["bearing_stiffness_N_per_m"] == ["inf", "inf"]
    rc, d = _cli(["modes", "synthetic:28t", "--torque", "300", "--json", "--no-impulse",
                  "--bearing-stiffness", "200e6"], capsys)
    assert len(d["natural_frequencies_Hz"]) == 3 and len(d["mode_shapes"]["shapes"][0]) == 4
    out = str(tmp_path / "r.h5")
    rc, d = _cli(["sweep", "synthetic:28t", "--torque", "100", "--fm", "1500:2500:3", "--direction", "up",
                  "--json", "--no-progress", "--out", out], capsys)
    assert rc == 0 and d["computed_speeds"] == {"up": 3}
    assert d["branches"]["up"]["mesh_frequency_Hz"] == [1500.0, 2000.0, 2500.0]
    rc, d = _cli(["sweep", "synthetic:28t", "--torque", "100", "--fm", "1500:2500:3", "--direction", "up",
                  "--json", "--no-progress", "--out", out], capsys)
    assert d["computed_speeds"] == {"up": 0}


def test_cli_user_errors_are_reported_without_traceback(capsys):
    from hacgear_core.cli import main

    assert main(["sweep", "synthetic:28t", "--torque", "100", "--fm", "1:x:2"]) == 2
    assert "START:STOP:N" in capsys.readouterr().err
    assert main(["modes", "synthetic:29t", "--torque", "100"]) == 2
    assert "synthetic:28t" in capsys.readouterr().err
    assert main(["modes", "synthetic:28t", "--torque", "-5"]) == 2
    assert "torque_Nm [N*m]" in capsys.readouterr().err


def test_simulator_state_snapshot_restores_exactly():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    sim = SpurPairSimulator(synthetic_28t_parameters(tab), tab)
    sim.set_speed_input(mesh_frequency_Hz=1800.0)
    sim.advance(3e-3)
    snap = sim.get_state()
    sim.advance(2e-3)
    x1, a1 = sim.mesh_deflection_m, sim.angle1_rad
    sim.set_torque_inputs(500.0, -100.0)
    sim.advance(1e-3)
    sim.set_state(snap)
    assert sim.mode == "speed"
    sim.advance(2e-3)
    assert sim.mesh_deflection_m == x1 and sim.angle1_rad == a1


def test_long_runs_keep_precision():
    """The reference rotation is (integer cycles, fraction): after 1e12 mesh cycles the dynamics
    are bit-identical to those at cycle 0 (an absolute angle in float64 would have lost the mesh
    position entirely by then)."""
    tab = spur_fdf_table(tip_relief_m=20e-6)
    sy = SpurPairSystem(synthetic_28t_parameters(tab), tab)
    out = []
    for cycles0 in (0.0, 1e12):
        s = sy.static_state(0.0)
        kin = np.array([0.25, cycles0, 1500.0 / sy.z1_2pi])
        sy.integrate(s, kin, 128 * 50, 1.0 / (1500.0 * 128), sy.fext_speed())
        out.append((s.copy(), kin[0], kin[1] - cycles0))
    np.testing.assert_array_equal(out[0][0], out[1][0])
    assert out[0][1] == out[1][1] and out[0][2] == out[1][2] == 50.0


def test_cli_refuses_a_table_of_another_model_unless_overridden(tmp_path, capsys):
    """A table made from another model file is refused with the regenerate command; the expert override
    uses a table of an edited model file, but a table of a different gear pair stays refused."""
    import shutil
    from pathlib import Path

    from hacgear_core.cli import main

    root = Path(__file__).resolve().parents[1] / "models"
    other = str(root / "spur_50t_icr137" / "tables.h5")
    assert main(["modes", "spur_28t_asym", "--torque", "300", "--tables", other]) == 2
    err = capsys.readouterr().err
    assert "does not belong to" in err and "hacgear statics" in err and "Traceback" not in err
    assert main(["modes", "spur_28t_asym", "--torque", "300", "--tables", other, "--ignore-model-hash"]) == 2
    assert "teeth (28, 28) do not match the table's teeth (50, 50)" in capsys.readouterr().err
    edited = tmp_path / "model.toml"
    edited.write_text((root / "spur_28t_asym" / "model.toml").read_text().replace(
        "modal_damping_ratio = 0.02", "modal_damping_ratio = 0.03"))
    shutil.copy(root / "spur_28t_asym" / "tables.h5", tmp_path / "tables.h5")
    assert main(["modes", str(edited), "--torque", "300"]) == 2
    capsys.readouterr()
    assert main(["modes", str(edited), "--torque", "300", "--ignore-model-hash", "--json"]) == 0
