"""Planetary sets placed in the carrier frame: planets at their angles, mesh directions, planet phasing, torque flow.

Frame: the carrier frame (rotating with the nominal carrier motion), origin at the sun centre, x towards
planet 1; angles counter-clockwise.  In it the set is a fixed-axis train: the sun and the ring turn about the
origin, planet ``i`` about its pin at ``r_c (cos psi_i, sin psi_i)``.  The train is expanded into its gear
instances (``sun``, ``ring``, ``planet_1 .. planet_N``) and mesh instances (``sun_planet_i``,
``ring_planet_i``: the model's two meshes, one per planet) and placed by :func:`~.train.train_geometry`: line of
action, moment arms, mesh phases and tooth passages of every instance come from the tooth geometry and the tooth
counts, never typed.

Planet phasing.  ``phase`` is the kernel's convention: the position of a mesh (mesh cycles) when sun_planet_1 is
at 0.  Parker's mesh *delay* ``gamma`` (Lin & Parker 2004) is the time, in mesh periods, by which a mesh lags
planet 1's mesh of the same kind: ``F_i(t) = F_1(t - gamma_i T_m)``, ``gamma_i = -(phase_i - phase_1)`` mod 1.
With the sun turning counter-clockwise relative to the carrier and the planets numbered counter-clockwise,
``gamma_si = z_s psi_i / (2 pi)`` mod 1 ({0, 2/3, 1/3} for three equally spaced planets on a 65-tooth sun) and
``gamma_ri = -z_r psi_i / (2 pi)`` mod 1; a planet can only be assembled where ``(z_s + z_r) psi_i / (2 pi)`` is an
integer.

Power flow (:func:`planetary_power_flow`).  The input (``[operating] torque_gear``), the fixed member and the output
(``[planetary] output_member``, default the remaining one) decide which member drives each mesh relative to the
carrier: the sun drives the planets when it is the input or the ring the output, otherwise the ring drives the
planets and the planets drive the sun.  Each mesh names its driver gear_a (the tables' mesh positions advance as
gear_a drives; a model whose gear order contradicts the power flow is refused with the mesh lines that fix it) and
the sun is moved to the origin of the placement whichever gear the first mesh names first.

Kinematics.  Relative to the carrier the members turn with the train's speed ratios ``rho_j`` (senses from the
loaded flank of the first mesh's driver, magnitudes from the tooth counts); with the fixed member ``f`` held, the
absolute speeds are ``omega_j = (rho_j - rho_f) Omega`` and the carrier's ``-rho_f Omega`` (``Omega`` the sun's
speed relative to the carrier, > 0 when the meshes run forwards: mesh frequency ``z_s Omega / 2 pi``).

Torque flow.  External torques (counter-clockwise) ``T_s : T_r : T_c = 1 : z_r/z_s : -(1 + z_r/z_s)``; each of the
``N`` planets carries ``F_s = |T_s| / (N r_bs)`` on its sun mesh and ``F_r = F_s r_bps / r_bpr`` on its ring mesh
(equal load sharing, the nominal forces of the tables and the linearisation).

Lumped models (no tooth geometry) are placed analytically: line of action from the operating pressure angle
(``n = cos(a) t + sin(a) d``, ``t`` the velocity direction of the driving member at the pitch point, ``d`` the
separating direction), moment arms ``+-`` the base radii, phases from the tooth counts alone (the sun-ring phase
within a planet, which needs the tooth geometry, is 0).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from fractions import Fraction
from types import SimpleNamespace
from typing import Any, Mapping

import numpy as np

from hacgear_core.errors import GeometryError, ModelError
from hacgear_core.geometry.gear import gear_geometry
from hacgear_core.geometry.mesh import mesh_geometry
from hacgear_core.geometry.train import train_geometry

__all__ = [
    "PlanetaryMembers",
    "PlanetaryPowerFlow",
    "planetary_power_flow",
    "PlanetMesh",
    "PlanetaryGeometry",
    "planetary_members",
    "planet_positions",
    "planetary_geometry",
    "planetary_torques",
    "assembly_step_rad",
]


@dataclass(frozen=True)
class PlanetaryMembers:
    """Names in a planetary model: the ``sun``, ``planet`` and ``ring`` gears and the ``sun_mesh`` (sun-planet)
    and ``ring_mesh`` (planet-ring) of the model."""

    sun: str
    planet: str
    ring: str
    sun_mesh: str
    ring_mesh: str


def planetary_members(model: Any) -> PlanetaryMembers:
    """Identify sun, planet, ring and the two meshes of a planetary model (the planet is in both meshes, the ring
    is the internal gear).

    Raises
    ------
    ModelError
        Not two meshes sharing one external gear, or no internal gear in the second.
    """
    if getattr(model, "planetary", None) is None:
        raise ModelError(f"{model.name}: not a planetary model (no [planetary] table)")
    if len(model.meshes) != 2:
        raise ModelError(f"{model.name}: a planetary set has exactly 2 [[meshes]] (sun-planet, planet-ring), "
                         f"found {len(model.meshes)}")
    internal = {g.name: bool(getattr(g, "internal", False)) for g in model.gears}
    m1, m2 = model.meshes
    shared = {m1.gear_a, m1.gear_b} & {m2.gear_a, m2.gear_b}
    if len(shared) != 1:
        raise ModelError(f"{model.name}: the two meshes must share exactly one gear (the planet), share {shared}")
    planet = shared.pop()
    if internal[planet]:
        raise ModelError(f"{model.name}: the planet '{planet}' (in both meshes) must be an external gear")
    others = {m.name: (m.gear_b if m.gear_a == planet else m.gear_a) for m in (m1, m2)}
    rings = [mn for mn, g in others.items() if internal[g]]
    if len(rings) != 1:
        raise ModelError(f"{model.name}: exactly one mesh must pair the planet with the internal gear (ring); "
                         f"meshes pair it with {others}")
    ring_mesh = rings[0]
    sun_mesh = m1.name if ring_mesh == m2.name else m2.name
    return PlanetaryMembers(sun=others[sun_mesh], planet=planet, ring=others[ring_mesh], sun_mesh=sun_mesh,
                            ring_mesh=ring_mesh)


@dataclass(frozen=True)
class PlanetaryPowerFlow:
    """The power flow of a planetary set: the ``input``, ``output`` and ``fixed`` members (roles ``sun``, ``ring``,
    ``carrier``) and the member that drives each mesh relative to the carrier: ``sun_mesh_driver`` (``sun`` or
    ``planet``) and ``ring_mesh_driver`` (``planet`` or ``ring``), gear names of the model.  ``sun_drives``: the
    sun drives the planets relative to the carrier (the sun is the input or the ring the output)."""

    input: str
    output: str
    fixed: str
    sun_drives: bool
    sun_mesh_driver: str
    ring_mesh_driver: str

    @property
    def arrangement(self) -> str:
        return f"{self.input} in, {self.output} out, {self.fixed} fixed"


def planetary_power_flow(model: Any, input_member: str | None = None,
                         members: PlanetaryMembers | None = None) -> PlanetaryPowerFlow:
    """The power flow of ``model``'s planetary set: input ``[operating] torque_gear`` (or ``input_member``: a gear
    name of the sun or the ring, or ``carrier``), ``[planetary] fixed_member`` and ``[planetary] output_member``
    (default: the remaining member).

    Relative to the carrier only the sun and the ring turn, and their powers ``T_s (w_s - w_c)`` and ``T_r (w_r -
    w_c)`` add to 0: one of them drives the planets, the other is driven.  With the torques ``T_s : T_r : T_c = 1 :
    z_r/z_s : -(1 + z_r/z_s)`` and Willis' kinematics the sun drives exactly when it is the input or the ring is
    the output (sun in, carrier or ring out; carrier in, ring out with the sun fixed); otherwise the ring drives
    the planets and the planets drive the sun (carrier in, sun out with the ring fixed: a wind turbine's stage;
    ring in, sun or carrier out).

    Raises
    ------
    ModelError
        An input that is not a member of the set, an input that is fixed, an output equal to the input.
    """
    mem = planetary_members(model) if members is None else members
    role = {mem.sun: "sun", mem.ring: "ring", "carrier": "carrier"}
    inp = model.operating.torque_gear if input_member is None else input_member
    if inp not in role:
        raise ModelError(f"operating.torque_gear = {inp!r}: the torque of a planetary set acts on a central member "
                         f"({mem.sun}, {mem.ring} or carrier)")
    pl = model.planetary
    i, f = role[inp], pl.fixed_member
    if i == f:
        raise ModelError(f"operating.torque_gear = {inp!r} is the fixed member (planetary.fixed_member = '{f}', zero "
                         "speed): the input torque must act on a turning member")
    rest = next(r for r in ("sun", "ring", "carrier") if r not in (i, f))
    o = rest if getattr(pl, "output_member", None) is None else pl.output_member
    if o != rest:
        raise ModelError(f"planetary.output_member = '{o}' with the input '{i}' (operating.torque_gear = {inp!r}) "
                         f"and '{f}' fixed; allowed: '{rest}' (input, output and fixed are the three members)")
    sun_drives = i == "sun" or o == "ring"
    return PlanetaryPowerFlow(input=i, output=o, fixed=f, sun_drives=sun_drives,
                              sun_mesh_driver=mem.sun if sun_drives else mem.planet,
                              ring_mesh_driver=mem.planet if sun_drives else mem.ring)


def _check_drivers(model: Any, mem: PlanetaryMembers, flow: PlanetaryPowerFlow) -> None:
    """Refuse a mesh whose gear_a is not the member that drives it relative to the carrier (the tables' mesh
    positions advance as gear_a drives), naming the arrangement and the mesh lines that fix it."""
    for kind, driver in ((mem.sun_mesh, flow.sun_mesh_driver), (mem.ring_mesh, flow.ring_mesh_driver)):
        m = model.mesh(kind)
        if m.gear_a == driver:
            continue
        raise ModelError(
            f"mesh '{kind}': with {flow.arrangement} (operating.torque_gear = {model.operating.torque_gear!r}, "
            f"planetary.fixed_member, planetary.output_member) '{m.gear_a}' is driven, not driving, relative to the "
            f"carrier: '{driver}' drives '{m.gear_a}'.  Name the driving member gear_a: gear_a = \"{m.gear_b}\", "
            f"gear_b = \"{m.gear_a}\", flank_a = \"{m.flank_b}\", flank_b = \"{m.flank_a}\" (the same flanks carry "
            "the load; the tables' mesh positions advance as gear_a drives, so regenerate them: `hacgear statics`)")


def assembly_step_rad(z_sun: int, z_ring: int) -> float:
    """Smallest angle between planet positions that can be assembled: ``2 pi / (z_s + z_r)`` [rad]."""
    return 2 * math.pi / (z_sun + z_ring)


def planet_positions(model: Any, planet_count: int | None = None) -> tuple[float, ...]:
    """Planet angles [rad] on the carrier: the model's ``planet_positions_deg`` or equal spacing, with
    ``planet_count`` overriding the model's count (equally spaced).

    Raises
    ------
    ModelError
        A position that cannot be assembled (``(z_s + z_r) psi / 2 pi`` not an integer), with the nearest ones.
    """
    pl = model.planetary
    n = pl.planet_count if planet_count is None else int(planet_count)
    if not 1 <= n <= 12:
        raise ModelError(f"planet count [-] = {n}; allowed: integer in [1, 12]")
    if planet_count is None or n == pl.planet_count:
        pos = pl.positions_rad
    else:
        pos = tuple(2 * math.pi * i / n for i in range(n))
    mem = planetary_members(model)
    zs, zr = model.gear(mem.sun).teeth, model.gear(mem.ring).teeth
    step = assembly_step_rad(zs, zr)
    for i, a in enumerate(pos):
        k = a / step
        if abs(k - round(k)) > 1e-6:
            lo, hi = math.floor(k) * step, math.ceil(k) * step
            raise ModelError(f"planet {i + 1} at {math.degrees(a):.6g} deg cannot be assembled: (z_sun + z_ring) "
                             f"psi / 360 deg = {k:.6g} must be an integer ({zs} + {zr} teeth: positions every "
                             f"{math.degrees(step):.6g} deg; nearest {math.degrees(lo):.6g} or "
                             f"{math.degrees(hi):.6g} deg)")
    return tuple(float(a) for a in pos)


def _snap(v: float) -> float:
    """``v`` mod 1 in [0, 1), snapped to the nearest fraction with denominator <= 720 when within 1e-9 (phases of
    assemblable planets are fractions of the tooth counts: exact values survive the trigonometry)."""
    f = v - math.floor(v)
    fr = Fraction(f).limit_denominator(720)
    if abs(float(fr) - f) < 1e-9:
        f = float(fr)
    return 0.0 if f >= 1.0 else f


@dataclass(frozen=True)
class PlanetMesh:
    """One mesh instance in the carrier frame: ``kind`` (the model's mesh name, its table), ``planet`` (1-based),
    gear instances ``gear_a``/``gear_b`` (gear_a pushes gear_b along ``line_of_action`` (2,)), ``moment_arm_m``
    {gear: m_g} (``x = (u_a - u_b).n + m_a th_a - m_b th_b``), ``phase`` [cycles] (kernel convention), ``delay``
    [cycles] (Parker's gamma, relative to planet 1), ``tooth_passage`` {gear: integer position},
    ``base_radius_m`` (gear_a, gear_b), ``teeth`` (gear_a, gear_b), ``pitch_point_m`` (2,); the coast side
    (:class:`~hacgear_core.geometry.train.MeshPlacement`): ``coast_line_of_action``, ``coast_moment_arm_m``,
    ``coast_base_radius_m``, ``backlash_normal_m`` (None / inf for lumped models)."""

    name: str
    kind: str
    planet: int
    gear_a: str
    gear_b: str
    internal: bool
    line_of_action: np.ndarray
    moment_arm_m: Mapping[str, float]
    phase: float
    delay: float
    tooth_passage: Mapping[str, int]
    base_radius_m: tuple[float, float]
    teeth: tuple[int, int]
    pitch_point_m: np.ndarray
    coast_line_of_action: np.ndarray | None = None
    coast_moment_arm_m: Mapping[str, float] | None = None
    coast_base_radius_m: tuple[float, float] | None = None
    backlash_normal_m: float = math.inf


@dataclass(frozen=True)
class PlanetaryGeometry:
    """A planetary set placed in the carrier frame (module docstring).

    ``members``; ``planet_count``; ``positions_rad`` (N,); ``carrier_radius_m``; ``planets`` instance names;
    ``relative_sense`` {sun, ring, planet_i: +1 CCW / -1 CW relative to the carrier}; ``relative_ratio``
    {member: rho_j}; ``absolute_ratio`` {sun, ring, carrier, planet_i: omega_j / Omega};
    ``meshes`` {instance name: :class:`PlanetMesh`} in the order sun_planet_1, ring_planet_1, sun_planet_2, ...;
    ``sun_delays``/``ring_delays`` (N,) [cycles] and ``ring_sun_phase`` [cycles] (position of ring_planet_1 when
    sun_planet_1 is at 0); ``lumped`` (placed without tooth geometry); ``power_flow``
    (:class:`PlanetaryPowerFlow`: input, output, fixed member, the driver of each mesh)."""

    members: PlanetaryMembers
    planet_count: int
    positions_rad: tuple[float, ...]
    carrier_radius_m: float
    planets: tuple[str, ...]
    teeth: Mapping[str, int]
    relative_sense: Mapping[str, float]
    relative_ratio: Mapping[str, float]
    absolute_ratio: Mapping[str, float]
    fixed_member: str
    meshes: Mapping[str, PlanetMesh]
    sun_delays: tuple[float, ...]
    ring_delays: tuple[float, ...]
    ring_sun_phase: float
    lumped: bool
    power_flow: PlanetaryPowerFlow | None = None

    @property
    def mesh_cycles_per_relative_rad(self) -> float:
        """Mesh cycles per radian of the sun relative to the carrier: ``z_s / 2 pi``."""
        return self.teeth[self.members.sun] / (2 * math.pi)

    def sun_mesh(self, i: int) -> PlanetMesh:
        return self.meshes[f"{self.members.sun_mesh}_{i}"]

    def ring_mesh(self, i: int) -> PlanetMesh:
        return self.meshes[f"{self.members.ring_mesh}_{i}"]


def _carrier_radius(model: Any, mg_sun) -> float:
    pl = model.planetary
    if pl.carrier_radius_m is not None:
        return float(pl.carrier_radius_m)
    if mg_sun is not None:
        return float(mg_sun.center_distance_m)
    raise ModelError(f"{model.name}: a lumped planetary model needs [planetary] carrier_radius_mm")


def _kinematics(model: Any, mem: PlanetaryMembers, sense: Mapping[str, float], teeth: Mapping[str, int],
                planets: tuple[str, ...]):
    """Counter-clockwise speeds relative to the carrier (``rho``) and absolute ones, per unit speed ``Omega`` of the
    sun relative to the carrier in its relative sense of rotation (the meshes run forwards for ``Omega > 0``)."""
    zs = teeth[mem.sun]
    rho = {mem.sun: float(sense[mem.sun]), mem.ring: sense[mem.ring] * zs / teeth[mem.ring]}
    for p in planets:
        rho[p] = sense[p] * zs / teeth[p]
    rho["carrier"] = 0.0
    fixed = model.planetary.fixed_member
    rf = rho[mem.sun] if fixed == "sun" else rho[mem.ring] if fixed == "ring" else 0.0
    absolute = {k: v - rf for k, v in rho.items()}
    absolute["carrier"] = -rf
    return rho, absolute


def _expanded(model: Any, mem: PlanetaryMembers, pos: tuple[float, ...]):
    """The planetary set as a fixed-axis train of gear and mesh instances (duck-typed model for
    :func:`~.train.train_geometry`)."""
    gears = {g.name: g for g in model.gears}
    msun, mring = model.mesh(mem.sun_mesh), model.mesh(mem.ring_mesh)
    inst_gears = [gears[mem.sun], gears[mem.ring]]
    inst_meshes = []
    planets = []
    for i, psi in enumerate(pos, start=1):
        pname = f"{mem.planet}_{i}"
        planets.append(pname)
        inst_gears.append(replace(gears[mem.planet], name=pname))
        for m, kind in ((msun, mem.sun_mesh), (mring, mem.ring_mesh)):
            ga = pname if m.gear_a == mem.planet else m.gear_a
            gb = pname if m.gear_b == mem.planet else m.gear_b
            # line of centres from gear_a to gear_b: the planet lies at psi from the (common) sun/ring centre
            loc = psi if gb == pname else psi + math.pi
            loc = math.atan2(math.sin(loc), math.cos(loc))
            inst_meshes.append(replace(m, name=f"{kind}_{i}", gear_a=ga, gear_b=gb, line_of_centres_rad=loc))
    # the sun-planet mesh of planet 1 first: it defines the senses (its driver's loaded flank) and phase 0
    first = next(m for m in inst_meshes if m.name == f"{mem.sun_mesh}_1")
    inst_meshes.remove(first)
    inst_meshes.insert(0, first)
    gmap = {g.name: g for g in inst_gears}
    mmap = {m.name: m for m in inst_meshes}
    dup = SimpleNamespace(name=model.name, kind="planetary", gears=tuple(inst_gears), meshes=tuple(inst_meshes),
                          planetary=None, gear=lambda n: gmap[n], mesh=lambda n=None: mmap[n] if n else inst_meshes[0])
    return dup, tuple(planets)


def _check_planets_apart(model: Any, positions_rad: Any, carrier_radius_m: float, tip_radius_m: float) -> None:
    """:class:`GeometryError` when two neighbouring planets (centres on the carrier radius at ``positions_rad``)
    are closer than a planet tip diameter: their teeth would overlap."""
    pos = [float(a) for a in positions_rad]
    if len(pos) < 2:
        return
    n_max = int(math.pi / math.asin(min(1.0, tip_radius_m / carrier_radius_m)) + 1e-9)
    for i, (a, b) in enumerate(zip(pos, pos[1:] + [pos[0] + 2 * math.pi])):
        gap = 2 * carrier_radius_m * math.sin(0.5 * (b - a))
        if gap <= 2 * tip_radius_m:
            j = (i + 1) % len(pos) + 1
            raise GeometryError(
                f"{model.name}: planets {i + 1} and {j} at {math.degrees(a):g} and {math.degrees(b) % 360:g} deg "
                f"overlap: their centres are {gap * 1e3:.4g} mm apart on the carrier radius "
                f"{carrier_radius_m * 1e3:.6g} mm, less than the planet tip diameter {2e3 * tip_radius_m:.6g} mm; at most {n_max} equally spaced "
                "planets fit this set")


def planetary_geometry(model: Any, planet_count: int | None = None) -> PlanetaryGeometry:
    """Place the planetary set of ``model`` in the carrier frame (module docstring); ``planet_count`` overrides
    the model's count (equally spaced planets).

    Raises
    ------
    ModelError, GeometryError
        Not a planetary model, planets that cannot be assembled, inconsistent meshes.
    """
    mem = planetary_members(model)
    pos = planet_positions(model, planet_count)
    n = len(pos)
    flow = planetary_power_flow(model, members=mem)
    lumped = bool(getattr(model, "lumped", False))
    if lumped:
        return _lumped_geometry(model, mem, pos, flow)
    _check_drivers(model, mem, flow)
    gg = {g.name: gear_geometry(g) for g in model.gears}
    mg = {m.name: mesh_geometry(model, m.name, gears=gg) for m in model.meshes}
    rc = _carrier_radius(model, mg[mem.sun_mesh])
    for m in model.meshes:
        if abs(mg[m.name].center_distance_m - rc) > 1e-9:
            raise ModelError(f"mesh '{m.name}': centre distance {mg[m.name].center_distance_m * 1e3:.6g} mm differs "
                             f"from the carrier radius {rc * 1e3:.6g} mm (the planets sit on the carrier radius)")
    _check_planets_apart(model, pos, rc, gg[mem.planet].tip_radius_m)
    dup, planets = _expanded(model, mem, pos)
    inst_gg = {g.name: gg[mem.planet if g.name in planets else g.name] for g in dup.gears}
    inst_mg = {m.name: mg[m.name.rsplit("_", 1)[0]] for m in dup.meshes}
    try:
        tg = train_geometry(dup, gears=inst_gg, meshes=inst_mg)
    except GeometryError as exc:
        raise GeometryError(f"{model.name}: the planets cannot be assembled with these tooth counts and positions "
                            f"({exc})") from None
    flank_sense = {"drive": 1.0, "coast": -1.0}
    for m in dup.meshes:
        if flank_sense[m.flank_a] != tg.sense[m.gear_a]:
            kind = m.name.rsplit("_", 1)[0]
            other = "coast" if m.flank_a == "drive" else "drive"
            first = model.mesh(mem.sun_mesh)
            raise ModelError(f"mesh '{kind}': relative to the carrier '{m.gear_a.rsplit('_', 1)[0]}' turns "
                             f"{'counter-' if tg.sense[m.gear_a] > 0 else ''}clockwise (mesh '{mem.sun_mesh}': "
                             f"'{first.gear_a}' drives with its {first.flank_a} flank), so its {m.flank_a} flank "
                             f"trails and cannot drive '{m.gear_b.rsplit('_', 1)[0]}': flank_a = \"{other}\" "
                             "(with the sun driving and the ring fixed: sun -> planet, planet (coast) -> ring (drive); "
                             "the planet's two meshes load its two flanks)")
    # the first mesh's gear_a sits at the origin of the placement: move the sun there
    c0 = np.asarray(tg.centre_m[mem.sun], float)
    for g in (mem.sun, mem.ring):
        c = np.asarray(tg.centre_m[g], float) - c0
        if np.linalg.norm(c) > 1e-9:
            raise ModelError(f"{model.name}: '{g}' is placed off the central axis at {c} m from the sun (check the "
                             "meshes' gear order: the planet must be placed on the carrier radius around sun and ring)")
    teeth = {mem.sun: gg[mem.sun].z, mem.ring: gg[mem.ring].z, **{p: gg[mem.planet].z for p in planets}}
    meshes = {}
    for mn in [f"{k}_{i}" for i in range(1, n + 1) for k in (mem.sun_mesh, mem.ring_mesh)]:
        pl = tg.meshes[mn]
        kind, i = mn.rsplit("_", 1)
        meshes[mn] = dict(name=mn, kind=kind, planet=int(i), gear_a=pl.gear_a, gear_b=pl.gear_b,
                          internal=pl.internal, line_of_action=np.asarray(pl.line_of_action, float),
                          moment_arm_m=dict(pl.moment_arm_m), phase=_snap(pl.phase),
                          tooth_passage={pl.gear_a: tg.tooth_passage[pl.gear_a][mn],
                                         pl.gear_b: tg.tooth_passage[pl.gear_b][mn]},
                          base_radius_m=tuple(pl.base_radius_m), teeth=tuple(pl.teeth),
                          pitch_point_m=np.asarray(pl.pitch_point_m, float) - c0,
                          coast_line_of_action=None if pl.coast_line_of_action is None
                          else np.asarray(pl.coast_line_of_action, float),
                          coast_moment_arm_m=None if pl.coast_moment_arm_m is None else dict(pl.coast_moment_arm_m),
                          coast_base_radius_m=tuple(inst_mg[mn].base_radius_coast_m[mem.planet if g in planets else g]
                                                    for g in (pl.gear_a, pl.gear_b)),
                          backlash_normal_m=float(pl.backlash_normal_m))
    return _finish(model, mem, pos, rc, planets, teeth, dict(tg.sense), meshes, lumped=False, flow=flow)


def _finish(model, mem, pos, rc, planets, teeth, sense, meshes, *, lumped, flow):
    n = len(pos)
    for kind in (mem.sun_mesh, mem.ring_mesh):
        p1 = meshes[f"{kind}_1"]["phase"]
        for i in range(1, n + 1):
            d = meshes[f"{kind}_{i}"]
            d["delay"] = _snap(p1 - d["phase"])
    rho, absolute = _kinematics(model, mem, sense, teeth, planets)
    return PlanetaryGeometry(
        members=mem, planet_count=n, positions_rad=pos, carrier_radius_m=rc, planets=planets, teeth=teeth,
        relative_sense={k: float(v) for k, v in sense.items()}, relative_ratio=rho, absolute_ratio=absolute,
        fixed_member=model.planetary.fixed_member, meshes={k: PlanetMesh(**v) for k, v in meshes.items()},
        sun_delays=tuple(meshes[f"{mem.sun_mesh}_{i}"]["delay"] for i in range(1, n + 1)),
        ring_delays=tuple(meshes[f"{mem.ring_mesh}_{i}"]["delay"] for i in range(1, n + 1)),
        ring_sun_phase=meshes[f"{mem.ring_mesh}_1"]["phase"], lumped=lumped, power_flow=flow)


def _lumped_geometry(model: Any, mem: PlanetaryMembers, pos: tuple[float, ...],
                     flow: PlanetaryPowerFlow) -> PlanetaryGeometry:
    """Analytic placement of a lumped model (module docstring).  The driver of the sun mesh turns counter-clockwise
    relative to the carrier: with the sun driving the planets (``flow.sun_drives``) the sun turns counter-clockwise,
    the planets and the ring clockwise; with the ring driving the planets and the planets the sun, the mirror image
    (the sun clockwise, the planets and the ring counter-clockwise: what a tooth model whose gear_a drive flanks
    are loaded gives).  Either gear order of a mesh is accepted (no flanks to name)."""
    rc = _carrier_radius(model, None)
    g = {x.name: x for x in model.gears}
    zs, zp, zr = g[mem.sun].teeth, g[mem.planet].teeth, g[mem.ring].teeth
    planets = tuple(f"{mem.planet}_{i}" for i in range(1, len(pos) + 1))
    s = 1.0 if flow.sun_drives else -1.0          # the sun's sense relative to the carrier
    sense = {mem.sun: s, mem.ring: -s, **{p: -s for p in planets}}
    teeth = {mem.sun: zs, mem.ring: zr, **{p: zp for p in planets}}
    msun, mring = model.mesh(mem.sun_mesh), model.mesh(mem.ring_mesh)
    rbs, rbp, rbr = g[mem.sun].base_radius_m, g[mem.planet].base_radius_m, g[mem.ring].base_radius_m
    meshes = {}
    for i, psi in enumerate(pos, start=1):
        pname = planets[i - 1]
        e = np.array([math.cos(psi), math.sin(psi)])
        perp = np.array([-e[1], e[0]])
        for m, mesh_name in ((msun, mem.sun_mesh), (mring, mem.ring_mesh)):
            a = float(m.pressure_angle_rad)
            ring_mesh = mesh_name == mem.ring_mesh
            if not ring_mesh:
                # the driver's material at the pitch point moves along s perp (both gears roll there); the driven
                # gear is pushed away from the driver: the planet along +e (sun driving), the sun along -e
                drv, drn = (mem.sun, pname) if flow.sun_drives else (pname, mem.sun)
                nvec = s * (math.cos(a) * perp + math.sin(a) * e)
                arms_of = {mem.sun: s * rbs, pname: -s * rbp}
                pp = rc * e * rbs / (rbs + rbp)
            else:
                # the planet pushes the ring outwards at the planet's outer side (velocity -perp), or the ring
                # (velocity +perp) pushes the planet inwards
                drv, drn = (pname, mem.ring) if flow.sun_drives else (mem.ring, pname)
                nvec = s * (-math.cos(a) * perp + math.sin(a) * e)
                arms_of = {pname: -s * rbp, mem.ring: -s * rbr}
                pp = rc * e * rbr / (rbr - rbp)
            ga = pname if m.gear_a == mem.planet else m.gear_a
            gb = pname if m.gear_b == mem.planet else m.gear_b
            arms = {drv: arms_of[drv], drn: arms_of[drn]}
            if ga != drv:  # the model names the driven member first: gear_a pushes gear_b along -n
                nvec = -nvec
                arms = {k: -v for k, v in arms.items()}
            if not ring_mesh:
                ph = _snap(-s * zs * psi / (2 * math.pi))
            else:
                ph = _snap(s * zr * psi / (2 * math.pi))
            meshes[f"{mesh_name}_{i}"] = dict(
                name=f"{mesh_name}_{i}", kind=mesh_name, planet=i, gear_a=ga, gear_b=gb, internal=ring_mesh,
                line_of_action=nvec, moment_arm_m=arms, phase=ph, tooth_passage={ga: 0, gb: 0},
                base_radius_m=(g[ga if ga in g else mem.planet].base_radius_m,
                               g[gb if gb in g else mem.planet].base_radius_m),
                teeth=(teeth[ga], teeth[gb]), pitch_point_m=pp)
    return _finish(model, mem, pos, rc, planets, teeth, sense, meshes, lumped=True, flow=flow)


def planetary_torques(model: Any, geometry: PlanetaryGeometry, torque_Nm: float | None = None,
                      input_member: str | None = None) -> dict:
    """Nominal torques and mesh forces of the constant-speed experiment (equal load sharing).

    Returns ``{"torque_ccw_Nm": {sun, ring, carrier: T_j counter-clockwise}, "force_N": {mesh instance: F},
    "flanks": "drive" | "coast", "input": member, "power_flow": PlanetaryPowerFlow}``; ``torque_Nm`` [N m] (default
    ``[operating] torque_Nm``) acts on ``input_member`` (default ``[operating] torque_gear``) in that member's
    sense of rotation: the power enters there.  A positive torque presses the flanks the model loads
    (``flank_a``/``flank_b``, "drive"), a negative one the opposite flanks ("coast"); ``F`` is the magnitude of the
    force on the pressed flanks at the drive flanks' base radii (the builder converts it to the coast base radii,
    as the spur and idler builders do).

    The sun's torque balance gives the sun-mesh force per planet, ``F_s = T_s / (N c_s)`` with ``c_s`` the sun's
    signed moment arm in the mesh deflection (``+m_sun`` as gear_a, ``-m_sun`` as gear_b: ``|c_s| = r_b,s``); each
    planet's balance the ring-mesh force ``F_r = F_s r_b,p(sun mesh) / r_b,p(ring mesh)``.

    Raises
    ------
    ModelError
        The input member is the fixed one, the torque is 0, or a positive torque would press the flanks the model
        does not load (the meshes' gear order does not follow the power flow of ``input_member``).
    """
    mem = geometry.members
    T = model.operating.torque_Nm if torque_Nm is None else float(torque_Nm)
    flow = planetary_power_flow(model, input_member, members=mem)
    inp = model.operating.torque_gear if input_member is None else input_member
    w_in = geometry.absolute_ratio[inp]
    if abs(w_in) < 1e-12:
        raise ModelError(f"operating.torque_gear = {inp!r} is the fixed member (zero speed): the input torque must "
                         "act on a turning member")
    zs, zr = geometry.teeth[mem.sun], geometry.teeth[mem.ring]
    ratio = {mem.sun: 1.0, mem.ring: zr / zs, "carrier": -(1.0 + zr / zs)}
    t_in_ccw = math.copysign(1.0, w_in) * T
    scale = t_in_ccw / ratio[inp]
    torque = {k: v * scale for k, v in ratio.items()}
    n = geometry.planet_count
    sm, rm = geometry.sun_mesh(1), geometry.ring_mesh(1)
    rbps = sm.base_radius_m[1 if sm.gear_a == mem.sun else 0]
    rbpr = rm.base_radius_m[0 if rm.gear_a != mem.ring else 1]
    if not (math.isfinite(T) and T != 0.0):
        raise ModelError(f"torque [N*m] = {T!r} on '{inp}'; allowed: finite and not 0 (negative loads the coast "
                         "flanks)")
    # the sun's signed arm in the sun mesh's deflection x = ... + m_a th_a - m_b th_b; the mesh force F (> 0 on the
    # flanks the model loads) puts -F c_s on the sun's rotation, which the sun's external torque balances
    # (|c_s| is the sun's base radius r_b,s: the arm's sign times r_b,s keeps the force exact)
    c_sign = math.copysign(1.0, sm.moment_arm_m[mem.sun]) * (1.0 if sm.gear_a == mem.sun else -1.0)
    rbs = sm.base_radius_m[0 if sm.gear_a == mem.sun else 1]
    fs = c_sign * torque[mem.sun] / (n * rbs)
    if fs * T <= 0:
        m = model.mesh(mem.sun_mesh)
        raise ModelError(f"with {flow.arrangement} (torque on '{inp}'), a positive torque loads the flanks the model "
                         f"does not load: '{flow.sun_mesh_driver}' drives mesh '{mem.sun_mesh}' relative to the "
                         f"carrier, the model names '{m.gear_a}' (gear_a); swap the meshes' gear order together "
                         "with their loaded flanks (flank_a/flank_b) and regenerate the tables, or apply the "
                         "torque with the opposite sign (the coast flanks)")
    fs = abs(fs)
    fr = fs * rbps / rbpr
    forces = {}
    for i in range(1, n + 1):
        forces[geometry.sun_mesh(i).name] = fs
        forces[geometry.ring_mesh(i).name] = fr
    return {"torque_ccw_Nm": torque, "force_N": forces, "flanks": "drive" if T > 0 else "coast", "input": inp,
            "power_flow": flow}
