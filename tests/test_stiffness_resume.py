"""`hacgear stiffness --out FILE.json` writes its result after each mesh and resumes after a kill (#51 item 5):
a process killed by SIGKILL right after its first mesh is written leaves that mesh in the file; the re-run takes it
without solving it again and ends with the file an uninterrupted run writes; a file of other inputs is refused
and kept."""
from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from hacgear_core.cli import main
from hacgear_core.model import shipped_systems_dir

ROOT = Path(__file__).resolve().parents[1]
ARGS = ["stiffness", "idler_28_33_39", "--positions", "4"]   # two meshes (m12, m23), the fewest positions allowed

# Runs `hacgear stiffness` in a child that SIGKILLs itself (no handler, no cleanup: as a kill from outside at that
# moment) either right after the result file is first replaced by its written version (after mesh m12:
# "after-first-write") or when the second version (m12 and m23) is written to the temporary file but not yet renamed
# ("before-second-rename").
_KILLED_CHILD = """
import os, signal, sys
from pathlib import Path
out, when = Path(sys.argv[1]).resolve(), sys.argv[2]
_replace, calls = os.replace, []
def replace(src, dst, *a, **k):
    if Path(dst).resolve() == out:
        calls.append(dst)
        if when == "before-second-rename" and len(calls) == 2:
            os.kill(os.getpid(), signal.SIGKILL)
    _replace(src, dst, *a, **k)
    if Path(dst).resolve() == out and when == "after-first-write":
        os.kill(os.getpid(), signal.SIGKILL)
os.replace = replace
from hacgear_core.cli import main
sys.exit(main(sys.argv[3:]))
"""


def _same(a, b, path="") -> None:
    """``a == b`` with floats equal within 1e-12 relative (the wall time ``seconds`` skipped)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), path
        for k in a:
            if k != "seconds":
                _same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{path}[{i}]")
    elif isinstance(a, float) and isinstance(b, float):
        assert math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-300), (path, a, b)
    else:
        assert a == b, path


@pytest.mark.parametrize("when", ["after-first-write", "before-second-rename"])
def test_stiffness_killed_after_the_first_mesh_resumes_without_solving_it_again(when, tmp_path, capsys):
    out = tmp_path / "idler.json"
    r = subprocess.run([sys.executable, "-c", _KILLED_CHILD, str(out), when, *ARGS, "--out", str(out)],
                       cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert r.returncode == -signal.SIGKILL, r.stderr
    assert "mesh m12: static contact" in r.stderr
    # killed before m23 started, or with m23 solved and written only to the temporary file, which the re-run
    # neither reads nor keeps
    assert ("m23" in r.stderr) == (when == "before-second-rename")
    assert (tmp_path / "idler.json.writing").exists() == (when == "before-second-rename")
    killed = json.loads(out.read_text())
    assert list(killed["meshes"]) == ["m12"] and killed["meshes_pending"] == ["m23"]

    # the re-run (text output) takes m12 from the file: not built, not solved; the file's m12 is the killed run's,
    # wall time included (a solve again would have measured its own)
    assert main([*ARGS, "--out", str(out)]) == 0
    text, err = capsys.readouterr()
    assert f"hacgear stiffness: resumed: 1 mesh from {out} (m12); solving m23" in err
    assert "mesh m12" not in err and "mesh m23: static contact at 4 mesh positions" in err
    assert "mesh m12 (gear1-gear2" in text and "mesh m23 (gear2-gear3" in text
    resumed = json.loads(out.read_text())
    assert not (tmp_path / "idler.json.writing").exists()
    assert resumed["meshes"]["m12"] == killed["meshes"]["m12"]
    assert list(resumed["meshes"]) == ["m12", "m23"] and resumed["meshes_pending"] == []

    # an uninterrupted run writes the same file (floats within 1e-12, wall times aside); its --json is the file
    # without the resume keys
    fresh = tmp_path / "fresh.json"
    assert main([*ARGS, "--out", str(fresh), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    whole = json.loads(fresh.read_text())
    _same(resumed, whole)
    assert resumed["inputs_sha256"] == whole["inputs_sha256"]
    assert printed == {k: v for k, v in whole.items() if k not in ("inputs", "inputs_sha256", "meshes_pending")}

    # a third run has nothing left to solve and leaves the file as it was
    before = out.read_bytes()
    assert main([*ARGS, "--out", str(out), "--json"]) == 0
    _, err = capsys.readouterr()
    assert "resumed: 2 meshes" in err and "nothing left to solve" in err and "building" not in err
    assert out.read_bytes() == before


def test_stiffness_file_of_other_inputs_is_refused_and_kept(tmp_path, capsys):
    """Another option or a changed model names what differs and keeps the file; --fresh solves again."""
    src = (shipped_systems_dir() / "idler_28_33_39" / "model.toml").read_text()
    model = tmp_path / "model.toml"
    model.write_text(src)
    out = tmp_path / "m12.json"
    args = ["stiffness", str(model), "--positions", "4", "--mesh", "m12", "--out", str(out)]
    assert main(args) == 0
    capsys.readouterr()
    before = out.read_bytes()

    assert main([*args, "--torque", "200"]) == 2
    err = capsys.readouterr().err
    assert "holds stiffness results of other inputs (differs: torque_Nm: 300.0 in the file, 200.0 now)" in err
    assert "it is kept: write to another --out, or replace it with --fresh" in err

    # a changed model value (gear1's face width) with the same options: the model values' hash differs
    assert "face_width_mm = 9.0" in src
    model.write_text(src.replace("face_width_mm = 9.0", "face_width_mm = 9.5", 1))
    assert main(args) == 2
    assert "differs: model_values_sha256: " in capsys.readouterr().err
    assert out.read_bytes() == before

    # what no static solve reads (damping, title) changes nothing: the file is taken as it is
    assert "modal_damping_ratio = 0.02" in src
    model.write_text(src.replace('title = "', 'title = "renamed ', 1).replace("modal_damping_ratio = 0.02",
                                                                              "modal_damping_ratio = 0.05"))
    assert main(args) == 0
    assert "resumed: 1 mesh" in capsys.readouterr().err

    model.write_text(src.replace("face_width_mm = 9.0", "face_width_mm = 9.5", 1))
    assert main([*args, "--fresh"]) == 0
    assert "resumed" not in capsys.readouterr().err
    assert json.loads(out.read_text())["meshes"]["m12"]["mean_mesh_stiffness_N_per_m"] != \
        json.loads(before)["meshes"]["m12"]["mean_mesh_stiffness_N_per_m"]

    # not a result file: refused and kept
    other = tmp_path / "notes.json"
    other.write_text('{"a": 1}')
    assert main(["stiffness", str(model), "--positions", "4", "--out", str(other)]) == 2
    assert "exists and is not a stiffness result file" in capsys.readouterr().err
    assert other.read_text() == '{"a": 1}'
    assert main(["stiffness", str(model), "--fresh"]) == 2
    assert "--fresh replaces the result file of --out" in capsys.readouterr().err
