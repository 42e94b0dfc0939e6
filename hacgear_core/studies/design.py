"""Design studies: every variant of a study file → its own tables → static and dynamic results in one HDF5 file.

For each variant (one combination of the study's variable values, :mod:`.study_file`):

1. **model**: the base model file with the variables set, written as ``<tables dir>/<values hash>/model.toml``;
   its values are validated (the model reader's ranges), its gears built
   (:func:`~hacgear_core.geometry.gear.gear_geometry`: impossible teeth are refused);
2. **tables**: :func:`~hacgear_core.statics.compute_statics` with the study's grid, on the study's executor (a local
   process pool, or a Dask cluster's executor), into ``tables_<grid hash>.h5`` beside that model file.  The
   folder is named after the model values' SHA-256 (:mod:`~hacgear_core.model.provenance`), the file after the
   grid, the solver and the load range, so a table with the same provenance is reused by any study that shares the
   tables folder, and a half-finished one is continued;
3. **static results** over the study's torques, from the tables: static transmission error peak-to-peak and mean
   local-slope mesh stiffness (FDF inversion, :func:`~hacgear_core.tables.fdf.static_stiffness`), peak root strain
   over the gauges (:func:`~hacgear_core.response.static_strain_max`) and peak contact pressure over the cycle;
4. **dynamic results** (optional): up/down speed sweeps at one or several torques
   (:func:`~hacgear_core.dynamics.sweep.run_sweeps`; the branches at several torques share the variant's system, so
   they run as lanes of the batched kernel where a task gets four or more), per speed the force and strain dynamic
   factors, the peak root strain (strain dynamic factor × static peak strain at that torque), contact loss and RMS
   mesh deflection, and the confirmed jumps.

Results file (``format = "hacgear-study"``; units in each dataset's ``unit`` attribute; ``nv`` variants, ``nt``
static torques, ``nd`` sweep torques, ``nf`` speeds)::

    /                         attrs: format, study_name, study_json, study_sha256, hacgear_version
    /variables/<i>/values     (nv,) value of variable i per variant   attrs: key, unit
    /variant_label (nv,)  status (nv,) 0 pending | 1 done | 2 failed   error (nv,)  mesh (nv,)
    /tables_file (nv,)        the variant's tables, relative to the results file's folder
    /static/torque_Nm (nt,)   /static/<metric> (nv, nt) for STATIC_METRICS
    /dynamic/mesh_frequency_Hz (nf,)  /dynamic/torque_Nm (nv, nd)  /dynamic/<up|down>/<metric> (nv, nd, nf),
                              speeds ascending
    /dynamic/jumps_json (nv, nd) confirmed jumps of the variant's mesh at each torque (JSON list)

(Files written before several sweep torques existed hold ``(nv,)`` and ``(nv, nf)``; :func:`read_study` reads them
as ``nd = 1``.)

A variant's rows are written and the file closed before its status is set to done, so a study killed at any time
and run again recomputes only the variants not done (their tables and sweep rows resume where they stopped).  A
variant that fails (values out of range, impossible geometry, a base model that is no model for the study, torques
beyond its tables' load range) is marked failed with a message naming its variables and values; the other
variants still run, and a later run tries the failed ones again.
"""
from __future__ import annotations

import concurrent.futures as cf
import hashlib
import json
import math
import os
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import h5py
import numpy as np

from hacgear_core import __version__
from hacgear_core.kinds import build_system
from hacgear_core.dynamics.steady import SteadyStateOptions
from hacgear_core.dynamics.sweep import SweepSpec, run_sweeps
from hacgear_core.errors import HacgearError, ModelError, TableError
from hacgear_core.geometry.gear import gear_geometry
from hacgear_core.h5files import STUDY_FORMAT, check_writable_kind, file_kind, holds_nothing
from hacgear_core.outpaths import written_whole
from hacgear_core.model import resolve_model_path
from hacgear_core.kinds import load_model, parse_model
from hacgear_core.model.provenance import model_values_sha256
from hacgear_core.response import static_strain_max
from hacgear_core.statics import compute_statics
from hacgear_core.model.toml_writer import dumps as dump_toml
from hacgear_core.studies.study_file import MODEL_KEY, StudySpec, apply_key
from hacgear_core.tables import load_system_tables
from hacgear_core.tables.fdf import static_stiffness

