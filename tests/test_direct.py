"""Level-1 direct model (hacgear_core.studies.direct): its integrator is the HAC equations, its force law is the
static solver (= the tables at their nodes), and a short dynamic run agrees with HAC; the long comparison is slow."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hacgear_core.studies import direct as D
from hacgear_core.kinds import build_system
from hacgear_core.studies.direct_compare import compare_at_speed, hac_root_strain, loaded_gauge
from hacgear_core.dynamics.steady import steady_state
from hacgear_core.errors import ModelError
from hacgear_core.kinds import load_model
from hacgear_core.tables import load_system_tables

MODELS = Path(__file__).resolve().parent.parent / "models"


def _pair(name):
    mp = MODELS / name / "model.toml"
    model = load_model(mp)
    return model, build_system(model, load_system_tables(mp))


@pytest.fixture(scope="module")
def pair50():
    model, system = _pair("spur_50t_icr137")
    drive, coast = D.level1_mesh_forces(model, system)
    return model, system, drive, coast


def _table_fn(system, k=0):
    """The HAC force law of mesh k as a MeshForceFn (the tables' bilinear rule)."""
    return lambda tau, x: (float(system.mesh_force(k, tau, x)), None)


def test_integrator_is_the_hac_kernel_for_the_table_force_law(pair50):
    """integrate_direct with the table's force law as the callable reproduces the compiled HAC kernel step for step
    (same equations, same RK4): the direct model differs from HAC only by its force law."""
    _, system, _, _ = pair50
    fn = float(system.natural_frequencies_Hz()[0])
    fm = 0.9 * fn
    nsp = 64
    h = 1.0 / (fm * nsp)
    res = steady_state(system, fm)
    s0 = res.state.copy()
    eqs = D.DirectEquations.from_system(system)
    load = D.contact_load(eqs, [_table_fn(system)])
    s1, tau, tr = D.integrate_direct(eqs, load, s0, mesh_frequency_Hz=fm, n_steps=3 * nsp, h=h)
    s2 = s0.copy()
    kin = np.array([0.0, 0.0, system.reference_speed(fm)])
    system.integrate(s2, kin, 3 * nsp, h, system.fext_speed())
    x1, x2 = system.V @ s1[:system.n], system.V @ s2[:system.n]
    assert abs(x1 - x2).max() < 1e-9 * abs(x2).max()
    assert np.allclose(s1[system.n:], s2[system.n:], rtol=0, atol=1e-9 * np.abs(s2[system.n:]).max())
    assert tau == pytest.approx(3.0, abs=1e-12)
    assert tr.load_calls == 4 * 3 * nsp and tr.steps == 3 * nsp
    # at 0.9 f_n the orbit loses contact for part of each cycle: the agreement holds across contact loss
    assert tr.mesh_force_N.shape == (3 * nsp, 1)
    assert np.any(tr.mesh_force_N == 0) and np.any(tr.mesh_force_N > 0)


def test_level1_force_is_the_solver_and_the_table_at_grid_nodes(pair50):
    """Static limit: level 1's force at a table node equals the table (built by the same solver) to the solver's
    convergence; between nodes it differs by the interpolation error only (< 0.5 % at mid-cell here)."""
    _, system, drive, _ = pair50
    tab = system.meshes[0].table
    f = drive[0]
    for ip, jd in ((0, 30), (7, 45), (33, 20)):
        val, st = f(float(tab.position[ip]), float(tab.deflection_m[jd]))
        assert st.success
        assert val == pytest.approx(float(tab.force_N[ip, jd]), rel=1e-8)
        assert val == pytest.approx(f.solver.state_deflection(float(tab.position[ip]),
                                                              float(tab.deflection_m[jd])).mesh_force_N, rel=1e-8)
    p = 0.5 * float(tab.position[3] + tab.position[4])
    x = 0.5 * float(tab.deflection_m[30] + tab.deflection_m[31])
    val, _ = f(p, x)
    assert 0 < abs(val / float(tab.force(p, x)) - 1.0) < 5e-3


def test_level1_quasi_static_run_tracks_the_static_solver(pair50):
    """Static limit: at a very low mesh frequency (1 Hz) the level-1 model started at the static solver's
    load-controlled state (nominal force) stays on it: along 24 steps of 5 us the mesh force is the nominal static
    force and the mesh deflection the solver's static deflection at the current position (load control)."""
    _, system, drive, coast = pair50
    solver = drive[0].solver
    fs = float(system.nominal_forces_N()[0])
    eqs = D.DirectEquations.from_system(system)
    q0 = system.preload_state()
    v = system.V[0]
    tau0 = float(system.phase[0] + system.W[0] @ q0)
    x0 = solver.state_load(tau0, fs).mesh_deflection_m
    q0 = q0 + (x0 - v @ q0) * v / (v @ v)                   # v is a pure rotation: tau moves by 1e-6 cycles
    load = D.contact_load(eqs, drive, coast)
    s, _, tr = D.integrate_direct(eqs, load, np.concatenate([q0, np.zeros(system.n)]), mesh_frequency_Hz=1.0,
                                  n_steps=24, h=5e-6)
    assert np.allclose(tr.mesh_force_N[:, 0], fs, rtol=1e-4)
    xs = np.array([solver.state_load(float(p), fs).mesh_deflection_m for p in tr.mesh_position[::8, 0]])
    assert np.allclose(tr.mesh_deflection_m[::8, 0], xs, rtol=1e-5)
    assert np.all(tr.coast_force_N == 0.0)


def test_coast_callable_skips_the_solve_below_the_backlash(pair50):
    _, _, _, coast = pair50
    c = coast[0]
    n0 = c.calls
    assert c(0.25, 0.5 * c.backlash_m) == (0.0, None)
    assert c.calls == n0


def test_short_dynamic_run_agrees_with_hac(pair50):
    """One mesh cycle of level 1 from the HAC steady state at 0.6 f_n (32 RK4 steps per cycle: reduced, the same
    step for both) stays on the HAC orbit: RMS DTE within 1 % and the largest root strain within 2 %."""
    model, system, drive, coast = pair50
    fn = float(system.natural_frequencies_Hz()[0])
    fm = 0.6 * fn
    nsp = 32
    h = 1.0 / (fm * nsp)
    res = steady_state(system, fm, options=None)
    s = res.state.copy()
    kin = np.array([0.0, 0.0, system.reference_speed(fm)])
    for _ in range(200):                                     # HAC's own orbit at this step
        kin[:] = (0.0, 0.0, system.reference_speed(fm))
        system.integrate(s, kin, nsp, h, system.fext_speed())
    eqs = D.DirectEquations.from_system(system)
    load = D.contact_load(eqs, drive, coast)
    _, _, tr1 = D.integrate_direct(eqs, load, s, mesh_frequency_Hz=fm, n_steps=nsp, h=h, keep_extra=True)
    _, _, trh = D.integrate_direct(eqs, D.contact_load(eqs, [_table_fn(system)]), s, mesh_frequency_Hz=fm,
                                   n_steps=nsp, h=h)
    d1 = tr1.dynamic_transmission_error_m[:, 0]
    dh = trh.dynamic_transmission_error_m[:, 0]
    rms1, rmsh = np.std(d1), np.std(dh)
    assert rmsh > 1e-6                                       # a real oscillation (m)
    assert abs(rmsh / rms1 - 1) < 0.01
    gauge = loaded_gauge(system)
    eps1 = D.solver_root_strain(drive[0].solver, [e[0][0] for e in tr1.extra], gauge).max()
    epsh = hac_root_strain(system.meshes[0].table, gauge, trh.mesh_position[:, 0],
                           trh.mesh_deflection_m[:, 0]).max()
    assert eps1 > 1e-4 and abs(epsh / eps1 - 1) < 0.02


def test_inputs_are_validated(pair50):
    _, system, _, _ = pair50
    eqs = D.DirectEquations.from_system(system)
    with pytest.raises(ModelError, match="fext"):
        D.DirectEquations(**{**eqs.__dict__, "fext": np.zeros(system.n + 1)})
    with pytest.raises(ModelError, match="mesh_frequency_Hz"):
        D.integrate_direct(eqs, D.contact_load(eqs, [_table_fn(system)]), np.zeros(2 * system.n),
                           mesh_frequency_Hz=-1.0, n_steps=1, h=1e-5)
    with pytest.raises(ModelError, match="rtol"):
        D.Level1Options(rtol=0.0)
    with pytest.raises(ModelError, match="one drive"):
        D.contact_load(eqs, [])


@pytest.mark.slow
@pytest.mark.parametrize("name, ratio", [("spur_28t_asym", 1.0), ("spur_50t_icr137", 1.0)])
def test_level1_and_hac_agree_at_the_resonance_with_contact_loss(name, ratio):
    """Issue #18 criterion at the hardest speed (resonance with contact loss): RMS DTE within 1 %, peak root strain
    within 2 %, level 1 converged, speed ratio >= 1e4 (benchmarks/bench_hac_vs_direct.py runs all speeds)."""
    model, system = _pair(name)
    c = compare_at_speed(model, system, ratio * float(system.natural_frequencies_Hz()[0]),
                         options=D.Level1Options(rtol=1e-4, max_cycles=8), hac_cycles=500)
    assert c.success, c.message
    assert c.hac["contact_loss_fraction"] > 0 and c.level1["contact_loss_fraction"] > 0
    assert abs(c.errors["dte_rms_m"]) < 0.01
    assert abs(c.errors["max_root_strain"]) < 0.02
    assert c.speed_ratio >= 1e4
    assert math.isfinite(c.level1["wall_s_per_cycle"])


@pytest.fixture(scope="module")
def superharmonic50():
    """The 50-tooth pair at its 1/2 super-harmonic resonance: HAC (committed tables) against level 1."""
    model, system = _pair("spur_50t_icr137")
    fm = 0.5 * float(system.natural_frequencies_Hz()[0])
    return model, system, fm, compare_at_speed(model, system, fm, options=D.Level1Options(rtol=1e-4, max_cycles=8),
                                               hac_cycles=200)


@pytest.mark.slow
def test_committed_tables_meet_the_criteria_at_the_superharmonic(superharmonic50):
    """The committed tables (256 positions x 64 deflections, the grid study's choice) are within 1 % of level 1 in
    RMS DTE and 2 % in peak root strain at the 1/2 super-harmonic resonance, the speed that decides the grid."""
    _, _, _, c = superharmonic50
    assert c.success, c.message
    assert abs(c.errors["dte_rms_m"]) < 0.01
    assert abs(c.errors["max_root_strain"]) < 0.02


@pytest.mark.slow
def test_64_positions_miss_1_percent_at_the_superharmonic(superharmonic50, tmp_path):
    """Why the committed grid has 256 positions: on 64 positions x 64 deflections (drive side, generated here with
    the statics grid) the position interpolation misses the second mesh harmonic that drives the 1/2 super-harmonic
    resonance, and RMS DTE is off by more than 1 % (grid study: -3.2 %)."""
    from hacgear_core.studies.direct_compare import hac_at_speed
    from hacgear_core.statics.grid import compute_statics
    from hacgear_core.tables import read_tables
    model, _, fm, c = superharmonic50
    mp = MODELS / "spur_50t_icr137" / "model.toml"
    out = tmp_path / "t64.h5"
    rep = compute_statics(mp, out, positions=64, deflections=64, sides=("drive",), workers=1, progress=False)
    assert rep.success, rep.message
    system = build_system(model, read_tables(out, mp))
    _, h, _ = hac_at_speed(system, fm, c.gauge)
    assert abs(h["dte_rms_m"] / c.level1["dte_rms_m"] - 1) > 0.01
    assert abs(c.errors["dte_rms_m"]) < 0.5 * abs(h["dte_rms_m"] / c.level1["dte_rms_m"] - 1)
