"""``hacgear simulate MODEL --fm F``: time simulation of a gear system (constant speed, a linear run-up, or shaft
torques in) with table post-processing (root strain, contact pressure, dynamic mesh stiffness)."""
from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._dyn_common import add_model_options, inputs_from_args
from hacgear_core.cli._options import check_option
from hacgear_core.dynamics.simulator import (Simulator, gauge_passage, passage_cycles, static_gauge_passage,
                                             strain_of_tooth, system_gauges)
from hacgear_core.dynamics.steady import trace_metrics
from hacgear_core.errors import ModelError
from hacgear_core.jsonio import dumps
from hacgear_core.outpaths import check_out_path, written_whole
from hacgear_core.response import dynamic_contact_pressure, dynamic_mesh_stiffness
from hacgear_core.tables.check import STEEL_PRESSURE_LIMIT_PA
from hacgear_core.tables.table import PRESSURE_PARTS

__all__ = ["register", "run", "SIMULATE_METRICS"]

#: the response metrics (:func:`hacgear_core.dynamics.steady.trace_metrics`) a simulation reports per mesh over its
#: recorded cycles, on the loaded flanks (``loaded_flank``) and the back side across the backlash
SIMULATE_METRICS = ("mean_deflection_m", "rms_deflection_m", "peak_force_N", "min_force_N", "contact_loss_fraction",
                    "back_side_contact_fraction", "peak_back_side_force_N", "back_side_impacts_per_cycle")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "simulate", help=command_help("simulate"),
        description=(
            "Integrate the lumped model from static equilibrium at constant mesh frequency --fm [Hz] (or ramped "
            "linearly to --fm-end) for --cycles mesh cycles, and write the last --record-cycles cycles: per mesh "
            "its position [cycles], deflection [m], force [N], dynamic mesh stiffness [N/m], peak contact pressure "
            "[Pa] (and the dynamic transmission error [m] when gears translate; with rigid bearings it equals the "
            "deflection), and the root strain [-] at every gauge (all meshes of its gear superposed) on the tooth "
            "whose whole passage through the mesh is recorded last. The root strain summary is taken over that "
            "passage (its tooth, time and mesh cycles are reported; more cycles than --record-cycles are recorded "
            "when the passage needs them), with the static strain at the same torque. Output: --out file (.csv or "
            ".npz) and/or a summary (--json); extremes are reported by magnitude with their sign."),
    )
    add_model_options(p)
    p.add_argument("--fm", type=float, required=True, help="mesh frequency [Hz] (start of a run-up)")
    p.add_argument("--fm-end", type=float, default=None, help="mesh frequency at the end of a linear run-up [Hz]")
    p.add_argument("--cycles", type=int, default=400, help="mesh cycles to simulate [-] (default %(default)s)")
    p.add_argument("--record-cycles", type=int, default=4,
                   help="mesh cycles written to --out and summarised per mesh, at the end [-] (default %(default)s)")
    p.add_argument("--steps-per-cycle", type=int, default=128, help="recorded samples per mesh cycle [-] (default %(default)s)")
    p.add_argument("--drive-torques", default=None,
                   help="T_in,T_out [N*m]: drivetrain coupling instead of a prescribed speed: shaft torques on the "
                        "input and output gears (each positive in its sense of rotation; a load is negative), "
                        "starting at --fm; the speed then follows from the dynamics (shafts of the model dropped)")
    p.add_argument("--out", default=None, help="output file: .csv or .npz (its folder must exist)")
    p.set_defaults(func=run)


def _check_out(path: str | None) -> None:
    if path is not None:
        check_out_path(path, "--out", suffixes=(".csv", ".npz"))


def _passage_summary(p, static, need: int) -> dict:
    """JSON summary of a gauge's recorded passage ``p`` (None: not recorded) and its ``static`` passage."""
    if p is None:
        return {"recorded": False, "cycles_needed": need}
    out = {"recorded": True, "tooth": p.tooth, "mesh_cycles": list(p.cycles), "time_s": list(p.time_s),
           "extreme": p.extreme, "max": p.max_strain, "min": p.min_strain}
    if static is not None:
        side = "tension" if static.extreme > 0 else "compression"
        out.update(static_extreme=static.extreme, static_max=static.max_strain, static_min=static.min_strain,
                   dynamic_factor=p.factor_over(static), factor_side=side,
                   peak_on_static_side=p.max_strain if side == "tension" else p.min_strain)
    return out


