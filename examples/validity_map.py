#!/usr/bin/env python
"""Where the quasi-static body assumption of HAC stops holding: level 2 (elastic bodies in motion) against the
quasi-static direct model on the 28-tooth pair and on compliant variants of its blank (issue #18, Deliver 2 and 4).

Two studies, each writing its part of ``<out>/validity_map.json`` (results are added as they come, so an
interrupted run keeps what it finished):

``convergence``
    The 28-tooth pair (``models/spur_28t_asym``, 300 N·m) at one mesh frequency: level 2 with the lowest ``n``
    fixed-hub body modes of each gear, ``n`` over complete degenerate sets (0 = level 1: the static contact solver at
    every RK4 stage), RMS DTE, peak mesh force, maximum root strain (pinion SG25) against ``n``.
``map``
    Variants of the blank (bore diameters, a web): for each, the first fixed-hub body mode ``f_1``, the lumped
    mesh resonance ``f_n`` (HAC tables of a small statics grid, only for the lumped system's damping and the
    starting orbit), and at a few mesh frequencies the error of the quasi-static model (level 1 = level 2 with no
    modes: same solver, same RK4, same step; so it isolates the quasi-static assumption, not the tables) against
    level 2 in RMS DTE, peak mesh force and maximum root strain, as a function of ``f_m / f_1``.
    Figure ``<out>/figures/validity_map.png``.

Every run starts from the HAC steady state at that speed and integrates whole mesh cycles until the Poincaré
change per cycle is below ``--rtol`` or ``--cycles`` is reached (reported per run: ``success``, ``changes``).

    python examples/validity_map.py convergence [--fm 2786] [--modes 0,1,3,5,11,37]
    python examples/validity_map.py map [--variants bore40,bore90,web5_60_110] [--speeds 0.5,1.0]
    python examples/validity_map.py compare [--runs spur_50t_icr137@0.6,...] [--bench-json main256.json]
    python examples/validity_map.py compare-figure   # docs/figures/hac_vs_direct_level2.png

``compare`` runs level 2 at the speeds of ``benchmarks/bench_hac_vs_direct.py`` and tabulates it beside that
benchmark's HAC and level-1 numbers (``<out>/hac_vs_direct_level2.json``).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import re
import tempfile
from pathlib import Path

import numpy as np

from hacgear_core.cli._help import plain_text

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "models" / "spur_28t_asym" / "model.toml"
GAUGE = "pinion/SG25"


def _json_update(path: Path, key: str, value) -> None:
    data = json.loads(path.read_text()) if path.exists() else {}
    data[key] = value
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1, default=float))


def _run(system, model, fm, n_modes, *, steps, cycles, rtol, gauge=GAUGE, mesh="m12", traces=None):
    """One level-2 run (``n_modes`` body modes per gear; 0 = level 1) from the HAC steady state at ``fm``
    (:func:`hacgear_core.studies.validity.level2_run`)."""
    from hacgear_core.studies.validity import level2_run

    return level2_run(system, model, fm, n_modes, steps=steps, cycles=cycles, rtol=rtol, gauge=gauge, mesh=mesh,
                      traces=traces)


def convergence(args) -> None:
    from hacgear_core.cli.inputs import load_inputs

    inp = load_inputs(str(MODEL))
    rows = []
    for n in [int(v) for v in args.modes.split(",")]:
        row = _run(inp.system, inp.model, args.fm, n, steps=args.steps, cycles=args.cycles, rtol=args.rtol)
        rows.append(row)
        print(json.dumps({k: row[k] for k in ("n_modes", "highest_mode_Hz", "dte_rms_m", "peak_force_N",
                                              "max_root_strain", "cycles", "success", "wall_s_per_cycle")}),
              flush=True)
        _json_update(Path(args.out) / "validity_map.json", "convergence",
                     dict(model="spur_28t_asym", torque_Nm=300.0, mesh_frequency_Hz=args.fm, rows=rows,
                          command="python examples/validity_map.py " + " ".join(args.argv)))


def modes(args) -> None:
    """Body-mode facts of the 28-tooth gear: mass and inertia against the geometry, frequencies, participation."""
    from hacgear_core.studies.direct_elastic import elastic_mesh
    from hacgear_core.geometry import gear_geometry
    from hacgear_core.kinds import load_model

    model = load_model(str(MODEL))
    em = elastic_mesh(model, "m12", damping_ratio=0.02)
    bm = em.modes[0]
    b = em.solver.face_width_m
    gg = gear_geometry(model.gears[0])
    fc = em.solver.compliance[0]
    share = {}
    for n in (1, 3, 5, 11, bm.n_modes):
        P = bm.flank_normal[:n, 0]
        share[n] = float(np.max(np.sum(P ** 2 / bm.omega_rad_s[:n, None] ** 2, axis=0) / np.diag(fc.far_field_m2_N[0])))
    row = dict(n_dofs=bm.info["n_dofs"], n_modes=bm.n_modes, frequency_Hz=bm.frequency_Hz.tolist(),
               mass_kg=bm.mass_kg_per_m * b, geometry_mass_kg=gg.mass_kg, inertia_kgm2=bm.inertia_kgm2_per_m * b,
               geometry_inertia_kgm2=gg.inertia_kgm2,
               rotation_participation_share=float(np.sum(bm.rotation_participation ** 2) / bm.inertia_kgm2_per_m),
               first_mode_rotation_share=float(bm.rotation_participation[0] ** 2 / bm.inertia_kgm2_per_m),
               modal_share_of_tooth0_far_field_diagonal=share,
               command="python examples/validity_map.py " + " ".join(args.argv))
    print(json.dumps(row, indent=1, default=float))
    _json_update(Path(args.out) / "validity_map.json", "modes_28t", row)


def _variant_text(name: str) -> str:
    text = MODEL.read_text(encoding="utf-8")
    m = re.fullmatch(r"bore(\d+)", name)
    w = re.fullmatch(r"web(\d+)_(\d+)_(\d+)", name)
    if m:
        text = text.replace("bore_diameter_mm = 40.0", f"bore_diameter_mm = {float(m.group(1))}")
    elif w:
        t, di, do = (float(v) for v in w.groups())
        web = (f"  [gears.web]\n  thickness_mm = {t}\n  inner_diameter_mm = {di}\n  outer_diameter_mm = {do}\n"
               "  [gears.support]")
        text = text.replace("  [gears.support]", web)
    else:
        raise SystemExit(f"unknown variant {name!r} (boreNN or webT_DI_DO, mm)")
    return text.replace('name = "spur_28t_asym"', f'name = "vm_{name}"', 1)


def _cli(argv):
    from hacgear_core.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(argv)
    if rc != 0:
        raise SystemExit(f"hacgear {' '.join(argv)} failed ({rc})")


def map_(args) -> None:
    from hacgear_core.studies.direct_elastic import elastic_mesh
    from hacgear_core.studies.validity import modes_to_keep
    from hacgear_core.cli.inputs import load_inputs

    out = Path(args.out)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.variants.split(","):
            folder = Path(tmp) / name
            folder.mkdir()
            path = folder / "model.toml"
            path.write_text(_variant_text(name), encoding="utf-8")
            _cli(["statics", str(path), "--positions", "32", "--loads", "16", "--deflections", "32",
                  "--no-progress", "--json"])
            inp = load_inputs(str(path))
            f_n = float(inp.system.natural_frequencies_Hz()[0])
            em = elastic_mesh(inp.model, "m12", damping_ratio=inp.system.modal_damping_ratio)
            bm = em.modes[0]
            f1 = float(bm.frequency_Hz[0])
            for fac in [float(v) for v in args.speeds.split(",")]:
                fm = fac * f_n
                n_keep = modes_to_keep(bm, fm, f_n, args.mode_factor)
                l2 = _run(inp.system, inp.model, fm, n_keep, steps=args.steps, cycles=args.cycles, rtol=args.rtol)
                # the quasi-static run takes level 2's step: only the body modes differ
                l1 = _run(inp.system, inp.model, fm, 0, steps=l2["steps_per_cycle"], cycles=args.cycles,
                          rtol=args.rtol)
                err = {k: (l1[k] - l2[k]) / l2[k] for k in ("dte_rms_m", "peak_force_N", "max_root_strain")}
                row = dict(variant=name, first_body_mode_Hz=f1, lumped_resonance_Hz=f_n, mesh_frequency_Hz=fm,
                           fm_over_f1=fm / f1, fn_over_f1=f_n / f1, n_modes=n_keep, level1=l1, level2=l2,
                           quasi_static_error=err, mass_kg=bm.mass_kg_per_m * em.solver.face_width_m)
                rows.append(row)
                print(json.dumps(dict(variant=name, f1=f1, fn=f_n, fm=fm, n=n_keep, err=err,
                                      cyc=(l1["cycles"], l2["cycles"]), ok=(l1["success"], l2["success"]))),
                      flush=True)
                _json_update(out / "validity_map.json", "map",
                             dict(rows=rows, torque_Nm=300.0, level1="level 2 with no body modes (same solver, RK4 "
                                  "and step): the quasi-static assumption alone",
                                  command="python examples/validity_map.py " + " ".join(args.argv)))
    figure(out)


COMPARE_RUNS = "spur_50t_icr137@0.6,spur_50t_icr137@1.0,spur_50t_icr137@0.5,spur_28t_asym@0.6"


def compare(args) -> None:
    """HAC / level 1 (from the benchmark JSON of ``benchmarks/bench_hac_vs_direct.py``, same pair, speed and gauge)
    against level 2 (body modes up to ``--mode-factor`` x max(f_m, f_n), at least the first complete set) for
    each ``pair@f_m/f_n`` of ``--runs``; rows into ``<out>/hac_vs_direct_level2.json``, level-2 traces of the
    recorded cycle into ``--traces``."""
    from hacgear_core.cli.inputs import load_inputs
    from hacgear_core.studies.direct_elastic import elastic_mesh
    from hacgear_core.studies.validity import modes_to_keep

    bench = json.loads(Path(args.bench_json).read_text())["rows"]
    out = Path(args.out) / "hac_vs_direct_level2.json"
    rows, traces = [], {}
    for spec in args.runs.split(","):
        pair, fac = spec.split("@")
        fac = float(fac)
        ref = [r for r in bench if r["pair"] == pair and abs(r["fm_over_fn"] - fac) < 1e-9]
        if not ref:
            raise SystemExit(f"{spec}: no row in {args.bench_json}")
        ref = ref[0]
        inp = load_inputs(str(ROOT / "models" / pair / "model.toml"))
        mesh = inp.model.meshes[0].name
        f_n = float(inp.system.natural_frequencies_Hz()[0])
        fm = float(ref["mesh_frequency_Hz"])  # the benchmark's speed (fac x its f_n)
        em = elastic_mesh(inp.model, mesh, damping_ratio=inp.system.modal_damping_ratio)
        f1 = [float(bm.frequency_Hz[0]) for bm in em.modes]
        n_keep = modes_to_keep(em.modes[0], fm, f_n, args.mode_factor)
        tr = {}
        l2 = _run(inp.system, inp.model, fm, n_keep, steps=args.steps, cycles=args.cycles, rtol=args.rtol,
                  gauge=ref["gauge"], mesh=mesh, traces=tr)
        key = f"{pair}_{fac:g}"
        for k, v in tr.items():
            traces[f"{key}/level2/{k}"] = np.asarray(v)
        level2 = dict(dte_rms_m=l2["dte_rms_m"], peak_force_N=l2["peak_force_N"],
                      max_root_strain=l2["max_root_strain"], contact_loss_fraction=l2["contact_loss_fraction"],
                      wall_s_per_cycle=l2["wall_s_per_cycle"], last_poincare_change=l2["changes"][-1],
                      changes=l2["changes"], cycles=l2["cycles"], success=l2["success"], message=l2["message"],
                      n_modes_per_gear=l2["n_modes"], highest_mode_Hz=l2["highest_mode_Hz"],
                      steps_per_cycle=l2["steps_per_cycle"], wall_s=l2["wall_s"])
        keys = ("dte_rms_m", "peak_force_N", "max_root_strain", "contact_loss_fraction", "wall_s_per_cycle")
        row = dict(pair=pair, label=ref["label"], fm_over_fn=fac, mesh_frequency_Hz=fm,
                   lumped_resonance_Hz=f_n, bench_lumped_resonance_Hz=fm / fac, first_body_mode_Hz=f1,
                   fn_over_f1=f_n / f1[0], gauge=ref["gauge"], torque_Nm=float(inp.model.operating.torque_Nm),
                   hac={k: ref["hac"][k] for k in keys}, level1={k: ref["level1"][k] for k in keys}, level2=level2,
                   error_vs_level2={m: {k: (ref[m][k] - l2[k]) / l2[k] for k in keys[:3]}
                                    for m in ("hac", "level1")})
        rows.append(row)
        print(json.dumps(dict(run=spec, fm=fm, fn=f_n, f1=f1, n=n_keep, nsp=l2["steps_per_cycle"],
                              l2={k: level2[k] for k in keys + ("last_poincare_change",)},
                              err=row["error_vs_level2"])), flush=True)
        _json_update(out, "compare", dict(rows=rows, bench_json=args.bench_json, traces=args.traces,
                                          command="python examples/validity_map.py " + " ".join(args.argv)))
        if args.traces:
            np.savez_compressed(args.traces, **traces)


def compare_figure(out: Path, bench_traces: str, traces: str) -> None:
    """One recorded mesh cycle of DTE, mesh force and the largest root strain over the teeth in mesh (the
    benchmark's gauge) of HAC, level 1 and level 2 per compared pair and speed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = json.loads((out / "hac_vs_direct_level2.json").read_text())["compare"]["rows"]
    tb, t2 = np.load(bench_traces), np.load(traces)
    fig, axes = plt.subplots(3, len(rows), figsize=(3.6 * len(rows), 8), constrained_layout=True, squeeze=False)
    for j, r in enumerate(rows):
        key = f"{r['pair']}_{r['fm_over_fn']:g}"
        series = {"HAC": (tb[f"{key}/hac/dte_m"], tb[f"{key}/hac/force_N"], np.max(tb[f"{key}/hac/root_strain"], 1)),
                  "level 1": (tb[f"{key}/level1/dte_m"], tb[f"{key}/level1/force_N"],
                              np.max(tb[f"{key}/level1/root_strain"], 1)),
                  "level 2": (t2[f"{key}/level2/dte_m"], t2[f"{key}/level2/force_N"],
                              t2[f"{key}/level2/root_strain_max"])}
        for (name, (dte, f, e)), ls in zip(series.items(), ("-", "--", "-")):
            x = np.arange(len(f)) / len(f)
            lw = 1.6 if name == "level 2" else 1.1
            for ax, y in zip(axes[:, j], (1e6 * dte, f, 1e6 * e)):
                ax.plot(x, y, ls, lw=lw, label=name)
        axes[0, j].set_title(f"{r['pair']}\n{r['fm_over_fn']:g} f_n = {r['mesh_frequency_Hz']:.0f} Hz ({r['label']})",
                             fontsize=8)
        for ax, lab in zip(axes[:, j], ("DTE [um]", "mesh force [N]", f"max root strain {r['gauge']} [ue]")):
            ax.set_ylabel(lab, fontsize=8)
            ax.grid(alpha=0.3)
            ax.tick_params(labelsize=7)
        axes[2, j].set_xlabel("mesh cycle (recorded)", fontsize=8)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("HAC (tables) / level 1 (static solver per stage) / level 2 (elastic bodies; 6 + 1 cycles from "
                 "the HAC orbit, not periodic)", fontsize=9)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "figures" / "hac_vs_direct_level2.png", dpi=110)


