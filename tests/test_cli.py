"""The command-line interface as a whole (hacgear_core.cli, hacgear_core/outpaths.py): help texts that match behaviour,
output paths checked before any work."""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hacgear_core.cli import build_parser, main
from hacgear_core.cli._commands import COMMANDS
from hacgear_core.model import shipped_systems
from hacgear_core.outpaths import check_out_dir, check_out_path
from hacgear_core.errors import HacgearError


def _subcommands():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices


@pytest.mark.parametrize("command", sorted(_subcommands()))
def test_help_states_defaults_and_never_a_default_for_a_required_option(command):
    """Every option with a default says so in its help; a required option never claims one (`modes --torque`
    used to say 'default: ...' while being required)."""
    p = _subcommands()[command]
    for a in p._actions:
        if isinstance(a, (argparse._HelpAction, argparse._StoreTrueAction, argparse._StoreFalseAction)) \
                or not a.option_strings:
            continue
        text = (a.help or "").lower()
        assert a.help, f"{command} {a.option_strings[0]}: no help text"
        if a.required:
            assert "default" not in text, f"{command} {a.option_strings[0]} is required but its help names a default"
        elif a.default is not None and a.default is not argparse.SUPPRESS:
            assert "default" in text, f"{command} {a.option_strings[0]}: default {a.default!r} not stated in the help"


@pytest.mark.parametrize("argv, suffix", [
    (["simulate", "synthetic:28t", "--fm", "1000", "--cycles", "100000"], "x.csv"),
    (["sweep", "synthetic:28t", "--fm", "500:4500:4000"], "r.h5"),
    (["statics", "spur_28t_asym", "--solver", "analytic", "--workers", "1"], "t.h5"),
    (["plot", "models/spur_28t_asym/tables.h5"], "f.png"),
    (["plot-geometry", "spur_28t_asym"], "g.png"),
])
def test_output_path_checked_before_any_work(argv, suffix, tmp_path, capsys):
    """A missing output folder is reported at once (before a long run), naming the option."""
    root = Path(__file__).resolve().parent.parent
    argv = [str(root / a) if a.startswith("models/") else a for a in argv]
    t0 = time.perf_counter()
    rc = main(argv + ["--out", str(tmp_path / "missing" / suffix)])
    err = capsys.readouterr().err
    assert rc == 2 and "--out" in err and "does not exist" in err, err
    assert time.perf_counter() - t0 < 10.0


