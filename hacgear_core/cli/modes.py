"""``hacgear modes MODEL [--torque T]``: natural frequencies and mode shapes of a gear system (linearised modal
analysis at the torque, plus the impulse test of dissertation Sec. 3.6.1)."""
from __future__ import annotations

import argparse

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._dyn_common import add_model_options, inputs_from_args
from hacgear_core.cli._options import check_option
from hacgear_core.dynamics.modes import gyroscopic_modes, impulse_test, modal_analysis
from hacgear_core.errors import ModelError
from hacgear_core.kinds import kind_of
from hacgear_core.jsonio import dumps

__all__ = ["register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "modes", help=command_help("modes"),
        description=(
            "Linearised modal analysis of the lumped model at the torque (each mesh's stiffness = cycle mean of the "
            "local slope of its force-deflection function at its static deflection) and the impulse test (free "
            "vibration at single- and double-tooth-contact positions of the first mesh, contact-ratio-weighted "
            "mean). Mode shapes: one row per mode over the DOFs, rotations as base radius x angle [m], "
            "counter-clockwise positive. Planetary sets: every mode (rigid-body modes as 0 Hz) with its type "
            "(rotational / translational / planet / rigid / mixed, Lin & Parker) and multiplicity, at the carrier "
            "speed of --carrier-speed or --fm (gyroscopic modes); a lumped model (constant mesh stiffnesses) needs "
            "no tables."),
    )
    add_model_options(p)
    p.add_argument("--no-impulse", action="store_true", help="skip the impulse test")
    p.add_argument("--carrier-speed", type=float, default=None,
                   help="planetary sets: carrier speed [rad/s] of the gyroscopic modes (default 0); gearboxes: the "
                        "input member's speed [rad/s] (each stage's carrier at its own ratio)")
    p.add_argument("--fm", type=float, default=None,
                   help="planetary sets and gearboxes: mesh frequency [Hz] of the reference mesh (a gearbox's "
                        "first stage) whose speed the gyroscopic modes use")
    p.set_defaults(func=run)


def _run_planetary(args: argparse.Namespace, inp) -> int:
    sy = inp.system
    if args.carrier_speed is not None and args.fm is not None:
        raise ModelError("give --carrier-speed [rad/s] or --fm [Hz], not both")
    wc = float(args.carrier_speed) if args.carrier_speed is not None else (
        sy.carrier_ratio * sy.reference_speed(args.fm) if args.fm is not None else 0.0)
    gm = gyroscopic_modes(sy, wc)
    n_pl = sum(1 for c in sy.meshes if c.group == sy.meshes[0].group)
    rep = {"model": inp.label, "synthetic_table": inp.synthetic, "lumped": bool(getattr(inp.model, "lumped", False)),
           "planet_count": n_pl, "torque_Nm": sy.torque_Nm, "force_law": args.force_law}
    rep.update(gm.to_json())
    if not args.no_impulse and not rep["lumped"]:
        rep["impulse_test"] = impulse_test(sy).to_json()
    if args.json:
        print(dumps(rep))
        return 0
    staged = any(g.stage for g in sy.gears.values())
    if staged:
        # a gearbox: every stage's carrier turns at its own ratio of the input speed
        ks = ", ".join(f"{m} {k / 1e6:.2f} N/um" for m, k in zip(sy.mesh_names, gm.mesh_stiffness_N_per_m))
        print(f"{inp.label}: torque {sy.torque_Nm:g} N*m, input speed {wc:g} rad/s, mesh stiffness {ks}")
    else:
        ks = ", ".join(f"{m} {k / 1e6:.2f} N/um" for m, k in zip(sy.mesh_names[:2], gm.mesh_stiffness_N_per_m[:2]))
        print(f"{inp.label}: {n_pl} planets, torque {sy.torque_Nm:g} N*m, carrier speed {wc:g} rad/s, mesh "
              f"stiffness {ks}")
    print("  mode  frequency [Hz]  type           multiplicity  dominant member (share of kinetic energy)")
    for i, (f, t, k, d) in enumerate(zip(gm.natural_frequencies_Hz, gm.types, gm.multiplicity, gm.dominant)):
        where = f"{d[0]}: {d[1]}" if d[0] else d[1]
        print(f"  {i + 1:4d}  {f:14.1f}  {t:13s}  {k:12d}  {where} ({d[2]:.0%})")
    if "impulse_test" in rep:
        it = rep["impulse_test"]
        for key, pos in (("single_contact_Hz", "single_contact_position"), ("double_contact_Hz", "double_contact_position")):
            print(f"impulse test at reference mesh position {it[pos]:.3f}: " + ", ".join(f"{f:.1f}" for f in it[key])
                  + " Hz")
    return 0


def run(args: argparse.Namespace) -> int:
    check_option("--fm", args.fm, "mesh_frequency_Hz")
    inp = inputs_from_args(args)
    sy = inp.system
    if kind_of(sy).rotating_carrier:
        return _run_planetary(args, inp)
    if args.carrier_speed is not None or args.fm is not None:
        raise ModelError("--carrier-speed / --fm apply to planetary sets only")
    mr = modal_analysis(sy)
    rep = {"model": inp.label, "synthetic_table": inp.synthetic, "torque_Nm": sy.torque_Nm,
           "force_law": args.force_law,
           "bearing_stiffness_N_per_m": {g.name: g.support[0] for g in sy.gears.values()}}
    rep.update(mr.to_json())
    if not args.no_impulse:
        rep["impulse_test"] = impulse_test(sy).to_json()
    if args.json:
        print(dumps(rep))
        return 0
    tag = " [SYNTHETIC TABLE]" if inp.synthetic else ""
    ks = ", ".join(f"{m} {k / 1e6:.2f} N/um" for m, k in zip(sy.mesh_names, mr.mesh_stiffness_N_per_m))
    print(f"{inp.label}{tag}: torque {sy.torque_Nm:g} N*m, force law {args.force_law}, mesh stiffness {ks}")
    print("linearised natural frequencies [Hz]: " + ", ".join(f"{f:.1f}" for f in mr.natural_frequencies_Hz))
    print("mode shapes (rotations as r_b*theta, CCW), dofs " + ", ".join(mr.dof_names) + ":")
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
