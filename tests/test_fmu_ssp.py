"""Drivetrain benches (hacgear_core.fmu.bench, .components, .ssp): the components' physics, the bench as SSP
files under fmpy and libcosim against the Python bench, and a two-stage gearbox (two gear-stage FMUs in series;
the planetary stage FMU, once it exists, is one more entry in the list of stages).  The shipped SSPs
(examples/*.ssp): valid under pyssp-standard, what the examples write, completed with their FMUs they run under
libcosim as under fmpy; fmpy.ssp.simulate_ssp drops the SSP's parameter values and fmpy_parameter_set restores
them; libcosim with a pythonfmu gear exits cleanly (subprocesses).
"""
from __future__ import annotations

import importlib.util
import math
import subprocess
import sys
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
from hacgear_core.fmu.ssp import (SSD_FILE, complete_ssp, fmpy_parameter_set, read_ssp, run_ssp_fmpy,  # noqa: E402
                                  run_ssp_libcosim, ssp_step, write_bench_ssp)

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


# ---------------------------------------------------------------------------------------------- shipped SSPs
#: the shipped SSPs: file -> (example script, its stage systems)
SHIPPED = {"drivetrain_bench.ssp": ("drivetrain_bench.py", ["spur_28t_asym"]),
           "two_stage_gearbox.ssp": ("two_stage_gearbox.py", ["idler_28_33_39", "spur_28t_asym"])}


#: shipped SSPs of other benches, tested in their own files
OTHER_SSPS = {f"wind_turbine_{s}.ssp": "tests/test_fmu_wind_turbine.py" for s in ("rated", "gust", "stop")}


def _example(script: str):
    spec = importlib.util.spec_from_file_location(f"example_{Path(script).stem}", ROOT / "examples" / script)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def shipped_fmus(stages, tmp_path_factory):
    """Folder with the stage FMUs the shipped SSPs name (FMI 2.0, native backend)."""
    out = Path(stages["spur_28t_asym"]).parent
    build_fmu(ROOT / "models" / "idler_28_33_39", out)
    return out


def _validate(ssp: Path) -> list[str]:
    """pyssp-standard's schema validation of the SSP's SystemStructure.ssd (raises when invalid) and its connection
    check (every input connected once, no connection between two outputs, every connector declared)."""
    from pyssp_standard.ssp import SSP

    with SSP(ssp, mode="r") as archive:
        ssd = archive.system_structure
        ssd.__check_compliance__()
        return ssd.check_connections(unconnected_inputs=True, connector_not_in_system=True)


def _same_ssd(a: bytes, b: bytes, rel: float = 1e-9) -> None:
    """Two SystemStructure.ssd documents are the same tree, attribute for attribute; numbers (the ``value`` of a
    parameter, ``stopTime``, ``baseStepSize``) equal to ``rel`` relative (they come from tables and builds)."""
    def walk(x, y, where):
        assert x.tag == y.tag, where
        assert sorted(x.attrib) == sorted(y.attrib), (where, x.attrib, y.attrib)
        for k, v in x.attrib.items():
            if k in ("value", "stopTime", "baseStepSize") and x.tag.split("}")[1] != "Integer":
                assert float(v) == pytest.approx(float(y.attrib[k]), rel=rel, abs=1e-300), (where, k)
            else:
                assert v == y.attrib[k], (where, k)
        assert len(x) == len(y), where
        for cx, cy in zip(x, y):
            walk(cx, cy, f"{where}/{cx.tag.split('}')[1]}[{cx.get('name', '')}]")
    walk(ET.fromstring(a), ET.fromstring(b), "")


