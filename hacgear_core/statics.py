"""Grids of static contact analyses → ``tables.h5`` (issue 4).

The static contact solver (``hacgear_core.contact``) answers one question at a time: *at mesh
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
and only then flagged done; a run killed at any moment and restarted with ``resume=True`` skips every
position already flagged and recomputes nothing else.  The file is built under ``<out>.partial`` and
renamed to ``<out>`` when complete, so ``<out>`` only ever holds a complete table.

Solvers
-------
Any object following :class:`MeshStaticSolver` works; workers build their own through a *picklable*
zero-argument factory (:class:`ModelSolverFactory` for model files; any picklable callable in tests),
so any :class:`concurrent.futures.Executor` can run the grid: a process pool (default), a thread pool,
or a Dask cluster via ``distributed.Client.get_executor()``.

:class:`AnalyticPairSolver` is an *analytical reference model* of an external spur pair (tooth pairs as
load-dependent springs with tip-relief gaps and a shared blank compliance).  It is not the
finite-element solver; it exists to test this machinery against closed forms, to document the
protocol by example, and to let the rest of the pipeline run before ``hacgear_core.contact`` exists.
"""
from __future__ import annotations

import concurrent.futures as cf
from concurrent.futures.process import BrokenProcessPool
import math
import os
import pickle
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Protocol, Sequence, runtime_checkable

import numpy as np

from hacgear_core.errors import ModelError, SolverError, TableError

__all__ = [
    "StaticSolution",
    "MeshStaticSolver",
    "SolverFactory",
    "MeshInfo",
    "AnalyticPairSolver",
    "AnalyticFactory",
    "ModelSolverFactory",
    "StaticsReport",
    "DEFAULT_DEFLECTION_MARGIN",
    "deflection_grid",
    "load_grid",
    "nominal_mesh_forces",
    "describe_solver",
    "run_statics",
    "compute_statics",
]

#: fraction of the static deflection range added above the largest static deflection (resonance margin)
DEFAULT_DEFLECTION_MARGIN = 0.5


# ---------------------------------------------------------------------------------------------
# Solver protocol
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class StaticSolution:
    """Result of one static contact solve of one mesh (SI).  ``Nw`` = number of tooth offsets.

    Attributes
    ----------
    success, message, iterations
        solver outcome; ``success=False`` aborts a statics run with the message.
    position : float
        mesh position [mesh cycles].
    mesh_force_N : float
        total mesh force along the line of action [N].
    mesh_deflection_m : float
        mesh deflection ``x = r_b1 θ1 + r_b2 θ2 (+ y1 − y2)`` [m].
    tooth_load_N : (Nw,) array
        load of each tooth pair (offset k of :attr:`MeshStaticSolver.tooth_offsets`) [N].
    contact_roll_deg : (Nw,) array
        roll angle of the contact on gear_b's loaded flank [deg]; NaN where the pair is unloaded.
    half_width_m : (Nw,) array
        Hertzian contact half-width [m] (0 where unloaded).
    peak_pressure_Pa : (Nw,) array
        maximum contact pressure of each pair [Pa] (0 where unloaded).
    strain : dict gauge → (Nw,) array
        strain [-] at gauge ``"<gear>/<gauge>"`` on the tooth belonging to pair offset k.
    stress : dict gauge → (Nw,) array
        surface stress along the profile [Pa] at the same gauges (empty when the solver gives none).
    contact_s_m : (Nw, 2) array or None
        profile coordinate of the contact (arc length from the tip) on gear_a's and gear_b's loaded flank
        [m]; NaN where the pair is unloaded (None when the solver gives none).
    hub_reaction : dict gear → (3,) array
        generalized mesh force on each gear ``[Fx N, Fy N, Mz N·m]``.
    """

    success: bool
    message: str
    iterations: int
    position: float
    mesh_force_N: float
    mesh_deflection_m: float
    tooth_load_N: np.ndarray
    contact_roll_deg: np.ndarray
    half_width_m: np.ndarray
    peak_pressure_Pa: np.ndarray
    strain: dict[str, np.ndarray] = field(default_factory=dict)
    hub_reaction: dict[str, np.ndarray] = field(default_factory=dict)
    stress: dict[str, np.ndarray] = field(default_factory=dict)
    contact_s_m: np.ndarray | None = None


@runtime_checkable
class MeshStaticSolver(Protocol):
    """What the statics grid needs from a static contact solver of one mesh.

    ``position`` is the mesh position in mesh cycles (an integer = pitch-point contact of the reference
    tooth pair, offset 0).  Tooth offset ``k`` is the pair that reaches the pitch point ``k`` mesh
    cycles after the reference pair (``+1`` = next pair to come into mesh).  Results must be periodic:
    the state at ``position + 1`` equals the state at ``position`` with offsets shifted by one.
    ``solve_position`` is optional: a batch of all loads and deflections at one position, reusing the
    per-position set-up; when absent the grid calls ``solve_load``/``solve_deflection`` one by one.
    """

    mesh_name: str
    gear_names: tuple[str, str]
    teeth: tuple[int, int]
    base_radius_m: tuple[float, float]
    tooth_offsets: np.ndarray
    gauge_names: tuple[str, ...]

    def no_load_deflection(self, position: float) -> float: ...

    def solve_load(self, position: float, mesh_force_N: float) -> StaticSolution: ...

    def solve_deflection(self, position: float, mesh_deflection_m: float) -> StaticSolution: ...


