"""The pythonfmu backend (hacgear_core.fmu.pythonfmu_backend, build_fmu.py --backend pythonfmu): FMI 2.0 FMUs of
pythonfmu 0.7.0 and FMI 3.0 FMUs of pythonfmu3 0.3.4, built by build_fmu.py on a PATH without a C compiler, then
validated and run under fmpy, libcosim and an isolated Python without hacgear and without pythonfmu.

The default suite checks spur_28t_asym; ``pytest -m slow`` every shipped system with tables (equal to the native
FMU, which tests/test_fmu*.py hold equal to the library).  The FMU-call fuzz of this backend is in
tests/test_fmu_fuzz.py.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
pytest.importorskip("pythonfmu")
pytest.importorskip("pythonfmu3")

from test_fmu import (_ISOLATED_RUN, _Low, _isolated_site, _library,  # noqa: E402
                      assert_contact_code_under_libcosim_and_ecos, assert_fmu_time_series_equals_library,
                      ecos_missing)

from hacgear_core.errors import HacgearError  # noqa: E402
from hacgear_core.fmu import build_fmu  # noqa: E402
from hacgear_core.fmu.pythonfmu_backend import PLATFORMS, choose_backend, slave_source  # noqa: E402
from hacgear_core.fmu.slave import DISCARD, ERROR, OK  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = "spur_28t_asym"
ALL_SYSTEMS = sorted(d.name for d in (ROOT / "models").iterdir() if (d / "tables.h5").exists())


def _no_compiler_env() -> dict:
    """The environment without a C compiler: CC unset, PATH without any folder holding cc or gcc."""
    env = {k: v for k, v in os.environ.items() if k != "CC"}
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep)
                                  if p and not any((Path(p) / c).exists() for c in ("cc", "gcc")))
    return env


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """spur_28t_asym's FMI 2.0 and 3.0 FMUs built by build_fmu.py (no --backend) without a C compiler."""
    out = tmp_path_factory.mktemp("pyfmu")
    p = subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--system", SYSTEM, "--out", str(out)],
                       capture_output=True, text=True, timeout=900, env=_no_compiler_env(), cwd=str(ROOT))
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-3000:]
    return {"out": out, "log": p.stdout, 2: out / f"{SYSTEM}.fmu", 3: out / f"{SYSTEM}_fmi3.fmu"}


def test_built_without_a_compiler_with_both_platforms(built):
    """No C compiler: build_fmu.py says it uses pythonfmu and why; the FMUs carry the Linux and Windows binaries,
    pythonfmu's Python code and the hacgear slave, and no compiled binary of ours."""
    assert "backend pythonfmu: no C compiler found" in built["log"]
    for version in (2, 3):
        with zipfile.ZipFile(built[version]) as z:
            names = set(z.namelist())
            module = z.read("resources/slavemodule.txt").decode().strip()
        for plat in PLATFORMS[version]:
            ext = "dll" if "win" in plat else "so"
            assert f"binaries/{plat}/{SYSTEM}.{ext}" in names, (version, plat)
        assert module.startswith(f"hacgear_pyfmu{version}_") and f"resources/{module}.py" in names
        assert f"resources/{'pythonfmu' if version == 2 else 'pythonfmu3'}/fmi{version}slave.py" in names
    assert choose_backend("native") == ("native", "chosen with --backend")
    with pytest.raises(HacgearError, match="--backend must be one of native, pythonfmu"):
        choose_backend("cffi")
    with pytest.raises(HacgearError, match="FMU backend must be one of native, pythonfmu"):
        build_fmu(ROOT / "models" / SYSTEM, built["out"], backend="cffi")
    src3 = slave_source(3)
    assert "class HacgearSlave(Fmi3Slave):" in src3 and "from pythonfmu3 import Fmi3Slave" in src3
    assert "FMI_VERSION = 3" in src3 and "(Fmi2Slave)" not in src3 and "import Fmi2Slave" not in src3


@pytest.mark.parametrize("version", (2, 3))
def test_validate_and_fmutool_check(built, version):
    sys.path.insert(0, str(ROOT))
    try:
        import build_fmu as script
    finally:
        sys.path.remove(str(ROOT))
    assert script.validate_fmu(built[version]) == []
    md = fmpy.read_model_description(str(built[version]))
    names = {v.name: v for v in md.modelVariables}
    assert names["m12.force"].unit == "N" and names["m12.force"].declaredType is None
    assert names["m12.contact"].declaredType.name == "ContactState"
    assert md.defaultExperiment.stopTime and md.coSimulation.canGetAndSetFMUstate
    assert len(md.initialUnknowns) == sum(v.causality == "output" for v in md.modelVariables)


