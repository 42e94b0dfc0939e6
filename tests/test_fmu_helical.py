"""The helical FMU (the generic adapter on the 12-DOF helical pair): built from the shipped model and its generalized
tables, validated (fmpy validate, fmutool -check), equal to the library (mesh force, twist moment, deflection, twist,
contact state, radial and axial bearing forces and tilting moments, the five face strains) in both experiments, and
in a drivetrain bench (motor on the pinion, load on the wheel); reversed torques load the coast flanks (FMI 2.0 and
3.0) and a state beyond the tables is flagged and logged once; on a drive-only table (no coast side) the teeth
crossing the backlash are flagged and logged once."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")

from _bench import assert_final_hold  # noqa: E402
from _fmi_reset import assert_reset_equals_fresh  # noqa: E402
from hacgear_core.kinds import build_system  # noqa: E402
from hacgear_core.dynamics.simulator import Simulator  # noqa: E402
from hacgear_core.fmu.bench import BenchConfig, run_drivetrain_bench  # noqa: E402
from hacgear_core.kinds import load_model  # noqa: E402
from hacgear_core.tables import read_tables  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = "helical_28_33"
GAUGES = ("SG1", "SG2", "SG3", "SG4", "SG5")


def _build_fmu():
    """The repository's build_fmu script as a module."""
    sys.path.insert(0, str(ROOT))
    try:
        import build_fmu
    finally:
        sys.path.remove(str(ROOT))
    return build_fmu


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    out = tmp_path_factory.mktemp("hfmu")
    build_fmu = _build_fmu()
    assert build_fmu.main(["--system", SYSTEM, "--out", str(out), "--fmi", "all"]) == 0
    return {"path": out / f"{SYSTEM}.fmu", "path3": out / f"{SYSTEM}_fmi3.fmu", "build_fmu": build_fmu}


def test_helical_fmu_validates_and_declares_the_helical_outputs(fmu):
    assert fmu["build_fmu"].validate_fmu(fmu["path"]) == []
    md = fmpy.read_model_description(str(fmu["path"]))
    names = {v.name: v for v in md.modelVariables}
    want = {"m12.force", "m12.twist_moment", "m12.deflection", "m12.twist", "m12.contact", "pinion.torque_in",
            "wheel.torque_in", "pinion.speed_in", "pinion.angle", "wheel.speed"}
    for g in ("pinion", "wheel"):
        want |= {f"{g}.bearing_force_{a}" for a in "xyz"} | {f"{g}.bearing_moment_{a}" for a in "xy"}
    want |= {f"wheel.{s}.root_strain" for s in GAUGES}
    assert want <= set(names)
    assert names["m12.twist_moment"].unit == "N.m" and names["m12.twist"].unit == "rad"


@pytest.mark.parametrize("mode", [0, 1])
def test_helical_fmu_equals_the_library(fmu, mode):
    """The FMU's outputs equal the library's Simulator (same parameters and inputs) within 1e-9 over 100
    communication steps, in the constant-speed experiment and in drivetrain coupling."""
    m = load_model(SYSTEM)
    tabs = read_tables(m.tables_path, m.path)
    sim = Simulator(build_system(m, tabs, shafts=mode == 0))
    start = {"mode": mode}
    w = 2 * math.pi * 1200.0 / 28                       # 1200 Hz mesh frequency
    if mode == 0:
        start["pinion.speed_in"] = w
        sim.set_speed_input(speed_rad_s=w)
    else:
        start.update({"pinion.speed_start": w, "pinion.torque_in": 200.0, "wheel.torque_in": -220.0})
        sim.reset(speed_rad_s=w)
        sim.set_torque_inputs({"pinion": 200.0, "wheel": -220.0})
    out = ["m12.force", "m12.twist_moment", "m12.deflection", "m12.twist", "m12.contact", "pinion.speed",
           "wheel.angle", "pinion.bearing_force_x", "wheel.bearing_force_y", "wheel.bearing_force_z",
           "pinion.bearing_moment_x", "wheel.bearing_moment_y"] + [f"wheel.{s}.root_strain" for s in GAUGES]
    res = fmpy.simulate_fmu(str(fmu["path"]), stop_time=0.01, output_interval=1e-4, start_values=start, output=out)
    for k in range(1, 101):
        assert sim.advance(1e-4).success
        r = res[k]
        assert r["m12.force"] == pytest.approx(sim.mesh_force_N[0], rel=1e-9)
        assert r["m12.twist_moment"] == pytest.approx(sim.twist_moment_Nm[0], rel=1e-9, abs=1e-12)
        assert r["m12.deflection"] == pytest.approx(sim.mesh_deflection_m[0], rel=1e-9)
        assert r["m12.twist"] == pytest.approx(sim.mesh_twist_rad[0], rel=1e-9, abs=1e-18)
        assert r["m12.contact"] == 1
        assert r["pinion.speed"] == pytest.approx(sim.speed_rad_s[0], rel=1e-9)
        assert r["wheel.angle"] == pytest.approx(sim.angle_rad[1], rel=1e-9)
        assert r["pinion.bearing_force_x"] == pytest.approx(sim.bearing_force_N("pinion")[0], rel=1e-9, abs=1e-9)
        assert r["wheel.bearing_force_y"] == pytest.approx(sim.bearing_force_N("wheel")[1], rel=1e-9, abs=1e-9)
        assert r["wheel.bearing_force_z"] == pytest.approx(sim.support_reaction("wheel.z"), rel=1e-9, abs=1e-9)
        assert r["pinion.bearing_moment_x"] == pytest.approx(sim.support_reaction("pinion.theta_x"), rel=1e-9,
                                                             abs=1e-12)
        assert r["wheel.bearing_moment_y"] == pytest.approx(sim.support_reaction("wheel.theta_y"), rel=1e-9,
                                                            abs=1e-12)
        for s in GAUGES:
            assert r[f"wheel.{s}.root_strain"] == pytest.approx(sim.strain(f"wheel/{s}"), rel=1e-9, abs=1e-15)