#: a picklable callable without arguments returning a :class:`MeshStaticSolver`
SolverFactory = Callable[[], MeshStaticSolver]


@dataclass(frozen=True)
class MeshInfo:
    """Static description of a mesh solver (what the table layout needs)."""

    mesh_name: str
    gear_names: tuple[str, str]
    teeth: tuple[int, int]
    base_radius_m: tuple[float, float]
    tooth_offsets: tuple[int, ...]
    gauge_names: tuple[str, ...]
    description: str


def describe_solver(solver: MeshStaticSolver) -> MeshInfo:
    """Check that ``solver`` follows :class:`MeshStaticSolver` and return its :class:`MeshInfo`."""
    missing = [a for a in ("mesh_name", "gear_names", "teeth", "base_radius_m", "tooth_offsets", "gauge_names",
                           "no_load_deflection", "solve_load", "solve_deflection") if not hasattr(solver, a)]
    if missing:
        raise SolverError(f"{type(solver).__name__} does not follow the MeshStaticSolver protocol: missing {missing}")
    offsets = tuple(int(k) for k in np.asarray(solver.tooth_offsets).ravel())
    if not offsets or len(set(offsets)) != len(offsets) or list(offsets) != sorted(offsets):
        raise SolverError(f"solver.tooth_offsets must be distinct increasing integers, got {offsets}")
    gauges = tuple(str(g) for g in solver.gauge_names)
    for g in gauges:
        if g.count("/") != 1 or not all(g.split("/")):
            raise SolverError(f"gauge name {g!r} must read '<gear>/<gauge>'")
    rb = tuple(float(r) for r in solver.base_radius_m)
    if len(rb) != 2 or not all(r > 0 and math.isfinite(r) for r in rb):
        raise SolverError(f"solver.base_radius_m must be two positive radii [m], got {rb}")
    return MeshInfo(
        mesh_name=str(solver.mesh_name),
        gear_names=tuple(str(g) for g in solver.gear_names),
        teeth=tuple(int(z) for z in solver.teeth),
        base_radius_m=rb,
        tooth_offsets=offsets,
        gauge_names=gauges,
        description=str(getattr(solver, "description", type(solver).__name__)),
    )