def figure(out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = json.loads((out / "validity_map.json").read_text())
    conv = data.get("convergence", {}).get("rows", [])
    if conv:
        fig, axes = plt.subplots(1, 3, figsize=(13, 3.6), constrained_layout=True)
        n = [r["n_modes"] for r in conv]
        for ax, key, scale, lab in zip(axes, ("dte_rms_m", "peak_force_N", "max_root_strain"), (1e6, 1.0, 1e6),
                                       ("RMS DTE [um]", "peak mesh force [N]", "max root strain [ue]")):
            ax.plot(n, [scale * r[key] for r in conv], "o-")
            ax.set_xscale("symlog", linthresh=1)
            ax.set_xlabel("body modes per gear (0 = quasi-static, level 1)")
            ax.set_ylabel(lab)
            ax.grid(alpha=0.3)
        fig.suptitle(f"level 2 against the number of body modes, spur_28t_asym 300 N m, "
                     f"f_m = {data['convergence']['mesh_frequency_Hz']:.0f} Hz, "
                     f"{max(r['cycles'] for r in conv)}+1 cycles from the HAC orbit (level 1 stops when periodic)")
        (out / "figures").mkdir(parents=True, exist_ok=True)
        fig.savefig(out / "figures" / "validity_map_convergence.png", dpi=110)
    rows = data.get("map", {}).get("rows", [])
    if not rows:
        return
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), constrained_layout=True)
    colors, marks = {}, {0.5: "o", 0.75: "s", 1.0: "^"}
    for r in rows:
        c = colors.setdefault(r["variant"], f"C{len(colors)}")
        fac = round(r["mesh_frequency_Hz"] / r["lumped_resonance_Hz"], 2)
        for ax, key in zip(axes, ("dte_rms_m", "peak_force_N", "max_root_strain")):
            ax.plot(r["fm_over_f1"], 100 * abs(r["quasi_static_error"][key]), marks.get(fac, "x"), color=c, ms=8)
    for ax, title in zip(axes, ("RMS DTE", "peak mesh force", "max root strain (pinion SG25)")):
        ax.axhline(5.0, color="r", lw=0.8, ls="--")
        ax.set_yscale("log")
        ax.set_xlabel("mesh frequency / first body mode frequency")
        ax.set_ylabel("|quasi-static - level 2| / level 2 [%]")
        ax.set_title(title)
        ax.grid(alpha=0.3, which="both")
    f1 = {r["variant"]: r["first_body_mode_Hz"] for r in rows}
    fnf = {r["variant"]: r["fn_over_f1"] for r in rows}
    hv = [plt.Line2D([], [], color=c, marker="s", ls="", label=f"{v}: f1 {f1[v]:.0f} Hz, fn/f1 {fnf[v]:.2f}")
          for v, c in colors.items()]
    hs = [plt.Line2D([], [], color="k", marker=m, ls="", mfc="none", label=f"f_m = {k:g} f_n") for k, m in marks.items()]
    axes[0].legend(handles=hv + hs, fontsize=7, loc="lower right")
    fig.suptitle("quasi-static model (level 1) against level 2 (elastic bodies), 28-tooth pair blank variants, 300 N m")
    (out / "figures").mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "figures" / "validity_map.png", dpi=110)


