"""Static contact of one gear mesh: kinematics, initial separations, complementarity solve.

For a mesh position (fraction of a mesh cycle) the two gears are placed kinematically (rigid,
conjugate involute motion), every tooth pair of a window around the reference pair is examined
for its closest approach, and the contact problem

    g_i = g0_i - lambda_i x + sum_j C_ij F_j  >= 0,   F_i >= 0,   F_i g_i = 0

is solved either for a given mesh deflection ``x`` (deflection control → mesh force
``W = sum lambda_i F_i``) or for a given mesh force ``W`` (load control → ``x``).

Quantities
----------
* **Candidates.**  One candidate contact per tooth pair and face slice: the point of the two
  loaded flanks (involute + tip edge, with tip relief) that closes first under a rigid mesh
  deflection (smallest ``g0/lambda``).  Both flanks are sampled densely and each sample of one
  flank is projected orthogonally onto the other flank's polyline; samples whose foot falls off
  the mating flank are discarded.  This finds involute contacts on the line of action *and*
  tip-edge contacts off the line of action (premature contact before the SAP / after the EAP,
  dissertation Figs. 2.5-2.6).
* **Mesh deflection** ``x = r_b1 θ1 + r_b2 θ2`` of the rigid hubs (θ positive in the sense that
  closes the mesh).  The static solve turns both hubs by the same share, ``r_b1 θ1 = r_b2 θ2 = x/2``:
  a candidate with contact normal ``n`` (from gear_a into gear_b) at point ``c`` closes by
  ``lambda x`` with ``lambda = ½ (h_a / r_b1 + h_b / r_b2)``, ``h_a = (ẑ × (c - O_a)) · n`` and
  ``h_b = -(ẑ × (c - O_b)) · n`` the moment arms about the two centres.  ``lambda = 1`` on the line
  of action; at a tip edge or on a relieved (tilted) flank it differs.  The mesh force is the
  generalized force conjugate to ``x``: ``W = sum lambda_i F_i = ½ (T_a / r_b1 + T_b / r_b2)``, which
  is the torque over the base radius for involute contact and treats driver and driven alike (the
  static state does not depend on which gear drives).
* **Initial separation** ``g0`` along the contact normal includes tip relief (profile, via the
  geometry's ``modification_m``) and lead crowning of both gears (per slice).
* **Compliance** ``C = C_a + C_b``: finite-element far field of each whole gear
  (:mod:`hacgear_core.statics.fe`, hub held, all teeth: cross-tooth coupling) plus the analytical
  near field (:mod:`hacgear_core.statics.nearfield`): the mutual term between distinct points on one
  tooth, and for every loaded contact the Hertz half-space approach of both bodies, which
  depends on the load (``~ w ln(1/w)``).  The latter is handled by Newton steps: tangent
  compliance on the diagonal, the secant-minus-tangent term as a separation offset (3-6 LCP
  solves per state; exact at convergence).
* **Face width.**  The face is cut into ``face_slices`` slices of equal width; crowning enters each
  slice's separation, the Hertz near field is per slice (line load ``F/b_s``).  The far field
  (``face_coupling``): ``"rigid"`` (default) couples it uniformly over the face — the plane-stress
  gear of the full width acts as one body, as the 2D idealisation itself assumes, appropriate for a
  narrow face (the 28-tooth pair: b = 15 mm = 3 modules, about 1.3 tooth heights); ``"slices"`` is
  the thin-slice model (each slice an independent plane-stress gear of the slice width, as in
  ISO 6336 load-distribution practice), appropriate for wide faces.  The truth of a 3D body lies in
  between; ``docs/static_contact.md`` reports both.

The complementarity problem is a strictly convex quadratic programme (``C`` symmetric positive
definite); :func:`solve_contact_lcp` solves it exactly with a primal active-set method (finite
termination, warm starts across loads at one position;
:mod:`hacgear_core.statics.lcp`).
"""


from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Sequence

import numpy as np

from hacgear_core.errors import GeometryError, ModelError, SolverError
from hacgear_core.geometry import gear_geometry, mesh_geometry
from hacgear_core.model import Model
from hacgear_core.kinds import kind_of, load_model
from hacgear_core.statics import fe as fe_mod
from hacgear_core.statics.contract import StaticSolution
from hacgear_core.statics.lcp import LCPResult, solve_contact_lcp
from hacgear_core.statics.nearfield import halfspace_approach_hertz, hertz_line_contact

__all__ = [
    "ContactOptions",
    "PositionSetup",
    "ContactState",
    "MeshContactSolver",
    "split_pressure",
    "make_mesh_solver",
    "default_contact_options",
    "spur_twist_axis",
    "prebuild_compliances",
    "mesh_solver_inputs",
]


def split_pressure(n_pairs: int, pair_index: np.ndarray, pressure_Pa: np.ndarray,
                   tip_contact: np.ndarray) -> dict[str, np.ndarray]:
    """Largest contact pressure of each pair [Pa] over its flank contacts and over its tip-edge contacts:
    ``{"flank_pressure_Pa": (n_pairs,), "edge_pressure_Pa": (n_pairs,)}`` (0 where there is none).
    ``pair_index``, ``pressure_Pa``: (Np,) per contact point; ``tip_contact``: (Np,) per contact point or
    (n_pairs,) per pair (the plane solver decides it per pair, the face-resolving one per slice)."""
    p = np.asarray(pressure_Pa, float)
    tip = np.asarray(tip_contact, bool)
    if tip.size != p.size:
        tip = tip[pair_index]
    flank = np.zeros(n_pairs)
    edge = np.zeros(n_pairs)
    np.maximum.at(flank, pair_index[~tip], p[~tip])
    np.maximum.at(edge, pair_index[tip], p[tip])
    return {"flank_pressure_Pa": flank, "edge_pressure_Pa": edge}


# =============================================================================================
# Options and geometry helpers
# =============================================================================================
@dataclass(frozen=True)
class ContactOptions:
    """Options of the static contact solver.

    Parameters
    ----------
    face_slices : int
        Slices across the face width (1..200).  21 (default) resolves parabolic lead crowning: the
        mean local-slope mesh stiffness of the 28-tooth pair moves < 0.2 % from 21 to 41/61/81 slices,
        while 5 slices are off by +0.9 % (docs/static_contact.md, "Face slices").
    face_coupling : {"rigid", "slices", "elastic"}
        Far-field coupling across the face (see the module docstring); default "rigid".  "elastic" (the 3D
        face-wise influence of :mod:`hacgear_core.statics.fe3d`) is served by the helical solver
        (:mod:`hacgear_core.statics.helical`).
    pair_window : int
        Tooth pairs examined on each side of the pair nearest the pitch point (>= 1); reported
        offsets are ``pair_centre - pair_window .. pair_centre + pair_window``.
    pair_centre : int
        Centre of the reported window of tooth-pair offsets (-10..10).  0 (default) suits positions in [0, 1);
        a solver asked at other positions centres the window on the pairs that touch there
        (:func:`hacgear_core.statics.coast.make_coast_solver`: the coast flanks' own positions ``c0 - tau``).
    n_profile : int
        Samples per flank for the gap computation (100..5000).
    corner_radius_m : float
        Edge radius used for the Hertz curvature at a sharp tip corner (tip_edge_radius = 0) [m].
    fixed_point_tol : float
        Relative change of the loads that ends the near-field (Newton) iteration.
    max_fixed_point : int
        Iteration limit of that loop.
    """

    face_slices: int = 21
    face_coupling: str = "rigid"
    pair_window: int = 2
    pair_centre: int = 0
    n_profile: int = 600
    corner_radius_m: float = 0.1e-3
    fixed_point_tol: float = 1e-6
    max_fixed_point: int = 30

    def __post_init__(self):
        if not (isinstance(self.face_slices, (int, np.integer)) and 1 <= self.face_slices <= 200):
            raise ModelError(f"face_slices must be an integer in [1, 200], got {self.face_slices!r}")
        if self.face_coupling not in ("slices", "rigid", "elastic"):
            raise ModelError(f"face_coupling must be 'slices', 'rigid' or 'elastic', got {self.face_coupling!r}")
        if not (isinstance(self.pair_window, (int, np.integer)) and 1 <= self.pair_window <= 10):
            raise ModelError(f"pair_window must be an integer in [1, 10], got {self.pair_window!r}")
        if not (isinstance(self.pair_centre, (int, np.integer)) and -10 <= self.pair_centre <= 10):
            raise ModelError(f"pair_centre must be an integer in [-10, 10], got {self.pair_centre!r}")
        if not (isinstance(self.n_profile, (int, np.integer)) and 100 <= self.n_profile <= 5000):
            raise ModelError(f"n_profile must be an integer in [100, 5000], got {self.n_profile!r}")
        if not (1e-6 <= self.corner_radius_m <= 1e-2):
            raise ModelError(f"corner_radius_m must be in [1e-6, 1e-2] m, got {self.corner_radius_m!r}")
        if not (0 < self.fixed_point_tol < 1e-2):
            raise ModelError(f"fixed_point_tol must be in (0, 1e-2), got {self.fixed_point_tol!r}")
        if not (1 <= self.max_fixed_point <= 1000):
            raise ModelError(f"max_fixed_point must be in [1, 1000], got {self.max_fixed_point!r}")


