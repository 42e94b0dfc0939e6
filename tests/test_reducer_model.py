"""The two-stage reducer 19:71 | 23:83 (models/reducer_19_71_23_83; issue #52 item 1): stages with unequal tooth
counts in one gear_train, each mesh at its own mesh frequency.  Rates and the system period from the teeth, the
static shaft and output torques equal the ratios times the input torque, the modes equal an eigen-solution of M
and K written here, and a sweep over the input mesh frequency peaks where each stage's mesh frequency (or a
harmonic) meets a mode."""
from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest
import scipy.linalg

from _fmu_runs import fmu_and_library_runs
from hacgear_core.cli import main
from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.dynamics.steady import steady_state
from hacgear_core.kinds import build_system, load_model
from hacgear_core.model import resolve_model_path
from hacgear_core.tables import load_system_tables

SYSTEM = "reducer_19_71_23_83"
RATE_2 = Fraction(19, 71) * 23 / 19   # stage 2's mesh frequency over stage 1's: (z_p1 / z_w1) z_p2 / z_p1


@pytest.fixture(scope="module")
def system():
    path = resolve_model_path(SYSTEM)
    return build_system(load_model(path), load_system_tables(path))


def test_each_stage_meshes_at_its_own_rate_and_the_system_repeats_after_71_cycles(system):
    assert RATE_2 == Fraction(23, 71)
    np.testing.assert_array_equal(system.rate, [[1, 1], [23, 71]])
    assert system.period_cycles == 71 and not system.unit_rates
    # overall speed ratio from the kinematic speeds of the assembled system: (19/71) (23/83) exactly (rounding)
    sp = {g: system.gears[g].speed_ratio for g in ("pinion1", "wheel1", "pinion2", "wheel2")}
    assert abs(sp["wheel2"] / sp["pinion1"]) == pytest.approx(float(Fraction(19, 71) * Fraction(23, 83)), rel=1e-12)
    # the kinematic mesh positions: mesh 2 at 23/71 of the reference position, every mesh back at 0 after 71 cycles
    base, whole = system.mesh_kinematics(np.array([0.25, 0.0, 0.5]), np.array([0.0, 71.0, 1e6]))
    np.testing.assert_allclose(base[:, 1], [23 / 71 * 0.25, 0.0, (23 * (1e6 + 0.5) / 71) % 1.0], atol=1e-12)
    np.testing.assert_array_equal(whole[:, 1], [0.0, 23.0, float((23 * 10**6) // 71)])


@pytest.mark.parametrize("tau_ref", [0.0, 0.37, 12.5, 70.9])
def test_static_torques_are_the_input_torque_times_the_stage_ratios(system, tau_ref):
    """At any reference position over the 71-cycle period: the intermediate shaft twists by 200 (71/19) N m over
    its stiffness, the meshes carry their nominal forces and the output brake takes 200 (71/19) (83/23) N m."""
    eq = static_equilibrium(system, tau_ref)
    assert eq.success
    np.testing.assert_allclose(eq.mesh_forces_N, system.nominal_forces_N(), rtol=1e-9)
    i_w1, i_p2 = system.gears["wheel1"].rotation, system.gears["pinion2"].rotation
    k_shaft = 1.34e5   # model.toml, shaft2
    sense = system.gears["wheel1"].sense
    assert sense == system.gears["pinion2"].sense
    assert sense * k_shaft * (eq.q[i_w1] - eq.q[i_p2]) == pytest.approx(200.0 * 71 / 19, rel=1e-9)
    fe = system.fext_speed()
    assert abs(fe[system.gears["wheel2"].rotation]) == pytest.approx(200.0 * 71 / 19 * 83 / 23, rel=1e-9)


def test_modes_equal_the_eigen_solution_of_m_and_k_written_here(system):
    """DOFs per gear: translation u along its mesh's line of action (bearing k_b = 2e9 N/m) and rotation theta in
    its own sense of rotation; mesh deflections x_1 = u_p1 + r_p1 th_p1 - u_w1 - r_w1 th_w1 (likewise stage 2, the
    u signs are free: each u is in one mesh and its own bearing), the shaft k_s (th_w1 - th_p2)^2 / 2, the meshes at
    the system's linearised stiffness."""
    g = system.gears
    names = ["pinion1", "wheel1", "pinion2", "wheel2"]
    mass = [g[n].mass_kg for n in names]
    inertia = [g[n].inertia_kgm2 for n in names]
    rb = {c.gear_a: c.base_radius_m[0] for c in system.meshes} | {c.gear_b: c.base_radius_m[1] for c in system.meshes}
    for n, z, m in (("pinion1", 19, 3e-3), ("wheel1", 71, 3e-3), ("pinion2", 23, 4e-3), ("wheel2", 83, 4e-3)):
        assert rb[n] == pytest.approx(z * m * math.cos(math.radians(20.0)) / 2, rel=1e-12)
    # q = [u_p1, th_p1, u_w1, th_w1, u_p2, th_p2, u_w2, th_w2]
    M = np.diag([mass[0], inertia[0], mass[1], inertia[1], mass[2], inertia[2], mass[3], inertia[3]])
    K = np.zeros((8, 8))
    for i in (0, 2, 4, 6):
        K[i, i] += 2.0e9
    km = system.mesh_stiffness_N_per_m
    for k, (a, b) in enumerate(((0, 2), (4, 6))):
        v = np.zeros(8)
        v[[a, a + 1, b, b + 1]] = [1.0, rb[names[a // 2]], -1.0, -rb[names[b // 2]]]
        K += km[k] * np.outer(v, v)
    e = np.zeros(8)
    e[[3, 5]] = [1.0, -1.0]
    K += 1.34e5 * np.outer(e, e)
    w2 = scipy.linalg.eigh(K, M, eigvals_only=True)
    f = np.sqrt(np.clip(w2[1:], 0, None)) / (2 * math.pi)   # the first: the rigid rotation of the train
    assert abs(w2[0]) < 1e-6 * w2[1]
    np.testing.assert_allclose(system.natural_frequencies_Hz(), f, rtol=1e-9)


def test_steady_state_spans_the_71_cycle_period(system):
    r = steady_state(system, 2000.0)
    assert r.converged and r.period_cycles == 71 and r.cycles_run % 71 == 0
    # the recorded period holds 71 cycles of mesh 1 and 23 of mesh 2
    assert r.metrics["peak_force_N"][1] > system.nominal_forces_N()[1]


@pytest.mark.parametrize("mesh, mode_Hz, harmonic, rate, fm", [
    # stage 1: the third mesh harmonic meets the 5342 Hz pinion-1 mode at f_1 = 5342 / 3 = 1781 Hz
    ("m12", 5341.8, 3, 1.0, "1700:1860:17"),
    # stage 2: its mesh frequency (23/71 of the input mesh frequency) meets the 388 Hz shaft mode at 1199 Hz
    ("m34", 388.38, 1, 23 / 71, "1120:1280:17"),
])
def test_sweep_peaks_where_a_stage_mesh_harmonic_meets_a_mode(system, capsys, mesh, mode_Hz, harmonic, rate, fm):
    """Each stage resonates where its own mesh frequency predicts, within 2 % (the contact softens the mesh below
    its linearised stiffness: the peaks sit 0.6-0.7 % low)."""
    assert np.min(np.abs(system.natural_frequencies_Hz() - mode_Hz)) < 0.05
    assert main(["sweep", SYSTEM, "--fm", fm, "--direction", "up", "--json", "--no-progress"]) == 0
    b = json.loads(capsys.readouterr().out)["branches"]["up"]
    f = np.array(b["mesh_frequency_Hz"])
    rms = np.array(b["meshes"][mesh]["dte_rms_m"])
    assert all(b["converged"]) and set(b["period_cycles"]) == {71}
    # each mesh reports its own mesh frequency: stage 2 at 23/71 of the input mesh frequency
    np.testing.assert_allclose(b["meshes"]["m34"]["mesh_frequency_Hz"], f * 23 / 71, rtol=1e-15)
    np.testing.assert_array_equal(b["meshes"]["m12"]["mesh_frequency_Hz"], f)
    peak = f[np.argmax(rms)]
    assert peak == pytest.approx(mode_Hz / (harmonic * rate), rel=0.02)
    assert rms.max() > 1.5 * max(rms[0], rms[-1])


def test_fmu_equals_the_library_with_stage_2_at_its_own_mesh_frequency(tmp_path):
    """The native FMI 2.0 FMU against the library's Simulator, step for step (1e-9): mesh forces, stage 2's mesh
    position (advancing at 23/71 of stage 1's: 647.9 cycles/s at a 2000 Hz input mesh frequency) and the shaft
    torque."""
    pytest.importorskip("fmpy")
    speed = 2 * math.pi * 2000.0 / 19          # pinion1 [rad/s] at a 2000 Hz stage-1 mesh frequency
    names = ["m12.force", "m34.force", "m12.position", "m34.position", "shaft2.torque"]

    def read(sim):
        i1, i2 = sim.gear_index("wheel1"), sim.gear_index("pinion2")
        return (sim.mesh_force_N[0], sim.mesh_force_N[1], sim.mesh_position[0], sim.mesh_position[1],
                1.34e5 * (sim.angle_rad[i1] - sim.angle_rad[i2]))
    _, res, lib = fmu_and_library_runs(SYSTEM, tmp_path, names, read, speed, 100)
    for k in names:
        v = np.asarray(lib[k])
        assert np.max(np.abs(res[k][1:] - v)) <= 1e-9 * np.max(np.abs(v)), k
    t = res["time"]
    rate = np.polyfit(t, res["m34.position"], 1)[0] / np.polyfit(t, res["m12.position"], 1)[0]
    assert rate == pytest.approx(23 / 71, rel=1e-4)   # the fit also sees the start-up vibration (w . q)
    assert np.mean(res["shaft2.torque"]) == pytest.approx(200.0 * 71 / 19, rel=0.01)


def test_root_strain_passages_follow_each_gear_in_its_own_mesh(capsys):
    """Gauges on wheel1 (stage 1, drive flank) and pinion2 (stage 2, the loaded coast flank): at a 40 Hz input
    mesh frequency (10x below the lowest mode) the recorded tooth passage equals the static one (dynamic factor
    1 within 1 %), the passage counted in the gear's own mesh cycles (pinion2: 5 stage-2 cycles, 17 reference
    cycles of record); both in tension on the loaded side."""
    assert main(["simulate", SYSTEM, "--fm", "40", "--cycles", "80", "--json"]) == 0
    rs = json.loads(capsys.readouterr().out)["root_strain"]
    for g in ("wheel1/SG", "pinion2/SG"):
        r = rs[g]
        assert r["recorded"] and r["factor_side"] == "tension", g
        assert r["dynamic_factor"] == pytest.approx(1.0, abs=0.01), g
        assert r["static_max"] > 100 * abs(r["static_min"]), g
    # the stage-2 passage lies within the last 80 reference cycles = 80 * 23/71 = 25.9 stage-2 cycles
    assert 0 < rs["pinion2/SG"]["mesh_cycles"][0] < rs["pinion2/SG"]["mesh_cycles"][1] <= 80 * 23 / 71
