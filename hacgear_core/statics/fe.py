"""Finite-element far field of a gear: mesh, assembly, factorisation, influence coefficients.

What this module does
---------------------
* Meshes ONE tooth sector of the gear (tooth 0, between the mid-root spaces at
  ``-pi/z`` and ``+pi/z``, down to the hub circle) with gmsh, with periodic (rotated)
  node distributions on the two radial cuts, and replicates it ``z`` times.  The
  whole-gear mesh is therefore *exactly* cyclically symmetric: the response on tooth
  ``k`` to a load on tooth ``j`` is the response on tooth ``k-j`` to the same load on
  tooth 0, rotated by ``2 pi j/z``.  Size fields refine the flanks (involute and tip
  rounding) and the fillets.
* Webbed blanks (``gg.web`` not None: ``inner_radius_m``, ``outer_radius_m``,
  ``relative_thickness`` = web thickness / face width): the sector is three gmsh surfaces
  (hub, web, rim + tooth) sharing the two web arcs, so the mesh conforms to both circles and
  the cuts stay periodic; the stiffness of the web triangles is scaled by
  ``relative_thickness`` (:attr:`GearMesh.sector_thickness`), rim, hub and teeth keep 1.
* Assembles 2D linear elasticity with scikit-fem P2 triangles (plane stress by
  default, thickness 1 m: everything is **per unit face width**) and ties every node of
  the hub circle (the bore of an external gear, the rim of an internal one) to a rigid
  hub that is held fixed (deflections are relative to the hub; the lumped coordinates
  of the dynamics move the hub rigidly).
* Solves by cyclic symmetry (:class:`CyclicGearFE`, the default): only the sector is
  assembled; a discrete Fourier transform over the ``z`` sectors splits the whole-gear
  problem into ``z//2+1`` sector-size harmonic problems, each factorised once
  (``scipy.sparse.linalg.splu``), so unit loads on tooth 0 give the response of every
  tooth exactly.  :class:`GearFE` (the replicated whole-gear mesh, one factorisation)
  gives the same numbers to round-off and is kept as the reference.
* :func:`gear_compliance` solves unit normal loads at sample points of tooth 0's
  flank and returns a :class:`FlankCompliance`: far-field normal compliances for every
  tooth ``k`` (read at a depth ``d`` below each point, so they do not depend on the
  mesh), surface strains at named gauges and the hub force per unit load; results are
  cached on disk (``$HACGEAR_CACHE_DIR`` or ``~/.cache/hacgear``) keyed by a hash of
  every input.

The analytical near field (Hertz/half-space) is in :mod:`hacgear_core.statics.nearfield`; the
contact solver adds, for every loaded contact and every body,
:meth:`FlankCompliance.self_approach` to the far-field matrix.

Geometry input (duck-typed, the contract of :mod:`hacgear_core.geometry`)
-------------------------------------------------------------------------
``gg.z`` (int), ``gg.internal`` (bool), ``gg.bore_radius_m`` (hub circle radius: bore
of an external gear, outer rim of an internal one), optional ``gg.web`` (None or an object
with ``inner_radius_m``, ``outer_radius_m``, ``relative_thickness``; external gears only),
``gg.tooth_boundary(n_per_flank)`` (``.xy`` (M,2) from the coast mid-root space to the drive mid-root space, ``.side``,
``.region``), ``gg.flank(side, n)`` (``.xy``, ``.normal`` (outward), ``.s`` (arc length
from the tip), ``.radius``, ``.region`` (0 root land, 1 fillet, 2 involute, 3 tip
rounding), ``.roll_angle_rad``, ``.curvature_radius_m``), ordered root to tip.

Sign conventions
----------------
Loads are compressive normal line loads: a load ``w > 0`` [N/m] at a flank point acts
along the *inward* normal ``-n``.  Compliances are displacements along the inward
normal per unit ``w`` [m per N/m = m^2/N]; a slice of width ``b`` carrying ``F``
newtons has ``w = F/b``.  Tooth ``k`` sits at angle ``2 pi k/z`` (counter-clockwise).
"""
from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import gc
import hashlib
import json
import math
import os
import threading
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from hacgear_core.errors import GeometryError, ModelError, SolverError
from hacgear_core.statics.nearfield import halfspace_approach_hertz, halfspace_approach_point

__all__ = [
    "FE_CODE_VERSION",
    "gmsh_model",
    "write_npz",
    "read_npz",
    "PlaneFE",
    "ElasticMaterial",
    "MeshOptions",
    "REFERENCE_MODULE_M",
    "COMPLIANCE_LENGTHS_M",
    "normal_module_m",
    "length_scale",
    "gear_mesh_options",
    "compliance_lengths",
    "Gauge",
    "GearMesh",
    "GearFE",
    "CyclicGearFE",
    "FlankCompliance",
    "mesh_gear",
    "build_gear_fe",
    "gear_compliance",
    "cache_dir",
    "rotation",
]

#: bump when anything changes the numbers produced (part of every cache key)
FE_CODE_VERSION = "fe-6"

_GMSH_LOCK = threading.Lock()


@contextlib.contextmanager
def gmsh_model(prefix: str):
    """A fresh gmsh model for one mesh, yielding ``gmsh.model.geo``.  gmsh is process-global: one model at a time
    (every FE mesher of the package holds this lock), initialised and finalised here unless someone else has
    initialised gmsh; the model is removed afterwards."""
    import gmsh  # imported where a mesh is made: FMUs and table readers never need it

    with _GMSH_LOCK:
        own = not gmsh.isInitialized()
        if own:
            gmsh.initialize(readConfigFiles=False, interruptible=False)
        name = f"{prefix}_{os.getpid()}_{threading.get_ident()}_{time.monotonic_ns()}"
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.model.add(name)
            yield gmsh.model.geo
        finally:
            try:
                gmsh.model.remove()
            except Exception:
                pass
            if own:
                gmsh.finalize()


# ----------------------------------------------------------------------------- inputs
@dataclass(frozen=True)
class ElasticMaterial:
    """Isotropic linear-elastic material of a gear body.

    Parameters
    ----------
    youngs_modulus_Pa : float
        Young's modulus [Pa], > 0.
    poisson_ratio : float
        Poisson's ratio [-], in (-1, 0.5).
    plane : {"stress", "strain"}
        2D idealisation; ``"stress"`` (thin slices / free faces) is the project default.
    """

    youngs_modulus_Pa: float
    poisson_ratio: float
    plane: str = "stress"

    def __post_init__(self):
        E, nu = self.youngs_modulus_Pa, self.poisson_ratio
        if not (isinstance(E, (int, float, np.floating)) and np.isfinite(E) and 1e6 <= E <= 1e13):
            raise ModelError(f"youngs_modulus_Pa must be in [1e6, 1e13] Pa, got {E!r}")
        if not (isinstance(nu, (int, float, np.floating)) and np.isfinite(nu) and -1.0 < nu < 0.5):
            raise ModelError(f"poisson_ratio must be in (-1, 0.5), got {nu!r}")
        if self.plane not in ("stress", "strain"):
            raise ModelError(f"plane must be 'stress' or 'strain', got {self.plane!r}")

    @property
    def lame(self) -> tuple[float, float]:
        """In-plane Lamé parameters ``(lambda, mu)`` [Pa] for the chosen plane idealisation."""
        E, nu = float(self.youngs_modulus_Pa), float(self.poisson_ratio)
        mu = E / (2.0 * (1.0 + nu))
        if self.plane == "stress":
            return E * nu / (1.0 - nu * nu), mu
        return E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), mu

    @classmethod
    def coerce(cls, m: Any, plane: str | None = None) -> "ElasticMaterial":
        """Accept an :class:`ElasticMaterial` or any object with ``youngs_modulus_Pa`` (or
        ``youngs_modulus_GPa``) and ``poisson_ratio`` attributes (e.g. a model material)."""
        if isinstance(m, cls):
            return m if plane is None or plane == m.plane else replace(m, plane=plane)
        E = getattr(m, "youngs_modulus_Pa", None)
        if E is None and getattr(m, "youngs_modulus_GPa", None) is not None:
            E = float(m.youngs_modulus_GPa) * 1e9
        nu = getattr(m, "poisson_ratio", None)
        if E is None or nu is None:
            raise ModelError("material needs youngs_modulus_Pa (or youngs_modulus_GPa) and poisson_ratio")
        return cls(float(E), float(nu), plane or getattr(m, "plane", "stress"))


@dataclass(frozen=True)
class MeshOptions:
    """Mesh-size parameters of the gear mesh (all lengths in m).

    Parameters
    ----------
    flank_size_m : float
        Element size on the flanks (involute and tip rounding) of every tooth.
    fillet_size_m : float
        Element size on fillets and root lands (reduced to 0.3 times the fillet's radius
        of curvature where that is smaller, but not below 0.3 ``fillet_size_m``; the tip
        rounding gets at most half its radius).
    body_size_m : float
        Element size far from the teeth (blank).
    fine_layer_m : float
        Depth below the tooth surface over which the fine size is kept (must cover the
        near-field reading depth).
    growth_length_m : float
        Distance over which the size grows from fine to ``body_size_m``.
    n_per_flank : int
        Boundary points per flank requested from ``gg.tooth_boundary`` (spline control points).
    """

    flank_size_m: float = 0.6e-3
    fillet_size_m: float = 0.6e-3
    body_size_m: float = 3.0e-3
    fine_layer_m: float = 1.2e-3
    growth_length_m: float = 6.0e-3
    n_per_flank: int = 120

    def __post_init__(self):
        for name in ("flank_size_m", "fillet_size_m", "body_size_m", "fine_layer_m", "growth_length_m"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.floating)) and np.isfinite(v) and 1e-6 <= v <= 1.0):
                raise ModelError(f"MeshOptions.{name} must be in [1e-6, 1] m, got {v!r}")
        if self.body_size_m < max(self.flank_size_m, self.fillet_size_m):
            raise ModelError("MeshOptions.body_size_m must be >= flank_size_m and fillet_size_m (m)")
        if not (isinstance(self.n_per_flank, (int, np.integer)) and 20 <= self.n_per_flank <= 5000):
            raise ModelError(f"MeshOptions.n_per_flank must be an integer in [20, 5000], got {self.n_per_flank!r}")

    def refined(self, factor: float) -> "MeshOptions":
        """Copy with the flank, fillet and body sizes divided by ``factor`` (> 0)."""
        if not factor > 0:
            raise ModelError(f"refinement factor must be > 0, got {factor!r}")
        return replace(self, flank_size_m=self.flank_size_m / factor,
                       fillet_size_m=self.fillet_size_m / factor,
                       body_size_m=self.body_size_m / factor)

    def scaled(self, factor: float) -> "MeshOptions":
        """Copy with every length (element sizes, fine layer, growth length) times ``factor`` (> 0) [-]; the
        boundary point count is kept.  ``MeshOptions().scaled(m_n / REFERENCE_MODULE_M)`` meshes a gear of normal
        module ``m_n`` as the default meshes a module-5 mm gear of the same tooth count (same element count)."""
        if not (isinstance(factor, (int, float, np.floating)) and np.isfinite(factor) and factor > 0):
            raise ModelError(f"length scale factor [-] must be a finite number > 0, got {factor!r}")
        return replace(self, flank_size_m=self.flank_size_m * factor, fillet_size_m=self.fillet_size_m * factor,
                       body_size_m=self.body_size_m * factor, fine_layer_m=self.fine_layer_m * factor,
                       growth_length_m=self.growth_length_m * factor)


