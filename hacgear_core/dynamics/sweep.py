"""Speed sweeps of the steady-state response, jump detection, resumable HDF5 output, parallel runs (any system).

A sweep visits mesh frequencies in order; each speed starts from the previous speed's steady state
(at mesh position 0), so a softening region shows both branches.  ``direction``:

``up``    ascending frequencies, starting from static equilibrium at the lowest;
``down``  descending, starting from static equilibrium at the highest;
``both``  the two branches above (independent, so they can run in parallel).

Results file (HDF5, one row per finished speed, flushed after each row)::

    /sweeps/<run_id>/                 attrs: spec (JSON), label, system, mesh_names (JSON), synthetic_table
    /sweeps/<run_id>/<branch>/        branch = "up" | "down"
        mesh_frequency_Hz (k,)  state (k, 2n)  converged (k,)  period_cycles (k,)  cycles_run (k,)
        max_multiplier (k,)  (largest elastic Floquet multiplier modulus; NaN unless ``options.stability``)
        <metric> (k, m)  for every name in METRIC_NAMES, one column per mesh

``run_id`` hashes everything the numbers depend on (the system's fingerprint: matrices, tables, force law,
torque, damping; frequency grid, direction, steady-state options).  Each branch is written to its own part file
``<out>.parts/<run_id>_<branch>.h5`` while it runs (so branches in different processes never share a
file) and copied into ``out`` when complete.  A killed sweep re-run with the same arguments reads
the finished rows and continues from the last stored state: rows already written are not
recomputed, and the continuation is bit-identical because the next speed starts from the stored
float64 state.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import warnings
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from hacgear_core.cpu import vector_units
from hacgear_core.dynamics.batch import Lanes, batch_supported, lanes_compatible, run_lanes
from hacgear_core.dynamics.steady import METRIC_NAMES, SteadyStateOptions, drive, steady_run
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError
from hacgear_core.h5files import SWEEP_FORMAT, check_writable_kind, holds_nothing
from hacgear_core.outpaths import written_whole
from hacgear_core.model.schema import RANGES
from hacgear_core.workers import executor_slots

__all__ = [
    "SweepSpec",
    "BranchResult",
    "SweepResult",
    "Jump",
    "parse_fm",
    "run_sweep",
    "run_sweeps",
    "detect_jumps",
    "missing_branches",
    "read_sweep",
    "sweep_mesh_names",
    "plan_lanes",
    "LANE_WIDTHS",
    "BATCH_MIN_LANES",
    "BATCH_MIN_VECTOR_DOUBLES",
]

DIRECTIONS = ("up", "down", "both")


def parse_fm(text: str) -> np.ndarray:
    """``START:STOP:N`` [Hz] -> N equally spaced mesh frequencies (CLI helper)."""
    try:
        a, b, n = text.split(":")
        a, b, n = float(a), float(b), int(n)
    except ValueError:
        raise ModelError(f"--fm must be START:STOP:N (Hz, Hz, count), got {text!r}") from None
    r = RANGES["mesh_frequency_Hz"]
    if not (r.contains(a) and r.contains(b)):
        raise ModelError(f"--fm START and STOP [Hz] = {text!r} are out of range; allowed: {r.text} each")
    if n < 1:
        raise ModelError(f"--fm N [-] = {n} in {text!r} is out of range; allowed: integer >= 1")
    if a > b:
        raise ModelError(f"--fm START [Hz] = {a:g} > STOP = {b:g} in {text!r}: give START <= STOP; the order the "
                         "speeds are run in is --direction (down: from STOP to START)")
    if n == 1 and a != b:
        raise ModelError(f"--fm N [-] = 1 in {text!r} gives one speed but START != STOP: give {a:g}:{a:g}:1 for one "
                         "speed, or N >= 2")
    return np.linspace(a, b, n) if n > 1 else np.array([a])


@dataclass(frozen=True)
class SweepSpec:
    """One sweep: system (with its tables and force law), torque, frequencies, direction."""

    system: LumpedSystem
    mesh_frequencies_Hz: tuple
    direction: str = "both"
    torque_Nm: float | None = None
    options: SteadyStateOptions = field(default_factory=SteadyStateOptions)
    label: str = ""

    def __post_init__(self) -> None:
        f = np.asarray(self.mesh_frequencies_Hz, dtype=float)
        if f.ndim != 1 or f.size < 1 or not np.all(np.isfinite(f)) or np.any(f <= 0):
            raise ModelError("mesh_frequencies_Hz [Hz] must be a non-empty list of finite values > 0")
        object.__setattr__(self, "mesh_frequencies_Hz", tuple(float(v) for v in np.sort(f)))
        if self.direction not in DIRECTIONS:
            raise ModelError(f"direction must be one of {DIRECTIONS}, got {self.direction!r}")
        if self.torque_Nm is not None and float(self.torque_Nm) != self.system.torque_Nm:
            object.__setattr__(self, "system", self.system.with_changes(torque_Nm=float(self.torque_Nm)))
        object.__setattr__(self, "torque_Nm", self.system.torque_Nm)

    @property
    def branches(self) -> tuple[str, ...]:
        return ("up", "down") if self.direction == "both" else (self.direction,)

    @property
    def mesh_names(self) -> tuple[str, ...]:
        return self.system.mesh_names

    def frequencies(self, branch: str) -> np.ndarray:
        f = np.asarray(self.mesh_frequencies_Hz)
        return f if branch == "up" else f[::-1]

    def run_id(self) -> str:
        h = hashlib.sha256()
        h.update(self.system.fingerprint().encode())
        h.update(json.dumps(self._describe(), sort_keys=True).encode())
        return h.hexdigest()[:16]

    def _describe(self) -> dict:
        sy = self.system
        return {"system": sy.name, "kind": sy.kind, "dofs": list(sy.dof_names), "meshes": list(sy.mesh_names),
                "torque_Nm": repr(sy.torque_Nm), "modal_damping_ratio": repr(sy.modal_damping_ratio),
                "force_law": sy.force_law_name, "fingerprint": sy.fingerprint(),
                "fm": [repr(v) for v in self.mesh_frequencies_Hz], "direction": self.direction,
                "options": dataclasses.asdict(self.options)}


@dataclass
class BranchResult:
    """One branch of a sweep: ``mesh_frequency_Hz`` (k,) in sweep order, metric arrays, flags."""

    branch: str
    mesh_frequency_Hz: np.ndarray
    metrics: dict
    converged: np.ndarray
    period_cycles: np.ndarray
    cycles_run: np.ndarray
    state: np.ndarray
    recomputed: int = 0
    discarded: int = 0
    #: (k,) largest elastic Floquet multiplier modulus of each speed's orbit (NaN: not checked)
    max_multiplier: np.ndarray | None = None


@dataclass
class Jump:
    """A jump of the RMS mesh deflection of one mesh between two adjacent speeds of a branch."""

    kind: str  # "jump-up" (value rises along the sweep) or "jump-down" (falls)
    branch: str
    frequency_Hz: float  # midpoint of the interval
    interval_Hz: tuple  # (lower, upper) adjacent speeds of the branch [Hz]
    rms_before_m: float
    rms_after_m: float
    confirmed: bool  # both branches exist and differ at the start of the interval (hysteresis)
    mesh: str = ""


@dataclass
class SweepResult:
    spec: SweepSpec
    run_id: str
    branches: dict
    jumps: list

    def to_json(self) -> dict:
        """Per branch: frequencies (of the reference mesh), flags and, per mesh, every metric over the speeds (SI;
        NaN -> None) and, where the meshes run at their own rates, the mesh's own mesh frequency [Hz]."""
        names = self.spec.mesh_names
        out = {"run_id": self.run_id, "system": self.spec.system.name, "torque_Nm": self.spec.system.torque_Nm,
               "force_law": self.spec.system.force_law_name, "direction": self.spec.direction,
               "mesh_names": list(names), "branches": {}, "jumps": [dataclasses.asdict(j) for j in self.jumps]}
        for b, r in self.branches.items():
            d = {"mesh_frequency_Hz": r.mesh_frequency_Hz.tolist(), "converged": r.converged.astype(bool).tolist(),
                 "period_cycles": r.period_cycles.tolist(), "cycles_run": r.cycles_run.tolist(), "meshes": {}}
            if r.max_multiplier is not None and np.any(np.isfinite(r.max_multiplier)):
                d["max_multiplier"] = [None if not math.isfinite(v) else float(v) for v in r.max_multiplier]
            sy = self.spec.system
            for k, mn in enumerate(names):
                d["meshes"][mn] = {m: [None if not math.isfinite(v) else v for v in np.asarray(r.metrics[m])[:, k]]
                                   for m in METRIC_NAMES}
                if not sy.unit_rates:   # meshes at their own rates: each one's own mesh frequency too
                    d["meshes"][mn]["mesh_frequency_Hz"] = (r.mesh_frequency_Hz * sy.rates[k]).tolist()
            out["branches"][b] = d
        return out


