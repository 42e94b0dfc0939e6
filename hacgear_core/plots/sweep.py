"""Response curves of sweep results files: RMS and mean mesh deflection over the mesh frequency, per mesh, up and
down branches in different colours, markers and line widths (both visible where they coincide), confirmed jumps
marked by an arrow from the state before to the state after (dissertation Figs. 3.5, 3.10, 4.7)."""
from __future__ import annotations

from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hacgear_core.dynamics.sweep import detect_jumps, missing_branches, read_sweep, sweep_mesh_names  # noqa: E402
from hacgear_core.errors import TableError  # noqa: E402
from hacgear_core.outpaths import save_figure  # noqa: E402

__all__ = ["plot_sweep_file", "sweep_figure", "mark_jump"]

#: branch -> (marker, line style, colour index, marker size, line width, z-order): the up sweep below with large
#: filled circles, the down sweep on top with crosses, so that where the branches coincide both stay visible
_BRANCH_STYLE = {"up": ("o", "-", 0, 5.0, 1.6, 2), "down": ("x", "--", 1, 4.0, 0.9, 3)}
_ORDER = {"up": 0, "down": 1}


def mark_jump(ax, jump, color: str, number: int, *, x_scale: float = 1.0, y_scale: float = 1.0,
              where: str | None = None) -> None:
    """Draw a confirmed :class:`~hacgear_core.dynamics.sweep.Jump` on an axes of RMS over frequency: a dotted
    line at its frequency, an arrow from the last state before it to the first after it, its ``number`` beside
    the arrow, and a legend entry "number: kind, branch, where" (``where`` default: the frequency in Hz), so that
    close jumps never print over each other.  ``x_scale`` / ``y_scale`` map Hz / metres to the axes' units.
    Call ``ax.legend()`` afterwards."""
    lo, hi = jump.interval_Hz
    f0, f1 = (lo, hi) if jump.branch == "up" else (hi, lo)
    a, b = (f0 * x_scale, jump.rms_before_m * y_scale), (f1 * x_scale, jump.rms_after_m * y_scale)
    ax.axvline(jump.frequency_Hz * x_scale, color=color, ls=":", lw=1.0, zorder=1)
    ax.annotate("", xy=b, xytext=a, arrowprops=dict(arrowstyle="-|>", color=color, lw=1.8, mutation_scale=14),
                zorder=5)
    right = jump.branch == "up"
    ax.annotate(str(number), (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])), xytext=(5 if right else -5, 0),
                textcoords="offset points", ha="left" if right else "right", va="center", fontsize=8,
                fontweight="bold", color=color, zorder=6, bbox=dict(fc="white", ec="none", alpha=0.8, pad=0.5))
    ax.plot([], [], ls="none", marker=f"${number}$", color=color, ms=7,
            label=f"{number}: {jump.kind}, {jump.branch} sweep, {where or f'{jump.frequency_Hz:.0f} Hz'}")


def plot_sweep_file(path: str | Path, out: str | Path, run_id: str | None = None) -> list[dict]:
    """Plot every run (or ``run_id``) of a sweep results file into one image file (:func:`sweep_figure`); returns
    the confirmed jumps."""
    fig, jumps = sweep_figure(path, run_id)
    save_figure(fig, out, dpi=110)
    plt.close(fig)
    return jumps


def sweep_figure(path: str | Path, run_id: str | None = None) -> tuple:
    """Figure of every run (or ``run_id``) of a sweep results file: one column of panels per mesh (RMS and mean
    deflection over the mesh frequency) → (figure, confirmed jumps as dicts)."""
    runs = read_sweep(path)
    if run_id is not None:
        if run_id not in runs:
            raise TableError(f"{path}: no sweep run {run_id!r}; runs: {sorted(runs)}")
        runs = {run_id: runs[run_id]}
    if not runs:
        raise TableError(f"{path}: no sweep results in this file (make one with `hacgear sweep ... --out FILE`)")
    with h5py.File(path, "r") as f:
        labels = {rid: str(f["sweeps"][rid].attrs.get("label", rid)) for rid in runs}
    lost = {rid: b for rid, b in missing_branches(path).items() if rid in runs}
    names = {rid: sweep_mesh_names(path, rid) for rid in runs}
    n_mesh = max(len(v) for v in names.values())
    fig, ax = plt.subplots(2, n_mesh, figsize=(8 * n_mesh ** 0.5 + 1, 7), sharex=True, squeeze=False)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    jumps_out = []
    for k, (rid, branches) in enumerate(runs.items()):
        label = labels[rid].replace("N*m", "N·m")
        for b, br in sorted(branches.items(), key=lambda t: _ORDER.get(t[0], 2)):
            mk, ls, ci, ms, lw, z = _BRANCH_STYLE.get(b, ("s", ":", 2, 3.0, 0.8, 4))
            col = colors[(2 * k + ci) % len(colors)]
            f_hz = np.asarray(br.mesh_frequency_Hz)
            for c, mn in enumerate(names[rid]):
                kw = dict(marker=mk, ls=ls, color=col, ms=ms, lw=lw, zorder=z, mfc=col if mk == "o" else "none")
                ax[0, c].plot(f_hz, np.asarray(br.metrics["rms_deflection_m"])[:, c] * 1e6,
                              label=f"{label}, {b} sweep", **kw)
                ax[1, c].plot(f_hz, np.asarray(br.metrics["mean_deflection_m"])[:, c] * 1e6, **kw)
        for j in detect_jumps(branches, mesh_names=names[rid]):
            if j.confirmed:
                c = names[rid].index(j.mesh)
                col = colors[(2 * k + _BRANCH_STYLE.get(j.branch, ("", "", 2))[2]) % len(colors)]
                mark_jump(ax[0, c], j, col, len(jumps_out) + 1, y_scale=1e6)
                jumps_out.append({"run": rid, "mesh": j.mesh, "kind": j.kind, "branch": j.branch,
                                  "frequency_Hz": j.frequency_Hz})
    for c in range(n_mesh):
        mn = next((v[c] for v in names.values() if len(v) > c), "")
        ax[0, c].set_ylabel(f"RMS of oscillating mesh deflection, {mn} [µm]")
        ax[1, c].set_ylabel(f"mean mesh deflection, {mn} [µm]")
        ax[1, c].set_xlabel("mesh frequency [Hz]   (arrows and dotted lines: confirmed jumps)")
    for c in range(n_mesh):
        ax[0, c].legend(fontsize=7, loc="best")
    if lost:
        note = "; ".join(f"{labels[rid]}: {' and '.join(b)} sweep missing" for rid, b in lost.items())
        fig.suptitle(f"INCOMPLETE: {note} (interrupted run; the same sweep command completes it)", color="firebrick",
                     fontsize=10)
    fig.tight_layout()
    return fig, jumps_out