#: normal module [m] at which the default lengths (MeshOptions, gear_compliance, ContactOptions, Mesh3DOptions) were
#: chosen: the shipped 28-tooth pairs.  Module-scaled lengths are these lengths times m_n / REFERENCE_MODULE_M.
REFERENCE_MODULE_M = 5.0e-3

#: gear_compliance's default sample spacing, fillet margin and near-field reading depth [m] (at REFERENCE_MODULE_M)
COMPLIANCE_LENGTHS_M = dict(spacing_m=0.25e-3, fillet_margin_m=0.5e-3, depth_m=1.0e-3)


def normal_module_m(gear: Any) -> float:
    """Normal module m_n [m] of a model gear: the ISO form's ``normal_module_m``; the transverse form's
    ``module_m cos(helix_angle)`` (= ``module_m`` for spur gears)."""
    iso = getattr(gear, "iso", None)
    if iso is not None:
        return float(iso.normal_module_m)
    return float(gear.module_m) * math.cos(float(getattr(gear, "helix_angle_rad", 0.0)))


def length_scale(gear: Any, mode: str = "auto") -> float | None:
    """Factor [-] on the default finite-element and contact lengths for ``gear``, or None for the absolute lengths.

    ``mode`` (the model's ``[statics] fe_lengths``): ``"absolute"`` → None (the lengths tuned on the module-5 mm
    gears, whatever the module: every shipped transverse-form model's tables); ``"module"`` → ``m_n /
    REFERENCE_MODULE_M`` (:func:`normal_module_m`; 1.0 exactly at m_n = 5 mm, so the lengths are then the absolute
    ones bit for bit); ``"auto"`` → ``"module"`` for an ISO 21771 form gear (``gear.iso`` set), ``"absolute"`` for the
    transverse (dissertation) form.
    """
    if mode not in ("auto", "module", "absolute"):
        raise ModelError(f"fe_lengths = {mode!r}; allowed: auto | module | absolute")
    if mode == "absolute" or (mode == "auto" and getattr(gear, "iso", None) is None):
        return None
    return normal_module_m(gear) / REFERENCE_MODULE_M


def gear_mesh_options(gear: Any, mode: str = "auto") -> MeshOptions:
    """The :class:`MeshOptions` statics uses for model gear ``gear`` under ``[statics] fe_lengths = mode``
    (:func:`length_scale`): the defaults, or the defaults scaled with the module."""
    f = length_scale(gear, mode)
    return MeshOptions() if f is None else MeshOptions().scaled(f)


def compliance_lengths(gear: Any, mode: str = "auto") -> dict[str, float]:
    """``spacing_m``, ``fillet_margin_m``, ``depth_m`` [m] for :func:`gear_compliance` of model gear ``gear``
    (:data:`COMPLIANCE_LENGTHS_M`, times :func:`length_scale` where that is not None)."""
    f = length_scale(gear, mode)
    return dict(COMPLIANCE_LENGTHS_M) if f is None else {k: v * f for k, v in COMPLIANCE_LENGTHS_M.items()}


@dataclass(frozen=True)
class Gauge:
    """A strain gauge on the root surface of tooth 0.

    Parameters
    ----------
    name : str
        Label used in tables (e.g. ``"SG2"``).
    side : {"drive", "coast"}
        Flank whose root carries the gauge.
    radius_m : float
        Distance of the gauge centre from the gear centre [m]; the gauge is the first
        point of that flank's profile, walking from the fillet towards the tip, at
        this radius (the root radius itself: the point where the fillet meets the root circle).  The measured quantity is the surface tangential strain there:
        ``t . eps . t`` with ``t`` the profile tangent, from the P2 displacement gradient
        of the element containing the point 2 um below the surface (the gradient is
        linear in each element; converged to ~0.1% on the default mesh of the
        28-tooth gear).
    """

    name: str
    side: str
    radius_m: float

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ModelError("Gauge.name must be a non-empty string")
        if self.side not in ("drive", "coast"):
            raise ModelError(f"Gauge.side must be 'drive' or 'coast', got {self.side!r}")
        if not (np.isfinite(self.radius_m) and self.radius_m > 0):
            raise ModelError(f"Gauge.radius_m must be > 0 m, got {self.radius_m!r}")


