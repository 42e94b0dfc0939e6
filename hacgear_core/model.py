"""Model files: ``models/<system>/model.toml`` → validated, frozen dataclasses (SI inside).

A model file describes one gear system: its kind, materials, gears, meshes, supports, damping,
operating point and the grids of the static analyses.  Keys carry their unit in the name when it is
not SI (``module_mm``, ``tip_relief_um``, ``youngs_modulus_GPa``); the dataclasses hold SI values with
the unit in the attribute name where it could be ambiguous (``module_m``, ``tip_relief_m``).

Unknown keys, missing keys, wrong types and out-of-range values are each reported as one
:class:`~hacgear_core.errors.ModelError` naming the file, the key, its unit and the allowed range.

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
    positions = 64; loads = 32; max_torque_factor = 3.0
"""
from __future__ import annotations

import hashlib
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

from hacgear_core.errors import ModelError

__all__ = [
    "SYSTEM_KINDS",
    "FLANKS",
    "RELIEF_SHAPES",
    "Material",
    "Flank",
    "Gauge",
    "Support",
    "Web",
    "Gear",
    "Mesh",
    "Damping",
    "Operating",
    "StaticsGrid",
    "Planetary",
    "Model",
    "load_model",
    "parse_model",
    "model_sha256",
    "resolve_model_path",
]

SYSTEM_KINDS = ("spur_pair", "idler_chain", "planetary", "helical_pair")
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
    """A strain gauge on the root surface of a flank at a given radius from the gear centre [m]."""

    name: str
    flank: str
    radius_m: float

    def __post_init__(self) -> None:
        if self.flank not in FLANKS:
            raise _fail("flank", "", " | ".join(FLANKS), self.flank)
        _check_range("radius_m", self.radius_m, "m", 0.0, 10.0, lo_open=True)


