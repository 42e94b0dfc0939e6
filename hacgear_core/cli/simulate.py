"""``hacgear simulate MODEL --torque T --fm F``: time simulation of a spur pair (constant speed or a
linear run-up) with table post-processing (root strain, contact pressure, dynamic mesh stiffness)."""
from __future__ import annotations

import argparse
import json

import numpy as np

from hacgear_core.cli._dyn_common import add_model_options, inputs_from_args, json_safe

__all__ = ["register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "simulate", help="time simulation at a mesh frequency (or a run-up) with post-processed outputs",
        description=(
            "Integrate the lumped spur-pair model from static equilibrium at constant mesh frequency --fm "
            "(or ramped linearly to --fm-end) for --cycles mesh cycles, and write the last --record-cycles "
            "cycles: mesh position, deflection, force, dynamic transmission error, dynamic mesh stiffness, "
            "peak contact pressure and root strain at every gauge (followed tooth). Output: --out file "
            "(.csv or .npz) and/or a summary (--json)."),
    )
    add_model_options(p)
    p.add_argument("--fm", type=float, required=True, help="mesh frequency [Hz] (start of a run-up)")
    p.add_argument("--fm-end", type=float, default=None, help="mesh frequency at the end of a linear run-up [Hz]")
    p.add_argument("--cycles", type=int, default=400, help="mesh cycles to simulate [-]")
    p.add_argument("--record-cycles", type=int, default=4, help="mesh cycles recorded at the end [-]")
    p.add_argument("--steps-per-cycle", type=int, default=128, help="recorded samples per mesh cycle [-]")
    p.add_argument("--drive-torques", default=None,
                   help="T1,T2 [N*m]: drivetrain coupling instead of a prescribed speed: shaft torques on gear 1 "
                        "and gear 2 (each positive in its direction of rotation; a load is negative), starting "
                        "at --fm; the speed then follows from the dynamics")
    p.add_argument("--out", default=None, help="output file: .csv or .npz")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hacgear_core import post
    from hacgear_core.dynamics.spur import SpurPairSimulator
    from hacgear_core.errors import ModelError

    inp = inputs_from_args(args)
    if args.cycles < 1 or not 1 <= args.record_cycles <= args.cycles or args.steps_per_cycle < 8:
        raise ModelError("need --cycles >= 1, 1 <= --record-cycles <= --cycles, --steps-per-cycle >= 8")
    if not args.fm > 0 or (args.fm_end is not None and not args.fm_end > 0):
        raise ModelError("--fm and --fm-end [Hz] must be > 0")
    sim = SpurPairSimulator(inp.params, inp.table, force_law=args.force_law)
    fm0 = args.fm
    fm1 = args.fm if args.fm_end is None else args.fm_end
    n_free = args.cycles - args.record_cycles
    drive = None
    if args.drive_torques is not None:
        try:
            drive = [float(t) for t in args.drive_torques.split(",")]
            assert len(drive) == 2
        except (ValueError, AssertionError):
            raise ModelError(f"--drive-torques must be T1,T2 [N*m], got {args.drive_torques!r}") from None
        if args.fm_end is not None:
            raise ModelError("--fm-end (prescribed run-up) and --drive-torques (torque inputs) exclude each other")
        sim.set_speed_input(mesh_frequency_Hz=fm0)
        sim.set_torque_inputs(*drive)

    def current_fm(c):
        if drive is not None:  # the speed is an output: step by the current mesh period
            return max(abs(sim.speed1_rad_s) * sim.system.z1_2pi, 1.0)
        fm = fm0 + (fm1 - fm0) * (c + 0.5) / args.cycles
        sim.set_speed_input(mesh_frequency_Hz=fm)
        return fm

    # free part: advance cycle by cycle (speed updated per cycle for a run-up)
    for c in range(n_free):
        fm = current_fm(c)
        r = sim.advance(1.0 / fm)
        if not r.success:
            raise ModelError(r.message)
    chunks = []
    for c in range(n_free, args.cycles):
        fm = current_fm(c)
        chunks.append(sim.run(1.0 / fm, 1.0 / (fm * args.steps_per_cycle)))
    tr = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0] if k != "state"}
    tab = inp.table
    tau, x = tr["mesh_position"], tr["mesh_deflection_m"]
    tr["dynamic_mesh_stiffness_N_per_m"] = post.dynamic_mesh_stiffness(tab, tau, x)
    if getattr(tab, "peak_pressure_Pa", None) is not None:
        tr["peak_pressure_Pa"] = post.dynamic_contact_pressure(tab, tau, x)
    t0 = np.floor(tau[0])
    for g in sorted(getattr(tab, "strain", None) or {}):
        tr[f"strain[{g}]"] = post.dynamic_root_strain(tab, g, tau - t0, x)
    summary = {
        "model": inp.label, "synthetic_table": inp.synthetic, "torque_Nm": inp.params.torque_Nm,
        "force_law": args.force_law, "mesh_frequency_Hz": [fm0, fm1], "cycles": args.cycles,
        "recorded_samples": int(tau.size),
        "mean_deflection_m": float(x.mean()), "rms_deflection_m": float(np.sqrt(np.mean((x - x.mean()) ** 2))),
        "peak_force_N": float(tr["mesh_force_N"].max()),
        "contact_loss_fraction": float(np.mean(tr["mesh_force_N"] <= 0)),
        "final_speed1_rad_s": sim.speed1_rad_s, "final_angle1_rad": sim.angle1_rad,
        "final_speed2_rad_s": sim.speed2_rad_s, "final_angle2_rad": sim.angle2_rad,
        "drive_torques_Nm": drive,
        "max_peak_pressure_Pa": float(tr["peak_pressure_Pa"].max()) if "peak_pressure_Pa" in tr else None,
        "max_strain": {k[7:-1]: float(v.max()) for k, v in tr.items() if k.startswith("strain[")},
        "out": args.out,
    }
    if args.out:
        if args.out.endswith(".npz"):
            np.savez(args.out, **tr)
        else:
            keys = list(tr)
            np.savetxt(args.out, np.column_stack([tr[k] for k in keys]), delimiter=",", header=",".join(keys),
                       comments="")
    if args.json:
        print(json.dumps(json_safe(summary), indent=2, allow_nan=False))
    else:
        tag = " [SYNTHETIC TABLE]" if inp.synthetic else ""
        print(f"{inp.label}{tag}: {args.cycles} cycles at f_m {fm0:g}" + (f"->{fm1:g}" if fm1 != fm0 else "")
              + f" Hz, torque {inp.params.torque_Nm:g} N*m, law {args.force_law}")
        if drive is not None:
            print(f"  torque inputs T1 = {drive[0]:g}, T2 = {drive[1]:g} N*m: final speeds {sim.speed1_rad_s:.3f}, "
                  f"{sim.speed2_rad_s:.3f} rad/s, angles {sim.angle1_rad:.4f}, {sim.angle2_rad:.4f} rad")
        print(f"  last {args.record_cycles} cycles: mean x {summary['mean_deflection_m'] * 1e6:.3f} um, rms "
              f"{summary['rms_deflection_m'] * 1e6:.3f} um, F_max {summary['peak_force_N']:.1f} N, contact loss "
              f"{summary['contact_loss_fraction']:.3f}")
        if summary["max_peak_pressure_Pa"] is not None:
            print(f"  max contact pressure {summary['max_peak_pressure_Pa'] / 1e6:.1f} MPa; max root strain "
                  + ", ".join(f"{g}: {v * 1e6:.1f} ustrain" for g, v in summary["max_strain"].items()))
        if args.out:
            print(f"  trace written to {args.out}")
    return 0