_OTHER_FLANK = {"drive": "coast", "coast": "drive"}


def _rot(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])




@dataclass(frozen=True)
class _Flank:
    """Loaded flank of tooth 0 in the gear's canonical frame (loaded flank on the CCW side)."""

    xy: np.ndarray          # (n,2) modified profile (relief removed), root -> tip
    xy0: np.ndarray         # (n,2) unmodified
    normal: np.ndarray      # (n,2) outward
    s: np.ndarray           # (n,) arc length from the tip [m]
    radius: np.ndarray      # (n,)
    region: np.ndarray      # (n,)
    curvature: np.ndarray   # (n,) signed radius of curvature [m] (nan where unknown)
    contact: np.ndarray     # (n,) bool: may touch the mating flank as a point (involute, tip)
    s_min: float            # range of the finite-element samples
    s_max: float


def _canonical_flank(gg: Any, side: str, n: int, corner_radius_m: float, s_range: tuple[float, float],
                     mirror: bool) -> _Flank:
    prof = gg.flank(side, n)
    xy = np.asarray(prof.xy, dtype=float)            # the geometry's profile includes the relief
    nrm = np.asarray(prof.normal, dtype=float)
    mod = np.asarray(getattr(prof, "modification_m", np.zeros(len(xy))), dtype=float)
    mod = np.where(np.isfinite(mod), mod, 0.0)
    if mirror:  # mirror about the tooth centreline (the whole picture is mirrored)
        xy = xy * [1.0, -1.0]
        nrm = nrm * [1.0, -1.0]
    xy0 = xy + mod[:, None] * nrm                     # unmodified involute (kinematics)
    region = np.asarray(prof.region).astype(int)
    curv = np.asarray(prof.curvature_radius_m, dtype=float).copy()
    tip = region == 3
    corner = np.zeros(len(xy0), bool)
    if not np.any(tip):
        corner[-1] = True   # sharp tip corner: the last profile point
    bad = ~np.isfinite(curv) | (curv == 0) | corner
    curv[bad & (tip | corner)] = corner_radius_m
    contact = (region == 2) | (region == 3) | corner
    return _Flank(xy=xy, xy0=xy0, normal=nrm, s=np.asarray(prof.s, float), radius=np.hypot(xy0[:, 0], xy0[:, 1]),
                  region=region, curvature=curv, contact=contact, s_min=s_range[0], s_max=s_range[1])


def _extended_involute_polar(radius_m: np.ndarray, polar_rad: np.ndarray, base_radius_m: float, r: float) -> float:
    """Polar angle [rad] at radius ``r`` [m] of the involute sampled by (``radius_m``, ``polar_rad``), continued
    beyond its samples.

    An involute of base radius ``r_b`` has the polar angle ``theta(r) = theta_0 + s inv(arccos(r_b / r))`` with
    ``s = +-1`` its winding sense (the sign of the samples' angle change with radius), at every ``r >= r_b``;
    the continuation starts from the sample nearest ``r`` (an end of the ascending ``radius_m``), so it meets the
    sampled curve there.

    Parameters
    ----------
    radius_m, polar_rad : numpy.ndarray
        Samples of the involute, ``radius_m`` ascending [m], their polar angles [rad].
    base_radius_m : float
        Base radius of the involute [m].
    r : float
        Radius [m] (>= ``base_radius_m``).
    """
    if not r >= base_radius_m:
        raise GeometryError(f"radius {r:.6g} m lies inside the base circle (r_b = {base_radius_m:.6g} m)")

    def inv(R: float) -> float:
        a = math.acos(min(base_radius_m / R, 1.0))
        return math.tan(a) - a

    end = 0 if r < radius_m[0] else len(radius_m) - 1
    sense = 1.0 if polar_rad[-1] >= polar_rad[0] else -1.0
    return float(polar_rad[end] + sense * (inv(r) - inv(float(radius_m[end]))))


def _project(P: np.ndarray, Q: np.ndarray, NQ: np.ndarray, tree: Any = None):
    """Closest point on the polyline ``Q`` for each point ``P``.

    The nearest vertex of ``Q`` (KD-tree) selects the two adjacent segments; the orthogonal foot on
    the nearer one is taken.  Returns (signed distance along the interpolated normal of Q,
    segment index, parameter in [0, 1], valid (foot not beyond either end of Q), unit normal)."""
    from scipy.spatial import cKDTree

    if tree is None:
        tree = cKDTree(Q)
    _, v = tree.query(P)
    m = len(Q) - 1
    best_d2 = np.full(len(P), np.inf)
    best_j = np.zeros(len(P), dtype=int)
    best_t = np.zeros(len(P))
    for j in (np.clip(v - 1, 0, m - 1), np.clip(v, 0, m - 1)):
        A = Q[j]
        D = Q[j + 1] - A
        rel = P - A
        t = np.einsum("ij,ij->i", rel, D) / np.einsum("ij,ij->i", D, D)
        tc = np.clip(t, 0.0, 1.0)
        diff = rel - tc[:, None] * D
        d2 = np.einsum("ij,ij->i", diff, diff)
        better = d2 < best_d2
        best_d2 = np.where(better, d2, best_d2)
        best_j = np.where(better, j, best_j)
        best_t = np.where(better, t, best_t)
    j, t = best_j, best_t
    valid = ~(((j == 0) & (t < 0)) | ((j == m - 1) & (t > 1)))
    tc = np.clip(t, 0.0, 1.0)
    foot = Q[j] * (1 - tc)[:, None] + Q[j + 1] * tc[:, None]
    nq = NQ[j] * (1 - tc)[:, None] + NQ[j + 1] * tc[:, None]
    nq /= np.linalg.norm(nq, axis=1, keepdims=True)
    gap = np.einsum("pi,pi->p", P - foot, nq)
    return gap, j, tc, valid, nq


@dataclass(frozen=True)
class PositionSetup:
    """Everything that depends on the mesh position only (reused for all loads there).

    ``n`` candidates = pairs × slices, ordered pair-major.  Arrays (n,) unless noted.
    """

    position: float
    pairs: np.ndarray            # (Np,) pair numbers (offset from the reference pair)
    g0: np.ndarray               # initial separation [m] (inf: pair cannot touch)
    lam: np.ndarray              # rigid approach per unit mesh deflection [-]
    C_lin: np.ndarray            # (n,n) linear compliance [m/N] (far field + mutual near field)
    pair_index: np.ndarray       # (n,) index into pairs
    slice_index: np.ndarray      # (n,)
    slice_width_m: float
    s_a: np.ndarray              # (Np,) profile coordinate on gear_a's flank [m]
    s_b: np.ndarray              # (Np,)
    roll_b_rad: np.ndarray       # (Np,) roll angle of the contact on gear_b's flank
    R_a: np.ndarray              # (Np,) radii of curvature at the contact [m]
    R_b: np.ndarray
    point: np.ndarray            # (Np,2) contact point (global canonical frame)
    normal: np.ndarray           # (Np,2) contact normal, from gear_a into gear_b
    tooth_a: np.ndarray          # (Np,) tooth index of gear_a (its own frame, actual numbering)
    tooth_b: np.ndarray
    phi: tuple[float, float]     # rotation of the gear frames (canonical) [rad]
    tip_contact: np.ndarray      # (Np,) bool: the contact is at a tip edge (off the involute pair)
    depth_a: np.ndarray          # (Np,) near-field reading depths of the finite-element far field [m]
    depth_b: np.ndarray
    R_eff: np.ndarray            # (Np,) Hertz effective radius [m]
    strain_op: dict = field(default_factory=dict)   # gauge -> (Nw, Np) strain per unit line load [m/N]
    hub_op: dict = field(default_factory=dict)      # gear -> (Np, 3) hub force per unit line load (global)


