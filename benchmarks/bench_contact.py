"""Benchmark of the static contact solver (hacgear_core.contact).

Target (issue 3): after the one-time finite-element factorisation, a load-controlled solve of the
28-tooth pair (spur_28t_asym, 300 N m) at 64 mesh positions takes <= 30 s on 2 cores.  Also timed:
the statics grid workload of one worker, 64 positions x (32 loads + 64 deflections), whose target is
<= 120 s on 2 cores (two workers share the positions).

Prints the times and the ratios time / target (<= 1 passes).

    python benchmarks/bench_contact.py [--grid]
    python benchmarks/bench_contact.py --figures docs/figures   # the study in docs/static_contact.md
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", action="store_true", help="also time the statics grid workload")
    ap.add_argument("--figures", metavar="DIR", help="instead: run the study of docs/static_contact.md, write "
                                                     "DIR/contact_*.png and print its numbers")
    ap.add_argument("--hob-figure", metavar="DIR", help="instead: only the hob tip radius study (Fig. 2.7 analogue), "
                                                        "write DIR/contact_fillet_strain_hob_radius.png")
    args = ap.parse_args()
    if args.figures:
        return figures(args.figures)
    if args.hob_figure:
        return hob_radius_figure(args.hob_figure)

    from hacgear_core.contact import make_mesh_solver
    from hacgear_core.model import load_model

    model = load_model("spur_28t_asym")
    t0 = time.perf_counter()
    solver = make_mesh_solver(model, "m12")          # FE build + factorisation (or disk cache)
    t_build = time.perf_counter() - t0
    info = solver.compliance[0].info
    print(f"set-up (FE influence, cache {'hit' if t_build < 2 else 'miss'}): {t_build:.2f} s, "
          f"{info.get('n_dofs')} DOF per gear")
    W = 300.0 / solver.base_radius_m[0]
    positions = np.arange(64) / 64
    t0 = time.perf_counter()
    x = []
    for p in positions:
        sol = solver.solve_load(p, W)
        assert sol.success, sol.message
        x.append(sol.mesh_deflection_m)
    t_load = time.perf_counter() - t0
    target = 30.0
    print(f"load-controlled solve, 64 positions at {W:.1f} N: {t_load:.2f} s "
          f"(STE mean {np.mean(x) * 1e6:.3f} um, p-p {np.ptp(x) * 1e6:.3f} um)")
    print(f"ratio (time / {target:.0f} s target, <= 1 passes): {t_load / target:.3f}")
    if args.grid:
        solver._setup_cache.clear()
        loads = np.linspace(0, 3 * W, 32)[1:]
        t0 = time.perf_counter()
        n = 0
        for p in positions:
            x0 = solver.no_load_deflection(p)
            ls, _ = solver.solve_position(p, loads, [])
            xmax = max(s.mesh_deflection_m for s in ls)
            defl = np.linspace(x0, x0 + 1.5 * (xmax - x0), 64)
            _, ds = solver.solve_position(p, [], defl)
            n += len(ls) + len(ds)
        t_grid = time.perf_counter() - t0
        cores = 2
        print(f"statics grid workload: {n} solves at 64 positions in {t_grid:.2f} s on 1 core "
              f"(~{t_grid / cores:.1f} s on {cores} cores, {1e3 * t_grid / n:.2f} ms per solve)")
        print(f"ratio (time on {cores} cores / 120 s target, <= 1 passes): {t_grid / cores / 120:.3f}")
    print(f"(cpu count {os.cpu_count()})")
    return 0


def figures(out_dir: str) -> int:
    """Dissertation Figs. 2.5 and 2.7 analogues and the stiffness table of docs/static_contact.md."""
    import math
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hacgear_core.contact import (ContactOptions, make_mesh_solver, mesh_stiffness_curve, model_variant,
                                      root_strain_scan)
    from hacgear_core.geometry import mesh_geometry
    from hacgear_core.model import load_model

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model = load_model("spur_28t_asym")
    mg = mesh_geometry(model, "m12")
    # ---- stiffness table
    print("| relief | crowning | face coupling | mean local slope [1e6 N/m] | secant | mean average slope "
          "| STE mean [um] | STE p-p [um] |")
    print("|---|---|---|---|---|---|---|---|")
    curves = {}
    for relief, crown, coup in ((False, False, "rigid"), (True, False, "rigid"), (False, True, "rigid"),
                                (True, True, "rigid"), (False, False, "slices"), (True, True, "slices")):
        s = make_mesh_solver(model_variant(model, tip_relief=relief, lead_crowning=crown), "m12",
                             options=ContactOptions(face_slices=model.statics.face_slices, face_coupling=coup))
        c = mesh_stiffness_curve(s, 300.0 / s.base_radius_m[0], positions=64)
        curves[(relief, crown, coup)] = c
        print(f"| {'47 um' if relief else 'none'} | {'15 um' if crown else 'none'} | {coup} | "
              f"{c.mean_mesh_stiffness_N_per_m / 1e6:.1f} | {c.secant_mesh_stiffness_N_per_m / 1e6:.1f} | "
              f"{c.average_slope_stiffness_N_per_m.mean() / 1e6:.1f} | {c.ste_m.mean() * 1e6:.2f} | "
              f"{np.ptp(c.ste_m) * 1e6:.2f} |", flush=True)
    fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for key, lab in (((False, False, "rigid"), "unmodified, no crowning"), ((True, False, "rigid"), "relief"),
                     ((True, True, "rigid"), "relief + crowning (model)"),
                     ((True, True, "slices"), "relief + crowning, thin slices")):
        c = curves[key]
        ax[0].plot(c.mesh_cycle, c.ste_m * 1e6, label=lab)
        ax[1].plot(c.mesh_cycle, c.local_slope_stiffness_N_per_m / 1e6, label=lab)
    ax[0].set_ylabel("static transmission error [um]")
    ax[1].set_ylabel("local slope stiffness [1e6 N/m]")
    ax[1].set_xlabel("mesh cycle")
    ax[0].legend(fontsize=8)
    ax[0].set_title("spur_28t_asym, 300 N m, 25 deg flank")
    fig.tight_layout()
    fig.savefig(out / "contact_ste_stiffness.png", dpi=120)
    plt.close(fig)

    # ---- Fig. 2.5 analogue: strain, tooth loads, contact location on the output gear
    pos = np.linspace(-1.0, 1.0, 257)
    offs = [-1, 0, 1]
    fig, ax = plt.subplots(3, 2, figsize=(11, 8.5), sharex=True)
    for col, relief in enumerate((False, True)):
        s = make_mesh_solver(model_variant(model, tip_relief=relief), "m12")
        W = 300.0 / s.base_radius_m[0]
        roll_pitch = math.sqrt(s.operating_pitch_radius_m[1] ** 2 / s.base_radius_m[1] ** 2 - 1)
        eps = np.zeros((len(pos), 3))
        load = np.zeros((len(pos), 3))
        loc = np.full((len(pos), 3), np.nan)
        tip = np.zeros((len(pos), 3), bool)
        for i, p in enumerate(pos):
            st = s.state_load(p, W)
            eps[i] = s.strains(st, offsets=offs)["wheel/SG25"]
            pr = s.pair_results(st)
            for j, k in enumerate(offs):
                m = np.flatnonzero(st.setup.pairs == k)
                if m.size:
                    load[i, j] = pr["load_N"][m[0]]
                    loc[i, j] = pr["s_b_m"][m[0]] * 1e3
                    tip[i, j] = pr["tip_contact"][m[0]]
        x = pos + 1.0
        for j, k in enumerate(offs):
            style = "-" if k == 0 else "--"
            lab = "tooth i" if k == 0 else f"tooth i{k:+d}"
            ax[0, col].plot(x, eps[:, j] * 1e6, style, label=lab)
            ax[1, col].plot(x, load[:, j], style, label=lab)
            ax[2, col].plot(x, loc[:, j], style, label=lab)
        for a in ax[:, col]:
            # wheel roll angles as mesh positions of tooth i, labelled as in the dissertation's Fig. 2.5 text
            # (start and end of contact "SAP"/"EAP", single contact bounds by the output gear's HPSTC/LPSTC)
            for name, lab in (("EAP", "SAP"), ("HPSTC", "HPSTC"), ("LPSTC", "LPSTC"), ("SAP", "EAP")):
                t = (roll_pitch - math.radians(mg.roll_angle_deg["wheel"][name])) / (2 * math.pi / 28) + 1.0
                a.axvline(t, color="0.6", lw=0.8, ls=":")
                if a is ax[0, col]:
                    a.text(t, 1.0, lab, transform=a.get_xaxis_transform(), fontsize=7, ha="center", va="bottom")
        early = (load[:, 1] > 0.01 * W) & ((x < 1 + (roll_pitch - math.radians(mg.roll_angle_deg["wheel"]["EAP"]))
                                            / (2 * math.pi / 28) - 1e-3))
        print(f"{'relief 47 um' if relief else 'unmodified'}: max wheel/SG25 strain {eps.max() * 1e6:.1f} ue at "
              f"mesh cycle {x[np.argmax(eps[:, 1])]:.3f}; tooth i loaded before its start of contact at "
              f"{int(early.sum())} of {len(pos)} positions (max {load[early, 1].max() if early.any() else 0:.0f} N); "
              f"tip-edge contacts loaded: {int(np.sum(tip & (load > 0)))}; max peak pressure "
              f"{max(s.solve_load(p, W).peak_pressure_Pa.max() for p in np.linspace(0, 1, 33)) / 1e6:.0f} MPa",
              flush=True)
        ax[0, col].set_title("unmodified" if not relief else "47 um parabolic tip relief from 28.54 deg")
    ax[0, 0].set_ylabel("strain wheel/SG25 [1e-6]")
    ax[1, 0].set_ylabel("tooth load [N]")
    ax[2, 0].set_ylabel("contact on wheel: s from tip [mm]")
    for a in ax[2]:
        a.set_xlabel("mesh cycle (pitch point of tooth i at 1)")
    ax[0, 0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "contact_strain_loads_location.png", dpi=120)
    plt.close(fig)

    hob_radius_figure(out_dir)
    return 0


def hob_radius_figure(out_dir: str) -> int:
    """Dissertation Fig. 2.7 analogue: wheel root strain for hob tip radii 0.4, 1.8 (the largest the
    28-tooth tool allows) and 0.01 mm."""
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hacgear_core.contact import make_mesh_solver, model_variant, root_strain_scan
    from hacgear_core.model import load_model

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model = load_model("spur_28t_asym")
    W = 300.0 / make_mesh_solver(model, "m12").base_radius_m[0]
    # ---- Fig. 2.7 analogue: strain along the root for three hob tip radii
    fig, ax = plt.subplots(1, 3, figsize=(13, 4), sharey=True)
    ref = None
    for a, r in zip(ax, (0.4e-3, 1.8e-3, 0.01e-3)):
        sc = root_strain_scan(model, "m12", W, positions=96) if r == 0.4e-3 else \
            root_strain_scan(model_variant(model, hob_tip_radius_m=r), "m12", W, positions=96)
        if ref is None:
            ref = sc.max_strain
        for k in range(0, len(sc.radius_m), 3):
            a.plot(sc.position + 1.0, sc.strain[:, k] * 1e6, lw=0.8, label=f"s = {sc.s_m[k] * 1e3:.2f} mm")
        a.set_title(f"hob tip radius {r * 1e3:g} mm: max {sc.max_strain * 1e6:.0f} ue "
                    f"({(sc.max_strain / ref - 1) * 100:+.1f} %)", fontsize=9)
        a.set_xlabel("mesh cycle")
        print(f"hob tip radius {r * 1e3:g} mm: max root strain {sc.max_strain * 1e6:.1f} ue at mesh cycle "
              f"{sc.max_position + 1:.3f}, radius {sc.max_radius_m * 1e3:.3f} mm; vs 0.4 mm "
              f"{(sc.max_strain / ref - 1) * 100:+.1f} %", flush=True)
    ax[0].set_ylabel("surface strain, wheel root (relief) [1e-6]")
    ax[0].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(out / "contact_fillet_strain_hob_radius.png", dpi=120)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
