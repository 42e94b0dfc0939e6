"""Response curves of sweep results files: RMS and mean mesh deflection over the mesh frequency, per mesh, up and
down branches in different colours and markers, confirmed jumps marked (dissertation Figs. 3.5, 3.10, 4.7)."""
from __future__ import annotations

from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hacgear_core.dynamics.sweep import detect_jumps, read_sweep, sweep_mesh_names  # noqa: E402
from hacgear_core.errors import TableError  # noqa: E402

__all__ = ["plot_sweep_file"]

_BRANCH_STYLE = {"up": ("o", "-", 0), "down": ("x", "--", 1)}


def plot_sweep_file(path: str | Path, out: str | Path, run_id: str | None = None) -> list[dict]:
    """Plot every run (or ``run_id``) of a sweep results file into one PNG: one row of panels per mesh (RMS and
    mean deflection); returns the confirmed jumps."""
    runs = read_sweep(path)
    if run_id is not None:
        if run_id not in runs:
            raise TableError(f"{path}: no sweep run {run_id!r}; runs: {sorted(runs)}")
        runs = {run_id: runs[run_id]}
    if not runs:
        raise TableError(f"{path}: no sweep results in this file (make one with `hacgear sweep ... --out FILE`)")
    with h5py.File(path, "r") as f:
        labels = {rid: str(f["sweeps"][rid].attrs.get("label", rid)) for rid in runs}
    names = {rid: sweep_mesh_names(path, rid) for rid in runs}
    n_mesh = max(len(v) for v in names.values())
    fig, ax = plt.subplots(2, n_mesh, figsize=(8 * n_mesh ** 0.5 + 1, 7), sharex=True, squeeze=False)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    jumps_out = []
    for k, (rid, branches) in enumerate(runs.items()):
        for b, br in branches.items():
            mk, ls, ci = _BRANCH_STYLE.get(b, ("s", ":", 2))
            col = colors[(2 * k + ci) % len(colors)]
            f_hz = np.asarray(br.mesh_frequency_Hz)
            for c, mn in enumerate(names[rid]):
                ax[0, c].plot(f_hz, np.asarray(br.metrics["rms_deflection_m"])[:, c] * 1e6, marker=mk, ls=ls,
                              color=col, ms=3, lw=0.8, label=f"{labels[rid]}, {b} sweep")
                ax[1, c].plot(f_hz, np.asarray(br.metrics["mean_deflection_m"])[:, c] * 1e6, marker=mk, ls=ls,
                              color=col, ms=3, lw=0.8)
        for j in detect_jumps(branches, mesh_names=names[rid]):
            if j.confirmed:
                c = names[rid].index(j.mesh)
                col = colors[(2 * k + _BRANCH_STYLE.get(j.branch, ("", "", 2))[2]) % len(colors)]
                ax[0, c].axvline(j.frequency_Hz, color=col, ls=":", lw=1.0)
                ax[0, c].annotate(j.kind, (j.frequency_Hz, 1.0), xycoords=("data", "axes fraction"), fontsize=7,
                                  ha="center", va="bottom", color=col)
                jumps_out.append({"run": rid, "mesh": j.mesh, "kind": j.kind, "branch": j.branch,
                                  "frequency_Hz": j.frequency_Hz})
    for c in range(n_mesh):
        mn = next((v[c] for v in names.values() if len(v) > c), "")
        ax[0, c].set_ylabel(f"RMS of oscillating mesh deflection, {mn} [µm]")
        ax[1, c].set_ylabel(f"mean mesh deflection, {mn} [µm]")
        ax[1, c].set_xlabel("mesh frequency [Hz]   (dotted: confirmed jumps)")
    ax[0, 0].legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return jumps_out
