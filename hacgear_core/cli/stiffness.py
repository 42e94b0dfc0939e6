"""``hacgear stiffness MODEL --torque T [--json]``: static transmission error and mesh stiffness of every mesh.

Solves the static contact (finite-element far field + Hertz near field, :mod:`hacgear_core.statics.contact`) at
``--positions`` mesh positions of one mesh cycle, each mesh under the force the torque ``T`` on the model's
``operating.torque_gear`` sends through it (an idler chain's second mesh carries ``T r_b,12 / (r_b,11 r_b,21)``
times its base radius...), and reports per mesh the static transmission error (mesh deflection), the local-slope
mesh stiffness ``dF/dx`` at that load at every position and its mean, and the secant stiffness
(:func:`hacgear_core.statics.studies.mesh_stiffness_report`).  ``--side coast``: the torque reversed, loading the
other flank of each gear (the coast side of the tables).  ``--out FILE.json``: the JSON result is written to FILE
after each mesh (whole, in one rename); a run killed and started again with the same inputs takes the meshes
FILE already holds and solves only the rest (:mod:`hacgear_core.statics.stiffness_file`).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from tqdm import tqdm

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._options import check_option
from hacgear_core.errors import ModelError
from hacgear_core.jsonio import dumps
from hacgear_core.kinds import load_model
from hacgear_core.outpaths import check_out_path
from hacgear_core.statics.stiffness_file import read_done, stiffness_inputs, write_results
from hacgear_core.statics.studies import mesh_stiffness_report, model_variant

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "stiffness", help=command_help("stiffness"),
        description="Static contact solve (FE far field + Hertz near field) over one mesh cycle of every mesh at the "
                    "given torque. Text: summary with units. --json: SI values, unit in the key name.")
    p.add_argument("model", help="model file, folder or system name")
    p.add_argument("--torque", type=float, default=None, metavar="T",
                   help="torque [N·m] on the model's operating torque gear (default: [operating] torque_Nm); a "
                        "negative torque loads the coast flanks (the same as --side coast with its magnitude)")
    p.add_argument("--mesh", default=None, help="only this mesh (default: every mesh of the model)")
    p.add_argument("--positions", type=int, default=64, help="mesh positions per cycle (default 64)")
    p.add_argument("--slices", type=int, default=None, help="face slices (default: model [statics] face_slices)")
    p.add_argument("--face-coupling", choices=("rigid", "slices", "elastic"), default=None,
                   help="far-field coupling across the face: rigid (2D, uniform; spur default), slices (thin-slice "
                        "model), elastic (2D + 3D face-wise influence; helical default)")
    p.add_argument("--twist", type=float, default=0.0, metavar="RAD",
                   help="mesh twist [rad] (helical meshes): relative rotation of the gears about the normal to the "
                        "plane of action, (theta_a - theta_b) . e1 (docs/helical.md); default 0")
    p.add_argument("--side", choices=("drive", "coast"), default="drive",
                   help="drive: the mesh's loaded flanks (default); coast: the torque reversed, loading the other "
                        "flank of each gear (STE measured from the coast flanks' kinematic contact)")
    p.add_argument("--no-relief", action="store_true", help="remove all tip relief (study)")
    p.add_argument("--no-crowning", action="store_true", help="remove all lead crowning (study)")
    p.add_argument("--json", action="store_true", help="print JSON (SI units, unit in the key name)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE.json",
                   help="also write the JSON result to FILE.json, after each mesh (written whole); run again with "
                        "the same inputs after a kill, it takes the meshes the file holds and solves the rest "
                        "(a file of other inputs is refused and kept)")
    p.add_argument("--fresh", action="store_true",
                   help="with --out: ignore and replace what FILE.json holds, solving every mesh again")
    p.set_defaults(func=run)


def _position_progress():
    """``on_position(done, total)`` for :func:`mesh_stiffness_report`: a progress bar on an interactive stderr, a
    line at each quarter of the positions otherwise (logs, pipes)."""
    state = {"bar": None}

    def on_position(done: int, total: int) -> None:
        if sys.stderr.isatty():
            if done == 1:
                state["bar"] = tqdm(total=total, desc="hacgear stiffness: positions", unit="position", file=sys.stderr)
            state["bar"].update(1)
            if done == total:
                state["bar"].close()
        elif total >= 8 and done % (total // 4) == 0 and done < total:
            print(f"hacgear stiffness: {done} of {total} positions solved", file=sys.stderr, flush=True)
    return on_position


def _result_file(args: argparse.Namespace, model: Any, torque: float) -> tuple[dict, Any]:
    """``(done, on_mesh)`` for :func:`mesh_stiffness_report` from ``--out``/``--fresh``: the meshes ``--out`` holds
    for these inputs (said on stderr) and a callback writing the file after each mesh; ``({}, None)`` without
    ``--out``."""
    if args.out is None:
        return {}, None
    out = args.out
    inputs = stiffness_inputs(model, torque_Nm=torque, side=args.side, positions=args.positions,
                              face_slices=args.slices, face_coupling=args.face_coupling, twist_rad=args.twist,
                              mesh=args.mesh, tip_relief=not args.no_relief, lead_crowning=not args.no_crowning)
    done = {} if args.fresh else read_done(out, inputs)
    names = [m.name for m in model.meshes if args.mesh is None or m.name == args.mesh]
    if done:
        rest = [n for n in names if n not in done]
        print(f"hacgear stiffness: resumed: {len(done)} mesh{'es' if len(done) != 1 else ''} from {out} "
              f"({', '.join(done)}); " + (f"solving {', '.join(rest)}" if rest else "nothing left to solve"),
              file=sys.stderr, flush=True)

    def on_mesh(report: dict) -> None:
        write_results(out, report, inputs, [n for n in names if n not in report["meshes"]])
    return done, on_mesh


def run(args: argparse.Namespace) -> int:
    check_option("--torque", args.torque, "torque_Nm", signed=True)
    check_option("--positions", args.positions, "statics.positions")
    check_option("--slices", args.slices, "statics.face_slices")
    if args.out is not None:
        check_out_path(args.out, "--out", suffixes=(".json",))
    elif args.fresh:
        raise ModelError("--fresh replaces the result file of --out; give --out FILE.json with it")
    model = load_model(args.model)
    if args.no_relief or args.no_crowning:
        model = model_variant(model, tip_relief=not args.no_relief, lead_crowning=not args.no_crowning)
    torque = model.operating.torque_Nm if args.torque is None else args.torque
    if torque < 0:
        # as in sweep and simulate, a negative torque loads the coast flanks
        if args.side == "coast":
            raise ModelError(f"--torque {torque:g} with --side coast: the coast side is the torque reversed "
                             "already; give --side coast with a positive torque, or a negative torque alone")
        print(f"hacgear stiffness: torque {torque:g} N*m < 0 loads the coast flanks: --side coast at "
              f"{-torque:g} N*m", file=sys.stderr)
        torque, args.side = -torque, "coast"
    done, on_mesh = _result_file(args, model, torque)
    d = mesh_stiffness_report(model, torque, mesh=args.mesh, positions=args.positions, slices=args.slices,
                              face_coupling=args.face_coupling, twist_rad=args.twist, side=args.side,
                              progress=lambda msg: print(f"hacgear stiffness: {msg}", file=sys.stderr, flush=True),
                              on_position=_position_progress(), done=done, on_mesh=on_mesh)
    if args.json:
        print(dumps(d, indent=1))
        return 0
    print(f"{d['model']}: torque {d['torque_Nm']:g} N·m on {d['torque_gear']}, {d['face_slices']} face slices "
          f"({d['face_coupling']})")
    for name, m in d["meshes"].items():
        ste = m["ste_m"]
        k = m["local_slope_stiffness_N_per_m"]
        print(f"mesh {name} ({m['gear_a']}-{m['gear_b']}, {m['side']} side: {'/'.join(m['flanks'])} flanks): "
              f"{m['torque_Nm']:.1f} N·m on {m['torque_gear']}, mesh force {m['mesh_force_N']:.1f} N, "
              f"{len(ste)} positions")
        if m["side"] == "coast":
            print(f"  backlash {m['backlash_normal_m'] * 1e6:.2f} µm normal, {m['backlash_circular_m'] * 1e6:.2f} µm "
                  "circular; STE from the coast flanks' kinematic contact")
        print(f"  mean mesh stiffness (local slope) {m['mean_mesh_stiffness_N_per_m'] / 1e6:9.2f} MN/m")
        print(f"  secant mesh stiffness             {m['secant_mesh_stiffness_N_per_m'] / 1e6:9.2f} MN/m")
        print(f"  mean average-slope stiffness      {m['mean_average_slope_stiffness_N_per_m'] / 1e6:9.2f} MN/m")
        print(f"  local slope min / max             {min(k) / 1e6:9.2f} / {max(k) / 1e6:.2f} MN/m")
        print(f"  static transmission error mean    {sum(ste) / len(ste) * 1e6:9.3f} µm, peak-to-peak "
              f"{m['ste_peak_to_peak_m'] * 1e6:.3f} µm  ({m['seconds']:.1f} s)")
        h = m.get("helical")
        if h:
            zs = h["slice_z_m"]
            print(f"  mesh twist {h['twist_rad']:.4g} rad; twist moment mean {h['mean_twist_moment_Nm']:.4g} N·m; "
                  f"twist stiffness mean {h['mean_twist_stiffness_Nm_per_rad']:.4g} N·m/rad")
            print(f"  (x and the mesh force are normal to the flank: base helix angle "
                  f"{abs(h['base_helix_angle_rad']) * 57.29577951308232:.4f} deg, lever arms "
                  f"{h['lever_arm_m'][0] * 1e3:.4f} / {h['lever_arm_m'][1] * 1e3:.4f} mm)")
            print(f"  contact pattern (mean load per face slice, z in mm): "
                  + ", ".join(f"{z * 1e3:.2f}:{f:.0f} N" for z, f in zip(zs, h["mean_slice_load_N"])))
            print(f"  load centroid across the face {h['mean_load_centroid_z_m'] * 1e3:.3f} mm (face "
                  f"{h['face_overlap_m'][0] * 1e3:.2f} … {h['face_overlap_m'][1] * 1e3:.2f} mm); peak pressure "
                  f"{h['max_peak_pressure_Pa'] / 1e9:.3f} GPa")
    return 0