# ------------------------------------------------------------------------------ HDF5 rows
def _open_part(path: Path, n2: int, m: int, spec: SweepSpec, branch: str):
    """Open (or create) a branch part file; rows beyond the committed count ``attrs['rows']`` (a write
    interrupted by a kill) are dropped.  An unreadable part file is moved aside."""
    try:
        f = h5py.File(path, "a")
    except OSError:
        bad = path.with_name(path.name + ".unreadable")
        path.replace(bad)
        warnings.warn(f"sweep part file {path} was unreadable (killed while writing?); moved to {bad.name}, "
                      "the branch restarts", RuntimeWarning, stacklevel=2)
        f = h5py.File(path, "a")
    if "mesh_frequency_Hz" not in f:
        f.attrs["branch"] = branch
        f.attrs["spec"] = json.dumps(spec._describe(), sort_keys=True)
        f.attrs["rows"] = 0
        for name in ("mesh_frequency_Hz", "converged", "period_cycles", "cycles_run", "max_multiplier"):
            dt = "f8" if name in ("mesh_frequency_Hz", "max_multiplier") else "i8"
            f.create_dataset(name, shape=(0,), maxshape=(None,), dtype=dt, chunks=(64,))
        for name in METRIC_NAMES:
            f.create_dataset(name, shape=(0, m), maxshape=(None, m), dtype="f8", chunks=(64, m))
        f.create_dataset("state", shape=(0, n2), maxshape=(None, n2), dtype="f8", chunks=(64, n2))
        f.flush()
    elif f.attrs.get("spec") != json.dumps(spec._describe(), sort_keys=True):
        f.close()
        raise ModelError(f"{path} belongs to another sweep (spec differs); remove it to start afresh")
    rows = int(f.attrs.get("rows", 0))
    for name in f.keys():
        if f[name].shape[0] != rows:
            f[name].resize(rows, axis=0)
    return f


