"""Figures of HAC against the level-1 direct model (docs/hac_vs_direct.md) from the benchmark's output.

``python benchmarks/bench_hac_vs_direct.py --grid 16,32,48,96,128 --json /tmp/hac18/bench.json --traces
/tmp/hac18/traces.npz`` writes the numbers and the recorded periods; this script draws, per spur pair, the steady
state over one mesh cycle at each speed (dynamic transmission error, mesh force, and the root strain of one tooth
through its pass, like dissertation Figs. 3.7-3.8) and the grid-resolution study::

    python examples/hac_vs_direct.py /tmp/hac18/bench.json /tmp/hac18/traces.npz --out docs/figures
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


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
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("json")
    ap.add_argument("traces")
    ap.add_argument("--out", default="docs/figures")
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
        axes[-1, 2].set_xlabel("tooth phase [mesh cycles] (0: its pair at the pitch point)")
        axes[0, 0].legend(fontsize=8)
        fig.suptitle(f"{pair}: HAC against the level-1 direct model, steady state over one mesh cycle")
        fig.tight_layout()
        fig.savefig(out / f"hac_vs_direct_{pair}.png", dpi=110)
        plt.close(fig)
    if data.get("grid"):
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
        for pair in pairs:
            for r in sorted({g["fm_over_fn"] for g in data["grid"] if g["pair"] == pair}):
                pts = [(64, 64, [x for x in data["rows"] if x["pair"] == pair and x["fm_over_fn"] == r][0]["errors"])]
                pts += [(g["positions"], g["deflections"], g["errors"]) for g in data["grid"]
                        if g["pair"] == pair and g["fm_over_fn"] == r and g["positions"] == g["deflections"]]
                pts.sort()
                n = [p for p, _, _ in pts]
                for ax, k in zip(axes, ("dte_rms_m", "max_root_strain")):
                    ax.plot(n, [abs(e[k]) * 100 for _, _, e in pts], "o-", label=f"{pair} f_m/f_n={r:g}")
        for ax, k, lim in zip(axes, ("RMS DTE", "max root strain"), (1.0, 2.0)):
            ax.axhline(lim, color="k", lw=0.8, ls=":")
            ax.set_xscale("log", base=2)
            ax.set_yscale("log")
            ax.set_xlabel("table grid N (positions = deflections)")
            ax.set_ylabel(f"|HAC - level 1| / level 1, {k} [%]")
        axes[0].legend(fontsize=7)
        fig.suptitle("grid-resolution study of the HAC tables against level 1 (dotted: issue #18 criteria)")
        fig.tight_layout()
        fig.savefig(out / "hac_vs_direct_grid.png", dpi=110)
        plt.close(fig)


if __name__ == "__main__":
    main()