__all__ = ["STATIC_METRICS", "DYNAMIC_METRICS", "VariantOutcome", "StudyReport", "StudyResults", "run_study",
           "read_study", "best_variants", "variant_model_text"]

#: static results per variant and torque: name -> (unit, description)
STATIC_METRICS = {
    "mesh_force_N": ("N", "static mesh force at the torque"),
    "ste_peak_to_peak_m": ("m", "peak-to-peak static transmission error (static mesh deflection over a mesh cycle)"),
    "mean_mesh_stiffness_N_per_m": ("N/m", "mean local-slope mesh stiffness dF/dx over a mesh cycle"),
    "max_root_strain": ("-", "largest static root strain over the gauges, teeth and mesh positions"),
    "max_contact_pressure_Pa": ("Pa", "largest static contact pressure over the mesh cycle"),
}

#: dynamic results per variant, branch and speed: name -> (unit, description)
DYNAMIC_METRICS = {
    "dynamic_factor_force": ("-", "largest drive-flank mesh force over the static force"),
    "dynamic_factor_strain": ("-", "largest dynamic root strain over the static peak root strain"),
    "peak_root_strain": ("-", "dynamic_factor_strain x the static peak root strain at the sweep torque"),
    "contact_loss_fraction": ("-", "fraction of the period with the loaded flanks out of contact"),
    "rms_deflection_m": ("m", "RMS of the oscillating part of the mesh deflection"),
    "converged": ("-", "1: steady state detected, 0: cycle cap reached"),
}

_STATUS = {"pending": 0, "done": 1, "failed": 2}
_STR = h5py.string_dtype()


@dataclass
class VariantOutcome:
    """What happened to one variant in this run: ``status`` computed | reused (done in an earlier run) | failed."""

    index: int
    label: str
    status: str
    error: str = ""
    tables_file: str = ""
    tables_reused: bool = False
    seconds: float = 0.0


@dataclass
class StudyReport:
    """Outcome of :func:`run_study`."""

    path: Path
    name: str
    variants: list
    wall_s: float
    message: str = ""

    @property
    def failed(self) -> list:
        return [v for v in self.variants if v.status == "failed"]

    def as_dict(self) -> dict:
        count = {s: sum(v.status == s for v in self.variants) for s in ("computed", "reused", "failed")}
        return {"study": self.name, "results_file": str(self.path), "wall_s": self.wall_s, "message": self.message,
                **{f"variants_{k}": n for k, n in count.items()},
                "variants": [vars(v) for v in self.variants]}


# ------------------------------------------------------------------------------------------------ variants
def _variant_raw(spec: StudySpec, values: tuple) -> tuple[dict, Path]:
    base = spec.base_model
    for var, val in zip(spec.variables, values):
        if var.key == MODEL_KEY:
            base = val
    path = resolve_model_path(base)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ModelError(f"base model {str(path)!r} is not a model file (TOML): {exc}") from None
    for var, val in zip(spec.variables, values):
        if var.key != MODEL_KEY:
            apply_key(raw, var.key, val)
    if spec.statics:
        st = raw.setdefault("statics", {})
        if not isinstance(st, dict):
            raise ModelError(f"base model {path}: [statics] is not a table")
        st.update(spec.statics)
    return raw, path


def variant_model_text(spec: StudySpec, values: tuple) -> tuple[str, Path]:
    """The model file text of one variant (the base model with the variables and the study's statics grid set)
    and the base model's path."""
    raw, path = _variant_raw(spec, values)
    header = (f"variant of {path} in study {spec.name!r}: {spec.label(values)}\n"
              "written by `hacgear study`; the tables beside it were computed from it")
    return dump_toml(raw, header), path


