"""Model files: ``models/<system>/model.toml`` (TOML, unit-suffixed keys) → :mod:`~hacgear_core.model.schema` (SI).

A model file describes one gear system: its kind, materials, gears, meshes, supports, damping,
operating point and the grids of the static analyses.  Keys carry their unit in the name when it is
not SI (``module_mm``, ``tip_relief_um``, ``youngs_modulus_GPa``); the dataclasses hold SI values with
the unit in the attribute name where it could be ambiguous (``module_m``, ``tip_relief_m``).

Unknown keys, missing keys, wrong types and out-of-range values are each reported as one
:class:`~hacgear_core.errors.ModelError` naming the file, the key, its unit and the allowed range.  Keys that
change the physics without a natural "absent" value (``bore_diameter_mm``, ``hob_tip_radius_mm``,
``poisson_ratio``, ``[damping] modal_damping_ratio``) are required; every default that is applied (no tip
relief, no crowning, rigid bearings, zero-backlash centre distance...) is recorded in
:attr:`Model.defaults_applied` with its meaning (:data:`DEFAULT_MEANINGS`) and echoed by ``hacgear info``.

The format (one example per system lives in ``models/``)::

    [system]
    name = "spur_28t_asym"           # folder name
    kind = "spur_pair"                # spur_pair | idler_chain | planetary | helical_pair
    title = "..."                     # free text
    source = "..."                    # where the numbers come from

    [materials.steel]
    density_kg_per_m3 = 7850.0
    youngs_modulus_GPa = 201.5
    poisson_ratio = 0.3

    [[gears]]
    name = "pinion"
    teeth = 28
    module_mm = 5.0                   # transverse module
    tip_diameter_mm = 149.9           # internal gears: the (smaller) tip diameter
    root_diameter_mm = 126.4
    tooth_thickness_mm = 7.64         # circular (transverse) tooth thickness on the reference circle
    hob_tip_radius_mm = 0.4           # edge radius of the cutting tool tip (shapes the trochoidal fillet)
    face_width_mm = 15.0
    bore_diameter_mm = 40.0
    material = "steel"
    [gears.web]                       # optional: webbed blank (absent: solid disk from bore to root)
    thickness_mm = 5.0                # web thickness, (0, face_width_mm]
    inner_diameter_mm = 60.0          # hub outer diameter, (bore_diameter_mm, outer_diameter_mm)
    outer_diameter_mm = 105.0         # rim inner diameter, <= root_diameter_mm - 2 mm
    [gears.drive]                     # flank named "drive" (counter-clockwise side of tooth 0)
    pressure_angle_deg = 25.0
    tip_relief_um = 47.0
    tip_relief_start_roll_deg = 28.54
    tip_relief_shape = "parabolic"    # none | linear | parabolic
    [gears.coast]
    pressure_angle_deg = 20.0
    [[gears.gauges]]
    name = "SG2"; flank = "drive"; radius_mm = 64.051
    [gears.support]
    translational_stiffness_N_per_m = inf   # inf: rigid (purely rotational model)

    [[meshes]]
    name = "m12"; gear_a = "pinion"; gear_b = "wheel"; flank_a = "drive"; flank_b = "drive"

    [damping]
    modal_damping_ratio = 0.02

    [operating]
    torque_Nm = 300.0; torque_gear = "pinion"

    [statics]
    positions = 256; loads = 32; max_torque_factor = 3.0   # 256 for spur pairs: docs/hac_vs_direct.md
    fe_lengths = "auto"   # optional: module | absolute | auto (module for ISO-form gears; docs/static_contact.md)

Planetary sets (``kind = "planetary"``: two meshes, sun -> planet and planet -> ring, each named after the member
that drives it relative to the carrier)::

    [planetary]
    planet_count = 3
    planet_positions_deg = [0.0, 120.0, 240.0]   # optional (default: equally spaced); multiples of 360/(z_s+z_r)
    carrier_radius_mm = 96.54                    # optional (default: the sun-planet centre distance)
    carrier_mass_kg = 3.0; carrier_inertia_kgm2 = 0.03
    fixed_member = "ring"                        # ring | carrier | sun, held at zero speed (its rotational support
                                                 # stiffness: inf held, finite sprung reaction, 0 a free port); a
                                                 # fixed member without [gears.support] is held (ring fixed)
    output_member = "carrier"                    # optional: ring | carrier | sun, the member the power leaves by
                                                 # (default: the one neither [operating] torque_gear, the input,
                                                 # nor fixed); input, output and fixed set which member drives
                                                 # each mesh relative to the carrier (its gear_a)
    [planetary.carrier_support]                  # absent: rotation prescribed (follows the kinematics), rigid
    translational_stiffness_N_per_m = 1e8; rotational_stiffness_Nm_per_rad = inf   # inf prescribed, 0 free
    [[planetary.pin_errors]]                     # optional: planet pin position errors
    planet = 2; radial_um = 0.0; tangential_um = 20.0
    [[planetary.planet_errors]]                  # optional: one planet's manufacturing errors, in place of the
    planet = 2; runout_um = 10.0                 # planet gear's [gears.errors] (the keys of [gears.errors])

The planet's ``[gears.support]`` is its bearing on the pin (translational stiffness; rotational stiffness 0).
A fully lumped planetary model (``[system] lumped = true``) has no materials, tooth geometry or statics: its gears
give ``name, teeth, internal, mass_kg, inertia_kgm2, base_radius_mm, [gears.support]``, its meshes
``name, gear_a, gear_b, mesh_stiffness_N_per_m, pressure_angle_deg`` (``examples/planetary_lumped.toml``).
"""


from __future__ import annotations

import difflib
import hashlib
import math
import tomllib
from dataclasses import replace
from importlib import resources as _resources
from pathlib import Path
from typing import Any, Callable

from hacgear_core.errors import ModelError
from hacgear_core.model import iso21771 as _iso
from hacgear_core.model.schema import (
    FE_LENGTH_CHOICES, FLANKS, HANDS, PLANETARY_MEMBERS, RELIEF_SHAPES, WEB_MIN_RIM_M, Damping, Flank, Gauge, Gear, GearErrors,
    IsoGear, LumpedGear, RANGES, Material, Mesh, Model, Operating, PinError, PlanetErrors, Planetary, StaticsGrid, Support, Web,
)

__all__ = ["read_model", "parse_model", "SectionReader", "TOP_LEVEL_KEYS", "model_sha256", "resolve_model_path", "shipped_systems", "shipped_systems_dir",
           "DEFAULT_MEANINGS"]

_INF = math.inf

