"""``hacgear statics MODEL``: static contact analyses on the (position × load / deflection) grids of
every mesh → ``models/<system>/tables.h5`` (format: docs/tables.md).  ``--check`` reads an existing
table instead and verifies its checksums, its provenance and its physical sanity."""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._options import check_option, given
from hacgear_core.errors import ModelError, TableError
from hacgear_core.jsonio import dumps
from hacgear_core.model import resolve_model_path
from hacgear_core.kinds import load_model
from hacgear_core.outpaths import check_out_path
from hacgear_core.statics import DEFAULT_DEFLECTION_MARGIN, compute_statics, nominal_mesh_forces
from hacgear_core.tables import file_integrity, read_tables
from hacgear_core.tables.check import pressure_notes, resolution_notes, sanity_problems

__all__ = ["register", "run", "check_report"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "statics",
        help=command_help("statics"),
        description=(
            "Run the static contact solver of every mesh on a grid of mesh positions (one mesh cycle) × "
            "mesh forces 0 … max_torque_factor × nominal (load control) and × a regular mesh-deflection grid "
            "(deflection control: the force-deflection function), for both sides of every mesh (drive flanks; coast "
            "flanks: positions in drive terms, deflection = coast approach from the drive kinematic position), in "
            "parallel over positions. Results go "
            "into <out>.partial position by position; a run killed at any time (even kill -9, whose worker "
            "processes end by themselves) continues where it stopped when the same command is run again, and "
            "the output says so; --fresh discards the partial file instead. A partial file made with other "
            "settings is never replaced silently. Grid sizes default to the model's [statics] section. "
            "Finite-element factorisations are cached in $HACGEAR_CACHE_DIR (default ~/.cache/hacgear)."
        ),
    )
    p.add_argument("model", help="model file models/<system>/model.toml, its folder, or the system name")
    p.add_argument("--out", type=Path, default=None, help="output file (default: tables.h5 next to the model)")
    p.add_argument("--positions", type=int, default=None, help="mesh positions per mesh cycle [-] (default: the model's [statics] positions)")
    p.add_argument("--loads", type=int, default=None, help="points of the load grid (incl. zero load) [-] (default: the model's [statics] loads)")
    p.add_argument("--deflections", type=int, default=None, help="points of the FDF deflection grid [-] (default: the model's [statics] deflections)")
    p.add_argument("--max-torque-factor", type=float, default=None,
                   help="largest load / nominal load [-] (>= 3; default from the model)")
    p.add_argument("--deflection-margin", type=float, default=None,
                   help="deflection grid reaches (1 + margin) x the static range above the NLMD [-] (default 0.5)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU count; 1 = in-process)")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--resume", action="store_true",
                      help="continue an interrupted run (<out>.partial); this is the default, the flag is kept "
                           "for scripts")
    mode.add_argument("--fresh", action="store_true",
                      help="discard an interrupted run (<out>.partial) and a finished table of the same settings, "
                           "and compute everything again")
    p.add_argument("--solver", choices=("fe", "analytic"), default=None,
                   help="fe: finite-element contact solver (hacgear_core.statics.contact); analytic: the analytical "
                        "reference spring model (not FE; for testing the pipeline); default fe")
    p.add_argument("--face-coupling", choices=("rigid", "slices", "elastic"), default=None,
                   help="far-field coupling across the face, as `hacgear stiffness --face-coupling`: rigid (2D, "
                        "uniform; spur default), slices (thin-slice model), elastic (2D + 3D face-wise influence; "
                        "helical default, and a spur pair's with [statics] twist_points > 1, which then gets a "
                        "twist axis; rigid is refused there); the choice is part of the tables' solver description")
    p.add_argument("--check", action="store_true",
                   help="do not compute: read the existing table, verify every dataset's checksum, that it belongs "
                        "to the model (the model values it depends on), its physical sanity (finite, forces >= 0, "
                        "non-decreasing in deflection, regular grids, plausible magnitudes) and that its load grid "
                        "spans >= 3 x the model's nominal mesh force; exit status 1 when anything fails")
    p.add_argument("--ignore-model-hash", action="store_true",
                   help="with --check: accept a table whose model values differ from the model file's")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the report as JSON (SI, unit in key names)")
    p.set_defaults(func=run)