def _grid_digest(model: Any, solver: str) -> str:
    st = model.statics
    d = {"positions": st.positions, "loads": st.loads, "deflections": st.deflections,
         "max_torque_factor": repr(st.max_torque_factor), "solver": solver,
         "torque_Nm": repr(model.operating.torque_Nm), "torque_gear": model.operating.torque_gear,
         "planet_count": getattr(model.planetary, "planet_count", None)}
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:12]


def _prepare(spec: StudySpec, values: tuple, tables_dir: Path) -> tuple[Path, Path, Any]:
    text, model = _checked_variant(spec, values)
    folder = tables_dir / model_values_sha256(model)[:16]
    folder.mkdir(parents=True, exist_ok=True)
    mpath = folder / "model.toml"
    if not mpath.exists() or mpath.read_text(encoding="utf-8") != text:
        mpath.write_text(text, encoding="utf-8")
    return mpath, folder / f"tables_{_grid_digest(model, spec.solver)}.h5", model


def _checked_variant(spec: StudySpec, values: tuple) -> tuple[str, Any]:
    """A variant's model file text and model, with every check that needs no computation (its values in range,
    gears that can be made, the study's mesh present, the study's torques within its tables' load range)."""
    text, base = variant_model_text(spec, values)
    model = parse_model(text, file=f"variant of {base}")
    if model.lumped:
        raise ModelError(f"base model {base} is a lumped model (constant mesh stiffnesses): it has no tooth "
                         "geometry or tables to study")
    for g in model.gears:
        gear_geometry(g)
    meshes = [m.name for m in model.meshes]
    if spec.mesh is not None and spec.mesh not in meshes:
        raise ModelError(f"[study] mesh = {spec.mesh!r} is not a mesh of the variant's model {base} ({meshes})")
    # the tables span 0 ... max_torque_factor x the operating torque (mesh forces are linear in the torque)
    top = model.statics.max_torque_factor * abs(model.operating.torque_Nm)
    asked = [("static torque", t) for t in spec.static_torques_Nm]
    if spec.dynamic and (spec.dynamic["torque_Nm"] is not None or spec.dynamic.get("torques_Nm")):
        asked += [("[dynamic] torque", t) for t in spec.dynamic_torques_Nm(model.operating.torque_Nm)]
    for what, t in asked:
        if t > top * (1 + 1e-12):
            raise TableError(f"{what} {t:g} N*m lies beyond the load range of the variant's tables, 0 … {top:g} N*m "
                             f"(max_torque_factor {model.statics.max_torque_factor:g} x the operating torque "
                             f"{model.operating.torque_Nm:g} N*m on {model.operating.torque_gear}); raise [statics] "
                             "max_torque_factor or lower the torques")
    return text, model


def _study_wide_problem(spec: StudySpec, pending: list[int]) -> str:
    """The one problem every variant of ``pending`` has before any computation ('' when none is shared by all):
    then the study file itself is wrong, and is refused once instead of failing every variant the same way."""
    found = set()
    for i in pending:
        try:
            _checked_variant(spec, spec.variants[i])
        except HacgearError as exc:
            found.add(str(exc))
        else:
            return ""
    return found.pop() if len(found) == 1 else ""


def _mesh_index(spec: StudySpec, system: Any) -> int:
    names = list(system.mesh_names)
    name = spec.mesh or names[0]
    if name not in names:
        raise ModelError(f"[study] mesh = {name!r} is not a mesh of the variant's model ({names})")
    return names.index(name)


def _static_rows(spec: StudySpec, system: Any, k: int) -> dict[str, np.ndarray]:
    table = system.meshes[k].table
    rows = {m: np.full(len(spec.static_torques_Nm), np.nan) for m in STATIC_METRICS}
    for i, torque in enumerate(spec.static_torques_Nm):
        force = float(system.nominal_forces_N(torque)[k])
        st = static_stiffness(table, force)
        strains = static_strain_max(table, force)
        rows["mesh_force_N"][i] = force
        rows["ste_peak_to_peak_m"][i] = st.ste_peak_to_peak_m
        rows["mean_mesh_stiffness_N_per_m"][i] = st.mean_local_slope_N_per_m
        rows["max_root_strain"][i] = max(strains.values()) if strains else np.nan
        rows["max_contact_pressure_Pa"][i] = float(np.max(table.pressure(st.position, st.deflection_m)))
    return rows


