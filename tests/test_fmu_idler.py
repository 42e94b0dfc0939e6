"""The idler chain's FMU from the generic adapter and slave: validation, equality with the library, drivetrain bench."""
from __future__ import annotations

import math
import sys

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")

from _bench import assert_final_hold  # noqa: E402
from hacgear_core.kinds import build_system  # noqa: E402
from hacgear_core.dynamics.simulator import Simulator  # noqa: E402
from hacgear_core.fmu import build_fmu, variables_for  # noqa: E402
from hacgear_core.fmu.bench import BenchConfig, run_drivetrain_bench  # noqa: E402
from hacgear_core.model import resolve_model_path  # noqa: E402
from hacgear_core.kinds import load_model  # noqa: E402
from hacgear_core.tables import load_system_tables  # noqa: E402

SYSTEM = "idler_28_33_39"


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    return build_fmu(resolve_model_path(SYSTEM).parent, tmp_path_factory.mktemp("idler_fmu"))


def test_idler_fmu_variables_and_validation(fmu):
    spec = {v.name: v for v in variables_for(resolve_model_path(SYSTEM).parent)}
    assert {"gear1.torque_in", "gear3.torque_in", "gear1.speed_in", "m12.force", "m23.force", "m12.contact",
            "m23.contact", "gear2.SG25.root_strain", "gear2.SG20.root_strain", "gear3.speed", "gear2.angle"} <= set(spec)
    assert "gear2.torque_in" not in spec  # the idler carries no external torque
    assert all(v.description and (v.type != "Real" or v.unit) for v in spec.values())
    root = resolve_model_path(SYSTEM).parents[2]
    sys.path.insert(0, str(root))
    try:
        import build_fmu as script
    finally:
        sys.path.remove(str(root))
    assert script.validate_fmu(fmu) == []


def test_idler_fmu_equals_the_library(fmu):
    speed, dt, n = 650.0, 1e-4, 200
    names = ["m12.force", "m23.force", "m23.deflection", "m23.position", "gear2.SG25.root_strain", "gear3.angle"]
    res = fmpy.simulate_fmu(str(fmu), stop_time=n * dt, output_interval=dt,
                            start_values={"gear1.speed_in": speed, "internal_step": 2e-6}, output=names)
    model = load_model(SYSTEM)
    sim = Simulator(build_system(model, load_system_tables(SYSTEM)), internal_step_s=2e-6)
    sim.reset(speed_rad_s=speed)
    lib = {k: [] for k in names}
    i3 = sim.gear_index("gear3")
    for _ in range(n):
        assert sim.advance(dt).success
        for k, v in (("m12.force", sim.mesh_force_N[0]), ("m23.force", sim.mesh_force_N[1]),
                     ("m23.deflection", sim.mesh_deflection_m[1]), ("m23.position", sim.mesh_position[1]),
                     ("gear2.SG25.root_strain", sim.strain("gear2/SG25")), ("gear3.angle", sim.angle_rad[i3])):
            lib[k].append(v)
    for k in names:
        v = np.asarray(lib[k])
        assert np.max(np.abs(res[k][1:] - v)) <= 1e-9 * np.max(np.abs(v)), k
    assert np.ptp(res["m23.force"]) > 0.05 * np.mean(res["m23.force"])


def test_idler_fmu_in_a_drivetrain_through_a_resonance(fmu):
    """Motor on gear 1, load on gear 3 (fmpy low-level bench): the speeds follow the drive, the load shaft carries
    the load torque, and the ramp through the second natural frequency (~1960 Hz) raises the mesh forces."""
    cfg = BenchConfig(speed_start_rpm=3600.0, speed_end_rpm=4600.0, ramp_s=0.25, hold_s=0.03, load_torque_Nm=300.0)
    res = run_drivetrain_bench(fmu, cfg)
    assert res["input_gear"] == "gear1" and res["output_gear"] == "gear3"
    end = assert_final_hold(res, cfg, 28 / 39, window_s=0.02, rel_speed=0.01)
    # the meshes carry what the shafts transmit (gear 1: F_1 r_11 = T_shaft1 on average over the final hold)
    r11 = load_model(SYSTEM).gear("gear1").module_m * 28 / 2 * math.cos(math.radians(25.0))
    assert np.mean(res["m12.force"][end]) == pytest.approx(np.mean(res["shaft1_torque_Nm"][end]) / r11, rel=0.05)
    fs = res["static_mesh_force_N"]
    for m in ("m12", "m23"):
        assert res[f"{m}.force"].max() > 1.3 * fs[m]
