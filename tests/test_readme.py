"""The README's commands run as written: every `hacgear` and `build_fmu.py` command of its shell blocks parses with
today's options, and the cheap ones run (a fresh clone's `hacgear statics spur_28t_asym` found the committed table
stale and exited 2)."""
from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from hacgear_core.cli import build_parser, main

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _commands() -> list[list[str]]:
    """Every `hacgear ...` / `python build_fmu.py ...` command in the README's ```bash blocks (split at &&, without
    comments), as argument lists after the program name, `build_fmu.py` as `hacgear fmu`."""
    out = []
    for block in re.findall(r"```bash\n(.*?)```", README, flags=re.S):
        for line in block.splitlines():
            for part in line.split("&&"):
                words = shlex.split(part, comments=True)
                if words[:1] == ["hacgear"]:
                    out.append(words[1:])
                elif words[:2] == ["python", "build_fmu.py"]:
                    out.append(["fmu", *words[2:]])
    return out


def test_the_readme_has_its_commands():
    names = [c[0] for c in _commands()]
    assert {"demo", "statics", "fmu", "study", "plot"} <= set(names), names


@pytest.mark.parametrize("argv", _commands(), ids=lambda a: " ".join(a))
def test_every_readme_command_parses(argv):
    args = build_parser(argv[0]).parse_args(argv)
    assert callable(args.func)


def test_statics_of_the_default_model_finds_its_committed_table(capsys):
    """The FMU recipe's first line: the committed table matches what the code would make, so there is nothing to
    do (exit 0), not 'made with other settings' (exit 2)."""
    assert ["statics", "spur_28t_asym"] in _commands()
    assert main(["statics", "spur_28t_asym"]) == 0
    out = capsys.readouterr()
    assert "already complete for these settings; nothing to do" in out.out
    # the step before any progress bar says what it does (helical_28_33 was silent for 90 s there)
    assert out.err.startswith("hacgear statics: building the contact solvers of 2 mesh side(s) (m12, m12/coast)")