# --------------------------------------------------------------------------------------------
# TOML reader with precise errors
# --------------------------------------------------------------------------------------------
class _Section:
    """Pops typed keys from one TOML table and reports unknown keys at the end."""

    def __init__(self, data: Any, path: str, file: str, defaults: list | None = None) -> None:
        self.file = file
        self.path = path
        self.defaults = [] if defaults is None else defaults  # (key, value) of every default applied, shared
        if not isinstance(data, dict):
            raise self.error(path, "", "a table", f"a {type(data).__name__}")
        self.data = dict(data)

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def error(self, key: str, unit: str, allowed: str, got: Any, problem: str = "") -> ModelError:
        unit_txt = f" [{unit}]" if unit else ""
        what = problem or f"got {got!r}"
        return ModelError(f"{self.file}: key '{key}'{unit_txt}: {what}; allowed: {allowed}")

    def _get(self, name: str, required: bool, default: Any, unit: str, allowed: str) -> Any:
        if name not in self.data:
            if required:
                typo = difflib.get_close_matches(name, [k for k in self.data if k not in _KNOWN_KEYS], n=1)
                if typo:
                    raise ModelError(f"{self.file}: unknown key '{self.key(typo[0])}' in [{self.path or 'top level'}]"
                                     f"; did you mean '{name}'? (required key '{self.key(name)}'"
                                     f"{f' [{unit}]' if unit else ''} is missing; allowed: {allowed})")
                raise self.error(self.key(name), unit, allowed, None, problem="missing required key")
            self.defaults.append((self.key(name), default))
            return default
        return self.data.pop(name)

    def number(
        self, name: str, unit: str, lo: float | None = None, hi: float | None = None, *, required: bool = True,
        default: float | None = None, lo_open: bool = False, hi_open: bool = False, allow_inf: bool = False,
    ) -> float | None:
        lo_txt = "-inf" if lo is None else f"{lo:g}"
        hi_txt = "inf" if hi is None else f"{hi:g}"
        allowed = f"{'(' if lo_open or lo is None else '['}{lo_txt}, {hi_txt}{')' if hi_open or hi is None else ']'}"
        if allow_inf:
            allowed += " or inf"
        v = self._get(name, required, default, unit, allowed)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.error(self.key(name), unit, f"a number in {allowed}", v, problem=f"wrong type {type(v).__name__} ({v!r})")
        v = float(v)
        if allow_inf and v == math.inf:
            return v
        bad = v != v or math.isinf(v)
        if lo is not None:
            bad |= v <= lo if lo_open else v < lo
        if hi is not None:
            bad |= v >= hi if hi_open else v > hi
        if bad:
            raise self.error(self.key(name), unit, allowed, v, problem=f"value {v:g} out of range")
        return v

    def ranged(self, name: str, quantity: str, *, required: bool = True, default: Any = None) -> Any:
        """Read key ``name`` (in the unit of the quantity) within ``RANGES[quantity]``, the range the command line
        and the FMUs share."""
        r = RANGES[quantity]
        if r.integer:
            return self.integer(name, int(r.lo), int(r.hi), required=required, default=default)
        return self.number(name, r.unit, r.lo, r.hi, required=required, default=default, lo_open=r.lo_open,
                           hi_open=r.hi_open, allow_inf=r.allow_inf)

    def integer(self, name: str, lo: int, hi: int, *, required: bool = True, default: int | None = None) -> int | None:
        allowed = f"integer in [{lo}, {hi}]"
        v = self._get(name, required, default, "-", allowed)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.error(self.key(name), "-", allowed, v, problem=f"wrong type {type(v).__name__} ({v!r})")
        if not lo <= v <= hi:
            raise self.error(self.key(name), "-", allowed, v, problem=f"value {v} out of range")
        return v

    def string(self, name: str, choices: tuple[str, ...] | None = None, *, required: bool = True,
               default: str | None = None) -> str | None:
        allowed = " | ".join(choices) if choices else "a string"
        v = self._get(name, required, default, "", allowed)
        if v is None:
            return None
        if not isinstance(v, str):
            raise self.error(self.key(name), "", allowed, v, problem=f"wrong type {type(v).__name__} ({v!r})")
        if choices and v not in choices:
            raise self.error(self.key(name), "", allowed, v, problem=f"unknown value {v!r}")
        return v

    def boolean(self, name: str, *, default: bool = False) -> bool:
        v = self._get(name, False, default, "", "true | false")
        if not isinstance(v, bool):
            raise self.error(self.key(name), "", "true | false", v, problem=f"wrong type {type(v).__name__} ({v!r})")
        return v

    def table(self, name: str, *, required: bool = True) -> "_Section | None":
        v = self._get(name, required, None, "", "a table")
        if v is None:
            return None
        return _Section(v, self.key(name), self.file, self.defaults)

    def array_of_tables(self, name: str, *, required: bool = True) -> list["_Section"]:
        v = self._get(name, required, [], "", "an array of tables [[...]]")
        if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
            raise self.error(self.key(name), "", f"an array of tables [[{self.key(name)}]]", v,
                             problem="wrong type")
        return [_Section(x, f"{self.key(name)}[{i}]", self.file, self.defaults) for i, x in enumerate(v)]

    def done(self, allowed: tuple[str, ...]) -> None:
        if self.data:
            unknown = sorted(self.data)
            near = difflib.get_close_matches(unknown[0], allowed, n=1)
            hint = f"did you mean '{near[0]}'? " if near else ""
            raise ModelError(
                f"{self.file}: unknown key '{self.key(unknown[0])}' in [{self.path or 'top level'}]; {hint}allowed "
                f"keys: {', '.join(sorted(allowed))}"
            )


_MATERIAL_KEYS = ("density_kg_per_m3", "youngs_modulus_GPa", "poisson_ratio")
_FLANK_KEYS = ("pressure_angle_deg", "tip_relief_um", "tip_relief_start_roll_deg", "tip_relief_shape")
_GAUGE_KEYS = ("name", "flank", "radius_mm", "face_fraction")
_ERROR_KEYS = ("single_pitch_deviations_um", "iso1328_grade", "seed", "runout_um", "runout_phase_deg",
               "lead_slope_um")
_SUPPORT_KEYS = (
    "translational_stiffness_N_per_m", "rotational_stiffness_Nm_per_rad", "axial_stiffness_N_per_m",
    "tilting_stiffness_Nm_per_rad",
)
_GEAR_KEYS = (
    "name", "teeth", "module_mm", "tip_diameter_mm", "root_diameter_mm", "tooth_thickness_mm", "hob_tip_radius_mm",
    "face_width_mm", "bore_diameter_mm", "material", "internal", "helix_angle_deg", "axial_position_mm",
    "lead_crowning_um", "tip_edge_radius_mm", "mass_kg", "inertia_kgm2", "drive", "coast", "gauges", "support",
    "web", "errors",
)
#: the ISO 21771 form of [[gears]] (marked by normal_module_mm)
_ISO_GEAR_KEYS = (
    "name", "teeth", "internal", "normal_module_mm", "normal_pressure_angle_deg", "helix_angle_deg", "hand",
    "profile_shift", "tip_alteration_mm", "tip_diameter_mm", "basic_rack", "rack_addendum_coefficient",
    "rack_dedendum_coefficient", "rack_root_radius_coefficient", "thickness_allowance_upper_mm",
    "thickness_allowance_lower_mm", "face_width_mm", "bore_diameter_mm", "material", "axial_position_mm",
    "lead_crowning_um", "tip_edge_radius_mm", "mass_kg", "inertia_kgm2", "drive", "coast", "gauges", "support", "web",
    "errors",
)
#: keys of the transverse (dissertation) form that the ISO form derives, and from what
_TRANSVERSE_ONLY = {
    "module_mm": "normal_module_mm and helix_angle_deg (m_t = m_n / cos beta)",
    "root_diameter_mm": "the basic rack's dedendum and profile_shift (d_f = d - 2 m_n (h_fP* - x))",
    "tooth_thickness_mm": "profile_shift and the thickness allowances (s_n = m_n (pi/2 + 2 x tan alpha_n) + A_sn)",
    "hob_tip_radius_mm": "the basic rack's root radius (rho_fP = rho_fP* m_n)",
}
_ISO_FLANK_KEYS = ("tip_relief_um", "tip_relief_start_roll_deg", "tip_relief_shape")
_RACK_KEYS = ("rack_addendum_coefficient", "rack_dedendum_coefficient", "rack_root_radius_coefficient")
_WEB_KEYS = ("thickness_mm", "inner_diameter_mm", "outer_diameter_mm")
_MESH_KEYS = ("name", "gear_a", "gear_b", "flank_a", "flank_b", "center_distance_mm", "line_of_centres_deg",
              "misalignment_in_plane_urad", "misalignment_out_of_plane_urad", "axis_deviation_in_axes_plane_urad",
              "axis_deviation_normal_to_axes_plane_urad")
