"""The planetary FMU (fmu_src/planetary.py with the generic adapter): built from the shipped model and its FE tables,
validated, equal to the library, planet count as a fixed structural parameter, and in a drivetrain bench (motor on
the sun, load on the carrier)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")

import hacgear_core.fmu as hf  # noqa: E402
from _bench import assert_final_hold, assert_reversed_torque_run  # noqa: E402
from _fmi_reset import assert_reset_equals_fresh  # noqa: E402
from hacgear_core.kinds import build_system  # noqa: E402
from hacgear_core.dynamics.simulator import Simulator  # noqa: E402
from hacgear_core.fmu.bench import BenchConfig, run_drivetrain_bench  # noqa: E402
from hacgear_core.kinds import load_model  # noqa: E402
from hacgear_core.tables import read_tables  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = "planetary_65_55_175"


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    out = tmp_path_factory.mktemp("pfmu")
    sys.path.insert(0, str(ROOT))
    try:
        import build_fmu
    finally:
        sys.path.remove(str(ROOT))
    assert build_fmu.main(["--system", SYSTEM, "--out", str(out)]) == 0
    path = out / f"{SYSTEM}.fmu"
    return {"path": path, "build_fmu": build_fmu}


def test_planetary_fmu_validates(fmu):
    assert fmu["build_fmu"].validate_fmu(fmu["path"]) == []
    md = fmpy.read_model_description(str(fmu["path"]))
    names = {v.name: v for v in md.modelVariables}
    pc = names["planet_count"]
    assert pc.causality == "parameter" and pc.variability == "fixed" and (pc.min, pc.max) == ("1", "6")
    for i in range(1, 7):  # 6 equally spaced planets fit this set, 7 cannot be assembled, 8 overlap
        for q in ("force", "contact", "load_share"):
            assert f"sun_planet_{i}.{q}" in names and f"ring_planet_{i}.{q}" in names
        assert f"planet_{i}.bearing_force_x" in names
    assert {"sun.torque_in", "carrier.torque_in", "sun.SGmid.root_strain"} <= set(names)


@pytest.mark.parametrize("mode, n", [(0, 3), (1, 5)])
def test_planetary_fmu_equals_the_library(fmu, mode, n):
    """The FMU's outputs equal the library's Simulator (same parameters and inputs) within 1e-9, per planet,
    load-sharing factors and the sun root strain included; planets beyond planet_count read 0."""
    m = load_model(SYSTEM)
    tabs = read_tables(m.tables_path, m.path)
    sim = Simulator(build_system(m, tabs, planet_count=n, shafts=mode == 0))
    start = {"mode": mode, "planet_count": n}
    if mode == 0:
        start["sun.speed_in"] = 150.0
        sim.set_speed_input(speed_rad_s=150.0)
    else:
        start.update({"sun.speed_start": 150.0, "sun.torque_in": 200.0, "carrier.torque_in": -700.0})
        sim.reset(speed_rad_s=150.0)
        sim.set_torque_inputs({"sun": 200.0, "carrier": -700.0})
    out = [f"sun_planet_{i}.force" for i in range(1, 6)] + [f"ring_planet_{i}.contact" for i in (1, 5)] + \
          ["sun_planet_2.load_share", "sun.SGmid.root_strain", "carrier.speed", "planet_2.bearing_force_y",
           "sun.angle"]
    res = fmpy.simulate_fmu(str(fmu["path"]), stop_time=0.01, output_interval=1e-4, start_values=start, output=out)
    rows = []
    for _ in range(100):
        assert sim.advance(1e-4).success
        rows.append(sim)
        k = len(rows)
        r = res[k]
        for i in range(1, 6):
            ref = sim.mesh_force_N[sim.system.mesh_names.index(f"sun_planet_{i}")] if i <= n else 0.0
            assert r[f"sun_planet_{i}.force"] == pytest.approx(ref, rel=1e-9, abs=1e-9)
        assert r["ring_planet_5.contact"] == (1.0 if n == 5 else 0.0)
        assert r["sun_planet_2.load_share"] == pytest.approx(sim.load_share(2), rel=1e-9)
        assert r["sun.SGmid.root_strain"] == pytest.approx(sim.strain("sun/SGmid"), rel=1e-9, abs=1e-15)
        assert r["carrier.speed"] == pytest.approx(sim.speed_rad_s[sim.gear_index("carrier")], rel=1e-9)
        assert r["planet_2.bearing_force_y"] == pytest.approx(sim.bearing_force_N("planet_2")[1], rel=1e-9, abs=1e-9)
        assert r["sun.angle"] == pytest.approx(sim.angle_rad[sim.gear_index("sun")], rel=1e-9)


def test_planetary_fmu_in_a_drivetrain_bench(fmu):
    """Motor on the sun, load on the carrier (ring fixed): speeds follow the drive at the kinematic ratio
    z_s / (z_s + z_r), the carrier shaft carries the load, the planets share it."""
    cfg = BenchConfig(speed_start_rpm=1500.0, speed_end_rpm=1600.0, ramp_s=0.06, hold_s=0.02, load_torque_Nm=700.0,
                      shaft1_stiffness_Nm_per_rad=2e4, shaft2_stiffness_Nm_per_rad=1e5, load_inertia_kg_m2=2.0)
    res = run_drivetrain_bench(fmu["path"], cfg)
    assert res["input_gear"] == "sun" and res["output_gear"] == "carrier"
    assert res["speed_ratio"] == pytest.approx(65 / 240, rel=1e-12)
    end = assert_final_hold(res, cfg, 65 / 240, window_s=0.01, rel_speed=0.02)
    f = [np.mean(res[f"sun_planet_{i}.force"][end]) for i in (1, 2, 3)]
    np.testing.assert_allclose(f, np.mean(f), rtol=0.02)
    assert np.mean(f) == pytest.approx(res["static_mesh_force_N"]["sun_planet_1"], rel=0.05)


@pytest.mark.parametrize("version", ["", "_fmi3"])
def test_planetary_fmu_with_the_torque_reversed(fmu, version):
    """FMI 2.0 and 3.0: ``torque`` = -200 N*m on the sun (it was refused with "swap flank_a/flank_b") loads the coast
    flanks of every sun-planet and ring-planet mesh of the 3 planets, within the coast tables, balancing the torque
    (tests/_bench.py)."""
    path = fmu["path"].with_name(f"{SYSTEM}{version}.fmu")
    assert_reversed_torque_run(fmpy, path, SYSTEM, speed_rad_s=150.0, planet_count=3)


@pytest.mark.parametrize("version", ["", "_fmi3"])
def test_planetary_fmu_reset_equals_a_fresh_instance(fmu, version):
    """Issue #50 item 1, planetary set: Reset, then the same parameters again: every
    Real output of every step equals a fresh instance's bit for bit (before the fix the rerun continued from the
    previous end state)."""
    path = fmu["path"].with_name(f"{SYSTEM}{version}.fmu")
    assert_reset_equals_fresh(path, h=1e-4, n=30, settings={"sun.speed_start": 150.0})


def test_carrier_input_fmu_turns_the_sun_at_willis_ratio_with_power_balanced(tmp_path):
    """Issue #51 item 3 in an FMU: the wind-turbine arrangement (carrier in, sun out, ring fixed; tables from our
    statics on a small grid) builds an FMU whose input port is the carrier: its documentation shows the carrier on
    the motor side, gear_ratio = 1 / (1 + z_r / z_s) (input over output speed), and a drivetrain run held at the
    nominal torques keeps the sun at Willis' ratio with the power in at the carrier leaving at the sun (both within
    1e-3: the meshes' elastic vibration) and equal to the library's simulator within 1e-9."""
    from test_planetary import _carrier_in_text

    from hacgear_core.fmu.documentation import coupling_diagram
    from hacgear_core.statics.grid import compute_statics

    folder = tmp_path / "planetary_carrier_in"
    folder.mkdir()
    (folder / "model.toml").write_text(_carrier_in_text("positions = 16\nloads = 6\ndeflections = 24"))
    compute_statics(folder / "model.toml", sides=("drive",), workers=1, progress=False)
    ad = hf.make_adapter(folder)
    assert ad.spec_system.input_gear == "carrier" and set(ad.ports) == {"carrier", "sun"}
    assert coupling_diagram(ad).splitlines()[1].startswith("shaft/motor --carrier.torque_in")
    path = hf.build_fmu(folder, tmp_path / "out", fmi_version=2)
    h, n = 1e-5, 400
    res = fmpy.simulate_fmu(str(path), stop_time=n * h, output_interval=h, start_values={"mode": 1},
                            output=["carrier.speed", "sun.speed", "carrier.power", "sun.power", "gear_ratio",
                                    "sun_planet_1.force"])
    willis = 1.0 + 175.0 / 65.0
    assert res["gear_ratio"][-1] == pytest.approx(1.0 / willis, rel=1e-12)
    assert np.allclose(res["sun.speed"] / res["carrier.speed"], willis, rtol=1e-3)
    assert np.allclose(res["sun.power"], -res["carrier.power"], rtol=1e-3)
    assert res["carrier.power"][-1] > 0 and np.all(res["sun_planet_1.force"] > 0)
    m = load_model(folder / "model.toml")
    sim = Simulator(build_system(m, read_tables(m.tables_path, m.path), shafts=False))
    sim.reset(speed_rad_s=float(res["carrier.speed"][0]))
    sim.set_torque_inputs({g: float(t) for g, t in ad.port_torques_Nm.items()})
    for _ in range(n):
        assert sim.advance(h).success
    assert sim.speed_rad_s[sim.gear_index("sun")] == pytest.approx(res["sun.speed"][-1], rel=1e-9)
