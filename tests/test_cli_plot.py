"""`hacgear plot`: tables files and sweep results become PNGs; other files give a clear error."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hacgear_core.cli import main
from hacgear_core.kinds import spur_pair_system
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


# ----------------------------------------------------------------------------------------------
# plots a person reads: unit symbols, legends off the data, branches and jumps distinguishable
# ----------------------------------------------------------------------------------------------
import re  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.text import Annotation, Text  # noqa: E402

#: ASCII stand-ins for unit symbols, and other spellings a reader should not have to decode
BAD_TEXT = [r"\bum\b", r"\bN m\b", r"N\*m", r"\bdeg\b", r"\b1e6\b", r"\bzeta\b", r"alpha_w", r" x K\b", r"\buE\b"]


def _texts(fig) -> list[str]:
    return [t.get_text() for t in fig.findobj(Text) if t.get_text()]


def _legend_covers_data(fig) -> list[str]:
    """Data points of lines that lie inside a legend drawn inside its axes (display coordinates)."""
    fig.canvas.draw()
    bad = []
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None:
            continue
        box = leg.get_window_extent()
        axbox = ax.get_window_extent()
        if not axbox.contains(box.x0 + 1, box.y0 + 1):
            continue  # outside the axes
        for line in ax.get_lines():
            xy = line.get_xydata()
            if xy.size == 0:
                continue
            disp = ax.transData.transform(xy[np.all(np.isfinite(xy), axis=1)])
            inside = (disp[:, 0] > box.x0) & (disp[:, 0] < box.x1) & (disp[:, 1] > box.y0) & (disp[:, 1] < box.y1)
            if inside.any():
                bad.append(f"{ax.get_title() or ax.get_ylabel()}: {line.get_label()} ({int(inside.sum())} points)")
    return bad


def _check(fig, name):
    texts = _texts(fig)
    for pat in BAD_TEXT:
        hits = [t for t in texts if re.search(pat, t)]
        assert not hits, f"{name}: {pat!r} in {hits}"
    covered = _legend_covers_data(fig)
    assert not covered, f"{name}: legend over data: {covered}"
    for ax in fig.axes:
        if ax.get_lines() or ax.collections:
            for label in (ax.get_xlabel(), ax.get_ylabel()):
                if label and not re.search(r"\[.*\]|\(.*\)|f_m|cycle|-\]", label):
                    raise AssertionError(f"{name}: axis label without a unit: {label!r}")


def test_table_figures_read_well():
    from hacgear_core.plots.tables import plot_fdf, plot_sdf
    from hacgear_core.tables import read_tables

    t = read_tables(ROOT / "models" / "spur_28t_asym" / "tables.h5").mesh()
    for name, fig in (("fdf", plot_fdf(t)), ("sdf", plot_sdf(t, "wheel/SG25"))):
        _check(fig, name)
        plt.close(fig)


def test_geometry_figure_reads_well_and_equal_gears_stay_visible():
    from hacgear_core.kinds import load_model
    from hacgear_core.plots.geometry import mesh_geometry_figure

    fig = mesh_geometry_figure(load_model("spur_28t_asym"), None)
    _check(fig, "geometry")
    # the two equal gears' relief and crowning curves coincide: drawn with different widths, both visible
    for ax in fig.axes[-2:]:
        widths = {round(line.get_linewidth(), 1) for line in ax.get_lines() if line.get_label()[:1] != "_"}
        assert len(widths) >= 2, ax.get_title()
    plt.close(fig)


def test_sweep_figure_branches_distinguishable_and_jumps_marked(tmp_path):
    from hacgear_core.plots.sweep import sweep_figure

    p, tab, _ = softening_example()
    sy = spur_pair_system(p, tab)
    fn = sy.natural_frequencies_Hz()[0]
    res = run_sweep(SweepSpec(sy, tuple(np.linspace(0.5 * fn, 1.3 * fn, 41)), "both"), out=tmp_path / "s.h5",
                    progress=False)
    fig, jumps = sweep_figure(tmp_path / "s.h5")
    _check(fig, "sweep")
    ax = fig.axes[0]
    lines = {line.get_label().rsplit(", ", 1)[-1]: line for line in ax.get_lines() if "sweep" in line.get_label()}
    up, down = lines["up sweep"], lines["down sweep"]
    assert up.get_color() != down.get_color() and up.get_marker() != down.get_marker()
    assert up.get_linestyle() != down.get_linestyle() and up.get_linewidth() > down.get_linewidth()
    assert down.get_zorder() > up.get_zorder()  # the thinner one on top: both visible where they coincide
    arrows = [a for a in ax.findobj(Annotation) if a.arrow_patch is not None]
    assert len(arrows) == len(jumps) == len([j for j in res.jumps if j.confirmed]) >= 2
    plt.close(fig)


def test_an_unknown_gauge_writes_no_figure(tmp_path, capsys):
    """`plot --gauge bad/x` wrote the FDF figure, then failed; now it fails first and writes nothing."""
    out = tmp_path / "fdf.png"
    assert main(["plot", str(ROOT / "models" / "spur_28t_asym" / "tables.h5"), "--out", str(out),
                 "--gauge", "bad/x"]) == 2
    assert "--gauge 'bad/x' not in" in capsys.readouterr().err and not out.exists()


def test_a_sweep_missing_a_branch_is_plotted_with_a_warning(tmp_path, capsys):
    """A results file whose down branch was never stored (a killed `sweep --direction both`): the plot command
    warns on stderr and the figure's title says INCOMPLETE (it drew the up branch without a word)."""
    import h5py
    p, tab, _ = softening_example()
    sy = spur_pair_system(p, tab)
    fn = sy.natural_frequencies_Hz()[0]
    res = run_sweep(SweepSpec(sy, tuple(np.linspace(0.8 * fn, 1.2 * fn, 5)), "both"), out=tmp_path / "s.h5",
                    progress=False)
    with h5py.File(tmp_path / "s.h5", "a") as f:
        del f[f"sweeps/{res.run_id}/down"]
    capsys.readouterr()
    assert main(["plot", str(tmp_path / "s.h5"), "--out", str(tmp_path / "s.png")]) == 0
    assert f"run {res.run_id}: the down sweep is missing" in capsys.readouterr().err
    from hacgear_core.plots.sweep import sweep_figure
    fig, _ = sweep_figure(tmp_path / "s.h5")
    assert fig._suptitle is not None and fig._suptitle.get_text().startswith("INCOMPLETE: ")