_LUMPED_GEAR_KEYS = ("name", "teeth", "internal", "mass_kg", "inertia_kgm2", "base_radius_mm", "support")
_LUMPED_MESH_KEYS = ("name", "gear_a", "gear_b", "mesh_stiffness_N_per_m", "pressure_angle_deg")
_PLANETARY_KEYS = ("planet_count", "planet_positions_deg", "carrier_radius_mm", "carrier_mass_kg",
                   "carrier_inertia_kgm2", "carrier_support", "fixed_member", "output_member", "pin_errors",
                   "planet_errors")
_PIN_ERROR_KEYS = ("planet", "radial_um", "tangential_um")
_TOP_KEYS = ("system", "materials", "gears", "meshes", "damping", "operating", "statics", "planetary")
_STATICS_KEYS = ("positions", "loads", "deflections", "max_torque_factor", "face_slices", "twist_points",
                 "max_twist_mrad", "fe_lengths")
_SYSTEM_KEYS = ("name", "kind", "title", "source", "lumped")
#: every key a model file may hold: a missing required key next to an unknown key close to it is a misspelling
_KNOWN_KEYS = frozenset(_MATERIAL_KEYS + _FLANK_KEYS + _GAUGE_KEYS + _ERROR_KEYS + _SUPPORT_KEYS + _GEAR_KEYS + _ISO_GEAR_KEYS
                        + _WEB_KEYS + _MESH_KEYS
                        + _LUMPED_GEAR_KEYS + _LUMPED_MESH_KEYS + _PLANETARY_KEYS + _PIN_ERROR_KEYS + _TOP_KEYS
                        + _STATICS_KEYS + _SYSTEM_KEYS + ("torque_Nm", "torque_gear", "modal_damping_ratio"))


#: the top-level tables every model file may have (a kind may add its own section)
TOP_LEVEL_KEYS = _TOP_KEYS
#: the reader a kind parses its own model section with (:meth:`hacgear_core.kinds.base.Kind.parse_section`)
SectionReader = _Section


def _kind_sections(top: _Section) -> dict[str, dict]:
    """The top-level tables no generic section reads, raw (popped from ``top``): a kind's own section, parsed by
    its :meth:`~hacgear_core.kinds.base.Kind.parse_section` (:func:`hacgear_core.kinds.load_model` refuses the
    tables the model's kind does not take)."""
    return {k: top.data.pop(k) for k in [k for k, v in top.data.items() if k not in _TOP_KEYS and isinstance(v, dict)]}


def _wrap(sec: _Section, key: str, fn: Callable[[], Any]) -> Any:
    """Re-raise a dataclass validation error with the file and the TOML key prefix."""
    try:
        return fn()
    except ModelError as exc:
        msg = str(exc)
        if msg.startswith(sec.file):
            raise
        raise ModelError(f"{sec.file}: [{key}] {msg}") from None


def _read_relief(sec: _Section, keys) -> tuple[float, float, str]:
    """A flank table's tip relief (``tip_relief_um`` [um], ``tip_relief_start_roll_deg`` [deg],
    ``tip_relief_shape``), its keys checked against ``keys``."""
    relief = sec.number("tip_relief_um", "um", 0.0, 1000.0, required=False, default=0.0)
    start = sec.number("tip_relief_start_roll_deg", "deg", 0.0, 89.0, required=False, default=0.0)
    shape = sec.string("tip_relief_shape", RELIEF_SHAPES, required=False,
                       default="parabolic" if relief > 0 else "none")
    sec.done(keys)
    if relief > 0 and start <= 0:
        raise sec.error(sec.key("tip_relief_start_roll_deg"), "deg", "(0, 89]", start,
                        problem="missing or zero while tip_relief_um > 0")
    if relief > 0 and shape == "none":
        raise sec.error(sec.key("tip_relief_shape"), "", "linear | parabolic", shape,
                        problem="'none' while tip_relief_um > 0")
    return relief, start, shape


def _read_gauges(sec: _Section) -> list:
    """A gear's ``[[gears.gauges]]`` (name, flank, ``radius_mm``, ``face_fraction``)."""
    gauges = []
    for gsec in sec.array_of_tables("gauges", required=False):
        gname = gsec.string("name")
        gflank = gsec.string("flank", FLANKS)
        grad = gsec.number("radius_mm", "mm", 0.0, 10000.0, lo_open=True)
        gface = gsec.number("face_fraction", "-", 0.0, 1.0, required=False, default=0.5)
        gsec.done(_GAUGE_KEYS)
        gauges.append(_wrap(gsec, gsec.path, lambda: Gauge(gname, gflank, grad * 1e-3, gface)))
    return gauges


def _read_errors(esec: "_Section | None", keys: tuple[str, ...] = ()) -> GearErrors | None:
    """``[gears.errors]`` (or a table with its keys and the caller's ``keys``, read before) → :class:`GearErrors`
    (None when absent)."""
    if esec is None:
        return None
    pitch = esec._get("single_pitch_deviations_um", False, (), "um", "an array of numbers, one per tooth")
    if not isinstance(pitch, (list, tuple)) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in pitch):
        raise esec.error(esec.key("single_pitch_deviations_um"), "um", "an array of numbers in [-1000, 1000], one "
                         "per tooth", pitch, problem=f"wrong type ({pitch!r})")
    for v in pitch:
        if not (-1000.0 <= float(v) <= 1000.0):
            raise esec.error(esec.key("single_pitch_deviations_um"), "um", "numbers in [-1000, 1000]", v,
                             problem=f"value {v:g} out of range")
    grade = esec.integer("iso1328_grade", 1, 11, required=False, default=None)
    seed = esec.integer("seed", 0, 2 ** 63 - 1, required=False, default=0)
    runout = esec.number("runout_um", "um", 0.0, 1000.0, required=False, default=0.0)
    phase = esec.number("runout_phase_deg", "deg", -360.0, 360.0, required=False, default=0.0)
    lead = esec.number("lead_slope_um", "um", -1000.0, 1000.0, required=False, default=0.0)
    esec.done(_ERROR_KEYS + tuple(keys))
    return _wrap(esec, esec.path, lambda: GearErrors(tuple(float(v) * 1e-6 for v in pitch), grade, seed,
                                                     runout * 1e-6, math.radians(phase), lead * 1e-6))


