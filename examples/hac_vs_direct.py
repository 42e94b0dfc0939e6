"""Figures of HAC against the level-1 direct model (docs/hac_vs_direct.md) from the benchmark's output.

``python benchmarks/bench_hac_vs_direct.py --grid 16,32,48,96,128 --grid-extra 128x64,64x128,256x64,512x64 --json
/tmp/hac18/final.json --traces /tmp/hac18/final.npz`` (and ``--level1-json /tmp/hac18/final.json --grid-extra 256x128
--json /tmp/hac18/grid_256x128.json`` for an added grid) writes the numbers and the recorded periods; this script
draws, per spur pair, the steady state over one mesh cycle at each speed (dynamic transmission error, mesh force,
and the root strain of one tooth through its pass, like dissertation Figs. 3.7-3.8) and the grid-resolution study::

    python examples/hac_vs_direct.py /tmp/hac18/main256.json /tmp/hac18/main256.npz \\
        --extra-json /tmp/hac18/final.json /tmp/hac18/grid_256x128.json --out docs/figures

(``main256``: the comparison on the committed tables; ``final``: the grid study, whose comparison rows ran on the
former 64 x 64 tables and are drawn as that grid's points.)
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hacgear_core.cli._help import plain_text  # noqa: E402


def tooth_pass(position: np.ndarray, strain: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Root strain of one tooth through its pass from one period-1 cycle: the tooth of pair offset ``o`` at mesh
    position ``p`` (in the table's / solver's frame, about [0, 1]) has phase ``p - o`` (``MeshTable.tooth_phase``),
    so the offsets' columns over one cycle tile the tooth's whole window.  Returns (phase [cycles], strain), sorted
    by phase."""
    ph = np.concatenate([position - o for o in offsets])
    ev = np.concatenate([strain[:, j] for j in range(len(offsets))])
    k = np.argsort(ph)
    return ph[k], ev[k]


def main() -> None:
    ap = argparse.ArgumentParser(description=plain_text(__doc__.splitlines()[0]),
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("json", help="JSON output of benchmarks/bench_hac_vs_direct.py --json")
    ap.add_argument("traces", help="recorded periods (.npz) of benchmarks/bench_hac_vs_direct.py --traces")
    ap.add_argument("--out", default="docs/figures", help="folder of the figures")
    ap.add_argument("--extra-json", nargs="*", default=[], help="more grid-study outputs (--level1-json runs)")
    args = ap.parse_args()
    data = json.loads(Path(args.json).read_text())
    tr = np.load(args.traces)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    pairs = sorted({r["pair"] for r in data["rows"]})
    for pair in pairs:
        rows = [r for r in data["rows"] if r["pair"] == pair]
        fig, axes = plt.subplots(len(rows), 3, figsize=(13, 3.1 * len(rows)), squeeze=False)
        for i, r in enumerate(rows):
            key = f"{pair}_{r['fm_over_fn']:g}"
            offs = tr[f"{key}/tooth_offsets"]
            for who, style, lab in (("hac", "-", "HAC (64 x 64 tables)"), ("level1", "--", "level 1 (solver per stage)")):
                p = tr[f"{key}/{who}/position"]
                pp = np.mod(p, 1.0)
                o = np.argsort(pp)
                axes[i, 0].plot(pp[o], tr[f"{key}/{who}/dte_m"][o] * 1e6, style, label=lab)
                axes[i, 1].plot(pp[o], tr[f"{key}/{who}/force_N"][o] / 1e3, style, label=lab)
                ph, ev = tooth_pass(p, tr[f"{key}/{who}/root_strain"], offs)
                axes[i, 2].plot(ph, ev * 1e6, style, label=lab)
            axes[i, 0].set_ylabel(f"{r['label']}\nf_m/f_n = {r['fm_over_fn']:g}\nDTE [um]")
            axes[i, 1].set_ylabel("mesh force [kN]")
            axes[i, 2].set_ylabel(f"root strain {r['gauge']} [ue]")
            e = r["errors"]
            axes[i, 0].set_title(f"RMS DTE error {e['dte_rms_m'] * 100:+.2f} %", fontsize=9)
            axes[i, 1].set_title(f"peak force error {e['peak_force_N'] * 100:+.2f} %", fontsize=9)
            axes[i, 2].set_title(f"max root strain error {e['max_root_strain'] * 100:+.2f} %", fontsize=9)
        for ax in axes[-1, :2]:
            ax.set_xlabel("mesh position in the cycle [cycles]")
        axes[-1, 2].set_xlabel("tooth phase [mesh cycles] (0: pitch point)")
        axes[0, 0].legend(fontsize=8)
        fig.suptitle(f"{pair}: HAC against the level-1 direct model, steady state over one mesh cycle")
        fig.tight_layout()
        fig.savefig(out / f"hac_vs_direct_{pair}.png", dpi=110)
        plt.close(fig)
    grid = list(data.get("grid", []))
    for extra in args.extra_json:
        more = json.loads(Path(extra).read_text())
        grid += more.get("grid", [])
        # an earlier comparison run's rows are grid points at the tables it ran on (64 x 64 before they were recorded)
        grid += [dict(pair=x["pair"], fm_over_fn=x["fm_over_fn"], errors=x["errors"],
                      positions=x.get("table_grid", (64, 64))[0], deflections=x.get("table_grid", (64, 64))[1])
                 for x in more.get("rows", [])]
    if grid:
        fig, axes = plt.subplots(2, len(pairs), figsize=(6.2 * len(pairs), 7.5), squeeze=False)
        for j, pair in enumerate(pairs):
            for r, col in zip((0.6, 1.0, 0.5), ("C0", "C1", "C2")):
                ref = [x for x in data["rows"] if x["pair"] == pair and x["fm_over_fn"] == r]
                if not ref:
                    continue
                pts = {tuple(ref[0].get("table_grid", (64, 64))): ref[0]["errors"]}
                pts.update({(g["positions"], g["deflections"]): g["errors"] for g in grid
                            if g["pair"] == pair and g["fm_over_fn"] == r})
                for fam, style in (("N x N", "o-"), ("N x 64", "s--")):
                    sel = sorted((p, e) for (p, d), e in pts.items() if (d == p if fam == "N x N" else d == 64))
                    if len(sel) < 2:
                        continue
                    for i, k in enumerate(("dte_rms_m", "max_root_strain")):
                        axes[i, j].plot([p for p, _ in sel], [max(abs(e[k]) * 100, 1e-3) for _, e in sel], style,
                                        color=col, label=f"f_m/f_n = {r:g}, {fam}")
            for i, (k, lim) in enumerate((("RMS DTE", 1.0), ("max root strain", 2.0))):
                ax = axes[i, j]
                ax.axhline(lim, color="k", lw=0.8, ls=":")
                ax.set_xscale("log", base=2)
                ax.set_yscale("log")
                ax.set_title(pair, fontsize=10)
                ax.set_xlabel("table positions N (deflections N or 64)")
                ax.set_ylabel(f"|HAC - level 1| / level 1, {k} [%]")
        axes[0, 0].legend(fontsize=7)
        fig.suptitle("grid-resolution study of the HAC tables against level 1 (dotted: issue #18 criteria)")
        fig.tight_layout()
        fig.savefig(out / "hac_vs_direct_grid.png", dpi=110)
        plt.close(fig)

if __name__ == "__main__":
    main()