@pytest.mark.parametrize("version", (2, 3))
def test_outputs_equal_the_library_step_for_step(built, version):
    """Same speed, torque, internal step: the pythonfmu FMU under fmpy equals the library (<= 1e-9 relative)."""
    res = assert_fmu_time_series_equals_library(built[version], SYSTEM, 1e-9)
    assert np.ptp(res["m12.force"]) > 0.05 * np.mean(res["m12.force"])


def test_statuses_through_the_pythonfmu_wrappers(built):
    """A bad parameter: the wrappers answer exitInitializationMode OK (they let Python choose a status only in
    doStep), the first doStep reports it: FMI 2.0 Discard with fmi2Terminated true and the reason in the log (debug
    logging on: pythonfmu 0.7.0 forwards nothing else), FMI 3.0 Error with the reason logged with debug logging
    off.  A valid run steps OK; an FMU state repeats a step bit for bit."""
    from fmpy.fmi2 import fmi2Terminated

    f2 = _Low(built[2], "bad2", logging_on=True)
    try:
        assert f2.init(modal_damping_ratio=2.0) == OK
        assert f2.step(0.0, 1e-4) == DISCARD
        assert f2.fmu.getBooleanStatus(fmi2Terminated) is True or f2.fmu.getBooleanStatus(fmi2Terminated) == 1
        assert "'modal_damping_ratio' [1] = 2.0 is outside the allowed range [0, 1)" in f2.text()
        assert any(s_ == ERROR for s_, _ in f2.messages)
        assert math.isnan(f2.fmu.getReal([987654])[0])  # a refused getter (no such variable): NaN, status OK
    finally:
        f2.close()
    f3 = _Low(built[3], "bad3", logging_on=False)
    try:
        assert f3.init(modal_damping_ratio=2.0) == OK
        assert f3.step(0.0, 1e-4) == ERROR
        assert "'modal_damping_ratio' [1] = 2.0 is outside the allowed range [0, 1)" in f3.text()
    finally:
        f3.close()
    for version in (2, 3):
        f = _Low(built[version], "ok")
        try:
            assert f.init(**{"pinion.speed_in": 400.0}) == OK
            for k in range(5):
                assert f.step(k * 1e-4, 1e-4) == OK
            get_state = f.fmu.getFMUState if f.v3 else f.fmu.getFMUstate
            set_state = f.fmu.setFMUState if f.v3 else f.fmu.setFMUstate
            serialize = f.fmu.serializeFMUState if f.v3 else f.fmu.serializeFMUstate
            deserialize = f.fmu.deserializeFMUState if f.v3 else f.fmu.deSerializeFMUstate
            s0 = get_state()
            blob = serialize(s0)
            assert f.step(5e-4, 1e-4) == OK
            a = f.get("m12.force", "pinion.angle")
            set_state(s0)
            assert f.step(5e-4, 1e-4) == OK and f.get("m12.force", "pinion.angle") == a
            set_state(deserialize(blob))
            assert f.step(5e-4, 1e-4) == OK and f.get("m12.force", "pinion.angle") == a
            assert f.get_int("m12.contact")[0] == 1
        finally:
            f.close()


def test_runs_under_libcosim(built):
    """libcosim (libcosimpy) runs the FMI 2.0 FMU: the mesh force equals fmpy's run of it (<= 1e-9 relative)."""
    pytest.importorskip("libcosimpy")
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    n, dt = 50, 1e-4
    ex = CosimExecution.from_step_size(step_size=int(dt * 1e9))
    idx = ex.add_local_slave(CosimLocalSlave(fmu_path=str(built[2]), instance_name="stage"))
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    ref = {v.name.decode(): v.reference for v in ex.slave_variables(idx)}
    ex.real_initial_value(idx, ref["pinion.speed_in"], 400.0)
    forces = []
    for _ in range(n):
        assert ex.step(1)
        forces.append(obs.last_real_values(idx, [ref["m12.force"]])[0])
    res = fmpy.simulate_fmu(str(built[2]), stop_time=n * dt, output_interval=dt, output=["m12.force"],
                            start_values={"pinion.speed_in": 400.0})
    assert np.max(np.abs(np.asarray(forces) - res["m12.force"][1:])) <= 1e-9 * np.max(np.abs(forces))