# ---------------------------------------------------------------------------------------------
# Analytical reference solver
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class AnalyticPairSolver:
    """Analytical reference model of an external spur pair (NOT the finite-element solver).

    Each tooth pair ``k`` is a spring along the line of action with

    * a position-dependent bending/shear compliance ``1/k_b(s)``,
      ``k_b(s) = pair_stiffness_N_per_m · (1 − stiffness_drop · ξ²)``, ``ξ`` = distance of the contact
      from the middle of the path of contact over half the path length (clipped to |ξ| ≤ 1.5);
    * a Hertz-like contact compliance ``hertz_compliance · f^(2/3)`` (crowned teeth: point contact);
    * an initial gap ``g_k(s)``: tip relief of both gears (``Δ·((θ−θ_s)/(θ_tip−θ_s))^n`` in roll angle,
      ``n`` = 1 linear, 2 parabolic) and, beyond the ends of the path of contact (tip-corner contact
      outside the line of action), ``overrun_gap_curvature_per_m · Δs²`` on top of the tip relief;

    and all pairs share the blank compliance ``blank_compliance_m_per_N`` (torsion of the blanks,
    carrying the total mesh force).  Hence, with mesh force ``F`` and pair loads ``f_k ≥ 0``::

        x = c0·F + g_k + f_k/k_b,k + C_h·f_k^(2/3)   for every loaded pair,   F = Σ f_k,

    which is solved exactly (bracketed root finding) under load and deflection control.  The contact
    of pair ``k`` lies ``s_k = (position − k)·p_b`` from the pitch point along the line of action
    (positive towards the driver's tip).  Contact pressure and half-width follow 2D Hertz theory with
    the involute curvature radii; gauge strains follow a cantilever model ``ε = 6 f h / (E b t²)``
    (``h`` = height of the contact above the gauge, ``t`` = root thickness); the gauge on the loaded
    fillet sees tension from its own tooth and −0.3× that of the adjacent tooth across the root space,
    a gauge on the unloaded fillet sees −0.7× the own-tooth term.  Hub reactions are the generalized
    mesh forces of the lumped model, Eq. (3.3): gear_a ``[0, −F, −F r_b1]``, gear_b ``[0, +F, −F r_b2]``
    (x ⊥ line of action, y along it).

    The defaults are set so that a single pair in the middle of the path has a mesh stiffness of about
    1.6e8 N/m at 4.7 kN (the order measured for the 28-tooth pair, see DESIGN.md).
    """

    base_radius_m: tuple[float, float]
    tip_radius_m: tuple[float, float]
    center_distance_m: float
    teeth: tuple[int, int]
    mesh_name: str = "m12"
    gear_names: tuple[str, str] = ("pinion", "wheel")
    tip_relief_m: tuple[float, float] = (0.0, 0.0)
    tip_relief_start_roll_rad: tuple[float, float] = (0.0, 0.0)
    tip_relief_exponent: tuple[float, float] = (2.0, 2.0)
    face_width_m: float = 0.015
    youngs_modulus_Pa: float = 201.5e9
    poisson_ratio: float = 0.3
    pair_stiffness_N_per_m: float = 2.9e8
    stiffness_drop: float = 0.35
    blank_compliance_m_per_N: float = 2.0e-9
    hertz_compliance_m_per_N23: float = 1.25e-8
    overrun_gap_curvature_per_m: float = 100.0
    root_thickness_m: tuple[float, float] = (0.011, 0.011)
    #: (gear index 0|1, gauge name, radius [m], on the loaded flank?)
    gauges: tuple[tuple[int, str, float, bool], ...] = ()
    description: str = "AnalyticPairSolver (analytical reference spring model, not FE)"

    def __post_init__(self) -> None:
        def bad(name: str, unit: str, allowed: str, got: Any) -> ModelError:
            return ModelError(f"AnalyticPairSolver.{name} [{unit}] = {got!r}; allowed: {allowed}")

        for name in ("base_radius_m", "tip_radius_m", "root_thickness_m"):
            v = getattr(self, name)
            if len(v) != 2 or not all(math.isfinite(r) and r > 0 for r in v):
                raise bad(name, "m", "two positive finite values", v)
        if not all(ra > rb for ra, rb in zip(self.tip_radius_m, self.base_radius_m)):
            raise bad("tip_radius_m", "m", "> base_radius_m", self.tip_radius_m)
        if not self.center_distance_m > sum(self.base_radius_m):
            raise bad("center_distance_m", "m", f"> r_b1 + r_b2 = {sum(self.base_radius_m):g}", self.center_distance_m)
        if len(self.teeth) != 2 or not all(isinstance(z, int) and z >= 6 for z in self.teeth):
            raise bad("teeth", "-", "two integers >= 6", self.teeth)
        pb_a = 2 * math.pi * self.base_radius_m[0] / self.teeth[0]
        pb_b = 2 * math.pi * self.base_radius_m[1] / self.teeth[1]
        if abs(pb_a - pb_b) > 1e-9 * pb_a:
            raise bad("base_radius_m", "m", f"equal base pitches 2π r_b/z (got {pb_a:.9g} and {pb_b:.9g} m)",
                      self.base_radius_m)
        for name, unit, lo, hi in (
            ("face_width_m", "m", 0.0, 10.0), ("youngs_modulus_Pa", "Pa", 1e9, 1e13),
            ("pair_stiffness_N_per_m", "N/m", 0.0, 1e12), ("blank_compliance_m_per_N", "m/N", -1e-30, 1e-6),
            ("hertz_compliance_m_per_N23", "m/N^(2/3)", -1e-30, 1e-3),
            ("overrun_gap_curvature_per_m", "1/m", 0.0, 1e8),
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and lo < v < hi):
                raise bad(name, unit, f"({lo:g}, {hi:g})", v)
        if not 0.0 <= self.stiffness_drop < 0.4:
            raise bad("stiffness_drop", "-", "[0, 0.4)", self.stiffness_drop)
        if not 0.0 <= self.poisson_ratio < 0.5:
            raise bad("poisson_ratio", "-", "[0, 0.5)", self.poisson_ratio)
        for i in range(2):
            if self.tip_relief_m[i] < 0 or self.tip_relief_m[i] > 1e-3:
                raise bad("tip_relief_m", "m", "[0, 1e-3]", self.tip_relief_m)
            if self.tip_relief_exponent[i] <= 0:
                raise bad("tip_relief_exponent", "-", "> 0", self.tip_relief_exponent)
        # derived geometry (cached on the instance; frozen dataclass → object.__setattr__)
        rb_a, rb_b = self.base_radius_m
        alpha = math.acos((rb_a + rb_b) / self.center_distance_m)
        L1, L2 = rb_a * math.tan(alpha), rb_b * math.tan(alpha)
        rho_tip = tuple(math.sqrt(ra * ra - rb * rb) for ra, rb in zip(self.tip_radius_m, self.base_radius_m))
        s_start, s_end = L2 - rho_tip[1], rho_tip[0] - L1
        if not s_start < 0 < s_end:
            raise bad("tip_radius_m", "m", "tips long enough to put the pitch point on the path of contact",
                      self.tip_radius_m)
        rho_rs = tuple(rb * th if d > 0 else math.inf for rb, th, d in
                       zip(self.base_radius_m, self.tip_relief_start_roll_rad, self.tip_relief_m))
        for i in range(2):
            if self.tip_relief_m[i] > 0 and not rho_rs[i] < rho_tip[i]:
                raise bad("tip_relief_start_roll_rad", "rad", f"< tip roll angle {rho_tip[i] / self.base_radius_m[i]:.6g}",
                          self.tip_relief_start_roll_rad)
        # pairs that can ever touch: gap below 2 mm
        over = math.sqrt(2e-3 / self.overrun_gap_curvature_per_m) if self.overrun_gap_curvature_per_m > 0 else pb_a
        k_min = math.ceil(-(s_end + over) / pb_a)
        k_max = math.floor(1.0 - (s_start - over) / pb_a)
        offsets = np.arange(min(k_min, -2), max(k_max, 2) + 1, dtype=np.int64)
        for k, v in dict(_alpha=alpha, _L=(L1, L2), _rho_tip=rho_tip, _s=(s_start, s_end), _pb=pb_a,
                         _rho_relief=rho_rs, _over=over, tooth_offsets=offsets).items():
            object.__setattr__(self, k, v)
        gnames = []
        for gi, gname, r, _loaded in self.gauges:
            if gi not in (0, 1) or not (0 < r < self.tip_radius_m[gi]):
                raise bad("gauges", "-", "(gear index 0|1, name, radius in (0, tip radius) m, bool)", (gi, gname, r))
            gnames.append(f"{self.gear_names[gi]}/{gname}")
        if len(set(gnames)) != len(gnames):
            raise bad("gauges", "-", "unique names", gnames)
        object.__setattr__(self, "gauge_names", tuple(gnames))

    # -- construction from a model file ------------------------------------------------------
    @classmethod
    def from_model(cls, model: Any, mesh_name: str | None = None, **overrides: Any) -> "AnalyticPairSolver":
        """Build the reference model of mesh ``mesh_name`` of a :class:`hacgear_core.model.Model`
        (external spur meshes only).  Root thickness is estimated as ``0.7 π m`` (chord of a standard
        tooth at the root); stiffness parameters keep their defaults unless overridden."""
        mesh = model.mesh(mesh_name)
        ga, gb = model.gear(mesh.gear_a), model.gear(mesh.gear_b)
        if ga.internal or gb.internal or ga.is_helical or gb.is_helical:
            raise SolverError(
                f"mesh '{mesh.name}': the analytical reference solver handles external spur meshes only; "
                "use the finite-element contact solver (--solver fe)")
        fa, fb = ga.flanks[mesh.flank_a], gb.flanks[mesh.flank_b]
        rb = tuple(0.5 * g.module_m * g.teeth * math.cos(f.pressure_angle_rad) for g, f in ((ga, fa), (gb, fb)))
        ra = (0.5 * ga.tip_diameter_m, 0.5 * gb.tip_diameter_m)
        cd = mesh.center_distance_m or 0.5 * ga.module_m * (ga.teeth + gb.teeth)
        expo = {"none": 2.0, "linear": 1.0, "parabolic": 2.0}
        gauges = []
        for gi, (g, flank) in enumerate(((ga, mesh.flank_a), (gb, mesh.flank_b))):
            for gg in g.gauges:
                gauges.append((gi, gg.name, gg.radius_m, gg.flank == flank))
        kw: dict[str, Any] = dict(
            base_radius_m=rb, tip_radius_m=ra, center_distance_m=cd, teeth=(ga.teeth, gb.teeth),
            mesh_name=mesh.name, gear_names=(ga.name, gb.name),
            tip_relief_m=(fa.tip_relief_m, fb.tip_relief_m),
            tip_relief_start_roll_rad=(fa.tip_relief_start_roll_rad, fb.tip_relief_start_roll_rad),
            tip_relief_exponent=(expo[fa.tip_relief_shape], expo[fb.tip_relief_shape]),
            face_width_m=min(ga.face_width_m, gb.face_width_m),
            youngs_modulus_Pa=ga.material.youngs_modulus_Pa, poisson_ratio=ga.material.poisson_ratio,
            root_thickness_m=(0.7 * math.pi * ga.module_m, 0.7 * math.pi * gb.module_m),
            gauges=tuple(gauges),
        )
        kw.update(overrides)
        return cls(**kw)

    @classmethod
    def spur_28t(cls, **overrides: Any) -> "AnalyticPairSolver":
        """The 28-tooth pair of dissertation Table 3.3 with its 25° flank loaded (47 µm parabolic tip
        relief from 28.54° roll), one tension gauge per gear at the root."""
        rb = 0.5 * 5e-3 * 28 * math.cos(math.radians(25.0))
        kw: dict[str, Any] = dict(
            base_radius_m=(rb, rb), tip_radius_m=(0.07495, 0.07495), center_distance_m=0.140, teeth=(28, 28),
            tip_relief_m=(47e-6, 47e-6), tip_relief_start_roll_rad=(math.radians(28.54),) * 2,
            root_thickness_m=(0.7 * math.pi * 5e-3,) * 2,
            gauges=((0, "SG25", 0.064051, True), (1, "SG25", 0.064051, True), (1, "SG20", 0.064465, False)),
        )
        kw.update(overrides)
        return cls(**kw)

    # -- geometry of the pairs -----------------------------------------------------------------
    @property
    def contact_ratio(self) -> float:
        """Involute contact ratio (path of contact / base pitch) [-]."""
        return (self._s[1] - self._s[0]) / self._pb

    def _relief(self, i: int, rho: np.ndarray) -> np.ndarray:
        d = self.tip_relief_m[i]
        if d <= 0:
            return np.zeros_like(rho)
        r0, r1 = self._rho_relief[i], self._rho_tip[i]
        u = np.clip((rho - r0) / (r1 - r0), 0.0, 1.0)
        return d * u ** self.tip_relief_exponent[i]

    def _pairs(self, position: float) -> tuple[np.ndarray, ...]:
        """Per pair: s [m], roll distances on gear a/b [m] (clamped to the flank), gap [m], bending
        compliance [m/N]."""
        s = (float(position) - self.tooth_offsets) * self._pb
        s0, s1 = self._s
        rho_a = np.clip(self._L[0] + s, self._L[0] + s0, self._rho_tip[0])
        rho_b = np.clip(self._L[1] - s, self._L[1] - s1, self._rho_tip[1])
        over = np.maximum(s - s1, 0.0) + np.maximum(s0 - s, 0.0)
        gap = self._relief(0, rho_a) + self._relief(1, rho_b) + self.overrun_gap_curvature_per_m * over ** 2
        gap = np.where(over > self._over, np.inf, gap)
        xi = np.clip((s - 0.5 * (s0 + s1)) / (0.5 * (s1 - s0)), -1.5, 1.5)
        cb = 1.0 / (self.pair_stiffness_N_per_m * (1.0 - self.stiffness_drop * xi * xi))
        return s, rho_a, rho_b, gap, cb

    def _pair_load(self, delta: np.ndarray, cb: np.ndarray) -> np.ndarray:
        """Inverse of the pair law δ = cb·f + C_h·f^(2/3) (f = 0 for δ <= 0), vectorised Newton in
        u = f^(1/3) started above the root (the cubic is convex for u > 0: monotone convergence)."""
        ch = self.hertz_compliance_m_per_N23
        d = np.where(np.isfinite(delta), np.maximum(delta, 0.0), 0.0)
        u = np.minimum(np.cbrt(d / cb), np.sqrt(d / ch) if ch > 0 else np.inf)
        for _ in range(60):
            g = cb * u ** 3 + ch * u * u - d
            dg = 3 * cb * u * u + 2 * ch * u
            step = np.divide(g, dg, out=np.zeros_like(g), where=dg > 0)
            u = u - step
            if np.all(np.abs(step) <= 1e-15 * np.maximum(u, 1e-30)):
                break
        return u ** 3

    def _pair_deflection(self, f: float, cb: float) -> float:
        return cb * f + self.hertz_compliance_m_per_N23 * f ** (2.0 / 3.0)

    # -- protocol ------------------------------------------------------------------------------
    def no_load_deflection(self, position: float) -> float:
        """NLMD: the smallest initial gap of all pairs [m]."""
        return float(np.min(self._pairs(position)[3]))

    def solve_deflection(self, position: float, mesh_deflection_m: float) -> StaticSolution:
        from scipy.optimize import brentq

        x = float(mesh_deflection_m)
        s, rho_a, rho_b, gap, cb = self._pairs(position)
        c0 = self.blank_compliance_m_per_N
        gmin = float(np.min(gap))
        if not math.isfinite(x):
            return self._failed(position, f"mesh deflection must be finite, got {x!r} m")
        if x <= gmin:
            return self._solution(position, 0.0, x, np.zeros_like(gap), 0, s, rho_a, rho_b)
        if c0 <= 0:
            f = self._pair_load(x - gap, cb)
            return self._solution(position, float(f.sum()), x, f, 1, s, rho_a, rho_b)

        def h(F: float) -> float:
            return F - float(self._pair_load(x - c0 * F - gap, cb).sum())

        hi = (x - gmin) / c0
        F, res = brentq(h, 0.0, hi, xtol=1e-10, rtol=1e-14, full_output=True)
        f = self._pair_load(x - c0 * F - gap, cb)
        return self._solution(position, float(f.sum()), x, f, res.iterations, s, rho_a, rho_b)

    def solve_load(self, position: float, mesh_force_N: float) -> StaticSolution:
        from scipy.optimize import brentq

        F = float(mesh_force_N)
        s, rho_a, rho_b, gap, cb = self._pairs(position)
        if not (math.isfinite(F) and F >= 0):
            return self._failed(position, f"mesh force must be finite and >= 0, got {F!r} N")
        k = int(np.argmin(gap))
        if F == 0:
            return self._solution(position, 0.0, float(gap[k]), np.zeros_like(gap), 0, s, rho_a, rho_b)
        lo, hi = float(gap[k]), float(gap[k]) + self._pair_deflection(F, float(cb[k])) * (1 + 1e-9) + 1e-15
        y, res = brentq(lambda y: float(self._pair_load(y - gap, cb).sum()) - F, lo, hi,
                        xtol=1e-16, rtol=1e-14, full_output=True)
        f = self._pair_load(y - gap, cb)
        x = y + self.blank_compliance_m_per_N * F
        return self._solution(position, F, x, f, res.iterations, s, rho_a, rho_b)

    def solve_position(self, position: float, loads_N: np.ndarray, deflections_m: np.ndarray
                       ) -> tuple[list[StaticSolution], list[StaticSolution]]:
        """Batch of load- and deflection-controlled solves at one position."""
        return ([self.solve_load(position, F) for F in np.asarray(loads_N, float)],
                [self.solve_deflection(position, x) for x in np.asarray(deflections_m, float)])

    # -- outputs -------------------------------------------------------------------------------
    def _failed(self, position: float, message: str) -> StaticSolution:
        n = len(self.tooth_offsets)
        nan = np.full(n, np.nan)
        return StaticSolution(False, message, 0, float(position), math.nan, math.nan, nan, nan, nan, nan)

    def _solution(self, position: float, F: float, x: float, f: np.ndarray, iterations: int,
                  s: np.ndarray, rho_a: np.ndarray, rho_b: np.ndarray) -> StaticSolution:
        E, nu, b = self.youngs_modulus_Pa, self.poisson_ratio, self.face_width_m
        loaded = f > 0
        rho_a_c = np.maximum(rho_a, 1e-4)
        rho_b_c = np.maximum(rho_b, 1e-4)
        R = rho_a_c * rho_b_c / (rho_a_c + rho_b_c)
        e_star = E / (2.0 * (1.0 - nu * nu))
        a = np.sqrt(4.0 * f * R / (math.pi * b * e_star))
        p = np.divide(2.0 * f, math.pi * a * b, out=np.zeros_like(f), where=a > 0)
        roll_b = np.where(loaded, np.degrees(rho_b / self.base_radius_m[1]), np.nan)
        strain: dict[str, np.ndarray] = {}
        for (gi, _name, r_g, on_loaded), full in zip(self.gauges, self.gauge_names):
            rho = rho_a if gi == 0 else rho_b
            r_c = np.sqrt(self.base_radius_m[gi] ** 2 + rho * rho)
            own = 6.0 * f * np.maximum(r_c - r_g, 0.0) / (E * b * self.root_thickness_m[gi] ** 2)
            if on_loaded:
                neighbour = np.zeros_like(own)
                if gi == 0:
                    neighbour[:-1] = own[1:]
                else:
                    neighbour[1:] = own[:-1]
                strain[full] = own - 0.3 * neighbour
            else:
                strain[full] = -0.7 * own
        hub = {
            self.gear_names[0]: np.array([0.0, -F, -F * self.base_radius_m[0]]),
            self.gear_names[1]: np.array([0.0, F, -F * self.base_radius_m[1]]),
        }
        return StaticSolution(True, "ok", int(iterations), float(position), float(F), float(x), f.copy(), roll_b,
                              a, p, strain, hub)


