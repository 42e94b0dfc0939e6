"""``hacgear campbell MODEL --speeds START:STOP:N``: Campbell diagram — natural frequencies over the input speed
with the mesh-harmonic and shaft-order lines and the speeds where they cross (:mod:`hacgear_core.spectra.campbell`)."""
from __future__ import annotations

import argparse

import numpy as np

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._dyn_common import add_model_options, inputs_from_args
from hacgear_core.errors import ModelError
from hacgear_core.jsonio import dumps
from hacgear_core.outpaths import check_out_path
from hacgear_core.spectra.campbell import RPM_PER_RAD_S, campbell

__all__ = ["register", "run", "parse_speeds"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "campbell", help=command_help("campbell"),
        description=(
            "Natural frequencies of the linearised model at the torque over the input gear's speed --speeds "
            "START:STOP:N [rpm] (N speeds, START >= 0) with the order lines: mesh harmonics k x f_m (f_m = z x the "
            "shaft speed, relative to the carrier in a planetary set) and shaft orders n x f_shaft, and every "
            "crossing (the input speed [rpm] where a line meets a natural frequency [Hz]). Spur, idler and helical "
            "systems: modes independent of speed, crossings in closed form (speed = f_mode / (k z) turns per "
            "second); planetary sets: gyroscopic modes at each carrier speed, crossings by bisection. --json: SI "
            "and rpm, unit in the key name."),
    )
    add_model_options(p)
    p.add_argument("--speeds", required=True, help="START:STOP:N input gear speeds [rpm]")
    p.add_argument("--harmonics", type=int, default=3, help="mesh harmonics drawn [-] (default %(default)s)")
    p.add_argument("--shaft-orders", type=int, default=1, help="shaft orders drawn per shaft [-] (default %(default)s)")
    p.add_argument("--plot", default=None, help="figure file (.png, .pdf, .svg)")
    p.set_defaults(func=run)


def parse_speeds(text: str) -> np.ndarray:
    """``START:STOP:N`` [rpm] -> N speeds [rpm] (N >= 2, 0 <= START < STOP)."""
    try:
        a, b, n = text.split(":")
        a, b, n = float(a), float(b), int(n)
    except ValueError:
        raise ModelError(f"--speeds must be START:STOP:N [rpm], got {text!r}") from None
    if not (0 <= a < b and np.isfinite(b) and 2 <= n <= 100000):
        raise ModelError(f"--speeds START:STOP:N [rpm] needs 0 <= START < STOP (finite) and 2 <= N <= 100000, got "
                         f"{text!r}")
    return np.linspace(a, b, n)


def run(args: argparse.Namespace) -> int:
    rpm = parse_speeds(args.speeds)
    if args.harmonics < 1 or args.shaft_orders < 0:
        raise ModelError("--harmonics [-] must be >= 1 and --shaft-orders [-] >= 0")
    if args.plot is not None:
        check_out_path(args.plot, "--plot", suffixes=(".png", ".pdf", ".svg"))
    inp = inputs_from_args(args)
    sy = inp.system
    res = campbell(sy, rpm / RPM_PER_RAD_S, harmonics=args.harmonics, shaft_orders=args.shaft_orders)
    if args.plot is not None:
        from hacgear_core.plots.spectra import save_campbell_figure

        save_campbell_figure(res, args.plot, title=f"{inp.label}\nCampbell diagram, torque {sy.torque_Nm:g} N·m")
    if args.json:
        print(dumps({"model": inp.label, "synthetic_table": inp.synthetic, "torque_Nm": sy.torque_Nm,
                     "plot": args.plot, **res.to_json()}))
        return 0
    tag = " [SYNTHETIC TABLE]" if inp.synthetic else ""
    kind = "gyroscopic modes, by rank, at each speed" if res.speed_dependent else "modes independent of speed"
    print(f"{inp.label}{tag}: torque {sy.torque_Nm:g} N*m, input gear {res.input_gear} {rpm[0]:g}-{rpm[-1]:g} rpm; "
          f"f_m = {res.mesh_hz_per_rad_s / RPM_PER_RAD_S:.6g} Hz per rpm; {kind}")
    print("  natural frequencies at the first speed [Hz]: "
          + ", ".join(f"{f:.1f}" for f in res.natural_frequencies_Hz[0]))
    print(f"  {len(res.crossings)} crossing(s):")
    for c in res.crossings:
        print(f"    {c.line:24s} mode {c.mode + 1:2d}: {c.input_speed_rpm:10.2f} rpm, {c.frequency_Hz:8.1f} Hz "
              f"(f_m {c.mesh_frequency_Hz:.1f} Hz)")
    if args.plot:
        print(f"  figure written to {args.plot}")
    return 0
