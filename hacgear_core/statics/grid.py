"""Grids of static contact analyses → ``tables.h5``, in parallel over mesh positions, resumable.

The static contact solver (:mod:`hacgear_core.statics.contact`) answers one question at a time: *at mesh
position p, with mesh force F (load control) or mesh deflection x (deflection control), what is the
loaded state?*  This module asks it many times, in parallel over mesh positions, and writes the answers
incrementally into an HDF5 file laid out by :mod:`hacgear_core.tables`:

phase 1 (load control)
    at every position: the no-load mesh deflection (NLMD) and the static mesh deflection for every load
    of the load grid (0 … ``max_torque_factor`` × nominal mesh force);
deflection grid
    one regular grid for all positions, chosen from the phase-1 results (:func:`deflection_grid`);
phase 2 (deflection control)
    at every position and every grid deflection above the NLMD: mesh force (the force-deflection
    function, FDF), tooth loads, contact roll angles, half-widths, peak pressure, gauge strains
    (the strain-deflection functions) and hub reactions.  Below the NLMD everything is zero (NaN roll
    angle): the teeth do not touch.

Each position's results are written into the (pre-allocated) HDF5 file as soon as they arrive, flushed,
and only then flagged done; a run killed at any moment and started again (``resume=True``, the default)
skips every position already flagged and recomputes nothing else; ``resume=False`` discards the partial
file and says so.  The file is built under ``<out>.partial`` and renamed to ``<out>`` when complete, so
``<out>`` only ever holds a complete table.  The worker processes of the default pool end by themselves when
the run is killed (:func:`hacgear_core.workers.process_pool`).

Solvers
-------
Any object following :class:`MeshStaticSolver` works; workers build their own through a *picklable*
zero-argument factory (:class:`ModelSolverFactory` for model files; any picklable callable in tests),
so any :class:`concurrent.futures.Executor` can run the grid: a process pool (default), a thread pool,
or a Dask cluster via ``distributed.Client.get_executor()``.

``solver="analytic"`` uses :class:`~hacgear_core.statics.reference.AnalyticPairSolver`, an analytical
reference spring model (not the finite-element solver) that tests this machinery against closed forms.
"""
from __future__ import annotations

import concurrent.futures as cf
from concurrent.futures.process import BrokenProcessPool
import hashlib
import math
import os
import pickle
import re
import threading
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from hacgear_core import tables as tb
from hacgear_core.errors import ModelError, SolverError, TableError
from hacgear_core.h5files import check_writable_kind
from hacgear_core.kinds import kind_of, load_model
from hacgear_core.model.provenance import model_values_json, model_values_sha256
from hacgear_core.statics.coast import CoastSideSolver, coast_mapping, make_coast_solver
from hacgear_core.statics.contact import ContactOptions, default_contact_options, prebuild_compliances, spur_twist_axis
from hacgear_core.statics.contract import MeshInfo, MeshStaticSolver, SolverFactory, StaticSolution, describe_solver
from hacgear_core.statics.helical import make_solver
from hacgear_core.statics.reference import AnalyticPairSolver
from hacgear_core.workers import process_pool

__all__ = [
    "SIDES",
    "region_key",
    "region_mesh",
    "ModelSolverFactory",
    "StaticsReport",
    "DEFAULT_DEFLECTION_MARGIN",
    "deflection_grid",
    "load_grid",
    "twist_grid",
    "nominal_mesh_forces",
    "run_statics",
    "compute_statics",
]

#: fraction of the static deflection range added above the largest static deflection (resonance margin)
DEFAULT_DEFLECTION_MARGIN = 0.5

#: the two sides of every mesh: the loaded ("drive") flanks and the opposite ("coast") flanks
SIDES = ("drive", "coast")


def region_key(mesh: str, side: str = "drive") -> str:
    """Key of one side of a mesh in a statics run and below ``/meshes`` in ``tables.h5``: ``<mesh>`` (drive),
    ``<mesh>/coast`` (coast)."""
    if side not in SIDES:
        raise ModelError(f"side = {side!r}; allowed: drive | coast")
    return mesh if side == "drive" else f"{mesh}/coast"


def region_mesh(key: str) -> tuple[str, str]:
    """``(mesh, side)`` of a region key (:func:`region_key`)."""
    mesh, _, side = key.partition("/")
    return mesh, (side or "drive")


