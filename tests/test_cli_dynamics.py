"""Tests of the dynamics subcommands (hacgear_core.cli.modes, .sweep, .simulate): JSON, user errors, table checks."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from hacgear_core.cli import main
from hacgear_core.model import resolve_model_path
from hacgear_core.response import static_strain_max
from hacgear_core.tables import load_system_tables


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
    assert main(["modes", "synthetic:28t", "--torque", "0"]) == 2  # the option, its value and range
    assert "--torque [N*m] = 0.0 is out of range; allowed: magnitude (0, 1e+08], either sign" in capsys.readouterr().err
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
    assert "left the tables' range (deflection, and twist for helical meshes) in m12" in err and "max_torque_factor" in err
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
    assert s["peak_back_side_force_N"] == 0.0 and s["back_side_contact_fraction"] == 0.0 and s["min_force_N"] > 0
    assert 0.5e9 < s["max_peak_pressure_Pa"] < 3e9
    assert main(["simulate", "spur_28t_asym", "--torque", "300", "--fm", "1000", "--cycles", "12", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)["meshes"]["m12"]
    assert d["loaded_flank"] == "drive" and d["contact_loss_fraction"] == 0.0 and d["peak_back_side_force_N"] == 0.0


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


def test_simulate_reports_the_root_strain_of_a_tooth_passing_through_the_mesh(capsys):
    """The issue's command: every gauge reports the strain of the last tooth whose whole passage was recorded (not
    tooth 0, which is out of mesh at the end of 400 cycles of a 28-tooth gear), with the tooth, its mesh cycles and
    time window, the static strain at the same torque and the dynamic factor; the static peaks agree with the
    table's own static strain (response.static_strain_max); a run too short for a passage says so instead of
    printing a zero."""
    argv = ["simulate", "spur_28t_asym", "--torque", "300", "--fm", "2500"]
    rc, d = _cli(argv + ["--json"], capsys)
    assert rc == 0 and d["recorded_samples"] == 4 * 128
    table = load_system_tables(resolve_model_path("spur_28t_asym")).meshes["m12"]
    sm = static_strain_max(table, 300.0 / float(table.base_radius_m[0]))
    assert set(d["root_strain"]) == {"pinion/SG20", "pinion/SG25", "wheel/SG20", "wheel/SG25"}
    for g, s in d["root_strain"].items():
        assert s["recorded"] and 0 <= s["tooth"] < 28 and s["tooth"] != 0
        c0, c1 = s["mesh_cycles"]
        assert 390 <= c0 < c1 <= 400 and c1 - c0 in (5.0, 6.0)         # one passage, in the last cycles
        assert s["time_s"][0] == pytest.approx(c0 / 2500.0, rel=1e-3) and s["time_s"][1] <= 400 / 2500.0
        assert s["extreme"] == d["extreme_strain"][g] and s["extreme"] in (s["min"], s["max"])
        assert abs(s["extreme"]) > 500e-6 and np.sign(s["extreme"]) == np.sign(s["static_extreme"])
        assert s["dynamic_factor"] == pytest.approx(s["extreme"] / s["static_extreme"])
        assert 1.0 < s["dynamic_factor"] < 2.0
        assert s["static_max"] == pytest.approx(sm[g], rel=0.01, abs=2e-6)    # table gauge names = system's
    rc, out = _cli(argv, capsys)
    assert rc == 0 and "+0.0 µε" not in out and "tooth " in out and "static " in out
    for g, s in d["root_strain"].items():   # the factor's peak is printed beside it, named by its side
        assert (f"    {g}: {s['factor_side']} peak {s['peak_on_static_side'] * 1e6:+.1f} µε (static "
                f"{s['static_extreme'] * 1e6:+.1f} µε, factor {s['dynamic_factor']:.3f})") in out
    rc, d = _cli(argv + ["--cycles", "5", "--json"], capsys)
    need = d["root_strain"]["wheel/SG25"]["cycles_needed"]
    # the coast pairs -1..3 of the tables (drive -2..2) widen the passage window by one cycle: 8 (was 7 with -2..2)
    assert rc == 0 and need == 8 and d["extreme_strain"]["wheel/SG25"] is None
    rc, out = _cli(argv + ["--cycles", "5"], capsys)
    assert f"not recorded: a tooth's passage takes {need} mesh cycles; give --cycles >= {need}" in out


#: every shipped kind; the helical pair joins once its committed table has a coast side (skipped until then)
REVERSED_KINDS = ["spur_28t_asym", "idler_28_33_39", "planetary_65_55_175", "helical_28_33"]


def _reversed_system(system):
    """(model, two-sided tables or None, the library's system at the reversed model torque)."""
    from hacgear_core.kinds import build_system
    from hacgear_core.kinds import load_model
    from hacgear_core.tables import load_system_tables

    model = load_model(system)
    tabs = load_system_tables(system)
    if not all(t.coast is not None for t in tabs.meshes.values()):
        return model, None, None
    return model, tabs, build_system(model, tabs, torque_Nm=-model.operating.torque_Nm)


@pytest.mark.parametrize("system", REVERSED_KINDS)
def test_simulate_reversed_torque_on_every_kind(system, capsys, tmp_path):
    """``hacgear simulate SYSTEM --torque -T`` (T the model's torque) at 1000 Hz: every mesh rests on its coast
    flanks the whole time (drive force 0, coast contact 100 %), its mean drive deflection lies within
    [-(backlash + coast table range), 0) and no step leaves the tables; the recorded mean coast force is the static
    coast force of the torque flow (3 %: the planets' instantaneous load sharing, 2.4 %), the peak at least that."""
    model, tabs, sy = _reversed_system(system)
    if tabs is None:
        pytest.skip(f"the committed {system} table is one-sided (no coast side)")
    torque = -model.operating.torque_Nm
    trace = tmp_path / "trace.csv"
    assert main(["simulate", system, "--torque", f"{torque:g}", "--fm", "1000", "--cycles", "12", "--json",
                 "--out", str(trace)]) == 0
    d = json.loads(capsys.readouterr().out)
    tr = np.genfromtxt(trace, delimiter=",", names=True, deletechars="")
    assert d["torque_Nm"] == torque
    nominal = dict(zip(sy.mesh_names, sy.nominal_coast_forces_N()))
    for k, c in enumerate(sy.meshes):
        s = d["meshes"][c.name]
        assert s["loaded_flank"] == "coast" and s["peak_back_side_force_N"] == 0.0 and s["contact_loss_fraction"] == 0.0
        assert s["steps_beyond_tables"] == 0
        assert -(c.backlash_m + np.ptp(c.coast_table.deflection_m)) <= s["mean_deflection_m"] < 0.0, c.name
        fc = tr[f"{c.name}.coast_force_N"]
        assert np.mean(fc) == pytest.approx(nominal[c.name], rel=0.03), c.name
        assert s["peak_force_N"] == pytest.approx(fc.max(), rel=1e-6)
        assert fc.max() >= 0.97 * nominal[c.name]


def test_modes_with_the_coast_flanks_loaded(capsys):
    """``hacgear modes --torque -T``: the linearisation and the impulse test about the coast flanks (the impulse
    test's contact positions from the coast table at the coast force; it asked the drive table at force 0)."""
    rc, d = _cli(["modes", "spur_28t_asym", "--torque", "-300", "--json"], capsys)
    assert rc == 0
    f = d["natural_frequencies_Hz"][0]
    imp = d["impulse_test"]
    assert imp["single_contact_Hz"] and abs(imp["single_contact_Hz"][0] / f - 1) < 0.1


def test_simulate_helical_reversed_drive_torques_loads_the_coast_flanks(capsys):
    """Issue 36: `hacgear simulate helical_28_33 --drive-torques=-200,235.7` drives the helical pair on its coast
    flanks: they carry the load in every recorded sample, the mean deflection stays within the backlash plus the
    coast table's range (here: x = -xc times the ratio of the lever arms, 20 % allowance for tilts and bearings);
    the impact of the first crossing of the backlash overshoots the coast table for a few steps, which the summary
    counts (measured: 6 steps)."""
    from hacgear_core.tables import load_system_tables

    argv = ["simulate", "helical_28_33", "--drive-torques=-200,235.7", "--fm", "1200", "--cycles", "24",
            "--record-cycles", "8", "--json"]
    rc = main(argv)
    cap = capsys.readouterr()
    assert rc == 0
    m = json.loads(cap.out)["meshes"]["m12"]
    assert m["loaded_flank"] == "coast" and m["contact_loss_fraction"] == 0.0 and 0 < m["steps_beyond_tables"] < 20
    t = load_system_tables(resolve_model_path("helical_28_33")).mesh("m12")
    ct = t.coast
    ratio = float(t.twist.lever_arm_m[0]) / float(ct.twist.lever_arm_m[0])
    contact = ct.backlash_normal_m * np.cos(ct.twist.base_helix_angle_rad)     # coast approach at first contact
    assert -1.2 * ratio * ct.deflection_m[-1] < m["mean_deflection_m"] < -ratio * contact
    assert ct.deflection_m[0] < m["mean_coast_approach_m"] < ct.deflection_m[-1]


def test_simulate_helical_beyond_the_coast_table_warns_once(capsys):
    """-2000 N*m (ten times the nominal torque, reversed) drives the coast approach beyond the coast table: the
    summary counts the steps and one WARNING names the mesh and both grids."""
    rc = main(["simulate", "helical_28_33", "--torque", "-2000", "--fm", "1200", "--cycles", "6", "--record-cycles",
               "2"])
    err = capsys.readouterr().err
    assert rc == 0
    assert err.count("WARNING: the state left the tables' range") == 1 and "m12:" in err and "coast grid" in err
    # a pressure read at states beyond the tables is extrapolated, and its warning says so
    assert all("extrapolated" in line for line in err.splitlines() if "contact pressure" in line)


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
    """hacgear stiffness says on stderr what it is doing before each long stage of each mesh and, on a stderr that
    is no terminal, how many positions are solved at each quarter; stdout stays JSON."""
    assert main(["stiffness", "spur_28t_asym", "--positions", "8", "--json"]) == 0
    out, err = capsys.readouterr()
    assert len(json.loads(out)["meshes"]["m12"]["ste_m"]) == 8
    assert err.splitlines() == ["hacgear stiffness: mesh m12: building the finite-element model of its gears",
                                "hacgear stiffness: mesh m12: static contact at 8 mesh positions",
                                "hacgear stiffness: 2 of 8 positions solved",
                                "hacgear stiffness: 4 of 8 positions solved",
                                "hacgear stiffness: 6 of 8 positions solved"]


def test_simulate_drive_only_helical_table_flags_the_backlash_crossing(capsys, tmp_path):
    """A drive-only helical table (the committed one without its coast side): `simulate --drive-torques=-200,235.7`
    drives the teeth across the backlash with no coast flanks to stop them; the summary counts the steps beyond it
    (many more than the two-sided table's few impact steps, 6), the flanks carry nothing in the recorded cycles and
    one WARNING names the mesh, the backlash and the fix; exit 0 as for any out-of-range run."""
    from _dyn import drive_only_copy

    folder = drive_only_copy("helical_28_33", tmp_path)
    argv = ["simulate", str(folder), "--drive-torques=-200,235.7", "--fm", "1200", "--cycles", "24",
            "--record-cycles", "8", "--json"]
    assert main(argv) == 0
    m = json.loads(capsys.readouterr().out)["meshes"]["m12"]
    assert m["steps_beyond_tables"] > 100 and m["contact_loss_fraction"] == 1.0 and m["peak_back_side_force_N"] == 0.0
    assert 390e-6 < m["backlash_m"] < 400e-6     # j_n cos(beta_bc) = 406.9 um x cos 14.13 deg = 394.5 um
    assert main(argv[:-1]) == 0
    err = capsys.readouterr().err
    assert err.count("WARNING") == 1 and "m12:" in err and "no coast table: beyond the backlash (394.5 µm" in err
    assert "hacgear statics" in err


def test_cli_sweep_batched_option_reaches_run_sweeps(capsys, monkeypatch):
    """``--batched auto|on|off`` maps to ``run_sweeps(batched=None|True|False)`` (the lanes' equality with the
    serial sweeps is tests/test_batch.py's); a value outside the three is refused by the parser."""
    import hacgear_core.cli.sweep as cli_sweep

    seen = []
    real = cli_sweep.run_sweeps

    def spy(specs, **kw):
        seen.append(kw["batched"])
        return real(specs, **{**kw, "batched": False})

    monkeypatch.setattr(cli_sweep, "run_sweeps", spy)
    argv = ["sweep", "synthetic:28t", "--torques", "100,200", "--fm", "1500:2500:2", "--json", "--no-progress"]
    outs = []
    for opt in ([], ["--batched", "on"], ["--batched", "off"]):
        rc, d = _cli(argv + opt, capsys)
        assert rc == 0
        outs.append(d)
    assert seen == [None, True, False]
    assert outs[0] == outs[1] == outs[2]
    with pytest.raises(SystemExit):
        main(argv + ["--batched", "yes"])
    assert "invalid choice" in capsys.readouterr().err


def test_strain_factor_is_shown_beside_the_peak_it_divides():
    """The idler's gear2/SG20 printed '+1802.0 µε (static −1580.4 µε, factor 1.100)': the factor compares the
    compression peaks, the number beside it was the tension peak.  The summary now carries the peak on the static
    extreme's side, and the text names the other side's larger peak separately."""
    from hacgear_core.cli.simulate import _passage_summary
    from hacgear_core.dynamics.simulator import GaugePassage
    dyn = GaugePassage("gear2/SG20", 3, (10.0, 12.0), (0.0, 1e-3), np.array([-1738.4e-6, 0.0, 1802.0e-6]))
    sta = GaugePassage("gear2/SG20", 3, (10.0, 12.0), None, np.array([-1580.4e-6, 0.0, 1200.0e-6]))
    s = _passage_summary(dyn, sta, 2)
    assert s["extreme"] == pytest.approx(1802.0e-6) and s["factor_side"] == "compression"
    assert s["peak_on_static_side"] == pytest.approx(-1738.4e-6)
    assert s["dynamic_factor"] == pytest.approx(1738.4 / 1580.4)


def test_simulate_tells_tip_edge_from_flank_pressure(capsys):
    """The idler at 2000 Hz reported 10.3 GPa 'max contact pressure' without a word; it is a tip-edge contact (a
    tip corner on the mating flank, its value set by the 0.1 mm edge radius), while the flanks carry under 2 GPa:
    both are reported apart, the peak is the larger, and the edge is named in a WARNING."""
    rc, d = _cli(["simulate", "idler_28_33_39", "--fm", "2000", "--json"], capsys)
    assert rc == 0
    for m, s in d["meshes"].items():
        assert s["max_peak_pressure_Pa"] == pytest.approx(max(s["max_flank_pressure_Pa"], s["max_edge_pressure_Pa"]))
        assert s["max_flank_pressure_Pa"] < 2.5e9, m
    m12 = d["meshes"]["m12"]
    assert m12["max_edge_pressure_Pa"] > 5e9 and 0 < m12["edge_contact_fraction"] < 0.5
    assert main(["simulate", "idler_28_33_39", "--fm", "2000"]) == 0
    out = capsys.readouterr()
    assert "max flank (Hertzian) contact pressure" in out.out and "tip-edge contact" in out.out
    assert "WARNING: mesh m12: tip-edge contact at" in out.err and "set by the edge radius" in out.err