def _read_flank(sec: _Section) -> Flank:
    pa = sec.number("pressure_angle_deg", "deg", 5.0, 40.0)
    relief, start, shape = _read_relief(sec, _FLANK_KEYS)
    return _wrap(sec, sec.path, lambda: Flank(math.radians(pa), relief * 1e-6, math.radians(start), shape))


def _read_support(ssec: "_Section | None") -> Support:
    if ssec is None:
        return Support()
    support = Support(
        ssec.ranged("translational_stiffness_N_per_m", "translational_stiffness_N_per_m", required=False,
                    default=_INF),
        ssec.number("rotational_stiffness_Nm_per_rad", "N*m/rad", 0.0, None, required=False, default=0.0,
                    allow_inf=True),
        ssec.number("axial_stiffness_N_per_m", "N/m", 0.0, None, required=False, default=_INF, allow_inf=True),
        ssec.number("tilting_stiffness_Nm_per_rad", "N*m/rad", 0.0, None, required=False, default=_INF,
                    allow_inf=True),
    )
    ssec.done(_SUPPORT_KEYS)
    return support


def _read_web(wsec: "_Section | None", face_mm: float, bore_mm: float, root_mm: float, internal: bool) -> Web | None:
    """``[gears.web]`` → :class:`Web` (None when absent); bounds that depend on the gear are checked here so
    that the message names the TOML key."""
    if wsec is None:
        return None
    if internal:
        raise wsec.error(wsec.path, "", "no [gears.web] on internal gears", "a table",
                         problem="a web is not supported for internal (ring) gears")
    rim = 2e3 * WEB_MIN_RIM_M

    def num(key: str, allowed: str, ok: Callable[[float], bool]) -> float:
        v = wsec._get(key, True, None, "mm", allowed)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise wsec.error(wsec.key(key), "mm", allowed, v, problem=f"wrong type {type(v).__name__} ({v!r})")
        v = float(v)
        if v != v or not ok(v):
            raise wsec.error(wsec.key(key), "mm", allowed, v, problem=f"value {v:g} out of range")
        return v

    d_max = root_mm - rim
    t = num("thickness_mm", f"(0, face_width_mm = {face_mm:g}]", lambda v: 0.0 < v <= face_mm)
    d_in = num("inner_diameter_mm", f"(bore_diameter_mm = {bore_mm:g}, root_diameter_mm - {rim:g} = {d_max:g})",
               lambda v: bore_mm < v < d_max)
    d_out = num("outer_diameter_mm", f"(web.inner_diameter_mm = {d_in:g}, root_diameter_mm - {rim:g} = {d_max:g}] "
                f"(a rim of at least {rim / 2:g} mm must remain below the root circle)",
                lambda v: d_in < v <= d_max)
    wsec.done(_WEB_KEYS)
    return Web(t * 1e-3, d_in * 1e-3, d_out * 1e-3)


def _read_gear(sec: _Section, materials: dict[str, Material]) -> Gear:
    if "normal_module_mm" in sec.data:
        return _read_iso_gear(sec, materials)
    name = sec.string("name")
    teeth = sec.integer("teeth", 6, 1000)
    module = sec.number("module_mm", "mm", 0.1, 100.0)
    internal = sec.boolean("internal", default=False)
    tip = sec.number("tip_diameter_mm", "mm", 1.0, 20000.0)
    root = sec.number("root_diameter_mm", "mm", 1.0, 20000.0)
    thick = sec.number("tooth_thickness_mm", "mm", 0.01, 1000.0)
    hob = sec.number("hob_tip_radius_mm", "mm", 0.0, 50.0)
    face = sec.number("face_width_mm", "mm", 0.1, 2000.0)
    bore = sec.number("bore_diameter_mm", "mm", 0.0, 40000.0)  # 0: solid disk without bore (say so explicitly)
    mat_name = sec.string("material")
    if mat_name not in materials:
        raise sec.error(sec.key("material"), "", " | ".join(sorted(materials)) or "(no [materials] defined)",
                        mat_name, problem=f"unknown material {mat_name!r}")
    helix = sec.number("helix_angle_deg", "deg", -45.0, 45.0, required=False, default=0.0)
    axial = sec.number("axial_position_mm", "mm", -1000.0, 1000.0, required=False, default=0.0)
    crown = sec.number("lead_crowning_um", "um", 0.0, 1000.0, required=False, default=0.0)
    tip_edge = sec.number("tip_edge_radius_mm", "mm", 0.0, 10.0, required=False, default=0.0)
    mass = sec.number("mass_kg", "kg", 0.0, None, required=False, default=None)
    inertia = sec.number("inertia_kgm2", "kg*m^2", 0.0, None, required=False, default=None)
    drive = _read_flank(sec.table("drive"))
    coast_sec = sec.table("coast", required=False)
    coast = _read_flank(coast_sec) if coast_sec is not None else drive
    gauges = _read_gauges(sec)
    support = _read_support(sec.table("support", required=False))
    web = _read_web(sec.table("web", required=False), face, bore, root, internal)
    errors = _read_errors(sec.table("errors", required=False))
    sec.done(_GEAR_KEYS)
    return _wrap(sec, sec.path, lambda: Gear(
        name=name, teeth=teeth, module_m=module * 1e-3, tip_diameter_m=tip * 1e-3, root_diameter_m=root * 1e-3,
        tooth_thickness_m=thick * 1e-3, hob_tip_radius_m=hob * 1e-3, face_width_m=face * 1e-3,
        bore_diameter_m=bore * 1e-3, material=materials[mat_name], flanks={"drive": drive, "coast": coast},
        internal=internal, helix_angle_rad=math.radians(helix), axial_position_m=axial * 1e-3,
        lead_crowning_m=crown * 1e-6, tip_edge_radius_m=tip_edge * 1e-3, mass_kg=mass, inertia_kgm2=inertia,
        gauges=tuple(gauges), support=support, web=web, errors=errors,
    ))


def _read_iso_flank(sec: "_Section | None", alpha_t: float) -> Flank:
    """``[gears.drive]`` / ``[gears.coast]`` of an ISO-form gear: tip relief only (the flank's transverse pressure
    angle ``alpha_t`` [rad] follows from normal_pressure_angle_deg and helix_angle_deg)."""
    if sec is None:
        return Flank(alpha_t)
    if "pressure_angle_deg" in sec.data:
        raise sec.error(sec.key("pressure_angle_deg"), "deg", "no pressure_angle_deg in an ISO-form gear's flank "
                        "tables", sec.data["pressure_angle_deg"],
                        problem="the ISO form's flanks take the gear's normal_pressure_angle_deg (transverse "
                                f"{math.degrees(alpha_t):.6f} deg here)")
    relief, start, shape = _read_relief(sec, _ISO_FLANK_KEYS)
    return _wrap(sec, sec.path, lambda: Flank(alpha_t, relief * 1e-6, math.radians(start), shape))


