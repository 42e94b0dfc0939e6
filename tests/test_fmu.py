"""FMUs (hacgear_core.fmu, fmu_src/, build_fmu.py): built once per session from synthetic tables into a
temporary folder, then run under fmpy (high- and low-level API) in this process."""
from __future__ import annotations

import json
import math
import subprocess
import sys
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402

import hacgear_core.fmu as hf  # noqa: E402
from hacgear_core.dynamics.build import build_system  # noqa: E402
from hacgear_core.dynamics.simulator import Simulator  # noqa: E402
from hacgear_core.errors import HacgearError  # noqa: E402
from hacgear_core.fmu.bench import BenchConfig, run_drivetrain_bench  # noqa: E402
from hacgear_core.model import load_model  # noqa: E402
from hacgear_core.tables import read_tables  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SYSTEMS = ("spur_28t_asym", "spur_50t_icr137")
GEARS = {"spur_28t_asym": ("pinion", "wheel"), "spur_50t_icr137": ("input", "output")}


def var(system, key):
    """The FMU variable name of a quantity of the spur pair ``system`` (gear 1 = driver, gear 2)."""
    g1, g2 = GEARS[system]
    names = {"speed1_in": f"{g1}.speed_in", "speed1_start": f"{g1}.speed_start", "torque1_in": f"{g1}.torque_in",
             "torque2_in": f"{g2}.torque_in", "m12.force": "m12.force", "mesh_deflection": "m12.deflection",
             "m12.dte": "m12.dte", "m12.position": "m12.position", "contact": "m12.contact",
             "peak_pressure": "m12.peak_pressure", "angle1": f"{g1}.angle", "angle2": f"{g2}.angle",
             "speed1": f"{g1}.speed", "speed2": f"{g2}.speed", "bearing_stiffness1": f"{g1}.bearing_stiffness",
             "bearing_force1_y": f"{g1}.bearing_force_y", "bearing_force2_y": f"{g2}.bearing_force_y"}
    return names.get(key, key)


def v28(key):
    return var("spur_28t_asym", key)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """Two spur-pair FMUs (synthetic tables) built by build_fmu.py's main() into a temporary folder."""
    base = tmp_path_factory.mktemp("fmu")
    models = base / "models"
    for s in SYSTEMS:
        hf.synthetic_system_folder(ROOT / "models" / s / "model.toml", models)
    sys.path.insert(0, str(ROOT))
    try:
        import build_fmu
    finally:
        sys.path.remove(str(ROOT))
    rc = build_fmu.main(["--models", str(models), "--out", str(base / "dist")])
    assert rc == 0
    return {"models": models, "dist": base / "dist", "fmu": {s: base / "dist" / f"{s}.fmu" for s in SYSTEMS},
            "build_fmu": build_fmu}


def _library(built, system, internal_step, torque=None, shafts=True):
    folder = built["models"] / system
    model = load_model(folder / "model.toml")
    tables = read_tables(folder / "tables.h5")
    sy = build_system(model, tables, torque_Nm=torque, shafts=shafts)
    return Simulator(sy, internal_step_s=internal_step), tables.mesh(model.mesh().name)