@dataclass(frozen=True)
class Support:
    """Bearing/shaft stiffness of one gear (SI).  ``inf`` translational stiffness: rigid (no
    translation DOF); ``0`` rotational stiffness: free rotation (torque-driven)."""

    translational_stiffness_N_per_m: float = _INF
    rotational_stiffness_Nm_per_rad: float = 0.0
    axial_stiffness_N_per_m: float = _INF
    tilting_stiffness_Nm_per_rad: float = _INF

    def __post_init__(self) -> None:
        for name, unit in (
            ("translational_stiffness_N_per_m", "N/m"),
            ("rotational_stiffness_Nm_per_rad", "N*m/rad"),
            ("axial_stiffness_N_per_m", "N/m"),
            ("tilting_stiffness_Nm_per_rad", "N*m/rad"),
        ):
            _check_range(name, getattr(self, name), unit, 0.0, None)

    @property
    def rigid_translation(self) -> bool:
        return math.isinf(self.translational_stiffness_N_per_m)


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
    to the root) or None (solid blank from the bore to the root).
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

    def __post_init__(self) -> None:
        where = f"gear '{self.name}'"
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
        d_ref = self.module_m * self.teeth
        if self.internal:
            if not self.tip_diameter_m < d_ref < self.root_diameter_m:
                raise ModelError(
                    f"{where}: internal gear needs tip_diameter < reference diameter {d_ref * 1e3:.3f} mm "
                    f"< root_diameter; got tip {self.tip_diameter_m * 1e3:.3f} mm, root "
                    f"{self.root_diameter_m * 1e3:.3f} mm"
                )
            if self.bore_diameter_m and self.bore_diameter_m <= self.root_diameter_m:
                raise ModelError(
                    f"{where}: bore_diameter [m] (outer rim diameter of an internal gear) = "
                    f"{self.bore_diameter_m:g} must exceed root_diameter {self.root_diameter_m:g}"
                )
        else:
            if not self.root_diameter_m < d_ref < self.tip_diameter_m:
                raise ModelError(
                    f"{where}: external gear needs root_diameter < reference diameter {d_ref * 1e3:.3f} mm "
                    f"< tip_diameter; got root {self.root_diameter_m * 1e3:.3f} mm, tip "
                    f"{self.tip_diameter_m * 1e3:.3f} mm"
                )
            if self.bore_diameter_m >= self.root_diameter_m:
                raise ModelError(
                    f"{where}: bore_diameter_m [m] = {self.bore_diameter_m:g} must be smaller than the root "
                    f"diameter {self.root_diameter_m:g} m (allowed: [0, root_diameter))"
                )
        pitch = math.pi * self.module_m
        if not 0.1 * pitch < self.tooth_thickness_m < 0.9 * pitch:
            raise ModelError(
                f"{where}: tooth_thickness_m [m] = {self.tooth_thickness_m:g} must lie within (0.1, 0.9) x "
                f"circular pitch = ({0.1 * pitch:g}, {0.9 * pitch:g}) m"
            )
        names = [g.name for g in self.gauges]
        if len(set(names)) != len(names):
            raise ModelError(f"{where}: gauge names must be unique, got {names}")
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
    geometry (the zero-backlash centre distance, see geometry; planetary: the carrier radius)."""

    name: str
    gear_a: str
    gear_b: str
    flank_a: str = "drive"
    flank_b: str = "drive"
    center_distance_m: float | None = None

    def __post_init__(self) -> None:
        for attr in ("flank_a", "flank_b"):
            if getattr(self, attr) not in FLANKS:
                raise _fail(attr, "", " | ".join(FLANKS), getattr(self, attr), f"mesh '{self.name}'")
        if self.gear_a == self.gear_b:
            raise ModelError(f"mesh '{self.name}': gear_a and gear_b must differ, both are '{self.gear_a}'")
        if self.center_distance_m is not None:
            _check_range("center_distance_m", self.center_distance_m, "m", 0.0, 20.0, lo_open=True)


@dataclass(frozen=True)
class Damping:
    """Viscous damping as a modal damping ratio (-) applied to every elastic mode of the linearised
    system (rigid-body rotation undamped)."""

    modal_damping_ratio: float = 0.02

    def __post_init__(self) -> None:
        _check_range("modal_damping_ratio", self.modal_damping_ratio, "-", 0.0, 1.0)


@dataclass(frozen=True)
class Operating:
    """Nominal operating point: ``torque_Nm`` applied on gear ``torque_gear``."""

    torque_Nm: float
    torque_gear: str

    def __post_init__(self) -> None:
        _check_range("torque_Nm", self.torque_Nm, "N*m", 0.0, 1e7, lo_open=True)


@dataclass(frozen=True)
class StaticsGrid:
    """Grids of the static analyses: ``positions`` per mesh cycle, ``loads`` from 0 to
    ``max_torque_factor`` x nominal torque, ``deflections`` points of the regular FDF deflection grid,
    ``face_slices`` slices across the face width (crowning, helix), ``twist_points`` (helical)."""

    positions: int = 64
    loads: int = 32
    deflections: int = 64
    max_torque_factor: float = 3.0
    face_slices: int = 21
    twist_points: int = 1

    def __post_init__(self) -> None:
        for name, lo, hi in (
            ("positions", 4, 4096),
            ("loads", 2, 1024),
            ("deflections", 4, 4096),
            ("face_slices", 1, 200),
            ("twist_points", 1, 64),
        ):
            v = getattr(self, name)
            if not isinstance(v, int) or not lo <= v <= hi:
                raise _fail(name, "-", f"integer in [{lo}, {hi}]", v)
        _check_range("max_torque_factor", self.max_torque_factor, "-", 1.0, 20.0)


@dataclass(frozen=True)
class Planetary:
    """Planetary set options: ``planet_count`` equally spaced planets on ``carrier_radius_m``
    (None: the sun-planet centre distance); carrier lumped mass/inertia and support."""

    planet_count: int
    carrier_radius_m: float | None = None
    carrier_mass_kg: float = 0.0
    carrier_inertia_kgm2: float = 0.0
    carrier_support: Support = field(default_factory=Support)

    def __post_init__(self) -> None:
        if not isinstance(self.planet_count, int) or not 1 <= self.planet_count <= 12:
            raise _fail("planet_count", "-", "integer in [1, 12]", self.planet_count)
        if self.carrier_radius_m is not None:
            _check_range("carrier_radius_m", self.carrier_radius_m, "m", 0.0, 10.0, lo_open=True)
        _check_range("carrier_mass_kg", self.carrier_mass_kg, "kg", 0.0, None)
        _check_range("carrier_inertia_kgm2", self.carrier_inertia_kgm2, "kg*m^2", 0.0, None)


@dataclass(frozen=True)
class Model:
    """A whole gear system (SI).  ``path``/``sha256`` identify the model file it came from."""

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

    def __post_init__(self) -> None:
        if self.kind not in SYSTEM_KINDS:
            raise _fail("system.kind", "", " | ".join(SYSTEM_KINDS), self.kind)
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
                        f"meshes.{m.name}.{attr} = {getattr(m, attr)!r} names no gear; allowed: {names}"
                    )
            ga, gb = self.gear(m.gear_a), self.gear(m.gear_b)
            if ga.internal and gb.internal:
                raise ModelError(f"mesh '{m.name}': two internal gears cannot mesh")
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
                    f"differs from {gb.name}.{m.flank_b} ({math.degrees(pb):g} deg); the loaded flanks must "
                    "be cut by the same rack"
                )
            if abs(ga.helix_angle_rad + gb.helix_angle_rad) > 1e-9 and not (ga.internal or gb.internal):
                raise ModelError(
                    f"mesh '{m.name}': external helical gears need opposite helix angles, got "
                    f"{math.degrees(ga.helix_angle_rad):g} and {math.degrees(gb.helix_angle_rad):g} deg"
                )
        if self.operating.torque_gear not in names:
            raise ModelError(f"operating.torque_gear = {self.operating.torque_gear!r} names no gear; allowed: {names}")
        expected_meshes = {"spur_pair": 1, "helical_pair": 1, "idler_chain": None, "planetary": 2}
        n = expected_meshes[self.kind]
        if n is not None and len(self.meshes) != n:
            raise ModelError(f"system.kind = '{self.kind}' needs exactly {n} [[meshes]], found {len(self.meshes)}")
        if self.kind == "planetary" and self.planetary is None:
            raise ModelError("system.kind = 'planetary' needs a [planetary] table (planet_count)")
        if self.kind != "planetary" and self.planetary is not None:
            raise ModelError(f"[planetary] is only allowed for kind 'planetary', not '{self.kind}'")
        if self.kind == "helical_pair" and not any(g.is_helical for g in self.gears):
            raise ModelError("system.kind = 'helical_pair' needs gears with helix_angle_deg != 0")
        if self.kind in ("spur_pair", "idler_chain", "planetary") and any(g.is_helical for g in self.gears):
            raise ModelError(f"system.kind = '{self.kind}' is spur: helix_angle_deg must be 0")

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


# --------------------------------------------------------------------------------------------
# TOML reader with precise errors
# --------------------------------------------------------------------------------------------
class _Section:
    """Pops typed keys from one TOML table and reports unknown keys at the end."""

    def __init__(self, data: Any, path: str, file: str) -> None:
        self.file = file
        self.path = path
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
                raise self.error(self.key(name), unit, allowed, None, problem="missing required key")
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
        return _Section(v, self.key(name), self.file)

    def array_of_tables(self, name: str, *, required: bool = True) -> list["_Section"]:
        v = self._get(name, required, [], "", "an array of tables [[...]]")
        if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
            raise self.error(self.key(name), "", f"an array of tables [[{self.key(name)}]]", v,
                             problem="wrong type")
        return [_Section(x, f"{self.key(name)}[{i}]", self.file) for i, x in enumerate(v)]

    def done(self, allowed: tuple[str, ...]) -> None:
        if self.data:
            unknown = sorted(self.data)
            raise ModelError(
                f"{self.file}: unknown key '{self.key(unknown[0])}' in [{self.path or 'top level'}]; allowed keys: "
                f"{', '.join(sorted(allowed))}"
            )


_MATERIAL_KEYS = ("density_kg_per_m3", "youngs_modulus_GPa", "poisson_ratio")
_FLANK_KEYS = ("pressure_angle_deg", "tip_relief_um", "tip_relief_start_roll_deg", "tip_relief_shape")
_GAUGE_KEYS = ("name", "flank", "radius_mm")
_SUPPORT_KEYS = (
    "translational_stiffness_N_per_m", "rotational_stiffness_Nm_per_rad", "axial_stiffness_N_per_m",
    "tilting_stiffness_Nm_per_rad",
)
_GEAR_KEYS = (
    "name", "teeth", "module_mm", "tip_diameter_mm", "root_diameter_mm", "tooth_thickness_mm", "hob_tip_radius_mm",
    "face_width_mm", "bore_diameter_mm", "material", "internal", "helix_angle_deg", "axial_position_mm",
    "lead_crowning_um", "tip_edge_radius_mm", "mass_kg", "inertia_kgm2", "drive", "coast", "gauges", "support",
    "web",
)
_WEB_KEYS = ("thickness_mm", "inner_diameter_mm", "outer_diameter_mm")
_MESH_KEYS = ("name", "gear_a", "gear_b", "flank_a", "flank_b", "center_distance_mm")
_TOP_KEYS = ("system", "materials", "gears", "meshes", "damping", "operating", "statics", "planetary")


def _wrap(sec: _Section, key: str, fn: Callable[[], Any]) -> Any:
    """Re-raise a dataclass validation error with the file and the TOML key prefix."""
    try:
        return fn()
    except ModelError as exc:
        msg = str(exc)
        if msg.startswith(sec.file):
            raise
        raise ModelError(f"{sec.file}: [{key}] {msg}") from None


def _read_flank(sec: _Section) -> Flank:
    pa = sec.number("pressure_angle_deg", "deg", 5.0, 40.0)
    relief = sec.number("tip_relief_um", "um", 0.0, 1000.0, required=False, default=0.0)
    start = sec.number("tip_relief_start_roll_deg", "deg", 0.0, 89.0, required=False, default=0.0)
    shape = sec.string("tip_relief_shape", RELIEF_SHAPES, required=False,
                       default="parabolic" if relief > 0 else "none")
    sec.done(_FLANK_KEYS)
    if relief > 0 and start <= 0:
        raise sec.error(sec.key("tip_relief_start_roll_deg"), "deg", "(0, 89]", start,
                        problem="missing or zero while tip_relief_um > 0")
    if relief > 0 and shape == "none":
        raise sec.error(sec.key("tip_relief_shape"), "", "linear | parabolic", shape,
                        problem="'none' while tip_relief_um > 0")
    return _wrap(sec, sec.path, lambda: Flank(math.radians(pa), relief * 1e-6, math.radians(start), shape))


def _read_support(ssec: "_Section | None") -> Support:
    if ssec is None:
        return Support()
    support = Support(
        ssec.number("translational_stiffness_N_per_m", "N/m", 0.0, None, required=False, default=_INF,
                    allow_inf=True),
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
    name = sec.string("name")
    teeth = sec.integer("teeth", 6, 1000)
    module = sec.number("module_mm", "mm", 0.1, 100.0)
    internal = sec.boolean("internal", default=False)
    tip = sec.number("tip_diameter_mm", "mm", 1.0, 20000.0)
    root = sec.number("root_diameter_mm", "mm", 1.0, 20000.0)
    thick = sec.number("tooth_thickness_mm", "mm", 0.01, 1000.0)
    hob = sec.number("hob_tip_radius_mm", "mm", 0.0, 50.0, required=False, default=0.25 * module)
    face = sec.number("face_width_mm", "mm", 0.1, 2000.0)
    bore = sec.number("bore_diameter_mm", "mm", 0.0, 40000.0, required=False, default=0.0)
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
    gauges = []
    for gsec in sec.array_of_tables("gauges", required=False):
        gname = gsec.string("name")
        gflank = gsec.string("flank", FLANKS)
        grad = gsec.number("radius_mm", "mm", 0.0, 20000.0, lo_open=True)
        gsec.done(_GAUGE_KEYS)
        gauges.append(Gauge(gname, gflank, grad * 1e-3))
    support = _read_support(sec.table("support", required=False))
    web = _read_web(sec.table("web", required=False), face, bore, root, internal)
    sec.done(_GEAR_KEYS)
    return _wrap(sec, sec.path, lambda: Gear(
        name=name, teeth=teeth, module_m=module * 1e-3, tip_diameter_m=tip * 1e-3, root_diameter_m=root * 1e-3,
        tooth_thickness_m=thick * 1e-3, hob_tip_radius_m=hob * 1e-3, face_width_m=face * 1e-3,
        bore_diameter_m=bore * 1e-3, material=materials[mat_name], flanks={"drive": drive, "coast": coast},
        internal=internal, helix_angle_rad=math.radians(helix), axial_position_m=axial * 1e-3,
        lead_crowning_m=crown * 1e-6, tip_edge_radius_m=tip_edge * 1e-3, mass_kg=mass, inertia_kgm2=inertia,
        gauges=tuple(gauges), support=support, web=web,
    ))


def model_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of the model file's bytes: the key that ties tables to their model."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def parse_model(text: str, *, file: str = "<model>", path: Path | None = None, sha256: str = "") -> Model:
    """Parse TOML text of a model file into a validated :class:`Model` (SI)."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"{file}: not valid TOML: {exc}") from None
    top = _Section(raw, "", file)

    sys_sec = top.table("system")
    name = sys_sec.string("name")
    kind = sys_sec.string("kind", SYSTEM_KINDS)
    title = sys_sec.string("title", required=False, default="")
    source = sys_sec.string("source", required=False, default="")
    sys_sec.done(("name", "kind", "title", "source"))

    materials: dict[str, Material] = {}
    mats = top.table("materials")
    for mname in list(mats.data):
        msec = _Section(mats.data.pop(mname), f"materials.{mname}", file)
        rho = msec.number("density_kg_per_m3", "kg/m^3", 100.0, 30000.0)
        e_gpa = msec.number("youngs_modulus_GPa", "GPa", 1.0, 1000.0)
        nu = msec.number("poisson_ratio", "-", 0.0, 0.5, required=False, default=0.3, hi_open=True)
        msec.done(_MATERIAL_KEYS)
        materials[mname] = Material(mname, rho, e_gpa * 1e9, nu)
    if not materials:
        raise top.error("materials", "", "at least one [materials.<name>] table", {}, problem="no material defined")

    gears = tuple(_read_gear(s, materials) for s in top.array_of_tables("gears"))
    if not gears:
        raise top.error("gears", "", "at least two [[gears]]", [], problem="no gear defined")

    meshes = []
    for msec in top.array_of_tables("meshes"):
        mname = msec.string("name")
        ga = msec.string("gear_a")
        gb = msec.string("gear_b")
        fa = msec.string("flank_a", FLANKS, required=False, default="drive")
        fb = msec.string("flank_b", FLANKS, required=False, default="drive")
        cd = msec.number("center_distance_mm", "mm", 0.0, 20000.0, required=False, default=None, lo_open=True)
        msec.done(_MESH_KEYS)
        meshes.append(_wrap(msec, msec.path, lambda: Mesh(mname, ga, gb, fa, fb, None if cd is None else cd * 1e-3)))

    dsec = top.table("damping", required=False)
    if dsec is not None:
        damping = Damping(dsec.number("modal_damping_ratio", "-", 0.0, 1.0))
        dsec.done(("modal_damping_ratio",))
    else:
        damping = Damping()

    osec = top.table("operating")
    torque = osec.number("torque_Nm", "N*m", 0.0, 1e7, lo_open=True)
    tgear = osec.string("torque_gear", required=False, default=gears[0].name)
    osec.done(("torque_Nm", "torque_gear"))
    operating = Operating(torque, tgear)

    ssec = top.table("statics", required=False)
    if ssec is not None:
        statics = StaticsGrid(
            positions=ssec.integer("positions", 4, 4096, required=False, default=64),
            loads=ssec.integer("loads", 2, 1024, required=False, default=32),
            deflections=ssec.integer("deflections", 4, 4096, required=False, default=64),
            max_torque_factor=ssec.number("max_torque_factor", "-", 1.0, 20.0, required=False, default=3.0),
            face_slices=ssec.integer("face_slices", 1, 200, required=False, default=21),
            twist_points=ssec.integer("twist_points", 1, 64, required=False, default=1),
        )
        ssec.done(("positions", "loads", "deflections", "max_torque_factor", "face_slices", "twist_points"))
    else:
        statics = StaticsGrid()

    psec = top.table("planetary", required=False)
    planetary = None
    if psec is not None:
        pc = psec.integer("planet_count", 1, 12)
        cr = psec.number("carrier_radius_mm", "mm", 0.0, 10000.0, required=False, default=None, lo_open=True)
        cm = psec.number("carrier_mass_kg", "kg", 0.0, None, required=False, default=0.0)
        ci = psec.number("carrier_inertia_kgm2", "kg*m^2", 0.0, None, required=False, default=0.0)
        cs = _read_support(psec.table("carrier_support", required=False))
        psec.done(("planet_count", "carrier_radius_mm", "carrier_mass_kg", "carrier_inertia_kgm2", "carrier_support"))
        planetary = Planetary(pc, None if cr is None else cr * 1e-3, cm, ci, cs)

    top.done(_TOP_KEYS)
    try:
        return Model(
            name=name, kind=kind, title=title, source=source, gears=gears, meshes=tuple(meshes), damping=damping,
            operating=operating, statics=statics, planetary=planetary, path=path, sha256=sha256,
        )
    except ModelError as exc:
        raise ModelError(f"{file}: {exc}") from None


_MODELS_DIR = Path(__file__).resolve().parent.parent / "models"


def resolve_model_path(model: str | Path) -> Path:
    """Accept ``models/<system>/model.toml``, its folder, or a bare system name found in ``models/``."""
    p = Path(model)
    if p.is_dir():
        p = p / "model.toml"
    if p.exists():
        return p.resolve()
    for base in (Path.cwd() / "models", _MODELS_DIR):
        cand = base / str(model) / "model.toml"
        if cand.exists():
            return cand.resolve()
    raise ModelError(f"model file not found: {model!r} (give models/<system>/model.toml, its folder, or a system name)")


def load_model(model: str | Path) -> Model:
    """Read and validate a model file (path, folder or system name) → :class:`Model`."""
    path = resolve_model_path(model)
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ModelError(f"{path}: model file is not UTF-8 text") from None
    return parse_model(text, file=str(path), path=path, sha256=hashlib.sha256(data).hexdigest())