def test_shipped_ssps_validate(tmp_path):
    """examples/*.ssp: SSP 1.0 archives whose SystemStructure.ssd passes pyssp-standard's schema validation and
    connection check; every component an FMU under resources/ that the archive does not carry (built by
    `python -m hacgear_core.fmu.ssp`), every stage in drivetrain mode, the communication step in the OSP annotation
    no coarser than 2e-5 s; a schema violation is caught."""
    pytest.importorskip("pyssp_standard")
    assert sorted(p.name for p in (ROOT / "examples").glob("*.ssp") if p.name not in OTHER_SSPS) == sorted(SHIPPED)
    for name in SHIPPED:
        ssp = ROOT / "examples" / name
        assert _validate(ssp) == [], name
        with zipfile.ZipFile(ssp) as z:
            assert z.namelist() == [SSD_FILE], name
            ssd = z.read(SSD_FILE)
        comps, cons = read_ssp(ssp)
        assert {str(p.parent) for p, _ in comps.values()} == {"resources"} and all(
            p.suffix == ".fmu" for p, _ in comps.values()), name
        assert all(params["mode"] == 1 for c, (_, params) in comps.items() if c.startswith("stage")), name
        ends = [(c[2], c[3]) for c in cons]
        assert len(ends) == len(set(ends)), name
        step, stop = ssp_step(ssp)
        assert 0 < step <= 2e-5 and stop > 1.0, name
        with zipfile.ZipFile(tmp_path / name, "w") as z:
            z.writestr(SSD_FILE, ssd.replace(b'kind="input"', b'kind="sideways"', 1))
        with pytest.raises(Exception, match="sideways"):
            _validate(tmp_path / name)


def test_shipped_ssps_are_what_the_examples_write(shipped_fmus, tmp_path):
    """Regenerating each shipped SSP from freshly built FMUs with its example's bench (the step: 2e-5 s or the
    stages' drivetrain_step, whichever is smaller) gives the shipped SystemStructure.ssd: the same tree and
    attributes, numbers within 1e-9 relative.  When this fails, rewrite the file with the command in the
    example's docstring."""
    for name, (script, systems) in SHIPPED.items():
        ex = _example(script)
        fmus = [shipped_fmus / f"{s}.fmu" for s in systems]
        cfg = ex.bench_config(fmus[0]) if len(fmus) == 1 else ex.bench_config(fmus)
        new = write_bench_ssp(fmus, tmp_path / name, cfg, fmus=False, name=ex.SSP_NAME)
        with zipfile.ZipFile(new) as a, zipfile.ZipFile(ROOT / "examples" / name) as b:
            _same_ssd(a.read(SSD_FILE), b.read(SSD_FILE))
        assert cfg.step_s <= 2e-5


def test_shipped_ssp_runs_under_libcosim(shipped_fmus, tmp_path):
    """`python -m hacgear_core.fmu.ssp examples/two_stage_gearbox.ssp DEST --fmus DIR` writes the SSP with its
    FMUs (valid under pyssp-standard); libcosim runs it at the step the SSP carries (no step given) and gives
    fmpy's run of the same SSP within 1e-9 for 400 steps; no FMU of a stage it cannot build."""
    pytest.importorskip("libcosimpy")
    pytest.importorskip("pyssp_standard")
    from hacgear_core.fmu.ssp import main

    dest = tmp_path / "two_stage.ssp"
    assert main([str(ROOT / "examples" / "two_stage_gearbox.ssp"), str(dest), "--fmus", str(shipped_fmus)]) == 0
    assert _validate(dest) == []
    with zipfile.ZipFile(dest) as z:
        assert {"resources/idler_28_33_39.fmu", "resources/spur_28t_asym.fmu", "resources/hacgear_motor.fmu",
                "resources/hacgear_shaft.fmu", "resources/hacgear_load.fmu"} <= set(z.namelist())
    step, _ = ssp_step(dest)
    rec = [("stage1", "m12.force"), ("stage1", "m23.force"), ("stage2", "m12.force"), ("shaft1", "torque"),
           ("load", "speed"), ("motor", "speed")]
    n = 400
    lc = run_ssp_libcosim(dest, n, None, rec)
    fm = run_ssp_fmpy(dest, n, step, rec)
    assert lc["time_s"][-1] == pytest.approx(n * step, rel=1e-12)
    for c, v in rec:
        ref = fm[f"{c}.{v}"]
        assert np.max(np.abs(lc[f"{c}.{v}"][1:] - ref[1:])) <= 1e-9 * np.max(np.abs(ref)), (c, v)
    # a stage FMU that is neither given nor a shipped system: refused, naming it
    with zipfile.ZipFile(ROOT / "examples" / "drivetrain_bench.ssp") as z:
        ssd = z.read(SSD_FILE).replace(b"resources/spur_28t_asym.fmu", b"resources/no_such_system.fmu")
    with zipfile.ZipFile(tmp_path / "odd.ssp", "w") as z:
        z.writestr(SSD_FILE, ssd)
    from hacgear_core.errors import HacgearError

    with pytest.raises(HacgearError, match="no_such_system"):
        complete_ssp(tmp_path / "odd.ssp", tmp_path / "odd_full.ssp", shipped_fmus)


