"""``hacgear stiffness MODEL --torque T [--json]``: static transmission error and mesh stiffness.

Solves the static contact (finite-element far field + Hertz near field, :mod:`hacgear_core.contact`)
at ``--positions`` mesh positions of one mesh cycle under the mesh force ``T / r_b`` (``T`` on the
model's ``operating.torque_gear`` when it belongs to the mesh, else on the driver ``gear_a``; ``r_b``
that gear's loaded-flank base radius) and reports

* the static transmission error (mesh deflection ``x = r_b1 θ1 + r_b2 θ2``) over the cycle,
* the local-slope mesh stiffness ``dF/dx`` at that load at every position and its mean
  (``mean_mesh_stiffness_N_per_m``),
* the secant stiffness ``F / mean(x)``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

__all__ = ["register", "run", "stiffness_dict"]


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "stiffness", help="static transmission error and mesh stiffness over a mesh cycle",
        description="Static contact solve (FE far field + Hertz near field) over one mesh cycle at the given torque. "
                    "Text: summary with units. --json: SI values, unit in the key name.")
    p.add_argument("model", help="model file, folder or system name")
    p.add_argument("--torque", type=float, required=True, metavar="T",
                   help="torque [N·m] on the model's operating torque gear (or the driver gear_a)")
    p.add_argument("--mesh", default=None, help="mesh name (default: the first mesh of the model)")
    p.add_argument("--positions", type=int, default=64, help="mesh positions per cycle (default 64)")
    p.add_argument("--slices", type=int, default=None, help="face slices (default: model [statics] face_slices)")
    p.add_argument("--face-coupling", choices=("rigid", "slices"), default="rigid",
                   help="far-field coupling across the face (default rigid; slices = thin-slice model)")
    p.add_argument("--no-relief", action="store_true", help="remove all tip relief (study)")
    p.add_argument("--no-crowning", action="store_true", help="remove all lead crowning (study)")
    p.add_argument("--json", action="store_true", help="print JSON (SI units, unit in the key name)")
    p.set_defaults(func=run)


def stiffness_dict(model: Any, torque_Nm: float, *, mesh: str | None = None, positions: int = 64,
                   slices: int | None = None, face_coupling: str = "rigid") -> dict:
    """Everything ``hacgear stiffness --json`` prints (SI)."""
    from hacgear_core.contact import ContactOptions, make_mesh_solver, mesh_stiffness_curve
    from hacgear_core.errors import ModelError

    if not (math.isfinite(torque_Nm) and torque_Nm > 0):
        raise ModelError(f"--torque [N·m] must be finite and > 0, got {torque_Nm!r}")
    if not 2 <= positions <= 4096:
        raise ModelError(f"--positions must be in [2, 4096], got {positions}")
    names = [m.name for m in model.meshes]
    if not names:
        raise ModelError("the model has no mesh")
    mesh = mesh or names[0]
    if mesh not in names:
        raise ModelError(f"--mesh {mesh!r} is not a mesh of the model; allowed: {', '.join(names)}")
    opts = ContactOptions(face_slices=slices if slices is not None else model.statics.face_slices,
                          face_coupling=face_coupling)
    solver = make_mesh_solver(model, mesh, options=opts)
    m = {x.name: x for x in model.meshes}[mesh]
    tg = model.operating.torque_gear
    gi = 1 if tg == m.gear_b else 0
    force = torque_Nm / solver.base_radius_m[gi]
    c = mesh_stiffness_curve(solver, force, positions=positions)
    return {
        "model": model.name, "mesh": mesh, "torque_Nm": torque_Nm, "torque_gear": solver.gear_names[gi],
        "mesh_force_N": force, "base_radius_m": list(solver.base_radius_m),
        "face_slices": opts.face_slices, "face_coupling": opts.face_coupling,
        "mean_mesh_stiffness_N_per_m": c.mean_mesh_stiffness_N_per_m,
        "secant_mesh_stiffness_N_per_m": c.secant_mesh_stiffness_N_per_m,
        "local_slope_stiffness_N_per_m": c.local_slope_stiffness_N_per_m.tolist(),
        "mean_average_slope_stiffness_N_per_m": float(c.average_slope_stiffness_N_per_m.mean()),
        "ste_m": c.ste_m.tolist(),
        "ste_peak_to_peak_m": float(c.ste_m.max() - c.ste_m.min()),
        "no_load_deflection_m": c.no_load_deflection_m.tolist(),
        "mesh_cycle": c.mesh_cycle.tolist(),
        "tooth_offsets": [int(k) for k in solver.tooth_offsets],
        "tooth_load_N": c.tooth_load_N.tolist(),
        "seconds": c.seconds,
    }


def run(args: argparse.Namespace) -> int:
    from hacgear_core.contact import model_variant
    from hacgear_core.model import load_model

    model = load_model(args.model)
    if args.no_relief or args.no_crowning:
        model = model_variant(model, tip_relief=not args.no_relief, lead_crowning=not args.no_crowning)
    d = stiffness_dict(model, args.torque, mesh=args.mesh, positions=args.positions, slices=args.slices,
                       face_coupling=args.face_coupling)
    if args.json:
        json.dump(d, sys.stdout, indent=1)
        sys.stdout.write("\n")
        return 0
    ste = d["ste_m"]
    print(f"{d['model']} mesh {d['mesh']}: torque {d['torque_Nm']:g} N·m on {d['torque_gear']}, "
          f"mesh force {d['mesh_force_N']:.1f} N, {len(ste)} positions, {d['face_slices']} face slices "
          f"({d['face_coupling']})")
    print(f"  mean mesh stiffness (local slope) {d['mean_mesh_stiffness_N_per_m'] / 1e6:9.2f} MN/m")
    print(f"  secant mesh stiffness             {d['secant_mesh_stiffness_N_per_m'] / 1e6:9.2f} MN/m")
    print(f"  mean average-slope stiffness      {d['mean_average_slope_stiffness_N_per_m'] / 1e6:9.2f} MN/m")
    k = d["local_slope_stiffness_N_per_m"]
    print(f"  local slope min / max             {min(k) / 1e6:9.2f} / {max(k) / 1e6:.2f} MN/m")
    print(f"  static transmission error mean    {sum(ste) / len(ste) * 1e6:9.3f} µm, peak-to-peak "
          f"{d['ste_peak_to_peak_m'] * 1e6:.3f} µm")
    print(f"  ({d['seconds']:.1f} s)")
    return 0
