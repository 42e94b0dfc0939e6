"""``hacgear fmu`` (hacgear_core/cli/fmu.py) and its checkout wrapper build_fmu.py: FMUs from an installed wheel,
not only from an editable checkout, and ``--check`` naming the package it needs."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import fmpy
import pytest

from hacgear_core.cli import fmu as cli_fmu

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def wheel_env(tmp_path_factory):
    """A virtual environment with hacgear installed from the checkout as a wheel would be (not editable; the
    other packages from this Python's site-packages)."""
    base = tmp_path_factory.mktemp("wheel")
    venv = base / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    py = venv / "bin" / "python"
    r = subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", str(ROOT)],
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    where = subprocess.run([str(py), "-c", "import hacgear_core; print(hacgear_core.__file__)"], cwd=base,
                           capture_output=True, text=True, env=env, check=True).stdout.strip()
    assert where.startswith(str(venv)), where
    return {"python": py, "hacgear": venv / "bin" / "hacgear", "base": base, "env": env}


def test_hacgear_fmu_builds_from_an_installed_wheel(wheel_env):
    """`hacgear fmu SYSTEM` of a wheel install, run outside the checkout, writes a valid FMU into ./dist; the
    checkout's build_fmu.py run with that Python uses the installed package (the source tree lacks the mapped
    package data: it failed with ModuleNotFoundError hacgear_core.fmu.slaves)."""
    base, env = wheel_env["base"], wheel_env["env"]
    r = subprocess.run([str(wheel_env["hacgear"]), "fmu", "spur_28t_asym", "--fmi", "2", "--no-compiled-code"],
                       cwd=base, capture_output=True, text=True, env=env, timeout=900)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    fmu = base / "dist" / "spur_28t_asym.fmu"
    assert fmpy.read_model_description(str(fmu)).modelName == "spur_28t_asym"
    r = subprocess.run([str(wheel_env["python"]), str(ROOT / "build_fmu.py"), "--system", "spur_28t_asym", "--fmi",
                        "3", "--no-compiled-code", "--out", str(base / "d3")], cwd=ROOT, capture_output=True,
                       text=True, env=env, timeout=900)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert fmpy.read_model_description(str(base / "d3" / "spur_28t_asym_fmi3.fmu")).fmiVersion == "3.0"
    wheel_env["fmu"] = fmu


def test_check_names_the_package_it_needs(wheel_env, monkeypatch):
    """Without fmu-manipulation-toolbox, --check reports a problem that names the package and the extra to
    install (it was a raw 'Error while finding module specification')."""
    fmu = wheel_env.get("fmu") or pytest.skip("needs the FMU of the wheel test")
    real = cli_fmu.importlib.util.find_spec
    monkeypatch.setattr(cli_fmu.importlib.util, "find_spec",
                        lambda name, *a: None if name == "fmu_manipulation_toolbox" else real(name, *a))
    problems = cli_fmu.validate_fmu(fmu)
    assert problems == [cli_fmu.FMUTOOL_MISSING]
    assert "pip install \"hacgear[check]\"" in problems[0] and "fmu-manipulation-toolbox" in problems[0]
    monkeypatch.undo()
    assert cli_fmu.validate_fmu(fmu) == []


def test_named_folder_without_tables_and_unknown_model(tmp_path, capsys):
    from hacgear_core.cli import main
    (tmp_path / "m" / "p").mkdir(parents=True)
    (tmp_path / "m" / "p" / "model.toml").write_bytes((ROOT / "models" / "spur_50t_icr18" / "model.toml").read_bytes())
    assert main(["fmu", str(tmp_path / "m" / "p"), "--out", str(tmp_path / "d")]) == 1
    assert "skipped, no tables.h5 (run `hacgear statics" in capsys.readouterr().err
    assert main(["fmu", "no_such_system"]) == 2
    assert "model file not found: 'no_such_system'" in capsys.readouterr().err