def test_runs_without_hacgear_and_without_pythonfmu(built, tmp_path):
    """A Python with only numpy, scipy, h5py, numba and fmpy (no hacgear, no pythonfmu installed) runs the FMU:
    the pythonfmu code it loads is the FMU's own copy."""
    site = _isolated_site(tmp_path / "site", ["numpy", "scipy", "h5py", "numba", "fmpy"])
    assert not (site / "pythonfmu").exists() and not (site / "hacgear_core").exists()
    code = _ISOLATED_RUN.format(site=str(site), fmu=str(built[2]), speed_in="pinion.speed_in")
    code += "print('PYTHONFMU', sys.modules['pythonfmu'].__file__)\n"
    p = subprocess.run([sys.executable, "-S", "-c", code], capture_output=True, text=True, timeout=900)
    assert p.returncode == 0 and "FORCE" in p.stdout, p.stdout[-2000:] + p.stderr[-3000:]
    force = float(p.stdout.split("FORCE")[1].split()[0])
    assert 1e3 < force < 1e5
    loaded = set(eval(p.stdout.split("FORCE")[1].split(None, 1)[1].split("\n")[0]))
    assert {"numpy", "scipy", "h5py", "numba"} <= loaded and "hacgear_core" not in loaded
    origin = p.stdout.split("PYTHONFMU")[1].strip()
    assert "/resources/pythonfmu/" in origin and not origin.startswith(str(site))


def test_contact_code_under_libcosim_and_ecos(built):
    """The pythonfmu FMU (FMI 2.0) under libcosim and Ecos: ``m12.contact_code`` equals the contact state of the
    forces read in the same master at every step, drive contact and backlash both occur."""
    assert_contact_code_under_libcosim_and_ecos(built[2])


@pytest.mark.slow
@pytest.mark.parametrize("system", ALL_SYSTEMS)
def test_every_system_validates_and_equals_the_native_fmu(system, tmp_path):
    """Every shipped system with tables, both FMI versions, both backends: fmpy validate + fmutool pass, and the
    pythonfmu FMU gives the native FMU's outputs in its default experiment (<= 1e-9 relative; the native ones equal
    the library in tests/test_fmu*.py); FMI 2.0 FMUs of both backends run under libcosim and Ecos with fmpy's
    first mesh force."""
    sys.path.insert(0, str(ROOT))
    try:
        import build_fmu as script
    finally:
        sys.path.remove(str(ROOT))
    ecos_why = ecos_missing()
    for version in (2, 3):
        py = build_fmu(ROOT / "models" / system, tmp_path / "py", fmi_version=version, backend="pythonfmu")
        nat = build_fmu(ROOT / "models" / system, tmp_path / "nat", fmi_version=version, backend="native")
        assert script.validate_fmu(py) == [] and script.validate_fmu(nat) == []
        kw = dict(stop_time=5e-3, output_interval=1e-4)
        a, b = fmpy.simulate_fmu(str(py), **kw), fmpy.simulate_fmu(str(nat), **kw)
        assert a.dtype.names == b.dtype.names
        for name in a.dtype.names:
            x, y = np.asarray(a[name], float), np.asarray(b[name], float)
            assert np.max(np.abs(x - y)) <= 1e-9 * max(np.max(np.abs(y)), 1e-300), (system, version, name)
        if version == 2:
            for fmu in (py, nat):
                _assert_libcosim_and_ecos_equal_fmpy(fmu, b, ecos=not ecos_why)
    if ecos_why:
        pytest.skip(f"everything but the Ecos runs passed; {ecos_why}")


def _assert_libcosim_and_ecos_equal_fmpy(fmu, reference, h=1e-4, n=50, ecos=True):
    """The FMI 2.0 FMU's first mesh force under libcosim and (``ecos``) under Ecos (in-process) at the
    communication step ``h`` [s] equals fmpy's ``reference`` run of the same default experiment step for step
    (<= 1e-9 relative)."""
    from fmpy import read_model_description
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    name = next(v.name for v in read_model_description(str(fmu)).modelVariables
                if v.causality == "output" and v.name.endswith(".force"))
    ref = np.asarray(reference[name][1:n + 1], float)
    tol = 1e-9 * np.max(np.abs(ref))
    ex = CosimExecution.from_step_size(step_size=int(round(h * 1e9)))
    i = ex.add_local_slave(CosimLocalSlave(fmu_path=str(fmu), instance_name="g"))
    vr = {v.name.decode(): v.reference for v in ex.slave_variables(i)}[name]
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    got = []
    for _ in range(n):
        assert ex.step(1)
        got.append(obs.last_real_values(i, [vr])[0])
    assert np.max(np.abs(np.asarray(got) - ref)) <= tol, (fmu.name, "libcosim", name)
    if not ecos:
        return
    import ecospy

    structure = ecospy.EcosSimulationStructure()
    structure.add_model("g", str(fmu))
    sim = ecospy.EcosSimulation(structure=structure, step_size=h)
    try:
        sim.init()
        got = []
        for _ in range(n):
            sim.step()
            got.append(sim.get_real(f"g::{name}"))
    finally:
        sim.terminate()
        sim.free()
    assert np.max(np.abs(np.asarray(got) - ref)) <= tol, (fmu.name, "Ecos", name)