def _append_row(f, fm, res) -> None:
    k = int(f.attrs["rows"])
    for name in f.keys():
        f[name].resize(k + 1, axis=0)
    f["mesh_frequency_Hz"][k] = fm
    f["converged"][k] = int(res.converged)
    f["period_cycles"][k] = res.period_cycles
    f["cycles_run"][k] = res.cycles_run
    f["max_multiplier"][k] = res.max_multiplier
    for m in METRIC_NAMES:
        f[m][k] = res.metrics[m]
    f["state"][k] = res.state
    f.flush()
    f.attrs["rows"] = k + 1  # commit marker: written after the row's data
    f.flush()


def _branch_from_group(g, branch: str, recomputed: int = 0) -> BranchResult:
    return BranchResult(
        branch=branch, mesh_frequency_Hz=g["mesh_frequency_Hz"][...], converged=g["converged"][...].astype(bool),
        period_cycles=g["period_cycles"][...], cycles_run=g["cycles_run"][...], state=g["state"][...],
        metrics={m: np.atleast_2d(g[m][...].T).T for m in METRIC_NAMES}, recomputed=recomputed,
        max_multiplier=(g["max_multiplier"][...] if "max_multiplier" in g
                        else np.full(g["mesh_frequency_Hz"].shape[0], np.nan)),
    )