def check_report(model: str | Path, tables: str | Path | None = None, *, ignore_model_hash: bool = False) -> dict:
    """Everything ``hacgear statics --check`` verifies, as a dict; ``problems`` lists what failed (empty: OK)."""
    mp = resolve_model_path(model)
    tp = Path(tables) if tables is not None else mp.parent / "tables.h5"
    if not tp.exists():
        raise TableError(f"no tables for {mp}: {tp} does not exist; generate it with `hacgear statics {mp}`")
    integ = file_integrity(tp)
    problems = [f"checksum: {u}" for u in integ["unreadable"]]
    if integ["attributes"] == "corrupted":
        problems.append("attributes: they do not match their checksum (corrupted)")
    rep: dict = {"path": str(tp), "model": str(mp), "checksums": integ, "meshes": {}, "problems": problems}
    if problems:
        return rep
    t = read_tables(tp, mp, allow_hash_mismatch=ignore_model_hash, check_values=False)
    rep.update({"model_values_sha256": t.attrs.get("model_values_sha256", ""), "model_sha256": t.model_sha256,
                "provenance": "model values" if t.attrs.get("model_values_sha256") else "model file bytes (old table)",
                "created": t.created, "format_version": t.format_version, "hacgear_version": t.hacgear_version})
    model_obj = load_model(mp)
    try:
        nominal = nominal_mesh_forces(model_obj, {m: mt.base_radius_m for m, mt in t.meshes.items()})
    except (ModelError, KeyError):
        nominal = {}
    regions = [(m, mt0, nominal.get(m)) for m, mt0 in t.meshes.items()]
    regions += [(f"{m}/coast", mt0.coast, None) for m, mt0 in t.meshes.items() if mt0.coast is not None]
    for m, mt, fn in regions:
        mp_problems = sanity_problems(mt)
        if fn is not None and mt.load_N[-1] < 3.0 * fn * (1 - 1e-9):
            mp_problems.append(
                f"load_N: the table spans loads up to {mt.load_N[-1]:.6g} N = {mt.load_N[-1] / fn:.3g} x the model's "
                f"nominal mesh force {fn:.6g} N (operating torque {model_obj.operating.torque_Nm:g} N*m); tables "
                "must span >= 3 x nominal: regenerate with `hacgear statics MODEL --fresh`")
        finite = np.isfinite(mt.force_N)
        rep["meshes"][m] = {
            "positions": mt.n_positions, "loads": int(mt.load_N.size), "deflections": mt.n_deflections,
            "tooth_offsets": [int(k) for k in mt.tooth_offsets], "gauges": list(mt.gauge_names),
            "load_max_N": float(mt.load_N[-1]), "nominal_mesh_force_N": fn,
            "no_load_deflection_min_m": float(np.min(mt.no_load_deflection_m)),
            "no_load_deflection_max_m": float(np.max(mt.no_load_deflection_m)),
            "deflection_grid_min_m": float(mt.deflection_m[0]), "deflection_grid_max_m": float(mt.deflection_m[-1]),
            "force_max_N": float(np.max(mt.force_N[finite])) if finite.any() else float("nan"),
            "peak_pressure_max_Pa": float(np.nanmax(mt.peak_pressure_Pa)),
            "flank_pressure_max_Pa": None if mt.flank_pressure_Pa is None else float(np.nanmax(mt.flank_pressure_Pa)),
            "edge_pressure_max_Pa": None if mt.edge_pressure_Pa is None else float(np.nanmax(mt.edge_pressure_Pa)),
            "solver": mt.solver, "problems": mp_problems, "notes": resolution_notes(mt) + pressure_notes(mt),
            "side": mt.side, "flanks": list(mt.flanks),
        }
        if mt.side == "coast":
            rep["meshes"][m].update(backlash_normal_m=mt.backlash_normal_m, backlash_circular_m=mt.backlash_circular_m,
                                    position_offset=mt.position_offset, pair_shift=dict(mt.pair_shift))
        if mt.twist is not None:
            tw = mt.twist
            rep["meshes"][m].update(
                twist_rad=tw.twist_rad.tolist(), slice_z_m=tw.slice_z_m.tolist(),
                base_helix_angle_rad=tw.base_helix_angle_rad, lever_arm_m=tw.lever_arm_m.tolist(),
                r_mesh=tw.r_mesh.tolist(), r_twist=tw.r_twist.tolist(),
                twist_moment_range_Nm=[float(tw.generalized_fdf[..., 1].min()), float(tw.generalized_fdf[..., 1].max())])
        problems += [f"mesh {m}: {q}" for q in mp_problems]
    for m, mt0 in t.meshes.items():
        if mt0.coast is None:
            rep.setdefault("warnings", []).append(
                f"mesh {m}: no coast side (one-sided table, format_version {t.format_version}); regenerate with "
                f"`hacgear statics {mp}` for torque reversal and backlash")
    return rep