def _dynamic_rows(spec: StudySpec, system: Any, k: int, sweeps_file: Path, executor, progress: bool, label: str):
    """The sweeps of one variant at each of the study's sweep torques: ``(torques (nd,), {branch: {metric: (nd, nf)}},
    [confirmed jumps of the studied mesh at each torque])``."""
    dyn = spec.dynamic
    torques = spec.dynamic_torques_Nm(system.torque_Nm)
    opts = SteadyStateOptions(max_cycles=dyn["max_cycles"])
    fms = np.asarray(spec.frequencies_Hz())
    sweeps = [SweepSpec(system, tuple(fms), dyn["direction"], torque_Nm=t, options=opts,
                        label=f"{label}, {t:g} N*m") for t in torques]
    results = run_sweeps(sweeps, out=sweeps_file, executor=executor, progress=progress)
    table = system.meshes[k].table
    mesh = system.mesh_names[k]
    names = ("dynamic_factor_force", "dynamic_factor_strain", "contact_loss_fraction", "rms_deflection_m")
    rows: dict[str, dict[str, np.ndarray]] = {}
    jumps = []
    for d, (sw, res) in enumerate(zip(sweeps, results)):
        strains = static_strain_max(table, float(sw.system.nominal_forces_N(sw.system.torque_Nm)[k]))
        smax = max(strains.values()) if strains else np.nan
        for b, br in res.branches.items():
            order = np.argsort(br.mesh_frequency_Hz)
            if not np.allclose(br.mesh_frequency_Hz[order], fms):
                raise ModelError(f"sweep branch {b}: frequencies differ from the study's")
            r = rows.setdefault(b, {m: np.full((len(torques), fms.size), np.nan)
                                    for m in names + ("peak_root_strain", "converged")})
            for m in names:
                r[m][d] = np.asarray(br.metrics[m])[order, k]
            r["peak_root_strain"][d] = r["dynamic_factor_strain"][d] * smax
            r["converged"][d] = np.asarray(br.converged, float)[order]
        jumps.append([{"kind": j.kind, "branch": j.branch, "frequency_Hz": j.frequency_Hz,
                       "interval_Hz": list(j.interval_Hz), "rms_before_m": j.rms_before_m,
                       "rms_after_m": j.rms_after_m} for j in res.jumps if j.confirmed and j.mesh == mesh])
    return np.asarray(torques, float), rows, jumps


# ------------------------------------------------------------------------------------------------ results file
def _create(path: Path, spec: StudySpec) -> None:
    nv, nt, nf = len(spec.variants), len(spec.static_torques_Nm), len(spec.frequencies_Hz())
    nd = spec.n_dynamic_torques
    tmp = path.with_name(path.name + ".creating")
    with h5py.File(tmp, "w") as f:
        f.attrs.update(format=STUDY_FORMAT, study_name=spec.name, study_sha256=spec.sha256(),
                       study_json=json.dumps(spec.canonical(), sort_keys=True), hacgear_version=__version__)
        for i, var in enumerate(spec.variables):
            g = f.create_group(f"variables/{i}")
            g.attrs.update(key=var.key, unit=var.unit)
            col = [v[i] for v in spec.variants]
            g.create_dataset("values", data=np.array(col, dtype=float) if var.numeric
                             else np.array(col, dtype=object), dtype=float if var.numeric else _STR)
        f.create_dataset("variant_label", data=np.array([spec.label(v) for v in spec.variants], dtype=object),
                         dtype=_STR)
        f.create_dataset("status", data=np.zeros(nv, dtype="i1"))
        f["status"].attrs["meaning"] = "0 pending, 1 done, 2 failed"
        for name in ("error", "tables_file", "mesh"):
            f.create_dataset(name, data=np.array([""] * nv, dtype=object), dtype=_STR)
        s = f.create_group("static")
        s.create_dataset("torque_Nm", data=np.asarray(spec.static_torques_Nm, float)).attrs["unit"] = "N*m"
        for m, (unit, desc) in STATIC_METRICS.items():
            d = s.create_dataset(m, data=np.full((nv, nt), np.nan))
            d.attrs.update(unit=unit, description=desc)
        if spec.dynamic:
            dg = f.create_group("dynamic")
            dg.create_dataset("mesh_frequency_Hz", data=np.asarray(spec.frequencies_Hz())).attrs["unit"] = "Hz"
            dg.create_dataset("torque_Nm", data=np.full((nv, nd), np.nan)).attrs["unit"] = "N*m"
            dg.create_dataset("jumps_json", data=np.full((nv, nd), "[]", dtype=object), dtype=_STR)
            for b in ("up", "down") if spec.dynamic["direction"] == "both" else (spec.dynamic["direction"],):
                for m, (unit, desc) in DYNAMIC_METRICS.items():
                    d = dg.create_dataset(f"{b}/{m}", data=np.full((nv, nd, nf), np.nan))
                    d.attrs.update(unit=unit, description=desc)
    tmp.replace(path)


