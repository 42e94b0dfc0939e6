"""The coast side of a mesh: the opposite flank pair's static contact, in the drive side's positions.

When the torque through a mesh reverses, or the teeth cross the backlash, the *other* flank of each gear
comes into contact (gear_a's and gear_b's unloaded flanks; for the 28-tooth pair the 20° side).  The
static contact solver of that flank pair is the ordinary :class:`~hacgear_core.statics.contact.MeshContactSolver`
(or any :class:`~hacgear_core.statics.contract.MeshStaticSolver`) built with the flanks swapped
(``make_mesh_solver(..., side="coast")``): its canonical picture is the mirror image of the drive side's, its
positions run the other way and its deflection is measured from the coast flanks' own kinematic contact.
:class:`CoastSideSolver` wraps it so that the coast side speaks the drive side's coordinates:

* **position** ``tau`` [mesh cycles]: the drive side's mesh position (integer when a drive pair touches at the
  pitch point, growing as gear_a turns in its operating sense).  The inner solver is asked at its own position
  ``tau_c = c0 - tau`` with ``c0 = (s_wa - s_wb - p_w) / (2 p_w)`` (:func:`hacgear_core.geometry.mesh_backlash`).
* **deflection** ``x_c`` [m]: the coast *approach* along the coast line of action, measured from the drive
  kinematic position (ideal drive involutes touching, ``x_d = 0``): ``x_c = x_s + j_n`` with ``x_s`` the inner
  solver's deflection and ``j_n`` the normal backlash along the coast line of action.  Coast contact begins
  near ``x_c = j_n`` (the coast no-load deflection).  For rigid gears ``x_c = -(r_bc / r_b) x_d``.
* **tooth pairs**: inner pair ``k`` becomes coast pair ``k' = -k`` (``X_k'(tau + 1) = X_k'-1(tau)`` as on the
  drive side).  Coast pair ``k'`` holds the physical tooth of gear ``g`` that drive pair ``k' - pair_shift[g]``
  holds, with ``pair_shift = {gear_a: 1, gear_b: 0}``: the strain of one physical tooth whose drive pair phase
  is ``phi`` is ``coast.sdf(gauge, phi - pair_shift[gear], x_c)``.  The tabulated pairs are those around the
  inner solver's own positions (:func:`coast_pair_centre`): coast offsets ``-1 .. 3`` for ``c0 = -1/2``.
* **hub reactions** are returned in the drive side's solver frame (the inner frame mirrored: ``Fy``, ``Mz``
  change sign; a face-resolving inner solver already returns them in the physical frame).
* **face-resolving (helical) inner solvers**
  (:class:`~hacgear_core.statics.helical.HelicalMeshContactSolver` built with ``side="coast"``) keep their
  physical mesh frame (``frame``: ``r_mesh``, ``r_twist`` of the coast flanks over the same 12 DOF as the
  drive side's), the mesh twist ``gamma_c = r_twist · q`` of that frame is passed through unchanged, and the
  deflection is the normal one: ``x_c = x_s + j_n cos(beta_bc)`` (``beta_bc`` the coast flanks' base helix
  angle, ``j_n`` the transverse normal backlash), so that ``x_c = r_mesh · q`` with ``q = 0`` the drive
  kinematic position.

The derivation (``docs/tables.md``, "The coast side"): with both hubs sharing the mesh deflection equally, each
gear's rotation in mesh cycles is ``u_a = tau + x_d/(2 p_b)``, ``u_b = tau - x_d/(2 p_b)``; the coast-side
coordinates of the same gear angles are ``u'_a = -u_a + s_wa/p_w``, ``u'_b = -u_b - s_wb/p_w``; the inner
solver's pair 0 meets the coast flank of gear_a's tooth one pitch later than the drive pair 0 does
(``u'_a = tau_c + x_s/(2 p_bc) + 1``, ``u'_b = tau_c - x_s/(2 p_bc)``), which gives ``tau_c = c0 - tau``,
``x_s = x_c - j_n`` and the pair shifts above, for external and internal meshes alike.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Sequence

import numpy as np

from hacgear_core.errors import SolverError
from hacgear_core.geometry import mesh_geometry
from hacgear_core.model import Model
from hacgear_core.kinds import load_model
from hacgear_core.statics.contact import ContactOptions, default_contact_options
from hacgear_core.statics.contract import MeshStaticSolver, StaticSolution
from hacgear_core.statics.helical import make_solver, needs_face_resolving_solver

__all__ = ["CoastSideSolver", "CoastMapping", "coast_mapping", "coast_pair_centre", "make_coast_solver",
           "COAST_PAIR_SHIFT"]

#: coast pair k' holds the tooth of gear_a (index 0) / gear_b (index 1) that drive pair k' - shift holds
COAST_PAIR_SHIFT = (1, 0)


@dataclass(frozen=True)
class CoastMapping:
    """How a mesh's coast side maps onto its drive side (from the geometry).

    ``position_offset`` ``c0`` [mesh cycles] (inner coast position = ``c0 - tau``), ``backlash_normal_m``
    ``j_n`` [m] along the coast line of action, ``backlash_circular_m`` ``j_t`` [m] on the operating pitch
    circle, ``flanks`` the coast flank of (gear_a, gear_b), ``pair_shift`` {gear: int}.
    """

    position_offset: float
    backlash_normal_m: float
    backlash_circular_m: float
    flanks: tuple[str, str]
    pair_shift: dict[str, int]


def coast_mapping(model: Any, mesh_name: str) -> CoastMapping:
    """:class:`CoastMapping` of mesh ``mesh_name`` of ``model`` (a :class:`~hacgear_core.model.Model` or path)."""
    if not isinstance(model, Model):
        model = load_model(model)
    mg = mesh_geometry(model, mesh_name, strict=False)
    other = {"drive": "coast", "coast": "drive"}
    if not (math.isfinite(mg.backlash_normal_m) and mg.backlash_normal_m >= 0):
        raise SolverError(f"mesh '{mesh_name}': the coast flanks have no line of action (normal backlash "
                          f"{mg.backlash_normal_m!r} m); see `hacgear info` warnings")
    return CoastMapping(position_offset=float(mg.coast_position_offset),
                        backlash_normal_m=float(mg.backlash_normal_m),
                        backlash_circular_m=float(mg.backlash_circular_m),
                        flanks=(other[mg.flank_a], other[mg.flank_b]),
                        pair_shift={mg.gear_a: COAST_PAIR_SHIFT[0], mg.gear_b: COAST_PAIR_SHIFT[1]})


class CoastSideSolver:
    """The coast side of a mesh as a :class:`~hacgear_core.statics.contract.MeshStaticSolver` in drive-side
    positions (``tau``) and coast approach (``x_c``, from the drive kinematic position); see the module docstring.

    Parameters
    ----------
    inner : MeshStaticSolver
        Static solver of the coast flank pair in its own canonical picture (e.g.
        ``make_mesh_solver(model, mesh, side="coast")``).
    mapping : CoastMapping
        From :func:`coast_mapping`.
    """

    side = "coast"

    def __init__(self, inner: MeshStaticSolver, mapping: CoastMapping) -> None:
        self.inner = inner
        self.mapping = mapping
        self.mesh_name = inner.mesh_name
        self.gear_names = tuple(inner.gear_names)
        self.teeth = tuple(inner.teeth)
        self.base_radius_m = tuple(inner.base_radius_m)
        self.gauge_names = tuple(inner.gauge_names)
        offs = np.asarray(inner.tooth_offsets, dtype=np.int64)
        self.tooth_offsets = np.sort(-offs)
        # row of the inner per-pair arrays for each coast offset k' (inner offset -k')
        self._rows = np.array([int(np.flatnonzero(offs == -k)[0]) for k in self.tooth_offsets])
        self.flanks = mapping.flanks
        self.backlash_normal_m = mapping.backlash_normal_m
        self.backlash_circular_m = mapping.backlash_circular_m
        self.position_offset = mapping.position_offset
        self.pair_shift = dict(mapping.pair_shift)
        # face-resolving inner solver: its physical mesh frame, slices and normal (3D) deflection
        self._face = bool(getattr(inner, "_resolves_face", False))
        self.frame = getattr(inner, "frame", None)
        if self.frame is not None:
            self.z_centre_m = inner.z_centre_m
            self.slice_z_m = inner.slice_z_m
            self.lever_arm_m = tuple(inner.lever_arm_m)
        cb = 1.0 if self.frame is None else math.cos(self.frame.base_helix_angle_rad)
        self.contact_deflection_m = mapping.backlash_normal_m * cb
        self.description = (f"{getattr(inner, 'description', type(inner).__name__)}; coast side in drive positions "
                            f"(inner position = {mapping.position_offset:.12g} - position, deflection = inner + "
                            f"{self.contact_deflection_m:.9g} m)")

    # -- coordinates ------------------------------------------------------------------------------
    def inner_position(self, position: float) -> float:
        """Inner solver's own position [mesh cycles] at drive-side ``position``."""
        return self.position_offset - float(position)

    def _convert(self, sol: StaticSolution, position: float) -> StaticSolution:
        r = self._rows

        def per_pair(d: dict) -> dict:
            return {k: np.asarray(v)[r] for k, v in d.items()}

        flip = [1.0, 1.0, 1.0] if self._face else [1.0, -1.0, -1.0]
        hub = {g: np.asarray(v, float) * flip for g, v in sol.hub_reaction.items()}
        return replace(sol, position=float(position),
                       mesh_deflection_m=sol.mesh_deflection_m + self.contact_deflection_m,
                       tooth_load_N=np.asarray(sol.tooth_load_N)[r], contact_roll_deg=np.asarray(sol.contact_roll_deg)[r],
                       half_width_m=np.asarray(sol.half_width_m)[r], peak_pressure_Pa=np.asarray(sol.peak_pressure_Pa)[r],
                       flank_pressure_Pa=None if sol.flank_pressure_Pa is None else np.asarray(sol.flank_pressure_Pa)[r],
                       edge_pressure_Pa=None if sol.edge_pressure_Pa is None else np.asarray(sol.edge_pressure_Pa)[r],
                       strain=per_pair(sol.strain), stress=per_pair(sol.stress), hub_reaction=hub,
                       contact_s_m=None if sol.contact_s_m is None else np.asarray(sol.contact_s_m)[r],
                       pattern_load_N=None if sol.pattern_load_N is None else np.asarray(sol.pattern_load_N)[r])

    # -- protocol -----------------------------------------------------------------------------------
    def _twist(self, twist_rad: float) -> dict:
        if twist_rad and not self._face:
            raise SolverError(f"mesh '{self.mesh_name}': twist_rad = {twist_rad!r} rad needs a face-resolving "
                              "(helical) solver; allowed: 0")
        return {"twist_rad": float(twist_rad)} if self._face else {}

    def no_load_deflection(self, position: float, twist_rad: float = 0.0) -> float:
        """Coast no-load deflection [m] (coast approach at which the coast flanks first touch) at drive
        ``position`` and coast mesh twist ``twist_rad`` [rad] (face-resolving solvers)."""
        return (float(self.inner.no_load_deflection(self.inner_position(position), **self._twist(twist_rad)))
                + self.contact_deflection_m)

    def solve_load(self, position: float, mesh_force_N: float, twist_rad: float = 0.0) -> StaticSolution:
        """Load control: coast contact force [N] >= 0 at drive ``position`` → coast approach etc."""
        return self._convert(self.inner.solve_load(self.inner_position(position), mesh_force_N,
                                                   **self._twist(twist_rad)), position)

    def solve_deflection(self, position: float, mesh_deflection_m: float, twist_rad: float = 0.0) -> StaticSolution:
        """Deflection control: coast approach ``x_c`` [m] at drive ``position`` → coast contact force etc."""
        return self._convert(self.inner.solve_deflection(self.inner_position(position),
                                                         float(mesh_deflection_m) - self.contact_deflection_m,
                                                         **self._twist(twist_rad)), position)

    def solve_position(self, position: float, loads_N: Sequence[float], deflections_m: Sequence[float],
                       twist_rad: float = 0.0):
        """Batch at one position (see :meth:`MeshContactSolver.solve_position`)."""
        p = self.inner_position(position)
        kw = self._twist(twist_rad)
        x = np.asarray(deflections_m, dtype=float).ravel() - self.contact_deflection_m
        batch = getattr(self.inner, "solve_position", None)
        if batch is not None:
            a, b = batch(p, np.asarray(loads_N, float).ravel(), x, **kw)
        else:
            a = [self.inner.solve_load(p, F, **kw) for F in np.asarray(loads_N, float).ravel()]
            b = [self.inner.solve_deflection(p, v, **kw) for v in x]
        return [self._convert(s, position) for s in a], [self._convert(s, position) for s in b]


