"""Dynamic validation against the dissertation on the committed FE tables: numbers and figures.

``python -m hacgear_core.plots.validation --out DIR`` computes the natural frequencies and speed sweeps that
``docs/validation.md`` quotes and draws the figures beside them (dissertation Figs. 3.5, 3.7-3.12 analogues) into
``DIR`` (``validation_dynamics.json`` and PNG files).  Every number is computed here from the shipped systems'
``tables.h5`` — nothing is stored by hand.  ``docs/`` is regenerated with ``--out docs`` (JSON) and
``--figures docs/figures``.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hacgear_core.errors import HacgearError  # noqa: E402
from hacgear_core.outpaths import check_out_dir  # noqa: E402
from hacgear_core.dynamics.modes import impulse_test, modal_analysis  # noqa: E402
from hacgear_core.dynamics.steady import steady_state  # noqa: E402
from hacgear_core.dynamics.sweep import SweepSpec, run_sweep  # noqa: E402
from hacgear_core.kinds import build_system, load_model  # noqa: E402
from hacgear_core.plots.sweep import mark_jump  # noqa: E402
from hacgear_core.response import dynamic_contact_pressure, dynamic_mesh_stiffness, dynamic_root_strain  # noqa: E402
from hacgear_core.response import static_mesh_stiffness  # noqa: E402
from hacgear_core.tables import load_system_tables  # noqa: E402
from hacgear_core.tables.fdf import static_stiffness  # noqa: E402

__all__ = ["natural_frequencies", "sweep", "idler_study", "flanks_study", "main"]


def _system(system: str, torque: float, bearing: float | None = None, force_law: str = "hac"):
    model = load_model(system)
    tables = load_system_tables(model.path)
    return build_system(model, tables, torque_Nm=torque, bearing_stiffness_N_per_m=bearing, force_law=force_law)


def natural_frequencies(system: str, torque: float, bearing: float | None = None) -> dict:
    """Linearised modal analysis and the impulse test (dissertation 3.6.1) at ``torque`` [N m]."""
    sy = _system(system, torque, bearing)
    ma = modal_analysis(sy)
    it = impulse_test(sy)
    return {
        "linearised_Hz": [float(f) for f in ma.natural_frequencies_Hz],
        "impulse_single_Hz": [float(f) for f in it.single_contact_Hz],
        "impulse_double_Hz": [float(f) for f in it.double_contact_Hz],
        "impulse_weighted_Hz": [float(f) for f in it.weighted_mean_Hz],
    }


def sweep(system: str, torque: float, fm_over_fn: tuple[float, float, int], force_law: str = "hac") -> dict:
    """Up and down sweep over ``f_m/f_n`` (``f_n`` linearised, HAC) → branches (first mesh) and confirmed jumps."""
    fn = float(modal_analysis(_system(system, torque)).natural_frequencies_Hz[0])
    sy = _system(system, torque, force_law=force_law)
    fm = tuple(np.linspace(fm_over_fn[0] * fn, fm_over_fn[1] * fn, fm_over_fn[2]))
    t0 = time.perf_counter()
    r = run_sweep(SweepSpec(sy, fm, "both"), progress=False)
    out = {"fn_Hz": fn, "wall_s": time.perf_counter() - t0, "branches": {}, "jumps": [],
           "confirmed_jumps": [j for j in r.jumps if j.confirmed]}
    for b, br in r.branches.items():
        out["branches"][b] = {
            "fm_over_fn": (np.asarray(br.mesh_frequency_Hz) / fn).tolist(),
            "rms_deflection_m": np.asarray(br.metrics["rms_deflection_m"])[:, 0].tolist(),
            "mean_deflection_m": np.asarray(br.metrics["mean_deflection_m"])[:, 0].tolist(),
            "contact_loss_fraction": np.asarray(br.metrics["contact_loss_fraction"])[:, 0].tolist(),
        }
    for j in out["confirmed_jumps"]:
        out["jumps"].append({"kind": j.kind, "branch": j.branch, "fm_over_fn": j.frequency_Hz / fn,
                             "frequency_Hz": j.frequency_Hz, "interval_Hz": list(j.interval_Hz),
                             "rms_before_m": j.rms_before_m, "rms_after_m": j.rms_after_m})
    return out


def _plot_sweep(res: dict, title: str, path: Path, extra: dict | None = None) -> None:
    fig, ax = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    # up below with large filled circles, down on top with crosses: both visible where they coincide
    for b, mk, col, ms, lw in (("up", "o-", "k", 4.5, 1.4), ("down", "x--", "tab:red", 4, 0.8)):
        br = res["branches"][b]
        ax[0].plot(br["fm_over_fn"], np.array(br["rms_deflection_m"]) * 1e6, mk, color=col, ms=ms, lw=lw,
                   label=f"HAC, {b} sweep", zorder=3)
        ax[1].plot(br["fm_over_fn"], np.array(br["mean_deflection_m"]) * 1e6, mk, color=col, ms=ms, lw=lw, zorder=3)
    for law, r in (extra or {}).items():
        style = {"local_slope": ("^", "tab:green", "local slope (Eq. 3.8)"),
                 "average_slope": ("x", "tab:orange", "average slope (Eq. 3.7)"),
                 "ste": ("+", "tab:blue", "STE (Eq. 3.6)")}[law]
        br = r["branches"]["up"]
        ax[0].plot(br["fm_over_fn"], np.array(br["rms_deflection_m"]) * 1e6, style[0], color=style[1], ms=4,
                   label=style[2] + ", up")
        ax[1].plot(br["fm_over_fn"], np.array(br["mean_deflection_m"]) * 1e6, style[0], color=style[1], ms=4)
    for n, j in enumerate(res["confirmed_jumps"], 1):
        mark_jump(ax[0], j, "k" if j.branch == "up" else "tab:red", n, x_scale=1 / res["fn_Hz"], y_scale=1e6,
                  where=f"$f_m/f_n$ = {j.frequency_Hz / res['fn_Hz']:.3f}")
    ax[0].set_ylabel("RMS of oscillating mesh deflection [µm]")
    ax[1].set_ylabel("mean mesh deflection [µm]")
    ax[1].set_xlabel(f"$f_m / f_n$   ($f_n$ = {res['fn_Hz']:.0f} Hz, linearised; arrows: confirmed HAC jumps)")
    ax[0].set_title(title, fontsize=9)
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_time_traces(system: str, torque: float, ratios: tuple[float, ...], gauge: str, path: Path) -> dict:
    """Steady-state time traces over three mesh cycles at several ``f_m/f_n`` (dissertation Figs. 3.7-3.9,
    3.11, 3.12): mesh deflection, mesh force, root strain of one followed tooth, peak contact pressure and the
    dynamic mesh stiffness (local slope of the FDF at the dynamic state; static: local slope at the static
    deflection); static values dashed.  Returns the dynamic factor (max dynamic / max static strain) per
    ratio."""
    sy = _system(system, torque)
    table = sy.meshes[0].table
    fn = float(modal_analysis(sy).natural_frequencies_Hz[0])
    st = static_mesh_stiffness(table, torque)
    fig, ax = plt.subplots(5, 1, figsize=(8, 12), sharex=True)
    tau_s = np.linspace(-1.0, 2.0, 600, endpoint=False)
    xs = np.interp(tau_s % 1.0, st.position, st.deflection_m, period=1.0)
    static_strain = dynamic_root_strain(table, gauge, tau_s, xs)
    k_static = np.interp(tau_s % 1.0, st.position, st.local_slope_N_per_m, period=1.0)
    for a, y in zip(ax, (xs * 1e6, table.force(tau_s, xs) / 1e3,
                         static_strain * 1e6, dynamic_contact_pressure(table, tau_s, xs) / 1e6,
                         k_static / 1e6)):
        a.plot(tau_s, y, "k--", lw=1.2, label="static", zorder=5)  # on top: dynamic curves close to it hide it
    factors = {}
    for ratio, col in zip(ratios, ("tab:blue", "tab:green", "tab:red", "tab:purple")):
        r = steady_state(sy, ratio * fn)
        r = steady_state(sy, ratio * fn, r.state, keep_trace=True)
        t1, x1 = r.trace["mesh_position"][:, 0], r.trace["mesh_deflection_m"][:, 0]
        per = max(int(r.period_cycles), 1)
        tt = np.concatenate([t1 - t1[0] - 1 + k * per for k in range(int(np.ceil(3 / per)) + 1)])
        xx = np.tile(x1, int(np.ceil(3 / per)) + 1)
        sel = tt < 2
        tt, xx = tt[sel], xx[sel]
        strain = dynamic_root_strain(table, gauge, tt, xx)
        lab = f"$f_m/f_n$ = {ratio:g} ({ratio * fn:.0f} Hz)"
        ax[0].plot(tt, xx * 1e6, color=col, label=lab)
        ax[1].plot(tt, table.force(tt, xx) / 1e3, color=col)
        ax[2].plot(tt, strain * 1e6, color=col)
        ax[3].plot(tt, dynamic_contact_pressure(table, tt, xx) / 1e6, color=col)
        ax[4].plot(tt, dynamic_mesh_stiffness(table, tt, xx) / 1e6, color=col)
        factors[f"{ratio:g}"] = float(np.nanmax(strain) / np.nanmax(static_strain))
    ax[0].plot(tau_s, np.interp(tau_s % 1.0, st.position, st.no_load_deflection_m, period=1.0) * 1e6, "k:", lw=0.8,
               label="no-load deflection")
    ax[0].set_ylabel("mesh deflection [µm]")
    ax[1].set_ylabel("mesh force [kN]")
    ax[2].set_ylabel(f"root strain {gauge} [µε]")
    ax[3].set_ylabel("peak contact pressure [MPa]")
    ax[4].set_ylabel("mesh stiffness [N/µm]\n(local slope of the FDF)")
    ax[4].set_xlabel("mesh cycle (followed tooth pair at the pitch point at 0)")
    h, lab = ax[0].get_legend_handles_labels()
    fig.suptitle(f"{system}, {torque:g} N·m, FE tables: steady-state dynamic response ($f_n$ = {fn:.0f} Hz)",
                 fontsize=9, y=0.995)
    fig.legend(h, lab, loc="upper center", ncol=3, fontsize=8, bbox_to_anchor=(0.5, 0.98))  # above the panels
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return factors


def idler_study(fig_dir: Path, torque: float = 300.0, fm=(400.0, 4200.0, 191)) -> dict:
    """The idler chain at ``torque`` on gear 1 (dissertation Figs. 4.7, 4.8): natural frequencies and mode shapes,
    up/down sweeps of both meshes with their jumps, super-harmonic peaks, contact loss on the upper branch near
    3400 Hz, and the time traces there; figures ``validation_sweep_idler.png`` and ``validation_traces_idler.png``."""
    sy = _system("idler_28_33_39", torque)
    mr = modal_analysis(sy)
    it = impulse_test(sy)
    freqs = tuple(np.linspace(*fm[:2], int(fm[2])))
    t0 = time.perf_counter()
    r = run_sweep(SweepSpec(sy, freqs, "both"), progress=False)
    wall = time.perf_counter() - t0
    out = {"natural_frequencies_Hz": mr.natural_frequencies_Hz.tolist(), "dof_names": list(mr.dof_names),
           "mode_shapes": mr.mode_shapes.T.tolist(), "impulse_weighted_Hz": it.weighted_mean_Hz.tolist(),
           "mesh_phase_m23": float(sy.phase[1]), "sweep_wall_s": wall,
           "jumps": [{"mesh": j.mesh, "kind": j.kind, "branch": j.branch, "frequency_Hz": j.frequency_Hz,
                      "interval_Hz": list(j.interval_Hz)} for j in r.jumps if j.confirmed],
           "speeds_at_cycle_cap": {b: int(np.sum(~br.converged)) for b, br in r.branches.items()}}
    up, down = r.branches["up"], r.branches["down"]
    rms_up = np.asarray(up.metrics["rms_deflection_m"])
    peaks = {}
    for k, name in enumerate(sy.mesh_names):
        y = rms_up[:, k]
        f = np.asarray(up.mesh_frequency_Hz)
        peaks[name] = [float(f[i]) for i in range(1, len(f) - 1) if y[i] >= y[i - 1] and y[i] > y[i + 1]
                       and y[i] > 1.2 * np.median(y)]
    out["up_sweep_rms_peaks_Hz"] = peaks
    sel = (np.asarray(down.mesh_frequency_Hz) > 3300) & (np.asarray(down.mesh_frequency_Hz) < 3500)
    out["upper_branch_3300_3500Hz_contact_loss_fraction"] = dict(
        zip(sy.mesh_names, np.asarray(down.metrics["contact_loss_fraction"])[sel].max(axis=0).tolist()))
    fig, ax = plt.subplots(2, 1, figsize=(8, 8), sharex=True)
    for k, name in enumerate(sy.mesh_names):
        for b, mk, ls, col in (("up", "o", "-", "tab:blue"), ("down", "x", "--", "tab:red")):
            br = r.branches[b]
            ax[k].plot(br.mesh_frequency_Hz, np.asarray(br.metrics["rms_deflection_m"])[:, k] * 1e6, marker=mk,
                       ls=ls, color=col, ms=3, lw=0.8, label=f"{b} sweep")
            loss = np.asarray(br.metrics["contact_loss_fraction"])[:, k] > 0
            ax[k].plot(np.asarray(br.mesh_frequency_Hz)[loss], np.zeros(loss.sum()) - 0.5 * (b == "down"), "|",
                       color=col, ms=6, label=f"contact loss ({b})")
        marks = sorted((j.frequency_Hz, j.kind) for j in r.jumps if j.confirmed and j.mesh == name)
        for i_mark, (fj, kind) in enumerate(marks):
            ax[k].axvline(fj, color="0.5", ls=":", lw=0.8)
            ax[k].annotate(f"{kind} {fj:.0f} Hz", (fj, 1.0 + 0.07 * (i_mark % 2)), xycoords=("data", "axes fraction"),
                           fontsize=7, ha="center", va="bottom")
        for fn in mr.natural_frequencies_Hz:
            ax[k].axvline(fn, color="k", lw=0.6, alpha=0.4)
        ax[k].set_ylabel(f"RMS of oscillating mesh deflection, {name} [µm]")
        ax[k].legend(fontsize=7, loc="upper left")
    ax[1].set_xlabel("mesh frequency [Hz]   (thin lines: linearised natural frequencies; dotted: confirmed jumps)")
    fig.suptitle(f"idler_28_33_39, {torque:g} N·m on gear 1, FE tables (cf. dissertation Fig. 4.7)", fontsize=10,
                 y=0.995)
    fig.tight_layout()
    fig.savefig(fig_dir / "validation_sweep_idler.png", dpi=110)
    plt.close(fig)
    # Fig. 4.8: the upper branch at 3400 Hz (continued down from the down sweep's state just above)
    fd = np.asarray(down.mesh_frequency_Hz)
    i = int(np.argmin(np.abs(fd - 3400.0)))
    state = down.state[i - 1] if i > 0 else None
    rr = steady_state(sy, 3400.0, state)
    rr = steady_state(sy, 3400.0, rr.state, keep_trace=True)
    tau, x, f = rr.trace["mesh_position"], rr.trace["mesh_deflection_m"], rr.trace["mesh_force_N"]
    fig, ax = plt.subplots(2, 2, figsize=(10, 6), sharex="col")
    for k, name in enumerate(sy.mesh_names):
        tt = tau[:, k] - np.floor(tau[0, k])
        tab = sy.meshes[k].table
        ax[0, k].plot(tt, x[:, k] * 1e6, "b-", label="dynamic mesh deflection (HAC)")
        ax[0, k].plot(tt, tab.no_load_deflection(tt) * 1e6, "g:", label="no-load mesh deflection")
        ax[1, k].plot(tt, f[:, k] / 1e3, "b-")
        ax[0, k].set_title(f"mesh {name}", fontsize=9)
        ax[1, k].set_xlabel(f"mesh position of {name} [cycles]")
        ax[0, k].set_ylabel("mesh deflection [µm]")
        ax[1, k].set_ylabel("mesh force [kN]")
    ax[0, 0].legend(fontsize=7)
    fig.suptitle(f"idler_28_33_39 at 3400 Hz on the upper branch, {torque:g} N·m (cf. dissertation Fig. 4.8); "
                 f"contact loss {', '.join(f'{n} {v:.2f}' for n, v in zip(sy.mesh_names, rr.metrics['contact_loss_fraction']))}",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(fig_dir / "validation_traces_idler.png", dpi=110)
    plt.close(fig)
    out["traces_3400Hz"] = {"period_cycles": rr.period_cycles,
                            "contact_loss_fraction": dict(zip(sy.mesh_names, rr.metrics["contact_loss_fraction"].tolist())),
                            "rms_deflection_m": dict(zip(sy.mesh_names, rr.metrics["rms_deflection_m"].tolist()))}
    return out


def _branch_metrics(res, fn: float, ratio: float) -> dict:
    """Steady-state metrics of both branches of a sweep at the speed nearest ``ratio * fn``."""
    out = {}
    for b, br in res.branches.items():
        i = int(np.argmin(np.abs(br.mesh_frequency_Hz / fn - ratio)))
        out[b] = {"fm_over_fn": float(br.mesh_frequency_Hz[i] / fn), "period_cycles": int(br.period_cycles[i]),
                  **{k: float(br.metrics[k][i, 0]) for k in ("contact_loss_fraction", "skipped_tooth_fraction",
                                                            "back_side_contact_fraction", "dynamic_factor_force",
                                                            "dynamic_factor_strain")}}
    return out


def flanks_study(fig_dir: Path) -> dict:
    """Both flanks (issue #13; dissertation Section 2.4.2, Figs. 2.8(c,d), 2.11, 2.12): the 28-tooth pair with its
    20° flank loaded (a negative torque: the coast tables) at 100 N·m through f_m/f_n = 1.7 (tooth skipping) and at
    300 N·m at 0.494; the 50-tooth ICR 1.8 pair at 200 N·m around its resonance.  Up and down sweeps, metrics of
    both branches; figure: the root strain of three consecutive wheel teeth on the skipping branch against the
    static strain (Fig. 2.12 analogue)."""
    out: dict = {}
    m28 = load_model("spur_28t_asym")
    t28 = load_system_tables(m28.path)
    sy = build_system(m28, t28, torque_Nm=-100.0)
    fn = float(sy.natural_frequencies_Hz()[0])
    r = run_sweep(SweepSpec(sy, tuple(fn * np.linspace(1.4, 2.2, 33)), "both"), progress=False)
    out["spur_28t_asym_20deg_100Nm"] = {"fn_Hz": fn, "at_1.7": _branch_metrics(r, fn, 1.7)}
    sy3 = build_system(m28, t28, torque_Nm=-300.0)
    fn3 = float(sy3.natural_frequencies_Hz()[0])
    r3 = run_sweep(SweepSpec(sy3, tuple(fn3 * np.linspace(0.4, 0.6, 21)), "both"), progress=False)
    out["spur_28t_asym_20deg_300Nm"] = {"fn_Hz": fn3, "at_0.494": _branch_metrics(r3, fn3, 0.494)}
    m50 = load_model("spur_50t_icr18")
    s50 = build_system(m50, load_system_tables(m50.path), torque_Nm=200.0)
    fn5 = float(s50.natural_frequencies_Hz()[0])
    r5 = run_sweep(SweepSpec(s50, tuple(fn5 * np.linspace(0.8, 1.2, 81)), "both"), progress=False)
    e5 = {"fn_Hz": fn5, "at_1.0": _branch_metrics(r5, fn5, 1.0), "at_1.069": _branch_metrics(r5, fn5, 1.069)}
    for b, br in r5.branches.items():
        k = int(np.argmax(br.metrics["dynamic_factor_strain"][:, 0]))
        e5[f"peak_{b}"] = {"fm_over_fn": float(br.mesh_frequency_Hz[k] / fn5),
                           "dynamic_factor_strain": float(br.metrics["dynamic_factor_strain"][k, 0]),
                           "contact_loss_fraction": float(br.metrics["contact_loss_fraction"][k, 0])}
    out["spur_50t_icr18_200Nm"] = e5
    # Fig. 2.12 analogue: the skipping branch at 1.7 (the down sweep's state there), three consecutive wheel teeth
    down = r.branches["down"]
    i = int(np.argmin(np.abs(down.mesh_frequency_Hz / fn - 1.7)))
    rr = steady_state(sy, float(down.mesh_frequency_Hz[i]), down.state[i], keep_trace=True)
    table = sy.meshes[0].coast_table
    gauge = "wheel/SG20"
    per = max(int(rr.period_cycles), 1)
    tau, xc = rr.trace["mesh_position"][:, 0], rr.trace["coast_approach_m"][:, 0]
    reps = int(np.ceil(4 / per)) + 1
    tt = np.concatenate([tau - tau[0] + k * per for k in range(reps)])
    xx = np.tile(xc, reps)
    sel = tt < 4
    tt, xx = tt[sel], xx[sel]
    st = static_stiffness(table, float(sy.nominal_coast_forces_N()[0]))
    fig, ax = plt.subplots(figsize=(8, 4))
    for k, col in zip((1, 2, 3), ("tab:blue", "tab:red", "k")):
        shift = table.pair_shift["wheel"]
        dyn = table.sdf(gauge, tt - k - shift, xx)
        xs = np.interp(tt % 1.0, st.position, st.deflection_m, period=1.0)
        stat = table.sdf(gauge, tt - k - shift, xs)
        ax.plot(tt, dyn * 1e6, color=col, label=f"tooth i{k - 2:+d}".replace("+0", "") + " dynamic")
        ax.plot(tt, stat * 1e6, color=col, ls="--", lw=1)
    ax.set_xlabel("mesh cycle")
    ax.set_ylabel(f"root strain {gauge} [µε]")
    ax.set_title(f"spur_28t_asym, 20° flanks loaded, 100 N·m, $f_m/f_n$ = {down.mesh_frequency_Hz[i] / fn:.2f} "
                 f"(period-{per}): dynamic (solid) and static (dashed), cf. Fig. 2.12", fontsize=9)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(Path(fig_dir) / "validation_tooth_skipping.png", dpi=110)
    plt.close(fig)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hacgear_core.plots.validation", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="folder of validation_dynamics.json (created if missing)")
    ap.add_argument("--figures", default=None, help="figure folder (default: --out)")
    args = ap.parse_args(argv)
    try:
        check_out_dir(args.out, "--out")
        if args.figures:
            check_out_dir(args.figures, "--figures")
    except HacgearError as exc:
        ap.error(str(exc))
    out = Path(args.figures or args.out)
    out.mkdir(parents=True, exist_ok=True)
    Path(args.out).mkdir(parents=True, exist_ok=True)
    json_path = Path(args.out) / "validation_dynamics.json"
    res: dict = {}
    res["spur_28t_asym_300Nm_rigid"] = natural_frequencies("spur_28t_asym", 300.0)
    res["spur_28t_asym_300Nm_ky200e6"] = natural_frequencies("spur_28t_asym", 300.0, 200e6)
    res["spur_50t_icr137_170Nm"] = natural_frequencies("spur_50t_icr137", 170.0)
    res["spur_50t_icr18_200Nm"] = natural_frequencies("spur_50t_icr18", 200.0)
    for k, v in res.items():
        print(f"{k}: linearised {v['linearised_Hz']}, impulse single/double/weighted {v['impulse_single_Hz']} / "
              f"{v['impulse_double_Hz']} / {v['impulse_weighted_Hz']} Hz")
    s50 = sweep("spur_50t_icr137", 170.0, (0.25, 1.3, 106))
    res["sweep_spur_50t_icr137_170Nm"] = {k: s50[k] for k in ("fn_Hz", "jumps", "wall_s")}
    print("50t ICR 1.37, 170 N m: fn", round(s50["fn_Hz"]), "Hz; confirmed jumps:",
          [(j["kind"], j["branch"], round(j["fm_over_fn"], 3)) for j in s50["jumps"]])
    _plot_sweep(s50, "spur_50t_icr137, 170 N·m, FE tables, ζ = 0.02 (cf. dissertation Fig. 3.5)",
                out / "validation_sweep_50t_icr137.png")
    s28 = sweep("spur_28t_asym", 300.0, (0.3, 1.4, 111))
    extra = {law: sweep("spur_28t_asym", 300.0, (0.3, 1.4, 111), law) for law in ("local_slope", "average_slope",
                                                                                   "ste")}
    res["sweep_spur_28t_asym_300Nm"] = {k: s28[k] for k in ("fn_Hz", "jumps", "wall_s")}
    for law, r in extra.items():
        up = r["branches"]["up"]
        i = int(np.argmax(up["rms_deflection_m"]))
        res["sweep_spur_28t_asym_300Nm"][f"{law}_peak_fm_over_fn"] = up["fm_over_fn"][i]
    up = s28["branches"]["up"]
    res["sweep_spur_28t_asym_300Nm"]["hac_peak_fm_over_fn"] = up["fm_over_fn"][int(np.argmax(up["rms_deflection_m"]))]
    print("28t, 300 N m: fn", round(s28["fn_Hz"]), "Hz; jumps:",
          [(j["kind"], j["branch"], round(j["fm_over_fn"], 3)) for j in s28["jumps"]])
    _plot_sweep(s28, "spur_28t_asym, 300 N·m, FE tables, ζ = 0.02, HAC and conventional models (cf. Fig. 3.10)",
                out / "validation_sweep_28t_asym.png", extra)
    res["dynamic_factor_spur_28t_asym_300Nm"] = plot_time_traces(
        "spur_28t_asym", 300.0, (0.571, 0.893, 1.027), "wheel/SG25", out / "validation_traces_28t_asym.png")
    print("28t dynamic factors (max dynamic / max static strain, wheel/SG25):", res["dynamic_factor_spur_28t_asym_300Nm"])
    res["idler_28_33_39_300Nm"] = idler_study(out)
    print("idler, 300 N m on gear 1:", {k: res["idler_28_33_39_300Nm"][k] for k in ("natural_frequencies_Hz", "jumps")})
    res["both_flanks"] = flanks_study(out)
    print("both flanks:", json.dumps(res["both_flanks"]))
    json_path.write_text(json.dumps(res, indent=1))
    print(f"wrote {json_path} and figures in {out}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
