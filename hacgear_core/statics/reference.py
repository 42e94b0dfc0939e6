"""Analytical reference solver of an external spur pair (tooth pairs as load-dependent springs with
tip-relief gaps and a shared blank compliance).

Not the finite-element solver: it tests the statics machinery against closed forms, documents the
:class:`~hacgear_core.statics.contract.MeshStaticSolver` protocol by example, and gives synthetic tables
(``hacgear statics --solver analytic``) for testing.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from hacgear_core.errors import ModelError, SolverError
from hacgear_core.statics.contract import StaticSolution

__all__ = ["AnalyticPairSolver", "AnalyticFactory"]

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
    def from_model(cls, model: Any, mesh_name: str | None = None, *, side: str = "drive",
                   **overrides: Any) -> "AnalyticPairSolver":
        """Build the reference model of mesh ``mesh_name`` of a :class:`hacgear_core.model.Model`
        (external spur meshes only).  Root thickness is estimated as ``0.7 π m`` (chord of a standard
        tooth at the root); stiffness parameters keep their defaults unless overridden.  ``side="coast"``:
        the other flank of each gear (its own positions and deflections, like
        ``make_mesh_solver(..., side="coast")``)."""
        mesh = model.mesh(mesh_name)
        ga, gb = model.gear(mesh.gear_a), model.gear(mesh.gear_b)
        if ga.internal or gb.internal or ga.is_helical or gb.is_helical:
            raise SolverError(
                f"mesh '{mesh.name}': the analytical reference solver handles external spur meshes only; "
                "use the finite-element contact solver (--solver fe)")
        if side not in ("drive", "coast"):
            raise ModelError(f"side = {side!r}; allowed: drive | coast")
        other = {"drive": "coast", "coast": "drive"}
        flank_a, flank_b = (mesh.flank_a, mesh.flank_b) if side == "drive" else (other[mesh.flank_a],
                                                                                 other[mesh.flank_b])
        fa, fb = ga.flanks[flank_a], gb.flanks[flank_b]
        rb = tuple(0.5 * g.module_m * g.teeth * math.cos(f.pressure_angle_rad) for g, f in ((ga, fa), (gb, fb)))
        ra = (0.5 * ga.tip_diameter_m, 0.5 * gb.tip_diameter_m)
        cd = mesh.center_distance_m or 0.5 * ga.module_m * (ga.teeth + gb.teeth)
        expo = {"none": 2.0, "linear": 1.0, "parabolic": 2.0}
        gauges = []
        for gi, (g, flank) in enumerate(((ga, flank_a), (gb, flank_b))):
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
                              a, p, strain, hub, flank_pressure_Pa=np.asarray(p, float).copy(),
                              edge_pressure_Pa=np.zeros_like(np.asarray(p, float)))   # involute contacts only


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