def _run_branch(spec: SweepSpec, branch: str, part: str | None, progress: bool, position: int = 0) -> BranchResult:
    """Compute one branch (in this process, the single-state kernel), appending rows to ``part`` if given."""
    lane = _branch_lane(spec, branch, part, progress, position)
    res = None
    try:
        while True:
            res = drive(spec.system, lane.send(res))
    except StopIteration as stop:
        return stop.value


def _branch_lane(spec: SweepSpec, branch: str, part: str | None, progress: bool, position: int = 0):
    """One branch as a generator (:func:`hacgear_core.dynamics.batch.run_lanes`): yields the
    :func:`~hacgear_core.dynamics.steady.steady_run` of each speed not yet stored, receives its result, appends it
    to ``part`` if given and returns the :class:`BranchResult`."""
    system = spec.system
    fms = spec.frequencies(branch)
    n2 = 2 * system.n
    f = None
    done = 0
    state = None
    if part is not None:
        Path(part).parent.mkdir(parents=True, exist_ok=True)
        f = _open_part(Path(part), n2, system.m, spec, branch)
        done = f["mesh_frequency_Hz"].shape[0]
        if done:
            if not np.array_equal(f["mesh_frequency_Hz"][...], fms[:done]):
                f.close()
                raise ModelError(f"{part}: stored frequencies differ from this sweep's; remove it to start afresh")
            state = f["state"][done - 1].copy()
    bar = None
    try:
        if progress:
            from tqdm import tqdm  # only for progress bars: the FMU runtime imports this module without tqdm

            bar = tqdm(total=len(fms), initial=done, desc=f"{spec.label or 'sweep'} {branch}", unit="speed",
                       position=position, leave=True)
        rows = []
        for i in range(done, len(fms)):
            res = yield steady_run(system, fms[i], state, spec.options)
            state = res.state
            if f is not None:
                _append_row(f, fms[i], res)
            else:
                rows.append((fms[i], res))
            if bar is not None:
                bar.update(1)
                bar.set_postfix(fm=f"{fms[i]:.0f}Hz", rms=f"{np.max(res.metrics['rms_deflection_m']) * 1e6:.2f}um")
        if f is not None:
            return _branch_from_group(f, branch, recomputed=len(fms) - done)
        m = system.m
        return BranchResult(
            branch=branch, mesh_frequency_Hz=np.array([r[0] for r in rows]),
            metrics={k: np.array([r[1].metrics[k] for r in rows]).reshape(-1, m) for k in METRIC_NAMES},
            converged=np.array([r[1].converged for r in rows]), period_cycles=np.array([r[1].period_cycles for r in rows]),
            cycles_run=np.array([r[1].cycles_run for r in rows]), state=np.array([r[1].state for r in rows]),
            recomputed=len(rows), max_multiplier=np.array([r[1].max_multiplier for r in rows], dtype=float),
        )
    finally:
        if bar is not None:
            bar.close()
        if f is not None:
            f.close()


def _task(args):
    spec, branch, part, progress, position = args
    return _run_branch(spec, branch, part, progress, position)


def _copy_into(out: Path, run_id: str, spec: SweepSpec, branch: str, part: Path) -> None:
    """Add a finished branch to the results file ``out`` in one rename (a kill leaves ``out`` as it was)."""
    with written_whole(out, start_from_existing=True) as tmp, h5py.File(tmp, "a") as fo, \
            h5py.File(part, "r") as fp:
        fo.attrs["format"] = SWEEP_FORMAT
        g = fo.require_group("sweeps").require_group(run_id)
        g.attrs["spec"] = json.dumps(spec._describe(), sort_keys=True)
        g.attrs["label"] = spec.label
        g.attrs["system"] = spec.system.name
        g.attrs["mesh_names"] = json.dumps(list(spec.mesh_names))
        g.attrs["synthetic_table"] = bool(any(_is_synthetic(c.table) for c in spec.system.meshes))
        if branch in g:
            del g[branch]
        fp.copy(fp["/"], g, name=branch)


