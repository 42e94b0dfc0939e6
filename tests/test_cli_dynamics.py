"""Tests of the dynamics subcommands (hacgear_core.cli.modes, .sweep, .simulate): JSON, user errors, table checks."""
from __future__ import annotations

import json
import shutil

import numpy as np

from hacgear_core.cli import main
from hacgear_core.model import resolve_model_path


def _cli(argv, capsys):
    rc = main(argv)
    out = capsys.readouterr().out
    return rc, (json.loads(out) if "--json" in argv and rc == 0 else out)


def test_cli_modes_and_sweep_json(capsys, tmp_path):
    rc, d = _cli(["modes", "synthetic:28t", "--torque", "300", "--json", "--no-impulse"], capsys)
    assert rc == 0 and d["synthetic_table"] is True
    f = d["natural_frequencies_Hz"]
    assert f == sorted(f) and len(f) == 1 and 2000 < f[0] < 3500
    assert d["bearing_stiffness_N_per_m"] == {"pinion": "inf", "wheel": "inf"}
    rc, d = _cli(["modes", "synthetic:28t", "--json", "--no-impulse", "--bearing-stiffness", "200e6"], capsys)
    assert len(d["natural_frequencies_Hz"]) == 3 and len(d["mode_shapes"]["shapes"][0]) == 4
    out = str(tmp_path / "r.h5")
    rc, d = _cli(["sweep", "synthetic:28t", "--torque", "100", "--fm", "1500:2500:3", "--direction", "up",
                  "--json", "--no-progress", "--out", out], capsys)
    assert rc == 0 and d["computed_speeds"] == {"up": 3}
    assert d["branches"]["up"]["mesh_frequency_Hz"] == [1500.0, 2000.0, 2500.0]
    assert len(d["branches"]["up"]["meshes"]["m12"]["rms_deflection_m"]) == 3
    rc, d = _cli(["sweep", "synthetic:28t", "--torque", "100", "--fm", "1500:2500:3", "--direction", "up",
                  "--json", "--no-progress", "--out", out], capsys)
    assert d["computed_speeds"] == {"up": 0}


def test_cli_user_errors_are_reported_without_traceback(capsys):
    assert main(["sweep", "synthetic:28t", "--torque", "100", "--fm", "1:x:2"]) == 2
    assert "START:STOP:N" in capsys.readouterr().err
    assert main(["modes", "synthetic:29t", "--torque", "100"]) == 2
    assert "synthetic:28t" in capsys.readouterr().err
    assert main(["modes", "synthetic:28t", "--torque", "0"]) == 2
    assert "torque_Nm [N*m]" in capsys.readouterr().err
    assert main(["modes", "synthetic:28t", "--torque", "-5"]) == 2  # the coast flanks: drive-only tables
    assert "coast" in capsys.readouterr().err


def test_cli_simulate_reports_extremes_with_sign_and_checks_the_output_path(capsys, tmp_path):
    rc = main(["simulate", "synthetic:28t", "--fm", "1000", "--cycles", "20", "--out", str(tmp_path / "no" / "x.csv")])
    assert rc == 2 and "does not exist" in capsys.readouterr().err
    out = tmp_path / "t.csv"
    rc, d = _cli(["simulate", "synthetic:28t", "--fm", "1000", "--cycles", "40", "--record-cycles", "28",
                  "--json", "--out", str(out)], capsys)
    assert rc == 0
    for v in d["extreme_strain"].values():
        assert v == v and abs(v) > 0
    header = out.read_text().splitlines()[0].split(",")
    assert "m12.deflection_m" in header and "m12.dynamic_transmission_error_m" not in header  # rigid: same column
    strain_cols = [i for i, h in enumerate(header) if h.startswith("strain[")]
    raw = np.loadtxt(out, delimiter=",", skiprows=1)
    for i in strain_cols:
        g = header[i][7:-1]
        k = int(np.argmax(np.abs(raw[:, i])))
        assert d["extreme_strain"][g] == raw[k, i]


def test_cli_refuses_a_table_of_another_model_unless_overridden(tmp_path, capsys):
    """A table made from another model file is refused with the regenerate command; the expert override uses a
    table of an edited model file, but a table of a different gear pair stays refused.  Editing the damping does
    not touch the tables: no override needed."""
    root = resolve_model_path("spur_28t_asym").parent.parent
    other = str(root / "spur_50t_icr137" / "tables.h5")
    assert main(["modes", "spur_28t_asym", "--tables", other]) == 2
    err = capsys.readouterr().err
    assert "does not belong to" in err and "hacgear statics" in err and "Traceback" not in err
    assert main(["modes", "spur_28t_asym", "--tables", other, "--ignore-model-hash"]) == 2
    assert "teeth (50, 50) differ from the model's (28, 28)" in capsys.readouterr().err
    edited = tmp_path / "model.toml"
    text = (root / "spur_28t_asym" / "model.toml").read_text()
    edited.write_text(text.replace("modal_damping_ratio = 0.02", "modal_damping_ratio = 0.03"))
    shutil.copy(root / "spur_28t_asym" / "tables.h5", tmp_path / "tables.h5")
    assert main(["modes", str(edited), "--json"]) == 0
    capsys.readouterr()
    edited.write_text(text.replace("hob_tip_radius_mm = 0.4", "hob_tip_radius_mm = 0.5", 1))
    assert main(["modes", str(edited)]) == 2
    assert "gears.pinion.hob_tip_radius_m: 0.0004 in the table, 0.0005 now" in capsys.readouterr().err
    assert main(["modes", str(edited), "--ignore-model-hash", "--json"]) == 0