def _read_iso_gear(sec: _Section, materials: dict[str, Material]) -> Gear:
    """``[[gears]]`` in the ISO 21771 form (marked by ``normal_module_mm``) → :class:`Gear` in the transverse form,
    its ISO data kept in :attr:`Gear.iso` (equations: :mod:`hacgear_core.model.iso21771`)."""
    for key, derived in _TRANSVERSE_ONLY.items():
        if key in sec.data:
            raise sec.error(sec.key(key), "", "the keys of one form: ISO 21771 (normal_module_mm ...) or transverse "
                            "(module_mm, root_diameter_mm, tooth_thickness_mm, hob_tip_radius_mm ...)",
                            sec.data[key], problem=f"a transverse-form key in an ISO-form gear (normal_module_mm "
                            f"given): the ISO form derives it from {derived}")
    name = sec.string("name")
    teeth = sec.integer("teeth", 6, 1000)
    internal = sec.boolean("internal", default=False)
    m_n = sec.number("normal_module_mm", "mm", 0.1, 100.0)
    alpha_n_deg = sec.number("normal_pressure_angle_deg", "deg", 5.0, 40.0)
    beta_deg = sec.number("helix_angle_deg", "deg", 0.0, 45.0, required=False, default=0.0)
    hand = sec.string("hand", HANDS, required=beta_deg > 0, default=None) or ""
    if beta_deg == 0 and hand:
        raise sec.error(sec.key("hand"), "", "absent for a spur gear (helix_angle_deg = 0)", hand,
                        problem="a spur gear has no hand")
    x = sec.number("profile_shift", "-", -3.0, 3.0, required=False, default=0.0)
    rack = sec.string("basic_rack", tuple(_iso.BASIC_RACKS), required=False, default=None)
    given = [k for k in _RACK_KEYS if k in sec.data]
    if rack is not None:
        if given:
            raise sec.error(sec.key(given[0]), "-", f"absent when basic_rack = '{rack}' is given", sec.data[given[0]],
                            problem=f"the ISO 53 profile {rack} fixes h_aP*, h_fP*, rho_fP* = "
                                    f"{', '.join(f'{v:g}' for v in _iso.BASIC_RACKS[rack])}; give basic_rack or the "
                                    "three rack_*_coefficient keys")
        h_ap, h_fp, rho_fp = _iso.BASIC_RACKS[rack]
    else:
        if not given:
            raise sec.error(sec.key("basic_rack"), "", f"basic_rack = {' | '.join(_iso.BASIC_RACKS)} (ISO 53) or the "
                            "three keys " + ", ".join(_RACK_KEYS), None,
                            problem="missing: the basic rack profile (h_aP*, h_fP*, rho_fP*) has no natural default")
        rack = "custom"
        h_ap = sec.number("rack_addendum_coefficient", "-", 0.5, 2.0)
        h_fp = sec.number("rack_dedendum_coefficient", "-", 0.5, 2.5)
        rho_fp = sec.number("rack_root_radius_coefficient", "-", 0.0, 1.0, lo_open=True)
    if "tip_alteration_mm" in sec.data and "tip_diameter_mm" in sec.data:
        raise sec.error(sec.key("tip_diameter_mm"), "mm", "tip_alteration_mm (k m_n) or tip_diameter_mm, not both",
                        sec.data["tip_diameter_mm"], problem="both tip keys given")
    beta = math.radians(beta_deg)
    alpha_n = math.radians(alpha_n_deg)
    if "tip_diameter_mm" in sec.data:
        d_a = sec.number("tip_diameter_mm", "mm", 1.0, 20000.0)
        k = _iso.tip_alteration(teeth, m_n, beta, h_ap, x, d_a, internal)
        if not -3.0 <= k <= 3.0:
            lo, hi = sorted(_iso.tip_diameter(teeth, m_n, beta, h_ap, x, kk, internal) for kk in (-3.0, 3.0))
            raise sec.error(sec.key("tip_diameter_mm"), "mm", f"[{lo:.6g}, {hi:.6g}] (k in [-3, 3])", d_a,
                            problem=f"value {d_a:g} gives the tip alteration k = {k:.6g}")
        tip_source = "tip_diameter_mm"
    else:
        k = sec.number("tip_alteration_mm", "mm", -3.0 * m_n, 3.0 * m_n, required=False, default=0.0) / m_n
        tip_source = "tip_alteration_mm"
    a_up = sec.number("thickness_allowance_upper_mm", "mm", -0.5 * m_n, 0.5 * m_n, required=False, default=0.0)
    a_lo = sec.number("thickness_allowance_lower_mm", "mm", -0.5 * m_n, 0.5 * m_n, required=False, default=a_up)
    face = sec.number("face_width_mm", "mm", 0.1, 2000.0)
    bore = sec.number("bore_diameter_mm", "mm", 0.0, 40000.0)
    mat_name = sec.string("material")
    if mat_name not in materials:
        raise sec.error(sec.key("material"), "", " | ".join(sorted(materials)) or "(no [materials] defined)",
                        mat_name, problem=f"unknown material {mat_name!r}")
    iso = _wrap(sec, sec.path, lambda: IsoGear(
        teeth=teeth, normal_module_m=m_n * 1e-3, normal_pressure_angle_rad=alpha_n, helix_angle_rad=beta, hand=hand,
        profile_shift=x, tip_alteration=k, tip_source=tip_source, basic_rack=rack, addendum_coefficient=h_ap,
        dedendum_coefficient=h_fp, root_radius_coefficient=rho_fp, thickness_allowance_upper_m=a_up * 1e-3,
        thickness_allowance_lower_m=a_lo * 1e-3, internal=internal))
    axial = sec.number("axial_position_mm", "mm", -1000.0, 1000.0, required=False, default=0.0)
    crown = sec.number("lead_crowning_um", "um", 0.0, 1000.0, required=False, default=0.0)
    tip_edge = sec.number("tip_edge_radius_mm", "mm", 0.0, 10.0, required=False, default=0.0)
    mass = sec.number("mass_kg", "kg", 0.0, None, required=False, default=None)
    inertia = sec.number("inertia_kgm2", "kg*m^2", 0.0, None, required=False, default=None)
    alpha_t = iso.transverse_pressure_angle_rad
    drive = _read_iso_flank(sec.table("drive", required=False), alpha_t)
    coast_sec = sec.table("coast", required=False)
    coast = _read_iso_flank(coast_sec, alpha_t) if coast_sec is not None else drive
    gauges = _read_gauges(sec)
    support = _read_support(sec.table("support", required=False))
    root_mm = iso.root_diameter_m * 1e3
    web = _read_web(sec.table("web", required=False), face, bore, root_mm, internal)
    errors = _read_errors(sec.table("errors", required=False))
    sec.done(_ISO_GEAR_KEYS)
    return _wrap(sec, sec.path, lambda: Gear(
        name=name, teeth=teeth, module_m=iso.transverse_module_m, tip_diameter_m=iso.tip_diameter_m,
        root_diameter_m=iso.root_diameter_m, tooth_thickness_m=iso.transverse_tooth_thickness_m,
        hob_tip_radius_m=iso.tool_tip_radius_m, face_width_m=face * 1e-3, bore_diameter_m=bore * 1e-3,
        material=materials[mat_name], flanks={"drive": drive, "coast": coast}, internal=internal,
        helix_angle_rad=iso.signed_helix_angle_rad, axial_position_m=axial * 1e-3, lead_crowning_m=crown * 1e-6,
        tip_edge_radius_m=tip_edge * 1e-3, mass_kg=mass, inertia_kgm2=inertia, gauges=tuple(gauges), support=support,
        web=web, iso=iso, errors=errors,
    ))