@dataclass(frozen=True)
class ModelSolverFactory:
    """Picklable factory: reads the model file in the worker, checks that the values the tables depend on
    (:func:`~hacgear_core.model.provenance.model_values_sha256`) are those the run started from, and builds
    the solver of one side of ``mesh_name`` (``solver`` = ``"fe"``: :func:`~hacgear_core.statics.helical.make_solver`
    (spur or helical) / :func:`~hacgear_core.statics.coast.make_coast_solver`; ``"analytic"``:
    :meth:`AnalyticPairSolver.from_model`, the coast side wrapped in :class:`CoastSideSolver`).  ``face_coupling``
    (``"fe"`` only): None, the solvers' defaults (spur ``rigid``, helical ``elastic``); or ``rigid`` | ``slices`` |
    ``elastic`` for every mesh (:class:`~hacgear_core.statics.contact.ContactOptions`)."""

    model_path: str
    mesh_name: str
    model_values_sha256: str
    solver: str = "fe"
    side: str = "drive"
    face_coupling: str | None = None

    def __call__(self) -> MeshStaticSolver:
        model = load_model(self.model_path)
        now = model_values_sha256(model)
        if self.model_values_sha256 and now != self.model_values_sha256:
            raise TableError(f"{self.model_path} changed while `hacgear statics` was running (model values "
                             f"sha256 {now[:12]}… != {self.model_values_sha256[:12]}…); start again")
        if self.side not in SIDES:
            raise ModelError(f"side = {self.side!r}; allowed: drive | coast")
        if self.solver == "analytic":
            if self.side == "coast":
                return CoastSideSolver(AnalyticPairSolver.from_model(model, self.mesh_name, side="coast"),
                                       coast_mapping(model, self.mesh_name))
            return AnalyticPairSolver.from_model(model, self.mesh_name)
        if self.solver != "fe":
            raise SolverError(f"unknown solver {self.solver!r}; allowed: fe | analytic")
        options = None
        if self.face_coupling is not None:
            options = default_contact_options(model, self.mesh_name, face_coupling=self.face_coupling)
        if self.side == "coast":
            return make_coast_solver(model, self.mesh_name, options=options)
        return make_solver(model, self.mesh_name, options=options)


# ---------------------------------------------------------------------------------------------
# Grids
# ---------------------------------------------------------------------------------------------
def nominal_mesh_forces(model: Any, base_radii: Mapping[str, tuple[float, float]],
                        torque_Nm: float | None = None) -> dict[str, float]:
    """Nominal mesh force of every mesh [N] under ``torque_Nm`` [N m] on ``model.operating.torque_gear``
    (default: the operating torque): the torque flow per contact as the model's kind gives it
    (:meth:`hacgear_core.kinds.base.Kind.nominal_mesh_forces`).  ``base_radii[mesh]`` are the loaded-flank base
    radii ``(r_b of gear_a, r_b of gear_b)`` [m].
    """
    if torque_Nm is not None and float(torque_Nm) != model.operating.torque_Nm:
        model = replace(model, operating=replace(model.operating, torque_Nm=float(torque_Nm)))
    return kind_of(model).nominal_mesh_forces(model, base_radii)


def load_grid(max_force_N: float, n_loads: int) -> np.ndarray:
    """Regular load grid ``linspace(0, max_force_N, n_loads)`` [N] (load 0 → the NLMD)."""
    if not (math.isfinite(max_force_N) and max_force_N > 0):
        raise ModelError(f"maximum mesh force [N] = {max_force_N!r}; allowed: finite > 0")
    if n_loads < 2:
        raise ModelError(f"loads [-] = {n_loads}; allowed: integer >= 2")
    return np.linspace(0.0, float(max_force_N), int(n_loads))


def deflection_grid(no_load_deflection_m: np.ndarray, static_deflection_m: np.ndarray, n_deflections: int,
                    margin: float = DEFAULT_DEFLECTION_MARGIN, contact_deflection_m: float = 0.0) -> np.ndarray:
    """The regular FDF deflection grid [m] (rule of ``tables.h5``).

    With ``x_b = min(x_k, min NLMD)`` (``x_k = contact_deflection_m``, the deflection at which ideal flanks
    touch: 0 on the drive side, the normal backlash on the coast side) and ``x_s = max static deflection``
    (at the largest load, over all positions)::

        dx = (x_s − x_b)·(1 + margin) / (Nd − 2),   x_j = x_b − dx + j·dx,  j = 0 … Nd−1

    i.e. the first column lies one step below every NLMD (force identically zero there, so the
    extrapolation below the grid is zero as well) and the last one ``margin`` × the static range above
    the largest static deflection, room for dynamic deflections near resonance.
    """
    nl = np.asarray(no_load_deflection_m, float)
    sd = np.asarray(static_deflection_m, float)
    if n_deflections < 4:
        raise ModelError(f"deflections [-] = {n_deflections}; allowed: integer >= 4")
    if not (margin >= 0 and math.isfinite(margin)):
        raise ModelError(f"deflection_margin [-] = {margin!r}; allowed: finite >= 0")
    if not (np.all(np.isfinite(nl)) and np.all(np.isfinite(sd))):
        raise SolverError("no-load or static mesh deflections contain NaN/inf: cannot build the deflection grid")
    if not math.isfinite(contact_deflection_m):
        raise ModelError(f"contact_deflection_m [m] = {contact_deflection_m!r}; allowed: finite")
    xb = min(float(contact_deflection_m), float(nl.min()))
    xs = float(sd.max())
    if not xs > xb:
        raise SolverError(f"largest static mesh deflection {xs:g} m does not exceed the smallest NLMD {xb:g} m")
    dx = (xs - xb) * (1.0 + margin) / (n_deflections - 2)
    return xb - dx + dx * np.arange(n_deflections, dtype=float)


