"""``hacgear study STUDY.toml``: a design study (model variants → tables → static and dynamic results) on a local
process pool or a Dask cluster, into one resumable HDF5 results file."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from hacgear_core.cli._commands import command_help
from hacgear_core.errors import ModelError
from hacgear_core.jsonio import dumps
from hacgear_core.outpaths import check_out_path
from hacgear_core.studies import best_variants, load_study, read_study, run_study

__all__ = ["register", "run", "dask_executor"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "study", help=command_help("study"),
        description=(
            "Run a study file (docs/studies.md): every combination of its variables' values is a variant of the base "
            "model; each variant gets its own tables (statics grid of the study, reused when a table of the same "
            "model values and grid exists in the tables folder), static results over the study's torques (STE "
            "peak-to-peak, mean mesh stiffness, peak root strain and contact pressure) and, with [dynamic], up/down "
            "speed sweeps (dynamic factors, peak root strain, contact loss, jumps). Results go into one HDF5 file, "
            "variant by variant: a run killed at any time continues when the same command is run again (finished "
            "variants are not recomputed). A variant that fails is reported with its variables and values, and the "
            "others still run (exit status 1). `hacgear plot STUDY.h5 --out map.png` draws the maps."),
    )
    p.add_argument("study", help="study file (TOML)")
    p.add_argument("--out", default=None,
                   help="results file .h5 (default: <study name>.h5 in the current folder; its folder must exist)")
    p.add_argument("--tables-dir", default=None,
                   help="folder of the variants' model files and tables (default: <out stem>_tables beside --out); "
                        "tables of the same provenance found there are reused")
    p.add_argument("--workers", type=int, default=None,
                   help="local worker processes [-] (default: CPU count; 1: in this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the statics positions and sweep branches on a Dask cluster (e.g. tcp://host:8786) "
                        "instead of local processes; needs the optional package dask[distributed] "
                        "(pip install 'hacgear[dask]')")
    p.add_argument("--fresh", action="store_true",
                   help="discard the results file and compute every variant's results again (tables and sweep rows "
                        "of the same provenance are still reused)")
    p.add_argument("--no-progress", action="store_true",
                   help="no progress bars: one line on stderr per stage of each variant instead")
    p.add_argument("--json", action="store_true", help="print a JSON summary (SI, unit in the key names)")
    p.set_defaults(func=run)


def dask_executor(address: str):
    """``(client, executor)`` of the Dask scheduler at ``address``: ``distributed.Client(address).get_executor()``.
    Raises :class:`ModelError` naming the missing package when dask.distributed is not installed."""
    try:
        from distributed import Client
    except ImportError:
        raise ModelError("--scheduler needs the optional package dask[distributed], which is not installed: "
                         "pip install 'hacgear[dask]' (or run without --scheduler on the local process pool)") from None
    try:
        client = Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise ModelError(f"--scheduler {address!r}: cannot connect to the Dask scheduler ({exc})") from None
    return client, client.get_executor()


def run(args: argparse.Namespace) -> int:
    spec = load_study(args.study)
    out = Path(args.out) if args.out is not None else Path(f"{spec.name}.h5")
    check_out_path(out, "--out", suffixes=(".h5", ".hdf5"))
    if args.workers is not None and args.workers < 1:
        raise ModelError(f"--workers [-] = {args.workers}; allowed: integer >= 1")
    if args.scheduler is not None and args.workers is not None:
        raise ModelError("--scheduler and --workers exclude each other: the Dask cluster has its own workers")
    client = executor = None
    if args.scheduler is not None:
        client, executor = dask_executor(args.scheduler)
    try:
        rep = run_study(spec, out, tables_dir=args.tables_dir, executor=executor, workers=args.workers,
                        fresh=args.fresh, progress=not args.no_progress,
                        log=(lambda m: print(f"hacgear study: {m}", file=sys.stderr, flush=True))
                        if args.no_progress else None)
    finally:
        if client is not None:
            client.close()
    res = read_study(out)
    best = best_variants(res)
    if args.json:
        d = rep.as_dict()
        d["static_torque_Nm"] = res.torque_Nm
        for v in d["variants"]:
            i = v["index"]
            if not res.done[i]:
                continue
            v["static"] = {m: res.static[m][i] for m in res.static}
            if res.dynamic:
                v["sweep_torque_Nm"] = res.dynamic_torque_Nm[i]
                v["sweep_max"] = {m: max(float(np.nanmax(br[m][i])) for br in res.dynamic.values())
                                  for m in ("dynamic_factor_force", "peak_root_strain", "contact_loss_fraction")}
                v["sweep_max_per_torque"] = {
                    m: [max(float(np.nanmax(br[m][i, d])) for br in res.dynamic.values())
                        for d in range(res.dynamic_torque_Nm.shape[1])]
                    for m in ("dynamic_factor_force", "peak_root_strain", "contact_loss_fraction")}
                v["jumps"] = res.jumps[i]
        d["best"] = {k: {kk: vv for kk, vv in v.items() if kk != "values"} for k, v in best.items()}
        print(dumps(d, indent=1))
        return 1 if rep.failed else 0
    print(f"study {spec.name}: {len(rep.variants)} variant(s) -> {out}" + (f" ({rep.message})" if rep.message else ""))
    for v in rep.variants:
        what = {"computed": "computed" + (" (tables reused)" if v.tables_reused else ""),
                "reused": f"finished in an earlier run, reused from {out}", "failed": "FAILED"}[v.status]
        print(f"  {v.index + 1:3d} {v.label}: {what}" + (f" ({v.seconds:.1f} s)" if v.status == "computed" else ""))
        if v.error:
            print(f"      {v.error}")
    done = np.flatnonzero(res.done)
    if done.size:
        print("static transmission error peak-to-peak [µm] at " + ", ".join(f"{t:g}" for t in res.torque_Nm) + " N·m:")
        for i in done:
            print(f"  {res.labels[i]}: " + ", ".join(f"{x * 1e6:.2f}" for x in res.static["ste_peak_to_peak_m"][i]))
        if res.dynamic:
            torques = res.dynamic_torque_Nm[done[0]]
            print("largest force dynamic factor of the sweeps at " + ", ".join(f"{t:g}" for t in torques) + " N·m:")
            for i in done:
                dfs = [max(float(np.nanmax(br["dynamic_factor_force"][i, d])) for br in res.dynamic.values())
                       for d in range(torques.size)]
                print(f"  {res.labels[i]}: " + ", ".join(f"{x:.2f}" for x in dfs)
                      + f" ({sum(len(j) for j in res.jumps[i])} confirmed jump(s))")
    for name, b in best.items():
        print(f"best by {name}: {b['label']} ({b['value']:.6g} {b['unit']})")
    if rep.failed:
        print(f"{len(rep.failed)} variant(s) failed; the others are complete (rerun the command to retry the failed "
              "ones)")
    return 1 if rep.failed else 0