def _read_lumped_gear(sec: _Section) -> LumpedGear:
    """``[[gears]]`` of a lumped model (``[system] lumped = true``): no tooth geometry."""
    name = sec.string("name")
    teeth = sec.integer("teeth", 3, 1000)
    internal = sec.boolean("internal", default=False)
    mass = sec.number("mass_kg", "kg", 0.0, None)
    inertia = sec.number("inertia_kgm2", "kg*m^2", 0.0, None)
    rb = sec.number("base_radius_mm", "mm", 0.0, 20000.0, lo_open=True)
    support = _read_support(sec.table("support", required=False))
    sec.done(_LUMPED_GEAR_KEYS)
    return _wrap(sec, sec.path, lambda: LumpedGear(name=name, teeth=teeth, mass_kg=mass, inertia_kgm2=inertia,
                                                   base_radius_m=rb * 1e-3, internal=internal, support=support))


def read_planetary(psec: _Section, keys: tuple[str, ...] = ()) -> Planetary:
    """``[planetary]`` (or a table with its keys and the caller's ``keys``, read before) → :class:`Planetary` (SI)."""
    pc = psec.ranged("planet_count", "planet_count")
    raw_pos = psec._get("planet_positions_deg", False, None, "deg", "a list of planet_count angles")
    positions = None
    if raw_pos is not None:
        if not isinstance(raw_pos, list) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                    for v in raw_pos):
            raise psec.error(psec.key("planet_positions_deg"), "deg", "a list of numbers, first 0, increasing "
                             "in [0, 360)", raw_pos, problem=f"wrong type ({raw_pos!r})")
        positions = tuple(math.radians(float(v)) for v in raw_pos)
    cr = psec.number("carrier_radius_mm", "mm", 0.0, 10000.0, required=False, default=None, lo_open=True)
    cm = psec.number("carrier_mass_kg", "kg", 0.0, None, required=False, default=0.0)
    ci = psec.number("carrier_inertia_kgm2", "kg*m^2", 0.0, None, required=False, default=0.0)
    csec = psec.table("carrier_support", required=False)
    # absent: the carrier follows the kinematics (prescribed rotation) on rigid bearings
    cs = Support(_INF, _INF) if csec is None else _read_support(csec)
    fixed = psec.string("fixed_member", PLANETARY_MEMBERS, required=False, default="ring")
    output = psec.string("output_member", PLANETARY_MEMBERS, required=False, default=None)
    errors = []
    for esec in psec.array_of_tables("pin_errors", required=False):
        planet = esec.ranged("planet", "planet_count")
        rad = esec.number("radial_um", "um", -1000.0, 1000.0, required=False, default=0.0)
        tan = esec.number("tangential_um", "um", -1000.0, 1000.0, required=False, default=0.0)
        esec.done(_PIN_ERROR_KEYS)
        errors.append(PinError(planet, rad * 1e-6, tan * 1e-6))
    planet_errors = []
    for esec in psec.array_of_tables("planet_errors", required=False):
        planet = esec.ranged("planet", "planet_count")
        ge = _read_errors(esec, ("planet",))
        planet_errors.append(_wrap(esec, esec.path, lambda: PlanetErrors(planet, ge)))
    psec.done(_PLANETARY_KEYS + tuple(keys))
    return _wrap(psec, psec.path, lambda: Planetary(
        pc, None if cr is None else cr * 1e-3, cm, ci, cs, planet_positions_rad=positions, fixed_member=fixed,
        pin_errors=tuple(errors), output_member=output, planet_errors=tuple(planet_errors)))


#: what a default means, by key name (the last part of the TOML key)
DEFAULT_MEANINGS = {
    "internal": "external gear", "helix_angle_deg": "spur gear", "axial_position_mm": "gears aligned axially",
    "lead_crowning_um": "no lead crowning", "tip_edge_radius_mm": "sharp tip edge",
    "mass_kg": "computed from the blank (density, bore, web)", "inertia_kgm2": "computed from the blank",
    "coast": "coast flank = drive flank (symmetric tooth)", "gauges": "no strain gauges",
    "support": "rigid bearings (translational, axial, tilting stiffness inf), free rotation",
    "web": "solid blank from the bore to the root",
    "errors": "ideal teeth (no pitch or runout errors)",
    "single_pitch_deviations_um": "no pitch deviations (unless iso1328_grade draws them)",
    "iso1328_grade": "no generated pitch deviations", "seed": "seed 0 of the generated pitch deviations",
    "runout_um": "no runout", "runout_phase_deg": "runout towards tooth 0",
    "lead_slope_um": "no lead slope deviation",
    "misalignment_in_plane_urad": "aligned shafts",
    "misalignment_out_of_plane_urad": "no tilt about the line of action",
    "axis_deviation_in_axes_plane_urad": "parallel axes (no f_Sigma_delta)",
    "axis_deviation_normal_to_axes_plane_urad": "parallel axes (no f_Sigma_beta)",
    "tip_relief_um": "no tip relief", "tip_relief_start_roll_deg": "no tip relief",
    "tip_relief_shape": "none without tip relief, parabolic with",
    "translational_stiffness_N_per_m": "rigid bearing (purely rotational model)",
    "rotational_stiffness_Nm_per_rad": "free rotation (no shaft spring to ground)",
    "axial_stiffness_N_per_m": "rigid", "tilting_stiffness_Nm_per_rad": "rigid",
    "flank_a": "the drive flank carries the load", "flank_b": "the drive flank carries the load",
    "center_distance_mm": "zero-backlash centre distance from the geometry (planetary: carrier radius)",
    "line_of_centres_deg": "gear_b placed along +x from gear_a",
    "torque_gear": "the first gear", "statics": "the default statics grid",
    "positions": "statics grid", "loads": "statics grid", "deflections": "statics grid",
    "max_torque_factor": "statics grid", "face_slices": "statics grid", "twist_points": "statics grid",
    "carrier_radius_mm": "the sun-planet centre distance", "carrier_mass_kg": "massless carrier",
    "carrier_inertia_kgm2": "carrier without inertia", "carrier_support": "rigid carrier bearings, carrier rotation prescribed by the kinematics",
    "lumped": "gears with tooth geometry (not a lumped model)", "fixed_member": "the ring is held",
    "output_member": "the member neither the input (torque_gear) nor fixed",
    "pin_errors": "no planet pin position errors", "planet_errors": "every planet with the planet gear's errors", "planet_positions_deg": "equally spaced planets",
    "face_fraction": "gauge at mid face", "max_twist_mrad": "statics grid (mesh twist range, helical pairs)",
    "fe_lengths": "FE and contact lengths scale with the module for ISO-form gears, absolute for the transverse form",
    "hand": "spur gear (no hand)", "profile_shift": "no profile shift (x = 0)",
    "tip_alteration_mm": "no tip alteration (k = 0)", "basic_rack": "the three rack_*_coefficient keys",
    "thickness_allowance_upper_mm": "nominal tooth thickness (no allowance)",
    "thickness_allowance_lower_mm": "equal to thickness_allowance_upper_mm",
    "drive": "no tip relief (ISO form: the flank follows normal_pressure_angle_deg)",
}


