"""``hacgear sweep MODEL --torque T --fm START:STOP:N --direction up|down|both``: steady-state
response over mesh frequency (each speed from the previous steady state), jumps, HDF5 results."""
from __future__ import annotations

import argparse
import json
import math

from hacgear_core.cli._dyn_common import add_model_options, inputs_from_args, json_safe

__all__ = ["register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "sweep", help="steady-state speed sweep (up/down/both) with jump detection",
        description=(
            "Steady-state dynamic response of a spur pair over mesh frequency. Each speed starts from the "
            "previous steady state; steady state is detected (period-n orbit of the once-per-mesh-cycle "
            "samples, n <= 4) or the cycle cap is reported. With --out, one row per finished speed is "
            "written to an HDF5 file; re-running the same command after an interruption computes only "
            "the missing speeds."),
    )
    add_model_options(p)
    p.add_argument("--fm", required=True, help="mesh frequencies START:STOP:N [Hz, Hz, count]")
    p.add_argument("--direction", choices=("up", "down", "both"), default="both")
    p.add_argument("--out", default=None, help="HDF5 results file (incremental, resumable)")
    p.add_argument("--workers", type=int, default=1,
                   help="processes for the branches (2 runs up and down in parallel) [-]")
    p.add_argument("--rtol", type=float, default=1e-5, help="steady-state tolerance (relative) [-]")
    p.add_argument("--max-cycles", type=int, default=3000, help="cycle cap per speed [-]")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hacgear_core.dynamics.steady import SteadyStateOptions
    from hacgear_core.dynamics.sweep import SweepSpec, parse_fm, run_sweep
    from hacgear_core.errors import ModelError

    inp = inputs_from_args(args)
    fms = parse_fm(args.fm)
    spec = SweepSpec(inp.params, inp.table, tuple(fms), args.direction, args.force_law,
                     options=SteadyStateOptions(rtol=args.rtol, max_cycles=args.max_cycles), label=inp.label)
    if args.workers < 1:
        raise ModelError(f"--workers must be >= 1, got {args.workers}")
    ex = None
    if args.workers > 1 and len(spec.branches) > 1:
        from concurrent.futures import ProcessPoolExecutor

        ex = ProcessPoolExecutor(max_workers=min(args.workers, len(spec.branches)))
    try:
        res = run_sweep(spec, out=args.out, executor=ex, progress=not args.no_progress)
    finally:
        if ex is not None:
            ex.shutdown()
    rep = res.to_json()
    rep.update({"model": inp.label, "synthetic_table": inp.synthetic, "results_file": args.out,
                "computed_speeds": {b: r.recomputed for b, r in res.branches.items()}})
    if args.json:
        print(json.dumps(json_safe(rep), indent=1, allow_nan=False))
        return 0
    tag = " [SYNTHETIC TABLE]" if inp.synthetic else ""
    print(f"{inp.label}{tag}: torque {inp.params.torque_Nm:g} N*m, force law {args.force_law}, "
          f"{len(fms)} speeds, direction {args.direction}")
    for b, r in res.branches.items():
        print(f"branch {b} ({r.recomputed} speeds computed now):")
        print("   f_m [Hz]   rms x [um]  mean x [um]  DTE rms [um]  F_max [N]  loss [-]  DF_F  state")
        for i, f in enumerate(r.mesh_frequency_Hz):
            m = {k: v[i] for k, v in r.metrics.items()}
            st = f"period-{r.period_cycles[i]}" if r.converged[i] else "CAP"
            print(f"  {f:9.1f}  {m['rms_deflection_m'] * 1e6:10.4f}  {m['mean_deflection_m'] * 1e6:11.4f}  "
                  f"{m['dte_rms_m'] * 1e6:12.4f}  {m['peak_force_N']:9.1f}  {m['contact_loss_fraction']:8.3f}  "
                  f"{m['dynamic_factor_force']:4.2f}  {st}")
    if res.jumps:
        for j in res.jumps:
            print(f"{j.kind} in the {j.branch} sweep between {j.interval_Hz[0]:.1f} and {j.interval_Hz[1]:.1f} Hz "
                  f"(rms {j.rms_before_m * 1e6:.3f} -> {j.rms_after_m * 1e6:.3f} um)"
                  f"{' confirmed by hysteresis' if j.confirmed else ' (unconfirmed)'}")
    else:
        print("no jumps")
    return 0
