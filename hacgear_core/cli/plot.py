"""``hacgear plot FILE --out PNG``: a picture of a tables file or of a sweep results file.

* ``tables.h5`` (from ``hacgear statics``): the force-deflection function over two mesh cycles with the
  single/double contact regions (dissertation Fig. 3.3) and, with ``--gauge``, the strain-deflection
  function of that gauge (Fig. 4.6), written to ``<out>`` and ``<out stem>_sdf.png``;
* a sweep results file (from ``hacgear sweep --out``): RMS and mean of the mesh deflection over the mesh
  frequency, up and down branches, confirmed jumps marked (Figs. 3.5, 3.10).

Axes are labelled with their units (µm, kN, Hz, µε).
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

__all__ = ["register", "run", "plot_sweep_file"]


def register(subparsers: Any) -> None:
    p = subparsers.add_parser("plot", help="plot a tables.h5 (FDF, strain) or a sweep results file",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", help="tables.h5 or sweep results .h5")
    p.add_argument("--out", required=True, help="PNG file to write")
    p.add_argument("--mesh", default=None, help="mesh of a tables file (default: the first)")
    p.add_argument("--gauge", default=None, help="gauge '<gear>/<gauge>' for the strain-deflection plot")
    p.add_argument("--run", default=None, help="run id of a sweep file holding several runs (default: all)")
    p.set_defaults(func=run)


def plot_sweep_file(path: str | Path, out: str | Path, run_id: str | None = None) -> list[dict]:
    """Plot every run (or ``run_id``) of a sweep results file into one PNG; returns the confirmed jumps."""
    import h5py
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from hacgear_core.dynamics.sweep import detect_jumps, read_sweep
    from hacgear_core.errors import TableError

    runs = read_sweep(path)
    if run_id is not None:
        if run_id not in runs:
            raise TableError(f"{path}: no sweep run {run_id!r}; runs: {sorted(runs)}")
        runs = {run_id: runs[run_id]}
    if not runs:
        raise TableError(f"{path}: no sweep results in this file (make one with `hacgear sweep ... --out FILE`)")
    with h5py.File(path, "r") as f:
        labels = {rid: str(f["sweeps"][rid].attrs.get("label", rid)) for rid in runs}
    fig, ax = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    jumps_out = []
    for k, (rid, branches) in enumerate(runs.items()):
        col = plt.rcParams["axes.prop_cycle"].by_key()["color"][k % 10]
        for b, mk in (("up", "o-"), ("down", "x--")):
            if b not in branches:
                continue
            br = branches[b]
            f_hz = np.asarray(br.mesh_frequency_Hz)
            ax[0].plot(f_hz, np.asarray(br.metrics["rms_deflection_m"]) * 1e6, mk, color=col, ms=3, lw=0.7,
                       label=f"{labels[rid]}, {b}")
            ax[1].plot(f_hz, np.asarray(br.metrics["mean_deflection_m"]) * 1e6, mk, color=col, ms=3, lw=0.7)
        for j in detect_jumps(branches):
            if j.confirmed:
                ax[0].axvline(j.frequency_Hz, color=col, ls=":", lw=0.8)
                jumps_out.append({"run": rid, "kind": j.kind, "branch": j.branch, "frequency_Hz": j.frequency_Hz})
    ax[0].set_ylabel("RMS of oscillating mesh deflection [µm]")
    ax[1].set_ylabel("mean mesh deflection [µm]")
    ax[1].set_xlabel("mesh frequency [Hz]   (dotted: confirmed jumps)")
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return jumps_out


def run(args) -> int:
    import h5py

    from hacgear_core.errors import TableError

    path = Path(args.file)
    if not path.exists():
        raise TableError(f"no such file: {path}")
    try:
        with h5py.File(path, "r") as f:
            kind = "tables" if f.attrs.get("format") == "hacgear-tables" else ("sweep" if "sweeps" in f else "")
    except OSError as exc:
        raise TableError(f"{path} is not an HDF5 file: {exc}") from None
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if kind == "tables":
        from hacgear_core import plots_tables
        from hacgear_core.tables import read_tables

        tabs = read_tables(path)
        table = tabs.mesh(args.mesh)
        fig = plots_tables.plot_fdf(table)
        fig.savefig(out, dpi=110)
        print(f"FDF of mesh '{table.name}': {out}")
        if args.gauge is not None:
            if args.gauge not in table.strain:
                raise TableError(f"--gauge {args.gauge!r} not in {path}; gauges: {sorted(table.strain)}")
            sdf = out.with_name(out.stem + "_sdf.png")
            plots_tables.plot_sdf(table, args.gauge).savefig(sdf, dpi=110)
            print(f"strain-deflection function of {args.gauge}: {sdf}")
        return 0
    if kind == "sweep":
        jumps = plot_sweep_file(path, out, args.run)
        print(f"sweep response: {out}")
        for j in jumps:
            print(f"  {j['kind']} at {j['frequency_Hz']:.0f} Hz ({j['branch']} sweep)")
        return 0
    raise TableError(f"{path} is neither a hacgear tables file (attribute format='hacgear-tables') nor a sweep "
                     "results file (group 'sweeps')")