def twist_grid(max_twist_rad: float, n_twists: int) -> np.ndarray:
    """Regular mesh-twist grid ``linspace(-max, max, n)`` [rad] (n odd, so 0 is a grid point; n = 1: [0])."""
    if not (isinstance(n_twists, (int, np.integer)) and n_twists >= 1 and n_twists % 2 == 1):
        raise ModelError(f"twist_points [-] = {n_twists!r}; allowed: odd integer >= 1 (0 must be a grid point)")
    if not (math.isfinite(max_twist_rad) and 0 < max_twist_rad <= 0.01):
        raise ModelError(f"max_twist [rad] = {max_twist_rad!r}; allowed: (0, 0.01]")
    return np.linspace(-max_twist_rad, max_twist_rad, n_twists) if n_twists > 1 else np.zeros(1)


# ---------------------------------------------------------------------------------------------
# Worker side
# ---------------------------------------------------------------------------------------------
_LOCAL = threading.local()


def _solver_for(factory: SolverFactory) -> MeshStaticSolver:
    """The worker's solver for ``factory`` (built once per worker process/thread, then reused)."""
    cache = getattr(_LOCAL, "solvers", None)
    if cache is None:
        cache = _LOCAL.solvers = {}
    key = pickle.dumps(factory)
    if key not in cache:
        if len(cache) >= 8:
            cache.clear()
        cache[key] = factory()
    return cache[key]


def _describe_task(factory: SolverFactory) -> MeshInfo:
    return describe_solver(_solver_for(factory))


def _check(sol: StaticSolution, what: str, nw: int) -> None:
    if not sol.success:
        raise SolverError(f"static solve failed at {what}: {sol.message}")
    if np.shape(sol.tooth_load_N) != (nw,):
        raise SolverError(f"solver returned tooth_load_N of shape {np.shape(sol.tooth_load_N)} at {what}; "
                          f"expected ({nw},) (one per tooth offset)")
    if not (math.isfinite(sol.mesh_force_N) and math.isfinite(sol.mesh_deflection_m)):
        raise SolverError(f"solver returned non-finite force/deflection at {what}")


