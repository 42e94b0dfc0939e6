"""``hacgear sweep MODEL --torque T --fm START:STOP:N --direction up|down|both``: steady-state response over mesh
frequency (each speed from the previous steady state), jumps per mesh, HDF5 results."""
from __future__ import annotations

import argparse

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._dyn_common import add_model_options, inputs_from_args
from hacgear_core.cli._options import check_option
from hacgear_core.dynamics.batch import BATCH_COMPILE_CPU_S
from hacgear_core.dynamics.steady import SteadyStateOptions
from hacgear_core.dynamics.sweep import SweepSpec, parse_fm, run_sweeps
from hacgear_core.errors import ModelError
from hacgear_core.h5files import check_writable_kind
from hacgear_core.jsonio import dumps
from hacgear_core.outpaths import check_out_path
from hacgear_core.workers import process_pool

__all__ = ["register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "sweep", help=command_help("sweep"),
        description=(
            "Steady-state dynamic response of a gear system over mesh frequency [Hz]. Each speed starts from the "
            "previous steady state; steady state is detected (period-n orbit of the once-per-mesh-cycle "
            "samples, n <= 4) or the cycle cap is reported. With --out, one row per finished speed is "
            "written to an HDF5 file; re-running the same command after an interruption (even kill -9, whose "
            "worker processes end by themselves) computes only the missing speeds and says how many it reused; "
            "--fresh computes them all again. Jumps: where the up and down branches differ (hysteresis), the "
            "up sweep jumps at the upper end of that region and the down sweep at its lower end (confirmed "
            "jumps, independent of the speed grid); other RMS changes > 30 % between adjacent speeds are "
            "listed as unconfirmed."),
    )
    add_model_options(p)
    p.add_argument("--fm", required=True, help="mesh frequencies START:STOP:N [Hz, Hz, count]")
    p.add_argument("--direction", choices=("up", "down", "both"), default="both",
                   help="up: ascending from static equilibrium at the lowest speed; down: descending from the highest; "
                        "both: the two (confirmed jumps need both; default %(default)s)")
    p.add_argument("--out", default=None, help="HDF5 results file .h5 (incremental, resumable; its folder must exist)")
    p.add_argument("--fresh", action="store_true",
                   help="with --out: discard the rows of this sweep already in the file and compute every speed again")
    p.add_argument("--workers", type=int, default=1,
                   help="processes for the branches (2 runs up and down in parallel) [-] (default %(default)s)")
    p.add_argument("--rtol", type=float, default=1e-5, help="steady-state tolerance (relative) [-] (default %(default)s)")
    p.add_argument("--max-cycles", type=int, default=3000, help="cycle cap per speed [-] (default %(default)s)")
    p.add_argument("--stability", action="store_true",
                   help="Floquet check of every detected orbit: an unstable one (largest multiplier modulus > 1) is "
                        "left along its growing perturbation, so each speed ends on an attractor; the table gains the "
                        "column |mu|max (--json: max_multiplier per speed)")
    p.add_argument("--torques", default=None,
                   help="several torques on the input gear, comma separated [N*m] (instead of --torque): one sweep "
                        "per torque, all branches in parallel over --workers processes (see --batched)")
    p.add_argument("--batched", choices=("auto", "on", "off"), default="auto",
                   help="run branches of one system (up and down, several --torques) as lanes of the batched kernel, "
                        "same numbers bit for bit: auto where a process gets >= 4 of them (e.g. 2 torques x both "
                        "directions on 1 worker), on where it gets >= 2, off never (default %(default)s; the first "
                        f"run on a machine compiles the batched loop, about {BATCH_COMPILE_CPU_S} s on one core per "
                        "lane count 2, 4 or 8)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _torques(args) -> list[float]:
    if args.torques is None:
        return [args.torque]  # None: the model's [operating] torque
    if args.torque is not None:
        raise ModelError(f"--torque {args.torque:g} and --torques {args.torques} exclude each other: give one torque "
                         "with --torque or several with --torques")
    try:
        ts = [float(t) for t in args.torques.split(",") if t.strip()]
    except ValueError:
        raise ModelError(f"--torques must be comma-separated numbers [N*m], got {args.torques!r}") from None
    if not ts:
        raise ModelError(f"--torques must be comma-separated numbers [N*m], got {args.torques!r}")
    for t in ts:
        check_option("--torques", t, "torque_Nm", signed=True)
    return ts


def run(args: argparse.Namespace) -> int:
    torques = _torques(args)
    args.torque = torques[0]
    fms = parse_fm(args.fm)
    if args.out is not None:
        check_out_path(args.out, "--out", suffixes=(".h5", ".hdf5"))
        check_writable_kind(args.out, "sweep", "sweep results")
    inp = inputs_from_args(args)
    if args.workers < 1:
        raise ModelError(f"--workers must be >= 1, got {args.workers}")
    opts = SteadyStateOptions(rtol=args.rtol, max_cycles=args.max_cycles, stability=args.stability)
    specs = [SweepSpec(inp.system, tuple(fms), args.direction, torque_Nm=t, options=opts,
                       label=f"{inp.system.name} {t or inp.system.torque_Nm:g} N*m") for t in torques]
    n_tasks = sum(len(s.branches) for s in specs)
    ex = None
    if args.workers > 1 and n_tasks > 1:
        ex = process_pool(min(args.workers, n_tasks))
    try:
        results = run_sweeps(specs, out=args.out, executor=ex, progress=not args.no_progress, fresh=args.fresh,
                             batched={"auto": None, "on": True, "off": False}[args.batched])
    finally:
        if ex is not None:
            ex.shutdown()
    reps = []
    for res in results:
        rep = res.to_json()
        rep.update({"model": inp.label, "synthetic_table": inp.synthetic, "results_file": args.out,
                    "computed_speeds": {b: r.recomputed for b, r in res.branches.items()},
                    "reused_speeds": {b: len(r.mesh_frequency_Hz) - r.recomputed for b, r in res.branches.items()},
                    "discarded_speeds": {b: r.discarded for b, r in res.branches.items()}})
        reps.append(rep)
    if args.json:
        print(dumps(reps[0] if len(reps) == 1 else reps, indent=1))
        return 0
    tag = " [SYNTHETIC TABLE]" if inp.synthetic else ""
    for res in results:
        print(f"{inp.label}{tag}: torque {res.spec.system.torque_Nm:g} N*m, force law {args.force_law}, "
              f"{len(fms)} speeds, direction {args.direction}")
        moving = any(g.translations for g in res.spec.system.gears.values())
        for b, r in res.branches.items():
            reused = len(r.mesh_frequency_Hz) - r.recomputed
            print(f"branch {b} ({r.recomputed} speeds computed now"
                  + (f", {reused} reused from {args.out} (--fresh recomputes them)" if reused else "")
                  + (f"; {r.discarded} stored speeds discarded (--fresh)" if r.discarded else "") + "):")
            sy = res.spec.system
            for k, mn in enumerate(res.spec.mesh_names):
                p, q = (int(v) for v in sy.rate[k])
                print(f" mesh {mn}:" if p == q else
                      f" mesh {mn} (its own mesh frequency {p}/{q} of f_m, the reference mesh {res.spec.mesh_names[0]}'s):")
                print("   f_m [Hz]   rms x [µm]  mean x [µm]" + ("  DTE rms [µm]" if moving else "")
                      + "  F_max [N]  loss [-]  DF_F  state" + ("     |mu|max" if args.stability else ""))
                for i, f in enumerate(r.mesh_frequency_Hz):
                    m = {key: v[i, k] for key, v in r.metrics.items()}
                    st = f"period-{r.period_cycles[i]}" if r.converged[i] else "CAP"
                    print(f"  {f:9.1f}  {m['rms_deflection_m'] * 1e6:10.4f}  {m['mean_deflection_m'] * 1e6:11.4f}  "
                          + (f"{m['dte_rms_m'] * 1e6:12.4f}  " if moving else "")
                          + f"{m['peak_force_N']:9.1f}  {m['contact_loss_fraction']:8.3f}  "
                          f"{m['dynamic_factor_force']:4.2f}  {st}"
                          + (f"  {r.max_multiplier[i]:10.4f}" if args.stability else ""))
        conf = [j for j in res.jumps if j.confirmed]
        for j in conf:
            print(f"{j.kind} of mesh {j.mesh} in the {j.branch} sweep between {j.interval_Hz[0]:.1f} and "
                  f"{j.interval_Hz[1]:.1f} Hz (rms {j.rms_before_m * 1e6:.3f} -> {j.rms_after_m * 1e6:.3f} µm), "
                  "confirmed by hysteresis")
        if not conf:
            print("no confirmed jumps")
        n_unc = len(res.jumps) - len(conf)
        if n_unc:
            print(f"{n_unc} unconfirmed RMS change(s) > 30 % between adjacent speeds (steep flanks or short "
                  "windows; listed in --json)")
    return 0