@dataclass(frozen=True)
class AnalyticFactory:
    """Picklable factory of an :class:`AnalyticPairSolver` (keyword arguments as a sorted tuple)."""

    kwargs: tuple[tuple[str, Any], ...] = ()
    preset: str = "spur_28t"

    def __call__(self) -> AnalyticPairSolver:
        kw = dict(self.kwargs)
        if self.preset == "spur_28t":
            return AnalyticPairSolver.spur_28t(**kw)
        return AnalyticPairSolver(**kw)


@dataclass(frozen=True)
class ModelSolverFactory:
    """Picklable factory: reads the model file in the worker, checks it is byte-identical to the one
    the run started from, and builds the solver of ``mesh_name`` (``solver`` = ``"fe"``:
    ``hacgear_core.contact.make_mesh_solver``; ``"analytic"``: :meth:`AnalyticPairSolver.from_model`)."""

    model_path: str
    mesh_name: str
    model_sha256: str
    solver: str = "fe"

    def __call__(self) -> MeshStaticSolver:
        from hacgear_core.model import load_model

        model = load_model(self.model_path)
        if self.model_sha256 and model.sha256 != self.model_sha256:
            raise TableError(f"{self.model_path} changed while `hacgear statics` was running "
                             f"(sha256 {model.sha256[:12]}… != {self.model_sha256[:12]}…); start again")
        if self.solver == "analytic":
            return AnalyticPairSolver.from_model(model, self.mesh_name)
        if self.solver != "fe":
            raise SolverError(f"unknown solver {self.solver!r}; allowed: fe | analytic")
        return _fe_factory()(model, self.mesh_name)