def _describe_defaults(records: list, gears: tuple) -> tuple[tuple[str, str, str], ...]:
    """(key, value, meaning) of every default applied; ``gears[i]`` keys carry the gear's name."""
    out = []
    names = {f"gears[{i}]": g.name for i, g in enumerate(gears)}
    for key, value in records:
        if key in ("planetary", "system.title", "system.source"):  # metadata, or a section other kinds must not have
            continue
        head = key.split(".")[0]
        if head in names:
            key = f"{head} ({names[head]})" + key[len(head):]
        leaf = key.rsplit(".", 1)[-1]
        if isinstance(value, bool):
            value = "true" if value else "false"
        elif isinstance(value, float):
            value = f"{value:g}"
        elif value is None or value == []:
            value = "absent"
        out.append((key, str(value), DEFAULT_MEANINGS.get(leaf, "")))
    return tuple(out)


def model_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of the model file's bytes: the key that ties tables to their model."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def parse_model(text: str, *, file: str = "<model>", path: Path | None = None, sha256: str = "") -> Model:
    """Parse TOML text of a model file into a validated :class:`Model` (SI)."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"{file}: not valid TOML: {exc}") from None
    top = _Section(raw, "", file, [])

    sys_sec = top.table("system")
    name = sys_sec.string("name")
    kind = sys_sec.string("kind")   # the kinds registry checks the name (hacgear_core.kinds.load_model)
    title = sys_sec.string("title", required=False, default="")
    source = sys_sec.string("source", required=False, default="")
    lumped = sys_sec.boolean("lumped", default=False)
    sys_sec.done(_SYSTEM_KEYS)

    # gears that give no [gears.support]: the fixed member of a planetary set is then held (ring fixed)
    glist = raw.get("gears", [])
    no_support = {g.get("name") for g in (glist if isinstance(glist, list) else [])
                  if isinstance(g, dict) and "support" not in g and isinstance(g.get("name"), str)}
    if lumped:
        return _parse_lumped(top, name=name, kind=kind, title=title, source=source, file=file, path=path,
                             sha256=sha256, no_support=no_support)

    materials: dict[str, Material] = {}
    mats = top.table("materials")
    for mname in list(mats.data):
        msec = _Section(mats.data.pop(mname), f"materials.{mname}", file, top.defaults)
        rho = msec.number("density_kg_per_m3", "kg/m^3", 100.0, 30000.0)
        e_gpa = msec.number("youngs_modulus_GPa", "GPa", 1.0, 1000.0)
        nu = msec.number("poisson_ratio", "-", 0.0, 0.5, hi_open=True)
        msec.done(_MATERIAL_KEYS)
        materials[mname] = Material(mname, rho, e_gpa * 1e9, nu)
    if not materials:
        raise top.error("materials", "", "at least one [materials.<name>] table", {}, problem="no material defined")

    gears = tuple(_read_gear(s, materials) for s in top.array_of_tables("gears"))
    if not gears:
        raise top.error("gears", "", "at least two [[gears]]", [], problem="no gear defined")
    _unique_gear_names(top, gears)

    meshes = []
    for msec in top.array_of_tables("meshes"):
        mname = msec.string("name")
        ga = msec.string("gear_a")
        gb = msec.string("gear_b")
        fa = msec.string("flank_a", FLANKS, required=False, default="drive")
        fb = msec.string("flank_b", FLANKS, required=False, default="drive")
        cd = msec.number("center_distance_mm", "mm", 0.0, 20000.0, required=False, default=None, lo_open=True)
        loc = msec.number("line_of_centres_deg", "deg", -360.0, 360.0, required=False, default=0.0)
        mis = msec.number("misalignment_in_plane_urad", "urad", -1e4, 1e4, required=False, default=0.0)
        # a tilt about the line of action: second order on the drive flanks, first order on the coast flanks
        # (dynamics/lead.py)
        out_of_plane = msec.number("misalignment_out_of_plane_urad", "urad", -1e4, 1e4, required=False, default=0.0)
        # ISO 10064-4 axis parallelism deviations as angles (deviation over the bearing span / span): their part
        # about the line of action is second order and accepted (dynamics/lead.py)
        f_d = msec.number("axis_deviation_in_axes_plane_urad", "urad", -1e4, 1e4, required=False, default=0.0)
        f_b = msec.number("axis_deviation_normal_to_axes_plane_urad", "urad", -1e4, 1e4, required=False,
                          default=0.0)
        msec.done(_MESH_KEYS)
        meshes.append(_wrap(msec, msec.path, lambda: Mesh(mname, ga, gb, fa, fb, None if cd is None else cd * 1e-3,
                                                                    math.radians(loc),
                                                                    misalignment_in_plane_rad=mis * 1e-6,
                                                                    axis_deviation_in_axes_plane_rad=f_d * 1e-6,
                                                                    axis_deviation_normal_to_axes_plane_rad=f_b
                                                                    * 1e-6,
                                                                    misalignment_out_of_plane_rad=out_of_plane
                                                                    * 1e-6)))

    dsec = top.table("damping")
    damping = Damping(dsec.ranged("modal_damping_ratio", "modal_damping_ratio"))
    dsec.done(("modal_damping_ratio",))

    osec = top.table("operating")
    torque = osec.ranged("torque_Nm", "torque_Nm")
    tgear = osec.string("torque_gear", required=False, default=gears[0].name)
    osec.done(("torque_Nm", "torque_gear"))
    operating = Operating(torque, tgear)

    ssec = top.table("statics", required=False)
    if ssec is not None:
        statics = StaticsGrid(
            positions=ssec.ranged("positions", "statics.positions", required=False, default=64),
            loads=ssec.ranged("loads", "statics.loads", required=False, default=32),
            deflections=ssec.ranged("deflections", "statics.deflections", required=False, default=64),
            max_torque_factor=ssec.ranged("max_torque_factor", "statics.max_torque_factor", required=False,
                                          default=3.0),
            face_slices=ssec.ranged("face_slices", "statics.face_slices", required=False, default=21),
            twist_points=ssec.ranged("twist_points", "statics.twist_points", required=False, default=1),
            # below 1e-6 mrad a twist grid is meaningless (and a subnormal value would underflow to 0 rad)
            max_twist_rad=1e-3 * ssec.number("max_twist_mrad", "mrad", 1e-6, 10.0, required=False, default=1.0),
            fe_lengths=ssec.string("fe_lengths", FE_LENGTH_CHOICES, required=False, default="auto"),
        )
        ssec.done(_STATICS_KEYS)
    else:
        statics = StaticsGrid()

    psec = top.table("planetary", required=False)
    planetary = None
    if psec is not None:
        planetary = read_planetary(psec)
        if planetary.fixed_member in no_support:
            gears = tuple(replace(g, support=Support(_INF, _INF)) if g.name == planetary.fixed_member else g
                          for g in gears)

    sections = _kind_sections(top)
    top.done(_TOP_KEYS)
    try:
        return Model(
            name=name, kind=kind, title=title, source=source, gears=gears, meshes=tuple(meshes), damping=damping,
            operating=operating, statics=statics, planetary=planetary, path=path, sha256=sha256,
            defaults_applied=_describe_defaults(top.defaults, gears), sections=sections,
        )
    except ModelError as exc:
        raise ModelError(f"{file}: {exc}") from None


#: Relative tolerance of a lumped planetary set's carrier radius against the one its base radii and pressure angles
#: need: base radii given to 0.1 um and pressure angles to 0.005 deg (a relative error of about 3e-5) pass.
CARRIER_REACH_RTOL = 1e-4


def _check_carrier_reach(psec: _Section, carrier_radius_m: float, gears, meshes) -> None:
    """Refuse a lumped planetary set whose planets cannot mesh on its carrier radius: every mesh of two gears with
    base radii r_a, r_b and operating pressure angle alpha needs the centre distance (r_a + r_b) / cos alpha (a ring,
    internal: |r_ring - r_planet| / cos alpha) to equal the carrier radius within :data:`CARRIER_REACH_RTOL`."""
    by = {g.name: g for g in gears}
    for mesh in meshes:
        ga, gb = by.get(mesh.gear_a), by.get(mesh.gear_b)
        if ga is None or gb is None:
            continue  # the model's own check names the missing gear
        ra, rb = ga.base_radius_m, gb.base_radius_m
        span = abs(ra - rb) if (ga.internal or gb.internal) else ra + rb
        need = span / math.cos(mesh.pressure_angle_rad)
        if abs(carrier_radius_m - need) > CARRIER_REACH_RTOL * need:
            sign = "-" if (ga.internal or gb.internal) else "+"
            raise psec.error(psec.key("carrier_radius_mm"), "mm",
                             f"{need * 1e3:.4f} mm within {CARRIER_REACH_RTOL:g} relative", carrier_radius_m * 1e3,
                             problem=(f"value {carrier_radius_m * 1e3:g} cannot be reached by mesh '{mesh.name}': its "
                                      f"base radii {ra * 1e3:g} {sign} {rb * 1e3:g} mm at pressure angle "
                                      f"{math.degrees(mesh.pressure_angle_rad):g} deg need a centre distance "
                                      f"(r_a {sign} r_b) / cos(alpha) = {need * 1e3:.4f} mm; the planets could not "
                                      "mesh"))


def _unique_gear_names(top: "_Section", gears) -> None:
    """Refuse two [[gears]] of one name before any mesh refers to them (a mesh would then see one gear twice)."""
    seen: dict[str, int] = {}
    for i, g in enumerate(gears):
        if g.name in seen:
            raise top.error(f"gears[{i}].name", "", "a name no other gear has", g.name,
                            problem=f"'{g.name}' is already the name of gears[{seen[g.name]}]")
        seen[g.name] = i


def _parse_lumped(top: _Section, *, name: str, kind: str, title: str, source: str, file: str, path: Path | None,
                  sha256: str, no_support: set) -> Model:
    """A fully lumped model (``[system] lumped = true``): members by mass, inertia and base radius, meshes by a
    constant stiffness and pressure angle; no materials, tooth geometry or statics grid."""
    gears = tuple(_read_lumped_gear(s) for s in top.array_of_tables("gears"))
    if not gears:
        raise top.error("gears", "", "at least two [[gears]]", [], problem="no gear defined")
    _unique_gear_names(top, gears)
    meshes = []
    for msec in top.array_of_tables("meshes"):
        mname = msec.string("name")
        ga = msec.string("gear_a")
        gb = msec.string("gear_b")
        k = msec.number("mesh_stiffness_N_per_m", "N/m", 0.0, 1e13, lo_open=True)
        pa = msec.number("pressure_angle_deg", "deg", 5.0, 40.0)
        msec.done(_LUMPED_MESH_KEYS)
        meshes.append(_wrap(msec, msec.path, lambda: Mesh(mname, ga, gb, mesh_stiffness_N_per_m=k,
                                                          pressure_angle_rad=math.radians(pa))))
    dsec = top.table("damping", required=False)
    damping = Damping()
    if dsec is not None:
        damping = Damping(dsec.ranged("modal_damping_ratio", "modal_damping_ratio"))
        dsec.done(("modal_damping_ratio",))
    osec = top.table("operating", required=False)
    operating = Operating(1.0, gears[0].name)
    if osec is not None:
        torque = osec.ranged("torque_Nm", "torque_Nm")
        tgear = osec.string("torque_gear", required=False, default=gears[0].name)
        osec.done(("torque_Nm", "torque_gear"))
        operating = Operating(torque, tgear)
    psec = top.table("planetary", required=False)
    planetary = read_planetary(psec) if psec is not None else None
    if planetary is not None and planetary.carrier_radius_m is not None:
        _check_carrier_reach(psec, planetary.carrier_radius_m, gears, meshes)
    if planetary is not None and planetary.fixed_member in no_support:
        gears = tuple(replace(g, support=Support(_INF, _INF)) if g.name == planetary.fixed_member else g
                      for g in gears)
    top.done(("system", "gears", "meshes", "damping", "operating", "planetary"))
    try:
        return Model(name=name, kind=kind, title=title, source=source, gears=gears, meshes=tuple(meshes),
                     damping=damping, operating=operating, statics=StaticsGrid(), planetary=planetary, path=path,
                     sha256=sha256, lumped=True)
    except ModelError as exc:
        raise ModelError(f"{file}: {exc}") from None


def shipped_systems_dir() -> Path:
    """Folder of the shipped gear systems (the package data ``hacgear_core.systems``, ``models/`` of the checkout)."""
    return Path(str(_resources.files("hacgear_core.systems")))


def shipped_systems() -> tuple[str, ...]:
    """Names of the shipped gear systems."""
    base = shipped_systems_dir()
    return tuple(sorted(d.name for d in base.iterdir() if (d / "model.toml").is_file()))


def resolve_model_path(model: str | Path) -> Path:
    """Accept a model file, its folder, or a system name (``./models/<name>`` first, then the shipped systems)."""
    p = Path(model)
    if p.is_dir():
        p = p / "model.toml"
    if p.exists():
        if not p.is_file():
            raise ModelError(f"model file {str(p)!r} is not a file (a folder?); give models/<system>/model.toml, its "
                             "folder or a system name")
        return p.resolve()
    for base in (Path.cwd() / "models", shipped_systems_dir()):
        cand = base / str(model) / "model.toml"
        if cand.is_file():
            return cand.resolve()
    raise ModelError(f"model file not found: {model!r} (give models/<system>/model.toml, its folder, or a system name; "
                     f"shipped systems: {', '.join(shipped_systems())})")


def read_model(model: str | Path) -> Model:
    """Read a model file (path, folder or system name) → :class:`Model`, every section validated but the rules of
    its kind (:func:`hacgear_core.kinds.load_model` adds them)."""
    path = resolve_model_path(model)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ModelError(f"{path}: cannot read the model file ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8-sig")   # a byte-order mark (Windows editors write one) is no TOML
    except UnicodeDecodeError:
        raise ModelError(f"{path}: model file is not UTF-8 text") from None
    return parse_model(text, file=str(path), path=path, sha256=hashlib.sha256(data).hexdigest())