def rotation(angle_rad: float) -> np.ndarray:
    """2x2 counter-clockwise rotation matrix."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s], [s, c]])


def cache_dir() -> Path:
    """Folder of the on-disk cache: ``$HACGEAR_CACHE_DIR`` or ``~/.cache/hacgear``."""
    d = os.environ.get("HACGEAR_CACHE_DIR")
    return Path(d) if d else Path.home() / ".cache" / "hacgear"


# ----------------------------------------------------------------------------- meshing
@dataclass(frozen=True)
class GearMesh:
    """Linear triangle mesh of the whole gear (P2 elements are built on it).

    Attributes
    ----------
    p : ndarray (N, 2)
        Node coordinates [m].
    t : ndarray (T, 3)
        Counter-clockwise triangles.
    z : int
        Number of teeth (the mesh is invariant under rotation by ``2 pi/z``).
    hub_radius_m : float
        Radius of the circle tied to the rigid hub.
    n_sector_triangles : int
        Triangles per tooth sector.
    mesh_time_s : float
        gmsh wall time for the sector.
    sector_p : ndarray (Ns, 2)
        Nodes of the tooth-0 sector (``-pi/z`` to ``+pi/z``); the cut on ``+pi/z`` is
        the rotation of the cut on ``-pi/z`` node by node.
    sector_t : ndarray (Ts, 3)
        Triangles of the sector.
    sector_offset_rad : float
        Angle of the sector centre (the cuts lie at ``sector_offset_rad -+ pi/z``).
    sector_thickness : ndarray (Ts,) or None
        Relative thickness of each sector triangle (factor on its plane stiffness): the web's
        ``relative_thickness`` inside the web annulus, 1 elsewhere; None: 1 everywhere (solid blank).
    thickness : ndarray (T,) or None
        The same for the triangles of the whole gear.
    web_radii_m : tuple (inner, outer) or None
        Radii of the two circles the mesh conforms to (web ends), None without a web.
    """

    p: np.ndarray
    t: np.ndarray
    z: int
    hub_radius_m: float
    n_sector_triangles: int
    mesh_time_s: float
    sector_p: np.ndarray
    sector_t: np.ndarray
    sector_offset_rad: float = 0.0
    sector_thickness: np.ndarray | None = None
    thickness: np.ndarray | None = None
    web_radii_m: tuple[float, float] | None = None


def _boundary_pieces(xy: np.ndarray, region: np.ndarray, side: np.ndarray):
    """Split the tooth boundary at label changes: list of (index array, region)."""
    lab = region.astype(int) * 10 + (side.astype(int) + 1)
    cuts = [0] + [i + 1 for i in range(len(xy) - 1) if lab[i] != lab[i + 1]] + [len(xy) - 1]
    cuts = sorted(set(cuts))
    pieces = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        if b > a:
            pieces.append((np.arange(a, b + 1), int(region[min(a + 1, b)] if b - a > 1 else region[a])))
    return pieces


def mesh_gear(gg: Any, options: MeshOptions = MeshOptions()) -> GearMesh:
    """Mesh the whole gear as ``z`` rotated copies of a periodic tooth-sector mesh.

    Parameters
    ----------
    gg : GearGeometry-like (see the module docstring)
    options : MeshOptions

    Returns
    -------
    GearMesh
    """
    import gmsh

    z = int(gg.z)
    if z < 3:
        raise GeometryError(f"gear teeth count z must be >= 3 for the sector mesh, got {z}")
    r_hub = float(gg.bore_radius_m)
    bnd = gg.tooth_boundary(int(options.n_per_flank))
    xy = np.asarray(bnd.xy, dtype=float)
    region = np.asarray(bnd.region)
    side = np.asarray(bnd.side)
    # drop repeated points
    # (closer than 1e-12 m at the default or finer sizes; larger module-scaled sizes scale the distance with them:
    # at module 45 the two fillet bottoms of a full-radius ring root lie 1e-11 m apart and would break the cut)
    dup = 1e-12 * max(1.0, options.flank_size_m / MeshOptions.flank_size_m)
    keep = np.r_[True, np.linalg.norm(np.diff(xy, axis=0), axis=1) > dup]
    xy, region, side = xy[keep], region[keep], side[keep]
    half = np.pi / z
    # the sector is [-pi/z + off, pi/z + off]: off = 0 unless the root land lies off the mid-space angle
    off = float(getattr(gg, "sector_offset_rad", 0.0))
    lo, hi = off - half, off + half
    r0, r1 = np.hypot(*xy[0]), np.hypot(*xy[-1])
    a0, a1 = np.arctan2(xy[0, 1], xy[0, 0]), np.arctan2(xy[-1, 1], xy[-1, 0])
    if abs(r0 - r1) > 1e-6 * r0 or abs(a0 - lo) > 1e-6 or abs(a1 - hi) > 1e-6:
        raise GeometryError("tooth_boundary must run from the coast root-space cut (angle -pi/z + sector_offset_rad) "
                            f"to the drive root-space cut (+pi/z + sector_offset_rad) at equal radii; got angles "
                            f"{a0:.6f}, {a1:.6f} rad (expected {lo:.6f}, {hi:.6f}) and radii {r0:.6e}, {r1:.6e} m")
    rr = 0.5 * (r0 + r1)
    xy[0] = rr * np.array([np.cos(lo), np.sin(lo)])
    xy[-1] = rr * np.array([np.cos(hi), np.sin(hi)])
    radii = np.hypot(xy[:, 0], xy[:, 1])
    internal = bool(getattr(gg, "internal", False))
    if (not internal and r_hub >= radii.min()) or (internal and r_hub <= radii.max()):
        raise GeometryError(f"bore_radius_m = {r_hub:.6g} m must lie {'outside' if internal else 'inside'} the "
                            f"tooth boundary (radii {radii.min():.6g}..{radii.max():.6g} m)")
    web = getattr(gg, "web", None)
    if web is not None:
        r_wi, r_wo, f_web = float(web.inner_radius_m), float(web.outer_radius_m), float(web.relative_thickness)
        if internal:
            raise GeometryError("a web is not supported for internal gears")
        if not r_hub < r_wi < r_wo < radii.min():
            raise GeometryError(f"web radii must satisfy bore {r_hub:.6g} < inner {r_wi:.6g} < outer {r_wo:.6g} < "
                                f"lowest boundary radius {radii.min():.6g} m")
        if not 0.0 < f_web <= 1.0:
            raise GeometryError(f"web relative_thickness must lie in (0, 1], got {f_web!r}")

    # resolve the tip rounding and the fillet curvature when the geometry gives them
    tip_size, fillet_size = options.flank_size_m, options.fillet_size_m
    for sd in ("drive", "coast"):
        try:
            prof = gg.flank(sd, 400)
            rc = np.abs(np.asarray(prof.curvature_radius_m, dtype=float))
            rg = np.asarray(prof.region)
        except Exception:  # geometry without curvature information: keep the given sizes
            continue
        r3 = rc[(rg == 3) & np.isfinite(rc) & (rc > 0)]
        if r3.size:
            tip_size = min(tip_size, max(0.5 * float(r3.min()), 0.25 * options.flank_size_m))
        r1 = rc[(rg == 1) & np.isfinite(rc) & (rc > 0)]
        if r1.size:
            rho = float(np.percentile(r1, 10))
            fillet_size = min(fillet_size, max(0.3 * rho, 0.3 * options.fillet_size_m))

    t0 = time.perf_counter()
    try:
        with gmsh_model("hacgear_sector") as geo:
            ptag = [geo.addPoint(x, y, 0.0) for x, y in xy]
            curves, flank_curves, fillet_curves, tip_curves = [], [], [], []
            for idx, reg in _boundary_pieces(xy, region, side):
                tags = [ptag[i] for i in idx]
                c = geo.addLine(tags[0], tags[1]) if len(tags) == 2 else geo.addSpline(tags)
                curves.append(c)
                (tip_curves if reg in (3, 4) else flank_curves if reg == 2 else fillet_curves).append(c)
            pc = geo.addPoint(0.0, 0.0, 0.0)
            hl = geo.addPoint(r_hub * np.cos(lo), r_hub * np.sin(lo), 0.0)
            hr = geo.addPoint(r_hub * np.cos(hi), r_hub * np.sin(hi), 0.0)
            c, s = np.cos(2 * half), np.sin(2 * half)
            affine = [c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
            web_surface = None
            if web is None:
                cut_l = geo.addLine(hl, ptag[0])
                cut_r = geo.addLine(hr, ptag[-1])
                arc = geo.addCircleArc(hr, pc, hl)
                loop = geo.addCurveLoop(curves + [-cut_r, arc, cut_l])
                geo.addPlaneSurface([loop])
                geo.synchronize()
                gmsh.model.mesh.setPeriodic(1, [cut_r], [cut_l], affine)
            else:
                # three conforming surfaces: hub (bore..r_wi), web (r_wi..r_wo), rim + tooth (r_wo..outline);
                # each radial cut is split at the two web radii and kept periodic piece by piece
                wil = geo.addPoint(r_wi * np.cos(lo), r_wi * np.sin(lo), 0.0)
                wir = geo.addPoint(r_wi * np.cos(hi), r_wi * np.sin(hi), 0.0)
                wol = geo.addPoint(r_wo * np.cos(lo), r_wo * np.sin(lo), 0.0)
                wor = geo.addPoint(r_wo * np.cos(hi), r_wo * np.sin(hi), 0.0)
                cl = [geo.addLine(hl, wil), geo.addLine(wil, wol), geo.addLine(wol, ptag[0])]
                cr = [geo.addLine(hr, wir), geo.addLine(wir, wor), geo.addLine(wor, ptag[-1])]
                arc = geo.addCircleArc(hr, pc, hl)
                arc_i = geo.addCircleArc(wir, pc, wil)
                arc_o = geo.addCircleArc(wor, pc, wol)
                geo.addPlaneSurface([geo.addCurveLoop([cr[0], arc_i, -cl[0], -arc])])
                web_surface = geo.addPlaneSurface([geo.addCurveLoop([cr[1], arc_o, -cl[1], -arc_i])])
                geo.addPlaneSurface([geo.addCurveLoop(curves + [-cr[2], arc_o, cl[2]])])
                geo.synchronize()
                gmsh.model.mesh.setPeriodic(1, cr, cl, affine)
            fld = gmsh.model.mesh.field
            mins = []
            for group, size, dmin in ((flank_curves, options.flank_size_m, options.fine_layer_m),
                                      (fillet_curves, fillet_size, options.fine_layer_m),
                                      (tip_curves, tip_size, 0.5 * options.fine_layer_m)):
                if not group:
                    continue
                fd = fld.add("Distance")
                fld.setNumbers(fd, "CurvesList", group)
                fld.setNumber(fd, "Sampling", 400)
                ft = fld.add("Threshold")
                fld.setNumber(ft, "InField", fd)
                fld.setNumber(ft, "SizeMin", size)
                fld.setNumber(ft, "SizeMax", options.body_size_m)
                fld.setNumber(ft, "DistMin", dmin)
                fld.setNumber(ft, "DistMax", options.fine_layer_m + options.growth_length_m)
                mins.append(ft)
            fm = fld.add("Min")
            fld.setNumbers(fm, "FieldsList", mins)
            fld.setAsBackgroundMesh(fm)
            gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
            gmsh.option.setNumber("Mesh.MeshSizeMax", options.body_size_m)
            gmsh.option.setNumber("Mesh.Algorithm", 6)
            gmsh.model.mesh.generate(2)
            ntags, coords, _ = gmsh.model.mesh.getNodes()
            etags, enodes = gmsh.model.mesh.getElementsByType(2)
            in_web = None
            if web_surface is not None:
                wtags, _ = gmsh.model.mesh.getElementsByType(2, web_surface)
                in_web = np.isin(np.asarray(etags), np.asarray(wtags))
    except Exception as exc:  # gmsh raises plain Exception
        raise GeometryError(f"gmsh could not mesh the tooth sector: {exc}") from exc
    mesh_time = time.perf_counter() - t0

    coords = np.asarray(coords).reshape(-1, 3)[:, :2]
    lookup = np.full(int(np.max(ntags)) + 1, -1, dtype=np.int64)
    lookup[np.asarray(ntags, dtype=np.int64)] = np.arange(len(ntags))
    tri = lookup[np.asarray(enodes, dtype=np.int64).reshape(-1, 3)]
    used = np.unique(tri)
    remap = np.full(len(coords), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    ps, ts = coords[used], remap[tri]
    # counter-clockwise orientation
    d = ps[ts]
    area2 = (d[:, 1, 0] - d[:, 0, 0]) * (d[:, 2, 1] - d[:, 0, 1]) - (d[:, 2, 0] - d[:, 0, 0]) * (d[:, 1, 1] - d[:, 0, 1])
    ts[area2 < 0] = ts[area2 < 0][:, [0, 2, 1]]
    if np.any(np.abs(area2) < 1e-20):
        raise GeometryError("gmsh produced degenerate triangles in the tooth sector")
    # replicate and merge the cut-line nodes
    P = np.concatenate([ps @ rotation(2 * half * k).T for k in range(z)])
    T = np.concatenate([ts + k * len(ps) for k in range(z)])
    tol = 1e-9 * max(r_hub, radii.max())
    pairs = cKDTree(P).query_pairs(tol, output_type="ndarray")
    parent = np.arange(len(P))
    for i, j in pairs:
        a, b = parent[i], parent[j]
        while parent[a] != a:
            a = parent[a]
        while parent[b] != b:
            b = parent[b]
        if a != b:
            parent[max(a, b)] = min(a, b)
    for i in range(len(P)):
        r = i
        while parent[r] != r:
            r = parent[r]
        parent[i] = r
    uniq, inv = np.unique(parent, return_inverse=True)
    P, T = P[uniq], inv[T]
    if web is None:
        return GearMesh(P, T.astype(np.int64), z, r_hub, len(ts), mesh_time, ps, ts.astype(np.int64), off)
    th_s = np.where(in_web, f_web, 1.0)
    return GearMesh(P, T.astype(np.int64), z, r_hub, len(ts), mesh_time, ps, ts.astype(np.int64), off,
                    sector_thickness=th_s, thickness=np.tile(th_s, z), web_radii_m=(r_wi, r_wo))


# ----------------------------------------------------------------------------- FE model
def _single_thread_blas():
    """Context limiting BLAS to one thread (SuperLU calls many tiny BLAS kernels; with
    OpenBLAS threads on a busy 2-core machine the factorisation was measured 7x slower).
    Uses ``threadpoolctl`` when installed, else does nothing."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # optional dependency
        import contextlib

        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def release_freed_memory() -> None:
    """Collect garbage and hand the freed heap pages back to the system (glibc ``malloc_trim``; elsewhere only the
    collection).  Freed blocks below glibc's mmap threshold otherwise stay resident (NREL stage 3, measured: 1.9 GB
    after the wheel's factorised 3D sector model was released; 0.67 GB after a sector's meshing and assembly, handed
    back by this call)."""
    gc.collect()
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError):
        return
    trim.argtypes = [ctypes.c_size_t]
    trim(0)