def _is_synthetic(table) -> bool:
    return bool(getattr(table, "synthetic", False)) or "synthetic" in str(getattr(table, "solver", ""))


def _complete_branch(out: Path, run_id: str, spec: SweepSpec, branch: str) -> BranchResult | None:
    if not out.exists():
        return None
    with h5py.File(out, "r") as f:
        path = f"sweeps/{run_id}/{branch}"
        if path in f and f[path]["mesh_frequency_Hz"].shape[0] == len(spec.mesh_frequencies_Hz):
            return _branch_from_group(f[path], branch)
    return None


def _discard(outp: Path, run_id: str, branch: str, part: Path) -> int:
    """Remove the stored rows of one branch (results file and part file); returns how many there were."""
    n = 0
    if part.exists():
        try:
            with h5py.File(part, "r") as f:
                n = int(f.attrs.get("rows", 0))
        except OSError:
            pass
        part.unlink()
    if outp.exists():
        with h5py.File(outp, "r") as f:
            path = f"sweeps/{run_id}/{branch}"
            stored = int(f[path]["mesh_frequency_Hz"].shape[0]) if path in f else None
        if stored is not None:
            n = max(n, stored)
            with written_whole(outp, start_from_existing=True) as tmp, h5py.File(tmp, "a") as f:
                del f[path]
    return n


#: lane counts the batched sweep tasks run with (a task of fewer branches idles the other lanes): each count is
#: one compilation of the batched loop per kind of system (:data:`~hacgear_core.dynamics.batch.BATCH_COMPILE_CPU_S`)
LANE_WIDTHS = (2, 4, 8)
#: fewest branches of one system a sweep runs as lanes of one batched task unless ``batched=True``: at 4 lanes the
#: loop advances a lane in half the time of the single-state kernel (docs/dynamics.md, "Batched kernel"); at 2 the
#: gain within a sweep is ~10 %, less than the loop's compilation is worth to a first run
BATCH_MIN_LANES = 4
#: fewest float64 per vector register (:func:`hacgear_core.cpu.vector_units`) for which ``batched=None`` batches at
#: all: with AVX2 (4) the loop at 8 lanes advances a lane in 0.43 of the single-state time, with AVX-512 (8) in
#: 0.34-0.40; with SSE2 only (2; numba's generic target) it gained nothing (0.67-0.97 x the single-state speed at
#: 2-8 lanes), so there the branches run one by one unless ``batched=True`` (docs/dynamics.md, "Batched kernel")
BATCH_MIN_VECTOR_DOUBLES = 4