def test_sweep_killed_leaves_no_workers_and_rerun_reuses_its_rows(tmp_path):
    """`hacgear sweep --workers 2 --out` SIGKILLed (main process only) mid-run: the branch workers end by
    themselves; the same command run again reuses the finished speeds and says so; --fresh recomputes them."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    import h5py
    import pytest

    from _procs import session_processes, wait_for_no_orphans

    if not Path("/proc/self/stat").exists():
        pytest.skip("needs Linux /proc")
    out = tmp_path / "r.h5"
    cmd = [sys.executable, "-c", "import sys; from hacgear_core.cli import main; sys.exit(main())", "sweep",
           "synthetic:28t", "--torque", "300", "--fm", "1200:3600:60", "--direction", "both", "--workers", "2",
           "--no-progress", "--out", str(out)]
    proc = subprocess.Popen(cmd, cwd=tmp_path, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    parts = tmp_path / "r.h5.parts"
    rows = {}
    workers = []
    t0 = time.monotonic()
    try:
        while time.monotonic() - t0 < 120 and proc.poll() is None:
            time.sleep(0.05)
            files = sorted(parts.glob("*.h5")) if parts.exists() else []
            try:
                for fp in files:
                    with h5py.File(fp, "r", locking=False) as f:
                        rows[fp.name] = int(f.attrs.get("rows", 0))
            except (OSError, KeyError):
                continue
            if len(rows) == 2 and min(rows.values()) >= 3:
                workers = [p for p, _ in session_processes(proc.pid) if p != proc.pid]
                os.kill(proc.pid, signal.SIGKILL)
                break
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        orphans = wait_for_no_orphans(proc.pid)
    assert proc.returncode == -signal.SIGKILL, proc.stderr.read().decode()
    assert len(workers) >= 2 and not orphans, f"workers {workers}, left behind: {orphans}"
    stored = {}
    for fp in parts.glob("*.h5"):
        with h5py.File(fp, "r") as f:
            stored[str(f.attrs["branch"])] = int(f.attrs["rows"])
    assert len(stored) == 2 and min(stored.values()) >= 3
    res = subprocess.run(cmd[:-5] + ["--workers", "1", "--no-progress", "--out", str(out)], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    for b, n in stored.items():
        assert f"branch {b} ({60 - n} speeds computed now, {n} reused from {out}" in res.stdout, res.stdout[:2000]
    fresh = subprocess.run(cmd[:-5] + ["--workers", "1", "--no-progress", "--out", str(out), "--fresh", "--json"],
                           cwd=tmp_path, capture_output=True, text=True, timeout=300)
    d = json.loads(fresh.stdout)
    assert d["computed_speeds"] == {"up": 60, "down": 60} and d["discarded_speeds"] == {"up": 60, "down": 60}


def test_sweep_table_has_no_duplicate_columns(capsys):
    """With rigid bearings the dynamic transmission error equals the mesh deflection: the text table shows it
    once; with bearing stiffness the DTE column appears and differs."""
    assert main(["sweep", "synthetic:28t", "--torque", "300", "--fm", "1500:2500:3", "--direction", "up",
                 "--no-progress"]) == 0
    rigid = capsys.readouterr().out
    header = next(line for line in rigid.splitlines() if "f_m [Hz]" in line)
    assert "DTE" not in header and header.count("rms") == 1
    assert main(["sweep", "synthetic:28t", "--torque", "300", "--fm", "1500:2500:3", "--direction", "up",
                 "--no-progress", "--bearing-stiffness", "200e6"]) == 0
    lines = capsys.readouterr().out.splitlines()
    i = next(k for k, line in enumerate(lines) if "f_m [Hz]" in line)
    assert "DTE rms" in lines[i]
    rows = [line.split() for line in lines[i + 1:i + 4]]
    assert any(abs(float(r[1]) - float(r[3])) > 1e-3 for r in rows), rows  # rms x and DTE rms differ


def test_simulate_beyond_the_tables_says_so(capsys):
    """A torque 100 x the nominal one drives the state past the tables' deflection grid: the run is reported with a
    warning counting the steps and naming the remedy, and the JSON carries the count."""
    assert main(["simulate", "spur_28t_asym", "--torque", "30000", "--fm", "1000", "--cycles", "12"]) == 0
    err = capsys.readouterr().err
    assert "left the tables' deflection range in m12" in err and "max_torque_factor" in err
    assert main(["simulate", "spur_28t_asym", "--torque", "30000", "--fm", "1000", "--cycles", "12", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["meshes"]["m12"]["steps_beyond_tables"] > 0
    assert main(["simulate", "spur_28t_asym", "--torque", "300", "--fm", "1000", "--cycles", "12", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["meshes"]["m12"]["steps_beyond_tables"] == 0


def test_simulate_with_the_coast_flanks_loaded_reports_them(capsys):
    """A negative torque loads the coast flanks: the summary's contact loss and contact pressure are those of the
    loaded (coast) flanks — no contact loss off resonance, the coast table's pressure — not the idle drive
    flanks' (always apart, zero pressure)."""
    assert main(["simulate", "spur_28t_asym", "--torque", "-300", "--fm", "1000", "--cycles", "12", "--json"]) == 0
    s = json.loads(capsys.readouterr().out)["meshes"]["m12"]
    assert s["loaded_flank"] == "coast" and s["contact_loss_fraction"] == 0.0
    assert s["peak_force_N"] == 0.0 and s["coast_contact_fraction"] == 1.0
    assert 0.5e9 < s["max_peak_pressure_Pa"] < 3e9
    assert main(["simulate", "spur_28t_asym", "--torque", "300", "--fm", "1000", "--cycles", "12", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)["meshes"]["m12"]
    assert d["loaded_flank"] == "drive" and d["contact_loss_fraction"] == 0.0 and d["peak_coast_force_N"] == 0.0


def test_sweep_stability_column_and_json(capsys):
    """``--stability``: every speed's largest Floquet multiplier, in the text table and in the JSON (< 1: the
    orbits of a damped pair under load are stable)."""
    rc, d = _cli(["sweep", "synthetic:28t", "--torque", "300", "--fm", "1500:2500:3", "--direction", "up",
                  "--json", "--no-progress", "--stability"], capsys)
    assert rc == 0
    mu = d["branches"]["up"]["max_multiplier"]
    assert len(mu) == 3 and all(0 < v < 1 for v in mu)
    assert main(["sweep", "synthetic:28t", "--torque", "300", "--fm", "1500:2500:3", "--direction", "up",
                 "--no-progress", "--stability"]) == 0
    lines = capsys.readouterr().out.splitlines()
    i = next(k for k, line in enumerate(lines) if "f_m [Hz]" in line)
    assert "|mu|max" in lines[i]
    assert [float(line.split()[-1]) for line in lines[i + 1:i + 4]] == [round(v, 4) for v in mu]


def test_compile_notices_go_to_stderr_not_into_json(monkeypatch, capsys):
    """A compile notice of the library (the COMPILE_LOGGER logger) is printed on stderr, prefixed with the command,
    while --json stdout stays pure JSON; the CLI's handler is gone after the command returns."""
    import logging

    import hacgear_core.cli.info as info_cli
    from hacgear_core.dynamics.kernels import COMPILE_LOGGER

    def fake_run(args):
        logging.getLogger(COMPILE_LOGGER).info("compiling the integration kernel for 2 DOF x 1 mesh (test)")
        print(json.dumps({"ok": 1}))
        return 0

    monkeypatch.setattr(info_cli, "run", fake_run)
    logger = logging.getLogger(COMPILE_LOGGER)
    before = list(logger.handlers)
    assert main(["info", "spur_28t_asym", "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out) == {"ok": 1}
    assert err == "hacgear info: compiling the integration kernel for 2 DOF x 1 mesh (test)\n"
    assert logger.handlers == before
    logging.getLogger(COMPILE_LOGGER).info("after the command: silent")
    assert capsys.readouterr() == ("", "")
    # a command run inside another (demo's stages) prints each notice once, through the outer command's handler
    monkeypatch.setattr(info_cli, "run", lambda a: fake_run(a) if a.json else main(["info", "spur_28t_asym",
                                                                                        "--json"]))
    assert main(["info", "spur_28t_asym"]) == 0
    assert capsys.readouterr().err == "hacgear info: compiling the integration kernel for 2 DOF x 1 mesh (test)\n"
    assert logger.handlers == before


def test_stiffness_shows_its_stages_on_stderr(capsys):
    """hacgear stiffness says on stderr what it is doing before each long stage of each mesh; stdout stays JSON."""
    assert main(["stiffness", "spur_28t_asym", "--positions", "4", "--json"]) == 0
    out, err = capsys.readouterr()
    assert len(json.loads(out)["meshes"]["m12"]["ste_m"]) == 4
    assert err.splitlines() == ["hacgear stiffness: mesh m12: building the finite-element model of its gears",
                                "hacgear stiffness: mesh m12: static contact at 4 mesh positions"]
