"""Benchmark of the static contact solver (hacgear_core.statics.contact).

Target (issue 3): after the one-time finite-element factorisation, a load-controlled solve of the
28-tooth pair (spur_28t_asym, 300 N m) at 64 mesh positions takes <= 30 s on 2 cores.  Also timed:
the statics grid workload of one worker, 64 positions x (32 loads + 64 deflections), whose target is
<= 120 s on 2 cores (two workers share the positions).

Prints the times and the ratios time / target (<= 1 passes).

    python benchmarks/bench_contact.py [--grid]
    python benchmarks/bench_contact.py --figures docs/figures   # the study in docs/static_contact.md
    python benchmarks/bench_contact.py --slices-figure docs/figures   # face-slice convergence (~1 min)
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np
from hacgear_core.cpu import vector_units


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", action="store_true", help="also time the statics grid workload")
    ap.add_argument("--figures", metavar="DIR", help="instead: run the study of docs/static_contact.md, write "
                                                     "DIR/contact_*.png and print its numbers")
    ap.add_argument("--hob-figure", metavar="DIR", help="instead: only the hob tip radius study (Fig. 2.7 analogue), "
                                                        "write DIR/contact_fillet_strain_hob_radius{,_profile}.png")
    ap.add_argument("--slices-figure", metavar="DIR", help="instead: only the face-slice convergence study, "
                                                           "write DIR/contact_face_slices.png and print its table")
    args = ap.parse_args()
    print(f"CPU the kernels are compiled for: {vector_units().describe()}", flush=True)
    if args.slices_figure:
        return face_slices_figure(args.slices_figure)
    if args.figures:
        return figures(args.figures)
    if args.hob_figure:
        return hob_radius_figure(args.hob_figure)

    from hacgear_core.statics import make_mesh_solver
    from hacgear_core.kinds import load_model

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

    from hacgear_core.statics import ContactOptions, make_mesh_solver, mesh_stiffness_curve, model_variant
    from hacgear_core.geometry import mesh_geometry
    from hacgear_core.kinds import load_model

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
        ax[0, col].set_title("unmodified" if not relief else "47 um parabolic tip relief from 28.54 deg", pad=14)
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
    28-tooth tool allows) and 0.01 mm, with the investigation of docs/static_contact.md "Hob tip
    radius": converged point strain (48 points equally spaced in arc length, 0.1 mm elements along
    the fillets), the same with the default mesh and with the default 24 radius-spaced points, a
    1 mm gauge grid, a fixed radial gauge axis, and the maximum restricted to radii above r_cut.
    Writes contact_fillet_strain_hob_radius.png (strain over two mesh cycles) and
    contact_fillet_strain_hob_radius_profile.png (maximum over the cycle along the root, fillets)."""
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hacgear_core.statics import make_mesh_solver, model_variant, root_strain_scan
    from hacgear_core.statics.fe import MeshOptions
    from hacgear_core.geometry import gear_geometry
    from hacgear_core.kinds import load_model

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model = load_model("spur_28t_asym")
    W = 300.0 / make_mesh_solver(model, "m12").base_radius_m[0]
    radii = (0.4e-3, 1.8e-3, 0.01e-3)
    fine = MeshOptions(fillet_size_m=0.1e-3)
    variants = {"point, arc 48, fillet mesh 0.1 mm": dict(sampling="arc", n_gauges=48, fe_options=fine),
                "point, arc 48, default mesh": dict(sampling="arc", n_gauges=48),
                "point, radius 24, default mesh (the former default)": dict(sampling="radius"),
                "1 mm gauge grid, arc 24, fillet mesh 0.1 mm": dict(sampling="arc", n_gauges=24, fe_options=fine,
                                                                  gauge_length_m=1e-3)}
    scans: dict = {}
    t0 = time.perf_counter()
    for name, kw in variants.items():
        scans[name] = {r: root_strain_scan(model_variant(model, hob_tip_radius_m=r), "m12", W, positions=96, **kw)
                       for r in radii}
    print(f"hob tip radius study: {time.perf_counter() - t0:.0f} s")

    def row(label, m):
        print(f"| {label} | {m[0.4e-3] * 1e6:.1f} | {m[1.8e-3] * 1e6:.1f} ({(m[1.8e-3] / m[0.4e-3] - 1) * 100:+.1f} %) | "
              f"{m[0.01e-3] * 1e6:.1f} ({(m[0.01e-3] / m[0.4e-3] - 1) * 100:+.1f} %) |", flush=True)

    print("| definition | 0.4 mm [ue] | 1.8 mm (vs 0.4) | 0.01 mm (vs 0.4) |")
    print("|---|---|---|---|")
    print("| dissertation Fig. 2.7 | | (-13.2 %) | (+10.0 %) |")
    for name, sc in scans.items():
        row(name, {r: s.max_strain for r, s in sc.items()})
    ref = scans["point, arc 48, fillet mesh 0.1 mm"]
    # fixed radial gauge axis: at the traction-free surface the stress is uniaxial along the tangent t,
    # so the strain along a unit d at angle th to t is eps_t (cos^2 th - nu' sin^2 th), nu' = nu (plane stress)
    nu = model.gears[1].material.poisson_ratio
    m_rad = {}
    for r, sc in ref.items():
        gg = gear_geometry(model_variant(model, hob_tip_radius_m=r).gears[1])
        p = gg.flank("drive", 4000)
        s, xy, nrm = np.asarray(p.s), np.asarray(p.xy), np.asarray(p.normal)
        o = np.argsort(s)
        P = np.stack([np.interp(sc.s_m, s[o], xy[o, k]) for k in range(2)], axis=1)
        N = np.stack([np.interp(sc.s_m, s[o], nrm[o, k]) for k in range(2)], axis=1)
        c = np.abs(np.sum(P / np.linalg.norm(P, axis=1)[:, None] * np.stack([-N[:, 1], N[:, 0]], 1), axis=1)
                   / np.linalg.norm(N, axis=1))
        m_rad[r] = float(np.max(sc.strain * (c ** 2 - nu * (1 - c ** 2))[None, :]))
    row("radial gauge axis (point, arc 48, fillet mesh 0.1 mm)", m_rad)
    for r_cut in (63.5e-3, 63.7e-3, 63.8e-3, 64.0e-3):
        row(f"max over r >= {r_cut * 1e3:.1f} mm only (point, arc 48, fillet mesh 0.1 mm)",
            {r: float(sc.strain[:, sc.radius_m >= r_cut].max()) for r, sc in ref.items()})
    for r, sc in ref.items():
        print(f"hob tip radius {r * 1e3:g} mm: max {sc.max_strain * 1e6:.1f} ue at mesh cycle {sc.max_position + 1:.3f}, "
              f"radius {sc.max_radius_m * 1e3:.3f} mm, arc {sc.max_s_m * 1e3:.3f} mm from the tip", flush=True)

    # ---- Fig. 2.7 analogue: strain over two mesh cycles at points along the root
    fig, ax = plt.subplots(1, 3, figsize=(13, 4), sharey=True)
    for a, r in zip(ax, radii):
        sc = ref[r]
        for k in range(0, len(sc.radius_m), 6):
            a.plot(sc.position + 1.0, sc.strain[:, k] * 1e6, lw=0.8, label=f"r = {sc.radius_m[k] * 1e3:.2f} mm")
        a.set_title(f"hob tip radius {r * 1e3:g} mm: max {sc.max_strain * 1e6:.0f} ue "
                    f"({(sc.max_strain / ref[0.4e-3].max_strain - 1) * 100:+.1f} %)", fontsize=9)
        a.set_xlabel("mesh cycle")
    ax[0].set_ylabel("surface strain, wheel root (relief) [1e-6]")
    ax[0].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(out / "contact_fillet_strain_hob_radius.png", dpi=120)
    plt.close(fig)

    # ---- where the maximum lies: max over the mesh cycle along the root, and the fillets
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
    for r, col in zip(radii, ("C0", "C1", "C2")):
        sc = ref[r]
        ax[0].plot(sc.radius_m * 1e3, sc.strain.max(axis=0) * 1e6, col, label=f"{r * 1e3:g} mm, point")
        g1 = scans["1 mm gauge grid, arc 24, fillet mesh 0.1 mm"][r]
        ax[0].plot(g1.radius_m * 1e3, g1.strain.max(axis=0) * 1e6, col + "--", lw=0.8, label=f"{r * 1e3:g} mm, 1 mm grid")
        gg = gear_geometry(model_variant(model, hob_tip_radius_m=r).gears[1])
        xy = np.asarray(gg.flank("drive", 2000).xy) * 1e3
        ax[1].plot(xy[:, 1], xy[:, 0], col, label=f"{r * 1e3:g} mm")
        ax[1].plot(sc.max_radius_m * 1e3 * np.sin(np.interp(sc.max_s_m, np.asarray(gg.flank("drive", 2000).s)[::-1],
                                                            np.arctan2(xy[::-1, 1], xy[::-1, 0]))),
                   sc.max_radius_m * 1e3 * np.cos(np.interp(sc.max_s_m, np.asarray(gg.flank("drive", 2000).s)[::-1],
                                                            np.arctan2(xy[::-1, 1], xy[::-1, 0]))), col + "o")
    ax[0].axvline(64.051, color="k", lw=0.6, ls=":")
    ax[0].set_xlabel("radius [mm] (dotted: gauge SG25, 64.051 mm)")
    ax[0].set_ylabel("max over two mesh cycles [1e-6]")
    ax[0].legend(fontsize=7)
    ax[1].set_aspect("equal")
    ax[1].set_xlim(3.5, 8.5)
    ax[1].set_ylim(62.9, 66.4)
    ax[1].set_xlabel("tooth frame y [mm]")
    ax[1].set_ylabel("tooth frame x [mm]")
    ax[1].set_title("25 deg fillet of the wheel (dots: location of the maximum)", fontsize=9)
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "contact_fillet_strain_hob_radius_profile.png", dpi=120)
    plt.close(fig)
    return 0