def run_sweeps(specs, *, out: str | Path | None = None, executor: Executor | None = None,
               progress: bool = True, fresh: bool = False, batched: bool | None = None,
               workers: int | None = None) -> list[SweepResult]:
    """Run several sweeps (e.g. several torques or models), their branches as independent tasks.

    Parameters
    ----------
    specs : sequence of SweepSpec
    out : path, optional
        HDF5 results file (incremental and resumable, see module docstring); None: in memory only.
    executor : concurrent.futures.Executor, optional
        Runs the tasks (process pools pickle the systems, a Dask client's executor spreads them over its
        cluster); None: serially in this process.
    progress : bool
        tqdm progress bars.
    fresh : bool
        Discard the rows of these sweeps already stored in ``out`` (finished or interrupted) and compute every
        speed again; by default they are reused.  Each :class:`BranchResult` says how many speeds it computed
        (``recomputed``) and how many were discarded (``discarded``).
    batched : bool, optional
        Run branches of systems that share their matrices and tables (the up and down branch of a sweep, sweeps at
        several torques, whose damping may differ) as lanes of the batched kernel
        (:func:`hacgear_core.dynamics.batch.run_lanes`; the same numbers bit for bit).  The branches of each such
        system are split over the executor's slots (``workers``; one without an executor), at most 8 lanes per task.
        None (default): only where a task gets at least :data:`BATCH_MIN_LANES` branches and the CPU's vectors hold
        at least :data:`BATCH_MIN_VECTOR_DOUBLES` float64 (AVX and wider); True: wherever a task gets two or more;
        False: never.  Branches of helical systems always run one by one.
    workers : int, optional
        How many tasks the executor runs at once (default: asked from a process pool or a Dask client,
        :func:`hacgear_core.workers.executor_slots`; an executor that cannot say gets no batched tasks unless
        ``batched=True``).
    """
    specs = list(specs)
    outp = Path(out) if out is not None else None
    if outp is not None:
        check_writable_kind(outp, "sweep", "sweep results")
        if holds_nothing(outp):
            warnings.warn(f"{outp} held no results (an empty HDF5 file, or the stub of a write killed at its start); "
                          "it is replaced", RuntimeWarning, stacklevel=2)
            outp.unlink()
    tasks, keys, results, discarded = [], [], {}, {}
    for si, spec in enumerate(specs):
        rid = spec.run_id()
        for b in spec.branches:
            if outp is not None and fresh:
                discarded[(si, b)] = _discard(outp, rid, b, outp.parent / f"{outp.name}.parts" / f"{rid}_{b}.h5")
            if outp is not None:
                done = _complete_branch(outp, rid, spec, b)
                if done is not None:
                    done.recomputed = 0
                    results[(si, b)] = done
                    continue
            part = None if outp is None else str(outp.parent / f"{outp.name}.parts" / f"{rid}_{b}.h5")
            tasks.append((spec, b, part, progress, len(tasks)))
            keys.append((si, b))
    slots = 1 if executor is None else (workers if workers is not None else executor_slots(executor))
    plan = plan_lanes(tasks, batched, slots)
    units = [([tasks[i] for i in idx], width) for idx, width in plan]
    order = [i for idx, _ in plan for i in idx]
    if executor is None:
        outs = [r for u in units for r in _unit(u)]
    else:
        # compile (or load) each kernel here, once, before the workers start: they then load it from numba's cache
        # instead of each compiling the same one at the same time
        for ts, width in units:
            if width:
                Lanes(ts[0][0].system, width).prepare()
            else:
                ts[0][0].system.prepare_kernel()
        outs = [r for rs in executor.map(_unit, units) for r in rs]
    for i, r in zip(order, outs):
        key, t = keys[i], tasks[i]
        results[key] = r
        if outp is not None:
            spec, b, part = t[0], t[1], Path(t[2])
            _copy_into(outp, spec.run_id(), spec, b, part)
            part.unlink()
            try:
                part.parent.rmdir()
            except OSError:
                pass
    for key, n in discarded.items():
        results[key].discarded = n
    final = []
    for si, spec in enumerate(specs):
        br = {b: results[(si, b)] for b in spec.branches}
        final.append(SweepResult(spec, spec.run_id(), br, detect_jumps(br, mesh_names=spec.mesh_names)))
    return final


def run_sweep(spec: SweepSpec, *, out=None, executor: Executor | None = None, progress: bool = True,
              fresh: bool = False, batched: bool | None = None, workers: int | None = None) -> SweepResult:
    """Run one sweep (see :func:`run_sweeps`)."""
    return run_sweeps([spec], out=out, executor=executor, progress=progress, fresh=fresh, batched=batched,
                      workers=workers)[0]