TWO_VARIABLES = """
[study]
name = "two"
base_model = "spur_28t_asym"

[[variables]]
key = "gears[*].drive.tip_relief_um"
values = [0.0, 30.0]

[[variables]]
key = "gears[*].lead_crowning_um"
values = [0.0, 15.0]

[statics]
positions = 16
loads = 8
deflections = 24
solver = "analytic"

[static]
torques_Nm = [100.0, 300.0, 500.0]

[dynamic]
torque_Nm = 300.0
mesh_frequency_Hz = [2000.0, 3500.0, 4]
max_cycles = 800
"""


def _overlaps(a, b) -> bool:
    return a.x0 < b.x1 - 1 and b.x0 < a.x1 - 1 and a.y0 < b.y1 - 1 and b.y0 < a.y1 - 1


def test_study_figures_of_two_variables_read_well(tmp_path):
    """A study of two variables (the issue's case: the dynamic map cut its right column, colour-bar labels over
    'variant', ~50 px panels, x ticks run together; the best-variant legend over the text; labels as key paths and
    Python names): every text inside the figure, no text over another axes or over another text of the same
    panel, panels at least 2.6 inches tall, variables by short name with units, criteria in words."""
    from hacgear_core.plots.study import best_variant_chart, dynamic_map, harris_map
    from hacgear_core.studies import load_study, read_study, run_study

    (tmp_path / "two.toml").write_text(TWO_VARIABLES)
    run_study(load_study(tmp_path / "two.toml"), tmp_path / "two.h5", workers=1, progress=False)
    res = read_study(tmp_path / "two.h5")
    for name, fig in (("harris", harris_map(res)), ("dynamic", dynamic_map(res)), ("best", best_variant_chart(res))):
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        page = fig.bbox
        # numeric tick labels are placed by matplotlib (those beyond the view limits exist but are not drawn)
        texts = [t for t in fig.findobj(Text) if t.get_text() and t.get_visible()
                 and not re.fullmatch(r"[−-]?[\d.]+", t.get_text())]
        for t in texts:
            e = t.get_window_extent(r)
            assert e.x0 >= -1 and e.x1 <= page.x1 + 1 and e.y0 >= -1 and e.y1 <= page.y1 + 1, \
                f"{name}: {t.get_text()!r} outside the figure"
        joined = " | ".join(t.get_text() for t in texts)
        assert "gears[*]" not in joined and "_um" not in joined and "ste_peak_to_peak" not in joined, joined
        assert "tip relief 30 µm, lead crowning 15 µm" in joined, name
        for i, ax in enumerate(fig.axes):   # a panel's texts stay clear of the other panels (colour bars too)
            for t in ax.get_yticklabels() + [ax.yaxis.label, ax.title]:
                if not t.get_text():
                    continue
                e = t.get_window_extent(r)
                for j, other in enumerate(fig.axes):
                    if j != i:
                        assert not _overlaps(e, other.get_window_extent(r)), \
                            f"{name}: {t.get_text()!r} of panel {i} over panel {j}"
        for leg in [fig.legends[0]] if fig.legends else []:
            for ax in fig.axes:
                assert not _overlaps(leg.get_window_extent(r), ax.get_window_extent(r)), f"{name}: legend over axes"
        if name == "dynamic":
            heights = [ax.get_window_extent(r).height / fig.dpi for ax in fig.axes if ax.collections]
            assert min(heights) >= 1.6, heights   # the heat map itself, without title and ticks
            ticks = [t.get_text() for ax in fig.axes for t in ax.get_xticklabels() if t.get_text()]
            assert all(len(t) <= 5 for t in ticks), ticks   # no '20003000'
        _check(fig, name)
        plt.close(fig)


def test_figures_are_written_whole(tmp_path):
    """A figure goes to its file by one rename (outpaths.save_figure): the format follows the suffix, no
    temporary file stays, and a failing save leaves an existing file as it was."""
    from hacgear_core.outpaths import save_figure
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    for name in ("a.png", "a.svg", "a.pdf"):
        save_figure(fig, tmp_path / name)
    assert _png(tmp_path / "a.png") and (tmp_path / "a.svg").read_bytes().lstrip().startswith(b"<?xml")
    assert (tmp_path / "a.pdf").read_bytes()[:4] == b"%PDF" and not list(tmp_path.glob("*.writing"))
    before = (tmp_path / "a.png").read_bytes()
    with pytest.raises(TypeError):
        save_figure(fig, tmp_path / "a.png", dpi="not a number")
    assert (tmp_path / "a.png").read_bytes() == before and not list(tmp_path.glob("*.writing"))
    plt.close(fig)