def _open_results(path: Path, spec: StudySpec, fresh: bool) -> str:
    check_writable_kind(path, "study", "study results")
    if path.exists() and fresh:
        path.unlink()
        note = f"discarded the results in {path} (--fresh)"
    else:
        note = ""
    if path.exists():
        if holds_nothing(path):
            path.unlink()
        else:
            try:
                with h5py.File(path, "r") as f:
                    same = f.attrs.get("study_sha256") == spec.sha256()
            except OSError:
                same = False
            if not same:
                raise TableError(f"{path} holds the results of another study (or other settings of this one); it is "
                                 "kept. Give another --out, or replace it with --fresh")
            return note
    _create(path, spec)
    return note


def _write_variant(path: Path, i: int, status: str, *, error: str = "", tables: str = "", mesh: str = "",
                   static: dict | None = None, dynamic: tuple | None = None) -> None:
    """Store one variant's results in one rename of the results file (a kill leaves it as it was)."""
    with written_whole(path, start_from_existing=True) as tmp, h5py.File(tmp, "a") as f:
        if static:
            for m, row in static.items():
                f[f"static/{m}"][i] = row
        if dynamic:
            torques, rows, jumps = dynamic
            f["dynamic/torque_Nm"][i] = torques
            f["dynamic/jumps_json"][i] = np.array([json.dumps(j) for j in jumps], dtype=object)
            for b, r in rows.items():
                for m, row in r.items():
                    f[f"dynamic/{b}/{m}"][i] = row
        f["error"][i] = error
        f["tables_file"][i] = tables
        f["mesh"][i] = mesh
        f.flush()
        f["status"][i] = _STATUS[status]  # commit marker: after the variant's rows
        f.flush()