def test_helical_fmu_in_a_drivetrain_bench(fmu):
    """Motor on the pinion, brake on the wheel: the speeds follow the drive at the kinematic ratio 28/33, the
    output shaft carries the load, the mesh carries the static mesh force; the axial bearing force balances the
    axial component of the mesh force (W sin beta_b, 15 deg helix)."""
    cfg = BenchConfig(speed_start_rpm=2500.0, speed_end_rpm=2600.0, ramp_s=0.06, hold_s=0.02, load_torque_Nm=235.7,
                      shaft1_stiffness_Nm_per_rad=2e4, shaft2_stiffness_Nm_per_rad=2e4, load_inertia_kg_m2=0.5,
                      motor_inertia_kg_m2=0.05)
    res = run_drivetrain_bench(fmu["path"], cfg)
    assert res["input_gear"] == "pinion" and res["output_gear"] == "wheel"
    assert res["speed_ratio"] == pytest.approx(28 / 33, rel=1e-9)
    end = assert_final_hold(res, cfg, 28 / 33, window_s=0.01, rel_speed=0.02)
    f = np.mean(res["m12.force"][end])
    assert f == pytest.approx(res["static_mesh_force_N"]["m12"], rel=0.05)


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_helical_fmu_reversed_torque_loads_the_coast_flanks(fmu, fmi):
    """Drivetrain coupling, -200 N*m on the pinion and +235.7 N*m on the wheel (issue 36): the FMU (FMI 2.0 and
    3.0) equals the library step by step (deflection, coast force, 1e-9) and ends on the coast flanks with the
    deflection within the backlash plus the coast table's range; the impact of the crossing overshoots the coast
    table for a few steps (as the library counts): m12.out_of_range turns true and the log says so once, and ten
    times those torques add no second message."""
    from test_fmu import OK, _Low

    m = load_model(SYSTEM)
    tabs = read_tables(m.tables_path, m.path)
    ct = tabs.mesh("m12").coast
    lib = Simulator(build_system(m, tabs, shafts=False))
    w = 2 * math.pi * 1200.0 / 28
    lib.reset(speed_rad_s=w)
    lib.set_torque_inputs({"pinion": -200.0, "wheel": 235.7})
    low = _Low(fmu["path"] if fmi == "2" else fmu["path3"])
    try:
        assert low.init(mode=1, **{"pinion.speed_start": w, "pinion.torque_in": -200.0,
                                   "wheel.torque_in": 235.7}) == OK
        t, dt = 0.0, 1e-4
        for k in range(200):
            assert low.step(t, dt) in (OK, 1)   # Warning (1) on the step that logs
            assert lib.advance(dt).success
            t += dt
            x, fc = low.get("m12.deflection", "m12.coast_force")
            assert x == pytest.approx(lib.mesh_deflection_m[0], rel=1e-9)
            assert fc == pytest.approx(lib.coast_force_N[0], rel=1e-9, abs=1e-9)
        assert low.get_int("m12.contact")[0] == 2 and fc > 0
        ratio = float(tabs.mesh("m12").twist.lever_arm_m[0]) / float(ct.twist.lever_arm_m[0])
        assert x > -1.2 * ratio * ct.deflection_m[-1]
        assert lib.out_of_range_steps[0] > 0
        assert low.fmu.getBoolean([low.vr["m12.out_of_range"]])[0]
        assert low.set(**{"pinion.torque_in": -2000.0, "wheel.torque_in": 2357.0}) == OK
        for k in range(50):
            assert low.step(t, dt) in (OK, 1)   # Warning (1) on the step that logs
            t += dt
        assert low.fmu.getBoolean([low.vr["m12.out_of_range"]])[0]
        warn = [msg for st, msg in low.messages if "left its tables" in msg]
        assert len(warn) == 1 and "m12" in warn[0]
    finally:
        low.close()