def _position_task(factory: SolverFactory, phase: int, mesh: str, ip: int, position: float,
                   values: np.ndarray, twists: np.ndarray | None = None) -> tuple[str, int, int, dict[str, Any]]:
    """One position of phase 1 (``values`` = loads [N]) or phase 2 (``values`` = deflections [m]); with
    ``twists`` [rad] (helical meshes) every twist of the grid, the zero-twist results also filling the
    datasets without twist axis."""
    solver = _solver_for(factory)
    info = describe_solver(solver)
    nw = len(info.tooth_offsets)
    values = np.asarray(values, float)
    batch = getattr(solver, "solve_position", None)
    tw = np.zeros(1) if twists is None else np.asarray(twists, float)
    kw = (lambda g: {}) if twists is None else (lambda g: {"twist_rad": float(g)})  # noqa: E731
    iz = int(np.argmin(np.abs(tw)))
    if phase == 1:
        nl_t = np.zeros(tw.size)
        sd_t = np.zeros((values.size, tw.size))
        for it, g in enumerate(tw):
            nlmd = float(solver.no_load_deflection(position, **kw(g)))
            if not math.isfinite(nlmd):
                raise SolverError(f"mesh '{mesh}': no-load deflection is not finite at position {position}")
            todo = values[values > 0]
            sols = (batch(position, todo, np.empty(0), **kw(g))[0] if batch
                    else [solver.solve_load(position, F, **kw(g)) for F in todo])
            out = np.full(values.shape, nlmd)
            sit = iter(sols)
            for j, F in enumerate(values):
                if F > 0:
                    sol = next(sit)
                    _check(sol, f"mesh '{mesh}' position {position:.6g} (index {ip}) load {F:.6g} N twist {g:.3g} rad",
                           nw)
                    out[j] = sol.mesh_deflection_m
            nl_t[it], sd_t[:, it] = nlmd, out
        res = {"no_load_deflection_m": nl_t[iz], "static_deflection_m": sd_t[:, iz].copy()}
        if twists is not None:
            res.update(no_load_deflection_twist_m=nl_t, static_deflection_twist_m=sd_t)
        return mesh, phase, ip, res
    nd, nt = values.size, tw.size
    ns = len(info.slice_z_m)
    T: dict[str, Any] = {
        "force_N": np.zeros((nd, nt)), "tooth_load_N": np.zeros((nd, nt, nw)),
        "contact_roll_deg": np.full((nd, nt, nw), np.nan), "half_width_m": np.zeros((nd, nt, nw)),
        "peak_pressure_Pa": np.zeros((nd, nt)), "flank_pressure_Pa": np.zeros((nd, nt)),
        "edge_pressure_Pa": np.zeros((nd, nt)), "strain": {g: np.zeros((nd, nt, nw)) for g in info.gauge_names},
        "hub_reaction": {g: np.zeros((nd, nt, 3)) for g in info.gear_names},
        "generalized_fdf": np.zeros((nd, nt, 2)), "generalized_force": np.zeros((nd, nt, 12)),
        "slice_load_N": np.zeros((nd, nt, ns)), "slice_pressure_Pa": np.zeros((nd, nt, ns)),
    }
    n_solves = 0
    for it, g in enumerate(tw):
        nlmd = float(solver.no_load_deflection(position, **kw(g)))
        if not math.isfinite(nlmd):
            raise SolverError(f"mesh '{mesh}': no-load deflection is not finite at position {position}")
        idx = np.nonzero(values > nlmd)[0]
        sols = (batch(position, np.empty(0), values[idx], **kw(g))[1] if batch
                else [solver.solve_deflection(position, values[j], **kw(g)) for j in idx])
        n_solves += int(idx.size)
        for j, sol in zip(idx, sols):
            _check(sol, f"mesh '{mesh}' position {position:.6g} (index {ip}) deflection {values[j]:.6g} m "
                        f"twist {g:.3g} rad", nw)
            T["force_N"][j, it] = sol.mesh_force_N
            T["tooth_load_N"][j, it] = sol.tooth_load_N
            T["contact_roll_deg"][j, it] = sol.contact_roll_deg
            T["half_width_m"][j, it] = sol.half_width_m
            for k in ("peak_pressure_Pa", "flank_pressure_Pa", "edge_pressure_Pa"):
                pp = getattr(sol, k)
                if pp is None:   # a solver that does not tell flank and edge contacts apart
                    T[k][j, it] = math.nan
                    continue
                pp = np.asarray(pp, float)
                T[k][j, it] = float(np.nanmax(pp)) if pp.size and np.any(np.isfinite(pp)) else 0.0
            for gg in info.gauge_names:
                if gg not in sol.strain:
                    raise SolverError(f"solver returned no strain for gauge {gg!r} at mesh '{mesh}' position {position}")
                T["strain"][gg][j, it] = sol.strain[gg]
            for gg in info.gear_names:
                if gg in sol.hub_reaction:
                    T["hub_reaction"][gg][j, it] = sol.hub_reaction[gg]
            if twists is not None:
                T["generalized_fdf"][j, it] = (sol.mesh_force_N, sol.twist_moment_Nm)
                T["generalized_force"][j, it] = sol.generalized_force
                T["slice_load_N"][j, it] = sol.slice_load_N
                T["slice_pressure_Pa"][j, it] = sol.slice_pressure_Pa
    res: dict[str, Any] = {k: T[k][:, iz] for k in ("force_N", "tooth_load_N", "contact_roll_deg", "half_width_m",
                                                    "peak_pressure_Pa", "flank_pressure_Pa", "edge_pressure_Pa")}
    res["strain"] = {g: a[:, iz] for g, a in T["strain"].items()}
    res["hub_reaction"] = {g: a[:, iz] for g, a in T["hub_reaction"].items()}
    if twists is not None:
        res.update(generalized_fdf=T["generalized_fdf"], generalized_force=T["generalized_force"],
                   tooth_load_twist_N=T["tooth_load_N"], peak_pressure_twist_Pa=T["peak_pressure_Pa"],
                   flank_pressure_twist_Pa=T["flank_pressure_Pa"], edge_pressure_twist_Pa=T["edge_pressure_Pa"],
                   slice_load_N=T["slice_load_N"], slice_pressure_Pa=T["slice_pressure_Pa"],
                   strain_twist=T["strain"])
    res["n_solves"] = n_solves
    return mesh, phase, ip, res