@dataclass(frozen=True)
class ContactState:
    """A solved contact state with everything per candidate (see :class:`PositionSetup`)."""

    setup: PositionSetup
    lcp: LCPResult
    force_N: np.ndarray          # (n,)
    line_load_N_m: np.ndarray    # (n,)
    half_width_m: np.ndarray     # (n,)
    peak_pressure_Pa: np.ndarray  # (n,)
    mesh_force_N: float
    mesh_deflection_m: float
    fixed_point_iterations: int
    success: bool
    message: str
    lcp_iterations: int = 0


# =============================================================================================
# The mesh solver
# =============================================================================================
class MeshContactSolver:
    """Static contact solver of one external spur mesh (follows ``statics.MeshStaticSolver``).

    Parameters
    ----------
    mesh_name : str
    gear_names : (str, str)
        ``gear_a`` (driver), ``gear_b`` (driven).
    geometry : (GearGeometry, GearGeometry)
        Objects following the geometry API (``flank``, ``z``, ``base_radius_m``...).
    flanks : (str, str)
        Loaded flank of each gear ("drive" | "coast"); must be equal for an external mesh.
    center_distance_m : float
    compliance : (FlankCompliance, FlankCompliance)
        Finite-element influence coefficients of each gear's loaded flank (per unit width).
    face_width_m : float
        Width in contact [m].
    crowning : (callable, callable)
        ``z_axial_m -> crowning depth [m]`` of each gear (0 at the face centre).
    materials : ((E, nu), (E, nu))
    gauges : sequence of (gear index 0|1, gauge index in that gear's compliance, public name)
    options : ContactOptions

    Mesh position 0 places tooth pair 0 with both loaded flanks' involutes through the operating pitch point
    (the geometry's and the dynamics' convention, :func:`hacgear_core.geometry.train.place_mesh`).  Where the pitch
    point lies off a flank (its tip circle short of the operating pitch circle: tip-shortened or profile-shifted
    teeth), that flank's involute is continued to it (:func:`_extended_involute_polar`; the gear is named in
    ``pitch_point_off_flank``); the contact path then lies wholly to one side of the pitch point, and a path that
    reaches ``options.pair_window`` base pitches from it is refused (:meth:`active_path_phases`).
    """

    #: True for solvers that resolve the face (3D face coupling, helix): :mod:`hacgear_core.statics.helical`
    _resolves_face = False

    def __init__(self, *, mesh_name: str, gear_names: tuple[str, str], geometry: tuple[Any, Any],
                 flanks: tuple[str, str], center_distance_m: float, compliance: tuple[Any, Any],
                 face_width_m: float, crowning: tuple[Callable, Callable],
                 materials: tuple[tuple[float, float], tuple[float, float]],
                 gauges: Sequence[tuple[int, int, str]] = (), options: ContactOptions = ContactOptions(),
                 plane: str = "stress", description: str = ""):
        for side in flanks:
            if side not in ("drive", "coast"):
                raise ModelError(f"flank must be 'drive' or 'coast', got {side!r}")
        internal = [bool(getattr(g, "internal", False)) for g in geometry]
        if all(internal):
            raise GeometryError(f"mesh '{mesh_name}': two internal gears cannot mesh")
        self.internal = any(internal)
        self.gear_internal = tuple(internal)
        if (flanks[0] == flanks[1]) == self.internal:
            raise SolverError(
                f"mesh '{mesh_name}': an {'internal' if self.internal else 'external'} mesh loads "
                f"{'opposite' if self.internal else 'same'}-named flanks (drive = counter-clockwise side of a "
                f"tooth); got flank_a={flanks[0]!r}, flank_b={flanks[1]!r}")
        if not (face_width_m > 0):
            raise ModelError(f"face_width_m must be > 0 m, got {face_width_m!r}")
        if options.face_coupling == "elastic" and not self._resolves_face:
            raise SolverError("face_coupling 'elastic' needs the face-resolving solver: "
                              "hacgear_core.statics.helical.make_solver / make_helical_solver")
        self.mesh_name = mesh_name
        self.gear_names = tuple(gear_names)
        self.teeth = (int(geometry[0].z), int(geometry[1].z))
        self.flanks = tuple(flanks)
        self.base_radius_m = (float(geometry[0].base_radius_m[flanks[0]]), float(geometry[1].base_radius_m[flanks[1]]))
        self.center_distance_m = float(center_distance_m)
        self.options = options
        self.face_width_m = float(face_width_m)
        self.materials = materials
        self.plane = plane
        self.compliance = tuple(compliance)
        self.description = description or f"FE/near-field static contact solver, mesh {mesh_name}"
        # canonical picture: gear_a turns counter-clockwise with its loaded flank on the CCW side of its
        # teeth (the whole picture is mirrored when that is the coast flank); gear_b turns clockwise
        # (external mesh) or counter-clockwise (internal mesh)
        self._mirror = flanks[0] == "coast"
        self._sense_b = 1 if self.internal else -1
        self._pair_sign = (-1, -self._sense_b)      # canonical tooth of pair k: (-k, +k) external, (-k, -k) internal
        W, Wc = options.pair_window, options.pair_centre
        self.tooth_offsets = np.arange(Wc - W, Wc + W + 1)
        self.gauges = tuple(gauges)
        self.gauge_names = tuple(name for _, _, name in gauges)
        self._flank = tuple(
            _canonical_flank(gg, side, options.n_profile, options.corner_radius_m,
                             (float(fc.s_m[0]), float(fc.s_m[-1])), self._mirror)
            for gg, side, fc in zip(geometry, flanks, compliance))
        n = options.face_slices
        b = self.face_width_m
        self.slice_width_m = b / n
        self.slice_z_m = -b / 2 + (np.arange(n) + 0.5) * b / n
        self.crowning_slices_m = np.asarray([[float(c(zz)) for zz in self.slice_z_m] for c in crowning])
        (Ea, nua), (Eb, nub) = materials
        self._E_star = hertz_line_contact(1.0, 1.0, 1.0, Ea, nua, Eb, nub, plane=plane).effective_modulus_Pa
        self._kinematics()
        self._setup_cache: dict[float, PositionSetup] = {}

    # -------------------------------------------------------------------- kinematics
    def _kinematics(self) -> None:
        """Frame angles at position 0: pitch-point contact of the reference pair (tooth 0 / tooth 0)."""
        rb_a, rb_b = self.base_radius_m
        C = self.center_distance_m
        if not self.internal and C <= rb_a + rb_b:
            raise GeometryError(f"center_distance_m = {C:.6g} m must exceed r_b1 + r_b2 = {rb_a + rb_b:.6g} m")
        if self.internal and C <= abs(rb_b - rb_a):
            raise GeometryError(f"center_distance_m = {C:.6g} m must exceed |r_b2 - r_b1| = {abs(rb_b - rb_a):.6g} m")
        if self.internal:
            rw_a, rw_b = C * rb_a / abs(rb_b - rb_a), C * rb_b / abs(rb_b - rb_a)
        else:
            rw_a = C * rb_a / (rb_a + rb_b)
            rw_b = C - rw_a
        self.operating_pitch_radius_m = (rw_a, rw_b)
        # pitch point P = (rw_a, 0); gear_b's centre on the far side (external) or the same side (internal)
        self._theta_P_b = 0.0 if self.internal else math.pi
        self._O = (np.zeros(2), np.array([rw_a - rw_b * math.cos(self._theta_P_b), 0.0]))

        off_flank = []

        def polar_at(g: int, r: float) -> float:
            fl = self._flank[g]
            inv = fl.region == 2
            rr = fl.radius[inv]
            ang = np.arctan2(fl.xy0[inv, 1], fl.xy0[inv, 0])
            o = np.argsort(rr)
            if rr.min() <= r <= rr.max():
                return float(np.interp(r, rr[o], ang[o]))
            # the pitch point lies beyond this flank's involute (a tip-shortened or profile-shifted tooth whose
            # tip circle does not reach the operating pitch circle): the involute extended to r
            off_flank.append((g, r, float(rr.min()), float(rr.max())))
            return _extended_involute_polar(rr[o], ang[o], self.base_radius_m[g], r)

        self._phi0 = (-polar_at(0, rw_a), self._theta_P_b - polar_at(1, rw_b))
        self.pitch_point_off_flank = tuple(self.gear_names[g] for g, *_ in off_flank)
        if off_flank:
            self._check_path_window(off_flank)

    def active_path_phases(self) -> tuple[float, float]:
        """Ends of the involute contact path on the line of action [base pitches], from the operating pitch point.

        The path is where both loaded flanks' involutes (their sampled involute radii) overlap on the line of
        action, ``xi`` the roll length of gear_a (``xi_P = sqrt(r_wa^2 - r_ba^2)`` at the pitch point) and
        ``L_b = (t_wa + t_wb) - xi`` (external) or ``L_b = xi + (t_wb - t_wa)`` (internal) that of gear_b, with
        ``t_w = sqrt(r_w^2 - r_b^2)``.  Returns ``((xi_lo - xi_P) / p_b, (xi_hi - xi_P) / p_b)``, ``p_b`` the base
        pitch; both of one sign when the pitch point lies off a flank."""
        t_w = [math.sqrt(max(rw * rw - rb * rb, 0.0)) for rw, rb in zip(self.operating_pitch_radius_m,
                                                                         self.base_radius_m)]
        roll = []
        for fl, rb in zip(self._flank, self.base_radius_m):
            rr = fl.radius[fl.region == 2]
            roll.append((math.sqrt(max(float(rr.min()) ** 2 - rb * rb, 0.0)),
                         math.sqrt(max(float(rr.max()) ** 2 - rb * rb, 0.0))))
        (a0, a1), (b0, b1) = roll
        if self.internal:
            d = t_w[1] - t_w[0]
            lo, hi = max(a0, b0 - d), min(a1, b1 - d)
        else:
            t = t_w[0] + t_w[1]
            lo, hi = max(a0, t - b1), min(a1, t - b0)
        p_b = 2 * math.pi * self.base_radius_m[0] / self.teeth[0]
        return (lo - t_w[0]) / p_b, (hi - t_w[0]) / p_b

    def _check_path_window(self, off_flank: Sequence[tuple[int, float, float, float]]) -> None:
        """With the pitch point off a flank the contact path lies to one side of it: refuse a path that reaches
        beyond the ``pair_window`` tooth pairs examined (and reported) on each side of the reference pair."""
        lo, hi = self.active_path_phases()
        W = self.options.pair_window
        if not lo < hi:
            raise GeometryError(f"mesh '{self.mesh_name}': the involutes of '{self.gear_names[0]}' and "
                                f"'{self.gear_names[1]}' do not overlap on the line of action (no contact path)")
        reach = max(abs(lo), abs(hi))
        if reach < W:
            return
        fixes = []
        for g, r, r_min, r_max in off_flank:
            name = self.gear_names[g]
            internal = self.gear_internal[g]
            tip_side = (r < r_min) == internal
            if tip_side:
                fixes.append(f"the tip circle of '{name}' (d = {2e3 * (r_min if internal else r_max):.4f} mm) "
                             f"brought to the operating pitch circle (d_w = {2e3 * r:.4f} mm) by its tip alteration "
                             f"(tip_alteration_mm / tip_diameter_mm) or profile shift")
            else:
                fixes.append(f"the involute form circle of '{name}' (d = {2e3 * (r_max if internal else r_min):.4f} "
                             f"mm) brought to the operating pitch circle (d_w = {2e3 * r:.4f} mm) by its profile shift "
                             f"or basic rack (smaller dedendum or root radius)")
        raise GeometryError(
            f"mesh '{self.mesh_name}': the operating pitch point lies off the involute of "
            f"{' and '.join(repr(self.gear_names[g]) for g, *_ in off_flank)} and the contact path reaches "
            f"{reach:.3f} base pitches from it ({lo:.3f} .. {hi:.3f}), beyond the {W} tooth pairs the contact solver "
            f"examines on each side of it (ContactOptions.pair_window = {W}); fix: {'; '.join(fixes)}")

    def frame_angles(self, position: float) -> tuple[float, float]:
        """Rotation angles [rad] of the canonical frames of gear_a (CCW) and gear_b (CW external, CCW
        internal) at ``position``."""
        za, zb = self.teeth
        return (self._phi0[0] + 2 * math.pi * position / za,
                self._phi0[1] + self._sense_b * 2 * math.pi * position / zb)

    def _place(self, gear: int, tooth: int, phi: float):
        """Global points/normals of the canonical loaded flank of ``tooth`` (canonical numbering)."""
        fl = self._flank[gear]
        R = _rot(phi + 2 * math.pi * tooth / self.teeth[gear])
        O = self._O[gear]
        return fl.xy @ R.T + O, fl.normal @ R.T, O

    def _pair_geometry(self, pair: int, phi: tuple[float, float]):
        """Closest approach of pair ``pair`` (gear_a tooth -pair, gear_b tooth +pair)."""
        fa, fb = self._flank
        Pa, Na, Oa = self._place(0, self._pair_sign[0] * pair, phi[0])
        Pb, Nb, Ob = self._place(1, self._pair_sign[1] * pair, phi[1])
        rb_a, rb_b = self.base_radius_m
        best = None
        # samples of a's flank onto b's flank polyline, and b's onto a's
        for src, (P, Psrc_fl, Q, NQ, Qfl) in enumerate(((Pa, fa, Pb, Nb, fb), (Pb, fb, Pa, Na, fa))):
            cand = np.flatnonzero(Psrc_fl.contact)
            if cand.size == 0:
                continue
            gap, j, t, valid, nq = _project(P[cand], Q, NQ)
            foot = Q[j] * (1 - t)[:, None] + Q[j + 1] * t[:, None]
            # contact normal from a into b: b's inward normal (= -n_b) or a's outward normal
            nrm = -nq if src == 0 else nq
            cpt = 0.5 * (P[cand] + foot)
            ra_, rb_ = cpt - Oa, cpt - Ob
            h_a = -ra_[:, 1] * nrm[:, 0] + ra_[:, 0] * nrm[:, 1]        # (ẑ × (c - O_a)) · n
            # closing rotation of gear_b is against its sense of rotation
            h_b = self._sense_b * (rb_[:, 0] * nrm[:, 1] - rb_[:, 1] * nrm[:, 0])
            lam = 0.5 * (h_a / rb_a + h_b / rb_b)
            ok = valid & (lam > 0.05) & (gap > -0.25 * Qfl.s.max())
            # foot must land where the mating flank can carry a point contact (not the root land)
            ok &= Qfl.region[j] >= 1
            if not np.any(ok):
                continue
            ratio = np.where(ok, gap / np.where(ok, lam, 1.0), np.inf)
            k = int(np.argmin(ratio))
            if best is None or ratio[k] < best[0]:
                i_src = cand[k]
                best = (ratio[k], src, i_src, j[k], t[k], gap[k], lam[k], cpt[k], nrm[k])
        if best is None:
            return None
        _, src, i_src, j, t, gap, lam, cpt, nrm = best
        if src == 0:   # a's sample i_src, b's foot (j, t)
            sa, Ra = fa.s[i_src], fa.curvature[i_src]
            sb = fb.s[j] * (1 - t) + fb.s[j + 1] * t
            Rb = fb.curvature[j] * (1 - t) + fb.curvature[j + 1] * t
            tip = bool(fa.region[i_src] == 3 or i_src == len(fa.s) - 1)
            pb = Pb[j] * (1 - t) + Pb[j + 1] * t
        else:
            sb, Rb = fb.s[i_src], fb.curvature[i_src]
            sa = fa.s[j] * (1 - t) + fa.s[j + 1] * t
            Ra = fa.curvature[j] * (1 - t) + fa.curvature[j + 1] * t
            tip = bool(fb.region[i_src] == 3 or i_src == len(fb.s) - 1)
            pb = Pb[i_src]
        r_b = float(np.hypot(*(pb - Ob)))
        roll_b = math.sqrt(max(r_b * r_b / (rb_b * rb_b) - 1.0, 0.0))
        return dict(gap=float(gap), lam=float(lam), s_a=float(sa), s_b=float(sb), R_a=float(Ra), R_b=float(Rb),
                    point=cpt, normal=nrm, roll_b=roll_b, tip=tip)

    def _actual_tooth(self, gear: int, canonical: int) -> int:
        z = self.teeth[gear]
        return (-canonical if self._mirror else canonical) % z

    # -------------------------------------------------------------------- set-up per position
    def setup(self, position: float) -> PositionSetup:
        """Kinematics, gaps and linear compliance at ``position`` (cached per position)."""
        position = float(position)
        if not math.isfinite(position):
            raise SolverError(f"position must be finite (mesh cycles), got {position!r}")
        key = round(position, 12)
        hit = self._setup_cache.get(key)
        if hit is not None:
            return hit
        phi = self.frame_angles(position)
        W = self.options.pair_window
        centre = int(round(position))
        # the pairs around the one nearest the pitch point, and every reported offset
        pairs = np.arange(min(centre - W - 1, int(self.tooth_offsets[0])),
                          max(centre + W + 1, int(self.tooth_offsets[-1])) + 1)
        geo = [self._pair_geometry(int(p), phi) for p in pairs]
        ns = self.options.face_slices
        npair = len(pairs)
        gap_pair = np.array([g["gap"] if g else np.inf for g in geo])
        lam_pair = np.array([g["lam"] if g else 1.0 for g in geo])
        get = lambda k, d=np.nan: np.array([g[k] if g else d for g in geo], dtype=float)  # noqa: E731
        s_a, s_b = get("s_a"), get("s_b")
        fa, fb = self._flank
        s_a = np.clip(np.nan_to_num(s_a, nan=fa.s_min), fa.s_min, fa.s_max)
        s_b = np.clip(np.nan_to_num(s_b, nan=fb.s_min), fb.s_min, fb.s_max)
        pair_index = np.repeat(np.arange(npair), ns)
        slice_index = np.tile(np.arange(ns), npair)
        crown = self.crowning_slices_m.sum(axis=0)          # both gears, per slice
        g0 = gap_pair[pair_index] + crown[slice_index]
        lam = lam_pair[pair_index]
        tooth_a = np.array([self._actual_tooth(0, self._pair_sign[0] * int(p)) for p in pairs])
        tooth_b = np.array([self._actual_tooth(1, self._pair_sign[1] * int(p)) for p in pairs])
        # pair-level 2D compliance (per unit width) [m^2/N]
        Cp = np.zeros((npair, npair))
        for g, (fc, teeth, s) in enumerate(((self.compliance[0], tooth_a, s_a), (self.compliance[1], tooth_b, s_b))):
            z = self.teeth[g]
            dk = (teeth[:, None] - teeth[None, :]) % z          # response tooth - load tooth
            for k in np.unique(dk):
                m = dk == k
                ii, jj = np.nonzero(m)
                Cp[ii, jj] += fc.compliance(int(k), s[jj], s[ii])
        Cp = 0.5 * (Cp + Cp.T)
        b, bs = self.face_width_m, self.slice_width_m
        same_slice = slice_index[:, None] == slice_index[None, :]
        Cfull = Cp[np.ix_(pair_index, pair_index)]
        if self.options.face_coupling == "slices":
            C_lin = np.where(same_slice, Cfull / bs, 0.0)
        else:
            C_lin = Cfull / b
        R_a, R_b = get("R_a", 1.0), get("R_b", 1.0)
        # combined curvature (a concave ring flank has R < 0); a non-positive value (conforming surfaces,
        # only met off the line of action) is treated as a flat-on-flat contact of 1 m effective radius
        curv = 1.0 / R_a + 1.0 / R_b
        R_eff = 1.0 / np.maximum(curv, 1.0)
        # generalized mesh force per unit contact load: on gear_b +n at c, on gear_a -n (global frame)
        pts = np.array([g["point"] if g else [0.0, 0.0] for g in geo])
        nrm = np.array([g["normal"] if g else [0.0, 0.0] for g in geo])
        hub_op = {}
        for g, (O, sign) in enumerate(((self._O[0], -1.0), (self._O[1], 1.0))):
            r = pts - O
            hub_op[g] = sign * np.stack([nrm[:, 0], nrm[:, 1], r[:, 0] * nrm[:, 1] - r[:, 1] * nrm[:, 0]], axis=1)
        out = PositionSetup(
            position=position, pairs=pairs, g0=g0, lam=lam, C_lin=C_lin, pair_index=pair_index,
            slice_index=slice_index, slice_width_m=bs, s_a=s_a, s_b=s_b, roll_b_rad=get("roll_b"),
            R_a=R_a, R_b=R_b,
            point=np.array([g["point"] if g else [np.nan, np.nan] for g in geo]),
            normal=np.array([g["normal"] if g else [np.nan, np.nan] for g in geo]),
            tooth_a=tooth_a, tooth_b=tooth_b, phi=phi,
            tip_contact=np.array([bool(g["tip"]) if g else False for g in geo]),
            depth_a=np.asarray(self.compliance[0].depth(s_a), dtype=float),
            depth_b=np.asarray(self.compliance[1].depth(s_b), dtype=float), R_eff=R_eff,
            strain_op=self._strain_operator(pairs, tooth_a, tooth_b, s_a, s_b, self.tooth_offsets),
            hub_op=hub_op)
        if len(self._setup_cache) > 256:
            self._setup_cache.clear()
        self._setup_cache[key] = out
        return out

    # -------------------------------------------------------------------- near field
    def _hertz(self, setup: PositionSetup, w: np.ndarray):
        """Half-width [m] and peak pressure [Pa] per candidate for line loads ``w`` [N/m]."""
        R = setup.R_eff[setup.pair_index]
        w = np.maximum(w, 0.0)
        a = np.sqrt(4.0 * w * R / (math.pi * self._E_star))
        p0 = np.sqrt(w * self._E_star / (math.pi * R))
        return a, p0

    def _near_compliance(self, setup: PositionSetup, w_eval: np.ndarray) -> np.ndarray:
        """Secant near-field compliance [m/N] of each candidate (both bodies' half-space approach
        between surface and reading depth, :func:`hacgear_core.statics.nearfield.halfspace_approach_hertz`)
        at line load ``w_eval`` [N/m] (> 0)."""
        a, _ = self._hertz(setup, w_eval)
        pi = setup.pair_index
        (Ea, nua), (Eb, nub) = self.materials
        da = halfspace_approach_hertz(1.0, a, setup.depth_a[pi], Ea, nua, self.plane)
        db = halfspace_approach_hertz(1.0, a, setup.depth_b[pi], Eb, nub, self.plane)
        return (da + db) / setup.slice_width_m

    # -------------------------------------------------------------------- solves
    def _solve(self, setup: PositionSetup, *, force: float | None = None, deflection: float | None = None,
               warm: np.ndarray | None = None) -> ContactState:
        n = setup.g0.size
        bs = setup.slice_width_m
        F = np.asarray(warm, float).copy() if warm is not None and np.any(warm > 0) else np.zeros(n)
        res = None
        msg = "converged"
        ok = True
        total = 0
        for it in range(1, self.options.max_fixed_point + 1):
            # Newton step on the load-dependent near field delta_i(F_i) = c_s(F_i) F_i: tangent compliance
            # c_t on the diagonal and the offset (c_s - c_t) F_k in the separation; exact at the fixed point
            w = F / bs
            w_ref = max(float(w.max()), 1.0)
            w_eval = np.maximum(w, 1e-3 * w_ref)      # continuous floor (unloaded / barely loaded points)
            c_s = self._near_compliance(setup, w_eval)
            c_t = c_s + (self._near_compliance(setup, 1.01 * w_eval) - c_s) / 0.01
            c_t = np.maximum(c_t, 0.3 * c_s)
            C = setup.C_lin.copy()
            C[np.diag_indices(n)] += c_t
            g = setup.g0 + (c_s - c_t) * F
            res = solve_contact_lcp(C, g, setup.lam, mesh_force_N=force, mesh_deflection_m=deflection,
                                    warm_start=F if np.any(F > 0) else None)
            total += res.iterations
            if not res.success:
                ok, msg = False, res.message
                break
            Fn = res.force_N
            scale = max(float(Fn.max()), 1e-30)
            change = float(np.max(np.abs(Fn - F))) / scale
            F = Fn
            if change < self.options.fixed_point_tol or not np.any(Fn > 0):
                break
        else:
            ok, msg = False, f"near-field fixed point did not converge in {self.options.max_fixed_point} iterations"
        w = F / bs
        a, p0 = self._hertz(setup, w)
        a = np.where(F > 0, a, 0.0)
        p0 = np.where(F > 0, p0, 0.0)
        return ContactState(setup=setup, lcp=res, force_N=F, line_load_N_m=w, half_width_m=a, peak_pressure_Pa=p0,
                            mesh_force_N=float(res.mesh_force_N), mesh_deflection_m=float(res.mesh_deflection_m),
                            fixed_point_iterations=it, success=ok and res.success, message=msg,
                            lcp_iterations=total)

    def no_load_deflection(self, position: float) -> float:
        """No-load mesh deflection [m] at ``position``: smallest rigid deflection that closes a gap."""
        s = self.setup(position)
        fin = np.isfinite(s.g0)
        if not np.any(fin):
            raise SolverError(f"mesh '{self.mesh_name}': no tooth pair can touch at position {position}")
        return float(np.min(s.g0[fin] / s.lam[fin]))

    @staticmethod
    def _modified(setup: PositionSetup, gap_offset_m: np.ndarray | None,
                  compliance_offset_m_N: np.ndarray | None) -> PositionSetup:
        """``setup`` with ``gap_offset_m`` (n,) added to the initial separations and ``compliance_offset_m_N``
        (n, n) added to the linear compliance (both optional; unchanged when None)."""
        if gap_offset_m is not None:
            off = np.asarray(gap_offset_m, float)
            if off.shape != setup.g0.shape:
                raise SolverError(f"gap_offset_m must have shape {setup.g0.shape}, got {off.shape}")
            setup = replace(setup, g0=setup.g0 + off)
        if compliance_offset_m_N is not None:
            dc = np.asarray(compliance_offset_m_N, float)
            if dc.shape != setup.C_lin.shape:
                raise SolverError(f"compliance_offset_m_N must have shape {setup.C_lin.shape}, got {dc.shape}")
            setup = replace(setup, C_lin=setup.C_lin + dc)
        return setup

    def state_load(self, position: float, mesh_force_N: float, warm: np.ndarray | None = None,
                   gap_offset_m: np.ndarray | None = None,
                   compliance_offset_m_N: np.ndarray | None = None) -> ContactState:
        """Load-controlled solve (mesh force [N] >= 0) → :class:`ContactState`.  ``gap_offset_m`` (n,) adds to the
        initial separation of every candidate (e.g. the deformation caused by loads outside this mesh);
        ``compliance_offset_m_N`` (n, n) [m/N] adds to the linear compliance of the candidates (e.g. minus the part
        of the bodies' compliance that a dynamic model carries in its own coordinates)."""
        W = float(mesh_force_N)
        if not (math.isfinite(W) and W >= 0):
            raise SolverError(f"mesh_force_N must be finite and >= 0 N, got {mesh_force_N!r}")
        setup = self._modified(self.setup(position), gap_offset_m, compliance_offset_m_N)
        return self._solve(setup, force=W, warm=warm)

    def state_deflection(self, position: float, mesh_deflection_m: float,
                         warm: np.ndarray | None = None, gap_offset_m: np.ndarray | None = None,
                         compliance_offset_m_N: np.ndarray | None = None) -> ContactState:
        """Deflection-controlled solve (mesh deflection [m]) → :class:`ContactState`; ``gap_offset_m`` and
        ``compliance_offset_m_N`` as in :meth:`state_load`."""
        x = float(mesh_deflection_m)
        if not math.isfinite(x):
            raise SolverError(f"mesh_deflection_m must be finite, got {mesh_deflection_m!r}")
        setup = self._modified(self.setup(position), gap_offset_m, compliance_offset_m_N)
        return self._solve(setup, deflection=x, warm=warm)

    # -------------------------------------------------------------------- outputs
    def pair_results(self, st: ContactState) -> dict[str, np.ndarray]:
        """Per-pair quantities of a state for the pairs of ``setup.pairs``: load [N], roll angle on
        gear_b [rad] (NaN unloaded), profile coordinates [m], max half-width [m], max pressure [Pa]."""
        s = st.setup
        npair = len(s.pairs)
        load = np.bincount(s.pair_index, weights=st.force_N, minlength=npair)
        hw = np.zeros(npair)
        pp = np.zeros(npair)
        np.maximum.at(hw, s.pair_index, st.half_width_m)
        np.maximum.at(pp, s.pair_index, st.peak_pressure_Pa)
        loaded = load > 0
        return dict(load_N=load, roll_b_rad=np.where(loaded, s.roll_b_rad, np.nan),
                    s_a_m=np.where(loaded, s.s_a, np.nan), s_b_m=np.where(loaded, s.s_b, np.nan),
                    half_width_m=hw, peak_pressure_Pa=pp, tip_contact=s.tip_contact & loaded,
                    **split_pressure(npair, s.pair_index, st.peak_pressure_Pa, s.tip_contact))

    def _strain_operator(self, setup_pairs: np.ndarray, tooth_a: np.ndarray, tooth_b: np.ndarray, s_a: np.ndarray,
                         s_b: np.ndarray, offsets: np.ndarray) -> dict[str, np.ndarray]:
        """gauge -> (len(offsets), Np) strain on the tooth of each offset per unit line load at each pair."""
        out = {}
        for gear, gi, name in self.gauges:
            fc = self.compliance[gear]
            z = self.teeth[gear]
            t_load = tooth_a if gear == 0 else tooth_b
            s_load = s_a if gear == 0 else s_b
            resp = np.array([self._actual_tooth(gear, self._pair_sign[gear] * int(k)) for k in offsets])
            M = np.zeros((len(offsets), len(setup_pairs)))
            dk = (resp[:, None] - t_load[None, :]) % z
            for k in np.unique(dk):
                ii, jj = np.nonzero(dk == k)
                M[ii, jj] = fc.strain(gi, int(k), s_load[jj])
            out[name] = M
        return out

    def strains(self, st: ContactState, offsets: Sequence[int] | None = None) -> dict[str, np.ndarray]:
        """Gauge strains [-] at the face centre on the teeth of pair offsets ``offsets`` (relative to
        the reference pair; default ``tooth_offsets``) → gauge name -> (len(offsets),)."""
        s = st.setup
        if offsets is None:
            ops = s.strain_op
        else:
            ops = self._strain_operator(s.pairs, s.tooth_a, s.tooth_b, s.s_a, s.s_b, np.asarray(offsets, int))
        ns = self.options.face_slices
        Wps = np.zeros((len(s.pairs), ns))                 # line load per pair and slice [N/m]
        np.add.at(Wps, (s.pair_index, s.slice_index), st.line_load_N_m)
        out = {}
        for name, M in ops.items():
            eps = M @ Wps                                  # (n_off, ns)
            if self.options.face_coupling == "slices" and ns > 1:
                out[name] = np.array([np.interp(0.0, self.slice_z_m, row) for row in eps])
            elif self.options.face_coupling == "slices":
                out[name] = eps[:, 0]
            else:
                out[name] = eps.sum(axis=1) * s.slice_width_m / self.face_width_m
        return out

    def surface_modulus_Pa(self, gauge: str) -> float:
        """Factor from the surface strain along the profile to the surface stress along it at gauge
        ``"<gear>/<gauge>"`` [Pa]: at a traction-free surface (normal stress 0) the tangential stress is
        ``E * eps_t`` in plane stress and ``E / (1 - nu**2) * eps_t`` in plane strain."""
        for gear, _, name in self.gauges:
            if name == gauge:
                fc = self.compliance[gear]
                e, nu = float(fc.youngs_modulus_Pa), float(fc.poisson_ratio)
                return e if fc.plane == "stress" else e / (1.0 - nu * nu)
        raise ModelError(f"no gauge {gauge!r}; gauges: {', '.join(n for _, _, n in self.gauges) or '(none)'}")

    def stresses(self, st: ContactState, offsets: Sequence[int] | None = None,
                 strains: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
        """Root surface stress [Pa] along the profile at each gauge (the root bending stress a gauge
        bonded along the profile measures), from :meth:`strains` (or the given ``strains``) and
        :meth:`surface_modulus_Pa` → gauge name -> (len(offsets),)."""
        eps = self.strains(st, offsets) if strains is None else strains
        return {name: self.surface_modulus_Pa(name) * v for name, v in eps.items()}

    def hub_reactions(self, st: ContactState) -> dict[str, np.ndarray]:
        """Generalized mesh force on each gear ``[Fx N, Fy N, Mz N m]`` (resultant of the contact forces
        about the gear centre = what the hub must react), in the global frame: gear_a at the origin,
        gear_b at ``(+C, 0)`` (external mesh, or internal with gear_a the ring) or ``(-C, 0)`` (gear_b the
        ring), the driver turning counter-clockwise (the picture mirrored when gear_a's coast flank is
        loaded)."""
        s = st.setup
        Fp = np.bincount(s.pair_index, weights=st.force_N, minlength=len(s.pairs))
        return {self.gear_names[g]: Fp @ s.hub_op[g] for g in (0, 1)}

    def to_solution(self, st: ContactState):
        """:class:`hacgear_core.statics.StaticSolution` of a state (per tooth offset)."""
        pr = self.pair_results(st)
        s = st.setup
        offs = self.tooth_offsets
        sel = np.searchsorted(s.pairs, offs)
        inside = (sel < len(s.pairs)) & (s.pairs[np.clip(sel, 0, len(s.pairs) - 1)] == offs)
        sel = np.clip(sel, 0, len(s.pairs) - 1)

        def pick(a, fill):
            return np.where(inside, a[sel], fill)

        return StaticSolution(success=bool(st.success), message=st.message,
                              iterations=int(st.lcp_iterations) + int(st.fixed_point_iterations),
                              position=float(s.position), mesh_force_N=float(st.mesh_force_N),
                              mesh_deflection_m=float(st.mesh_deflection_m), tooth_load_N=pick(pr["load_N"], 0.0),
                              contact_roll_deg=pick(np.degrees(pr["roll_b_rad"]), np.nan),
                              half_width_m=pick(pr["half_width_m"], 0.0),
                              peak_pressure_Pa=pick(pr["peak_pressure_Pa"], 0.0),
                              flank_pressure_Pa=pick(pr["flank_pressure_Pa"], 0.0),
                              edge_pressure_Pa=pick(pr["edge_pressure_Pa"], 0.0),
                              strain=(eps := self.strains(st)), stress=self.stresses(st, strains=eps),
                              hub_reaction=self.hub_reactions(st),
                              contact_s_m=np.stack([pick(pr["s_a_m"], np.nan), pick(pr["s_b_m"], np.nan)], axis=1))

    def solve_load(self, position: float, mesh_force_N: float):
        """Load control: mesh force [N] → :class:`~hacgear_core.statics.StaticSolution`."""
        return self.to_solution(self.state_load(position, mesh_force_N))

    def solve_deflection(self, position: float, mesh_deflection_m: float):
        """Deflection control: mesh deflection [m] → :class:`~hacgear_core.statics.StaticSolution`."""
        return self.to_solution(self.state_deflection(position, mesh_deflection_m))

    def solve_position(self, position: float, loads_N, deflections_m):
        """Batch at one position (set-up and warm starts reused): load-controlled solutions for
        ``loads_N`` and deflection-controlled ones for ``deflections_m``."""
        loads = np.asarray(loads_N, dtype=float).ravel()
        defl = np.asarray(deflections_m, dtype=float).ravel()
        self.setup(position)
        return (self._warm_started(self.state_load, position, loads),
                self._warm_started(self.state_deflection, position, defl))

    def _warm_started(self, state_fn, position: float, values: np.ndarray) -> list:
        """Solve ``state_fn(position, v)`` for each value in order, each warm-started from the last
        loaded contact state."""
        out, warm = [], None
        for v in values:
            st = state_fn(position, v, warm=warm)
            if st.success and np.any(st.force_N > 0):
                warm = st.force_N
            out.append(self.to_solution(st))
        return out

    # pickling: drop the set-up cache
    def __getstate__(self):
        d = self.__dict__.copy()
        d["_setup_cache"] = {}
        return d


# =============================================================================================
# Mesh stiffness over a mesh cycle
# =============================================================================================

# =============================================================================================
# Model → solver
# =============================================================================================
def _compliance_request(model: Model, gear: Any, gg: Any, loaded: str, glist: Sequence[Any], fe_options: Any,
                        plane: str) -> dict[str, Any]:
    """Keyword arguments of :func:`~hacgear_core.statics.fe.gear_compliance` for model gear ``gear`` loaded on its
    ``loaded`` flank with model gauges ``glist``: the model's ``[statics] fe_lengths`` sets the mesh options (unless
    ``fe_options`` is given) and the sample spacing / fillet margin / reading depth."""
    mode = model.statics.fe_lengths
    opts = fe_options if fe_options is not None else fe_mod.gear_mesh_options(gear, mode)
    return dict(gg=gg, material=fe_mod.ElasticMaterial(gear.material.youngs_modulus_Pa, gear.material.poisson_ratio,
                                                       plane),
                side=loaded, gauges=tuple(fe_mod.Gauge(x.name, x.flank, x.radius_m) for x in glist), options=opts,
                **fe_mod.compliance_lengths(gear, mode))


def spur_twist_axis(model: Model) -> bool:
    """True where ``model``'s spur meshes get tables with a twist axis: its kind takes them
    (:attr:`~hacgear_core.kinds.base.Kind.face_twist`, a spur pair) and ``[statics] twist_points > 1``; the
    face-resolving solver then computes them (elastic face coupling by default, or independent slices)."""
    return bool(kind_of(model).face_twist and model.statics.twist_points > 1)


def default_contact_options(model: Model, mesh_name: str, **kw: Any) -> ContactOptions:
    """:class:`ContactOptions` of mesh ``mesh_name`` with the model's face slices and ``kw``; under module-scaled
    lengths (``[statics] fe_lengths``, :func:`~hacgear_core.statics.fe.length_scale` of the mesh's first gear)
    the sharp-tip corner radius is the default 0.1 mm times the scale."""
    meshes = {x.name: x for x in model.meshes}
    if mesh_name not in meshes:
        raise ModelError(f"unknown mesh {mesh_name!r}; the model has: {', '.join(meshes) or '(none)'}")
    ga = {g.name: g for g in model.gears}[meshes[mesh_name].gear_a]
    f = fe_mod.length_scale(ga, model.statics.fe_lengths)
    if f is not None and "corner_radius_m" not in kw:
        kw["corner_radius_m"] = ContactOptions.corner_radius_m * f
    kw.setdefault("face_slices", model.statics.face_slices)
    return ContactOptions(**kw)


def prebuild_compliances(model: Any, mesh_names: Sequence[str] | None = None, sides: Sequence[str] = ("drive",),
                         *, plane: str = "stress", face_coupling: str | None = None, log: Any = None
                         ) -> dict[str, int]:
    """Fill the on-disk cache with the finite-element compliances the contact solvers of ``mesh_names`` (default:
    every mesh) on ``sides`` will read, building and factorising each gear's FE model once for all its loaded
    flanks (a planet in two meshes, drive and coast: one build, not four), one gear at a time; solvers built
    afterwards (in ``hacgear statics``'s worker processes) read the cache and build nothing.  The 3D face influence
    (:func:`hacgear_core.statics.fe3d.face_influence`) likewise, one 3D tooth-sector model per gear, for the meshes
    whose solvers use it: ``face_coupling`` ``"elastic"``, or None (the solvers' defaults) with a helical gear in
    the mesh.  Returns ``{gear name: FE builds}`` (2D and 3D models; 0: everything was cached already)."""
    if not isinstance(model, Model):
        model = load_model(model)
    meshes = {m.name: m for m in model.meshes}
    gears = {g.name: g for g in model.gears}
    from hacgear_core.statics import fe3d

    requests: dict[str, list] = {}
    requests3d: dict[str, list] = {}
    for name in (mesh_names if mesh_names is not None else list(meshes)):
        mesh = meshes[name]
        elastic = face_coupling == "elastic" or (face_coupling is None and (
            gears[mesh.gear_a].is_helical or gears[mesh.gear_b].is_helical or spur_twist_axis(model)))
        for side in sides:
            fl = (mesh.flank_a, mesh.flank_b) if side == "drive" else (_OTHER_FLANK[mesh.flank_a],
                                                                       _OTHER_FLANK[mesh.flank_b])
            for gname, loaded in zip((mesh.gear_a, mesh.gear_b), fl):
                requests.setdefault(gname, []).append(loaded)
                if elastic:
                    requests3d.setdefault(gname, []).append(loaded)
    builds: dict[str, int] = {}
    for gname, flanks in requests.items():
        g = gears[gname]
        gg = gear_geometry(g)
        built: list = []

        def shared(build, what):
            if not built:
                if log is not None:
                    log(f"{what} of gear {gname}: meshing and factorising (once for its loaded flank(s))")
                built.append(build())
            return built[0]

        for loaded in dict.fromkeys(flanks):
            req = _compliance_request(model, g, gg, loaded, g.gauges, None, plane)
            fe_mod.gear_compliance(**req, cache=True, fe=lambda req=req: shared(
                lambda: fe_mod.build_gear_fe(req["gg"], req["material"], req["options"]), "finite-element model"))
        builds[gname] = len(built)
        built.clear()
        if gname in requests3d:
            mat3 = fe3d.material_of(g, plane)
            opts3 = fe3d.gear_mesh3d_options(g, model.statics.fe_lengths, model.statics.face_slices)
            gauges3 = tuple((x.name, x.flank, x.radius_m, float(getattr(x, "face_fraction", 0.5))) for x in g.gauges)
            for loaded in dict.fromkeys(requests3d[gname]):
                fe3d.face_influence(gg, mat3, loaded, gauges=gauges3, options=opts3, cache=True, fe=lambda: shared(
                    lambda: fe3d.ToothSectorFE(gg, mat3, opts3), "3D tooth-sector model"))
            builds[gname] += len(built)
            built.clear()
        fe_mod.release_freed_memory()
    return builds


def mesh_solver_inputs(model: Any, mesh_name: str, *, fe_options: Any = None, plane: str = "stress",
                       cache: bool = True, gauges: Sequence[tuple[str, Any]] | None = None,
                       side: str = "drive") -> dict[str, Any]:
    """What every static contact solver of mesh ``mesh_name`` of ``model`` is built from (spur and helical):
    gear geometries, loaded flanks, centre distance, finite-element compliances of both gears (cached on disk),
    gauges, the overlapping face width and its centre, crowning per gear, materials.  ``gauges``: ``(gear name,
    model Gauge)`` pairs replacing the model's gauges.  ``side``: ``"drive"`` loads the mesh's flanks
    (``flank_a``/``flank_b`` of the model); ``"coast"`` the other flank of each gear (the contact after a torque
    reversal).  Returns a dict; ``mesh``, ``gears`` (model gears), ``gauge_models`` (per gear index, the model
    gauges in the order of ``gauges``) and ``z_centre_m`` are extra to the :class:`MeshContactSolver` keyword
    arguments."""
    if side not in ("drive", "coast"):
        raise ModelError(f"side = {side!r}; allowed: drive | coast")
    if not isinstance(model, Model):
        model = load_model(model)
    meshes = {m.name: m for m in model.meshes}
    if mesh_name not in meshes:
        raise ModelError(f"unknown mesh {mesh_name!r}; the model has: {', '.join(meshes) or '(none)'}")
    mesh = meshes[mesh_name]
    flank_a, flank_b = mesh.flank_a, mesh.flank_b
    if side == "coast":
        flank_a, flank_b = (_OTHER_FLANK[flank_a], _OTHER_FLANK[flank_b])
    gears = {g.name: g for g in model.gears}
    ga, gb = gears[mesh.gear_a], gears[mesh.gear_b]
    mg = mesh_geometry(model, mesh_name)
    ggs = (gear_geometry(ga), gear_geometry(gb))
    comps, gauge_list, gauge_models = [], [], ([], [])
    for gi, (g, gg, loaded) in enumerate(((ga, ggs[0], flank_a), (gb, ggs[1], flank_b))):
        glist = g.gauges if gauges is None else tuple(x for name, x in gauges if name == g.name)
        comps.append(fe_mod.gear_compliance(**_compliance_request(model, g, gg, loaded, glist, fe_options, plane),
                                            cache=cache))
        gauge_list += [(gi, k, f"{g.name}/{x.name}") for k, x in enumerate(glist)]
        gauge_models[gi].extend(glist)
    # overlapping face width (axial positions of both gears)
    lo = max(ga.axial_position_m - ga.face_width_m / 2, gb.axial_position_m - gb.face_width_m / 2)
    hi = min(ga.axial_position_m + ga.face_width_m / 2, gb.axial_position_m + gb.face_width_m / 2)
    if hi <= lo:
        raise ModelError(f"mesh '{mesh_name}': the face widths of {ga.name} and {gb.name} do not overlap axially")
    zc = 0.5 * (lo + hi)

    def crown(gear, gg):
        fn = getattr(gg, "crowning_m", None)
        off = zc - gear.axial_position_m
        if fn is not None:
            return lambda zz: float(np.asarray(fn(np.asarray(zz + off)), dtype=float))
        c, b = gear.lead_crowning_m, gear.face_width_m
        return lambda zz: c * (2 * (zz + off) / b) ** 2

    return dict(
        mesh_name=mesh_name, gear_names=(ga.name, gb.name), geometry=ggs, flanks=(flank_a, flank_b),
        center_distance_m=float(mg.center_distance_m), compliance=tuple(comps), face_width_m=hi - lo,
        crowning=(crown(ga, ggs[0]), crown(gb, ggs[1])),
        materials=((ga.material.youngs_modulus_Pa, ga.material.poisson_ratio),
                   (gb.material.youngs_modulus_Pa, gb.material.poisson_ratio)),
        gauges=gauge_list, plane=plane, mesh=mesh, gears=(ga, gb), gauge_models=gauge_models, z_centre_m=zc,
        model=model)


def make_mesh_solver(model: Any, mesh_name: str, *, options: ContactOptions | None = None,
                     fe_options: Any = None, plane: str = "stress", cache: bool = True,
                     gauges: Sequence[tuple[str, Any]] | None = None, side: str = "drive") -> MeshContactSolver:
    """Build the static contact solver of spur mesh ``mesh_name`` of ``model`` (a :class:`~hacgear_core.model.Model`,
    or a path / system name).  Finite-element influence coefficients come from
    :func:`hacgear_core.statics.fe.gear_compliance` (cached on disk), so rebuilding in a worker is cheap.
    Helical meshes: :func:`hacgear_core.statics.helical.make_solver` (which dispatches on the gears).

    ``options`` default: :func:`default_contact_options` (the model's face slices; the corner radius scaled with
    the module under ``[statics] fe_lengths``); ``fe_options``: a :class:`hacgear_core.statics.fe.MeshOptions`
    (default: :func:`hacgear_core.statics.fe.gear_mesh_options` per gear); ``gauges``: ``(gear name, model Gauge)``
    pairs replacing the model's gauges (e.g. a row of points along a fillet).  ``side``: ``"drive"`` loads the mesh's flanks;
    ``"coast"`` the other flank of each gear, in that flank pair's own canonical picture and positions —
    :func:`hacgear_core.statics.coast.make_coast_solver` maps it onto the drive side's positions and deflections.
    """
    if not isinstance(model, Model):
        model = load_model(model)
    meshes = {m.name: m for m in model.meshes}
    if mesh_name in meshes:
        gears = {g.name: g for g in model.gears}
        m = meshes[mesh_name]
        if gears[m.gear_a].is_helical or gears[m.gear_b].is_helical:
            raise SolverError(f"mesh '{mesh_name}' is helical: build its solver with "
                              "hacgear_core.statics.helical.make_solver")
    if options is None:
        options = default_contact_options(model, mesh_name)
    kw = mesh_solver_inputs(model, mesh_name, fe_options=fe_options, plane=plane, cache=cache, gauges=gauges,
                            side=side)
    for k in ("mesh", "gears", "gauge_models", "z_centre_m", "model"):
        kw.pop(k)
    fl = kw["flanks"]
    return MeshContactSolver(
        **kw, options=options,
        description=f"FE far field + Hertz near field, {options.face_slices} slices ({options.face_coupling}), "
                    f"mesh {mesh_name} of {model.name}" + ("" if side == "drive" else
                                                           f", {side} side ({fl[0]}/{fl[1]} flanks)"))
