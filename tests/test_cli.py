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
