"""``hacgear statics MODEL``: static contact analyses on the (position × load / deflection) grids of
every mesh → ``models/<system>/tables.h5`` (format: docs/tables.md).  ``--check`` reads an existing
table instead, verifies it against the model file and prints its figures."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from hacgear_core.errors import ModelError
from hacgear_core.model import resolve_model_path
from hacgear_core.statics import DEFAULT_DEFLECTION_MARGIN, compute_statics
from hacgear_core.tables import read_tables

__all__ = ["register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "statics",
        help="static contact analyses on the mesh grids → tables.h5 (FDF, strains, pressures)",
        description=(
            "Run the static contact solver of every mesh on a grid of mesh positions (one mesh cycle) × "
            "mesh forces 0 … max_torque_factor × nominal (load control) and × a regular mesh-deflection grid "
            "(deflection control: the force-deflection function), in parallel over positions. Results go "
            "into the HDF5 file position by position: a run killed at any time continues with --resume. "
            "Grid sizes default to the model's [statics] section."
        ),
    )
    p.add_argument("model", help="model file models/<system>/model.toml, its folder, or the system name")
    p.add_argument("--out", type=Path, default=None, help="output file (default: tables.h5 next to the model)")
    p.add_argument("--positions", type=int, default=None, help="mesh positions per mesh cycle [-]")
    p.add_argument("--loads", type=int, default=None, help="points of the load grid (incl. zero load) [-]")
    p.add_argument("--deflections", type=int, default=None, help="points of the FDF deflection grid [-]")
    p.add_argument("--max-torque-factor", type=float, default=None,
                   help="largest load / nominal load [-] (>= 3; default from the model)")
    p.add_argument("--deflection-margin", type=float, default=None,
                   help="deflection grid reaches (1 + margin) x the static range above the NLMD [-] (default 0.5)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU count; 1 = in-process)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run (<out>.partial)")
    p.add_argument("--solver", choices=("fe", "analytic"), default="fe",
                   help="fe: finite-element contact solver (hacgear_core.statics.contact); analytic: the analytical "
                        "reference spring model (not FE; for testing the pipeline)")
    p.add_argument("--check", action="store_true",
                   help="do not compute: read the existing table, check it against the model and print figures")
    p.add_argument("--ignore-model-hash", action="store_true",
                   help="with --check: accept a table whose model_sha256 differs from the model file")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the report as JSON (SI, unit in key names)")
    p.set_defaults(func=run)


def _check(args: argparse.Namespace) -> int:
    mp = resolve_model_path(args.model)
    tp = args.out or mp.parent / "tables.h5"
    t = read_tables(tp, mp, allow_hash_mismatch=args.ignore_model_hash)
    rep = {
        "path": str(tp), "model_sha256": t.model_sha256, "created": t.created, "format_version": t.format_version,
        "hacgear_version": t.hacgear_version, "meshes": {},
    }
    for m, mt in t.meshes.items():
        rep["meshes"][m] = {
            "positions": mt.n_positions, "loads": int(mt.load_N.size), "deflections": mt.n_deflections,
            "tooth_offsets": [int(k) for k in mt.tooth_offsets], "gauges": list(mt.gauge_names),
            "load_max_N": float(mt.load_N[-1]),
            "no_load_deflection_min_m": float(mt.no_load_deflection_m.min()),
            "no_load_deflection_max_m": float(mt.no_load_deflection_m.max()),
            "deflection_grid_min_m": float(mt.deflection_m[0]), "deflection_grid_max_m": float(mt.deflection_m[-1]),
            "force_max_N": float(mt.force_N.max()), "peak_pressure_max_Pa": float(mt.peak_pressure_Pa.max()),
            "solver": mt.solver,
        }
        if mt.twist is not None:
            tw = mt.twist
            rep["meshes"][m].update(
                twist_rad=tw.twist_rad.tolist(), slice_z_m=tw.slice_z_m.tolist(),
                base_helix_angle_rad=tw.base_helix_angle_rad, lever_arm_m=tw.lever_arm_m.tolist(),
                r_mesh=tw.r_mesh.tolist(), r_twist=tw.r_twist.tolist(),
                twist_moment_range_Nm=[float(tw.generalized_fdf[..., 1].min()), float(tw.generalized_fdf[..., 1].max())])
    if args.json:
        print(json.dumps(rep, indent=2))
    else:
        print(f"{tp}: OK for {mp} (created {t.created}, hacgear {t.hacgear_version})")
        for m, r in rep["meshes"].items():
            print(f"  mesh {m}: {r['positions']} positions x {r['loads']} loads (0 … {r['load_max_N']:.6g} N) x "
                  f"{r['deflections']} deflections ({r['deflection_grid_min_m'] * 1e6:.4g} … "
                  f"{r['deflection_grid_max_m'] * 1e6:.4g} µm); NLMD {r['no_load_deflection_min_m'] * 1e6:.4g} … "
                  f"{r['no_load_deflection_max_m'] * 1e6:.4g} µm; max force {r['force_max_N']:.6g} N; "
                  f"solver: {r['solver']}")
            if "twist_rad" in r:
                print(f"    twist axis {len(r['twist_rad'])} points, {r['twist_rad'][0] * 1e3:.4g} … "
                      f"{r['twist_rad'][-1] * 1e3:.4g} mrad; {len(r['slice_z_m'])} face slices; twist moment "
                      f"{r['twist_moment_range_Nm'][0]:.4g} … {r['twist_moment_range_Nm'][1]:.4g} N·m")
    return 0


def run(args: argparse.Namespace) -> int:
    if args.check:
        return _check(args)
    for name in ("positions", "loads", "deflections", "workers"):
        v = getattr(args, name)
        if v is not None and v < 1:
            raise ModelError(f"--{name} [-] = {v}; allowed: integer >= 1")
    rep = compute_statics(
        args.model, args.out, positions=args.positions, loads=args.loads, deflections=args.deflections,
        max_torque_factor=args.max_torque_factor,
        deflection_margin=DEFAULT_DEFLECTION_MARGIN if args.deflection_margin is None else args.deflection_margin,
        solver=args.solver, workers=args.workers, resume=args.resume, progress=not args.no_progress,
    )
    if args.json:
        print(json.dumps(rep.as_dict(), indent=2))
    else:
        print(rep.message)
        print(f"  {rep.tasks_computed} position task(s) computed, {rep.tasks_resumed} resumed, "
              f"wall time {rep.wall_s:.2f} s")
        for m, s in rep.meshes.items():
            print(f"  mesh {m}: NLMD {s['no_load_deflection_min_m'] * 1e6:.4g} … {s['no_load_deflection_max_m'] * 1e6:.4g} µm,"
                  f" deflection grid {s['deflection_grid_min_m'] * 1e6:.4g} … {s['deflection_grid_max_m'] * 1e6:.4g} µm,"
                  f" FDF reproduces the load-control results within {100 * s['fdf_reproduces_static_rel_err']:.3g}% "
                  "of the largest load")
    sys.stdout.flush()
    return 0 if rep.success else 1
