"""``hacgear demo``: the main job on the embedded default model, end to end.

Runs, in order, every stage of the pipeline on the default model (``spur_28t_asym``) and writes what a
person looks at into ``--out`` (default ``demo_out/``):

1. ``info``           derived geometry (contact ratios, roll angles, masses)      → info.json
2. ``plot-geometry``  the teeth in mesh, modifications exaggerated                  → geometry.png
3. ``stiffness``      static transmission error and mesh stiffness at the torque  → stiffness.json
4. ``modes``          natural frequencies from the committed tables               → modes.json
5. ``sweep``          up/down speed sweep through the main resonance              → sweep.h5, sweep.json
6. FMU                build the model's FMU and run the drivetrain bench           → <system>.fmu, drivetrain.png

Any shipped system or model file can be given instead of the default.  A stage whose inputs are missing
(e.g. no ``tables.h5``) stops the demo with a clear message.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import time
from pathlib import Path

import numpy as np

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._help import plain_text
from hacgear_core.dynamics.kernels import COMPILE_CPU_S
from hacgear_core.encodings import ContactState
from hacgear_core.fmu import build_fmu
from hacgear_core.fmu.bench import BenchConfig, plot_bench, run_drivetrain_bench
from hacgear_core.kinds import load_model
from hacgear_core.outpaths import check_not_shipped, check_out_dir

__all__ = ["register", "run"]

DEFAULT_MODEL = "spur_28t_asym"


def register(sub) -> None:
    p = sub.add_parser("demo", help=command_help("demo"),
                       description=plain_text(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", nargs="?", default=DEFAULT_MODEL, help="model (default: %(default)s)")
    p.add_argument("--out", default="demo_out", help="output folder, created if missing (default: %(default)s)")
    p.add_argument("--quick", action="store_true", help="fewer speeds and a shorter drivetrain run")
    p.set_defaults(func=run)


def _stage(name: str, argv: list[str], out: Path, json_name: str | None) -> dict | None:
    from hacgear_core.cli import main  # the CLI package imports this module: resolved at call time

    t0 = time.perf_counter()
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(argv)
    dt = time.perf_counter() - t0
    text = buf.getvalue()
    if rc != 0:
        print(text)
        raise SystemExit(f"hacgear demo: stage '{name}' failed (exit {rc}); command: hacgear {' '.join(argv)}")
    data = None
    if json_name:
        data = json.loads(text)
        (out / json_name).write_text(json.dumps(data, indent=2))
    print(f"[{name}] done in {dt:.1f} s" + (f" -> {out / json_name}" if json_name else ""))
    return data


def run(args) -> int:
    out = check_out_dir(args.out, "--out")
    check_not_shipped(out, "--out")
    model = load_model(args.model)
    out.mkdir(parents=True, exist_ok=True)
    torque = model.operating.torque_Nm
    info = _stage("info", ["info", args.model, "--json"], out, "info.json")
    for mname, m in info["meshes"].items():
        print(f"  mesh {mname}: contact ratio {m['contact_ratio']:.3f} (loaded flank), "
              f"{m.get('contact_ratio_coast') or float('nan'):.3f} (other flank), "
              f"centre distance {m['center_distance_m'] * 1e3:.2f} mm, phase {m['phase']:.4f} mesh cycles")
    _stage("plot-geometry", ["plot-geometry", args.model, "--out", str(out / "geometry.png")], out, None)
    print(f"  geometry plot: {out / 'geometry.png'}")
    st = _stage("stiffness", ["stiffness", args.model, "--torque", str(torque), "--json",
                              "--positions", "16" if args.quick else "32"], out, "stiffness.json")
    for mname, ms in st["meshes"].items():
        print(f"  mesh {mname}: mean mesh stiffness {ms['mean_mesh_stiffness_N_per_m'] / 1e6:.1f}e6 N/m at "
              f"{ms['torque_Nm']:g} N*m on {ms['torque_gear']}")
    tables = model.tables_path
    if tables is None or not tables.exists():
        print(f"hacgear demo: no tables for {model.name} ({tables}); run `hacgear statics {args.model}` first")
        return 1
    md = _stage("modes", ["modes", args.model, "--json"], out, "modes.json")
    print(f"  natural frequencies: {', '.join(f'{f:.0f}' for f in md['natural_frequencies_Hz'])} Hz")
    n = 40 if args.quick else 120
    sw = _stage("sweep", ["sweep", args.model, "--fm", f"500:4500:{n}", "--direction", "both", "--json",
                          "--no-progress", "--out", str(out / "sweep.h5")], out, "sweep.json")
    jumps = [f"{j['kind']} of {j['mesh']} at {j['frequency_Hz']:.0f} Hz ({j['branch']} sweep)"
             for j in sw.get("jumps", []) if j.get("confirmed")]
    print(f"  confirmed jumps: {', '.join(jumps) if jumps else 'none'}")
    t0 = time.perf_counter()
    print(f"[fmu] building the FMU (the build runs it once and ships its compiled code; the first build on this "
          f"machine compiles the FMU's own copy of the integration kernel: about {COMPILE_CPU_S} s on one core)",
          flush=True)
    fmu = build_fmu(model.folder, out)
    print(f"[fmu] {fmu} built in {time.perf_counter() - t0:.1f} s")
    # the bench steps at 2e-5 s (the shafts on the gears' inertias); a 0.5 s ramp keeps the demo short
    print(f"[drivetrain] running {fmu.name}", flush=True)
    res = run_drivetrain_bench(fmu, BenchConfig(ramp_s=0.2 if args.quick else 0.5))
    for mn, fs in res["static_mesh_force_N"].items():
        f = res[f"{mn}.force"]
        k = int(np.argmax(f))
        print(f"  drivetrain bench, mesh {mn}: peak mesh force {f[k] / fs:.2f} x static at mesh frequency "
              f"{res['mesh_frequency_Hz'][k]:.0f} Hz; contact lost in {np.count_nonzero(res[f'{mn}.contact'] == int(ContactState.SEPARATED))} "
              f"of {len(f)} samples")
    plot_bench(res, out / "drivetrain.png", f"{model.name} FMU in a drivetrain (fmpy low-level API)")
    print(f"  drivetrain bench plot: {out / 'drivetrain.png'}")
    return 0