def coast_pair_centre(mapping: CoastMapping) -> int:
    """Centre of the coast flank pair's window of reported pairs, in the inner solver's own pair numbering.

    The inner solver is asked at its positions ``c0 - tau`` in ``(c0 - 1, c0]`` (``tau`` in [0, 1)); the pairs
    touching there have inner phase ``c0 - tau - k`` around 0 (the inner contact path is centred on its pitch
    point), so the window ``centre +- pair_window`` with ``centre = round(c0 - 1/2)`` covers inner phases
    ``(c0 - 1 - centre - W, c0 - centre + W]``, centred within half a pair on 0.  For ``c0 = -1/2`` (equal
    tooth thicknesses) that is ``(-2.5, 2.5]`` with the default ``W = 2``: coast offsets ``-1 .. 3``.  A window
    centred on 0 instead (inner phases ``(-3.5, 1.5]``) loses the pair past inner phase 1.5 that a mesh whose
    contact spans more than three pairs loads (the ring-planet mesh of ``planetary_65_55_175``: up to 1.6)."""
    return int(round(mapping.position_offset - 0.5))


def make_coast_solver(model: Any, mesh_name: str, *, options: ContactOptions | None = None,
                      **kwargs: Any) -> CoastSideSolver:
    """Coast side of mesh ``mesh_name``: :func:`~hacgear_core.statics.helical.make_solver` (spur or helical) with
    ``side="coast"`` (``kwargs`` passed on) wrapped in :class:`CoastSideSolver` with the geometry's mapping.
    Spur meshes: ``options`` default the model's face slices, and their ``pair_centre`` is replaced by
    :func:`coast_pair_centre` (the reported pairs are those that touch at the coast side's own positions).  The
    face-resolving (helical) solver picks its candidate pairs around each slice's own phase and keeps its default
    options."""
    if not isinstance(model, Model):
        model = load_model(model)
    mapping = coast_mapping(model, mesh_name)
    if not needs_face_resolving_solver(model, mesh_name, options):
        if options is None:
            options = default_contact_options(model, mesh_name)
        options = replace(options, pair_centre=coast_pair_centre(mapping))
    return CoastSideSolver(make_solver(model, mesh_name, side="coast", options=options, **kwargs), mapping)