# ---------------------------------------------------------------------------------------------
# Driver
# ---------------------------------------------------------------------------------------------
@dataclass
class StaticsReport:
    """Outcome of :func:`run_statics` (counts are position tasks: one phase at one position)."""

    success: bool
    message: str
    path: Path
    tasks_total: int
    tasks_computed: int
    tasks_resumed: int
    wall_s: float
    meshes: dict[str, dict[str, float]] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {
            "success": self.success, "message": self.message, "path": str(self.path),
            "tasks_total": self.tasks_total, "tasks_computed": self.tasks_computed,
            "tasks_resumed": self.tasks_resumed, "wall_s": self.wall_s, "meshes": self.meshes,
        }


def _partial_path(out: Path) -> Path:
    return out.with_name(out.name + ".partial")


def run_statics(
    factories: Mapping[str, SolverFactory],
    out: str | Path,
    *,
    n_positions: int,
    n_deflections: int,
    loads_N: Mapping[str, Sequence[float]] | Callable[[dict[str, MeshInfo]], Mapping[str, Sequence[float]]],
    deflection_margin: float = DEFAULT_DEFLECTION_MARGIN,
    model_sha256: str = "",
    model_file: str = "",
    model_values: str = "",
    executor: cf.Executor | None = None,
    workers: int | None = None,
    resume: bool = True,
    progress: bool = True,
    twists_rad: np.ndarray | None = None,
    log: Callable[[str], None] | None = None,
) -> StaticsReport:
    """Run the static grid of every mesh and write ``out`` (HDF5, format of :mod:`hacgear_core.tables`).

    Parameters
    ----------
    factories : region key (:func:`region_key`: ``<mesh>`` for the drive side, ``<mesh>/coast`` for the coast
        side, whose solver has ``side = "coast"``) → picklable zero-argument solver factory; a coast region needs
        its drive region.
    out : final path; the run writes ``<out>.partial`` and renames it when complete.
    n_positions, n_deflections : grid sizes (positions ``k / n_positions`` of one mesh cycle).
    loads_N : region key → load grid [N] (ascending, first value >= 0), or a function of the
        :class:`MeshInfo` of all regions returning that mapping.
    deflection_margin : see :func:`deflection_grid`.
    model_sha256, model_file : provenance written to the root attributes (hash of the model file's bytes,
        its name; informative).
    model_values : canonical JSON of the model values the tables depend on
        (:func:`~hacgear_core.model.provenance.model_values_json`); its SHA-256 is the table's
        ``model_values_sha256``, checked when the table is read with its model and when a run is resumed.
    executor : any :class:`concurrent.futures.Executor`; None → a process pool with ``workers`` processes
        (``spawn``; :func:`hacgear_core.workers.process_pool`, workers end when this process is killed), or
        in-process when ``workers == 1``.
    resume : True (default): continue ``<out>.partial`` if it exists and matches these settings (positions
        flagged done are not recomputed; a partial file of other settings is refused, never replaced
        silently) and do nothing when ``<out>`` is already complete for them.  False: discard both and start
        afresh (``--fresh``); the report's message says what was discarded.
    progress : show a tqdm progress bar (stderr).
    twists_rad : mesh-twist grid [rad] (odd length, contains 0) for the meshes whose solver resolves the face
        (helical: :class:`~hacgear_core.statics.helical.HelicalMeshContactSolver`); None: no twist axis.
    log : called with a line at each stage that runs before the progress bar (building the solvers, checking an
        existing table), so a long step never runs silently; None: nothing.
    """
    t0 = time.perf_counter()
    say = log or (lambda _msg: None)
    out = Path(out)
    partial = _partial_path(out)
    check_writable_kind(out, "tables", "a tables file")
    if n_positions < 2:
        raise ModelError(f"positions [-] = {n_positions}; allowed: integer >= 2")
    for k in factories:
        mesh, side = region_mesh(k)
        if side not in SIDES or "/" in mesh or (side == "coast" and mesh not in factories):
            raise ModelError(f"region key {k!r}: allowed '<mesh>' or '<mesh>/coast' (with '<mesh>' present)")
    # each mesh's drive region, then its coast region (the HDF5 group of the coast side lies inside the drive's)
    names = [r for k in factories if region_mesh(k)[1] == "drive"
             for r in (k, region_key(k, "coast")) if r in factories]
    if not names:
        raise ModelError("no mesh to analyse")
    own_executor = None
    if executor is None and (workers or os.cpu_count() or 1) > 1:
        own_executor = executor = process_pool(workers or os.cpu_count(), start_method="spawn")
    try:
        # --- solver descriptions (in a worker, so the solver built there is reused) ----------
        say(f"building the contact solvers of {len(names)} mesh side(s) ({', '.join(names)}): finite-element "
            "meshes and factorisations, cached on disk after their first build"
            + (f"; then {out} is compared with what they would write" if out.exists() and resume else ""))
        if executor is None:
            infos = {m: _describe_task(factories[m]) for m in names}
        else:
            futs = {m: executor.submit(_describe_task, factories[m]) for m in names}
            infos = {m: f.result() for m, f in futs.items()}
        for m, info in infos.items():
            if (info.mesh_name, info.side) != region_mesh(m):
                raise SolverError(f"factory for region '{m}' built a solver of mesh '{info.mesh_name}', "
                                  f"side {info.side!r}")
        loads = loads_N(infos) if callable(loads_N) else loads_N
        loads = {m: np.asarray(loads[m], float) for m in names}
        for m, ld in loads.items():
            if ld.ndim != 1 or ld.size < 2 or ld[0] < 0 or np.any(np.diff(ld) <= 0) or not np.all(np.isfinite(ld)):
                raise ModelError(f"load grid of mesh '{m}' [N] must be >= 2 ascending finite values >= 0, got {ld}")
        positions = np.arange(n_positions, dtype=float) / n_positions
        layouts = {
            m: tb.MeshLayout(
                name=m, gear_names=infos[m].gear_names, teeth=infos[m].teeth,
                base_radius_m=infos[m].base_radius_m, tooth_offsets=np.asarray(infos[m].tooth_offsets),
                gauge_names=infos[m].gauge_names, position=positions, load_N=loads[m],
                n_deflections=int(n_deflections), solver_description=infos[m].description,
                **({} if twists_rad is None or infos[m].mesh_frame is None else dict(
                    twist_rad=np.asarray(twists_rad, float), slice_z_m=np.asarray(infos[m].slice_z_m, float),
                    mesh_frame=infos[m].mesh_frame)),
                side=infos[m].side, flanks=infos[m].flanks, contact_deflection_m=infos[m].contact_deflection_m,
                coast=infos[m].coast,
            )
            for m in names
        }
        root_attrs = {
            "model_sha256": model_sha256, "model_file": model_file,
            "model_values": model_values,
            "model_values_sha256": hashlib.sha256(model_values.encode()).hexdigest() if model_values else "",
            "deflection_margin": float(deflection_margin),
        }
        for existing in ((partial,) if partial.exists() else (out,) if out.exists() else ()):
            if resume:
                _check_face_coupling(existing, layouts)
        if resume and not partial.exists() and out.exists():
            done = tb.completed_table_matches(out, layouts, root_attrs)
            if done:
                total = 2 * n_positions * len(names)
                return StaticsReport(True, f"{out} is already complete for these settings; nothing to do "
                                           "(--fresh recomputes it)", out, total, 0, total,
                                     time.perf_counter() - t0, done)
            diff = tb.layout_difference(out, layouts, root_attrs) or "unfinished positions"
            raise TableError(f"{out} is a finished table made with other settings (differs: {diff}); it is kept. "
                             "Write the new grid to another file with --out, or replace this one with "
                             "--fresh")
        say(f"solvers ready after {time.perf_counter() - t0:.1f} s; solving {2 * n_positions * len(names)} position "
            "tasks")
        f, resumed_note = tb.open_statics_file(partial, layouts, root_attrs, resume=resume)
        try:
            return _run_phases(f, tb, factories, layouts, positions, executor, deflection_margin, progress,
                               out, partial, t0, resumed_note)
        finally:
            if f.id.valid:
                f.close()
    except BaseException as exc:
        if own_executor is not None:
            own_executor.shutdown(wait=False, cancel_futures=True)
            own_executor = None
        if isinstance(exc, BrokenProcessPool):
            raise SolverError(
                f"a statics worker process died ({exc}); likely out of memory or killed. When calling "
                "run_statics/compute_statics from a script, guard it with `if __name__ == '__main__':` (worker "
                f"processes are spawned). Finished positions are kept in {partial}: continue with resume=True "
                "(`hacgear statics` continues it by default)."
            ) from None
        raise
    finally:
        if own_executor is not None:
            own_executor.shutdown(wait=True)


