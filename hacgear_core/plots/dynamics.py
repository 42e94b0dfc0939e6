"""Figures of docs/dynamics.md, all from SYNTHETIC tables (``python -m hacgear_core.plots.dynamics OUTDIR``)."""
from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hacgear_core.kinds import spur_pair_system  # noqa: E402
from hacgear_core.errors import HacgearError  # noqa: E402
from hacgear_core.outpaths import check_out_dir  # noqa: E402
from hacgear_core.plots.sweep import mark_jump  # noqa: E402
from hacgear_core.dynamics.steady import steady_state  # noqa: E402
from hacgear_core.dynamics.sweep import SweepSpec, run_sweep  # noqa: E402
from hacgear_core.dynamics.synthetic import softening_example, spur_fdf_table, synthetic_28t_parameters  # noqa: E402
from hacgear_core.response import (  # noqa: E402
    dynamic_contact_pressure,
    dynamic_mesh_stiffness,
    dynamic_root_strain,
    static_mesh_stiffness,
)

__all__ = ["main"]


def main(outdir: str) -> dict:
    """Draw the figures into ``outdir``; returns the facts the text quotes."""
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    facts = {}
    tab = spur_fdf_table(tip_relief_m=20e-6)
    p = synthetic_28t_parameters(tab, torque_Nm=300.0)
    sy = spur_pair_system(p, tab)
    fn = sy.natural_frequencies_Hz()[0]
    facts["fn_Hz"] = fn

    # 1. sweep: HAC up/down and the conventional laws
    fm = tuple(np.linspace(0.2 * fn, 1.5 * fn, 131))
    fig, ax = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    styles = {"hac": ("k", "HAC"), "local_slope": ("tab:green", "local slope (Eq. 3.8)"),
              "average_slope": ("tab:orange", "average slope (Eq. 3.7)"), "ste": ("tab:blue", "STE (Eq. 3.6)")}
    for law, (col, lab) in styles.items():
        r = run_sweep(SweepSpec(spur_pair_system(p, tab, law), fm, "both"), progress=False)
        hac = law == "hac"
        for b, mk in (("up", "o"), ("down", "x")):
            br = r.branches[b]
            f = br.mesh_frequency_Hz / fn
            # HAC on top as lines; the conventional laws as markers below (filled: up, crosses: down)
            kw = dict(color=col, ms=3.5 if hac else 4.5, lw=1.2 if hac else 0, zorder=4 if hac else 2,
                      ls=("-" if b == "up" else "--") if hac else "none", marker=mk,
                      mfc=col if mk == "o" and not hac else "none", alpha=1.0 if hac else 0.75)
            ax[0].plot(f, br.metrics["rms_deflection_m"][:, 0] * 1e6, label=f"{lab}, {b} sweep", **kw)
            ax[1].plot(f, br.metrics["mean_deflection_m"][:, 0] * 1e6, **kw)
        if hac:
            facts["hac_jumps"] = [(j.kind, j.branch, j.interval_Hz) for j in r.jumps if j.confirmed]
            for j in r.jumps:
                if j.confirmed:
                    ax[0].axvline(j.frequency_Hz / fn, color="0.5", ls=":", lw=0.8, zorder=1)
    ax[0].set_yscale("log")  # the large-amplitude (rattling) branch and the small ones both readable
    ax[0].set_ylabel("RMS of oscillating mesh deflection [µm] (log)")
    ax[1].set_ylabel("mean mesh deflection [µm]")
    ax[1].set_xlabel(f"$f_m / f_n$  ($f_n$ = {fn:.0f} Hz, linearised; dotted: confirmed HAC jumps)")
    h, lab = ax[0].get_legend_handles_labels()
    ax[1].legend(h, lab, fontsize=7, ncol=2, loc="lower right")  # the empty corner of the lower panel
    ax[0].set_title("SYNTHETIC table (28-tooth blanks, 150 N/µm, 20 µm tip relief), 300 N·m, ζ = 0.02")
    fig.tight_layout()
    fig.savefig(out / "dynamics_sweep_synthetic.png", dpi=120)
    plt.close(fig)

    # 2. dynamic vs static mesh stiffness near resonance (cf. dissertation Fig. 3.12)
    fm_r = 1.0 * fn
    r = steady_state(sy, fm_r, keep_trace=True)
    tau, x = r.trace["mesh_position"][:, 0], r.trace["mesh_deflection_m"][:, 0]
    kd = dynamic_mesh_stiffness(tab, tau, x)
    st = static_mesh_stiffness(tab, p.torque_Nm)
    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    ax[0].plot(tau, kd / 1e6, "r-", label=f"dynamic (HAC, $f_m/f_n$ = {fm_r / fn:.2f})")
    ax[0].plot(st.position, st.local_slope_N_per_m / 1e6, "b--", label="static local slope at 300 N·m")
    ax[0].set_ylabel("mesh stiffness [N/µm]")
    ax[0].legend(fontsize=8)
    ax[1].plot(tau, x * 1e6, "r-", label="dynamic mesh deflection")
    ax[1].plot(st.position, st.deflection_m * 1e6, "b--", label="static mesh deflection")
    ax[1].plot(st.position, st.no_load_deflection_m * 1e6, "k:", label="no-load mesh deflection")
    ax[1].set_ylabel("mesh deflection [µm]")
    ax[1].set_xlabel("mesh position [cycles]")
    ax[1].legend(fontsize=8)
    ax[0].set_title("SYNTHETIC table: dynamic mesh stiffness over one steady-state cycle")
    fig.tight_layout()
    fig.savefig(out / "dynamics_stiffness_synthetic.png", dpi=120)
    plt.close(fig)
    facts["resonance_contact_loss_fraction"] = float(r.metrics["contact_loss_fraction"][0])

    # 3. dynamic root strain and contact pressure at two speeds (cf. dissertation Figs. 3.7-3.9)
    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    tau_s = np.linspace(-1, 2, 600, endpoint=False)
    xs = np.interp(tau_s % 1.0, st.position, st.deflection_m, period=1.0)
    ax[0].plot(tau_s, dynamic_root_strain(tab, "wheel/SG", tau_s, xs) * 1e6, "k--", label="static")
    for ratio, col in ((0.57, "tab:blue"), (0.9, "tab:red")):
        rr = steady_state(sy, ratio * fn)
        rr = steady_state(sy, ratio * fn, rr.state, keep_trace=True)
        t1, x1 = rr.trace["mesh_position"][:, 0], rr.trace["mesh_deflection_m"][:, 0]
        # one steady cycle repeated over three cycles (period-1 orbit), tooth followed through its mesh
        reps = int(np.ceil(3 / max(rr.period_cycles, 1)))
        tt = np.concatenate([t1 - 1 + k * max(rr.period_cycles, 1) for k in range(reps)])
        xx = np.tile(x1, reps)
        sel = tt < 2
        ax[0].plot(tt[sel], dynamic_root_strain(tab, "wheel/SG", tt[sel], xx[sel]) * 1e6, color=col,
                   label=f"dynamic, $f_m/f_n$ = {ratio}")
        ax[1].plot(tt[sel], dynamic_contact_pressure(tab, tt[sel], xx[sel]) / 1e6, color=col)
    ax[1].plot(tau_s, dynamic_contact_pressure(tab, tau_s, xs) / 1e6, "k--")
    ax[0].set_ylabel("root strain, wheel/SG [µε]")
    ax[1].set_ylabel("max contact pressure [MPa]")
    ax[1].set_xlabel("mesh position [cycles] (followed tooth: reference pair at 0..1)")
    ax[0].legend(fontsize=8)
    ax[0].set_title("SYNTHETIC table: post-processed root strain and contact pressure")
    fig.tight_layout()
    fig.savefig(out / "dynamics_strain_synthetic.png", dpi=120)
    plt.close(fig)

    # 4. the classical softening oscillator: jumps
    lp, ltab, xs0 = softening_example()
    lsy = spur_pair_system(lp, ltab)
    fnl = lsy.natural_frequencies_Hz()[0]
    r = run_sweep(SweepSpec(lsy, tuple(np.linspace(0.5 * fnl, 1.3 * fnl, 81)), "both"), progress=False)
    fig, ax = plt.subplots(figsize=(8, 4))
    for b, mk, col, ms, lw in (("up", "o-", "tab:blue", 5, 1.8), ("down", "x--", "tab:red", 4, 1.0)):
        br = r.branches[b]
        ax.plot(br.mesh_frequency_Hz / fnl, br.metrics["rms_deflection_m"][:, 0] / xs0, mk, color=col, ms=ms, lw=lw,
                label=f"{b} sweep")
    for n, j in enumerate([j for j in r.jumps if j.confirmed], 1):
        mark_jump(ax, j, "tab:blue" if j.branch == "up" else "tab:red", n, x_scale=1 / fnl, y_scale=1 / xs0,
                  where=f"$f_m/f_n$ = {j.frequency_Hz / fnl:.3f}")
    facts["softening_jumps_f_over_fn"] = [(j.kind, j.frequency_Hz / fnl) for j in r.jumps if j.confirmed]
    ax.set_xlabel("$f_m / f_n$   (arrows: confirmed jumps)")
    ax.set_ylabel("RMS deflection / static deflection [-]")
    ax.set_title("constant stiffness, sinusoidal NLMD (20 % of static deflection), contact loss, ζ = 0.03")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "dynamics_softening_synthetic.png", dpi=120)
    plt.close(fig)
    return facts


if __name__ == "__main__":  # pragma: no cover
    if len(sys.argv) != 2 or sys.argv[1].startswith("-"):
        raise SystemExit("usage: python -m hacgear_core.plots.dynamics OUTDIR  (writes the figures into OUTDIR only)")
    try:
        check_out_dir(sys.argv[1], "OUTDIR")
    except HacgearError as exc:
        raise SystemExit(f"python -m hacgear_core.plots.dynamics: error: {exc}") from None
    print(main(sys.argv[1]))
