"""``hacgear modes MODEL --torque T``: natural frequencies and mode shapes of a spur pair
(linearised modal analysis at the torque, plus the impulse test of dissertation Sec. 3.6.1)."""
from __future__ import annotations

import argparse
import json

from hacgear_core.cli._dyn_common import add_model_options, inputs_from_args, json_safe

__all__ = ["register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "modes", help="natural frequencies and mode shapes at a torque (modal analysis + impulse test)",
        description=(
            "Linearised modal analysis of the lumped model at the torque (mesh stiffness = cycle mean of the "
            "local slope of the force-deflection function at the static deflection) and the impulse test "
            "(free vibration at single- and double-tooth-contact positions, contact-ratio-weighted mean)."),
    )
    add_model_options(p)
    p.add_argument("--no-impulse", action="store_true", help="skip the impulse test")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hacgear_core.dynamics.modes import impulse_test, modal_analysis
    from hacgear_core.dynamics.spur import SpurPairSystem

    inp = inputs_from_args(args)
    sy = SpurPairSystem(inp.params, inp.table, args.force_law)
    mr = modal_analysis(sy)
    rep = {"model": inp.label, "synthetic_table": inp.synthetic, "torque_Nm": inp.params.torque_Nm,
           "force_law": args.force_law, "bearing_stiffness_N_per_m": list(inp.params.bearing_stiffness_N_per_m)}
    rep.update(mr.to_json())
    if not args.no_impulse:
        rep["impulse_test"] = impulse_test(sy).to_json()
    if args.json:
        print(json.dumps(json_safe(rep), indent=2, allow_nan=False))
        return 0
    tag = " [SYNTHETIC TABLE]" if inp.synthetic else ""
    print(f"{inp.label}{tag}: torque {inp.params.torque_Nm:g} N*m, force law {args.force_law}, "
          f"mesh stiffness {mr.mesh_stiffness_N_per_m / 1e6:.2f} N/um")
    print("linearised natural frequencies [Hz]: " + ", ".join(f"{f:.1f}" for f in mr.natural_frequencies_Hz))
    print("mode shapes (rotations as r_b*theta), dofs " + ", ".join(mr.dof_names) + ":")
    for i, f in enumerate(mr.natural_frequencies_Hz):
        print(f"  {f:9.1f} Hz: " + " ".join(f"{c:+.3f}" for c in mr.mode_shapes[:, i]))
    if "impulse_test" in rep:
        it = rep["impulse_test"]
        print(f"impulse test: single contact (position {it['single_contact_position']:.3f}) "
              + ", ".join(f"{f:.1f}" for f in it["single_contact_Hz"]) + " Hz; double contact (position "
              f"{it['double_contact_position']:.3f}) " + ", ".join(f"{f:.1f}" for f in it["double_contact_Hz"])
              + f" Hz; contact ratio {it['contact_ratio']:.3f} -> weighted mean "
              + ", ".join(f"{f:.1f}" for f in it["weighted_mean_Hz"]) + " Hz")
    return 0