@pytest.fixture(scope="module")
def drive_only_fmu(tmp_path_factory):
    """FMI 2.0 and 3.0 FMUs of the helical pair built on its table without the coast side."""
    from _dyn import drive_only_copy

    models = tmp_path_factory.mktemp("drive_only_models")
    drive_only_copy(SYSTEM, models)
    out = tmp_path_factory.mktemp("drive_only_fmu")
    assert _build_fmu().main(["--models", str(models), "--system", SYSTEM, "--out", str(out), "--fmi", "all"]) == 0
    return {"2": out / f"{SYSTEM}.fmu", "3": out / f"{SYSTEM}_fmi3.fmu", "models": models / SYSTEM}


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_drive_only_helical_fmu_flags_the_backlash_crossing(drive_only_fmu, fmi):
    """A drive-only helical table in the FMU (FMI 2.0 and 3.0), drivetrain coupling with the torques of issue 36
    reversed: the FMU follows the library step by step (deflection 1e-9, step count beyond the tables equal);
    m12.out_of_range stays false while the coast approach is below the backlash and turns true once the teeth
    pass it (no coast flanks carry them: force and coast force 0), with one log message."""
    from test_fmu import OK, _Low

    m = load_model(drive_only_fmu["models"])
    tabs = read_tables(m.tables_path, m.path)
    assert tabs.mesh("m12").coast is None
    sy = build_system(m, tabs, shafts=False)
    lib = Simulator(sy)
    w = 2 * math.pi * 1200.0 / 28
    lib.reset(speed_rad_s=w)
    lib.set_torque_inputs({"pinion": -200.0, "wheel": 235.7})
    low = _Low(drive_only_fmu[fmi])
    try:
        assert low.init(mode=1, **{"pinion.speed_start": w, "pinion.torque_in": -200.0,
                                   "wheel.torque_in": 235.7}) == OK
        t, dt, flagged = 0.0, 1e-4, None
        for k in range(60):
            assert low.step(t, dt) in (OK, 1)   # Warning (1) on the step that logs
            assert lib.advance(dt).success
            t += dt
            x, f, fc = low.get("m12.deflection", "m12.force", "m12.coast_force")
            assert x == pytest.approx(lib.mesh_deflection_m[0], rel=1e-9)
            assert f == 0.0 or lib.coast_approach_m[0] < sy.backlash_m[0]
            assert fc == 0.0
            oor = low.fmu.getBoolean([low.vr["m12.out_of_range"]])[0]
            assert oor == (lib.out_of_range_steps[0] > 0)
            if lib.coast_approach_m[0] < sy.backlash_m[0] and flagged is None:
                assert not oor
            if oor and flagged is None:
                flagged = k
        assert flagged is not None and lib.coast_approach_m[0] > 2 * sy.backlash_m[0]
        warn = [msg for st, msg in low.messages if "left its tables" in msg]
        assert len(warn) == 1 and "m12" in warn[0]
    finally:
        low.close()


@pytest.mark.parametrize("key", ["path", "path3"])
def test_helical_fmu_reset_equals_a_fresh_instance(fmu, key):
    """Issue #50 item 1, helical pair (FMI 2.0 and 3.0): Reset, then the same parameters again: every Real output
    of every step equals a fresh instance's bit for bit."""
    assert_reset_equals_fresh(fmu[key], h=5e-5, n=40)