def test_fmpy_simulate_ssp_drops_the_parameter_values_and_the_workaround(stages, tmp_path):
    """fmpy.ssp.simulate_ssp applies none of the SSP's parameter bindings: the stage runs in mode 0 at its own
    default speed, the bench's input speed is off by far more than 50 %.  With fmpy_parameter_set (and the SSP's
    step and stop time) it follows fmpy's run of the bench within 1 %: its connections start at 0.0 instead of the
    initial outputs, the first step's transient is what remains."""
    from fmpy.ssp.simulation import simulate_ssp

    ssp = write_bench_ssp(stages["spur_28t_asym"], tmp_path / "bench.ssp", SHORT)
    step, stop = ssp_step(ssp)
    assert step == SHORT.step_s
    rec = [("stage1", "pinion.speed"), ("motor", "speed"), ("load", "speed"), ("shaft0", "torque")]
    ref = run_ssp_fmpy(ssp, SHORT.steps, SHORT.step_s, rec)

    def dev(res, key):  # simulate_ssp's row k holds the values after step k + 1
        a = res[key]
        b = ref[key][1:len(a) + 1]
        return float(np.max(np.abs(a[:len(b)] - b)) / np.max(np.abs(b)))

    plain = simulate_ssp(str(ssp), stop_time=stop, step_size=step)
    assert dev(plain, "stage1.pinion.speed") > 0.5
    fixed = simulate_ssp(str(ssp), stop_time=stop, step_size=step, parameter_set=fmpy_parameter_set(ssp))
    assert len(fixed) >= SHORT.steps
    for c, v in rec:
        assert dev(fixed, f"{c}.{v}") < 0.01, (c, v)


#: a libcosim execution of an SSP with the pythonfmu gear in a fresh process; argv: SSP, case
_EXIT_SCRIPT = r"""
import faulthandler, sys
faulthandler.enable()
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
log_output_level(CosimLogLevel.ERROR)
ssp, case = sys.argv[1], sys.argv[2]
if case == "no_step":  # instantiated, never initialized, released at exit
    ex = CosimExecution.from_ssp_file(ssp)
elif case == "steps":  # stepped, alive at exit
    ex = CosimExecution.from_ssp_file(ssp)
    ex.step(20)
else:  # the library's runner, then exit
    from hacgear_core.fmu.ssp import run_ssp_libcosim
    out = run_ssp_libcosim(ssp, 20, None, [("stage1", "m12.force")])
    assert out["stage1.m12.force"][-1] > 0
print("done", flush=True)
"""


def test_libcosim_exits_cleanly_with_the_pythonfmu_gear(tmp_path):
    """libcosim (libcosimpy) with the pythonfmu gear FMU in an SSP: a process that creates the execution and exits
    without a step, one that steps and exits with the execution alive, one that runs the library's runner: each
    exits with status 0 (pythonfmu 0.7.0's fmi2FreeInstance deletes the FMU's logger before the slave, whose
    destructor then logs the messages still queued: the slave queues none at instantiation)."""
    pytest.importorskip("libcosimpy")
    gear = build_fmu(ROOT / "models" / "spur_28t_asym", tmp_path, backend="pythonfmu")
    ssp = write_bench_ssp(gear, tmp_path / "bench.ssp", SHORT)
    for case in ("no_step", "steps", "runner"):
        r = subprocess.run([sys.executable, "-c", _EXIT_SCRIPT, str(ssp), case], capture_output=True, text=True,
                           timeout=600, cwd=tmp_path)
        assert r.returncode == 0 and "done" in r.stdout, (case, r.returncode, r.stderr[-2000:])