def _lu_solve(lu, B: np.ndarray) -> np.ndarray:
    """Solve with a SuperLU factor column by column (measured 5x faster than SuperLU's
    multi-right-hand-side solve through scipy for ~50 columns)."""
    B = np.asarray(B)
    if B.ndim == 1:
        return lu.solve(np.ascontiguousarray(B))
    if B.shape[1] == 0:
        return np.zeros(B.shape)
    x0 = lu.solve(np.ascontiguousarray(B[:, 0]))
    X = np.empty(B.shape, dtype=np.result_type(B.dtype, x0.dtype))
    X[:, 0] = x0
    for j in range(1, B.shape[1]):
        X[:, j] = lu.solve(np.ascontiguousarray(B[:, j]))
    return X



class PlaneFE:
    """Factorised 2D linear-elastic P2 finite-element model (thickness 1 m).

    Parameters
    ----------
    p : ndarray (N, 2)
        Vertex coordinates [m].
    t : ndarray (T, 3)
        Triangles (vertex indices).
    material : ElasticMaterial
    fixed_facets : callable
        ``fixed_facets(x0, x1) -> bool mask`` over boundary facets with end points
        ``x0, x1`` (each (nf, 2)); every DOF (vertex and mid-side) of those facets is
        prescribed (0 unless given to :meth:`solve`).
    factorize : bool
        Factorise the free-free stiffness (needed by :meth:`solve`).
    thickness : ndarray (T,), optional
        Relative thickness of each triangle (factor on its stiffness, > 0); None: 1 everywhere.

    Attributes
    ----------
    mesh, basis : scikit-fem mesh and vector P2 basis
    n_dofs, n_free : int
    fixed, free : ndarray of DOF indices
    K : scipy.sparse.csr_matrix (n_dofs, n_dofs)
    timings_s : dict
        ``assemble`` and ``factorize`` wall times [s].
    """

    def __init__(self, p: np.ndarray, t: np.ndarray, material: ElasticMaterial, fixed_facets,
                 factorize: bool = True, thickness: np.ndarray | None = None):
        from skfem import Basis, ElementTriP2, ElementVector, MeshTri, asm
        from skfem.models.elasticity import linear_elasticity

        self.material = material
        t0 = time.perf_counter()
        self.mesh = MeshTri(np.ascontiguousarray(np.asarray(p, dtype=float).T),
                            np.ascontiguousarray(np.asarray(t).T))
        self._scalar_elem = ElementTriP2()
        self.basis = Basis(self.mesh, ElementVector(self._scalar_elem))
        lam, mu = material.lame
        if thickness is None:
            self.K = asm(linear_elasticity(lam, mu), self.basis).tocsr()
        else:
            th = np.asarray(thickness, dtype=float)
            if th.shape != (self.mesh.t.shape[1],) or not np.all(np.isfinite(th) & (th > 0)):
                raise ModelError(f"thickness must be {self.mesh.t.shape[1]} finite factors > 0 (one per triangle)")
            # assemble each thickness group on its own elements (global DOF numbering) and scale it
            K = None
            for f in np.unique(th):
                sub = Basis(self.mesh, ElementVector(self._scalar_elem), elements=np.flatnonzero(th == f))
                Kf = f * asm(linear_elasticity(lam, mu), sub)
                K = Kf if K is None else K + Kf
            self.K = K.tocsr()
        self.thickness = None if thickness is None else np.asarray(thickness, dtype=float)
        t1 = time.perf_counter()
        pm = self.mesh.p
        bf = self.mesh.boundary_facets()
        ends = self.mesh.facets[:, bf]
        fac = bf[np.asarray(fixed_facets(pm[:, ends[0]].T, pm[:, ends[1]].T), dtype=bool)]
        if fac.size == 0:
            raise GeometryError("no boundary facet is fixed (the model would be singular)")
        self.fixed = np.unique(self.basis.get_dofs(fac).all())
        mask = np.ones(self.basis.N, dtype=bool)
        mask[self.fixed] = False
        self.free = np.flatnonzero(mask)
        self._lu = None
        if factorize:
            Kff = self.K[self.free][:, self.free].tocsc()
            try:
                with _single_thread_blas():
                    self._lu = spla.splu(Kff, permc_spec="COLAMD")
            except RuntimeError as exc:
                raise SolverError(f"factorisation of the stiffness matrix failed: {exc}") from exc
        t2 = time.perf_counter()
        self.n_dofs = int(self.basis.N)
        self.n_free = int(self.free.size)
        self.timings_s = {"assemble": t1 - t0, "factorize": t2 - t1}
        comp = np.zeros(self.basis.N, dtype=np.int8)
        comp[self.basis.nodal_dofs[1]] = 1
        comp[self.basis.facet_dofs[1]] = 1
        self._comp = comp
        self._doflocs = self.basis.doflocs
        tp = pm[:, self.mesh.t]                              # (2, 3, T)
        A = np.stack([tp[:, 1] - tp[:, 0], tp[:, 2] - tp[:, 0]], axis=1).transpose(2, 0, 1)
        self._p0 = tp[:, 0].T
        self._Ainv = np.linalg.inv(A)
        self._h = np.sqrt(np.abs(np.linalg.det(A)))
        self._tree = cKDTree(tp.mean(axis=1).T)

    def mass_matrix(self, density_kg_m3: float) -> sp.csr_matrix:
        """Consistent P2 mass matrix ``(n_dofs, n_dofs)`` per unit thickness [kg/m]: ``density_kg_m3`` [kg/m^3]
        times the relative thickness of each triangle (:attr:`thickness`, 1 where None).  Assembled on demand
        beside the stiffness (:attr:`K` is not touched)."""
        from skfem import Basis, BilinearForm, ElementVector, asm
        from skfem.helpers import dot

        rho = float(density_kg_m3)
        if not (np.isfinite(rho) and 1.0 <= rho <= 1e5):
            raise ModelError(f"density_kg_m3 must be in [1, 1e5] kg/m^3, got {density_kg_m3!r}")

        @BilinearForm
        def mass(u, v, w):
            return dot(u, v)

        if self.thickness is None:
            return (rho * asm(mass, self.basis)).tocsr()
        M = None
        for f in np.unique(self.thickness):
            sub = Basis(self.mesh, ElementVector(self._scalar_elem), elements=np.flatnonzero(self.thickness == f))
            Mf = (rho * f) * asm(mass, sub)
            M = Mf if M is None else M + Mf
        return M.tocsr()

    @property
    def dof_component(self) -> np.ndarray:
        """0 for x DOF, 1 for y DOF, shape (n_dofs,)."""
        return self._comp

    @property
    def dof_locations(self) -> np.ndarray:
        """(2, n_dofs) coordinates of the DOF [m]."""
        return self._doflocs

    # -- point location and interpolation operators
    def _locate(self, pts: np.ndarray):
        pts = np.atleast_2d(np.asarray(pts, dtype=float))
        k = min(24, self.mesh.t.shape[1])
        _, idx = self._tree.query(pts, k)
        X = np.einsum("nkij,nkj->nki", self._Ainv[idx], pts[:, None, :] - self._p0[idx])
        lam = np.stack([1 - X[..., 0] - X[..., 1], X[..., 0], X[..., 1]], axis=-1)
        score = lam.min(axis=-1)
        best = np.argmax(score, axis=1)
        rows = np.arange(len(pts))
        el = idx[rows, best]
        L = lam[rows, best]
        out = score[rows, best] < -1e-10
        if np.any(out):
            L[out] = np.clip(L[out], 0.0, None)
            L[out] /= L[out].sum(axis=1, keepdims=True)
            v = self.mesh.p[:, self.mesh.t[:, el[out]]]        # (2,3,n)
            q = np.einsum("dvn,nv->nd", v, L[out])
            dist = np.linalg.norm(q - pts[out], axis=1)
            bad = dist > 0.5 * self._h[el[out]]
            if np.any(bad):
                raise GeometryError(f"point(s) {pts[out][bad][:3].tolist()} m lie outside the gear mesh "
                                    f"(distance {dist[bad].max():.3g} m)")
        return el, L[:, 1:]

    def displacement_operator(self, points_m: np.ndarray) -> sp.csr_matrix:
        """Sparse ``(2n, n_dofs)`` matrix giving ``(ux, uy)`` at ``n`` points (rows ``2q``, ``2q+1``)."""
        el, X = self._locate(points_m)
        n = len(el)
        rows, cols, vals = [], [], []
        for i in range(6):
            phi, _ = self._scalar_elem.lbasis(X.T, i)
            for c in range(2):
                rows.append(2 * np.arange(n) + c)
                cols.append(self.basis.element_dofs[2 * i + c, el])
                vals.append(phi)
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(2 * n, self.n_dofs))

    def strain_operator(self, points_m: np.ndarray, directions: np.ndarray) -> sp.csr_matrix:
        """Sparse ``(n, n_dofs)`` matrix giving the normal strain ``t.eps.t`` along unit
        ``directions`` (n, 2) at ``points_m`` (n, 2) (P2 gradient of the containing element)."""
        el, X = self._locate(points_m)
        t = np.asarray(directions, dtype=float)
        t = t / np.linalg.norm(t, axis=1, keepdims=True)
        n = len(el)
        Ainv = self._Ainv[el]                      # (n,2,2)
        rows, cols, vals = [], [], []
        for i in range(6):
            _, dphi = self._scalar_elem.lbasis(X.T, i)    # (2, n) reference gradient
            grad = np.einsum("nkj,kn->nj", Ainv, dphi)     # (n,2) physical gradient
            dt = np.einsum("nj,nj->n", grad, t)
            for c in range(2):
                rows.append(np.arange(n))
                cols.append(self.basis.element_dofs[2 * i + c, el])
                vals.append(t[:, c] * dt)
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(n, self.n_dofs))

    def point_loads(self, points_m: np.ndarray, forces_N_m: np.ndarray) -> np.ndarray:
        """Consistent nodal load vectors ``(n_dofs, n)`` of point forces (per unit face width).

        Column ``q`` is the force ``forces_N_m[q]`` [N/m] applied at ``points_m[q]`` [m]
        (boundary points are snapped into the nearest element)."""
        Op = self.displacement_operator(points_m)
        f = np.asarray(forces_N_m, dtype=float)
        n = f.shape[0]
        W = sp.csr_matrix((f.ravel(), (np.arange(2 * n), np.repeat(np.arange(n), 2))), shape=(2 * n, n))
        return np.asarray((Op.T @ W).todense())

    def solve(self, F: np.ndarray, U_fixed: np.ndarray | None = None) -> np.ndarray:
        """Displacements ``(n_dofs, m)`` for load vectors ``F`` ``(n_dofs, m)``.

        ``U_fixed`` (n_dofs,) optionally prescribes the fixed DOF (default 0)."""
        F = np.asarray(F, dtype=float)
        one = F.ndim == 1
        F2 = F[:, None] if one else F
        U = np.zeros_like(F2)
        rhs = F2[self.free]
        if U_fixed is not None:
            ub = np.asarray(U_fixed, dtype=float)[self.fixed]
            U[self.fixed] = ub[:, None]
            rhs = rhs - (self.K[self.free][:, self.fixed] @ ub)[:, None]
        with _single_thread_blas():
            U[self.free] = _lu_solve(self._lu, rhs)
        return U[:, 0] if one else U

