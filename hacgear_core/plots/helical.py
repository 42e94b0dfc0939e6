"""Figures of a helical mesh table (twist axis): generalized FDF over deflection and twist, contact pattern across
the face, strain-deflection functions of gauges across the face (dissertation Figs. 5.3, 5.4, 5.6).

``python -m hacgear_core.plots.helical [TABLES.h5] [--mesh M] [--gauge GEAR/GAUGE] [--out docs/figures]`` writes
``helical_gfdf.png``, ``helical_twist.png``, ``helical_pattern.png`` and ``helical_sdf.png``.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from hacgear_core.errors import TableError
from hacgear_core.plots.tables import contact_count
from hacgear_core.tables import MeshTable, read_tables

__all__ = ["plot_gfdf", "plot_twist", "plot_pattern", "plot_face_sdf", "write_helical_figures", "main"]


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _twist(table: MeshTable):
    if table.twist is None:
        raise TableError(f"mesh table '{table.name}' has no twist axis (not a helical mesh table)")
    return table.twist


def plot_gfdf(table: MeshTable, *, cycles: int = 2, n_curves: int = 6) -> Any:
    """Generalized FDF at zero twist (Fig. 5.4): mesh force and the axial force on gear_a (its f_d component along
    e3) over ``cycles`` mesh cycles at several deflections, and the map of loaded pairs over (position,
    deflection) — the double-contact region widening with deflection."""
    plt = _plt()
    tw = _twist(table)
    x = table.deflection_m
    xs = np.linspace(max(x[1], float(table.no_load_deflection_m.max())), x[-1], n_curves)
    p = np.linspace(0.0, cycles, 200 * cycles)
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.6))
    for xv in xs:
        g = table.generalized(p, xv, 0.0)
        ax[0].plot(p, g[:, 0] / 1e3, label=f"x = {xv * 1e6:.1f} µm")
        fd = table.generalized_force(p, xv, 0.0)
        ax[1].plot(p, fd[:, 2] / 1e3)
    ax[0].set(xlabel="mesh position [mesh cycles]", ylabel="mesh force W [kN] (normal to the flank)",
              title="generalized FDF, twist 0")
    ax[0].legend(fontsize=7)
    ax[1].set(xlabel="mesh position [mesh cycles]", ylabel="f_d of gear_a along e3 (axial) [kN]",
              title="axial component (Fig. 5.4's quantity)")
    P, X = np.meshgrid(p, x[1:], indexing="ij")
    n = contact_count(table, P.ravel(), X.ravel()).reshape(P.shape)
    im = ax[2].pcolormesh(p, x[1:] * 1e6, n.T, shading="auto", cmap="viridis", vmin=0, vmax=max(3, n.max()))
    ax[2].plot(p, table.no_load_deflection(p) * 1e6, "w-", lw=1)
    fig.colorbar(im, ax=ax[2], label="loaded tooth pairs")
    ax[2].set(xlabel="mesh position [mesh cycles]", ylabel="mesh deflection [µm]",
              title="contact regions (white: no-load deflection)")
    fig.suptitle(f"mesh {table.name}: {table.solver[:110]}", fontsize=8)
    fig.tight_layout()
    return fig


def plot_twist(table: MeshTable, *, position: float = 0.25, n_curves: int = 5) -> Any:
    """Mesh force, twist moment and load centroid across the face over the twist axis at one position."""
    plt = _plt()
    tw = _twist(table)
    g = np.linspace(tw.twist_rad[0], tw.twist_rad[-1], 41)
    x = table.deflection_m
    xs = np.linspace(max(x[1], float(table.no_load_deflection_m.max())), x[-1], n_curves + 1)[1:]
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.4))
    for xv in xs:
        v = table.generalized(position, xv, g)
        ax[0].plot(g * 1e3, v[:, 0] / 1e3, label=f"x = {xv * 1e6:.1f} µm")
        ax[1].plot(g * 1e3, v[:, 1])
        sl = table.twist_quantity(tw.slice_load_N, position, xv, g)
        tot = sl.sum(axis=1)
        ax[2].plot(g * 1e3, (sl @ tw.slice_z_m) / np.where(tot > 0, tot, 1.0) * 1e3)
    ax[0].set(xlabel="mesh twist γ [mrad]", ylabel="mesh force W [kN]", title=f"position {position:g}")
    ax[0].legend(fontsize=7)
    ax[1].set(xlabel="mesh twist γ [mrad]", ylabel="twist moment M [N·m]", title="twist moment (conjugate to γ)")
    z = tw.slice_z_m
    ax[2].axhline(z[0] * 1e3, color="k", lw=0.5)
    ax[2].axhline(z[-1] * 1e3, color="k", lw=0.5)
    ax[2].set(xlabel="mesh twist γ [mrad]", ylabel="load centroid across the face [mm]",
              title="contact pattern moves with the twist")
    fig.tight_layout()
    return fig


def plot_pattern(table: MeshTable, force_N: float, *, cycles: float = 1.0) -> Any:
    """Contact pattern: load per face slice over the mesh cycle at the static deflection of ``force_N`` (zero-twist
    FDF) for the smallest, zero and largest twist of the table (like Fig. 5.3)."""
    plt = _plt()
    tw = _twist(table)
    p = np.linspace(0.0, cycles, 97)
    from hacgear_core.tables.fdf import static_deflection, table_arrays

    xs = static_deflection(table_arrays(table), force_N)
    xp = np.interp(np.mod(p, 1.0), np.r_[table.position, 1.0], np.r_[xs, xs[0]])
    picks = sorted({0, tw.zero_index, tw.twist_rad.size - 1})
    fig, ax = plt.subplots(1, len(picks), figsize=(5 * len(picks), 4.2), squeeze=False)
    z = tw.slice_z_m * 1e3
    vmax = 0.0
    data = []
    for k in picks:
        sl = table.twist_quantity(tw.slice_load_N, p, xp, np.full(p.size, tw.twist_rad[k]))
        data.append(sl)
        vmax = max(vmax, float(sl.max()))
    for a, k, sl in zip(ax[0], picks, data):
        im = a.pcolormesh(p, z, sl.T, shading="auto", cmap="inferno", vmin=0, vmax=vmax)
        a.set(xlabel="mesh position [mesh cycles]", ylabel="axial position z [mm]",
              title=f"twist {tw.twist_rad[k] * 1e3:+.3g} mrad")
    fig.colorbar(im, ax=ax[0, -1], label="load per face slice [N]")
    fig.suptitle(f"contact pattern at mesh force {force_N:.0f} N (static deflection of the zero-twist FDF)")
    fig.tight_layout()
    return fig


def plot_face_sdf(table: MeshTable, gauges: list[str] | None = None, *, n_curves: int = 4) -> Any:
    """Strain-deflection functions at zero twist of the gauges across the face (Fig. 5.6: SG3), over the pass of
    one tooth (pair offsets unrolled: tooth phase)."""
    plt = _plt()
    gauges = gauges or list(table.strain)
    x = table.deflection_m
    xs = np.linspace(max(x[1], float(table.no_load_deflection_m.max())), x[-1], n_curves + 1)[1:]
    ph = np.linspace(-float(table.tooth_offsets.max()), 1.0 - float(table.tooth_offsets.min()), 400,
                     endpoint=False)
    fig, ax = plt.subplots(1, len(gauges), figsize=(3.6 * len(gauges), 3.8), squeeze=False, sharey=True)
    for a, gname in zip(ax[0], gauges):
        for xv in xs:
            a.plot(ph, table.sdf(gname, ph, xv) * 1e6, label=f"{xv * 1e6:.0f} µm")
        a.set(xlabel="tooth phase [mesh cycles]", title=gname)
    ax[0, 0].set_ylabel("root strain [µε]")
    ax[0, 0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def write_helical_figures(tables_path: str | Path, out_dir: str | Path, mesh: str | None = None,
                          force_N: float | None = None) -> list[Path]:
    """All four figures of a helical tables file into ``out_dir`` → their paths."""
    t = read_tables(tables_path)
    m = t.mesh(mesh)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    force = force_N if force_N is not None else float(m.load_N[-1]) / 3.0
    figs = {"helical_gfdf.png": plot_gfdf(m), "helical_twist.png": plot_twist(m),
            "helical_pattern.png": plot_pattern(m, force),
            "helical_sdf.png": plot_face_sdf(m, [g for g in m.strain if g.rsplit("/", 1)[1].startswith("SG")])}
    paths = []
    for name, fig in figs.items():
        fig.savefig(out / name, dpi=110)
        paths.append(out / name)
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("tables", nargs="?", default="models/helical_28_33/tables.h5")
    ap.add_argument("--mesh", default=None)
    ap.add_argument("--force", type=float, default=None, help="mesh force of the contact-pattern figure [N] "
                                                               "(default: the nominal force)")
    ap.add_argument("--out", default="docs/figures")
    a = ap.parse_args(argv)
    for p in write_helical_figures(a.tables, a.out, a.mesh, a.force):
        print(p)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
