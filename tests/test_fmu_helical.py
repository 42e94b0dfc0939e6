"""The helical FMU (the generic adapter on the 12-DOF helical pair): built from the shipped model and its generalized
tables, validated (fmpy validate, fmutool -check), equal to the library (mesh force, twist moment, deflection, twist,
contact state, radial and axial bearing forces and tilting moments, the five face strains) in both experiments, and
in a drivetrain bench (motor on the pinion, load on the wheel)."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")

from _bench import assert_final_hold  # noqa: E402
from hacgear_core.dynamics.build import build_system  # noqa: E402
from hacgear_core.dynamics.simulator import Simulator  # noqa: E402
from hacgear_core.fmu.bench import BenchConfig, run_drivetrain_bench  # noqa: E402
from hacgear_core.model import load_model  # noqa: E402
from hacgear_core.tables import read_tables  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = "helical_28_33"
GAUGES = ("SG1", "SG2", "SG3", "SG4", "SG5")


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    out = tmp_path_factory.mktemp("hfmu")
    sys.path.insert(0, str(ROOT))
    try:
        import build_fmu
    finally:
        sys.path.remove(str(ROOT))
    assert build_fmu.main(["--system", SYSTEM, "--out", str(out), "--fmi", "2"]) == 0
    return {"path": out / f"{SYSTEM}.fmu", "build_fmu": build_fmu}


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
