"""`hacgear plot`: tables files and sweep results become PNGs; other files give a clear error."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from hacgear_core.cli import main
from hacgear_core.dynamics.build import spur_pair_system
from hacgear_core.dynamics.sweep import SweepSpec, run_sweep
from hacgear_core.dynamics.synthetic import softening_example

ROOT = Path(__file__).resolve().parent.parent


def _png(path: Path) -> bool:
    return path.exists() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_tables_fdf_and_sdf(tmp_path):
    out = tmp_path / "fdf.png"
    assert main(["plot", str(ROOT / "models" / "spur_28t_asym" / "tables.h5"), "--out", str(out),
                 "--gauge", "wheel/SG25"]) == 0
    assert _png(out) and _png(tmp_path / "fdf_sdf.png")


def test_plot_sweep_marks_the_jumps(tmp_path, capsys):
    p, tab, _ = softening_example()
    sy = spur_pair_system(p, tab)
    fn = sy.natural_frequencies_Hz()[0]
    res = run_sweep(SweepSpec(sy, tuple(np.linspace(0.5 * fn, 1.3 * fn, 41)), "both"), out=tmp_path / "s.h5",
                    progress=False)
    capsys.readouterr()
    assert main(["plot", str(tmp_path / "s.h5"), "--out", str(tmp_path / "s.png")]) == 0
    text = capsys.readouterr().out
    assert _png(tmp_path / "s.png")
    confirmed = [j for j in res.jumps if j.confirmed]
    assert confirmed, "the softening table must jump"
    for j in confirmed:
        assert f"{j.kind} of mesh {j.mesh} at {j.frequency_Hz:.0f} Hz" in text


def test_plot_rejects_other_files(tmp_path, capsys):
    assert main(["plot", str(ROOT / "README.md"), "--out", str(tmp_path / "x.png")]) == 2
    assert "is not an HDF5 file" in capsys.readouterr().err