def _check(args: argparse.Namespace) -> int:
    rep = check_report(args.model, args.out, ignore_model_hash=args.ignore_model_hash)
    if args.json:
        print(dumps(rep, indent=2))
        return 1 if rep["problems"] else 0
    c = rep["checksums"]
    tp = rep["path"]
    if c["checksummed"] == c["datasets"]:
        print(f"{tp}: {c['datasets']} datasets with Fletcher-32 checksums, {len(c['unreadable'])} failed; "
              f"attribute digest: {c['attributes']}")
    else:
        print(f"{tp}: {c['datasets'] - c['checksummed']} of {c['datasets']} datasets carry no checksum (written "
              "before hacgear stored checksums: corruption cannot be detected); regenerate it with "
              "`hacgear statics MODEL --fresh`")
    if "provenance" in rep:
        print(f"  belongs to {rep['model']} (by {rep['provenance']}; created {rep['created']}, hacgear "
              f"{rep['hacgear_version']})")
    for m, r in rep["meshes"].items():
        nom = "" if r["nominal_mesh_force_N"] is None else f" = {r['load_max_N'] / r['nominal_mesh_force_N']:.3g} x nominal"
        extra = ""
        if r["side"] == "coast":
            extra = (f"; coast approach from the drive kinematic position, backlash "
                     f"{r['backlash_normal_m'] * 1e6:.4g} µm normal / {r['backlash_circular_m'] * 1e6:.4g} µm "
                     f"circular")
        print(f"  mesh {m} ({r['side']}, {'/'.join(r['flanks']) or '?'} flanks): {r['positions']} positions x "
              f"{r['loads']} loads (0 … {r['load_max_N']:.6g} N{nom}) x "
              f"{r['deflections']} deflections ({r['deflection_grid_min_m'] * 1e6:.4g} … "
              f"{r['deflection_grid_max_m'] * 1e6:.4g} µm); NLMD {r['no_load_deflection_min_m'] * 1e6:.4g} … "
              f"{r['no_load_deflection_max_m'] * 1e6:.4g} µm; max force {r['force_max_N']:.6g} N{extra}; "
              f"solver: {r['solver']}")
        if "twist_rad" in r:
            print(f"    twist axis {len(r['twist_rad'])} points, {r['twist_rad'][0] * 1e3:.4g} … "
                  f"{r['twist_rad'][-1] * 1e3:.4g} mrad; {len(r['slice_z_m'])} face slices; twist moment "
                  f"{r['twist_moment_range_Nm'][0]:.4g} … {r['twist_moment_range_Nm'][1]:.4g} N·m")
        for note in r["notes"]:
            print(f"    note: {note}")
    for w in rep.get("warnings", []):
        print(f"warning: {w}", file=sys.stderr)
    if rep["problems"]:
        print(f"FAILED: {len(rep['problems'])} problem(s)")
        for q in rep["problems"]:
            print(f"  - {q}")
        return 1
    what = "checksums, provenance" if c["checksummed"] == c["datasets"] else "provenance (no checksums to verify)"
    print(f"OK: {what} and physical sanity (finite, forces >= 0, non-decreasing in deflection, zero "
          "where the teeth do not touch, regular grids, plausible magnitudes, loads >= 3 x nominal)")
    return 0


#: options that set up a computation: they have no effect with --check, so giving them there is an error
_COMPUTE_OPTIONS = {"positions": "--positions", "loads": "--loads", "deflections": "--deflections",
                    "max_torque_factor": "--max-torque-factor", "deflection_margin": "--deflection-margin",
                    "workers": "--workers", "resume": "--resume", "fresh": "--fresh", "solver": "--solver",
                    "no_progress": "--no-progress", "face_coupling": "--face-coupling"}


def run(args: argparse.Namespace) -> int:
    if args.check:
        ignored = [opt for dest, opt in _COMPUTE_OPTIONS.items() if given(args, dest)]
        if ignored:
            raise ModelError(f"{', '.join(ignored)}: no effect with --check (it reads the existing table and computes "
                             "nothing); run `hacgear statics MODEL` without --check to compute a table with them")
        return _check(args)
    if args.ignore_model_hash:
        raise ModelError("--ignore-model-hash applies to --check only (a computed table always belongs to its model)")
    for name in ("positions", "loads", "deflections", "max_torque_factor"):
        check_option(f"--{name.replace('_', '-')}", getattr(args, name), f"statics.{name}")
    if args.workers is not None and args.workers < 1:
        raise ModelError(f"--workers [-] = {args.workers} is out of range; allowed: integer >= 1")
    if args.deflection_margin is not None and not (math.isfinite(args.deflection_margin)
                                                   and args.deflection_margin >= 0):
        raise ModelError(f"--deflection-margin [-] = {args.deflection_margin!r} is out of range; allowed: finite >= 0")
    if args.out is not None:
        check_out_path(args.out, "--out", suffixes=(".h5", ".hdf5"))
    if args.face_coupling is not None and args.solver == "analytic":
        raise ModelError("--face-coupling applies to the finite-element solver (--solver fe) only")
    rep = compute_statics(
        args.model, args.out, positions=args.positions, loads=args.loads, deflections=args.deflections,
        max_torque_factor=args.max_torque_factor,
        deflection_margin=DEFAULT_DEFLECTION_MARGIN if args.deflection_margin is None else args.deflection_margin,
        solver=args.solver or "fe", workers=args.workers, resume=not args.fresh, progress=not args.no_progress,
        log=lambda msg: print(f"hacgear statics: {msg}", file=sys.stderr, flush=True),
        face_coupling=args.face_coupling,
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