def plan_lanes(tasks, batched: bool | None, slots: int | None) -> list[tuple[list[int], int]]:
    """How :func:`run_sweeps` runs its branch tasks (``tasks[i][0]`` the branch's :class:`SweepSpec`): a list of
    ``(indices, width)``, each one task: a single branch on the single-state kernel (``width`` 0) or branches of one
    system (at any torques: :func:`~hacgear_core.dynamics.batch.lanes_compatible`) as lanes of the batched loop
    compiled for ``width`` lanes.  The branches of each system are split over
    ``slots`` tasks (the executor's; None: unknown), at most 8 lanes each; ``batched`` as in :func:`run_sweeps`."""
    units: list[tuple[list[int], int]] = []
    groups: list[list[int]] = []
    if batched is None and vector_units().doubles < BATCH_MIN_VECTOR_DOUBLES:
        batched = False   # vectors too narrow for the batched loop to pay (BATCH_MIN_VECTOR_DOUBLES)
    for i, t in enumerate(tasks):
        if batched is False or not batch_supported(t[0].system):
            units.append(([i], 0))
            continue
        for g in groups:
            if lanes_compatible(tasks[g[0]][0].system, t[0].system):
                g.append(i)
                break
        else:
            groups.append([i])
    least = 2 if batched else BATCH_MIN_LANES
    for g in groups:
        if slots is None and not batched:
            per = 1
        else:
            per = min(LANE_WIDTHS[-1], math.ceil(len(g) / (slots or 1)))
        for c in range(0, len(g), per):
            chunk = g[c:c + per]
            if len(chunk) >= least:
                units.append((chunk, next(w for w in LANE_WIDTHS if w >= len(chunk))))
            else:
                units.extend(([i], 0) for i in chunk)
    return units


def _unit(unit) -> list[BranchResult]:
    """One task of :func:`plan_lanes`: its branches' results, in order."""
    ts, width = unit
    if not width:
        return [_task(ts[0])]
    return run_lanes(ts[0][0].system, [_branch_lane(*t) for t in ts], width, systems=[t[0].system for t in ts])


#: smallest value of a sweep metric whose changes can be jumps (below it a response is numerical noise)
JUMP_FLOOR = {"rms_deflection_m": 1e-9}