class GearFE(PlaneFE):
    """Factorised plane finite-element model of a whole gear with its hub held fixed.

    Build with :func:`build_gear_fe`.  Thickness is 1 m: forces are per unit face width
    [N/m], displacements in m.  Every node on the hub circle (bore of an external gear,
    rim of an internal one) is tied to the rigid hub, which is held fixed, so
    displacements are relative to the hub.

    Attributes (in addition to :class:`PlaneFE`)
    --------------------------------------------
    gear_mesh : GearMesh
    z : int
    hub_radius_m : float
    timings_s : dict
        ``mesh``, ``assemble``, ``factorize`` wall times [s].
    """

    def __init__(self, gear_mesh: GearMesh, material: ElasticMaterial):
        r = gear_mesh.hub_radius_m

        def on_hub(x0, x1):
            return ((np.abs(np.hypot(x0[:, 0], x0[:, 1]) - r) < 1e-7 * r)
                    & (np.abs(np.hypot(x1[:, 0], x1[:, 1]) - r) < 1e-7 * r))

        super().__init__(gear_mesh.p, gear_mesh.t, material, on_hub,
                         thickness=getattr(gear_mesh, "thickness", None))
        self.gear_mesh = gear_mesh
        self.z = gear_mesh.z
        self.hub_radius_m = r
        self.timings_s = {"mesh": gear_mesh.mesh_time_s, **self.timings_s}

    def hub_force(self, U: np.ndarray, F: np.ndarray | None = None) -> np.ndarray:
        """Force and moment exerted BY the gear ON the fixed hub, ``(m, 3)``: ``Fx, Fy``
        [N/m] and ``Mz`` about the gear centre [N m/m], for displacement columns ``U``.

        Equals the resultant of the applied loads (equilibrium)."""
        U2 = U[:, None] if U.ndim == 1 else U
        R = self.K[self.fixed] @ U2                      # forces the hub exerts on the gear (+ applied)
        if F is not None:
            F2 = F[:, None] if F.ndim == 1 else F
            R = R - F2[self.fixed]
        cx = self._comp[self.fixed] == 0
        x, y = self._doflocs[0, self.fixed], self._doflocs[1, self.fixed]
        Fx = R[cx].sum(axis=0)
        Fy = R[~cx].sum(axis=0)
        Mz = (x[~cx, None] * R[~cx]).sum(axis=0) - (y[cx, None] * R[cx]).sum(axis=0)
        return -np.stack([Fx, Fy, Mz], axis=1)

    def influence(self, load_xy: np.ndarray, load_force: np.ndarray, disp_xy: np.ndarray,
                  disp_dir: np.ndarray, strain_xy: np.ndarray, strain_dir: np.ndarray):
        """Responses on every tooth to point loads on tooth 0 (full-model solve).

        Parameters
        ----------
        load_xy, load_force : (m, 2)
            Load points on tooth 0 [m] and forces [N/m].
        disp_xy, disp_dir : (p, 2)
            Read points (tooth-0 frame) [m] and unit directions of the displacement.
        strain_xy, strain_dir : (q, 2)
            Strain points (tooth-0 frame) and unit directions of the normal strain.

        Returns
        -------
        disp : (z, p, m)
            ``disp[k, j, i]``: displacement along ``R_k disp_dir[j]`` at ``R_k disp_xy[j]``
            (tooth ``k``) caused by load ``i`` [m per N/m].
        strain : (z, q, m)
        hub : (m, 3)
            :meth:`hub_force` of each load.
        """
        F = self.point_loads(load_xy, load_force)
        U = self.solve(F)
        z = self.z
        disp = np.zeros((z, len(disp_xy), F.shape[1]))
        strain = np.zeros((z, len(strain_xy), F.shape[1]))
        for k in range(z):
            R = rotation(2 * np.pi * k / z)
            if len(disp_xy):
                D = (self.displacement_operator(np.asarray(disp_xy) @ R.T) @ U).reshape(len(disp_xy), 2, -1)
                disp[k] = np.einsum("jc,jci->ji", np.asarray(disp_dir) @ R.T, D)
            if len(strain_xy):
                strain[k] = self.strain_operator(np.asarray(strain_xy) @ R.T, np.asarray(strain_dir) @ R.T) @ U
        return disp, strain, self.hub_force(U, F)