def pressure_text(s: dict) -> str:
    """The contact pressures of one mesh's summary: flank (Hertzian) and tip edge apart where the tables tell them."""
    if math.isnan(s["max_flank_pressure_Pa"]):
        return (f"max contact pressure {s['max_peak_pressure_Pa'] / 1e6:.1f} MPa (flank and tip-edge contacts not "
                "told apart by these tables)")
    text = f"max flank (Hertzian) contact pressure {s['max_flank_pressure_Pa'] / 1e6:.1f} MPa"
    if s["max_edge_pressure_Pa"] > 0:
        text += (f", tip-edge contact {100 * s['edge_contact_fraction']:.3g} % of the time at up to "
                 f"{s['max_edge_pressure_Pa'] / 1e6:.1f} MPa")
    return text


def pressure_warnings(mesh: str, s: dict) -> list[str]:
    """Warnings for contact pressures beyond what gear steel carries (:data:`STEEL_PRESSURE_LIMIT_PA`)."""
    lim = STEEL_PRESSURE_LIMIT_PA
    out = []
    beyond = (" (read at states beyond the tables: extrapolated, see the WARNING on the tables' range)"
              if s["steps_beyond_tables"] else "")
    if s["max_flank_pressure_Pa"] > lim:
        out.append(f"mesh {mesh}: flank contact pressure {s['max_flank_pressure_Pa'] / 1e9:.2f} GPa exceeds the "
                   f"{lim / 1e9:g} GPa no gear steel carries (static capacity of case-hardened steel, ISO 6336-2/-5: "
                   f"about 2.6 GPa): the flanks would pit or crush{beyond}")
    if s["max_edge_pressure_Pa"] > lim:
        out.append(f"mesh {mesh}: tip-edge contact at {s['max_edge_pressure_Pa'] / 1e9:.2f} GPa (a tip corner on the "
                   "mating flank, off the line of action): its value is set by the edge radius (tip_edge_radius_mm, "
                   f"0.1 mm taken for a sharp corner), not a flank stress; tip relief or a rounded tip edge avoids it"
                   f"{beyond}")
    if math.isnan(s["max_flank_pressure_Pa"]) and s["max_peak_pressure_Pa"] > lim:
        out.append(f"mesh {mesh}: contact pressure {s['max_peak_pressure_Pa'] / 1e9:.2f} GPa exceeds {lim / 1e9:g} "
                   "GPa; these tables do not tell flank from tip-edge contact (regenerate them: `hacgear statics "
                   f"MODEL --fresh`){beyond}")
    return out