def main(argv=None) -> int:
    import sys

    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(description=plain_text(__doc__.split("\n\n")[0]),
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("study", choices=("modes", "convergence", "map", "figure", "compare", "compare-figure"),
                    help="which study to run or draw")
    ap.add_argument("--fm", type=float, default=2786.0, help="convergence: mesh frequency [Hz]")
    ap.add_argument("--modes", default="0,1,3,5,11,37", help="convergence: modes per gear (complete sets)")
    ap.add_argument("--variants", default="bore40,bore90,web5_60_110", help="blank variants, comma-separated")
    ap.add_argument("--speeds", default="0.5,1.0", help="map: mesh frequencies as multiples of the lumped resonance")
    ap.add_argument("--mode-factor", type=float, default=4.0,
                    help="map: keep the body modes up to this multiple of max(f_m, f_n)")
    ap.add_argument("--steps", type=int, default=64,
                    help="fewest RK4 steps per mesh cycle (level 2 takes more when its highest frequency needs it)")
    ap.add_argument("--cycles", type=int, default=6, help="most mesh cycles before the recorded one")
    ap.add_argument("--rtol", type=float, default=2e-3, help="Poincaré change per cycle that ends a run")
    ap.add_argument("--out", default=str(ROOT / "docs"), help="folder of the JSON results and figures/")
    ap.add_argument("--runs", default=COMPARE_RUNS, help="compare: pair@f_m/f_n, comma-separated")
    ap.add_argument("--bench-json", default="/tmp/hac18/main256.json",
                    help="compare: HAC and level-1 rows of benchmarks/bench_hac_vs_direct.py --json")
    ap.add_argument("--bench-traces", default="/tmp/hac18/main256.npz",
                    help="compare-figure: HAC and level-1 traces of benchmarks/bench_hac_vs_direct.py --traces")
    ap.add_argument("--traces", default="/tmp/hac18/level2.npz", help="compare: level-2 traces written here")
    args = ap.parse_args(argv)
    args.argv = argv
    {"modes": modes, "convergence": convergence, "map": map_,
     "figure": lambda a: figure(Path(a.out)), "compare": compare,
     "compare-figure": lambda a: compare_figure(Path(a.out), a.bench_traces, a.traces)}[args.study](args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