def test_demo_checks_its_output_folder(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    assert main(["demo", "--out", str(tmp_path / "file")]) == 2
    assert "is a file; give a folder" in capsys.readouterr().err


def test_path_checks(tmp_path):
    assert check_out_path(tmp_path / "a.png", suffixes=(".png",)) == tmp_path / "a.png"
    with pytest.raises(HacgearError, match="must end in .csv or .npz"):
        check_out_path(tmp_path / "a.txt", suffixes=(".csv", ".npz"))
    with pytest.raises(HacgearError, match="is a folder"):
        check_out_path(tmp_path)
    assert check_out_dir(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"  # created later by the command
    (tmp_path / "f").write_text("")
    with pytest.raises(HacgearError, match="cannot be created"):
        check_out_dir(tmp_path / "f" / "sub")


@pytest.mark.parametrize("module, argv", [
    ("hacgear_core.plots.tables", []),
    ("hacgear_core.plots.validation", []),
])
def test_module_entry_points_write_only_where_told(module, argv, tmp_path):
    """`python -m hacgear_core.plots.*` need an output folder and refuse one that cannot be made; nothing is
    written into the checkout (docs/ used to be the default)."""
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", module, *argv], cwd=tmp_path, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 2 and "--out" in r.stderr, r.stderr
    (tmp_path / "f").write_text("")
    r = subprocess.run([sys.executable, "-m", module, *argv, "--out", str(tmp_path / "f" / "x")], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "cannot be created" in r.stderr, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]


def test_top_level_help_loads_no_library():
    """`hacgear --help` imports neither the library's numerics nor numba, scipy or matplotlib (it took 2.5 s of
    CPU importing every command's module); each command is listed with its one-line help."""
    code = ("import sys\nfrom hacgear_core.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "heavy = sorted(m for m in ('numba', 'scipy', 'matplotlib', 'h5py', 'hacgear_core.dynamics', "
            "'hacgear_core.statics') if m in sys.modules)\nprint('HEAVY', heavy)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "HEAVY []" in r.stdout
    for name, (_, one_line) in COMMANDS.items():
        assert name in r.stdout
    assert set(_subcommands()) == set(COMMANDS)


def test_each_command_is_registered_by_its_listed_module():
    """build_parser(name) registers exactly that command fully (its options), the others by name only."""
    for name in COMMANDS:
        sub = next(a for a in build_parser(name)._actions if isinstance(a, argparse._SubParsersAction))
        full = [n for n, p in sub.choices.items() if p._actions]   # the others: no options, not even -h
        assert full == [name], (name, full)


def test_list_names_every_shipped_system(capsys):
    assert main(["list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["systems"]
    assert [r["name"] for r in rows] == list(shipped_systems())
    spur = next(r for r in rows if r["name"] == "spur_28t_asym")
    assert spur["kind"] == "spur_pair" and spur["gears"] == {"pinion": 28, "wheel": 28} and spur["tables"]
    assert main(["list"]) == 0
    assert f"{len(rows)} systems in " in capsys.readouterr().out


def test_a_closed_pipe_ends_the_command_quietly():
    """`hacgear info X | head -1`: the reader is gone before the command writes; no BrokenPipeError traceback,
    nothing on stderr, SIGPIPE's exit status."""
    p = subprocess.Popen([sys.executable, "-m", "hacgear_core.cli", "info", "idler_28_33_39"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 141
    assert "Traceback" not in err and "BrokenPipe" not in err, err


ISO_STAGE = """
[system]
name = "iso_stage"
kind = "helical_pair"
[materials.steel]
density_kg_per_m3 = 7830.0
youngs_modulus_GPa = 206.0
poisson_ratio = 0.3
[[gears]]
name = "pinion"
teeth = 24
normal_module_mm = 14.0
normal_pressure_angle_deg = 20.0
helix_angle_deg = 10.0
hand = "right"
profile_shift = 0.480
tip_alteration_mm = -0.938
basic_rack = "A"
thickness_allowance_upper_mm = -0.1
thickness_allowance_lower_mm = -0.2
face_width_mm = 360.0
bore_diameter_mm = 150.0
material = "steel"
[[gears]]
name = "wheel"
teeth = 95
normal_module_mm = 14.0
normal_pressure_angle_deg = 20.0
helix_angle_deg = 10.0
hand = "left"
profile_shift = 0.669
tip_alteration_mm = -0.938
basic_rack = "A"
thickness_allowance_upper_mm = -0.1
thickness_allowance_lower_mm = -0.2
face_width_mm = 360.0
bore_diameter_mm = 400.0
material = "steel"
[[meshes]]
name = "m12"
gear_a = "pinion"
gear_b = "wheel"
center_distance_mm = 861.0
[damping]
modal_damping_ratio = 0.02
[operating]
torque_Nm = 1.0e5
"""


def test_info_reports_iso_form_gears_in_iso_terms(tmp_path, capsys):
    """`hacgear info --json` of an ISO-form model (NREL 5 MW stage 3 with thickness allowances): each gear's ISO
    block (normal and transverse), each mesh's a_w, alpha_wt, contact ratios and backlash range; the text output
    prints the same in an ISO table."""
    import math

    (tmp_path / "model.toml").write_text(ISO_STAGE)
    assert main(["info", str(tmp_path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    p = d["gears"]["pinion"]["iso"]
    assert p["form"] == "iso21771" and p["profile_shift"] == 0.48 and p["hand"] == "right"
    assert p["normal_module_m"] == 0.014 or abs(p["normal_module_m"] - 0.014) < 1e-15
    assert p["tip_alteration_m"] == -0.938e-3 or abs(p["tip_alteration_m"] + 0.938e-3) < 1e-15
    # the modelled teeth sit at the mean allowance: x_E = x + A_mean / (2 m_n tan(alpha_n))
    assert abs(p["generating_profile_shift"] - (0.48 - 0.15 / (2 * 14 * math.tan(math.radians(20))))) < 1e-12
    assert abs(p["nominal_normal_tooth_thickness_m"] - p["normal_tooth_thickness_m"] - 0.15e-3) < 1e-15
    m = d["meshes"]["m12"]["iso"]
    assert m["center_distance_m"] == 0.861
    assert m["backlash_circular_min_m"] < m["backlash_circular_m"] < m["backlash_circular_max_m"]
    assert abs(m["total_contact_ratio"] - m["transverse_contact_ratio"] - m["overlap_ratio"]) < 1e-12
    assert main(["info", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "Gears in ISO 21771 terms" in out and "iso21771" in out and "10.0000 right" in out
    assert "ISO 21771              a_w 861.0000 mm, alpha_wt" in out and "over the thickness allowances" in out


def test_info_refuses_a_set_that_cannot_mesh_naming_the_fix(tmp_path, capsys):
    """Thicker teeth (positive allowances) at the same centre distance overlap: refused, naming the gears, the key and
    the allowance that gives zero backlash; the named allowance then loads."""
    import re

    bad = ISO_STAGE.replace("thickness_allowance_upper_mm = -0.1\nthickness_allowance_lower_mm = -0.2",
                            "thickness_allowance_upper_mm = 0.1\nthickness_allowance_lower_mm = 0.0")
    (tmp_path / "model.toml").write_text(bad)
    assert main(["info", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "mesh 'm12': negative backlash" in err and "the teeth of 'pinion' and 'wheel' overlap" in err
    fix = re.search(r"thickness_allowance_upper_mm = (-?[0-9.]+) on 'pinion'", err)
    assert fix and "thickness_allowance_upper_mm of 'pinion' + 'wheel' <= " in err
    (tmp_path / "model.toml").write_text(bad.replace(
        "thickness_allowance_upper_mm = 0.1\nthickness_allowance_lower_mm = 0.0",
        f"thickness_allowance_upper_mm = {fix.group(1)}\nthickness_allowance_lower_mm = -0.2", 1))
    assert main(["info", str(tmp_path), "--json"]) == 0
    j = json.loads(capsys.readouterr().out)["meshes"]["m12"]["iso"]["backlash_circular_min_m"]
    assert 0.0 <= j < 2e-9
