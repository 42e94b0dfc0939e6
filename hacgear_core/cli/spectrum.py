"""``hacgear spectrum MODEL --fm F --quantity Q``: order spectrum of a steady-state response (dynamic or static
transmission error, mesh force, bearing force, root strain) over mesh orders and shaft orders, with the mesh
harmonics, their sidebands and the shaft orders marked (:mod:`hacgear_core.spectra`)."""
from __future__ import annotations

import argparse

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._dyn_common import add_model_options, inputs_from_args
from hacgear_core.cli._options import check_option
from hacgear_core.errors import ModelError
from hacgear_core.jsonio import dumps
from hacgear_core.outpaths import check_out_path
from hacgear_core.spectra.records import QUANTITIES, UNITS, system_spectra
from hacgear_core.spectra.spectrum import order_basis
from hacgear_core.spectra.waterfall import resonance_of_track, system_waterfalls

__all__ = ["register", "run"]

#: display scale and unit per quantity unit
_DISPLAY = {"m": (1e6, "µm"), "N": (1.0, "N"), "-": (1e6, "µε")}


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "spectrum", help=command_help("spectrum"),
        description=(
            "Simulate the constant-speed experiment at mesh frequency --fm [Hz] (static equilibrium, --settle-cycles "
            "mesh cycles for the transient, then a record of --periods common periods of the shafts: the mesh cycles "
            "after which every shaft is back in place, e.g. 28 for a 28:28 pair, lcm(28, 33, 39) = 12012 for the "
            "idler chain) and take the order spectrum of each channel of --quantity: dte (dynamic transmission error "
            "per mesh [m]), ste (static transmission error of the same positions [m]), force (drive-flank mesh force "
            "per mesh [N]), bearing_force (each gear's force on its bearing, fixed-frame x and y [N]), root_strain "
            "(every gauge on tooth 0 of its gear [-]). Orders: mesh order f/f_m; shaft order f/f_shaft with "
            "f_m = z x f_shaft (relative to the carrier in a planetary set). Marked: mesh harmonics k, sidebands "
            "k +- n shaft orders of each shaft, shaft orders n. Over whole common periods the amplitudes are exact "
            "(no window); a --record-cycles shorter than the common period uses the flat-top window "
            "(amplitude error <= 0.12 percent). Amplitudes: single-sided peak, in the quantity's unit (--json: SI). "
            "Perfect gears (no manufacturing errors) respond at mesh harmonics only. Run-up waterfall: --fm-end F2 "
            "ramps the mesh frequency linearly from --fm to F2 over --cycles mesh cycles (dte, force, root_strain), "
            "sampled equally in angle (order tracking), and takes the order spectrum of segments of "
            "--segment-cycles mesh cycles (default one common period): amplitude over mesh order and speed, and the "
            "mesh harmonics' amplitude over the mesh frequency (--json: per segment)."),
    )
    add_model_options(p)
    p.add_argument("--fm", type=float, required=True, help="mesh frequency [Hz]")
    p.add_argument("--quantity", choices=QUANTITIES, default="dte", help="the response analysed (default dte)")
    p.add_argument("--periods", type=int, default=1, help="common periods of the shafts recorded [-] (default 1)")
    p.add_argument("--record-cycles", type=int, default=None,
                   help="record this many mesh cycles instead [-] (at least one common period: the last whole "
                        "common periods are analysed without window; shorter: the flat-top window)")
    p.add_argument("--max-record-cycles", type=int, default=30000,
                   help="refuse a common period longer than this [mesh cycles] (default %(default)s)")
    p.add_argument("--settle-cycles", type=int, default=400,
                   help="mesh cycles simulated before the record [-] (default %(default)s)")
    p.add_argument("--steps-per-cycle", type=int, default=128, help="samples per mesh cycle [-] (default %(default)s)")
    p.add_argument("--harmonics", type=int, default=5, help="mesh harmonics marked [-] (default %(default)s)")
    p.add_argument("--sidebands", type=int, default=3,
                   help="shaft orders marked on each side of each harmonic, and as shaft orders [-] "
                        "(default %(default)s)")
    p.add_argument("--fm-end", type=float, default=None,
                   help="run-up waterfall: mesh frequency at the end of a linear run-up from --fm [Hz]")
    p.add_argument("--cycles", type=int, default=2800, help="run-up: mesh cycles of the ramp [-] (default %(default)s)")
    p.add_argument("--segment-cycles", type=int, default=None,
                   help="run-up: mesh cycles per spectrum [-] (default one common period of the shafts)")
    p.add_argument("--bins", action="store_true", help="--json: every bin too (mesh order, amplitude, phase)")
    p.add_argument("--plot", default=None, help="figure file (.png, .pdf, .svg): amplitude over mesh order per channel")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    check_option("--fm", args.fm, "mesh_frequency_Hz")
    if args.plot is not None:
        check_out_path(args.plot, "--plot", suffixes=(".png", ".pdf", ".svg"))
    for opt, v, lo in (("--periods", args.periods, 1), ("--max-record-cycles", args.max_record_cycles, 1),
                       ("--settle-cycles", args.settle_cycles, 0), ("--steps-per-cycle", args.steps_per_cycle, 8),
                       ("--harmonics", args.harmonics, 1), ("--sidebands", args.sidebands, 0),
                       ("--record-cycles", 1 if args.record_cycles is None else args.record_cycles, 1)):
        if v < lo:
            raise ModelError(f"{opt} [-] must be >= {lo}, got {v}")
    inp = inputs_from_args(args)
    sy = inp.system
    if args.fm_end is not None:
        return _run_up(args, inp)
    rec, spectra = system_spectra(sy, args.fm, args.quantity, record_cycles=args.record_cycles, periods=args.periods,
                                  max_record_cycles=args.max_record_cycles, samples_per_cycle=args.steps_per_cycle,
                                  settle_cycles=args.settle_cycles, harmonics=args.harmonics,
                                  sideband_orders=args.sidebands)
    groups = order_basis(sy).groups
    unit = UNITS[args.quantity]
    if args.plot is not None:
        from hacgear_core.plots.spectra import save_spectrum_figure

        scale, shown = _DISPLAY[unit]
        save_spectrum_figure(spectra, args.plot, unit=shown, scale=scale,
                             title=f"{inp.label}: {args.quantity} at f_m = {args.fm:g} Hz, "
                                   f"torque {sy.torque_Nm:g} N·m")
    if args.json:
        print(dumps({"model": inp.label, "synthetic_table": inp.synthetic, "torque_Nm": sy.torque_Nm,
                     "quantity": args.quantity, "unit": unit, "mesh_frequency_Hz": args.fm,
                     "shaft_order_ratios": {label: r for label, r in groups}, "record_cycles": rec.record_cycles,
                     "settle_cycles": rec.settle_cycles, "samples_per_cycle": rec.samples_per_cycle,
                     "periodicity_error": rec.periodicity_error, "plot": args.plot,
                     "channels": {ch: sp.to_json(bins=args.bins) for ch, sp in spectra.items()}}))
        return 0
    scale, shown = _DISPLAY[unit]
    tag = " [SYNTHETIC TABLE]" if inp.synthetic else ""
    print(f"{inp.label}{tag}: {args.quantity} spectrum at f_m {args.fm:g} Hz, torque {sy.torque_Nm:g} N*m; "
          f"{rec.record_cycles} mesh cycles after {rec.settle_cycles}, {rec.samples_per_cycle} samples per cycle; "
          f"periodicity error {rec.periodicity_error:.1e}")
    print("  shafts (turns per mesh cycle): " + ", ".join(f"{label} 1/{1 / r:.6g}" for label, r in groups))
    for ch, sp in spectra.items():
        if not sp.success:
            print(f"  {ch}: no spectrum: {sp.message}")
            continue
        frac = (f", {100 * (1 - sp.mesh_harmonic_power_fraction):.3g} % of the AC power off the mesh harmonics"
                if sp.coherent else "")
        print(f"  {ch}: mean {sp.mean * scale:.6g} {shown}, AC rms {sp.ac_rms * scale:.6g} {shown}"
              f" ({'coherent, no window' if sp.coherent else 'flat-top window'}){frac}")
        if sp.message:
            print(f"    note: {sp.message}")
        peak = max((ln.amplitude for ln in sp.lines), default=0.0)
        for ln in sp.lines:
            if ln.family == "mesh" or ln.amplitude > 1e-4 * peak:
                print(f"    {ln.family:8s} {ln.label:28s} order {ln.mesh_order:9.5f}  "
                      f"{ln.amplitude * scale:.6g} {shown}")
    if args.plot:
        print(f"  figure written to {args.plot}")
    return 0


