"""Plots of force-deflection and strain-deflection functions (dissertation Figs. 3.3 and 4.6).

``python -m hacgear_core.plots.tables [TABLES.h5] [--mesh NAME] [--gauge GEAR/GAUGE] --out DIR`` writes
``DIR/tables_fdf<suffix>.png`` and ``DIR/tables_sdf<suffix>.png`` (nothing anywhere else).  Without a table file it plots the analytical
reference pair (:class:`hacgear_core.statics.AnalyticPairSolver`, not FE; suffix ``_analytic``).
"""
from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np

from hacgear_core.errors import HacgearError
from hacgear_core.outpaths import check_out_dir
from hacgear_core.statics import AnalyticFactory, load_grid, run_statics
from hacgear_core.tables import MeshTable, read_tables

__all__ = ["plot_fdf", "plot_sdf", "contact_count", "main"]


def _plt() -> Any:
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt  # after the backend is chosen

    return plt


def _short(solver: str) -> str:
    return solver.split(" (")[0] + (" — analytical reference, not FE" if "not FE" in solver else "")


def contact_count(table: MeshTable, position: np.ndarray, deflection: np.ndarray, threshold_N: float = 1.0
                  ) -> np.ndarray:
    """Number of tooth pairs carrying more than ``threshold_N`` at (position, deflection) (broadcast)."""
    p, x = np.broadcast_arrays(np.asarray(position, float), np.asarray(deflection, float))
    n = np.zeros(p.shape, dtype=int)
    for k in table.tooth_offsets:
        load = table.tooth_load(p, x, int(k))
        n += np.nan_to_num(load, nan=0.0) > threshold_N
    return n


def plot_fdf(table: MeshTable, *, cycles: int = 2, n_curves: int = 7, title: str | None = None) -> Any:
    """Figure: (a) mesh force over ``cycles`` mesh cycles at ``n_curves`` mesh deflections (curves
    drawn solid where two or more pairs are in contact, thin where one is); (b) the FDF over (mesh
    cycle, deflection) with the single/double-tooth contact regions and the NLMD."""
    plt = _plt()
    stats_before = (table.stats.n_queries, table.stats.n_below, table.stats.n_above)
    pos = np.linspace(0.0, cycles, 400 * cycles + 1)
    x_top = table.static_deflection_m.max()
    xs = np.linspace(max(table.no_load_deflection_m.max(), 0.0) * 0.5, x_top, n_curves + 1)[1:]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13.5, 4.8), constrained_layout=True)
    cmap = plt.get_cmap("viridis")
    for i, x in enumerate(xs):
        f = table.force(pos, x)
        n = contact_count(table, pos, x)
        col = cmap(i / max(len(xs) - 1, 1))
        ax1.plot(pos, f / 1e3, color=col, lw=0.8, label=f"x = {x * 1e6:.0f} µm")
        ax1.plot(pos, np.where(n >= 2, f, np.nan) / 1e3, color=col, lw=2.6)
    ax1.set_xlabel("mesh cycle [-]  (integer: pitch-point contact)")
    ax1.set_ylabel("mesh force F [kN]")
    ax1.set_title("(a) FDF at fixed mesh deflections (thick: ≥2 pairs in contact)")
    ax1.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
               title="deflection", title_fontsize=7)  # outside the axes: never over a curve
    ax1.set_xlim(0, cycles)
    ax1.grid(alpha=0.3)
    xg = np.linspace(table.deflection_m[0], table.deflection_m[-1], 220)
    P, X = np.meshgrid(pos[::4], xg, indexing="xy")
    F = table.force(P, X)
    n = contact_count(table, P, X)
    cs = ax2.contourf(P, X * 1e6, F / 1e3, levels=20, cmap="viridis")
    fig.colorbar(cs, ax=ax2, label="mesh force F [kN]")
    ax2.contour(P, X * 1e6, n, levels=[0.5, 1.5, 2.5], colors=["w", "r", "m"], linewidths=1.2)
    ax2.plot(pos, table.no_load_deflection(pos) * 1e6, "w--", lw=1.0)
    # label regions at the static deflection of the nominal third of the largest load
    x_lab = table.static_deflection(pos[::4], table.load_N[-1] / 3).mean()
    n_lab = contact_count(table, pos[::4], x_lab)
    pl = pos[::4]
    for want, txt in ((1, "single"), (2, "double")):
        mask = np.concatenate([[False], n_lab == want, [False]]).astype(int)
        starts, ends = np.nonzero(np.diff(mask) == 1)[0], np.nonzero(np.diff(mask) == -1)[0]
        for a, b in zip(starts, ends):
            if b - a < 0.1 * pl.size / cycles:
                continue
            ax2.text(0.5 * (pl[a] + pl[b - 1]), x_lab * 1e6, txt, color="w" if want == 1 else "k", ha="center",
                     va="center", fontsize=8, bbox=dict(fc="k" if want == 1 else "w", alpha=0.5, lw=0))
    ax2.set_xlabel("mesh cycle [-]")
    ax2.set_ylabel("mesh deflection x [µm]")
    ax2.set_title("(b) FDF; solid: boundaries between 0|1 (white), 1|2 (red), 2|3 (magenta)\nloaded pairs; "
                  "white dashed: no-load mesh deflection", fontsize=10)
    fig.suptitle(title or f"Force-deflection function, mesh '{table.name}' ({_short(table.solver)})", fontsize=10)
    table.stats.n_queries, table.stats.n_below, table.stats.n_above = stats_before  # plotting is not a query
    return fig