def run(args: argparse.Namespace) -> int:
    _check_out(args.out)
    if args.cycles < 1 or not 1 <= args.record_cycles <= args.cycles or args.steps_per_cycle < 8:
        raise ModelError("need --cycles >= 1, 1 <= --record-cycles <= --cycles, --steps-per-cycle >= 8")
    check_option("--fm", args.fm, "mesh_frequency_Hz")
    check_option("--fm-end", args.fm_end, "mesh_frequency_Hz")
    drive = None
    if args.drive_torques is not None:
        try:
            drive = [float(t) for t in args.drive_torques.split(",")]
            assert len(drive) == 2
        except (ValueError, AssertionError):
            raise ModelError(f"--drive-torques must be T_in,T_out [N*m], got {args.drive_torques!r}") from None
        if args.fm_end is not None:
            raise ModelError("--fm-end (prescribed run-up) and --drive-torques (torque inputs) exclude each other")
    inp = inputs_from_args(args, shafts=drive is None)
    sy = inp.system
    sim = Simulator(sy)
    fm0 = args.fm
    fm1 = args.fm if args.fm_end is None else args.fm_end
    gauges = system_gauges(sy)
    need = {g: passage_cycles(sy, g) for g in gauges}      # a whole tooth passage per gauge
    n_rec = min(args.cycles, max([args.record_cycles, *need.values()]))
    n_free = args.cycles - n_rec
    if drive is not None:
        if len(sim.ports) != 2:
            raise ModelError(f"--drive-torques needs a system with two port gears; {sy.name} has {sim.ports}")
        sim.set_speed_input(mesh_frequency_Hz=fm0)
        out_gear = next(g for g in sim.ports if g != sy.input_gear)
        sim.set_torque_inputs({sy.input_gear: drive[0], out_gear: drive[1]})
    iref = sim.gear_index(sy.reference_gear)

    def current_fm(c):
        if drive is not None:  # the speed is an output: step by the current mesh period
            return max(abs(sim.speed_rad_s[iref]) * sy.zref_2pi, 1.0)
        fm = fm0 + (fm1 - fm0) * (c + 0.5) / args.cycles
        sim.set_speed_input(mesh_frequency_Hz=fm)
        return fm

    for c in range(n_free):
        fm = current_fm(c)
        r = sim.advance(1.0 / fm)
        if not r.success:
            raise ModelError(r.message)
    chunks = []
    for c in range(n_free, args.cycles):
        fm = current_fm(c)
        chunks.append(sim.run(1.0 / fm, 1.0 / (fm * args.steps_per_cycle)))
    full = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0] if k != "state"}
    passages = {g: gauge_passage(sy, g, full) for g in gauges}
    static = {g: static_gauge_passage(sy, g) for g in gauges} if drive is None else {}
    raw = {k: v[-args.record_cycles * args.steps_per_cycle:] for k, v in full.items()}   # the trace
    tau, x, f = raw["mesh_position"], raw["mesh_deflection_m"], raw["mesh_force_N"]
    xc, fc = raw["coast_approach_m"], raw["coast_force_N"]
    moving = any(g.translations for g in sy.gears.values())
    tr = {"time_s": raw["time_s"]}
    for k, c in enumerate(sy.meshes):
        m = c.name
        tr[f"{m}.position"] = tau[:, k]
        tr[f"{m}.deflection_m"] = x[:, k]
        tr[f"{m}.force_N"] = f[:, k]
        if c.coast_table is not None:
            tr[f"{m}.coast_approach_m"] = xc[:, k]
            tr[f"{m}.coast_force_N"] = fc[:, k]
            tr[f"{m}.contact_state"] = raw["contact_state"][:, k]
        if c.t is not None:  # helical mesh: the mesh twist and the twist moment (Fig. 5.11)
            tr[f"{m}.twist_rad"] = raw["mesh_twist_rad"][:, k]
            tr[f"{m}.twist_moment_Nm"] = raw["twist_moment_Nm"][:, k]
            if "coast_twist_rad" in raw:
                tr[f"{m}.coast_twist_rad"] = raw["coast_twist_rad"][:, k]
                tr[f"{m}.coast_twist_moment_Nm"] = raw["coast_twist_moment_Nm"][:, k]
        if moving:
            tr[f"{m}.dynamic_transmission_error_m"] = raw["dynamic_transmission_error_m"][:, k]
        gk = raw["mesh_twist_rad"][:, k] if c.t is not None else None      # helical: read at the mesh twist
        tr[f"{m}.dynamic_mesh_stiffness_N_per_m"] = dynamic_mesh_stiffness(c.table, tau[:, k], x[:, k], gk)
        for part in PRESSURE_PARTS:   # every contact, the flank (Hertzian) contacts, the tip edges
            pressure = dynamic_contact_pressure(c.table, tau[:, k], x[:, k], gk, part)
            if c.coast_table is not None:  # the flanks in contact: drive or coast (never both)
                gc = raw["coast_twist_rad"][:, k] if "coast_twist_rad" in raw else None   # helical: the coast twist
                pressure = np.maximum(pressure, dynamic_contact_pressure(c.coast_table, tau[:, k], xc[:, k], gc, part))
            tr[f"{m}.{part}_pressure_Pa"] = pressure
    for g in gauges:  # the tooth of the reported passage (tooth 0 when none was recorded)
        tooth = passages[g].tooth if passages[g] is not None else 0
        tr[f"strain[{g}]"] = strain_of_tooth(sy, g, tau, x, xc, raw.get("mesh_twist_rad"), tooth=tooth)
    per_mesh = {}
    if drive is None:   # the operating torque's sign picks the loaded flanks
        coast = np.full(sy.m, sy.torque_Nm < 0)
    else:               # torque inputs: the flanks that carry the load on average
        coast = fc.mean(axis=0) > f.mean(axis=0)
    metrics = trace_metrics(sy, x, f, raw["dynamic_transmission_error_m"], fc=fc, xc=xc,
                            cycles=args.record_cycles, coast_loaded=coast, periodic=False)
    for k, c in enumerate(sy.meshes):
        per_mesh[c.name] = {
            "loaded_flank": "coast" if coast[k] else "drive",
            **{name: float(metrics[name][k]) for name in SIMULATE_METRICS},
            "max_peak_pressure_Pa": float(tr[f"{c.name}.peak_pressure_Pa"].max()),
            "max_flank_pressure_Pa": float(np.max(tr[f"{c.name}.flank_pressure_Pa"])),
            "max_edge_pressure_Pa": float(np.max(tr[f"{c.name}.edge_pressure_Pa"])),
            "edge_contact_fraction": float(np.mean(tr[f"{c.name}.edge_pressure_Pa"] > 0)),
            "steps_beyond_tables": sim.out_of_range_steps[k],
            "table_deflection_range_m": [float(c.table.deflection_m[0]), float(c.table.deflection_m[-1])],
        }
        if c.t is not None:
            gk = raw["mesh_twist_rad"][:, k]
            per_mesh[c.name].update(mean_twist_rad=float(gk.mean()), rms_twist_rad=float(np.sqrt(np.mean(
                (gk - gk.mean()) ** 2))), mean_twist_moment_Nm=float(raw["twist_moment_Nm"][:, k].mean()))
        if c.coast_table is not None:
            per_mesh[c.name].update(mean_coast_approach_m=float(xc[:, k].mean()),
                                    coast_table_deflection_range_m=[float(c.coast_table.deflection_m[0]),
                                                                    float(c.coast_table.deflection_m[-1])])
        elif c.v_c is not None and math.isfinite(c.backlash_m):
            # a drive-only table: beyond the backlash the teeth pass through each other (counted as out of range)
            per_mesh[c.name].update(backlash_m=float(c.backlash_m))
    summary = {
        "model": inp.label, "synthetic_table": inp.synthetic, "torque_Nm": sy.torque_Nm,
        "force_law": args.force_law, "mesh_frequency_Hz": [fm0, fm1], "cycles": args.cycles,
        "recorded_samples": int(tau.shape[0]), "meshes": per_mesh,
        "final_speed_rad_s": dict(zip(sim.gear_names, sim.speed_rad_s)),
        "final_angle_rad": dict(zip(sim.gear_names, sim.angle_rad)),
        "drive_torques_Nm": drive,
        "extreme_strain": {g: None if p is None else p.extreme for g, p in passages.items()},
        "root_strain": {g: _passage_summary(p, static.get(g), need[g]) for g, p in passages.items()},
        "out": args.out,
    }
    if args.out:
        with written_whole(args.out) as tmp, open(tmp, "wb") as fh:
            if args.out.endswith(".npz"):
                np.savez(fh, **tr)
            else:
                keys = list(tr)
                np.savetxt(fh, np.column_stack([tr[k] for k in keys]), delimiter=",", header=",".join(keys),
                           comments="")
    if args.json:
        print(dumps(summary))
        return 0
    tag = " [SYNTHETIC TABLE]" if inp.synthetic else ""
    print(f"{inp.label}{tag}: {args.cycles} cycles at f_m {fm0:g}" + (f"->{fm1:g}" if fm1 != fm0 else "")
          + f" Hz, torque {sy.torque_Nm:g} N*m, law {args.force_law}")
    if drive is not None:
        print("  torque inputs " + ", ".join(f"{g} {t:g} N*m" for g, t in sim.port_torques_Nm.items())
              + ": final speeds " + ", ".join(f"{g} {w:.3f} rad/s" for g, w in zip(sim.gear_names, sim.speed_rad_s)))
    for m, s in per_mesh.items():
        print(f"  {m}, last {args.record_cycles} cycles: mean x {s['mean_deflection_m'] * 1e6:.3f} µm, rms "
              f"{s['rms_deflection_m'] * 1e6:.3f} µm; {s['loaded_flank']} flanks (the loaded ones): F_max "
              f"{s['peak_force_N']:.1f} N, contact loss {s['contact_loss_fraction']:.3f}; "
              + pressure_text(s))
        for w in pressure_warnings(m, s):
            print(f"  WARNING: {w}", file=sys.stderr)
        if sy.meshes[list(per_mesh).index(m)].coast_table is not None:
            print(f"    back side ({'drive' if s['loaded_flank'] == 'coast' else 'coast'} flanks) in contact "
                  f"{s['back_side_contact_fraction']:.3f} of the time, peak force {s['peak_back_side_force_N']:.1f} "
                  f"N, {s['back_side_impacts_per_cycle']:.3g} impact(s) per mesh cycle")
    beyond = {m: s["steps_beyond_tables"] for m, s in per_mesh.items() if s["steps_beyond_tables"]}

    def grid(m):
        s = per_mesh[m]
        out = (f"drive grid {s['table_deflection_range_m'][0] * 1e6:.4g} … "
               f"{s['table_deflection_range_m'][1] * 1e6:.4g} µm")
        if "coast_table_deflection_range_m" in s:
            out += (f", coast grid {s['coast_table_deflection_range_m'][0] * 1e6:.4g} … "
                    f"{s['coast_table_deflection_range_m'][1] * 1e6:.4g} µm")
        if "backlash_m" in s:
            out += (f"; no coast table: beyond the backlash ({s['backlash_m'] * 1e6:.4g} µm coast approach) the teeth "
                    "pass through each other, build the coast side with `hacgear statics MODEL`")
        return out

    if beyond:
        print("  WARNING: the state left the tables' range (deflection, and twist for helical meshes) in " + ", ".join(
            f"{m}: {n} integration steps ({grid(m)})" for m, n in beyond.items())
            + "; forces, pressures and strains there are extrapolated. Extend the tables: raise [statics] "
            "max_torque_factor in the model file and run `hacgear statics MODEL`", file=sys.stderr)
    if gauges:
        print("  root strain over one tooth's passage through the mesh, largest magnitude"
              + (", the static one at the same torque and their ratio (dynamic factor):" if static else ":"))
        for g, s in summary["root_strain"].items():
            if not s["recorded"]:
                print(f"    {g}: not recorded: a tooth's passage takes {s['cycles_needed']} mesh cycles; give "
                      f"--cycles >= {s['cycles_needed']}")
                continue
            if "static_extreme" in s:
                # the factor compares peaks of one sign: the static extreme's side (tension or compression)
                st = (f"{s['factor_side']} peak {s['peak_on_static_side'] * 1e6:+.1f} µε (static "
                      f"{s['static_extreme'] * 1e6:+.1f} µε, factor {s['dynamic_factor']:.3f})")
                if (s["extreme"] > 0) != (s["static_extreme"] > 0):
                    st += f"; largest magnitude {s['extreme'] * 1e6:+.1f} µε, on the other side"
            else:
                st = f"{s['extreme'] * 1e6:+.1f} µε"
            print(f"    {g}: {st}, range {s['min'] * 1e6:+.1f} … "
                  f"{s['max'] * 1e6:+.1f} µε; "
                  f"tooth {s['tooth']}, mesh cycles {s['mesh_cycles'][0]:.2f}-{s['mesh_cycles'][1]:.2f}, "
                  f"t {s['time_s'][0]:.6g}-{s['time_s'][1]:.6g} s")
    if args.out:
        print(f"  trace written to {args.out}")
    return 0