def _run_up(args: argparse.Namespace, inp) -> int:
    """The run-up waterfall of ``--fm`` .. ``--fm-end``."""
    check_option("--fm-end", args.fm_end, "mesh_frequency_Hz")
    if args.cycles < 1 or (args.segment_cycles is not None and not 1 <= args.segment_cycles <= args.cycles):
        raise ModelError("need --cycles >= 1 and 1 <= --segment-cycles <= --cycles")
    sy = inp.system
    rec, wfs = system_waterfalls(sy, args.fm, args.fm_end, args.cycles, args.quantity,
                                 segment_cycles=args.segment_cycles, samples_per_cycle=args.steps_per_cycle,
                                 settle_cycles=args.settle_cycles, harmonics=args.harmonics)
    unit = UNITS[args.quantity]
    scale, shown = _DISPLAY[unit]
    if args.plot is not None:
        from hacgear_core.plots.spectra import save_waterfall_figure

        save_waterfall_figure(wfs, args.plot, unit=shown, scale=scale, max_order=args.harmonics + 0.5,
                              title=f"{inp.label}: {args.quantity}, run-up f_m {args.fm:g} -> {args.fm_end:g} Hz in "
                                    f"{args.cycles} mesh cycles, torque {sy.torque_Nm:g} N·m")
    if args.json:
        print(dumps({"model": inp.label, "synthetic_table": inp.synthetic, "torque_Nm": sy.torque_Nm,
                     "quantity": args.quantity, "unit": unit, "mesh_frequency_Hz": [args.fm, args.fm_end],
                     "cycles": args.cycles, "samples_per_cycle": rec.samples_per_cycle, "plot": args.plot,
                     "channels": {ch: wf.to_json(bins=args.bins) for ch, wf in wfs.items()}}))
        return 0
    print(f"{inp.label}: {args.quantity} run-up waterfall, f_m {args.fm:g} -> {args.fm_end:g} Hz in {args.cycles} "
          f"mesh cycles, torque {sy.torque_Nm:g} N*m")
    for ch, wf in wfs.items():
        print(f"  {ch}: {wf.mesh_frequency_Hz.size} segments of {wf.segment_cycles} mesh cycles "
              f"({'coherent, no window' if wf.coherent else 'flat-top window'}); largest amplitude per mesh harmonic:")
        for k in range(1, args.harmonics + 1):
            if str(k) in wf.tracks:
                f, a = resonance_of_track(wf, str(k))
                print(f"    order {k}: {a * scale:.6g} {shown} at f_m {f:.1f} Hz ({k * f:.1f} Hz)")
    if args.plot:
        print(f"  figure written to {args.plot}")
    return 0
