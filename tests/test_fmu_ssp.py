"""Drivetrain benches (hacgear_core.fmu.bench, .components, .ssp): the components' physics, the bench as SSP
files under fmpy and libcosim against the Python bench, and a two-stage gearbox (two gear-stage FMUs in series;
the planetary stage FMU, once it exists, is one more entry in the list of stages)."""
from __future__ import annotations

import math
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest

pytest.importorskip("fmpy")
from fmpy.validation import validate_fmu  # noqa: E402

from hacgear_core.fmu import build_component_fmu, build_fmu, synthetic_system_folder  # noqa: E402
from hacgear_core.fmu.bench import BenchConfig, drivetrain_layout, run_drivetrain_bench  # noqa: E402
from hacgear_core.fmu.components import Load, Motor, Shaft  # noqa: E402
from hacgear_core.fmu.ssp import SSD_FILE, read_ssp, run_ssp_fmpy, run_ssp_libcosim, write_bench_ssp  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
#: a short bench (CI): 0.03 s, through a speed change
SHORT = BenchConfig(speed_start_rpm=3000.0, speed_end_rpm=3300.0, ramp_s=0.02, hold_s=0.005, load_torque_Nm=200.0)
#: two stages: the shaft between the stages couples two gear inertias; 2e-5 s resolves it
TWO = BenchConfig(speed_start_rpm=6000.0, speed_end_rpm=6300.0, ramp_s=0.01, hold_s=0.002, load_torque_Nm=300.0,
                  step_s=2e-5, coupling_shaft_stiffness_Nm_per_rad=1.0e4)


@pytest.fixture(scope="module")
def stages(tmp_path_factory):
    """Stage FMUs: spur_28t_asym (committed FE tables) and spur_50t_icr137 (synthetic tables)."""
    out = tmp_path_factory.mktemp("stages")
    synth = synthetic_system_folder(ROOT / "models" / "spur_50t_icr137" / "model.toml", out / "models")
    return {"spur_28t_asym": build_fmu(ROOT / "models" / "spur_28t_asym", out),
            "spur_50t_icr137": build_fmu(synth, out)}


# ---------------------------------------------------------------------------------------------- components
def test_components_closed_forms():
    """Motor at a constant reference with no load holds its speed; a shaft's torque is k twist + c dw; a load
    decelerates at T/J."""
    m = Motor(inertia=0.1, speed_start=100.0, speed_end=100.0, hold_time=0.0, ramp_time=1.0, gain_p=5.0,
              gain_i=100.0, torque_limit=1e3)
    for _ in range(1000):
        m.advance(1e-3)
    assert m.speed == pytest.approx(100.0, rel=1e-12) and m.angle == pytest.approx(100.0, rel=1e-9)
    s = Shaft(stiffness=1e4, damping=2.0, twist_start=0.01)
    s.speed_a, s.speed_b = 10.0, 9.0
    s.advance(1e-3)
    assert s.twist == pytest.approx(0.011) and s.torque == pytest.approx(1e4 * 0.011 + 2.0) and s.torque_a == -s.torque
    ld = Load(inertia=2.0, braking_torque=10.0, speed_start=50.0)
    ld.shaft_torque = -4.0  # the shaft drives the load (torque on side a is -(-4)) against the brake
    for _ in range(100):
        ld.advance(1e-3)
    assert ld.speed == pytest.approx(50.0 + (4.0 - 10.0) / 2.0 * 0.1, rel=1e-12)


def test_component_fmus_validate_and_run():
    import fmpy

    d = Path(__import__("tempfile").mkdtemp())
    for kind in ("motor", "shaft", "load"):
        p = build_component_fmu(kind, d)
        assert validate_fmu(str(p)) == []
    r = fmpy.simulate_fmu(str(d / "hacgear_load.fmu"), stop_time=0.1, output_interval=1e-3,
                          start_values={"inertia": 2.0, "braking_torque": 10.0, "speed_start": 50.0})
    assert r["speed"][-1] == pytest.approx(50.0 - 10.0 / 2.0 * 0.1, rel=1e-9)


# ---------------------------------------------------------------------------------------------- SSP
def test_bench_ssp_structure(stages, tmp_path):
    ssp = write_bench_ssp(stages["spur_28t_asym"], tmp_path / "bench.ssp", SHORT)
    with zipfile.ZipFile(ssp) as z:
        names = set(z.namelist())
        root = ET.fromstring(z.read(SSD_FILE))
        z.extractall(tmp_path / "x")
    assert {SSD_FILE, "resources/spur_28t_asym.fmu", "resources/hacgear_motor.fmu", "resources/hacgear_shaft.fmu",
            "resources/hacgear_load.fmu"} <= names
    assert root.tag.endswith("SystemStructureDescription") and root.get("version") == "1.0"
    comps, cons = read_ssp(tmp_path / "x")
    assert set(comps) == {"motor", "shaft0", "stage1", "shaft1", "load"}
    assert comps["stage1"][1]["mode"] == 1 and comps["shaft0"][1]["twist_start"] > 0
    lay = drivetrain_layout(stages["spur_28t_asym"], SHORT)
    assert sorted(cons) == sorted(lay.connections)


