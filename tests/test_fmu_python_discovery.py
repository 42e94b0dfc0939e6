"""Which Python a native FMU starts in a master that is not a Python program (fmu_src/bridge.h, hg_discover): an FMU
moved away from the interpreter recorded at its build (built in a virtual environment that is then removed, as on
another machine) runs with a ``python3`` on ``PATH`` that has the requirements, or with ``HACGEAR_FMU_PYTHON``; with
neither, its instantiation fails with one message naming the three candidates, why each cannot run it, and the
command that fixes it.  The loader's requirement message (hacgear_core/fmu/bootstrap.py) says whether
``HACGEAR_FMU_PYTHON`` applies."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description  # noqa: E402

import hacgear_core.fmu as hf  # noqa: E402
from hacgear_core.fmu import bootstrap  # noqa: E402
from hacgear_core.fmu.build import compile_binary, python_runtime  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = "spur_28t_asym"
STEPS, STEP_S = 100, 5e-5


def _run(args, env, timeout=900):
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout, env=env)


@pytest.fixture(scope="module")
def moved(tmp_path_factory):
    """One FMI 2.0 FMU of spur_28t_asym, unpacked twice: ``normal`` as built (its recorded interpreter is this
    one) and ``moved``, whose binary and ``python_runtime`` record the python of a virtual environment
    (``--system-site-packages``, so that a build in it would work) that is removed afterwards; the C master
    (tests/_fmi2_master.c, no libpython in it) compiled; a virtual environment ``bare`` without the packages."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if not cc:
        pytest.skip("no C compiler")
    if not python_runtime()["libpython"]:
        pytest.skip("this Python has no shared libpython: a master that is not a Python program cannot start it")
    base = tmp_path_factory.mktemp("discovery")
    fmu = hf.build_fmu(ROOT / "models" / SYSTEM, base / "dist")
    normal = Path(extract(str(fmu), unzipdir=str(base / "normal")))
    moved = Path(extract(str(fmu), unzipdir=str(base / "moved")))
    venv = base / "builder_venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", str(venv)], check=True,
                   capture_output=True, timeout=300)
    runtime = python_runtime(str(venv / "bin" / "python"))
    assert runtime["executable"] == str(venv / "bin" / "python") and runtime["libpython"]
    binary = moved / "binaries" / "linux64" / f"{SYSTEM}.so"
    compile_binary(2, binary, runtime)
    info_file = moved / "resources" / bootstrap.INFO_FILE
    info = json.loads(info_file.read_text(encoding="utf-8"))
    info["python_runtime"] = runtime
    info_file.write_text(json.dumps(info, indent=1), encoding="utf-8")
    shutil.rmtree(venv)  # the builder's venv is gone: the FMU now is where that path does not exist
    assert not Path(runtime["executable"]).exists()
    bare = base / "bare"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(bare)], check=True, capture_output=True,
                   timeout=300)
    p = _run([str(bare / "bin" / "python3"), "-c", "import numpy"], os.environ, timeout=60)
    assert p.returncode != 0, "the bare venv sees numpy"
    master = base / "master"
    r = subprocess.run([cc, "-O1", f"-I{Path(fmpy.__file__).parent / 'c-code'}", "-o", str(master),
                        str(ROOT / "tests" / "_fmi2_master.c"), "-ldl"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}["m12.force"]
    # the environment of a master that is not a Python program: no preload, no Python variables, no HACGEAR_FMU_PYTHON
    env = {k: v for k, v in os.environ.items()
           if k not in ("LD_PRELOAD", "LD_LIBRARY_PATH", "PYTHONHOME", "PYTHONPATH", "HACGEAR_FMU_PYTHON")}

    def args(folder: Path) -> list[str]:
        return [str(master), str(folder / "binaries" / "linux64" / f"{SYSTEM}.so"),
                (folder / "resources").as_uri(), md.guid, str(vr), str(STEPS), repr(STEP_S)]

    return {"normal": args(normal), "moved": args(moved), "env": env, "bare": bare, "base": base,
            "recorded": runtime["executable"], "info": info}


def _value(p) -> float:
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    return float(p.stdout.split("VALUE")[1])


def test_moved_fmu_finds_a_python_on_path_or_from_the_variable_and_says_how_to_fix_none(moved):
    """The FMU whose recorded interpreter does not exist, in the C master: (a) runs with the ``python3`` first on
    ``PATH`` when that has the requirements, giving the force of the FMU as built (recorded interpreter present),
    bit for bit; (b) runs with ``HACGEAR_FMU_PYTHON`` while the ``python3`` on ``PATH`` lacks the packages; (c)
    with neither, fails its instantiation with one message (FMI logger, status Error, and stderr) naming the three
    candidates, why each cannot run it, and the commands that fix it."""
    env, bare = moved["env"], moved["bare"]
    exe = sys.executable
    reference = _value(_run(moved["normal"], env))
    assert 1e3 < reference < 1e5

    # (a) a python3 on PATH that has the requirements (this interpreter under that name)
    good = moved["base"] / "good_bin"
    good.mkdir(exist_ok=True)
    if not (good / "python3").exists():
        (good / "python3").symlink_to(exe)
    p = _run(moved["moved"], {**env, "PATH": f"{good}{os.pathsep}{bare / 'bin'}{os.pathsep}{env.get('PATH', '')}"})
    assert _value(p) == reference
    assert f"at {good / 'python3'} (started by the FMU binary: program {good / 'python3'}," in p.stdout
    assert "(found as python3 on PATH)" in p.stdout

    # (b) HACGEAR_FMU_PYTHON, the python3 on PATH lacking the packages
    no_pkgs = {**env, "PATH": f"{bare / 'bin'}{os.pathsep}{env.get('PATH', '')}"}
    p = _run(moved["moved"], {**no_pkgs, "HACGEAR_FMU_PYTHON": exe})
    assert _value(p) == reference
    assert f"at {exe} (started by the FMU binary: program {exe}," in p.stdout
    assert "(from HACGEAR_FMU_PYTHON)" in p.stdout

    # (c) neither: one message, through the logger and on stderr
    p = _run(moved["moved"], no_pkgs, timeout=120)
    assert p.returncode == 1 and "fmi2Instantiate returned NULL" in p.stderr, p.stdout[-3000:] + p.stderr[-3000:]
    logged = [line for line in p.stdout.splitlines() if line.startswith("LOG 3 logStatusError: instantiation failed:")]
    assert len(logged) == 1, p.stdout[-3000:]
    message = logged[0].split("instantiation failed: ", 1)[1]
    assert f"instantiation failed: {message}" in p.stderr
    reqs = moved["info"]["requirements"]
    python3 = bare / "bin" / "python3"
    version = ".".join(map(str, sys.version_info[:3]))
    for part in ("found no Python that can run this FMU",
                 "(1) HACGEAR_FMU_PYTHON: not set",
                 f"(2) the interpreter recorded when the FMU was built, {moved['recorded']}: does not exist here",
                 f"(3) python3 on PATH, {python3}: is Python {version}, which lacks what the FMU needs: "
                 + "; ".join(f"{k}>={v} is not installed" for k, v in reqs.items()),
                 f"python on PATH, {bare / 'bin' / 'python'}: is the same file as the python3",
                 f"To fix: install the packages into the python3 on PATH: {python3} -m pip install "
                 + " ".join(f"'{k}>={v}'" for k, v in reqs.items()),
                 "or name a Python that has them: export HACGEAR_FMU_PYTHON=/path/to/python"):
        assert part in message, (part, message)


def test_loader_requirement_message_says_whether_hacgear_fmu_python_applies(tmp_path):
    """The loader's check (bootstrap.check_requirements, the one implementation) as the binary's probe reports it
    (``HG-NEED``/``HG-FIX`` lines), and its error: for an interpreter the FMU binary started it points to
    ``HACGEAR_FMU_PYTHON``; for the master's own it says that the variable does not apply."""
    res = tmp_path / "resources"
    res.mkdir()
    need = {"numpy": "999.0", "no-such-package-xyz": "1.0"}
    (res / bootstrap.INFO_FILE).write_text(json.dumps({"system": "s", "requirements": need, "python": "3.11"}))
    lines = bootstrap.probe(res.as_uri())
    assert lines[:2] == ["HG-NEED " + bootstrap.check_requirements(need)[0], "HG-NEED no-such-package-xyz>=1.0 is "
                         "not installed"]
    install = f"{sys.executable} -m pip install 'numpy>=999.0' 'no-such-package-xyz>=1.0'"
    assert lines[2:] == [f"HG-FIX {install}"]
    (res / bootstrap.INFO_FILE).write_text(json.dumps({"system": "s", "requirements": need, "python": "99.0"}))
    assert not [line for line in bootstrap.probe(str(res)) if line.startswith("HG-FIX")]  # pip cannot fix that
    (res / bootstrap.INFO_FILE).write_text(json.dumps({"system": "s", "requirements": need, "python": "3.11"}))
    with pytest.raises(ImportError) as started:
        bootstrap.instantiate("i", str(res), "", False, 2, chosen_by_binary=True)
    assert f"in the Python the FMU binary started ({sys.executable}," in str(started.value)
    assert f"Install with: {install}; or point the FMU to a Python that has them: export " \
           "HACGEAR_FMU_PYTHON=/path/to/python" in str(started.value)
    with pytest.raises(ImportError) as own:
        bootstrap.instantiate("i", str(res), "", False, 2)
    assert f"already running in the master's process ({sys.executable}," in str(own.value)
    assert f"Install with: {install} (HACGEAR_FMU_PYTHON does not apply here" in str(own.value)
