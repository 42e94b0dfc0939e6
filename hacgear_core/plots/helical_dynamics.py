"""Figures of a helical pair's dynamic response from a ``hacgear simulate --out trace.npz`` trace (Figs. 5.11, 5.12).

``python -m hacgear_core.plots.helical_dynamics TRACE.npz [--mesh m12] [--gear wheel] [--teeth 33] [--out DIR]``
writes ``helical_dynamic.png`` (dynamic mesh deflection, mesh twist, mesh force and twist moment over mesh cycles)
and ``helical_strains.png`` (root strains of the gauges of ``--gear`` over the pair phase of its tooth 0).
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, Mapping

import numpy as np

__all__ = ["plot_dynamic_mesh", "plot_face_strains", "main"]


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_dynamic_mesh(trace: Mapping[str, np.ndarray], mesh: str = "m12", *, cycles: float = 4.0) -> Any:
    """Fig. 5.11: the dynamic mesh deflection [µm] and mesh twist [µrad] (left axes), the mesh force [kN] and
    twist moment [N m] over the last ``cycles`` mesh cycles of ``trace`` (arrays keyed as ``hacgear simulate``
    writes them: ``<mesh>.position``, ``.deflection_m``, ``.twist_rad``, ``.force_N``, ``.twist_moment_Nm``)."""
    plt = _plt()
    tau = np.asarray(trace[f"{mesh}.position"])
    sel = tau >= tau[-1] - cycles
    t = tau[sel] - np.floor(tau[sel][0])
    fig, ax = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    ax[0].plot(t, np.asarray(trace[f"{mesh}.deflection_m"])[sel] * 1e6, color="C0", label="mesh deflection x")
    ax[0].set_ylabel("mesh deflection x [µm]", color="C0")
    a2 = ax[0].twinx()
    a2.plot(t, np.asarray(trace[f"{mesh}.twist_rad"])[sel] * 1e6, color="C3", label="mesh twist γ")
    a2.set_ylabel("mesh twist γ [µrad]", color="C3")
    ax[1].plot(t, np.asarray(trace[f"{mesh}.force_N"])[sel] * 1e-3, color="C0")
    ax[1].set_ylabel("mesh force W [kN]", color="C0")
    b2 = ax[1].twinx()
    b2.plot(t, np.asarray(trace[f"{mesh}.twist_moment_Nm"])[sel], color="C3")
    b2.set_ylabel("twist moment M [N·m]", color="C3")
    ax[1].set_xlabel("mesh position [mesh cycles]")
    ax[0].set_title(f"dynamic mesh deflection and twist, mesh {mesh}")
    fig.tight_layout()
    return fig


def plot_face_strains(trace: Mapping[str, np.ndarray], gear: str = "wheel", teeth: int = 33, mesh: str = "m12",
                      gauges: tuple[str, ...] | None = None) -> Any:
    """Fig. 5.12: root strains [µε] at the gauges of ``gear`` (default every ``strain[<gear>/...]`` of the trace)
    over the pair phase of its tooth 0 [mesh cycles; 0 = its pitch-point contact in the reference plane]."""
    plt = _plt()
    tau = np.asarray(trace[f"{mesh}.position"])
    ph = ((tau + 0.5 * teeth) % teeth) - 0.5 * teeth
    keys = [k for k in trace if k.startswith(f"strain[{gear}/")]
    if gauges is not None:
        keys = [f"strain[{gear}/{g}]" for g in gauges]
    o = np.argsort(ph)
    win = (ph[o] > -3.0) & (ph[o] < 4.0)
    fig, ax = plt.subplots(figsize=(9, 4.8))
    for k in sorted(keys):
        ax.plot(ph[o][win], np.asarray(trace[k])[o][win] * 1e6, label=k[7:-1])
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel(f"pair phase of tooth 0 of {gear} [mesh cycles]")
    ax.set_ylabel("root strain [µε]")
    ax.set_title(f"dynamic root strains of {gear} across the face")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trace", help="trace .npz written by hacgear simulate --out")
    ap.add_argument("--mesh", default="m12")
    ap.add_argument("--gear", default="wheel")
    ap.add_argument("--teeth", type=int, default=33)
    ap.add_argument("--out", default=".")
    a = ap.parse_args(argv)
    tr = dict(np.load(a.trace))
    out = Path(a.out)
    plot_dynamic_mesh(tr, a.mesh).savefig(out / "helical_dynamic.png", dpi=110)
    plot_face_strains(tr, a.gear, a.teeth, a.mesh).savefig(out / "helical_strains.png", dpi=110)
    print(f"wrote {out / 'helical_dynamic.png'}, {out / 'helical_strains.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