def _fe_factory() -> Callable[[Any, str], MeshStaticSolver]:
    try:
        from hacgear_core.contact import make_mesh_solver  # type: ignore[attr-defined]
    except ImportError as exc:
        raise SolverError(
            "the static contact solver is not available: hacgear_core.contact.make_mesh_solver(model, mesh_name) "
            f"could not be imported ({exc}). It is issue 3 (contact); meanwhile `--solver analytic` runs the "
            "analytical reference spring model (not FE)."
        ) from None
    return make_mesh_solver


# ---------------------------------------------------------------------------------------------
# Grids
# ---------------------------------------------------------------------------------------------
def nominal_mesh_forces(model: Any, base_radii: Mapping[str, tuple[float, float]]) -> dict[str, float]:
    """Nominal mesh force of every mesh [N] from the operating torque ``model.operating``.

    The mesh touching ``torque_gear`` carries ``T / r_b`` (divided by the planet count for planetary
    sets, whose planets share the torque); the force then propagates through free gears (idlers,
    planets) by their torque balance ``F_out = F_in · r_b,in / r_b,out``.  ``base_radii[mesh]`` are the
    loaded-flank base radii ``(r_b of gear_a, r_b of gear_b)`` [m].
    """
    T, g0 = model.operating.torque_Nm, model.operating.torque_gear
    share = model.planetary.planet_count if getattr(model, "planetary", None) is not None else 1
    meshes = {m.name: m for m in model.meshes}
    force: dict[str, float] = {}
    frontier: list[tuple[str, float | None, float | None]] = [(g0, None, None)]  # gear, F_in, r_b,in
    seen = {g0}
    while frontier:
        gear, f_in, rb_in = frontier.pop(0)
        for name, m in meshes.items():
            if name in force or gear not in (m.gear_a, m.gear_b):
                continue
            rb = base_radii[name][0 if m.gear_a == gear else 1]
            f = T / rb / share if f_in is None else f_in * rb_in / rb
            force[name] = f
            other = m.gear_b if m.gear_a == gear else m.gear_a
            if other not in seen:
                seen.add(other)
                frontier.append((other, f, base_radii[name][1 if m.gear_a == gear else 0]))
    missing = [n for n in meshes if n not in force]
    if missing:
        raise ModelError(f"meshes {missing} carry no load from operating.torque_gear = '{g0}' (not connected)")
    return force