def detect_jumps(branches: dict, threshold: float = 0.3, metric: str = "rms_deflection_m",
                 mesh_names: tuple[str, ...] | None = None) -> list[Jump]:
    """Jumps of ``metric`` in each branch, for every mesh.

    **Confirmed jumps** (both branches swept over the same speeds) come from the hysteresis itself, so they do not
    depend on the spacing of the speed grid: the *multi-valued region* is a run of adjacent speeds where the up
    and down branches differ by more than ``threshold / 3`` (relative to the larger value).  The up sweep leaves
    such a region at its upper end and the down sweep at its lower end, each jumping onto the other branch between
    the region's last speed and the next speed of its sweep; a jump is reported there when the branch changes
    by more than ``threshold / 3`` over that interval.  ``jump-up`` when the value rises in the branch's sweep
    direction, ``jump-down`` when it falls: a softening system jumps up at the upper end of the region in the
    up sweep and down at its lower end in the down sweep.  A region that reaches the end of the grid has no jump
    there (it continues beyond the grid).

    **Unconfirmed** (``confirmed = False``): every other change by more than ``threshold`` between adjacent speeds
    of a branch — steep flanks of a peak on a coarse grid, short subharmonic windows, or jumps of a single
    branch (``direction`` up or down only), which a fine grid may resolve into a steep flank.

    Changes between values that are both below a floor are no jumps: 1e-3 of the mesh's largest value over the
    branches, and at least :data:`JUMP_FLOOR` of the metric (1 nm of RMS deflection) — a response of 0.000 µm is
    numerical noise, whose relative changes are large.
    """
    def col(r, k):
        return np.atleast_2d(np.asarray(r.metrics[metric]).T).T[:, k]

    tol = threshold / 3.0
    any_b = next(iter(branches.values()))
    nm = np.atleast_2d(np.asarray(any_b.metrics[metric]).T).T.shape[1]
    names = tuple(mesh_names) if mesh_names is not None else tuple(f"mesh{k}" for k in range(nm))
    jumps: list[Jump] = []
    for k in range(nm):
        vals = {b: dict(zip(np.round(np.asarray(r.mesh_frequency_Hz, float), 9), map(float, col(r, k))))
                for b, r in branches.items()}
        finite = [abs(x) for v in vals.values() for x in v.values() if math.isfinite(x)]
        floor = max(1e-3 * max(finite, default=0.0), JUMP_FLOOR.get(metric, 0.0), 1e-30)

        def rel(a, b, floor=floor):
            return abs(a - b) / max(abs(a), abs(b), floor)

        confirmed: set = set()
        if "up" in vals and "down" in vals:
            up, dn = vals["up"], vals["down"]
            f = sorted(set(up) & set(dn))
            ok = [math.isfinite(up[x]) and math.isfinite(dn[x]) for x in f]
            multi = [o and rel(up[x], dn[x]) > tol for x, o in zip(f, ok)]
            i = 0
            while i < len(f):
                if not multi[i]:
                    i += 1
                    continue
                j = i
                while j + 1 < len(f) and multi[j + 1]:
                    j += 1
                # up sweep leaves the region between f[j] and f[j+1]; down sweep between f[i] and f[i-1]
                for b, here, there in (("up", j, j + 1), ("down", i, i - 1)):
                    if not 0 <= there < len(f) or not ok[there]:
                        continue
                    v = vals[b]
                    a0, a1 = v[f[here]], v[f[there]]
                    if rel(a0, a1) <= tol:
                        continue
                    lo, hi = sorted((f[here], f[there]))
                    jumps.append(Jump("jump-up" if a1 > a0 else "jump-down", b, 0.5 * (lo + hi), (lo, hi), a0, a1,
                                      True, names[k]))
                    confirmed.add((b, lo, hi))
                i = j + 1
        for b, r in branches.items():
            fb = np.asarray(r.mesh_frequency_Hz, float)
            v = col(r, k)
            for i in range(len(fb) - 1):
                a0, a1 = float(v[i]), float(v[i + 1])
                if not (math.isfinite(a0) and math.isfinite(a1)) or rel(a0, a1) <= threshold:
                    continue
                lo, hi = sorted((round(float(fb[i]), 9), round(float(fb[i + 1]), 9)))
                if (b, lo, hi) in confirmed:
                    continue
                jumps.append(Jump("jump-up" if a1 > a0 else "jump-down", b, 0.5 * (lo + hi), (lo, hi), a0, a1,
                                  False, names[k]))
    return jumps


def read_sweep(out: str | Path, run_id: str | None = None) -> dict:
    """Read a results file: {run_id: {branch: BranchResult}} (or one run's branches)."""
    res = {}
    with h5py.File(out, "r") as f:
        for rid, g in f.get("sweeps", {}).items():
            res[rid] = {b: _branch_from_group(g[b], b) for b in g.keys()}
    return res if run_id is None else res[run_id]


def missing_branches(out: str | Path) -> dict[str, list[str]]:
    """Branches a run of a results file asked for but does not hold (an interrupted or killed sweep; rerunning the
    same command completes them): {run_id: [branch, ...]} for the runs with any missing."""
    res = {}
    with h5py.File(out, "r") as f:
        for rid, g in f.get("sweeps", {}).items():
            try:
                direction = json.loads(g.attrs.get("spec", "{}")).get("direction", "")
            except ValueError:
                direction = ""
            want = ("up", "down") if direction == "both" else ((direction,) if direction in DIRECTIONS else ())
            lost = [b for b in want if b not in g]
            if lost:
                res[rid] = lost
    return res


def sweep_mesh_names(out: str | Path, run_id: str) -> tuple[str, ...]:
    """Mesh names (the metric columns) of run ``run_id`` in a results file."""
    with h5py.File(out, "r") as f:
        g = f["sweeps"][run_id]
        raw = g.attrs.get("mesh_names")
        if raw is None:
            ncol = np.atleast_2d(g[next(iter(g.keys()))]["rms_deflection_m"][...].T).T.shape[1]
            return tuple(f"mesh{k}" for k in range(ncol))
        return tuple(json.loads(raw))