# ------------------------------------------------------------------------------------------------ runner
def run_study(spec: StudySpec, out: str | Path, *, tables_dir: str | Path | None = None,
              executor: cf.Executor | None = None, workers: int | None = None, fresh: bool = False,
              progress: bool = True, log: Callable[[str], None] | None = None) -> StudyReport:
    """Run every variant of ``spec`` not yet done in ``out`` (module docstring) and return what happened.

    Parameters
    ----------
    spec : the study (:func:`~hacgear_core.studies.study_file.load_study`).
    out : results file (HDF5, written incrementally; a rerun continues it).
    tables_dir : folder of the variants' model files and tables (default ``<out stem>_tables`` beside ``out``);
        a table of the same provenance found there is reused.
    executor : any :class:`concurrent.futures.Executor` for the statics positions and the sweep branches (a Dask
        cluster: ``distributed.Client(address).get_executor()``); None: a local process pool of ``workers``
        processes (default: CPU count; 1: in this process).
    fresh : discard ``out`` and recompute every variant's results (tables and sweep rows of the same provenance
        are still reused).
    progress : progress bars on stderr.
    log : called with one line as each variant starts a stage (tables, static rows, sweeps) and as it ends, so a
        run without progress bars is never silent for a whole variant; None: nothing.
    """
    from hacgear_core.workers import process_pool

    say = log or (lambda _msg: None)

    t0 = time.perf_counter()
    out = Path(out)
    shared = _study_wide_problem(spec, list(range(len(spec.variants))))   # before any file is written
    if shared:
        raise ModelError(f"study {spec.name!r}: every variant fails before any computation with the same problem, "
                         f"so the study file is to be fixed: {shared}")
    tables_dir = Path(tables_dir) if tables_dir is not None else out.with_name(out.stem + "_tables")
    tables_dir.mkdir(parents=True, exist_ok=True)
    note = _open_results(out, spec, fresh)
    with h5py.File(out, "r") as f:
        status = f["status"][()].copy()
    own = None
    if executor is None and (workers is None or workers > 1):
        own = executor = process_pool(workers, start_method="spawn")
    bar = None
    outcomes = []
    try:
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(spec.variants), initial=int(np.sum(status == 1)), desc=f"hacgear study {spec.name}",
                       unit="variant", file=sys.stderr, dynamic_ncols=True)
        for i, values in enumerate(spec.variants):
            label = spec.label(values)
            if status[i] == _STATUS["done"]:
                with h5py.File(out, "r") as f:
                    tf = f["tables_file"][i].decode() if isinstance(f["tables_file"][i], bytes) else f["tables_file"][i]
                outcomes.append(VariantOutcome(i, label, "reused", tables_file=str(out.resolve().parent / tf)))
                continue
            t1 = time.perf_counter()
            tables = ""
            reused = False
            tag = f"variant {i + 1}/{len(spec.variants)} ({label})"
            try:
                mpath, tpath, _ = _prepare(spec, values, tables_dir.resolve())
                tables = str(tpath)
                reused = tpath.exists()
                say(f"{tag}: tables {'(reused) ' if reused else ''}{tpath}")
                compute_statics(mpath, tpath, solver=spec.solver, executor=executor,
                                workers=1 if executor is None else None, progress=progress,
                                log=None if log is None else (lambda m, tag=tag: say(f"{tag}: statics: {m}")))
                system = build_system(load_model(mpath), load_system_tables(mpath, tpath))
                k = _mesh_index(spec, system)
                say(f"{tag}: static rows over {len(spec.static_torques_Nm)} torques")
                static = _static_rows(spec, system, k)
                dynamic = None
                if spec.dynamic:
                    say(f"{tag}: sweeps over {len(spec.frequencies_Hz())} speeds "
                        f"({spec.dynamic['direction']})")
                    dynamic = _dynamic_rows(spec, system, k, tpath.with_name(tpath.stem + "_sweeps.h5"),
                                            executor, progress, f"variant {i + 1}/{len(spec.variants)}")
                _write_variant(out, i, "done", tables=os.path.relpath(tpath, out.resolve().parent),
                               mesh=system.mesh_names[k], static=static, dynamic=dynamic)
                outcomes.append(VariantOutcome(i, label, "computed", tables_file=tables, tables_reused=reused,
                                               seconds=time.perf_counter() - t1))
                say(f"{tag}: done in {time.perf_counter() - t1:.1f} s")
            except HacgearError as exc:
                msg = f"variant {i + 1} ({label}): {exc}"
                _write_variant(out, i, "failed", error=msg,
                               tables=os.path.relpath(tables, out.resolve().parent) if tables else "")
                outcomes.append(VariantOutcome(i, label, "failed", error=msg, tables_file=tables,
                                               seconds=time.perf_counter() - t1))
                say(f"{tag}: FAILED: {exc}")
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        if own is not None:
            own.shutdown(wait=True)
    return StudyReport(out, spec.name, outcomes, time.perf_counter() - t0, note)


# ------------------------------------------------------------------------------------------------ reading
@dataclass
class StudyResults:
    """A study results file in memory (see the module docstring for the arrays' shapes and units)."""

    name: str
    spec: dict
    variables: list
    labels: list
    status: np.ndarray
    errors: list
    torque_Nm: np.ndarray
    static: dict
    frequency_Hz: np.ndarray | None = None
    #: (nv, nd) the sweep torques of each variant [N*m]
    dynamic_torque_Nm: np.ndarray | None = None
    #: {branch: {metric: (nv, nd, nf)}}
    dynamic: dict = field(default_factory=dict)
    #: jumps[variant][torque]: the confirmed jumps (dicts)
    jumps: list = field(default_factory=list)

    @property
    def done(self) -> np.ndarray:
        return self.status == _STATUS["done"]