def load_grid(max_force_N: float, n_loads: int) -> np.ndarray:
    """Regular load grid ``linspace(0, max_force_N, n_loads)`` [N] (load 0 → the NLMD)."""
    if not (math.isfinite(max_force_N) and max_force_N > 0):
        raise ModelError(f"maximum mesh force [N] = {max_force_N!r}; allowed: finite > 0")
    if n_loads < 2:
        raise ModelError(f"loads [-] = {n_loads}; allowed: integer >= 2")
    return np.linspace(0.0, float(max_force_N), int(n_loads))


def deflection_grid(no_load_deflection_m: np.ndarray, static_deflection_m: np.ndarray, n_deflections: int,
                    margin: float = DEFAULT_DEFLECTION_MARGIN) -> np.ndarray:
    """The regular FDF deflection grid [m] (rule of ``tables.h5``).

    With ``x_b = min(0, min NLMD)`` and ``x_s = max static deflection`` (at the largest load, over all
    positions)::

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
    xb = min(0.0, float(nl.min()))
    xs = float(sd.max())
    if not xs > xb:
        raise SolverError(f"largest static mesh deflection {xs:g} m does not exceed the smallest NLMD {xb:g} m")
    dx = (xs - xb) * (1.0 + margin) / (n_deflections - 2)
    return xb - dx + dx * np.arange(n_deflections, dtype=float)


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
                   values: np.ndarray) -> tuple[str, int, int, dict[str, Any]]:
    """One position of phase 1 (``values`` = loads [N]) or phase 2 (``values`` = deflections [m])."""
    solver = _solver_for(factory)
    info = describe_solver(solver)
    nw = len(info.tooth_offsets)
    values = np.asarray(values, float)
    nlmd = float(solver.no_load_deflection(position))
    if not math.isfinite(nlmd):
        raise SolverError(f"mesh '{mesh}': no-load deflection is not finite at position {position}")
    batch = getattr(solver, "solve_position", None)
    if phase == 1:
        todo = values[values > 0]
        sols = batch(position, todo, np.empty(0))[0] if batch else [solver.solve_load(position, F) for F in todo]
        out = np.full(values.shape, nlmd)
        it = iter(sols)
        for j, F in enumerate(values):
            if F > 0:
                sol = next(it)
                _check(sol, f"mesh '{mesh}' position {position:.6g} (index {ip}) load {F:.6g} N", nw)
                out[j] = sol.mesh_deflection_m
        return mesh, phase, ip, {"no_load_deflection_m": nlmd, "static_deflection_m": out}
    nd = values.size
    res: dict[str, Any] = {
        "force_N": np.zeros(nd),
        "tooth_load_N": np.zeros((nd, nw)),
        "contact_roll_deg": np.full((nd, nw), np.nan),
        "half_width_m": np.zeros((nd, nw)),
        "peak_pressure_Pa": np.zeros(nd),
        "strain": {g: np.zeros((nd, nw)) for g in info.gauge_names},
        "hub_reaction": {g: np.zeros((nd, 3)) for g in info.gear_names},
    }
    idx = np.nonzero(values > nlmd)[0]
    sols = (batch(position, np.empty(0), values[idx])[1] if batch
            else [solver.solve_deflection(position, values[j]) for j in idx])
    for j, sol in zip(idx, sols):
        _check(sol, f"mesh '{mesh}' position {position:.6g} (index {ip}) deflection {values[j]:.6g} m", nw)
        res["force_N"][j] = sol.mesh_force_N
        res["tooth_load_N"][j] = sol.tooth_load_N
        res["contact_roll_deg"][j] = sol.contact_roll_deg
        res["half_width_m"][j] = sol.half_width_m
        pp = np.asarray(sol.peak_pressure_Pa, float)
        res["peak_pressure_Pa"][j] = float(np.nanmax(pp)) if pp.size and np.any(np.isfinite(pp)) else 0.0
        for g in info.gauge_names:
            if g not in sol.strain:
                raise SolverError(f"solver returned no strain for gauge {g!r} at mesh '{mesh}' position {position}")
            res["strain"][g][j] = sol.strain[g]
        for g in info.gear_names:
            if g in sol.hub_reaction:
                res["hub_reaction"][g][j] = sol.hub_reaction[g]
    res["n_solves"] = int(idx.size)
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
    executor: cf.Executor | None = None,
    workers: int | None = None,
    resume: bool = False,
    progress: bool = True,
) -> StaticsReport:
    """Run the static grid of every mesh and write ``out`` (HDF5, format of :mod:`hacgear_core.tables`).

    Parameters
    ----------
    factories : mesh name → picklable zero-argument solver factory.
    out : final path; the run writes ``<out>.partial`` and renames it when complete.
    n_positions, n_deflections : grid sizes (positions ``k / n_positions`` of one mesh cycle).
    loads_N : mesh name → load grid [N] (ascending, first value >= 0), or a function of the
        :class:`MeshInfo` of all meshes returning that mapping.
    deflection_margin : see :func:`deflection_grid`.
    model_sha256, model_file : provenance written to the root attributes.
    executor : any :class:`concurrent.futures.Executor`; None → a ``ProcessPoolExecutor`` with
        ``workers`` processes (``spawn``), or in-process when ``workers == 1``.
    resume : continue ``<out>.partial`` if it exists and matches these settings; positions flagged done
        are not recomputed.
    progress : show a tqdm progress bar (stderr).
    """
    from hacgear_core import tables as tb

    t0 = time.perf_counter()
    out = Path(out)
    partial = _partial_path(out)
    if n_positions < 2:
        raise ModelError(f"positions [-] = {n_positions}; allowed: integer >= 2")
    names = list(factories)
    if not names:
        raise ModelError("no mesh to analyse")
    own_executor = None
    if executor is None and (workers or os.cpu_count() or 1) > 1:
        import multiprocessing as mp

        own_executor = executor = cf.ProcessPoolExecutor(
            max_workers=workers or os.cpu_count(), mp_context=mp.get_context("spawn"))
    try:
        # --- solver descriptions (in a worker, so the solver built there is reused) ----------
        if executor is None:
            infos = {m: _describe_task(factories[m]) for m in names}
        else:
            futs = {m: executor.submit(_describe_task, factories[m]) for m in names}
            infos = {m: f.result() for m, f in futs.items()}
        for m, info in infos.items():
            if info.mesh_name != m:
                raise SolverError(f"factory for mesh '{m}' built a solver of mesh '{info.mesh_name}'")
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
            )
            for m in names
        }
        root_attrs = {
            "model_sha256": model_sha256, "model_file": model_file,
            "deflection_margin": float(deflection_margin),
        }
        if resume and not partial.exists() and out.exists():
            done = tb.completed_table_matches(out, layouts, root_attrs)
            if done:
                total = 2 * n_positions * len(names)
                return StaticsReport(True, f"{out} is already complete for these settings; nothing to do", out,
                                     total, 0, total, time.perf_counter() - t0, done)
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
                "(--resume)."
            ) from None
        raise
    finally:
        if own_executor is not None:
            own_executor.shutdown(wait=True)


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

    def run(phase: int, jobs: list[tuple[str, int, np.ndarray]]) -> None:
        nonlocal computed
        if not jobs:
            return
        if executor is None:
            results = (_position_task(factories[m], phase, m, ip, positions[ip], v) for m, ip, v in jobs)
            for r in results:
                tb.write_position(f, *r)
                computed += 1
                if bar is not None:
                    bar.update(1)
            return
        futs = [executor.submit(_position_task, factories[m], phase, m, ip, positions[ip], v) for m, ip, v in jobs]
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
            grid = deflection_grid(g["no_load_deflection_m"][()], g["static_deflection_m"][()],
                                   layouts[m].n_deflections, margin)
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
    f.close()
    os.replace(partial, out)
    msg = f"wrote {out} ({len(names)} mesh(es), {n_pos} positions)"
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
    resume: bool = False,
    progress: bool = True,
) -> StaticsReport:
    """``hacgear statics``: the static grids of every mesh of a model file → ``tables.h5``.

    Grid sizes default to the model's ``[statics]`` section; the load grid of each mesh is
    ``linspace(0, max_torque_factor × nominal mesh force, loads)`` (:func:`nominal_mesh_forces`).
    ``solver``: ``"fe"`` (``hacgear_core.contact.make_mesh_solver``) or ``"analytic"``
    (:class:`AnalyticPairSolver`, reference spring model).
    """
    from hacgear_core.model import load_model

    mdl = load_model(model)
    if solver == "fe":
        _fe_factory()  # fail early and clearly when the contact solver does not exist yet
    elif solver != "analytic":
        raise SolverError(f"unknown solver {solver!r}; allowed: fe | analytic")
    st = mdl.statics
    n_pos = positions or st.positions
    n_loads = loads or st.loads
    n_def = deflections or st.deflections
    factor = max_torque_factor or st.max_torque_factor
    if factor < 3.0:
        raise ModelError(f"max_torque_factor [-] = {factor:g}; allowed: >= 3 (tables span 0 … >= 3 x nominal torque)")
    out_path = Path(out) if out is not None else mdl.tables_path
    factories = {m.name: ModelSolverFactory(str(mdl.path), m.name, mdl.sha256, solver) for m in mdl.meshes}

    def loads_for(infos: dict[str, MeshInfo]) -> dict[str, np.ndarray]:
        fn = nominal_mesh_forces(mdl, {m: i.base_radius_m for m, i in infos.items()})
        return {m: load_grid(factor * fn[m], n_loads) for m in infos}

    return run_statics(
        factories, out_path, n_positions=n_pos, n_deflections=n_def, loads_N=loads_for,
        deflection_margin=deflection_margin, model_sha256=mdl.sha256, model_file=str(mdl.path.name),
        executor=executor, workers=workers, resume=resume, progress=progress,
    )