_COUPLING = re.compile(r"slices \((rigid|slices|elastic)\)")


def _check_face_coupling(path: Path, layouts: Mapping[str, "tb.MeshLayout"]) -> None:
    """Refuse to resume or accept the tables file ``path`` whose meshes were solved with another far-field face
    coupling than ``layouts`` (read from the solver descriptions, "N slices (coupling)")."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            stored = {m: str(f["meshes"][m].attrs.get("solver", "")) for m in layouts if m in f.get("meshes", {})}
    except (OSError, KeyError):
        return      # unreadable / other layout: the layout checks that follow say what differs
    for m, desc in stored.items():
        a, b = _COUPLING.search(desc), _COUPLING.search(layouts[m].solver_description)
        if a and b and a.group(1) != b.group(1):
            raise TableError(f"{path} holds mesh '{m}' solved with face coupling {a.group(1)!r}, this run asks for "
                             f"{b.group(1)!r}; it is kept. Write to another file with --out, or replace it with "
                             "--fresh")


def _run_phases(f, tb, factories, layouts, positions, executor, margin, progress, out, partial, t0, note):
    names = list(layouts)
    n_pos = len(positions)
    total = 2 * n_pos * len(names)
    done0 = sum(int(np.count_nonzero(f[f"meshes/{m}/{d}"][()])) for m in names
                for d in ("done_loads", "done_deflections"))
    computed = 0
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=total, initial=done0, desc="hacgear statics", unit="pos", dynamic_ncols=True)

    twists = {m: layouts[m].twist_rad for m in names}

    def run(phase: int, jobs: list[tuple[str, int, np.ndarray]]) -> None:
        nonlocal computed
        if not jobs:
            return
        if executor is None:
            results = (_position_task(factories[m], phase, m, ip, positions[ip], v, twists[m]) for m, ip, v in jobs)
            for r in results:
                tb.write_position(f, *r)
                computed += 1
                if bar is not None:
                    bar.update(1)
            return
        futs = [executor.submit(_position_task, factories[m], phase, m, ip, positions[ip], v, twists[m])
                for m, ip, v in jobs]
        try:
            for fut in cf.as_completed(futs):
                tb.write_position(f, *fut.result())
                computed += 1
                if bar is not None:
                    bar.update(1)
        except BaseException:
            for fu in futs:
                fu.cancel()
            raise

    try:
        jobs1 = [(m, ip, layouts[m].load_N) for m in names
                 for ip in np.nonzero(f[f"meshes/{m}/done_loads"][()] == 0)[0]]
        run(1, jobs1)
        grids = {}
        for m in names:
            g = f[f"meshes/{m}"]
            tw = "no_load_deflection_twist_m" in g
            grid = deflection_grid(g["no_load_deflection_twist_m" if tw else "no_load_deflection_m"][()],
                                   g["static_deflection_twist_m" if tw else "static_deflection_m"][()],
                                   layouts[m].n_deflections, margin, layouts[m].contact_deflection_m)
            tb.write_deflection_grid(f, m, grid)
            grids[m] = grid
        jobs2 = [(m, ip, grids[m]) for m in names
                 for ip in np.nonzero(f[f"meshes/{m}/done_deflections"][()] == 0)[0]]
        run(2, jobs2)
    finally:
        if bar is not None:
            bar.close()
    summary = {}
    for m in names:
        g = f[f"meshes/{m}"]
        summary[m] = tb.consistency_summary(g)
    tb.seal_file(f)
    f.close()
    os.replace(partial, out)
    n_mesh = len({region_mesh(m)[0] for m in names})
    n_coast = sum(region_mesh(m)[1] == "coast" for m in names)
    msg = f"wrote {out} ({n_mesh} mesh(es), {n_coast} with the coast side, {n_pos} positions)"
    if note:
        msg += f"; {note}"
    return StaticsReport(True, msg, out, total, computed, total - computed, time.perf_counter() - t0, summary)


def compute_statics(
    model: str | Path,
    out: str | Path | None = None,
    *,
    positions: int | None = None,
    loads: int | None = None,
    deflections: int | None = None,
    max_torque_factor: float | None = None,
    deflection_margin: float = DEFAULT_DEFLECTION_MARGIN,
    solver: str = "fe",
    workers: int | None = None,
    executor: cf.Executor | None = None,
    resume: bool = True,
    progress: bool = True,
    sides: Sequence[str] = SIDES,
    log: Callable[[str], None] | None = None,
    face_coupling: str | None = None,
) -> StaticsReport:
    """``hacgear statics``: the static grids of both sides of every mesh of a model file → ``tables.h5``.

    Grid sizes default to the model's ``[statics]`` section; the load grid of each side of each mesh is
    ``linspace(0, max_torque_factor × nominal mesh force, loads)`` (:func:`nominal_mesh_forces` with that side's
    base radii or lever arms: the coast side carries the operating torque reversed).  ``solver``: ``"fe"``
    (``hacgear_core.statics.helical.make_solver``: spur, or helical with the model's ``[statics] twist_points``
    mesh twists from ``-max_twist_mrad`` to ``+max_twist_mrad``; the coast side
    ``hacgear_core.statics.coast.make_coast_solver``) or ``"analytic"`` (:class:`AnalyticPairSolver`, reference
    spring model).  ``sides``: ``("drive", "coast")`` (default; helical meshes: both sides over the same twist
    grid, each in its own mesh frame) or ``("drive",)`` (a one-sided table, e.g. for quick studies).  ``log``: as
    in :func:`run_statics`.  ``face_coupling``: None (the solvers' defaults: spur ``rigid``, helical ``elastic``) or
    ``rigid`` | ``slices`` | ``elastic`` (``hacgear stiffness --face-coupling``'s choices), ``solver="fe"`` only.

    Before the worker processes start, every gear's finite-element model is built and factorised once, in this
    process, one gear at a time, and the compliances of all its loaded flanks are written to the on-disk cache
    (:func:`~hacgear_core.statics.contact.prebuild_compliances`): the workers read them and build no FE model, so
    the peak memory is that of the largest single gear, whatever the worker count.
    """
    mdl = load_model(model)
    if solver not in ("fe", "analytic"):
        raise SolverError(f"unknown solver {solver!r}; allowed: fe | analytic")
    st = mdl.statics
    n_pos = positions or st.positions
    n_loads = loads or st.loads
    n_def = deflections or st.deflections
    factor = max_torque_factor or st.max_torque_factor
    if factor < 3.0:
        raise ModelError(f"max_torque_factor [-] = {factor:g}; allowed: >= 3 (tables span 0 … >= 3 x nominal torque)")
    out_path = Path(out) if out is not None else mdl.tables_path
    values = model_values_json(mdl)
    # helical meshes, and a spur pair asked for twists, tabulate the mesh twist (spur_twist_axis)
    helical = (any(g.is_helical for g in mdl.gears) or spur_twist_axis(mdl)) and solver == "fe"
    twists = twist_grid(st.max_twist_rad, st.twist_points) if helical and st.twist_points > 1 else (
        np.zeros(1) if helical else None)
    if spur_twist_axis(mdl) and face_coupling == "rigid":
        raise ModelError(f"face_coupling = 'rigid' with [statics] twist_points = {st.twist_points} on a spur pair: a "
                         "mesh twist loads the face linearly, which a face rigid across its width cannot spread "
                         "(allowed: slices | elastic, the default)")
    sides = tuple(sides)
    if "drive" not in sides or not set(sides) <= set(SIDES):
        raise ModelError(f"sides = {sides!r}; allowed: ('drive',) or ('drive', 'coast')")
    if face_coupling is not None:
        if solver != "fe":
            raise ModelError(f"face_coupling = {face_coupling!r} applies to solver 'fe' only (got solver {solver!r})")
        ContactOptions(face_coupling=face_coupling)     # validates the choice here, not in a worker
    factories = {region_key(m.name, side): ModelSolverFactory(str(mdl.path), m.name, model_values_sha256(mdl),
                                                              solver, side, face_coupling)
                 for m in mdl.meshes for side in sides}
    if solver == "fe":
        # one FE build per gear, before the workers: they read the cached compliances (docstring)
        prebuild_compliances(mdl, sides=sides, face_coupling=face_coupling, log=log)

    def loads_for(infos: dict[str, MeshInfo]) -> dict[str, np.ndarray]:
        # the mesh force is conjugate to the mesh deflection: torque = force x lever arm (r_b cos(beta_b))
        out = {}
        for side in sides:
            keys = {region_mesh(k)[0]: k for k in infos if region_mesh(k)[1] == side}
            fn = nominal_mesh_forces(mdl, {m: infos[k].lever_arm_m or infos[k].base_radius_m for m, k in keys.items()})
            out.update({k: load_grid(factor * fn[m], n_loads) for m, k in keys.items()})
        return out

    return run_statics(
        factories, out_path, n_positions=n_pos, n_deflections=n_def, loads_N=loads_for,
        deflection_margin=deflection_margin, model_sha256=mdl.sha256, model_file=str(mdl.path.name),
        model_values=values,
        executor=executor, workers=workers, resume=resume, progress=progress, twists_rad=twists, log=log,
    )