def _s(v: Any) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


def read_study(path: str | Path) -> StudyResults:
    """Read a study results file."""
    if file_kind(path) != "study":
        raise TableError(f"{path} is not a hacgear study results file (root attribute format = '{STUDY_FORMAT}')")
    with h5py.File(path, "r") as f:
        variables = []
        for i in sorted(f["variables"], key=int):
            g = f[f"variables/{i}"]
            vals = g["values"][()]
            variables.append({"key": _s(g.attrs["key"]), "unit": _s(g.attrs["unit"]),
                              "values": [float(v) for v in vals] if np.issubdtype(vals.dtype, np.floating) else [_s(v) for v in vals]})
        res = StudyResults(
            name=_s(f.attrs["study_name"]), spec=json.loads(_s(f.attrs["study_json"])), variables=variables,
            labels=[_s(v) for v in f["variant_label"][()]], status=f["status"][()].astype(int),
            errors=[_s(v) for v in f["error"][()]], torque_Nm=f["static/torque_Nm"][()],
            static={m: f[f"static/{m}"][()] for m in STATIC_METRICS})
        if "dynamic" in f:
            dg = f["dynamic"]
            res.frequency_Hz = dg["mesh_frequency_Hz"][()]
            one = dg["torque_Nm"].ndim == 1  # written before several sweep torques existed: nd = 1
            res.dynamic_torque_Nm = dg["torque_Nm"][()][:, None] if one else dg["torque_Nm"][()]
            res.dynamic = {b: {m: dg[f"{b}/{m}"][()][:, None, :] if one else dg[f"{b}/{m}"][()]
                               for m in DYNAMIC_METRICS} for b in ("up", "down") if b in dg}
            js = dg["jumps_json"][()]
            res.jumps = [[json.loads(_s(v)) for v in (row if not one else [row])] for row in js]
    return res


def best_variants(res: StudyResults) -> dict[str, dict]:
    """The best finished variant per criterion (smallest value): the static metrics averaged over the study's load
    spectrum (its torques and time shares, linear interpolation between the static torques; without a spectrum the
    static torques with equal shares), and the largest force dynamic factor and peak root strain over the sweep
    (both branches, every sweep torque).  {criterion: {index, label, value, unit, values (per variant, None where not
    done)}}."""
    spec = res.spec
    ts, ws = spec.get("spectrum_torques_Nm") or [], spec.get("spectrum_weights") or []
    if not ts:
        ts, ws = list(res.torque_Nm), [1.0 / len(res.torque_Nm)] * len(res.torque_Nm)
    crit: dict[str, tuple[np.ndarray, str]] = {}
    for m in ("ste_peak_to_peak_m", "max_root_strain", "max_contact_pressure_Pa"):
        vals = res.static[m]
        crit[f"spectrum_mean_{m}"] = (np.array([sum(w * np.interp(t, res.torque_Nm, row) for t, w in zip(ts, ws))
                                                for row in vals]), STATIC_METRICS[m][0])
    if res.dynamic:
        for m in ("dynamic_factor_force", "peak_root_strain"):
            stack = np.stack([br[m] for br in res.dynamic.values()])  # (branches, nv, nd, nf)
            with np.errstate(all="ignore"):
                crit[f"sweep_max_{m}"] = (np.nanmax(np.where(np.isfinite(stack), stack, -np.inf), axis=(0, 2, 3)),
                                          DYNAMIC_METRICS[m][0])
    out = {}
    ok = res.done
    for name, (v, unit) in crit.items():
        v = np.where(ok & np.isfinite(v), v, np.nan)
        if not np.any(np.isfinite(v)):
            continue
        i = int(np.nanargmin(v))
        out[name] = {"index": i, "label": res.labels[i], "value": float(v[i]), "unit": unit,
                     "values": [None if not math.isfinite(x) else float(x) for x in v]}
    return out