def plot_sdf(table: MeshTable, gauge: str | None = None, *, n_curves: int = 5, title: str | None = None) -> Any:
    """Figure: strain-deflection function of ``gauge`` — root strain of one tooth over its pass
    through the mesh (tooth phase τ, 0 = pitch-point contact of its pair) at several mesh deflections
    (static deflections at evenly spaced loads)."""
    plt = _plt()
    gauge = gauge or table.gauge_names[0]
    k = table.tooth_offsets
    tau = np.linspace(-float(k[-1]), 1.0 - float(k[0]) - 1e-9, 600)
    loads = table.load_N[-1] * np.arange(1, n_curves + 1) / n_curves
    fig, ax = plt.subplots(figsize=(8, 4.6), constrained_layout=True)
    cmap = plt.get_cmap("plasma")
    for i, F in enumerate(loads):
        x = float(table.static_deflection(0.0, F))
        eps = table.sdf(gauge, tau, x)
        ax.plot(tau, eps * 1e6, color=cmap(i / n_curves), label=f"x = {x * 1e6:.0f} µm (≈{F / 1e3:.1f} kN static)")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("tooth phase τ [mesh cycles]  (0: its pair at the pitch point)")
    ax.set_ylabel("root strain [µε]")
    ax.set_title(title or f"Strain-deflection function, gauge {gauge}, mesh '{table.name}' ({_short(table.solver)})",
                 fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return fig


def _reference_table(tmp: Path) -> MeshTable:
    f_nom = 300.0 / (0.07 * math.cos(math.radians(25.0)))
    out = tmp / "reference_tables.h5"
    run_statics({"m12": AnalyticFactory()}, out, n_positions=128, n_deflections=96,
                loads_N={"m12": load_grid(3 * f_nom, 32)}, workers=1, progress=False)
    return read_tables(out).mesh("m12")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("tables", nargs="?", help="tables.h5 (default: the analytical reference pair)")
    ap.add_argument("--mesh", default=None)
    ap.add_argument("--gauge", default=None, help="gauge '<gear>/<gauge>' of the SDF plot")
    ap.add_argument("--out", type=Path, required=True, help="folder for the figures (created if missing)")
    ap.add_argument("--suffix", default=None,
                    help="file name suffix: tables_fdf<suffix>.png (default: '_analytic' without a table file, else '')")
    a = ap.parse_args(argv)
    try:
        check_out_dir(a.out, "--out")
    except HacgearError as exc:
        ap.error(str(exc))
    a.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as td:
        if a.tables:
            t = read_tables(a.tables).mesh(a.mesh)
        else:
            t = _reference_table(Path(td))
        plt = _plt()
        suffix = a.suffix if a.suffix is not None else ("" if a.tables else "_analytic")
        for name, fig in ((f"tables_fdf{suffix}.png", plot_fdf(t)), (f"tables_sdf{suffix}.png", plot_sdf(t, a.gauge))):
            fig.savefig(a.out / name, dpi=120)
            plt.close(fig)
            print(a.out / name)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