def face_slices_figure(out_dir: str, slices=(1, 3, 5, 9, 11, 15, 21, 25, 31, 41, 61, 81)) -> int:
    """Convergence of the crowned 28-tooth pair's stiffness and STE in the number of face slices
    (docs/static_contact.md, "Face slices")."""
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hacgear_core.statics import ContactOptions, make_mesh_solver, mesh_stiffness_curve
    from hacgear_core.kinds import load_model

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model = load_model("spur_28t_asym")
    rows = []
    print("| slices | mean local slope [1e6 N/m] | secant [1e6 N/m] | mean STE [um] | STE p-p [um] |")
    print("|---|---|---|---|---|")
    for ns in slices:
        s = make_mesh_solver(model, "m12", options=ContactOptions(face_slices=ns))
        c = mesh_stiffness_curve(s, 300.0 / s.base_radius_m[0], positions=64)
        rows.append((ns, c.mean_mesh_stiffness_N_per_m, c.secant_mesh_stiffness_N_per_m, c.ste_m.mean(),
                     np.ptp(c.ste_m)))
        print(f"| {ns} | {rows[-1][1] / 1e6:.2f} | {rows[-1][2] / 1e6:.2f} | {rows[-1][3] * 1e6:.3f} | "
              f"{rows[-1][4] * 1e6:.3f} |")
    a = np.array(rows)
    ref = a[a[:, 0] >= 21, 1:].mean(axis=0)
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    for j, lab in ((1, "mean local slope"), (2, "secant"), (3, "mean STE")):
        ax[0].plot(a[:, 0], 100 * (a[:, j] / ref[j - 1] - 1), "o-", label=lab)
    ax[0].axhspan(-0.3, 0.3, color="0.9", label="±0.3 % (test)")
    ax[0].axvline(model.statics.face_slices, color="k", ls=":", label="model default")
    ax[0].set_xscale("log")
    ax[0].set_ylim(-3, 3)
    ax[0].set_xlabel("face slices")
    ax[0].set_ylabel("change vs mean of >= 21 slices [%]")
    ax[0].legend(fontsize=7)
    ax[1].plot(a[:, 0], a[:, 1] / 1e6, "o-")
    ax[1].axhspan(135, 165, color="0.9", label="150e6 ± 10 % (dissertation 3.6.2)")
    ax[1].set_xscale("log")
    ax[1].set_xlabel("face slices")
    ax[1].set_ylabel("mean local-slope stiffness [1e6 N/m]")
    ax[1].legend(fontsize=7)
    fig.suptitle("spur_28t_asym, 300 N m, 15 um crowning, 47 um relief: face-slice convergence", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "contact_face_slices.png", dpi=120)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