def test_ssp_under_fmpy_and_libcosim_equals_the_python_bench(stages, tmp_path):
    """The same bench as Python objects + FMU, as an SSP under fmpy, as an SSP under libcosim: equal to 1e-9
    (relative to each series' largest value) at the same communication step."""
    pytest.importorskip("libcosimpy")
    py = run_drivetrain_bench(stages["spur_28t_asym"], SHORT)
    ssp = write_bench_ssp(stages["spur_28t_asym"], tmp_path / "bench.ssp", SHORT)
    lay = py["layout"]
    reals = [r for r in lay.record if not r[1].endswith(".contact")]
    fm = run_ssp_fmpy(ssp, SHORT.steps, SHORT.step_s, lay.record)
    lc = run_ssp_libcosim(ssp, SHORT.steps, SHORT.step_s, reals)
    for c, v in reals:
        ref = py[f"{c}.{v}"]
        scale = np.max(np.abs(ref))
        assert np.max(np.abs(fm[f"{c}.{v}"] - ref)) <= 1e-9 * scale, (c, v)
        assert np.max(np.abs(lc[f"{c}.{v}"][1:] - ref[1:])) <= 1e-9 * scale, (c, v)  # libcosim: no t = 0 sample
    assert np.array_equal(fm["stage1.m12.contact"], py["stage1.m12.contact"])
    # a dynamic run, not a constant: the bench follows the ramp
    assert py["motor.speed"][-1] > py["motor.speed"][0] + 20.0


# ---------------------------------------------------------------------------------------------- two stages
def test_two_stage_gearbox(stages, tmp_path):
    """A 50-tooth stage driving the 28-tooth stage through a shaft: speeds in the product ratio, every shaft
    carries the static torque flow of the load, each stage's mean mesh force is its static one; the same under
    fmpy's SSP run."""
    fmus = [stages["spur_50t_icr137"], stages["spur_28t_asym"]]
    res = run_drivetrain_bench(fmus, TWO)
    lay = res["layout"]
    i1, i2 = lay.infos["stage1"], lay.infos["stage2"]
    assert (i1["input"], i1["output"], i2["input"], i2["output"]) == ("pinion", "wheel", "pinion", "wheel")
    assert res["speed_ratio"] == pytest.approx(i1["ratio"] * i2["ratio"]) == pytest.approx(1.0)
    t = res["time_s"]
    hold = t < TWO.hold_s
    w0 = TWO.speed_start_rpm * 2 * math.pi / 60
    for key in ("stage1.pinion.speed", "stage1.wheel.speed", "stage2.pinion.speed", "load.speed"):
        assert np.mean(res[key][hold]) == pytest.approx(w0, rel=5e-3), key
    # static torque flow: load 300 N m through two unity-ratio stages
    assert lay.static["input_torque_Nm"] == pytest.approx([300.0, 300.0])
    assert np.mean(res["shaft2.torque"][hold]) == pytest.approx(-300.0, rel=0.02)
    assert np.mean(res["shaft1.torque"][hold]) == pytest.approx(300.0, rel=0.02)
    assert np.mean(res["shaft0.torque"][hold]) == pytest.approx(300.0, rel=0.02)
    for name, k in (("stage1", 0), ("stage2", 1)):
        info = lay.infos[name]
        scale = lay.static["input_torque_Nm"][k] / info["ports"][info["input"]]["nominal_torque_Nm"]
        for m in info["meshes"]:
            assert np.mean(res[f"{name}.{m}.force"][hold]) == pytest.approx(
                info["meshes"][m]["nominal_force_N"] * scale, rel=0.05), (name, m)
            assert np.ptp(res[f"{name}.{m}.force"]) > 0.05 * info["meshes"][m]["nominal_force_N"]  # it vibrates
    ssp = write_bench_ssp(fmus, tmp_path / "two.ssp", TWO)
    fm = run_ssp_fmpy(ssp, TWO.steps, TWO.step_s, lay.record)
    for key in ("stage1.m12.force", "stage2.m12.force", "load.speed", "shaft1.torque"):
        assert np.max(np.abs(fm[key] - res[key])) <= 1e-9 * np.max(np.abs(res[key])), key
