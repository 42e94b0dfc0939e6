"""Validated, frozen SI dataclasses of a gear system (what a model file means; one table of ranges).

Every dataclass checks its fields in ``__post_init__`` and raises :class:`~hacgear_core.errors.ModelError`
naming the field, its unit and the allowed range.  Units: SI throughout, the unit in the attribute name where
it could be ambiguous (``module_m``, ``tip_relief_m``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from hacgear_core.errors import ModelError
from hacgear_core.model import iso21771 as _iso

__all__ = [
    "FLANKS",
    "RELIEF_SHAPES",
    "WEB_MIN_RIM_M",
    "Material",
    "Flank",
    "Gauge",
    "Support",
    "Web",
    "GearErrors",
    "ISO1328_GRADES",
    "Gear",
    "IsoGear",
    "HANDS",
    "Mesh",
    "Damping",
    "Operating",
    "StaticsGrid",
    "PinError",
    "PlanetErrors",
    "Planetary",
    "LumpedGear",
    "PLANETARY_MEMBERS",
    "Model",
    "Range",
    "RANGES",
]

#: the central members of a planetary set (``carrier`` is not a gear of ``[[gears]]``)
PLANETARY_MEMBERS = ("sun", "ring", "carrier")
FLANKS = ("drive", "coast")
RELIEF_SHAPES = ("none", "linear", "parabolic")

_INF = math.inf


def _fail(field_name: str, unit: str, allowed: str, got: Any, where: str = "") -> ModelError:
    unit_txt = f" [{unit}]" if unit else ""
    loc = f"{where}: " if where else ""
    return ModelError(f"{loc}{field_name}{unit_txt} = {got!r} is out of range; allowed: {allowed}")


def _check_range(
    name: str, value: float, unit: str, lo: float | None, hi: float | None, *, lo_open: bool = False,
    hi_open: bool = False,
) -> None:
    """Raise ModelError if ``value`` is NaN or outside [lo, hi] (bounds optional/open)."""
    bad = value != value  # NaN
    if lo is not None:
        bad |= value <= lo if lo_open else value < lo
    if hi is not None:
        bad |= value >= hi if hi_open else value > hi
    if bad:
        lo_txt = "-inf" if lo is None else f"{lo:g}"
        hi_txt = "inf" if hi is None else f"{hi:g}"
        allowed = f"{'(' if lo_open or lo is None else '['}{lo_txt}, {hi_txt}{')' if hi_open or hi is None else ']'}"
        raise _fail(name, unit, allowed, value)


@dataclass(frozen=True)
class Range:
    """The allowed values of one quantity, in its unit ``unit``: ``[lo, hi]`` (``lo_open``/``hi_open``: that bound
    excluded; None: unbounded), integers only when ``integer``, and ``+inf`` as well when ``allow_inf`` (a rigid
    support).  :data:`RANGES` holds one per quantity; model files, the command line and the FMUs read them there."""

    unit: str
    lo: float | None
    hi: float | None
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False
    allow_inf: bool = False

    @property
    def text(self) -> str:
        """The range as the error messages state it, e.g. ``integer in [4, 4096]``, ``(0, 1e+15] or inf``."""
        lo_txt = "-inf" if self.lo is None else f"{self.lo:g}"
        hi_txt = "inf" if self.hi is None else f"{self.hi:g}"
        txt = (f"{'(' if self.lo_open or self.lo is None else '['}{lo_txt}, {hi_txt}"
               f"{')' if self.hi_open or self.hi is None else ']'}")
        return ("integer in " if self.integer else "") + txt + (" or inf" if self.allow_inf else "")

    def contains(self, value: Any) -> bool:
        """True when ``value`` lies in the range."""
        if isinstance(value, bool):
            return False
        if self.integer:
            if not isinstance(value, int):
                return False
        else:
            try:
                value = float(value)
            except (TypeError, ValueError, OverflowError):
                return False
            if value != value:  # NaN
                return False
            if self.allow_inf and value == _INF:
                return True
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        if self.hi is not None and (value >= self.hi if self.hi_open else value > self.hi):
            return False
        return True

    def check(self, name: str, value: Any, where: str = "") -> Any:
        """``value`` when it lies in the range, else :class:`ModelError` naming ``name``, the unit, the value and
        the range (``name``: a field, a model-file key or a command-line option)."""
        if not self.contains(value):
            raise _fail(name, self.unit, self.text, value, where)
        return value


#: One range per quantity that a model file, the command line and the FMU share (units as ``Range.unit``).
RANGES: dict[str, Range] = {
    # magnitude: a negative torque (command line, FMU) loads the coast flanks; a model file's operating torque is > 0
    "torque_Nm": Range("N*m", 0.0, 1e8, lo_open=True),
    # an underdamped modal damping ratio: every elastic mode keeps an oscillating part
    "modal_damping_ratio": Range("-", 0.0, 1.0, hi_open=True),
    # a rigid bearing is inf (no translation DOF) everywhere: model files, --bearing-stiffness, the FMU; 0 is no
    # bearing (a floating member of a planetary set; fixed-axis trains need > 0)
    "translational_stiffness_N_per_m": Range("N/m", 0.0, 1e15, allow_inf=True),
    "planet_count": Range("-", 1, 12, integer=True),
    "statics.positions": Range("-", 4, 4096, integer=True),
    "statics.loads": Range("-", 2, 1024, integer=True),
    "statics.deflections": Range("-", 4, 4096, integer=True),
    "statics.face_slices": Range("-", 1, 200, integer=True),
    "statics.twist_points": Range("-", 1, 64, integer=True),
    # tables span 0 ... >= 3 x the nominal load (hacgear statics --check requires it)
    "statics.max_torque_factor": Range("-", 3.0, 20.0),
    "mesh_frequency_Hz": Range("Hz", 0.0, 1e5, lo_open=True),
    "speed_rad_s": Range("rad/s", -2e4, 2e4),
}


# --------------------------------------------------------------------------------------------
# Dataclasses (SI)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Material:
    """Linear elastic, isotropic material.

    Attributes: ``density_kg_per_m3`` (kg/m³), ``youngs_modulus_Pa`` (Pa), ``poisson_ratio`` (-).
    """

    name: str
    density_kg_per_m3: float
    youngs_modulus_Pa: float
    poisson_ratio: float

    def __post_init__(self) -> None:
        _check_range("density_kg_per_m3", self.density_kg_per_m3, "kg/m^3", 100.0, 30000.0)
        _check_range("youngs_modulus_Pa", self.youngs_modulus_Pa, "Pa", 1e9, 1e12)
        _check_range("poisson_ratio", self.poisson_ratio, "-", 0.0, 0.5, hi_open=True)


@dataclass(frozen=True)
class Flank:
    """One flank of a tooth: pressure angle and tip relief.

    ``pressure_angle_rad`` is the (transverse) pressure angle at the reference circle;
    ``tip_relief_m`` the material removed at the tip along the flank normal, starting at roll angle
    ``tip_relief_start_roll_rad`` (0 → no relief) and growing ``linear``-ly or ``parabolic``-ally
    with roll angle up to the tip.
    """

    pressure_angle_rad: float
    tip_relief_m: float = 0.0
    tip_relief_start_roll_rad: float = 0.0
    tip_relief_shape: str = "none"

    def __post_init__(self) -> None:
        _check_range("pressure_angle_rad", self.pressure_angle_rad, "rad", math.radians(5), math.radians(40))
        _check_range("tip_relief_m", self.tip_relief_m, "m", 0.0, 1e-3)
        _check_range("tip_relief_start_roll_rad", self.tip_relief_start_roll_rad, "rad", 0.0, math.radians(89))
        if self.tip_relief_shape not in RELIEF_SHAPES:
            raise _fail("tip_relief_shape", "", " | ".join(RELIEF_SHAPES), self.tip_relief_shape)
        if self.tip_relief_m > 0 and self.tip_relief_shape == "none":
            raise ModelError("tip_relief_shape = 'none' but tip_relief_m > 0; allowed: linear | parabolic")
        if self.tip_relief_m > 0 and self.tip_relief_start_roll_rad <= 0:
            raise ModelError("tip_relief_start_roll_rad [rad] must be > 0 when tip_relief_m > 0")

    @property
    def has_relief(self) -> bool:
        return self.tip_relief_m > 0.0


@dataclass(frozen=True)
class Gauge:
    """A strain gauge on the root surface of a flank at a given radius from the gear centre [m], at the axial
    position ``face_fraction`` of the gear's face width (0 = its face at lower axial coordinate, 1 = the other
    face; 0.5 = mid-face, which face-averaging solvers assume)."""

    name: str
    flank: str
    radius_m: float
    face_fraction: float = 0.5

    def __post_init__(self) -> None:
        if self.flank not in FLANKS:
            raise _fail("flank", "", " | ".join(FLANKS), self.flank)
        _check_range("radius_m", self.radius_m, "m", 0.0, 10.0, lo_open=True)
        _check_range("face_fraction", self.face_fraction, "-", 0.0, 1.0)


@dataclass(frozen=True)
class Support:
    """Bearing/shaft stiffness of one gear (SI).  ``inf`` translational stiffness: rigid (no
    translation DOF); ``0`` rotational stiffness: free rotation (torque-driven)."""

    translational_stiffness_N_per_m: float = _INF
    rotational_stiffness_Nm_per_rad: float = 0.0
    axial_stiffness_N_per_m: float = _INF
    tilting_stiffness_Nm_per_rad: float = _INF

    def __post_init__(self) -> None:
        RANGES["translational_stiffness_N_per_m"].check("translational_stiffness_N_per_m",
                                                        self.translational_stiffness_N_per_m)
        for name, unit in (
            ("rotational_stiffness_Nm_per_rad", "N*m/rad"),
            ("axial_stiffness_N_per_m", "N/m"),
            ("tilting_stiffness_Nm_per_rad", "N*m/rad"),
        ):
            _check_range(name, getattr(self, name), unit, 0.0, None)

    @property
    def rigid_translation(self) -> bool:
        return math.isinf(self.translational_stiffness_N_per_m)


#: accuracy grades of ISO 1328-1:2013 (single pitch tolerance ``f_pT``, :func:`hacgear_core.dynamics.gear_errors.iso1328_single_pitch_tolerance_m`)
ISO1328_GRADES = (1, 11)


@dataclass(frozen=True)
class GearErrors:
    """Manufacturing errors of one gear (SI; docs/spectra.md "Manufacturing errors").

    ``single_pitch_deviations_m``: the single pitch deviation ``f_p,j`` [m] of every pitch, on the reference
    circle, ``j = 0 .. z-1`` the pitch ending at tooth ``j`` (from tooth ``j - 1``, tooth ``-1`` = tooth ``z - 1``;
    teeth counted in the order they reach a mesh); positive: a longer pitch, tooth ``j`` and the teeth after it
    arrive later.  They close (their sum is 0, within 1e-9 m).  Empty: none, or generated from ``iso1328_grade``
    (ISO 1328-1:2013 accuracy grade, an integer in [1, 11]) with the random ``seed`` (an integer >= 0).
    ``runout_m``: eccentricity [m] of the gear's teeth about its axis of rotation (the runout ``F_r`` of ISO
    1328-2 is about twice it), in [0, 1e-3]; ``runout_phase_rad``: the direction of the offset of the teeth's
    centre, from tooth 0's centre line in the gear's sense of rotation, in [-2 pi, 2 pi].
    ``lead_slope_m``: the helix slope deviation ``f_Hbeta`` [m] of the flank the gear loads in its mesh, over the
    gear's own face width, measured along the transverse line of action (tangent to the base circle, as ISO 1328-1
    measures helix deviations); positive: material added at the gear's +z face end relative to its -z end, in
    [-1e-3, 1e-3].  The sign is geometric: an inspection report's signed f_Hbeta follows its own rule (helix angle,
    flank, reference face), so check which face end of this flank gains material before copying a value.  It enters the dynamics as a
    constant offset of the mesh twist (:mod:`hacgear_core.dynamics.lead`; helical meshes only), not through the
    error profile (:attr:`any` leaves it out)."""

    single_pitch_deviations_m: tuple[float, ...] = ()
    iso1328_grade: int | None = None
    seed: int = 0
    runout_m: float = 0.0
    runout_phase_rad: float = 0.0
    lead_slope_m: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "single_pitch_deviations_m", tuple(float(v) for v in self.single_pitch_deviations_m))
        for v in self.single_pitch_deviations_m:
            _check_range("errors.single_pitch_deviations_m", v, "m", -1e-3, 1e-3)
        if self.single_pitch_deviations_m and abs(sum(self.single_pitch_deviations_m)) > 1e-9:
            raise ModelError(f"errors.single_pitch_deviations_m [m] must close (sum 0 within 1e-9 m: the pitches "
                             f"make up the whole circle), got sum {sum(self.single_pitch_deviations_m):.6g} m")
        if self.iso1328_grade is not None:
            lo, hi = ISO1328_GRADES
            if isinstance(self.iso1328_grade, bool) or not isinstance(self.iso1328_grade, int) or not (
                    lo <= self.iso1328_grade <= hi):
                raise _fail("errors.iso1328_grade", "-", f"integer in [{lo}, {hi}]", self.iso1328_grade)
            if self.single_pitch_deviations_m:
                raise ModelError("errors: give single_pitch_deviations_m or iso1328_grade, not both")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or not 0 <= self.seed < 2 ** 63:
            raise _fail("errors.seed", "-", "integer in [0, 2**63)", self.seed)
        _check_range("errors.runout_m", self.runout_m, "m", 0.0, 1e-3)
        _check_range("errors.runout_phase_rad", self.runout_phase_rad, "rad", -2 * math.pi, 2 * math.pi)
        _check_range("errors.lead_slope_m", self.lead_slope_m, "m", -1e-3, 1e-3)

    @property
    def any(self) -> bool:
        """Whether the gear has a pitch or runout error (the errors of the mesh error profile,
        :mod:`hacgear_core.dynamics.gear_errors`; a lead slope deviation acts through the mesh twist instead)."""
        return bool(self.single_pitch_deviations_m) or self.iso1328_grade is not None or self.runout_m != 0.0


#: smallest radial rim thickness a web may leave below the root circle: outer_diameter <= root - 2 * this
WEB_MIN_RIM_M = 1e-3


@dataclass(frozen=True)
class Web:
    """Web of a webbed gear blank (SI): a thin annulus of axial ``thickness_m`` between the hub
    (outer diameter ``inner_diameter_m``) and the rim (inner diameter ``outer_diameter_m``); hub and
    rim keep the full face width.  Checks against the gear (bore, root, face width) are in
    :class:`Gear`."""

    thickness_m: float
    inner_diameter_m: float
    outer_diameter_m: float

    def __post_init__(self) -> None:
        _check_range("web.thickness_m", self.thickness_m, "m", 0.0, 2.0, lo_open=True)
        _check_range("web.inner_diameter_m", self.inner_diameter_m, "m", 0.0, 40.0, lo_open=True)
        _check_range("web.outer_diameter_m", self.outer_diameter_m, "m", 0.0, 40.0, lo_open=True)
        if not self.inner_diameter_m < self.outer_diameter_m:
            raise ModelError(
                f"web.inner_diameter_m [m] = {self.inner_diameter_m:g} must be smaller than web.outer_diameter_m "
                f"= {self.outer_diameter_m:g} m"
            )

    @property
    def inner_radius_m(self) -> float:
        return 0.5 * self.inner_diameter_m

    @property
    def outer_radius_m(self) -> float:
        return 0.5 * self.outer_diameter_m


#: helix hands of the ISO form; a right-hand helix is a positive ``Gear.helix_angle_rad`` (the transverse section
#: turns counter-clockwise, seen from +z, as z grows)
HANDS = ("right", "left")


@dataclass(frozen=True)
class IsoGear:
    """The ISO 21771 / ISO 53 data a gear of the ISO form was given in (SI), kept beside the transverse form it was
    converted to (:attr:`Gear.iso`; the geometry reads the transverse form only, ``hacgear info`` reports both).

    ``normal_module_m`` m_n; ``normal_pressure_angle_rad`` alpha_n; ``helix_angle_rad`` beta >= 0 at the reference
    cylinder and its ``hand`` (``right`` | ``left``; ``""`` for spur gears); ``profile_shift`` x (normal, ISO sign:
    an internal gear's x is positive towards its tooth tips, i.e. towards the axis); ``tip_alteration`` k (tip
    diameter d_a = d +- 2 m_n (h_aP* + x + k)), ``tip_source`` the key it came from (``tip_alteration_mm`` or
    ``tip_diameter_mm``); ``basic_rack`` an ISO 53 profile name (``A`` .. ``D``) or ``custom``, with its
    ``addendum_coefficient`` h_aP*, ``dedendum_coefficient`` h_fP*, ``root_radius_coefficient`` rho_fP*;
    ``thickness_allowance_upper_m`` / ``thickness_allowance_lower_m`` A_sne / A_sni (normal, on the reference
    cylinder; the teeth are modelled at their mean); ``internal`` as the gear.  Equations:
    :mod:`hacgear_core.model.iso21771`.
    """

    teeth: int
    normal_module_m: float
    normal_pressure_angle_rad: float
    helix_angle_rad: float = 0.0
    hand: str = ""
    profile_shift: float = 0.0
    tip_alteration: float = 0.0
    tip_source: str = "tip_alteration_mm"
    basic_rack: str = "A"
    addendum_coefficient: float = 1.0
    dedendum_coefficient: float = 1.25
    root_radius_coefficient: float = 0.38
    thickness_allowance_upper_m: float = 0.0
    thickness_allowance_lower_m: float = 0.0
    internal: bool = False

    def __post_init__(self) -> None:
        if isinstance(self.teeth, bool) or not isinstance(self.teeth, int) or not 6 <= self.teeth <= 1000:
            raise _fail("teeth", "-", "integer in [6, 1000]", self.teeth)
        _check_range("normal_module_m", self.normal_module_m, "m", 1e-4, 0.1)
        _check_range("normal_pressure_angle_rad", self.normal_pressure_angle_rad, "rad", math.radians(5),
                     math.radians(40))
        _check_range("helix_angle_rad", self.helix_angle_rad, "rad", 0.0, math.radians(45))
        if self.helix_angle_rad > 0 and self.hand not in HANDS:
            raise _fail("hand", "", " | ".join(HANDS) + " (a helical gear)", self.hand)
        if self.helix_angle_rad == 0 and self.hand:
            raise _fail("hand", "", "'' (a spur gear has no hand)", self.hand)
        _check_range("profile_shift", self.profile_shift, "-", -3.0, 3.0)
        _check_range("tip_alteration", self.tip_alteration, "-", -3.0, 3.0)
        if self.tip_source not in ("tip_alteration_mm", "tip_diameter_mm"):
            raise _fail("tip_source", "", "tip_alteration_mm | tip_diameter_mm", self.tip_source)
        if self.basic_rack not in tuple(_iso.BASIC_RACKS) + ("custom",):
            raise _fail("basic_rack", "", " | ".join(_iso.BASIC_RACKS) + " | custom", self.basic_rack)
        _check_range("addendum_coefficient", self.addendum_coefficient, "-", 0.5, 2.0)
        _check_range("dedendum_coefficient", self.dedendum_coefficient, "-", 0.5, 2.5)
        _check_range("root_radius_coefficient", self.root_radius_coefficient, "-", 0.0, 1.0, lo_open=True)
        if not self.dedendum_coefficient > self.addendum_coefficient:
            raise ModelError(f"dedendum_coefficient h_fP* = {self.dedendum_coefficient:g} must exceed "
                             f"addendum_coefficient h_aP* = {self.addendum_coefficient:g} (the mate's tip needs a "
                             "root clearance)")
        lim = 0.5 * self.normal_module_m
        for name in ("thickness_allowance_upper_m", "thickness_allowance_lower_m"):
            _check_range(name, getattr(self, name), "m", -lim, lim)
        if self.thickness_allowance_lower_m > self.thickness_allowance_upper_m:
            raise ModelError(
                f"thickness_allowance_lower [mm] = {self.thickness_allowance_lower_m * 1e3:g} exceeds "
                f"thickness_allowance_upper [mm] = {self.thickness_allowance_upper_m * 1e3:g}; allowed: lower <= upper")
        h_a = self.addendum_coefficient + self.profile_shift + self.tip_alteration
        if not h_a > 0:
            raise ModelError(
                f"tip addendum h_aP* + x + k = {self.addendum_coefficient:g} + {self.profile_shift:g} + "
                f"{self.tip_alteration:.6g} = {h_a:.6g} puts the tip circle inside the reference circle; allowed: > 0 "
                f"(a larger tip_alteration_mm or tip diameter, or a larger profile_shift)")
        h_f = self.dedendum_coefficient - self.profile_shift
        if not h_f > 0:
            raise ModelError(
                f"root dedendum h_fP* - x = {self.dedendum_coefficient:g} - {self.profile_shift:g} = {h_f:.6g} puts "
                f"the root circle beyond the reference circle; allowed: profile_shift < {self.dedendum_coefficient:g}")
        s_n, p_n = self.normal_tooth_thickness_m, math.pi * self.normal_module_m
        if not 0.1 * p_n < s_n < 0.9 * p_n:
            raise ModelError(
                f"normal tooth thickness s_n = m_n (pi/2 + 2 x tan(alpha_n)) + mean allowance = {s_n * 1e3:.6g} mm "
                f"must lie within (0.1, 0.9) x pi m_n = ({0.1e3 * p_n:.6g}, {0.9e3 * p_n:.6g}) mm (profile_shift "
                f"{self.profile_shift:g}, thickness allowances {self.thickness_allowance_upper_m * 1e3:g} / "
                f"{self.thickness_allowance_lower_m * 1e3:g} mm)")

    # -- ISO 21771 closed forms (SI) -----------------------------------------------------------
    @property
    def signed_helix_angle_rad(self) -> float:
        """The helix angle with the sign of the transverse form: + right hand, - left hand."""
        return -self.helix_angle_rad if self.hand == "left" else self.helix_angle_rad

    @property
    def transverse_module_m(self) -> float:
        return _iso.transverse_module(self.normal_module_m, self.helix_angle_rad)

    @property
    def transverse_pressure_angle_rad(self) -> float:
        return _iso.transverse_pressure_angle(self.normal_pressure_angle_rad, self.helix_angle_rad)

    @property
    def reference_diameter_m(self) -> float:
        return _iso.reference_diameter(self.teeth, self.normal_module_m, self.helix_angle_rad)

    @property
    def tip_diameter_m(self) -> float:
        return _iso.tip_diameter(self.teeth, self.normal_module_m, self.helix_angle_rad, self.addendum_coefficient,
                                 self.profile_shift, self.tip_alteration, self.internal)

    @property
    def root_diameter_m(self) -> float:
        return _iso.root_diameter(self.teeth, self.normal_module_m, self.helix_angle_rad, self.dedendum_coefficient,
                                  self.profile_shift, self.internal)

    @property
    def thickness_allowance_mean_m(self) -> float:
        return 0.5 * (self.thickness_allowance_upper_m + self.thickness_allowance_lower_m)

    @property
    def nominal_normal_tooth_thickness_m(self) -> float:
        """s_n without allowance [m] (reference cylinder)."""
        return _iso.normal_tooth_thickness(self.normal_module_m, self.normal_pressure_angle_rad, self.profile_shift)

    @property
    def normal_tooth_thickness_m(self) -> float:
        """s_n at the mean allowance [m]: the tooth the geometry models."""
        return self.nominal_normal_tooth_thickness_m + self.thickness_allowance_mean_m

    @property
    def transverse_tooth_thickness_m(self) -> float:
        """s_t = s_n / cos(beta) [m] at the mean allowance (the transverse form's ``tooth_thickness_m``)."""
        return self.normal_tooth_thickness_m / math.cos(self.helix_angle_rad)

    @property
    def tool_tip_radius_m(self) -> float:
        """rho_fP = rho_fP* m_n [m], the transverse form's ``hob_tip_radius_m`` (the tool's normal-section radius)."""
        return self.root_radius_coefficient * self.normal_module_m

    @property
    def mesh_teeth(self) -> int:
        """The tooth count of the mesh relations: negative for an internal gear (ISO 21771)."""
        return _iso.mesh_tooth_count(self.teeth, self.internal)


@dataclass(frozen=True)
class Gear:
    """One gear (SI).  For helical gears, module, pressure angles and tooth thickness are transverse.

    ``teeth``: number of teeth; ``internal``: ring gear (material outside the teeth);
    ``tip_diameter_m`` / ``root_diameter_m``: for internal gears the tip diameter is the smaller one;
    ``tooth_thickness_m``: circular tooth thickness on the reference circle; ``hob_tip_radius_m``: edge
    radius of the generating tool tip; ``bore_diameter_m``: hub bore (inner boundary of the blank; for
    internal gears the outer rim diameter); ``mass_kg``/``inertia_kgm2``: lumped values overriding the
    values computed from the blank (None: computed); ``web``: a :class:`Web` (webbed blank: hub from the
    bore to ``web.inner_diameter_m``, web of ``web.thickness_m``, full-width rim from ``web.outer_diameter_m``
    to the root) or None (solid blank from the bore to the root); ``iso``: the :class:`IsoGear` data a gear of the
    ISO 21771 form was converted from (None: the gear was given in this transverse form).
    """

    name: str
    teeth: int
    module_m: float
    tip_diameter_m: float
    root_diameter_m: float
    tooth_thickness_m: float
    hob_tip_radius_m: float
    face_width_m: float
    bore_diameter_m: float
    material: Material
    flanks: Mapping[str, Flank]
    internal: bool = False
    helix_angle_rad: float = 0.0
    axial_position_m: float = 0.0
    lead_crowning_m: float = 0.0
    tip_edge_radius_m: float = 0.0
    mass_kg: float | None = None
    inertia_kgm2: float | None = None
    gauges: tuple[Gauge, ...] = ()
    support: Support = field(default_factory=Support)
    web: Web | None = None
    iso: IsoGear | None = None
    errors: GearErrors | None = None

    def __post_init__(self) -> None:
        where = f"gear '{self.name}'"
        if self.errors is not None and self.errors.single_pitch_deviations_m and len(
                self.errors.single_pitch_deviations_m) != self.teeth:
            raise ModelError(f"{where}: errors.single_pitch_deviations_m needs one value per tooth ({self.teeth}), "
                             f"got {len(self.errors.single_pitch_deviations_m)}")
        if not isinstance(self.teeth, int) or self.teeth < 6 or self.teeth > 1000:
            raise _fail("teeth", "-", "integer in [6, 1000]", self.teeth, where)
        for name, unit, lo, hi in (
            ("module_m", "m", 1e-4, 0.1),
            ("tip_diameter_m", "m", 1e-3, 20.0),
            ("root_diameter_m", "m", 1e-3, 20.0),
            ("tooth_thickness_m", "m", 1e-5, 1.0),
            ("hob_tip_radius_m", "m", 0.0, 0.05),
            ("face_width_m", "m", 1e-4, 2.0),
            ("bore_diameter_m", "m", 0.0, 40.0),
            ("helix_angle_rad", "rad", -math.radians(45), math.radians(45)),
            ("axial_position_m", "m", -1.0, 1.0),
            ("lead_crowning_m", "m", 0.0, 1e-3),
            ("tip_edge_radius_m", "m", 0.0, 0.01),
        ):
            try:
                _check_range(name, float(getattr(self, name)), unit, lo, hi)
            except ModelError as exc:
                raise ModelError(f"{where}: {exc}") from None
        for name in ("mass_kg", "inertia_kgm2"):
            v = getattr(self, name)
            if v is not None:
                try:
                    _check_range(name, v, "kg" if name == "mass_kg" else "kg*m^2", 0.0, None)
                except ModelError as exc:
                    raise ModelError(f"{where}: {exc}") from None
        if set(self.flanks) != set(FLANKS):
            raise ModelError(f"{where}: flanks must be exactly {FLANKS}, got {tuple(self.flanks)}")
        if self.iso is not None:
            if not isinstance(self.iso, IsoGear):
                raise ModelError(f"{where}: iso must be an IsoGear or None, got {type(self.iso).__name__}")
            if self.iso.teeth != self.teeth or self.iso.internal != self.internal:
                raise ModelError(f"{where}: its ISO data (teeth {self.iso.teeth}, internal {self.iso.internal}) "
                                 f"disagree with the gear (teeth {self.teeth}, internal {self.internal})")
        d_ref = self.module_m * self.teeth
        ref_txt = (f"reference diameter (module_mm x teeth = {self.module_m * 1e3:g} x {self.teeth}) "
                   f"{d_ref * 1e3:.3f} mm")
        if self.internal:
            if not self.tip_diameter_m < d_ref < self.root_diameter_m:
                raise ModelError(
                    f"{where}: internal gear (internal = true) needs tip_diameter < {ref_txt} < root_diameter; got tip_diameter_mm "
                    f"{self.tip_diameter_m * 1e3:.3f}, root_diameter_mm {self.root_diameter_m * 1e3:.3f}"
                )
            if self.bore_diameter_m and self.bore_diameter_m <= self.root_diameter_m:
                raise ModelError(
                    f"{where}: bore_diameter_mm (outer rim diameter of an internal gear) = "
                    f"{self.bore_diameter_m * 1e3:g} must exceed root_diameter_mm = {self.root_diameter_m * 1e3:g} "
                    f"(allowed: 0 for no rim, or > {self.root_diameter_m * 1e3:g} mm)"
                )
        else:
            if not self.root_diameter_m < d_ref < self.tip_diameter_m:
                raise ModelError(
                    f"{where}: external gear (internal = false) needs root_diameter < {ref_txt} < tip_diameter; got root_diameter_mm "
                    f"{self.root_diameter_m * 1e3:.3f}, tip_diameter_mm {self.tip_diameter_m * 1e3:.3f}"
                )
            if self.bore_diameter_m >= self.root_diameter_m:
                raise ModelError(
                    f"{where}: bore_diameter_mm = {self.bore_diameter_m * 1e3:g} must be smaller than "
                    f"root_diameter_mm = {self.root_diameter_m * 1e3:g} "
                    f"(allowed: [0, {self.root_diameter_m * 1e3:g}) mm)"
                )
        pitch = math.pi * self.module_m
        if not 0.1 * pitch < self.tooth_thickness_m < 0.9 * pitch:
            raise ModelError(
                f"{where}: tooth_thickness_mm = {self.tooth_thickness_m * 1e3:g} must lie within (0.1, 0.9) x "
                f"circular pitch (pi x module_mm = {pitch * 1e3:g} mm); allowed: ({0.1e3 * pitch:g}, "
                f"{0.9e3 * pitch:g}) mm"
            )
        names = [g.name for g in self.gauges]
        if len(set(names)) != len(names):
            raise ModelError(f"{where}: gauge names must be unique, got {names}")
        r_lo, r_hi = sorted((0.5 * self.root_diameter_m, 0.5 * self.tip_diameter_m))
        for gauge in self.gauges:
            if not r_lo <= gauge.radius_m <= r_hi:
                raise ModelError(
                    f"{where}: gauge '{gauge.name}' radius_mm = {gauge.radius_m * 1e3:g} does not lie on the tooth; "
                    f"allowed: [{r_lo * 1e3:g}, {r_hi * 1e3:g}] mm (root_diameter_mm / 2 to tip_diameter_mm / 2; "
                    "root gauges sit near the root)")
        if self.web is not None:
            self._check_web(where)

    def _check_web(self, where: str) -> None:
        w = self.web
        if not isinstance(w, Web):
            raise ModelError(f"{where}: web must be a Web or None, got {type(w).__name__}")
        if self.internal:
            raise ModelError(f"{where}: web is not supported for internal gears (ring gears have no hub/web); "
                             "remove [gears.web]")
        if w.thickness_m > self.face_width_m * (1 + 1e-12):
            raise ModelError(
                f"{where}: web.thickness [mm] = {w.thickness_m * 1e3:g} exceeds the face width; allowed: "
                f"(0, face_width = {self.face_width_m * 1e3:g}] mm"
            )
        if not w.inner_diameter_m > self.bore_diameter_m:
            raise ModelError(
                f"{where}: web.inner_diameter [mm] = {w.inner_diameter_m * 1e3:g} must exceed the bore diameter "
                f"{self.bore_diameter_m * 1e3:g} mm (the hub lies between bore and web); allowed: "
                f"(bore_diameter, web.outer_diameter) = ({self.bore_diameter_m * 1e3:g}, "
                f"{w.outer_diameter_m * 1e3:g}) mm"
            )
        d_max = self.root_diameter_m - 2 * WEB_MIN_RIM_M
        if w.outer_diameter_m > d_max * (1 + 1e-12):
            raise ModelError(
                f"{where}: web.outer_diameter [mm] = {w.outer_diameter_m * 1e3:g} leaves no rim below the root "
                f"circle; allowed: (web.inner_diameter, root_diameter - {2e3 * WEB_MIN_RIM_M:g} mm] = "
                f"({w.inner_diameter_m * 1e3:g}, {d_max * 1e3:g}] mm"
            )

    @property
    def is_helical(self) -> bool:
        return self.helix_angle_rad != 0.0

    @property
    def reference_radius_m(self) -> float:
        return 0.5 * self.module_m * self.teeth


@dataclass(frozen=True)
class Mesh:
    """A tooth mesh between ``gear_a`` (driver) and ``gear_b`` (driven).  ``flank_a``/``flank_b`` name
    the flank of each gear that carries the load; ``center_distance_m`` None → derived from the
    geometry (the zero-backlash centre distance, see geometry; planetary: the carrier radius);
    ``line_of_centres_rad``: direction of the vector from gear_a's centre to gear_b's centre in the fixed
    frame (counter-clockwise from the x axis), which places the gears of a train and sets the phase between
    its meshes (:mod:`hacgear_core.geometry.train`).  Lumped models (``Model.lumped``) give instead a constant
    ``mesh_stiffness_N_per_m`` and the operating ``pressure_angle_rad`` of the mesh (no tooth geometry).
    ``misalignment_in_plane_rad``: the installed relative tilt of the two gears' axes in the plane of action, as a
    rotation ``(theta_a - theta_b) . e1`` about the normal to the plane of action (the sign of the mesh twist,
    docs/helical.md: positive closes the flanks at the -z end of the face), in [-0.01, 0.01] rad; helical meshes
    only (:mod:`hacgear_core.dynamics.lead`).  ``axis_deviation_in_axes_plane_rad`` (``f_Sigma_delta``) and
    ``axis_deviation_normal_to_axes_plane_rad`` (``f_Sigma_beta``): the ISO 10064-4 axis parallelism deviations as
    angles (the deviation over the bearing span divided by the span), the rotation of gear_b's axis relative to
    gear_a's about the normal to the plane of the axes (positive: the +z end of gear_b's axis away from gear_a)
    and about the line of centres (positive: right-handed about the direction from gear_a to gear_b), each in
    [-0.01, 0.01] rad; their share about the normal to the plane of action adds to the misalignment (meshes with
    a twist axis only, :func:`hacgear_core.dynamics.lead.axis_deviation_rotation`).
    ``misalignment_out_of_plane_rad``: the installed rotation of gear_b's axis relative to gear_a's about the
    transverse line of action ``e2 = z x e1`` (right-handed), in [-0.01, 0.01] rad: second order on the drive
    flanks (not modelled there, its bound :func:`hacgear_core.dynamics.lead.out_of_plane_gap_m`), first order on
    the coast flanks' own twist axis."""

    name: str
    gear_a: str
    gear_b: str
    flank_a: str = "drive"
    flank_b: str = "drive"
    center_distance_m: float | None = None
    line_of_centres_rad: float = 0.0
    mesh_stiffness_N_per_m: float | None = None
    pressure_angle_rad: float | None = None
    misalignment_in_plane_rad: float = 0.0
    axis_deviation_in_axes_plane_rad: float = 0.0
    axis_deviation_normal_to_axes_plane_rad: float = 0.0
    misalignment_out_of_plane_rad: float = 0.0

    def __post_init__(self) -> None:
        for attr in ("misalignment_in_plane_rad", "axis_deviation_in_axes_plane_rad",
                     "axis_deviation_normal_to_axes_plane_rad", "misalignment_out_of_plane_rad"):
            _check_range(attr, getattr(self, attr), "rad", -0.01, 0.01)
        for attr in ("flank_a", "flank_b"):
            if getattr(self, attr) not in FLANKS:
                raise _fail(attr, "", " | ".join(FLANKS), getattr(self, attr), f"mesh '{self.name}'")
        if self.gear_a == self.gear_b:
            raise ModelError(f"mesh '{self.name}': gear_a and gear_b must differ, both are '{self.gear_a}'")
        if self.center_distance_m is not None:
            _check_range("center_distance_m", self.center_distance_m, "m", 0.0, 20.0, lo_open=True)
        _check_range("line_of_centres_rad", self.line_of_centres_rad, "rad", -2 * math.pi, 2 * math.pi)
        if self.mesh_stiffness_N_per_m is not None:
            _check_range("mesh_stiffness_N_per_m", self.mesh_stiffness_N_per_m, "N/m", 0.0, 1e13, lo_open=True)
        if self.pressure_angle_rad is not None:
            _check_range("pressure_angle_rad", self.pressure_angle_rad, "rad", math.radians(5), math.radians(40))


@dataclass(frozen=True)
class Damping:
    """Viscous damping as a modal damping ratio (-) applied to every elastic mode of the linearised
    system (rigid-body rotation undamped)."""

    modal_damping_ratio: float = 0.02

    def __post_init__(self) -> None:
        RANGES["modal_damping_ratio"].check("modal_damping_ratio", self.modal_damping_ratio)


@dataclass(frozen=True)
class Operating:
    """Nominal operating point: ``torque_Nm`` applied on gear ``torque_gear``."""

    torque_Nm: float
    torque_gear: str

    def __post_init__(self) -> None:
        RANGES["torque_Nm"].check("torque_Nm", self.torque_Nm)


#: ``[statics] fe_lengths`` choices (:class:`StaticsGrid`)
FE_LENGTH_CHOICES = ("auto", "module", "absolute")


@dataclass(frozen=True)
class StaticsGrid:
    """Grids of the static analyses: ``positions`` per mesh cycle, ``loads`` from 0 to
    ``max_torque_factor`` x nominal torque, ``deflections`` points of the regular FDF deflection grid,
    ``face_slices`` slices across the face width (crowning, helix), ``twist_points`` mesh twists from
    ``-max_twist_rad`` to ``+max_twist_rad`` (helical meshes; odd, so that 0 is a grid point).  ``fe_lengths``: the
    finite-element and contact lengths (element sizes, sample spacings, reading depths) — ``"absolute"`` the fixed
    lengths tuned on the module-5 mm gears (0.6 mm at the flanks, 3 mm in the body), ``"module"`` the same lengths
    times m_n / 5 mm (every gear costs what a module-5 mm gear of its tooth count costs), ``"auto"`` (default)
    ``"module"`` for gears of the ISO 21771 form and ``"absolute"`` for the transverse form
    (:func:`hacgear_core.statics.fe.length_scale`)."""

    positions: int = 64
    loads: int = 32
    deflections: int = 64
    max_torque_factor: float = 3.0
    face_slices: int = 21
    twist_points: int = 1
    max_twist_rad: float = 1.0e-3
    fe_lengths: str = "auto"

    def __post_init__(self) -> None:
        for name in ("positions", "loads", "deflections", "face_slices", "twist_points", "max_torque_factor"):
            RANGES[f"statics.{name}"].check(name, getattr(self, name))
        _check_range("max_twist_rad", self.max_twist_rad, "rad", 0.0, 0.01, lo_open=True)
        if self.fe_lengths not in FE_LENGTH_CHOICES:
            raise _fail("statics.fe_lengths", "", " | ".join(FE_LENGTH_CHOICES), self.fe_lengths)


@dataclass(frozen=True)
class PinError:
    """Position error of one planet's pin on the carrier (SI): ``planet`` (1-based, in the order of the planet
    positions), ``radial_m`` (outwards) and ``tangential_m`` (counter-clockwise) offsets of the pin from its
    nominal position on the carrier radius."""

    planet: int
    radial_m: float = 0.0
    tangential_m: float = 0.0

    def __post_init__(self) -> None:
        RANGES["planet_count"].check("pin_errors.planet", self.planet)
        for name in ("radial_m", "tangential_m"):
            _check_range(f"pin_errors.{name}", getattr(self, name), "m", -1e-3, 1e-3)


@dataclass(frozen=True)
class PlanetErrors:
    """Manufacturing errors of one planet (SI): ``planet`` (1-based, in the order of the planet positions) and its
    :class:`GearErrors`, which that planet carries in place of the planet gear's ``[gears.errors]`` (the other
    planets keep those)."""

    planet: int
    errors: GearErrors

    def __post_init__(self) -> None:
        RANGES["planet_count"].check("planet_errors.planet", self.planet)
        if not isinstance(self.errors, GearErrors):
            raise ModelError(f"planet_errors.errors must be GearErrors, got {type(self.errors).__name__}")


def _prescribed_carrier() -> Support:
    return Support(_INF, _INF)


@dataclass(frozen=True)
class Planetary:
    """Planetary set options (SI).

    ``planet_count`` planets at ``planet_positions_rad`` (angles of the planet centres on the carrier,
    counter-clockwise from planet 1; None: equally spaced) on ``carrier_radius_m`` (None: the sun-planet centre
    distance); carrier lumped mass/inertia and support (``carrier_support``: translational stiffness as for a gear;
    rotational stiffness ``inf`` = the carrier follows the kinematics (prescribed, the default), ``0`` = free
    (a torque port), finite = sprung to the kinematic motion).  ``fixed_member``: the member held at zero
    speed (``ring`` by default; its rotational support stiffness: ``inf`` held, finite a sprung reaction
    mount, ``0`` a free reaction port).  ``output_member``: the member the power leaves by (None: the one that is
    neither the input, ``[operating] torque_gear``, nor fixed); with the input and the fixed member it sets the
    power flow (:func:`hacgear_core.geometry.planetary.planetary_power_flow`).  ``pin_errors``: planet pin
    position errors; ``planet_errors``: manufacturing errors of single planets (:class:`PlanetErrors`).
    """

    planet_count: int
    carrier_radius_m: float | None = None
    carrier_mass_kg: float = 0.0
    carrier_inertia_kgm2: float = 0.0
    carrier_support: Support = field(default_factory=_prescribed_carrier)
    planet_positions_rad: tuple[float, ...] | None = None
    fixed_member: str = "ring"
    pin_errors: tuple[PinError, ...] = ()
    output_member: str | None = None
    planet_errors: tuple[PlanetErrors, ...] = ()

    def __post_init__(self) -> None:
        RANGES["planet_count"].check("planet_count", self.planet_count)
        if self.carrier_radius_m is not None:
            _check_range("carrier_radius_m", self.carrier_radius_m, "m", 0.0, 10.0, lo_open=True)
        _check_range("carrier_mass_kg", self.carrier_mass_kg, "kg", 0.0, None)
        _check_range("carrier_inertia_kgm2", self.carrier_inertia_kgm2, "kg*m^2", 0.0, None)
        if self.fixed_member not in PLANETARY_MEMBERS:
            raise _fail("fixed_member", "", " | ".join(PLANETARY_MEMBERS), self.fixed_member)
        if self.output_member is not None and self.output_member not in PLANETARY_MEMBERS:
            raise _fail("output_member", "", " | ".join(PLANETARY_MEMBERS), self.output_member)
        if self.output_member == self.fixed_member:
            raise _fail("output_member", "", f"a member other than fixed_member = '{self.fixed_member}' (the fixed "
                        "member does not turn: no power leaves by it)", self.output_member)
        if self.planet_positions_rad is not None:
            pos = tuple(float(a) for a in self.planet_positions_rad)
            if len(pos) != self.planet_count:
                raise ModelError(f"planet_positions [deg]: {len(pos)} angles given for planet_count = "
                                 f"{self.planet_count}; allowed: exactly planet_count angles")
            if pos[0] != 0.0:
                raise _fail("planet_positions[0]", "deg", "0 (planet 1 defines the carrier frame)",
                            math.degrees(pos[0]))
            for a, b in zip(pos, pos[1:] + (2 * math.pi,)):
                if not (math.isfinite(b) and b - a > 1e-9):
                    raise ModelError(f"planet_positions [deg] must increase strictly within [0, 360), got "
                                     f"{[round(math.degrees(v), 6) for v in pos]}")
            object.__setattr__(self, "planet_positions_rad", pos)
        for key in ("pin_errors", "planet_errors"):   # per-planet entries: each planet once, within the count
            seen = set()
            for e in getattr(self, key):
                if e.planet > self.planet_count:
                    raise _fail(f"{key}.planet", "-", f"integer in [1, planet_count = {self.planet_count}]", e.planet)
                if e.planet in seen:
                    raise ModelError(f"{key}: planet {e.planet} is given twice")
                seen.add(e.planet)

    @property
    def positions_rad(self) -> tuple[float, ...]:
        """Planet centre angles [rad] on the carrier (equally spaced unless given)."""
        if self.planet_positions_rad is not None:
            return self.planet_positions_rad
        return tuple(2 * math.pi * i / self.planet_count for i in range(self.planet_count))

    @property
    def equally_spaced(self) -> bool:
        n = self.planet_count
        return all(abs(a - 2 * math.pi * i / n) < 1e-12 for i, a in enumerate(self.positions_rad))


@dataclass(frozen=True)
class LumpedGear:
    """A member of a fully lumped model (``Model.lumped``; no tooth geometry), SI: ``teeth`` (mesh
    frequencies and planet phasing), ``mass_kg``, ``inertia_kgm2``, ``base_radius_m`` (of its meshes' flanks),
    ``internal`` (ring), ``support``."""

    name: str
    teeth: int
    mass_kg: float
    inertia_kgm2: float
    base_radius_m: float
    internal: bool = False
    support: Support = field(default_factory=Support)
    gauges: tuple = ()

    def __post_init__(self) -> None:
        where = f"gear '{self.name}'"
        if isinstance(self.teeth, bool) or not isinstance(self.teeth, int) or not 3 <= self.teeth <= 1000:
            raise _fail("teeth", "-", "integer in [3, 1000]", self.teeth, where)
        try:
            _check_range("mass_kg", self.mass_kg, "kg", 0.0, None)
            _check_range("inertia_kgm2", self.inertia_kgm2, "kg*m^2", 0.0, None)
            _check_range("base_radius_m", self.base_radius_m, "m", 0.0, 20.0, lo_open=True)
        except ModelError as exc:
            raise ModelError(f"{where}: {exc}") from None

    @property
    def is_helical(self) -> bool:
        return False


def _check_iso_pair(mesh: str, ga: Gear, gb: Gear) -> None:
    """Refuse two gears of the ISO form that cannot mesh, naming their ISO keys: the same normal module, normal
    pressure angle and helix angle, and hands opposite for an external pair, equal for an internal one."""
    ia, ib = ga.iso, gb.iso
    for key, unit, va, vb, scale in (
            ("normal_module_mm", "mm", ia.normal_module_m, ib.normal_module_m, 1e3),
            ("normal_pressure_angle_deg", "deg", ia.normal_pressure_angle_rad, ib.normal_pressure_angle_rad,
             180.0 / math.pi),
            ("helix_angle_deg", "deg", ia.helix_angle_rad, ib.helix_angle_rad, 180.0 / math.pi)):
        if abs(va - vb) > 1e-12 * max(abs(va), abs(vb), 1e-300):
            raise ModelError(f"mesh '{mesh}': {key} [{unit}] differs between '{ga.name}' ({va * scale:g}) and "
                             f"'{gb.name}' ({vb * scale:g}); meshing gears need the same value")
    if ia.helix_angle_rad > 0:
        internal = ga.internal or gb.internal
        if (ia.hand == ib.hand) != internal:
            need = "the same hand (internal pair)" if internal else "opposite hands (external pair)"
            raise ModelError(f"mesh '{mesh}': hand = '{ia.hand}' on '{ga.name}' and '{ib.hand}' on '{gb.name}'; "
                             f"allowed: {need}")


@dataclass(frozen=True)
class Model:
    """A whole gear system (SI).  ``path``/``sha256`` identify the model file it came from;
    ``defaults_applied`` lists ``(key, value, meaning)`` of every default the model file left to the reader;
    ``sections`` the top-level tables no generic section reads, raw ({name: table}), and ``section`` the model's
    kind's own section as its kind parsed it (:func:`hacgear_core.kinds.load_model`; None without one)."""

    name: str
    kind: str
    title: str
    source: str
    gears: tuple[Gear, ...]
    meshes: tuple[Mesh, ...]
    damping: Damping
    operating: Operating
    statics: StaticsGrid
    planetary: Planetary | None = None
    path: Path | None = None
    sha256: str = ""
    lumped: bool = False
    defaults_applied: tuple[tuple[str, str, str], ...] = ()
    sections: Mapping[str, Any] = field(default_factory=dict, hash=False, compare=False)
    section: Any = None

    def __post_init__(self) -> None:
        if not (isinstance(self.kind, str) and self.kind):
            raise _fail("system.kind", "", "a kind name (hacgear_core.kinds.KINDS)", self.kind)
        if self.lumped:
            self._check_lumped()
            return
        names = [g.name for g in self.gears]
        if len(set(names)) != len(names):
            raise ModelError(f"gear names must be unique, got {names}")
        mnames = [m.name for m in self.meshes]
        if len(set(mnames)) != len(mnames):
            raise ModelError(f"mesh names must be unique, got {mnames}")
        for m in self.meshes:
            for attr in ("gear_a", "gear_b"):
                if getattr(m, attr) not in names:
                    raise ModelError(
                        f"meshes.{m.name}.{attr} = {getattr(m, attr)!r} names no gear (no [[gears]] with that name); "
                        f"allowed: {names}"
                    )
            ga, gb = self.gear(m.gear_a), self.gear(m.gear_b)
            if ga.internal and gb.internal:
                raise ModelError(f"mesh '{m.name}': two internal gears cannot mesh")
            if ga.iso is not None and gb.iso is not None:
                _check_iso_pair(m.name, ga, gb)
            if abs(ga.module_m - gb.module_m) > 1e-9:
                raise ModelError(
                    f"mesh '{m.name}': module_mm differs between '{ga.name}' ({ga.module_m * 1e3:g} mm) and "
                    f"'{gb.name}' ({gb.module_m * 1e3:g} mm); meshing gears need the same module"
                )
            pa = ga.flanks[m.flank_a].pressure_angle_rad
            pb = gb.flanks[m.flank_b].pressure_angle_rad
            if abs(pa - pb) > 1e-9:
                raise ModelError(
                    f"mesh '{m.name}': pressure_angle_deg of {ga.name}.{m.flank_a} ({math.degrees(pa):g} deg) "
                    f"differs from {gb.name}.{m.flank_b} ({math.degrees(pb):g} deg); the loaded flanks (flank_a = "
                    f"'{m.flank_a}', flank_b = '{m.flank_b}') must be cut by the same rack"
                )
            if abs(ga.helix_angle_rad + gb.helix_angle_rad) > 1e-9 and not (ga.internal or gb.internal):
                raise ModelError(
                    f"mesh '{m.name}': external helical gears need opposite helix angles, got helix_angle_deg "
                    f"{math.degrees(ga.helix_angle_rad):g} ({ga.name}) and {math.degrees(gb.helix_angle_rad):g} "
                    f"({gb.name})"
                )

    def _check_lumped(self) -> None:
        """A fully lumped model: members and meshes without tooth geometry (whether its kind allows one, and its
        section, are the kind's checks)."""
        names = [g.name for g in self.gears]
        if len(set(names)) != len(names):
            raise ModelError(f"gear names must be unique, got {names}")
        if any(not isinstance(g, LumpedGear) for g in self.gears):
            raise ModelError("a lumped model's gears are LumpedGear members (mass_kg, inertia_kgm2, base_radius_mm)")
        for m in self.meshes:
            for attr in ("gear_a", "gear_b"):
                if getattr(m, attr) not in names:
                    raise ModelError(f"meshes.{m.name}.{attr} = {getattr(m, attr)!r} names no gear; allowed: {names}")
            for attr, unit in (("mesh_stiffness_N_per_m", "N/m"), ("pressure_angle_rad", "rad")):
                if getattr(m, attr) is None:
                    raise ModelError(f"mesh '{m.name}': a lumped model needs {attr} [{unit}]")

    def gear(self, name: str) -> Gear:
        for g in self.gears:
            if g.name == name:
                return g
        raise ModelError(f"no gear named {name!r}; gears: {[g.name for g in self.gears]}")

    def mesh(self, name: str | None = None) -> Mesh:
        """The mesh called ``name`` (None: the first mesh)."""
        if name is None:
            return self.meshes[0]
        for m in self.meshes:
            if m.name == name:
                return m
        raise ModelError(f"no mesh named {name!r}; meshes: {[m.name for m in self.meshes]}")

    @property
    def folder(self) -> Path | None:
        return None if self.path is None else self.path.parent

    @property
    def tables_path(self) -> Path | None:
        """Default location of the tables file, ``models/<system>/tables.h5``."""
        return None if self.path is None else self.path.parent / "tables.h5"