class _Low:
    """fmpy low-level co-simulation session that records log messages."""

    def __init__(self, path, name="inst"):
        self.md = read_model_description(str(path))
        self.dir = extract(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.messages = []

        def logger(component, instance, status, category, message):
            self.messages.append((status, message.decode(errors="replace")))

        from fmpy.fmi2 import (calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free)

        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(logger)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._cb = cb
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(loggingOn=True, callbacks=cb)

    def init(self, **params):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for k, v in params.items():
            if k == "mode":
                self.fmu.setInteger([self.vr[k]], [int(v)])
            else:
                self.fmu.setReal([self.vr[k]], [float(v)])
        self.fmu.exitInitializationMode()

    def get(self, *names):
        return self.fmu.getReal([self.vr[n] for n in names])

    def close(self):
        try:
            self.fmu.terminate()
        except FMICallException:
            pass
        self.fmu.freeInstance()
        import shutil

        shutil.rmtree(self.dir, ignore_errors=True)


# ---------------------------------------------------------------------------------------------- build
def test_model_description_units_ranges_and_spec(built):
    path = built["fmu"]["spur_28t_asym"]
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
        names = set(z.namelist())
        info = json.loads(z.read("resources/hacgear_fmu.json"))
    assert {"resources/model.toml", "resources/tables.h5", "resources/hacgear_spur_28t_asym.py",
            "binaries/linux64/spur_28t_asym.so"} <= names
    assert info["requirements"]["hacgear"].startswith("==") and "numba" in info["requirements"]
    units = {u.get("name") for u in root.find("UnitDefinitions")}
    spec = {v.name: v for v in hf.variables_for(built["models"] / "spur_28t_asym")}
    xml_vars = root.find("ModelVariables").findall("ScalarVariable")
    assert {sv.get("name") for sv in xml_vars} == set(spec)
    for sv in xml_vars:
        v = spec[sv.get("name")]
        assert sv.get("description") == v.description and v.description
        if v.type == "Real":
            real = sv.find("Real")
            assert real.get("unit") == v.unit and v.unit in units
        if sv.get("causality") == "output":
            assert sv.get("initial") == "exact" and sv.find(v.type).get("start") is not None
        else:
            t = sv.find(v.type)
            assert float(t.get("min")) == v.min and float(t.get("max")) == v.max
            assert v.min <= float(t.get("start")) <= v.max
    # only the enumerated switch is an Integer (FMI 2.0 has no unit attribute on Integer)
    assert [n for n, v in spec.items() if v.type != "Real"] == ["mode"]
    outs = {n for n, v in spec.items() if v.causality == "output"}
    assert {"m12.force", "m12.deflection", "m12.dte", "m12.position", "m12.contact", "m12.peak_pressure",
            "pinion.bearing_force_x", "wheel.bearing_force_y", "pinion.angle", "wheel.angle", "pinion.speed",
            "wheel.speed", "wheel.SG.root_strain", "pinion.SG.root_strain"} <= outs
    assert {"pinion.torque_in", "wheel.torque_in", "pinion.speed_in"} <= set(spec)
    assert info["ports"]["wheel"]["speed_ratio"] == pytest.approx(-1.0) and info["input_gear"] == "pinion"
    # the output start values are the initial static equilibrium at the nominal torque
    start_f = float(next(sv for sv in xml_vars if sv.get("name") == "m12.force").find("Real").get("start"))
    sim, table = _library(built, "spur_28t_asym", None)
    assert start_f == pytest.approx(sim.system.torque_Nm / table.base_radius_m[0], rel=1e-6)


@pytest.mark.parametrize("system", SYSTEMS)
def test_fmpy_validate_and_fmutool_check(built, system):
    assert built["build_fmu"].validate_fmu(built["fmu"][system]) == []


def test_postprocess_refuses_spec_mismatch(built):
    with zipfile.ZipFile(built["fmu"]["spur_28t_asym"]) as z:
        xml = z.read("modelDescription.xml")
    spec = hf.variables_for(built["models"] / "spur_28t_asym")
    with pytest.raises(HacgearError, match="not in the spec"):
        hf.postprocess_model_description(xml, spec[1:])
    extra = spec + (hf.FmuVariable("ghost", "Real", "output", "continuous", "m", "a variable the slave lacks"),)
    with pytest.raises(HacgearError, match="missing in modelDescription"):
        hf.postprocess_model_description(xml, extra)


def test_build_script_skips_and_errors(built, tmp_path, capsys):
    bf = built["build_fmu"]
    # a model folder without tables is skipped when building all, an error when named
    (tmp_path / "m" / "spur_50t_icr18").mkdir(parents=True)
    (tmp_path / "m" / "spur_50t_icr18" / "model.toml").write_bytes(
        (ROOT / "models" / "spur_50t_icr18" / "model.toml").read_bytes())
    assert bf.main(["--models", str(tmp_path / "m"), "--out", str(tmp_path / "d")]) == 0
    assert "skipped, no tables.h5" in capsys.readouterr().out
    assert bf.main(["--models", str(tmp_path / "m"), "--out", str(tmp_path / "d"), "--system", "spur_50t_icr18"]) == 1
    # tables of another model are refused with the table module's message
    (tmp_path / "m" / "spur_50t_icr18" / "tables.h5").write_bytes(
        (built["models"] / "spur_28t_asym" / "tables.h5").read_bytes())
    assert bf.main(["--models", str(tmp_path / "m"), "--out", str(tmp_path / "d"), "--system", "spur_50t_icr18"]) == 1
    err = capsys.readouterr().err
    assert "does not belong to" in err
    # the message names the user's files, never the temporary build folder
    assert str(tmp_path / "m" / "spur_50t_icr18" / "tables.h5") in err and "hacgear_fmu_" not in err, err


def test_field_checks_name_unit_and_range():
    v = hf.FmuVariable("torque", "Real", "parameter", "fixed", "N.m", "a torque", 1.0, 0.0, 10.0)
    assert v.check(5.0) == ""
    msg = v.check(float("nan"))
    assert "torque" in msg and "N.m" in msg and "[0, 10]" in msg
    assert "outside" in v.check(11.0)
    with pytest.raises(ValueError):
        hf.FmuVariable("x", "Real", "output", "continuous", "furlong", "bad unit")
    with pytest.raises(ValueError):
        hf.FmuVariable("x", "Real", "parameter", "fixed", "m", "no start")


def test_requirements_check_messages():
    assert hf.check_requirements(hf.requirements()) == []
    probs = hf.check_requirements({"hacgear": "==99.0", "numpy": ">=999", "no-such-package-xyz": ">=1"})
    assert len(probs) == 3
    assert "hacgear" in probs[0] and "==99.0" in probs[0]
    assert "not installed" in probs[2]


# ---------------------------------------------------------------------------------------------- runs
def test_fmu_reproduces_library_time_series(built):
    """Same speed, torque, internal step: the FMU under fmpy equals the library to <= 1e-9 (relative)."""
    speed, torque, h_int, dt, n = 520.0, 250.0, 2e-6, 1e-4, 300
    res = fmpy.simulate_fmu(str(built["fmu"]["spur_28t_asym"]), start_time=0.0, stop_time=n * dt, step_size=dt,
                            output_interval=dt,
                            start_values={"pinion.speed_in": speed, "torque": torque, "internal_step": h_int},
                            output=["m12.force", "m12.deflection", "m12.dte", "m12.position", "pinion.angle",
                                    "wheel.speed"])
    sim, _ = _library(built, "spur_28t_asym", h_int, torque)
    sim.reset(speed_rad_s=speed)
    sim.set_speed_input(speed_rad_s=speed)
    get = {"m12.force": lambda: sim.mesh_force_N[0], "m12.deflection": lambda: sim.mesh_deflection_m[0],
           "m12.dte": lambda: sim.dynamic_transmission_error_m[0], "m12.position": lambda: sim.mesh_position[0],
           "pinion.angle": lambda: sim.angle_rad[0], "wheel.speed": lambda: sim.speed_rad_s[1]}
    lib = {k: [] for k in get}
    for _ in range(n):
        assert sim.advance(dt).success
        for k, g in get.items():
            lib[k].append(g())
    assert len(res) == n + 1
    for k, v in lib.items():
        v = np.asarray(v)
        f = res[k][1:]
        scale = np.max(np.abs(v))
        assert scale > 0
        assert np.max(np.abs(f - v)) <= 1e-9 * scale, k
    # a dynamic run, not a constant: the mesh force varies over the mesh cycle
    assert np.ptp(res["m12.force"]) > 0.05 * np.mean(res["m12.force"])


def _adapter_and_library(built, system, mode, h_int, **inputs):
    """The FMU's adapter (as the slave drives it) and a library simulator with the same parameters and inputs."""
    ad = hf.make_adapter(built["models"] / system)
    values = {v.name: v.start for v in ad.variables if v.causality != "output"}
    values.update(mode=mode, internal_step=h_int, **{var(system, k): v for k, v in inputs.items()})
    ad.configure(values)
    sim, _ = _library(built, system, h_int, shafts=mode == hf.MODE_SPEED)
    g1, g2 = GEARS[system]
    if mode == hf.MODE_SPEED:
        sim.reset(speed_rad_s=values[f"{g1}.speed_in"])
        sim.set_speed_input(speed_rad_s=values[f"{g1}.speed_in"])
    else:
        sim.reset(speed_rad_s=values[f"{g1}.speed_start"])
        sim.set_torque_inputs({g1: values[f"{g1}.torque_in"], g2: values[f"{g2}.torque_in"]})
    return ad, values, sim


def _lib_outputs(sim, system):
    g1, g2 = GEARS[system]
    return {"m12.force": sim.mesh_force_N[0], "m12.deflection": sim.mesh_deflection_m[0],
            "m12.dte": sim.dynamic_transmission_error_m[0], "m12.position": sim.mesh_position[0],
            f"{g1}.angle": sim.angle_rad[0], f"{g2}.angle": sim.angle_rad[1], f"{g1}.speed": sim.speed_rad_s[0],
            f"{g2}.speed": sim.speed_rad_s[1]}


@pytest.mark.parametrize("system, mode", [("spur_28t_asym", 0), ("spur_50t_icr137", 0), ("spur_50t_icr137", 1)])
def test_fmu_step_path_equals_library_advance(built, system, mode):
    """The adapter's step is the library's Simulator.advance: every output identical (bit for bit), in both modes,
    over steps of different lengths and a changing input."""
    inputs = {"speed1_in": 410.0} if mode == 0 else {"speed1_start": 150.0, "torque1_in": 250.0, "torque2_in": -200.0}
    ad, values, sim = _adapter_and_library(built, system, mode, 1.5e-6, **inputs)
    get = ad.getters()
    steps = [1e-4] * 40 + [3.3e-5, 2e-4, 1e-6] * 5
    for k, dt in enumerate(steps):
        if k == 20:  # an input changes between steps (applied by the slave before the step)
            key, val = (var(system, "speed1_in"), 430.0) if mode == 0 else (var(system, "torque1_in"), 400.0)
            values[key] = val
            ad.apply_inputs(values)
            g1, g2 = GEARS[system]
            if mode == 0:
                sim.set_speed_input(speed_rad_s=val)
            else:
                sim.set_torque_inputs({g1: val, g2: values[f"{g2}.torque_in"]})
        assert ad.advance(dt) == ""
        assert sim.advance(dt).success
        for name, ref in _lib_outputs(sim, system).items():
            assert get[name]() == ref, (k, name)
        assert get["m12.contact"]() == (1.0 if sim.in_contact[0] else 0.0)
        if k % 7 == 0:  # bearing forces and the table post-processing
            for i, g in enumerate(GEARS[system]):
                assert get[f"{g}.bearing_force_x"]() == sim.bearing_force_N(g)[0]
                assert get[f"{g}.bearing_force_y"]() == sim.bearing_force_N(g)[1]
            assert get["m12.peak_pressure"]() == pytest.approx(sim.peak_pressure_Pa(0), rel=1e-12)
    assert ad.sim.time_s == pytest.approx(sim.time_s, rel=1e-15)
    assert all(type(g()) is float for g in get.values())  # pythonfmu's C wrapper reads Python floats


def test_fmu_step_divergence_keeps_the_state(built):
    """A step whose integration is not finite is refused with a message and leaves state and outputs as they were."""
    ad, _, _ = _adapter_and_library(built, "spur_28t_asym", 0, 2e-6, speed1_in=300.0)
    assert ad.advance(1e-4) == ""
    get = ad.getters()
    outputs = lambda: {k: g() for k, g in get.items()}  # noqa: E731
    s, kin, out, t = ad.sim.s.copy(), ad.sim.kin.copy(), outputs(), ad.sim.time_s
    good = ad.sim.fext
    ad.sim.fext = np.full_like(good, np.nan)
    msg = ad.advance(1e-4)
    assert "diverged" in msg and "restored" in msg
    assert np.array_equal(ad.sim.s, s) and np.array_equal(ad.sim.kin, kin) and outputs() == out
    assert ad.sim.time_s == t
    ad.sim.fext = good
    assert ad.advance(1e-4) == "" and outputs() != out


def test_get_set_real_of_unknown_references_are_logged(built):
    """getReal of a reference that is not a Real variable gives NaN and a message, setReal of an output or an
    unknown reference is ignored with a message: no exception reaches pythonfmu's wrapper (fmi2Fatal)."""
    low = _Low(built["fmu"]["spur_28t_asym"])
    try:
        low.init(**{"pinion.speed_in": 300.0})
        low.fmu.doStep(0.0, 1e-4)
        f = low.get("m12.force")[0]
        vals = low.fmu.getReal([low.vr["m12.force"], 99999, low.vr["mode"]])
        assert vals[0] == f and math.isnan(vals[1]) and math.isnan(vals[2])
        assert any("99999" in m and "not a Real variable" in m for _, m in low.messages)
        low.fmu.setReal([low.vr["m12.force"], 99999], [1.0, 2.0])
        assert any("not a settable Real variable" in m for _, m in low.messages)
        assert low.get("m12.force")[0] == f
        low.fmu.doStep(1e-4, 1e-4)  # goes on normally
        assert low.get("m12.position")[0] > 0
    finally:
        low.close()


def test_any_communication_step_is_substepped(built):
    """One 2 ms step equals twenty 0.1 ms steps at a fixed internal step (same sub-steps)."""
    kw = dict(start_values={"pinion.speed_in": 400.0, "internal_step": 1e-6}, output=["m12.force", "m12.dte"])
    fine = fmpy.simulate_fmu(str(built["fmu"]["spur_28t_asym"]), stop_time=2e-3, step_size=1e-4,
                             output_interval=1e-4, **kw)
    coarse = fmpy.simulate_fmu(str(built["fmu"]["spur_28t_asym"]), stop_time=2e-3, step_size=2e-3,
                               output_interval=2e-3, **kw)
    assert coarse["m12.dte"][-1] == pytest.approx(fine["m12.dte"][-1], rel=1e-9, abs=1e-18)
    assert coarse["m12.force"][-1] == pytest.approx(fine["m12.force"][-1], rel=1e-9)


def test_drivetrain_mode_transmits_balanced_torques(built):
    """Mode 1: shaft torques in, speeds out.  Balanced torques (T2 = -T1 r_b2/r_b1) keep the mean speed and the
    mean mesh force is T1/r_b1; an unbalanced driving torque accelerates the pair as one inertia."""
    t1 = 300.0
    sim, table = _library(built, "spur_50t_icr137", None)
    rb1, rb2 = table.base_radius_m
    j1, j2 = np.diag(sim.system.M)
    w0 = 200.0
    v = lambda k: var("spur_50t_icr137", k)  # noqa: E731
    res = fmpy.simulate_fmu(str(built["fmu"]["spur_50t_icr137"]), stop_time=0.05, step_size=1e-4,
                            start_values={"mode": 1, v("speed1_start"): w0, v("torque1_in"): t1,
                                          v("torque2_in"): -t1 * rb2 / rb1},
                            output=[v("speed1"), v("speed2"), "m12.force", v("angle1")])
    assert np.mean(res[v("speed1")]) == pytest.approx(w0, rel=1e-3)
    assert np.mean(res[v("speed2")]) == pytest.approx(w0 * rb1 / rb2, rel=1e-3)
    assert np.mean(res["m12.force"][len(res) // 2:]) == pytest.approx(t1 / rb1, rel=0.02)
    assert res[v("angle1")][-1] == pytest.approx(w0 * 0.05, rel=2e-3)
    # net torque: d(omega1)/dt = (T1 + T2 r_b1/r_b2) / (J1 + J2 (r_b1/r_b2)^2)
    t2 = -0.5 * t1 * rb2 / rb1
    res = fmpy.simulate_fmu(str(built["fmu"]["spur_50t_icr137"]), stop_time=0.05, step_size=1e-4,
                            start_values={"mode": 1, v("speed1_start"): w0, v("torque1_in"): t1, v("torque2_in"): t2},
                            output=[v("speed1")])
    alpha = (t1 + t2 * rb1 / rb2) / (j1 + j2 * (rb1 / rb2) ** 2)
    slope = np.polyfit(res["time"], res[v("speed1")], 1)[0]
    assert slope == pytest.approx(alpha, rel=0.02)


def test_root_strain_follows_one_tooth(built):
    """The gauge tooth is loaded once per revolution of its gear (every z mesh cycles) and unloaded between."""
    z = 28
    speed = 300.0  # rad/s -> one pinion revolution in 20.9 ms
    res = fmpy.simulate_fmu(str(built["fmu"]["spur_28t_asym"]), stop_time=0.05, step_size=2e-5,
                            output_interval=2e-5, start_values={"pinion.speed_in": speed},
                            output=["pinion.SG.root_strain", "m12.position", "m12.peak_pressure"])
    s = res["pinion.SG.root_strain"]
    loaded = np.abs(s) > 0.1 * np.max(np.abs(s))
    pos = res["m12.position"][loaded]
    # loaded only within a few mesh cycles around multiples of z
    phase = (pos + z / 2) % z - z / 2
    assert np.all(np.abs(phase) < 3.0)
    assert {int(round(p / z)) for p in pos} == {0, 1, 2}
    assert np.all(res["m12.peak_pressure"] >= 0) and np.max(res["m12.peak_pressure"]) > 1e8


def test_bad_parameters_are_logged_and_steps_refused(built):
    low = _Low(built["fmu"]["spur_28t_asym"])
    try:
        low.init(modal_damping_ratio=2.0, internal_step=-1.0)
        text = " ".join(m for _, m in low.messages)
        assert "modal_damping_ratio" in text and "[0, 0.99]" in text and "internal_step" in text
        with pytest.raises(FMICallException, match="discard"):
            low.fmu.doStep(0.0, 1e-4)
        assert "doStep refused" in low.messages[-1][1]
    finally:
        low.close()
    # fmpy's high-level call logs it and ends the run at the refused (discarded) first step
    msgs = []
    res = fmpy.simulate_fmu(str(built["fmu"]["spur_28t_asym"]), stop_time=1e-3, step_size=1e-4,
                            start_values={"pinion.bearing_stiffness": -5.0}, debug_logging=True,
                            logger=lambda *a: msgs.append(a[-1].decode(errors="replace")))
    assert len(res) < 3 and any("pinion.bearing_stiffness" in m and "[N/m]" in m for m in msgs)


def test_nan_input_and_bad_steps_are_discarded_with_state_kept(built):
    low = _Low(built["fmu"]["spur_28t_asym"])
    try:
        low.init(**{"pinion.speed_in": 300.0})
        low.fmu.doStep(0.0, 1e-4)
        before = low.get("m12.force", "m12.dte", "m12.position")
        low.fmu.setReal([low.vr["pinion.speed_in"]], [float("nan")])
        with pytest.raises(FMICallException, match="discard"):
            low.fmu.doStep(1e-4, 1e-4)
        assert low.get("m12.force", "m12.dte", "m12.position") == before
        assert any("pinion.speed_in" in m and "NaN" in m for _, m in low.messages)
        low.fmu.setReal([low.vr["pinion.speed_in"]], [1e9])
        with pytest.raises(FMICallException, match="discard"):
            low.fmu.doStep(1e-4, 1e-4)
        low.fmu.setReal([low.vr["pinion.speed_in"]], [300.0])
        for bad in (0.0, -1e-4, float("inf"), float("nan")):
            with pytest.raises(FMICallException, match="discard"):
                low.fmu.doStep(1e-4, bad)
        assert any("step size" in m for _, m in low.messages)
        low.fmu.doStep(1e-4, 1e-4)  # goes on normally
        assert low.get("m12.position")[0] > before[2]
    finally:
        low.close()


def test_two_fmus_and_repeated_runs_in_one_process(built):
    a, b = (str(built["fmu"][s]) for s in SYSTEMS)
    kw = dict(stop_time=5e-3, step_size=1e-4, output_interval=1e-4, output=["m12.position", "m12.force"])
    sa, sb = ({var(s, "speed1_in"): 300.0} for s in SYSTEMS)
    ra1 = fmpy.simulate_fmu(a, start_values=sa, **kw)
    rb = fmpy.simulate_fmu(b, start_values=sb, **kw)
    ra2 = fmpy.simulate_fmu(a, start_values=sa, **kw)
    rb2 = fmpy.simulate_fmu(b, start_values=sb, **kw)
    assert np.array_equal(ra1["m12.force"], ra2["m12.force"])
    assert np.array_equal(rb["m12.force"], rb2["m12.force"])
    # mesh position advances z1 * speed / (2 pi) cycles per second: 28 vs 50 teeth
    assert ra1["m12.position"][-1] == pytest.approx(28 * 300.0 * 5e-3 / (2 * math.pi), rel=1e-3)
    assert rb["m12.position"][-1] == pytest.approx(50 * 300.0 * 5e-3 / (2 * math.pi), rel=1e-3)
    # two instances of different FMUs side by side (low-level)
    la, lb = _Low(built["fmu"][SYSTEMS[0]], "a"), _Low(built["fmu"][SYSTEMS[1]], "b")
    try:
        la.init(**sa)
        lb.init(**sb)
        for k in range(50):
            la.fmu.doStep(k * 1e-4, 1e-4)
            lb.fmu.doStep(k * 1e-4, 1e-4)
        assert la.get("m12.force")[0] == pytest.approx(ra1["m12.force"][50], rel=1e-12)
        assert lb.get("m12.force")[0] == pytest.approx(rb["m12.force"][50], rel=1e-12)
    finally:
        la.close()
        lb.close()


def test_unmet_requirement_refuses_instantiation(built, tmp_path):
    bad = tmp_path / "spur_28t_asym.fmu"
    bad.write_bytes(built["fmu"]["spur_28t_asym"].read_bytes())
    with zipfile.ZipFile(bad) as z:
        info = json.loads(z.read("resources/hacgear_fmu.json"))
    info["requirements"]["hacgear"] = "==99.0"
    hf.build._rewrite_zip_member(bad, "resources/hacgear_fmu.json", json.dumps(info).encode())
    low = _Low(bad)
    try:
        low.init(**{"pinion.speed_in": 300.0})
        with pytest.raises(FMICallException, match="discard"):
            low.fmu.doStep(0.0, 1e-4)
        text = " ".join(m for _, m in low.messages)
        assert "hacgear==99.0" in text and "cannot run" in text
    finally:
        low.close()


def test_fresh_process_hits_numba_cache(built):
    """Kernels come from the installed package: in a fresh process (after a first one filled the cache)
    the FMU loads the compiled integrator from numba's cache instead of compiling it."""
    code = (
        "import fmpy, sys, json\n"
        f"r = fmpy.simulate_fmu({str(built['fmu']['spur_28t_asym'])!r}, stop_time=1e-3, step_size=1e-4,"
        " start_values={'pinion.speed_in': 300.0})\n"
        "from hacgear_core.dynamics import kernels\n"
        "ds = [d for d in vars(kernels).values() if hasattr(d, 'stats')]\n"
        "print(json.dumps({'file': kernels.__file__, 'hits': sum(sum(d.stats.cache_hits.values()) for d in ds),"
        " 'misses': sum(sum(d.stats.cache_misses.values()) for d in ds)}))\n"
    )
    out = None
    for _ in range(2):
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, p.stderr[-2000:]
        out = json.loads(p.stdout.strip().splitlines()[-1])
    assert Path(out["file"]).resolve().is_relative_to(ROOT / "hacgear_core")
    assert out["hits"] >= 1 and out["misses"] == 0


def test_drivetrain_bench_follows_the_motor_and_carries_the_load(built):
    """Short ramp of the bench (fmpy low-level API): speeds follow the drive, the shafts carry the load torque,
    the mean mesh force is the static one."""
    cfg = BenchConfig(speed_start_rpm=3000.0, speed_end_rpm=3300.0, ramp_s=0.1, hold_s=0.05, load_torque_Nm=200.0)
    res = run_drivetrain_bench(built["fmu"]["spur_28t_asym"], cfg)
    t = res["time_s"]
    assert t[-1] == pytest.approx(0.2, abs=1e-9)
    assert res["input_gear"] == "pinion" and res["output_gear"] == "wheel"
    end = t > 0.17
    w_ref = 3300.0 * 2 * math.pi / 60
    assert np.mean(res["motor_speed_rad_s"][end]) == pytest.approx(w_ref, rel=0.01)
    assert np.mean(res["input_speed_rad_s"][end]) == pytest.approx(w_ref, rel=0.01)
    # the wheel turns at r_b1/r_b2 of the pinion speed and the load shaft carries -T_load on average
    assert np.mean(res["output_speed_rad_s"][end]) == pytest.approx(w_ref * res["speed_ratio"], rel=0.01)
    assert np.mean(res["shaft2_torque_Nm"][end]) == pytest.approx(-200.0, rel=0.05)
    assert np.mean(res["m12.force"][end]) == pytest.approx(res["static_mesh_force_N"]["m12"], rel=0.05)


def test_importer_exits_cleanly(built):
    """pythonfmu 0.7.0's binary frees its interpreter state twice at process exit unless the slave releases it
    first (hacgear_core.fmu.slave._guard_pythonfmu_exit): fresh importer processes that load scipy, numba and h5py only
    through the FMU must exit with status 0, not abort."""
    code = (
        "import fmpy\n"
        f"r = fmpy.simulate_fmu({str(built['fmu']['spur_28t_asym'])!r}, stop_time=2e-3, step_size=1e-4,"
        " start_values={'pinion.speed_in': 300.0})\n"
        "import hacgear_core.fmu.slave as hs\n"
        "assert any(k.endswith('spur_28t_asym.so') for k in hs._PYTHONFMU_BINARIES), hs._PYTHONFMU_BINARIES\n"
    )
    for _ in range(4):
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, (p.returncode, p.stderr[-2000:])