class CyclicGearFE:
    """Gear model solved by cyclic symmetry: one tooth sector, ``z`` harmonics.

    The whole-gear stiffness is block-circulant over the ``z`` sectors (written in each
    sector's rotated frame).  A discrete Fourier transform over the sectors decouples it
    into ``floor(z/2)+1`` independent (complex Hermitian) sector problems
    ``K_h = T_h^H K_s T_h``, where ``T_h`` imposes ``u_right = exp(i h 2pi/z) R(2pi/z) u_left``
    on the two radial cuts.  A load on tooth 0 has the same transform for every harmonic,
    so the responses of all teeth follow from one solve per harmonic and an inverse DFT.
    Results equal those of :class:`GearFE` on the replicated mesh (to round-off) at a
    fraction of the cost: only one sector is assembled, and the factorised systems have
    sector size.

    Attributes
    ----------
    gear_mesh : GearMesh
    sector : PlaneFE
        The assembled (unfactorised) sector with the hub DOF fixed.
    z : int
    n_dofs : int
        DOF of the equivalent whole-gear model (``z`` times the reduced sector DOF plus the hub DOF).
    n_free : int
        Unknowns of the equivalent whole-gear model.
    n_sector_free : int
        Unknowns of each harmonic problem.
    timings_s : dict
        ``mesh``, ``assemble``, ``factorize`` wall times [s].
    """

    def __init__(self, gear_mesh: GearMesh, material: ElasticMaterial):
        r = gear_mesh.hub_radius_m
        z = self.z = gear_mesh.z
        self.gear_mesh = gear_mesh
        self.material = material
        self.hub_radius_m = r

        def on_hub(x0, x1):
            return ((np.abs(np.hypot(x0[:, 0], x0[:, 1]) - r) < 1e-7 * r)
                    & (np.abs(np.hypot(x1[:, 0], x1[:, 1]) - r) < 1e-7 * r))

        t0 = time.perf_counter()
        sec = self.sector = PlaneFE(gear_mesh.sector_p, gear_mesh.sector_t, material, on_hub, factorize=False,
                                    thickness=getattr(gear_mesh, "sector_thickness", None))
        th = 2 * np.pi / z
        half = th / 2
        X = sec.dof_locations                                   # (2, N)
        N = sec.n_dofs
        scale = float(np.max(np.hypot(X[0], X[1])))
        tol = 1e-9 * scale

        def on_line(angle):
            e = np.array([np.cos(angle), np.sin(angle)])
            return (np.abs(e[0] * X[1] - e[1] * X[0]) < tol) & (e[0] * X[0] + e[1] * X[1] > 0)

        off = self.sector_offset_rad = float(getattr(gear_mesh, "sector_offset_rad", 0.0))
        left = np.flatnonzero(on_line(off - half))
        right = np.flatnonzero(on_line(off + half))
        comp = sec.dof_component
        Rt = rotation(th)
        # pair each right DOF with the two left DOF at the rotated location
        locL = (Rt @ X[:, left]).T
        tree = cKDTree(locL)
        dist, idx = tree.query(X[:, right].T)
        if right.size != left.size or right.size == 0 or dist.max() > 1e3 * tol:
            raise GeometryError("the two radial cuts of the tooth sector do not match (periodic mesh expected)")
        pairs = {}
        for d_l in left:
            pairs.setdefault(tuple(np.round(X[:, d_l] / tol).astype(np.int64)), {})[int(comp[d_l])] = d_l
        fixed = np.zeros(N, dtype=bool)
        fixed[sec.fixed] = True
        is_right = np.zeros(N, dtype=bool)
        is_right[right] = True
        keep = np.flatnonzero(~fixed & ~is_right)
        red = np.full(N, -1, dtype=np.int64)
        red[keep] = np.arange(keep.size)
        n_red = keep.size
        Ti = sp.csr_matrix((np.ones(n_red), (keep, np.arange(n_red))), shape=(N, n_red))
        rows, cols, vals = [], [], []
        c, s_ = Rt[0, 0], Rt[1, 0]
        for j, d_r in enumerate(right):
            if fixed[d_r]:
                continue
            d_l_any = left[idx[j]]
            key = tuple(np.round(X[:, d_l_any] / tol).astype(np.int64))
            lx, ly = pairs[key][0], pairs[key][1]
            if fixed[lx] or fixed[ly]:
                raise GeometryError("inconsistent hub tie on the sector cuts")
            # u_R = e^{i phi} R u_L
            coef = (c, -s_) if comp[d_r] == 0 else (s_, c)
            for dl, cf in ((lx, coef[0]), (ly, coef[1])):
                if cf != 0.0:
                    rows.append(d_r)
                    cols.append(red[dl])
                    vals.append(cf)
        Tr = sp.csr_matrix((vals, (rows, cols)), shape=(N, n_red))
        K = sec.K
        self._Ti, self._Tr = Ti, Tr
        A0 = (Ti.T @ K @ Ti + Tr.T @ K @ Tr).tocsc()
        A1 = (Ti.T @ K @ Tr).tocsc()
        t1 = time.perf_counter()
        self._lu = []
        self._harmonics = list(range(z // 2 + 1))
        with _single_thread_blas():
            self._factorize_harmonics(A0, A1, th)
        t2 = time.perf_counter()
        self.n_sector_free = int(n_red)
        self.n_free = int(z * n_red)
        self.n_dofs = int(z * n_red + z * (np.count_nonzero(fixed) - np.count_nonzero(fixed[right])))
        self.timings_s = {"mesh": gear_mesh.mesh_time_s, "assemble": t1 - t0, "factorize": t2 - t1}
        self.mesh = sec.mesh

    def _factorize_harmonics(self, A0, A1, th):
        z = self.z
        for h in self._harmonics:
            ph = np.exp(1j * h * th)
            if h == 0 or 2 * h == z:
                Kh = (A0 + ph.real * (A1 + A1.T)).tocsc()
            else:
                Kh = (A0 + ph * A1 + np.conj(ph) * A1.T).tocsc()
            try:
                # Hermitian positive definite: symmetric ordering, no pivoting
                self._lu.append(spla.splu(Kh, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                          options=dict(SymmetricMode=True)))
            except RuntimeError as exc:
                raise SolverError(f"factorisation of harmonic {h} failed: {exc}") from exc

    def _map_to_sector(self, pts, dirs):
        """Rotate points (and directions) into sector 0; return them and the sector shift."""
        pts = np.atleast_2d(np.asarray(pts, dtype=float))
        dirs = np.atleast_2d(np.asarray(dirs, dtype=float))
        th = 2 * np.pi / self.z
        ang = np.arctan2(pts[:, 1], pts[:, 0]) - getattr(self, "sector_offset_rad", 0.0)
        m = np.round(ang / th).astype(int)
        P = np.empty_like(pts)
        D = np.empty_like(dirs)
        for q in range(len(pts)):
            R = rotation(-m[q] * th)
            P[q] = R @ pts[q]
            D[q] = R @ dirs[q]
        return P, D, m

    def _all_teeth(self, Op, U_h, shift):
        """Inverse DFT: ``(z, rows, m)`` values of operator ``Op`` (rows x sector DOF) on
        every sector, from the harmonic solutions; ``shift`` re-indexes rows whose point
        was mapped from sector ``shift`` into sector 0."""
        z = self.z
        OTi = Op @ self._Ti
        OTr = Op @ self._Tr
        th = 2 * np.pi / z
        Y = np.zeros((z, Op.shape[0], U_h[0].shape[1]), dtype=complex)
        for h, Uh in zip(self._harmonics, U_h):
            Y[h] = OTi @ Uh + np.exp(1j * h * th) * (OTr @ Uh)
            if 0 < h and 2 * h != z:
                Y[z - h] = np.conj(Y[h])
        V = np.fft.ifft(Y, axis=0).real                       # V[k] = (1/z) sum_h e^{i h k th} Y_h
        if np.any(shift != 0):
            out = np.empty_like(V)
            k = np.arange(z)
            for r in range(V.shape[1]):
                out[:, r] = V[(k + shift[r]) % z, r]
            return out
        return V

    def influence(self, load_xy, load_force, disp_xy, disp_dir, strain_xy, strain_dir):
        """Same contract as :meth:`GearFE.influence` (loads on tooth 0, responses on all teeth)."""
        sec = self.sector
        P, Fd, m_load = self._map_to_sector(load_xy, load_force)
        if np.any(m_load != 0):
            raise GeometryError("load points must lie on tooth 0 (its sector -pi/z..pi/z, shifted by sector_offset_rad)")
        F = sec.point_loads(P, Fd)
        U_h = []
        with _single_thread_blas():
            self._solve_harmonics(F, U_h)
        return self._post(U_h, F.shape[1], disp_xy, disp_dir, strain_xy, strain_dir)

    def _solve_harmonics(self, F, U_h):
        for h, lu in zip(self._harmonics, self._lu):
            ph = np.exp(1j * h * 2 * np.pi / self.z)
            rhs = self._Ti.T @ F + np.conj(ph) * (self._Tr.T @ F)
            if h == 0 or 2 * h == self.z:
                rhs = rhs.real
            U_h.append(_lu_solve(lu, rhs))

    def _post(self, U_h, nload, disp_xy, disp_dir, strain_xy, strain_dir):
        sec = self.sector
        z = self.z
        disp = np.zeros((z, len(disp_xy), nload))
        strain = np.zeros((z, len(strain_xy), nload))
        if len(disp_xy):
            Pd, Dd, md = self._map_to_sector(disp_xy, disp_dir)
            Op = sec.displacement_operator(Pd)
            W = sp.csr_matrix((Dd.ravel(), (np.repeat(np.arange(len(Pd)), 2), np.arange(2 * len(Pd)))),
                              shape=(len(Pd), 2 * len(Pd)))
            disp = self._all_teeth((W @ Op).tocsr(), U_h, md)
        if len(strain_xy):
            Ps, Ds, ms = self._map_to_sector(strain_xy, strain_dir)
            strain = self._all_teeth(sec.strain_operator(Ps, Ds), U_h, ms)
        # hub: element forces of every sector on its hub nodes, summed in the gear frame
        fx = sec.fixed
        cx = sec.dof_component[fx] == 0
        x, y = sec.dof_locations[0, fx], sec.dof_locations[1, fx]
        G = sp.csr_matrix(np.vstack([cx.astype(float), (~cx).astype(float),
                                     np.where(cx, -y, x)])) @ sec.K[fx]
        H = self._all_teeth(G.tocsr(), U_h, np.zeros(3, dtype=int))     # (z, 3, m) per sector, local frame
        hub = np.zeros((nload, 3))
        for k in range(z):
            R = rotation(2 * np.pi * k / z)
            hub[:, :2] += (R @ H[k, :2]).T
            hub[:, 2] += H[k, 2]
        return disp, strain, -hub


def build_gear_fe(gg: Any, material: Any, options: MeshOptions = MeshOptions(),
                  method: str = "cyclic") -> "CyclicGearFE | GearFE":
    """Mesh, assemble and factorise the whole gear (hub held fixed).

    Parameters
    ----------
    gg : GearGeometry-like
    material : ElasticMaterial or object with ``youngs_modulus_Pa``/``poisson_ratio``
    options : MeshOptions
    method : {"cyclic", "full"}
        ``"cyclic"`` (default): one sector and ``z//2+1`` harmonic factorisations
        (:class:`CyclicGearFE`); ``"full"``: the replicated whole-gear mesh with one
        factorisation (:class:`GearFE`), same results, slower; kept as the reference.

    Returns
    -------
    CyclicGearFE or GearFE
        Both provide ``influence(...)``, ``n_dofs``, ``n_free``, ``timings_s``.
    """
    if method not in ("cyclic", "full"):
        raise ModelError(f"method must be 'cyclic' or 'full', got {method!r}")
    gm = mesh_gear(gg, options)
    mat = ElasticMaterial.coerce(material)
    return CyclicGearFE(gm, mat) if method == "cyclic" else GearFE(gm, mat)


# ----------------------------------------------------------------------------- influence coefficients
@dataclass(frozen=True)
class FlankCompliance:
    """Influence coefficients of one gear for loads on one flank side (per unit face width).

    Sample points ``i = 0..n-1`` lie on the ``side`` flank of tooth 0, uniformly spaced in
    the profile coordinate ``s`` (arc length from the tip, increasing towards the root),
    covering the tip rounding, the involute and ``fillet_margin_m`` of the fillet.

    Attributes
    ----------
    side : str
    z : int
    s_m : ndarray (n,)
        Profile coordinate of the samples [m] (uniform, increasing).
    xy_m, normal : ndarray (n, 2)
        Sample points [m] and outward unit normals of tooth 0.
    region : ndarray (n,) int
        0 root land, 1 fillet, 2 involute, 3 tip rounding.
    roll_angle_rad, curvature_radius_m : ndarray (n,)
        From the geometry (NaN where undefined).
    depth_m : ndarray (n,)
        Near-field reading depth at each sample [m].
    far_field_m2_N : ndarray (z, n, n)
        ``[k, i, j]``: displacement along the inward normal at the point ``depth_m[j]``
        below sample ``j`` of tooth ``k`` per unit compressive normal line load [N/m] at
        sample ``i`` of tooth 0 [m^2/N].  By cyclic symmetry a load on tooth ``m`` acts on
        tooth ``k`` through ``[(k - m) % z]``.
    strain_per_N_m : ndarray (g, z, n)
        ``[g, k, i]``: surface tangential strain at gauge ``g`` on tooth ``k`` per unit load
        at sample ``i`` of tooth 0 [1/(N/m) = m/N].
    hub_force_per_N_m : ndarray (n, 3)
        Force ``Fx, Fy`` [N per N/m] and moment ``Mz`` [N m per N/m] exerted by the gear on its
        hub per unit load at sample ``i`` of tooth 0 (gear frame).
    gauge_names : tuple of str
    gauge_xy_m, gauge_tangent : ndarray (g, 2)
        Gauge points on tooth 0 and the unit surface tangents of the measured strain.
    youngs_modulus_Pa, poisson_ratio : float
    plane : str
    info : dict
        Mesh and timing information (DOF, element counts, options, cache key).
    """

    side: str
    z: int
    s_m: np.ndarray
    xy_m: np.ndarray
    normal: np.ndarray
    region: np.ndarray
    roll_angle_rad: np.ndarray
    curvature_radius_m: np.ndarray
    depth_m: np.ndarray
    far_field_m2_N: np.ndarray
    strain_per_N_m: np.ndarray
    hub_force_per_N_m: np.ndarray
    gauge_names: tuple
    gauge_xy_m: np.ndarray
    gauge_tangent: np.ndarray
    youngs_modulus_Pa: float
    poisson_ratio: float
    plane: str
    info: dict = field(default_factory=dict)

    _ARRAYS = ("s_m", "xy_m", "normal", "region", "roll_angle_rad", "curvature_radius_m", "depth_m",
               "far_field_m2_N", "strain_per_N_m", "hub_force_per_N_m", "gauge_xy_m", "gauge_tangent")

    # -- helpers
    @property
    def n_samples(self) -> int:
        return int(self.s_m.size)

    def _frac(self, s):
        s = np.asarray(s, dtype=float)
        lo, hi = self.s_m[0], self.s_m[-1]
        tol = 1e-9 + 1e-6 * (hi - lo)
        smin, smax = (float(s), float(s)) if s.ndim == 0 else (s.min(), s.max())
        if not (lo - tol <= smin and smax <= hi + tol):
            raise GeometryError(f"profile coordinate s must lie in [{lo:.6e}, {hi:.6e}] m (the sampled flank "
                                f"of side {self.side!r}); got {np.min(s):.6e}..{np.max(s):.6e} m")
        u = (np.clip(s, lo, hi) - lo) * ((self.n_samples - 1) / (hi - lo))
        i0 = np.minimum(u.astype(int), self.n_samples - 2)
        return i0, u - i0

    def point(self, s_m):
        """Point [m] and outward unit normal on tooth 0's flank at profile coordinate(s) ``s_m``."""
        i0, f = self._frac(s_m)
        f2 = f[..., None]
        xy = self.xy_m[i0] * (1 - f2) + self.xy_m[i0 + 1] * f2
        n = self.normal[i0] * (1 - f2) + self.normal[i0 + 1] * f2
        return xy, n / np.linalg.norm(n, axis=-1, keepdims=True)

    def depth(self, s_m):
        """Near-field reading depth [m] at ``s_m``."""
        i0, f = self._frac(s_m)
        return self.depth_m[i0] * (1 - f) + self.depth_m[i0 + 1] * f

    def rotation(self, k: int) -> np.ndarray:
        """Rotation from tooth 0 to tooth ``k`` (2x2)."""
        return rotation(2 * np.pi * (int(k) % self.z) / self.z)

    # -- influence coefficients
    def far_field(self, k: int, s_load, s_resp):
        """Far-field compliance [m^2/N] (bilinear in ``s``), tooth offset ``k``, broadcasting."""
        C = self.far_field_m2_N[int(k) % self.z]
        i0, fi = self._frac(s_load)
        j0, fj = self._frac(s_resp)
        return ((1 - fi) * (1 - fj) * C[i0, j0] + fi * (1 - fj) * C[i0 + 1, j0]
                + (1 - fi) * fj * C[i0, j0 + 1] + fi * fj * C[i0 + 1, j0 + 1])

    def compliance(self, k: int, s_load, s_resp, min_offset_m: float | None = None):
        """Linear compliance [m^2/N] between a load at ``s_load`` on tooth 0 and the inward
        normal displacement at ``s_resp`` on tooth ``k`` (broadcasting).

        Far field plus, on the same tooth (``k % z == 0``), the analytical near-field term of
        a concentrated load at the distance ``|s_load - s_resp|`` (half-space approach
        between the surface and the reading depth).  For coincident points (distance below
        ``min_offset_m``, default 1e-9 m) only the far field is returned: add the
        load-dependent :meth:`self_approach` for the loaded contact itself.
        """
        c = np.asarray(self.far_field(k, s_load, s_resp), dtype=float)
        if int(k) % self.z != 0:
            return c
        x2 = (np.asarray(s_load, dtype=float) - np.asarray(s_resp, dtype=float)) ** 2
        eps = 1e-9 if min_offset_m is None else float(min_offset_m)
        d2 = self.depth(s_resp) ** 2
        Ep, nuq = self._plane_constants
        with np.errstate(divide="ignore", invalid="ignore"):
            corr = (np.log1p(d2 / x2) - (1.0 + nuq) * d2 / (x2 + d2)) / (np.pi * Ep)
        return c + np.where(x2 > eps * eps, corr, 0.0)

    @property
    def _plane_constants(self):
        """``(E', nu'')`` of :func:`hacgear_core.statics.nearfield.halfspace_approach_point`."""
        E, nu = self.youngs_modulus_Pa, self.poisson_ratio
        if self.plane == "stress":
            return E, nu
        return E / (1 - nu * nu), nu / (1 - nu)

    def matrix(self) -> np.ndarray:
        """``(z, n, n)`` compliance at the samples: far field plus the mutual near-field
        terms on tooth 0 (diagonal = far field only; add :meth:`self_approach`)."""
        out = self.far_field_m2_N.copy()
        dx = np.abs(self.s_m[:, None] - self.s_m[None, :])
        off = ~np.eye(self.n_samples, dtype=bool)
        d = np.broadcast_to(self.depth_m[None, :], dx.shape)
        out[0][off] += halfspace_approach_point(1.0, dx[off], d[off], self.youngs_modulus_Pa,
                                                self.poisson_ratio, self.plane)
        return out

    def self_approach(self, load_per_width_N_m, half_width_m, s_m):
        """This body's near-field approach [m] between the contact surface and the reading
        depth, for a Hertz contact of load ``w`` [N/m] and half-width ``a`` [m] at ``s_m``.

        The total compliance displacement of a contact on this body is
        ``sum_i compliance * w_i + self_approach(w, a, s)``; ``a`` comes from
        :func:`hacgear_core.statics.nearfield.hertz_line_contact` with both bodies' curvatures."""
        w = np.asarray(load_per_width_N_m, dtype=float)
        a = np.asarray(half_width_m, dtype=float)
        out = np.zeros(np.broadcast(w, a, np.asarray(s_m)).shape)
        pos = np.broadcast_to(w > 0, out.shape)
        if np.any(pos):
            W = np.broadcast_to(w, out.shape)[pos]
            A = np.broadcast_to(a, out.shape)[pos]
            D = np.broadcast_to(self.depth(s_m), out.shape)[pos]
            out[pos] = halfspace_approach_hertz(W, A, D, self.youngs_modulus_Pa, self.poisson_ratio, self.plane)
        return out

    def strain(self, gauge: int | str, k: int, s_load):
        """Gauge strain [m/N] on tooth ``k`` per unit load at ``s_load`` on tooth 0."""
        g = self.gauge_names.index(gauge) if isinstance(gauge, str) else int(gauge)
        S = self.strain_per_N_m[g, int(k) % self.z]
        i0, f = self._frac(s_load)
        return S[i0] * (1 - f) + S[i0 + 1] * f

    def hub_force(self, k: int, s_load):
        """``(..., 3)`` force/moment on the hub per unit load at ``s_load`` on tooth ``k``."""
        i0, f = self._frac(s_load)
        H = self.hub_force_per_N_m[i0] * (1 - f)[..., None] + self.hub_force_per_N_m[i0 + 1] * f[..., None]
        R = self.rotation(k)
        out = H.copy()
        out[..., :2] = H[..., :2] @ R.T
        return out

    # -- persistence
    def save(self, path: str | os.PathLike) -> None:
        """Write to an ``.npz`` file (arrays + JSON metadata)."""
        meta = dict(side=self.side, z=self.z, gauge_names=list(self.gauge_names),
                    youngs_modulus_Pa=self.youngs_modulus_Pa, poisson_ratio=self.poisson_ratio,
                    plane=self.plane, info=self.info)
        write_npz(path, meta, {a: getattr(self, a) for a in self._ARRAYS})

    @classmethod
    def load(cls, path: str | os.PathLike) -> "FlankCompliance":
        """Read a file written by :meth:`save`."""
        meta, arrays = read_npz(path, cls._ARRAYS)
        return cls(side=meta["side"], z=meta["z"], gauge_names=tuple(meta["gauge_names"]),
                   youngs_modulus_Pa=meta["youngs_modulus_Pa"], poisson_ratio=meta["poisson_ratio"],
                   plane=meta["plane"], info=meta["info"], **arrays)


def _resample_profile(prof, s_grid):
    s = np.asarray(prof.s, dtype=float)
    order = np.argsort(s)
    s = s[order]

    def lin(a):
        a = np.asarray(a, dtype=float)[order]
        if a.ndim == 1:
            return np.interp(s_grid, s, a)
        return np.stack([np.interp(s_grid, s, a[:, c]) for c in range(a.shape[1])], axis=1)

    xy = lin(prof.xy)
    n = lin(prof.normal)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    near = np.clip(np.searchsorted(s, s_grid), 0, len(s) - 1)
    region = np.asarray(prof.region)[order][near]
    roll = lin(prof.roll_angle_rad)
    rc = lin(prof.curvature_radius_m)
    return xy, n, region.astype(int), roll, rc


def _chord_inward(points, normals, poly):
    """Distance from each point along -normal to the next crossing of the closed polyline."""
    a = poly[:-1]
    b = poly[1:]
    e = b - a
    out = np.full(len(points), np.inf)
    for q, (x, n) in enumerate(zip(points, normals)):
        dvec = -n
        # solve x + t d = a + u e
        den = dvec[0] * (-e[:, 1]) - dvec[1] * (-e[:, 0])
        with np.errstate(divide="ignore", invalid="ignore"):
            rx = a - x
            t = (rx[:, 0] * (-e[:, 1]) - rx[:, 1] * (-e[:, 0])) / den
            u = (dvec[0] * rx[:, 1] - dvec[1] * rx[:, 0]) / den
        ok = (np.abs(den) > 1e-30) & (u >= 0) & (u <= 1) & (t > 1e-5)
        if np.any(ok):
            out[q] = t[ok].min()
    return out


def _gauge_location(gg, gauge: Gauge, n_profile: int):
    prof = gg.flank(gauge.side, n_profile)
    r = np.asarray(prof.radius, dtype=float)
    xy = np.asarray(prof.xy, dtype=float)
    nrm = np.asarray(prof.normal, dtype=float)
    s = np.asarray(prof.s, dtype=float)
    reg = np.asarray(prof.region)
    # a gauge at the root radius sits where the fillet meets the root circle, not on the root land
    hit = np.flatnonzero(((r[:-1] - gauge.radius_m) * (r[1:] - gauge.radius_m) <= 0) & (reg[1:] >= 1))
    if hit.size == 0:
        raise GeometryError(f"gauge {gauge.name!r}: radius_m = {gauge.radius_m:.6g} m is not on the {gauge.side} "
                            f"flank profile (radii {r.min():.6g}..{r.max():.6g} m)")
    i = hit[0]
    f = 1.0 if r[i + 1] == r[i] else (gauge.radius_m - r[i]) / (r[i + 1] - r[i])
    p = xy[i] * (1 - f) + xy[i + 1] * f
    n = nrm[i] * (1 - f) + nrm[i + 1] * f
    n /= np.linalg.norm(n)
    return p, np.array([-n[1], n[0]]), n, float(s[i] * (1 - f) + s[i + 1] * f), int(reg[i + 1] if f >= 0.5 else reg[i])


def _hash_inputs(gg, material, options, side, s_grid, depth, gauges, n_profile) -> str:
    h = hashlib.sha256()
    h.update(FE_CODE_VERSION.encode())
    bnd = gg.tooth_boundary(int(options.n_per_flank))
    for arr in (bnd.xy, bnd.region, bnd.side):
        h.update(np.ascontiguousarray(np.asarray(arr, dtype=float)).tobytes())
    for sd in ("drive", "coast"):
        prof = gg.flank(sd, n_profile)
        for arr in (prof.xy, prof.normal, prof.s, prof.region, prof.curvature_radius_m):
            h.update(np.ascontiguousarray(np.asarray(arr, dtype=float)).tobytes())
    h.update(json.dumps(dict(z=int(gg.z), bore=float(gg.bore_radius_m), internal=bool(getattr(gg, "internal", False)),
                             material=asdict(material), options=asdict(options), side=side, depth=depth,
                             gauges=[asdict(g) for g in gauges], n_profile=n_profile),
                        sort_keys=True, default=float).encode())
    h.update(np.ascontiguousarray(s_grid).tobytes())
    off = float(getattr(gg, "sector_offset_rad", 0.0))
    if off != 0.0:  # sector cut off the mid-space angle (kept out of the key otherwise: old caches stay valid)
        h.update(f"sector_offset_rad={off!r}".encode())
    web = getattr(gg, "web", None)
    if web is not None:  # webbed blank (kept out of the key for solid blanks: their caches stay valid)
        h.update((f"web={float(web.inner_radius_m)!r},{float(web.outer_radius_m)!r},"
                  f"{float(web.relative_thickness)!r}").encode())
    return h.hexdigest()[:32]


def gear_compliance(gg: Any, material: Any, side: str, *, options: MeshOptions = MeshOptions(),
                    spacing_m: float = 0.25e-3, fillet_margin_m: float = 0.5e-3,
                    depth_m: float = 1.0e-3, depth_fraction: float = 0.3,
                    gauges: Sequence[Gauge] = (), n_profile: int = 800, cache: bool = True,
                    fe: GearFE | None = None) -> FlankCompliance:
    """Influence coefficients for normal loads on the ``side`` flank of a gear.

    Parameters
    ----------
    gg : GearGeometry-like
    material : ElasticMaterial or model material
    side : {"drive", "coast"}
        Loaded flank.
    options : MeshOptions
    spacing_m : float
        Sample spacing along the profile [m] (0.01..2 mm).
    fillet_margin_m : float
        How far the samples extend below the involute into the fillet [m] (>= 0).
    depth_m : float
        Near-field reading depth [m] (0.05..5 mm); reduced to ``depth_fraction`` times the
        tooth chord along the normal where the tooth is thin (tip).
    gauges : sequence of Gauge (or model gauges with ``name``, ``flank``, ``radius_m``)
    n_profile : int
        Points of the dense profile from ``gg.flank``.
    cache : bool
        Read/write the on-disk cache (:func:`cache_dir`).
    fe : CyclicGearFE or GearFE or callable, optional
        Reuse an already factorised model (must match ``gg``, ``material`` and ``options``);
        default: :func:`build_gear_fe` with ``method="cyclic"``.  A callable without arguments returning such a
        model is called only when the on-disk cache does not hold the result (several flanks, one build:
        :func:`hacgear_core.statics.contact.prebuild_compliances`).

    Returns
    -------
    FlankCompliance
    """
    if side not in ("drive", "coast"):
        raise ModelError(f"side must be 'drive' or 'coast', got {side!r}")
    # the ranges cover the defaults scaled from m_n = 0.1 mm to 100 mm (length_scale 0.02 .. 20)
    if not (1e-6 <= spacing_m <= 1e-2):
        raise ModelError(f"spacing_m must be in [1e-6, 1e-2] m, got {spacing_m!r}")
    if not (0 <= fillet_margin_m <= 2e-2):
        raise ModelError(f"fillet_margin_m must be in [0, 2e-2] m, got {fillet_margin_m!r}")
    if not (1e-6 <= depth_m <= 5e-2):
        raise ModelError(f"depth_m must be in [1e-6, 5e-2] m, got {depth_m!r}")
    if not (0.05 <= depth_fraction <= 0.5):
        raise ModelError(f"depth_fraction must be in [0.05, 0.5], got {depth_fraction!r}")
    mat = ElasticMaterial.coerce(material)
    gauges = tuple(g if isinstance(g, Gauge) else Gauge(g.name, getattr(g, "side", None) or g.flank, g.radius_m)
                   for g in gauges)     # model gauges (``.flank``) are accepted too
    if len({g.name for g in gauges}) != len(gauges):
        raise ModelError("gauge names must be unique")
    z = int(gg.z)

    prof = gg.flank(side, n_profile)
    s = np.asarray(prof.s, dtype=float)
    reg = np.asarray(prof.region)
    act = (reg == 2) | (reg == 3)
    if not np.any(reg == 2):
        raise GeometryError(f"the {side} flank profile has no involute points (region 2)")
    s_lo = s[act].min()
    s_hi = min(s[reg == 2].max() + fillet_margin_m, s.max())
    n = int(np.ceil((s_hi - s_lo) / spacing_m)) + 1
    s_grid = np.linspace(s_lo, s_hi, max(n, 3))

    key = _hash_inputs(gg, mat, options, side, s_grid, (depth_m, depth_fraction), gauges, n_profile)
    path = cache_dir() / "fe" / f"flank_{key}.npz"
    lazy = fe is not None and not hasattr(fe, "influence")
    if cache and (fe is None or lazy) and path.exists():
        try:
            return FlankCompliance.load(path)
        except Exception:
            pass  # unreadable cache entry: recompute

    xy, nrm, region, roll, rc = _resample_profile(prof, s_grid)
    poly = np.asarray(gg.tooth_boundary(int(options.n_per_flank)).xy, dtype=float)
    chord = _chord_inward(xy, nrm, poly)
    depth = np.minimum(depth_m, depth_fraction * chord)

    g_xy, g_t, g_n, g_info = [], [], [], []
    for g in gauges:           # located first: a bad gauge fails before the expensive build
        p, t, nn, sg, rg = _gauge_location(gg, g, n_profile)
        g_xy.append(p)
        g_t.append(t)
        g_n.append(nn)
        g_info.append(dict(name=g.name, side=g.side, radius_m=g.radius_m, s_m=sg, region=rg))

    t0 = time.perf_counter()
    if fe is None:
        fe = build_gear_fe(gg, mat, options)
    elif lazy:
        fe = fe()
    t1 = time.perf_counter()
    read = xy - depth[:, None] * nrm
    g_q = np.array([p - 2e-6 * nn for p, nn in zip(g_xy, g_n)]).reshape(-1, 2)
    disp, S, H = fe.influence(xy, -nrm, read, -nrm, g_q, np.array(g_t).reshape(-1, 2))
    C = np.ascontiguousarray(disp.transpose(0, 2, 1))          # [k, i (load), j (response)]
    S = np.ascontiguousarray(S.transpose(1, 0, 2))              # [g, k, i]
    t2 = time.perf_counter()
    info = dict(cache_key=key, n_dofs=fe.n_dofs, n_free=fe.n_free, n_triangles=int(fe.gear_mesh.t.shape[0]),
                n_sector_triangles=fe.gear_mesh.n_sector_triangles, options=asdict(options),
                timings_s=dict(fe.timings_s, build_total=t1 - t0, solve=t2 - t1),
                gauges=g_info, face="per unit face width (thickness 1 m)", code_version=FE_CODE_VERSION,
                depth_m=depth_m, depth_fraction=depth_fraction)
    out = FlankCompliance(side=side, z=z, s_m=s_grid, xy_m=xy, normal=nrm, region=region, roll_angle_rad=roll,
                          curvature_radius_m=rc, depth_m=depth, far_field_m2_N=C, strain_per_N_m=S,
                          hub_force_per_N_m=H, gauge_names=tuple(g.name for g in gauges),
                          gauge_xy_m=np.array(g_xy).reshape(-1, 2), gauge_tangent=np.array(g_t).reshape(-1, 2),
                          youngs_modulus_Pa=mat.youngs_modulus_Pa, poisson_ratio=mat.poisson_ratio,
                          plane=mat.plane, info=info)
    if cache:
        try:
            out.save(path)
        except OSError:
            pass
    return out


def write_npz(path: str | os.PathLike, meta: dict, arrays: dict) -> None:
    """Write ``arrays`` and JSON ``meta`` to the ``.npz`` file ``path`` atomically (a temporary file, then a
    rename: concurrent readers and writers of a cache see a whole file or none)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + f".tmp{os.getpid()}.npz")
    np.savez(tmp, meta=np.array(json.dumps(meta)), **arrays)
    os.replace(tmp, path)


def read_npz(path: str | os.PathLike, names) -> tuple[dict, dict]:
    """``(meta, arrays)`` of a file written by :func:`write_npz`, the arrays ``names``."""
    with np.load(path, allow_pickle=False) as d:
        return json.loads(str(d["meta"])), {a: d[a] for a in names}
