"""Gearboxes of planetary and parallel stages (``kind = "gearbox"``): stages in series joined by shafts.

A *stage* is a planetary set (a ``[[gearbox.planetary]]`` entry naming its sun and its carrier, with the keys of
a planetary model's ``[planetary]`` table) or a group of meshed gears on fixed axes (a spur or helical pair, an
idler chain: every group of meshed gears no planetary entry claims).  A *shaft* (``[[gearbox.shafts]]``) joins the
output member of one stage to the input member of the next with its torsional stiffness; the stages form one
chain from ``[operating] torque_gear`` (the input member of the first stage) to ``[gearbox] output_member`` (of
the last).  Every gear and mesh of every stage is in the model's ``[[gears]]`` and ``[[meshes]]``; their tables
come from ``hacgear statics`` of the gearbox as of any model.

Model section::

    [gearbox]
    output_member = "pinion3"                  # the member the power leaves by (default: the last stage's only one)

    [[gearbox.planetary]]
    name = "stage1"
    sun = "sun1"                               # the stage's sun gear (its planet and ring: the gears it meshes with)
    carrier = "carrier1"                       # the carrier's name (a member like a gear)
    planet_count = 3                           # ... and the other keys of [planetary]
    fixed_member = "ring"                      # role: ring | sun | carrier
      [gearbox.planetary.carrier_support]
      translational_stiffness_N_per_m = 2.8e9

    [[gearbox.shafts]]
    name = "lss"
    member_a = "sun1"                          # upstream member
    member_b = "carrier2"                      # downstream member
    torsional_stiffness_Nm_per_rad = 1.4e9     # (0, 1e12]
    bending_stiffness_N_per_m = 0.0            # [0, 1e15]; 0: the members' own bearings only (default)

Dynamics: each stage is built by its kind's builder (:func:`~hacgear_core.kinds.planetary.planetary_from_model`,
:func:`~hacgear_core.kinds.fixed_axis.train_from_model`, :func:`~hacgear_core.kinds.helical_pair.helical_from_model`)
at the static torque the chain brings to it, and the trains are joined:

* **a rotating frame per planetary stage.**  A planetary stage's coordinates live in its carrier's frame, turning
  at ``W_s = c_s omega_ref`` (``omega_ref`` the input member's speed, ``c_s`` the stage's carrier speed over it,
  exact from the tooth counts).  The one equation of motion keeps the form ``M q'' + (C + W G) q' + (K - W^2 K_W) q
  = ...`` with ``W = omega_ref`` and the stages' own matrices summed, ``G = sum_s c_s G_s`` and ``K_W = sum_s c_s^2
  K_W,s`` (each stage's gyroscopic and centripetal terms at its own carrier speed); each body reports its bearing
  force turned by its own stage's frame (``frame_ratio = c_s``; parallel stages: the fixed frame).
* **each mesh at its own rate.**  Every mesh's frequency over the reference mesh's (the first stage's first mesh)
  is a reduced fraction of the tooth counts (:func:`mesh_rates`); the system repeats after the lcm of their
  denominators in reference mesh cycles (``period_cycles``), which for a wind-turbine gearbox is tens of input
  revolutions: steady-state analyses then run over a stated number of revolutions of the slowest shaft.
* **shafts** act between the rotations of the members they join, each measured in its direction of motion (the
  stages' frames are independent: a stage may be built mirrored to the next).  A shaft's optional
  ``bending_stiffness_N_per_m`` acts between the in-plane displacements of its members' centres in the fixed frame
  (x, y of the model file: parallel stages are placed by their meshes' ``line_of_centres_deg``, a planetary stage's
  planets at their angles from x, its frame turning with its carrier from the assembly position); a spur gear with
  one mesh then gets x and y instead of its line-of-action translation.  Between members whose translations live in
  one frame it is a constant spring; between a member of a planetary stage whose carrier turns and a member in
  another frame it is a frame coupling (:class:`~hacgear_core.kinds.base.FrameSpring`), its stiffness periodic in
  the frames' relative angle at the exact rate of the tooth counts.  A helical gear's x and y live in its pair's own
  frame: they are turned into the fixed frame by the angle that takes the pair's line of centres onto the placed
  one (:func:`~hacgear_core.kinds.gear_train.pair_frame_turn`).  Stages built turning opposite ways on one shaft
  (mirror images) are refused: their x and y are not one frame's.

Constant-speed experiment (``shafts=True``): the torque acts on the input member, the output member follows the
kinematics (its rotation held to the reference motion, as a generator on the grid and as the planetary stage
models hold their output), every turning member in between is free on its shafts.  (With both ends free the
linearised centrifugal terms of the carrier frames, exact only to ``O(m_p W^2 / k_p)``, would push the free
rotation by a constant torque.)  Drivetrain coupling (``shafts=False``): input and output members are free torque
ports; the fixed members keep their supports.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any, Mapping

from hacgear_core.errors import GeometryError, ModelError
from hacgear_core.geometry import nominal_mesh_forces as fixed_axis_forces
from hacgear_core.geometry import train_geometry
from hacgear_core.geometry.planetary import planetary_geometry, planetary_members, planetary_torques
from hacgear_core.geometry.train import TrainGeometry
from hacgear_core.kinds.base import ExtraOutput, FrameSpring, Kind, Spring, Train, shaft_torque_output
from hacgear_core.kinds.fixed_axis import train_from_model
from hacgear_core.kinds.gear_train import _in_plane, _mesh_groups, centre_row as _centre_row, pair_frame_turn
from hacgear_core.kinds.helical_pair import helical_from_model
from hacgear_core.kinds.planetary import planetary_error_inputs, planetary_from_model
from hacgear_core.model.schema import Planetary, Support
from hacgear_core.model.toml import read_planetary

__all__ = ["GearboxKind", "GearboxSection", "PlanetaryStage", "GearboxShaft", "Stage", "gearbox_stages",
           "mesh_rates", "planetary_stage_error_inputs"]

_STAGE_KEYS = ("name", "sun", "carrier")
_SHAFT_KEYS = ("name", "member_a", "member_b", "torsional_stiffness_Nm_per_rad", "bending_stiffness_N_per_m")


@dataclass(frozen=True)
class PlanetaryStage:
    """A ``[[gearbox.planetary]]`` entry: the stage ``name``, its ``sun`` gear, its ``carrier``'s name and its
    :class:`~hacgear_core.model.schema.Planetary` options (``fixed_member`` a role: ring, sun or carrier)."""

    name: str
    sun: str
    carrier: str
    planetary: Planetary


@dataclass(frozen=True)
class GearboxShaft:
    """A shaft from member ``member_a`` of one stage to ``member_b`` of the next (SI): torsional stiffness
    [N m/rad] between their rotations, bending stiffness [N/m] between their centres' in-plane translations (0:
    none; members whose translations live in the fixed frame only, :meth:`GearboxKind.check`)."""

    name: str
    member_a: str
    member_b: str
    torsional_stiffness_Nm_per_rad: float
    bending_stiffness_N_per_m: float = 0.0

    def __post_init__(self) -> None:
        where = f"gearbox.shafts '{self.name}'"
        if self.member_a == self.member_b:
            raise ModelError(f"{where}: member_a and member_b must differ, both are {self.member_a!r}")
        k = float(self.torsional_stiffness_Nm_per_rad)
        if not (0.0 < k <= 1e12):
            raise ModelError(f"{where}: torsional_stiffness_Nm_per_rad [N*m/rad] must be in (0, 1e12], got {k!r}")
        kb = float(self.bending_stiffness_N_per_m)
        if not (0.0 <= kb <= 1e15):
            raise ModelError(f"{where}: bending_stiffness_N_per_m [N/m] must be in [0, 1e15], got {kb!r}")
        object.__setattr__(self, "torsional_stiffness_Nm_per_rad", k)
        object.__setattr__(self, "bending_stiffness_N_per_m", kb)


@dataclass(frozen=True)
class GearboxSection:
    """The ``[gearbox]`` section: planetary stages, shafts and the output member (None: the last stage's only
    candidate)."""

    planetary: tuple[PlanetaryStage, ...] = ()
    shafts: tuple[GearboxShaft, ...] = ()
    output_member: str | None = None


@dataclass(frozen=True)
class Stage:
    """One stage along the chain: ``name``, ``planetary`` (its entry, None for a fixed-axis group), ``gears`` and
    ``meshes`` (names, model order), ``input`` / ``output`` members, ``speed_in`` / ``speed_out`` (revolutions per
    revolution of the gearbox's input member, exact), ``mesh_frequency`` (mesh cycles per revolution of the input
    member, exact; every mesh of a stage runs at it), ``torque_in`` (static input torque per N m on the gearbox's
    input member)."""

    name: str
    planetary: PlanetaryStage | None
    gears: tuple[str, ...]
    meshes: tuple[str, ...]
    input: str
    output: str
    speed_in: Fraction
    speed_out: Fraction
    mesh_frequency: Fraction
    torque_in: float

    @property
    def members(self) -> tuple[str, ...]:
        return self.gears + ((self.planetary.carrier,) if self.planetary else ())


def _section_of(model: Any) -> GearboxSection:
    sec = getattr(model, "section", None)
    return sec if isinstance(sec, GearboxSection) else GearboxSection()


def _planetary_speeds(model: Any, st: PlanetaryStage, gears: tuple[str, ...], meshes: tuple[str, ...],
                      input_member: str, speed_in: Fraction) -> tuple[dict[str, Fraction], Fraction]:
    """Signed speeds {sun, ring, carrier name: Fraction} of a planetary stage with its input member at
    ``speed_in`` and its fixed member at rest (Willis: z_s w_s + z_r w_r = (z_s + z_r) w_c), and its mesh
    frequency z_r |w_r - w_c| (per revolution of the gearbox's input)."""
    sub = _planetary_model(model, st, gears, meshes, input_member)
    mem = planetary_members(sub)
    zs, zr = sub.gear(mem.sun).teeth, sub.gear(mem.ring).teeth
    role = {mem.sun: "sun", mem.ring: "ring", st.carrier: "carrier"}[input_member]
    fixed = st.planetary.fixed_member
    w = {fixed: Fraction(0), role: speed_in}
    if "carrier" not in w:     # ring or sun fixed, the other one in
        w["carrier"] = (zs * w.get("sun", 0) + zr * w.get("ring", 0)) / (zs + zr)
    if "sun" not in w:
        w["sun"] = ((zs + zr) * w["carrier"] - zr * w["ring"]) / zs
    if "ring" not in w:
        w["ring"] = ((zs + zr) * w["carrier"] - zs * w["sun"]) / zr
    return {mem.sun: w["sun"], mem.ring: w["ring"], st.carrier: w["carrier"]}, abs(zr * (w["ring"] - w["carrier"]))


def gearbox_stages(model: Any) -> tuple[Stage, ...]:
    """The stages of a gearbox ``model`` along the chain from its input member, with their exact kinematics and
    static torques (module docstring); raises ModelError naming the key for a gearbox that is not one chain."""
    sec = _section_of(model)
    gears = {g.name: g for g in model.gears}
    groups = _mesh_groups(model)
    group_of = {g: k for k, grp in enumerate(groups) for m in grp for g in (m.gear_a, m.gear_b)}
    planetary_of: dict[int, PlanetaryStage] = {}
    for st in sec.planetary:
        if st.sun not in gears:
            raise ModelError(f"gearbox.planetary '{st.name}'.sun = {st.sun!r} names no gear; allowed: {list(gears)}")
        if st.carrier in gears:
            raise ModelError(f"gearbox.planetary '{st.name}'.carrier = {st.carrier!r} is a gear's name; a carrier "
                             "needs a name of its own")
        k = group_of[st.sun]
        if k in planetary_of:
            raise ModelError(f"gearbox.planetary '{st.name}' and '{planetary_of[k].name}' name the same set")
        planetary_of[k] = st
    carriers = [st.carrier for st in sec.planetary]
    if len(set(carriers)) != len(carriers):
        raise ModelError(f"gearbox.planetary: carrier names repeat: {carriers}")
    member_stage = {g: group_of[g] for g in gears}
    member_stage.update({st.carrier: group_of[st.sun] for st in sec.planetary})
    for sh in sec.shafts:
        for attr in ("member_a", "member_b"):
            if getattr(sh, attr) not in member_stage:
                raise ModelError(f"gearbox.shafts '{sh.name}'.{attr} = {getattr(sh, attr)!r} names no member; "
                                 f"allowed: {sorted(member_stage)}")
        if member_stage[sh.member_a] == member_stage[sh.member_b]:
            raise ModelError(f"gearbox.shafts '{sh.name}' joins two members of one stage ({sh.member_a!r}, "
                             f"{sh.member_b!r}); a shaft joins consecutive stages")
    inp = model.operating.torque_gear
    if inp not in member_stage:
        raise ModelError(f"operating.torque_gear = {inp!r} names no member; allowed: {sorted(member_stage)}")
    out_member = sec.output_member
    if out_member is not None and out_member not in member_stage:
        raise ModelError(f"gearbox.output_member = {out_member!r} names no member; allowed: {sorted(member_stage)}")
    stages: list[Stage] = []
    k, member, speed, torque, used = member_stage[inp], inp, Fraction(1), 1.0, set()
    visited = {k}
    while True:
        grp = groups[k]
        g_names = tuple(g for g in gears if group_of[g] == k)
        m_names = tuple(m.name for m in grp)
        st = planetary_of.get(k)
        if st is not None:
            sp, fm = _planetary_speeds(model, st, g_names, m_names, member, speed)
            if sp[member] == 0:
                raise ModelError(f"gearbox.planetary '{st.name}': the input member {member!r} is its fixed member "
                                 f"(fixed_member = '{st.planetary.fixed_member}')")
        else:
            if member not in gears:
                raise ModelError(f"member {member!r} drives no gear")
            sp = {g: speed * gears[member].teeth / gears[g].teeth for g in g_names}
            fm = speed * gears[member].teeth
        nxt = [sh for sh in sec.shafts if sh.name not in used and member_stage[sh.member_a] == k
               and sh.member_a != member]
        back = [sh for sh in sec.shafts if sh.name not in used and member_stage[sh.member_b] == k
                and sh.member_b != member]
        if back:
            raise ModelError(f"gearbox.shafts '{back[0].name}': member_b = {back[0].member_b!r} leads into a stage "
                             "already driven (the stages form one chain in series, member_a upstream)")
        if len(nxt) > 1:
            raise ModelError(f"gearbox.shafts {[sh.name for sh in nxt]} all leave one stage: the stages form one "
                             "chain in series")
        name = st.name if st else "+".join(m_names)
        if nxt:
            out = nxt[0].member_a
        elif out_member is not None:
            if member_stage[out_member] != k:
                raise ModelError(f"gearbox.output_member = {out_member!r} is not a member of the last stage "
                                 f"({name}: {sorted(sp)})")
            out = out_member
        else:
            cand = [g for g in sp if g != member and sp[g] != 0]
            if len(cand) != 1:
                raise ModelError(f"gearbox.output_member: the last stage ({name}) has members {sorted(sp)}; name "
                                 "the one the power leaves by")
            out = cand[0]
        if out == member:
            raise ModelError(f"stage {name}: the output member {out!r} is its input member")
        if sp[out] == 0:
            raise ModelError(f"stage {name}: the output member {out!r} is fixed (speed 0)")
        speed_out = abs(sp[out])
        stages.append(Stage(name=name, planetary=st, gears=g_names, meshes=m_names, input=member, output=out,
                            speed_in=abs(speed), speed_out=speed_out, mesh_frequency=fm, torque_in=torque))
        torque = torque * float(abs(speed) / speed_out)
        if not nxt:
            break
        used.add(nxt[0].name)
        k, member, speed = member_stage[nxt[0].member_b], nxt[0].member_b, speed_out
        if k in visited:
            raise ModelError(f"gearbox.shafts '{nxt[0].name}' closes a loop of stages")
        visited.add(k)
    covered = {m for s in stages for m in s.meshes}
    missing = [m.name for m in model.meshes if m.name not in covered]
    if missing:
        raise ModelError(f"meshes {missing} are not in the chain of stages from operating.torque_gear = {inp!r} "
                         "(join their stage by [[gearbox.shafts]])")
    unused = [sh.name for sh in sec.shafts if sh.name not in used]
    if unused:
        raise ModelError(f"gearbox.shafts {unused} are not on the chain from operating.torque_gear = {inp!r}")
    return tuple(stages)


def mesh_rates(model: Any, stages: tuple[Stage, ...] | None = None) -> dict[str, tuple[int, int]]:
    """Each model mesh's frequency over the reference mesh's (the first stage's meshes), a reduced fraction
    ``(p, q)`` of the tooth counts."""
    stages = gearbox_stages(model) if stages is None else stages
    ref = stages[0].mesh_frequency
    return {m: ((s.mesh_frequency / ref).numerator, (s.mesh_frequency / ref).denominator)
            for s in stages for m in s.meshes}


def _planetary_model(model: Any, st: PlanetaryStage, gears: tuple[str, ...], meshes: tuple[str, ...],
                     input_member: str, held: str | None = None) -> Any:
    """The planetary model of stage ``st``: its gears and meshes, its carrier called ``carrier``, its turning
    members free on their shafts (rotational support 0) but ``held`` (inf: its rotation follows the kinematics),
    its fixed member as given."""
    sub = replace(model, kind="planetary", gears=tuple(g for g in model.gears if g.name in gears),
                  meshes=tuple(m for m in model.meshes if m.name in meshes), section=None,
                  planetary=replace(st.planetary, output_member=None), sections={},
                  operating=replace(model.operating, torque_gear="carrier" if input_member == st.carrier
                                    else input_member))
    mem = planetary_members(sub)
    fixed = st.planetary.fixed_member
    cs = st.planetary.carrier_support
    carrier_support = cs if fixed == "carrier" else Support(cs.translational_stiffness_N_per_m,
                                                            math.inf if held == st.carrier else 0.0)
    return replace(sub, planetary=replace(sub.planetary, carrier_support=carrier_support), gears=tuple(
        g if {mem.sun: "sun", mem.ring: "ring"}.get(g.name) in (None, fixed) else replace(
            g, support=replace(g.support, rotational_stiffness_Nm_per_rad=math.inf if g.name == held else 0.0))
        for g in sub.gears))


def planetary_stage_error_inputs(model: Any) -> dict:
    """What :func:`~hacgear_core.dynamics.gear_errors.with_gear_errors` needs for the manufacturing errors of the
    gears of a gearbox's planetary stages: each stage's :func:`~hacgear_core.kinds.planetary.planetary_error_inputs`
    on the stage model its train is built from (the same gear and mesh instances, tooth passages and carrier frame),
    merged: ``{"gears", "pressure_angles_rad", "coast_pressure_angles_rad", "internal_gears", "runout_passage"}``."""
    out: dict = {"gears": {}, "pressure_angles_rad": {}, "coast_pressure_angles_rad": {}, "internal_gears": (),
                 "runout_passage": {}}
    for s in gearbox_stages(model):
        if s.planetary is None:
            continue
        sub = _planetary_model(model, s.planetary, s.gears, s.meshes, s.input)
        inp = planetary_error_inputs(sub, s.planetary.planetary.planet_count)
        out["gears"].update(inp["gears"])
        out["pressure_angles_rad"].update(inp["pressure_angles_rad"])
        out["coast_pressure_angles_rad"].update(inp["coast_pressure_angles_rad"])
        out["internal_gears"] += tuple(inp["internal_gears"])
        out["runout_passage"].update(inp["runout_passage"])
    return out


def _fixed_axis_model(model: Any, stage: Stage, held: str | None = None) -> Any:
    """The fixed-axis model of ``stage``: its gears (the ``held`` one's rotation following the kinematics) and
    meshes, its input gear carrying the torque."""
    sub_gears = tuple(replace(g, support=replace(g.support, rotational_stiffness_Nm_per_rad=math.inf))
                      if g.name == held else g for g in model.gears if g.name in stage.gears)
    helical = any(g.is_helical for g in sub_gears)
    kind = "helical_pair" if helical else ("spur_pair" if len(stage.meshes) == 1 else "idler_chain")
    return replace(model, kind=kind, gears=sub_gears, meshes=tuple(m for m in model.meshes if m.name in stage.meshes),
                   section=None, sections={}, operating=replace(model.operating, torque_gear=stage.input))


def _stage_pair_turn(model: Any, stage: Stage, coupling: Any) -> float:
    """:func:`~hacgear_core.kinds.gear_train.pair_frame_turn` of a helical stage placed on its own."""
    return pair_frame_turn(train_geometry(_fixed_axis_model(model, stage)), coupling, model.name)


def _renamed(train: Train, names: Mapping[str, str]) -> Train:
    """``train`` with its bodies renamed by ``names`` (every key that names one)."""
    def key(k):
        return (names.get(k[0], k[0]), k[1])

    def kv(v):
        return None if v is None else tuple((key(k), c) for k, c in v)
    bodies = tuple(replace(b, name=names.get(b.name, b.name)) for b in train.bodies)
    couplings = tuple(replace(c, gear_a=names.get(c.gear_a, c.gear_a), gear_b=names.get(c.gear_b, c.gear_b),
                              v=kv(c.v), w=kv(c.w), v_rot=kv(c.v_rot), v_c=kv(c.v_c), t=kv(c.t), t_c=kv(c.t_c),
                              tooth_passage={names.get(g, g): p for g, p in c.tooth_passage.items()},
                              gear_alias={names.get(g, g): names.get(a, a) for g, a in c.gear_alias.items()})
                      for c in train.couplings)
    springs = tuple(replace(s, rows=tuple(kv(r) for r in s.rows), reports=names.get(s.reports, s.reports))
                    for s in train.springs)
    return replace(train, bodies=bodies, couplings=couplings, springs=springs,
                   gyroscopic=tuple((key(a), key(b), v) for a, b, v in train.gyroscopic),
                   centripetal=tuple((key(a), key(b), v) for a, b, v in train.centripetal),
                   rigid_mode=kv(train.rigid_mode), input_gear=names.get(train.input_gear, train.input_gear),
                   reference_gear=names.get(train.reference_gear, train.reference_gear),
                   nominal_torques_per_Nm=None if train.nominal_torques_per_Nm is None else {
                       names.get(g, g): t for g, t in train.nominal_torques_per_Nm.items()},
                   support_reports=tuple(names.get(b, b) for b in train.support_reports),
                   bearing_reports=tuple(names.get(b, b) for b in train.bearing_reports))


class GearboxKind(Kind):
    """``kind = "gearbox"``: planetary and parallel stages in series joined by shafts (module docstring)."""

    name = "gearbox"
    section = "gearbox"
    helical = None
    rotating_carrier = True

    def parse_section(self, reader: Any) -> GearboxSection:
        if reader is None:
            return GearboxSection()
        stages = []
        for psec in reader.array_of_tables("planetary", required=False):
            name, sun, carrier = psec.string("name"), psec.string("sun"), psec.string("carrier")
            stages.append(PlanetaryStage(name, sun, carrier, read_planetary(psec, _STAGE_KEYS)))
        shafts = []
        for ssec in reader.array_of_tables("shafts", required=False):
            values = dict(name=ssec.string("name"), member_a=ssec.string("member_a"),
                          member_b=ssec.string("member_b"),
                          torsional_stiffness_Nm_per_rad=ssec.number("torsional_stiffness_Nm_per_rad", "N*m/rad",
                                                                     0.0, 1e12, lo_open=True),
                          bending_stiffness_N_per_m=ssec.number("bending_stiffness_N_per_m", "N/m", 0.0, 1e15,
                                                                required=False, default=0.0))
            ssec.done(_SHAFT_KEYS)
            try:
                shafts.append(GearboxShaft(**values))
            except ModelError as exc:
                raise ModelError(f"{reader.file}: [{ssec.path}] {exc}") from None
        out = reader.string("output_member", required=False, default=None)
        reader.done(("planetary", "shafts", "output_member"))
        for what, names in (("planetary.name", [s.name for s in stages]), ("shafts.name", [s.name for s in shafts])):
            if len(set(names)) != len(names):
                raise reader.error(f"{reader.path}.{what}", "", "unique names", names, problem="names repeat")
        return GearboxSection(tuple(stages), tuple(shafts), out)

    def members(self, model: Any) -> tuple[str, ...]:
        return tuple(g.name for g in model.gears) + tuple(st.carrier for st in _section_of(model).planetary)

    def bearing_stiffness(self, model: Any, member: str) -> float:
        for st in _section_of(model).planetary:
            if st.carrier == member:
                return float(st.planetary.carrier_support.translational_stiffness_N_per_m)
        return super().bearing_stiffness(model, member)

    def with_bearing_stiffness(self, model: Any, stiffness: Mapping[str, float]) -> Any:
        model = super().with_bearing_stiffness(model, stiffness)
        sec = _section_of(model)
        stages = tuple(st if st.carrier not in stiffness else replace(st, planetary=replace(
            st.planetary, carrier_support=replace(st.planetary.carrier_support,
                                                  translational_stiffness_N_per_m=float(stiffness[st.carrier]))))
            for st in sec.planetary)
        return replace(model, section=replace(sec, planetary=stages))

    def check(self, model: Any) -> None:
        super().check(model)
        fixed = set()
        stages = gearbox_stages(model)
        for s in stages:
            if s.planetary is None:
                if any(model.gear(g).is_helical for g in s.gears) and len(s.meshes) != 1:
                    raise ModelError(f"stage {s.name}: a helical stage of a gearbox is one pair (one mesh), got "
                                     f"meshes {list(s.meshes)}")
                continue
            sub = _planetary_model(model, s.planetary, s.gears, s.meshes, s.input)
            mem = planetary_members(sub)
            fixed.add({"sun": mem.sun, "ring": mem.ring, "carrier": s.planetary.carrier}[s.planetary.planetary.fixed_member])
            kr = s.planetary.planetary.carrier_support.rotational_stiffness_Nm_per_rad
            if s.planetary.carrier not in fixed and kr not in (0.0, math.inf):
                raise ModelError(f"gearbox.planetary '{s.planetary.name}'.carrier_support.rotational_stiffness_Nm_per_rad "
                                 f"[N*m/rad] = {kr:g}: a turning carrier's rotation belongs to the gearbox's shafts "
                                 "(allowed: 0, or leave it out)")
            planetary_geometry(sub)
        turning = [g.name for g in model.gears
                   if g.name not in fixed and g.support.rotational_stiffness_Nm_per_rad != 0]
        if turning:
            raise ModelError(f"gears {turning}: support.rotational_stiffness_Nm_per_rad [N*m/rad] must be 0 for a "
                             "turning member of a gearbox (its shafts join the stages; its input and output members "
                             "are the drivetrain's: FMU mode 1)")

    def placement(self, model: Any, gears: Mapping, meshes: Mapping) -> TrainGeometry:
        """No placement of the whole: each stage is placed in its own frame when its train is built (a planetary
        stage by :func:`~hacgear_core.geometry.planetary.planetary_geometry`, a parallel one by
        :func:`~hacgear_core.geometry.train_geometry`); raises GeometryError (``hacgear info`` then shows no mesh
        phases)."""
        raise GeometryError(f"{model.name}: a gearbox's stages are placed each in its own frame (no single placement)")

    def nominal_mesh_forces(self, model: Any, base_radii: Mapping[str, tuple[float, float]]) -> dict[str, float]:
        """Per contact: a planetary stage's force per planet, a fixed-axis stage's mesh force, at the static
        torque the chain brings to the stage."""
        out = {}
        t = abs(model.operating.torque_Nm)
        for s in gearbox_stages(model):
            if s.planetary is not None:
                sub = _planetary_model(model, s.planetary, s.gears, s.meshes, s.input)
                flow = planetary_torques(sub, planetary_geometry(sub), t * s.torque_in)
                out.update({m: flow["force_N"][f"{m}_1"] for m in s.meshes})
            else:
                sub = _fixed_axis_model(model, s)
                out.update(fixed_axis_forces(sub, {m: base_radii[m] for m in s.meshes}, torque_Nm=t * s.torque_in))
        return out

    def train(self, model: Any, tables: Any, *, force_law: str = "hac", torque_Nm: float | None = None,
              bearing_stiffness_N_per_m: float | None = None, modal_damping_ratio: float | None = None,
              shafts: bool = True) -> Train:
        """Each stage by its kind's builder at the torque the chain brings to it, joined (module docstring)."""
        torque = model.operating.torque_Nm if torque_Nm is None else float(torque_Nm)
        stages = gearbox_stages(model)
        rates = mesh_rates(model, stages)
        parts: list[tuple[Stage, Train, float, float]] = []   # stage, train, lambda, c_s
        frame_speed: dict[str, Fraction] = {}
        u: dict[tuple[str, str], float] = {}
        # constant speed: the output member follows the kinematics (a generator on the grid); drivetrain coupling:
        # free (a torque port)
        held = stages[-1].output if shafts else None
        for s in stages:
            opts = dict(force_law=force_law, torque_Nm=torque * s.torque_in,
                        bearing_stiffness_N_per_m=bearing_stiffness_N_per_m, modal_damping_ratio=modal_damping_ratio,
                        shafts=shafts)
            if s.planetary is not None:
                sub = _planetary_model(model, s.planetary, s.gears, s.meshes, s.input, held)
                part = _renamed(planetary_from_model(sub, tables, **opts), {"carrier": s.planetary.carrier})
            else:
                sub = _fixed_axis_model(model, s, held)
                build = helical_from_model if sub.kind == "helical_pair" else train_from_model
                part = build(sub, tables, **opts)
            local = dict(part.rigid_mode)
            b_in = next(b for b in part.bodies if b.name == s.input)
            u_in = local[(s.input, b_in.rotation)]
            if not u:   # the input member: the rigid mode's sign in its sense of rotation, shared by every body
                sign = math.copysign(1.0, u_in) * b_in.sense
            # the stage's rigid mode scaled to the input member's speed, its sign such that every body moves in
            # its own sense of rotation (the stages' frames are independent)
            lam = float(s.speed_in) / abs(u_in) * math.copysign(1.0, u_in) * b_in.sense * sign
            u.update({k: c * lam for k, c in local.items()})
            c_s = part.carrier_ratio * abs(lam)
            parts.append((s, part, lam, c_s))
            # the stage frame's speed in revolutions per input revolution, exact (counter-clockwise, as c_s)
            w_c = Fraction(0)
            if c_s != 0.0:
                w_c = abs(_planetary_speeds(model, s.planetary, s.gears, s.meshes, s.input, s.speed_in)[0][
                    s.planetary.carrier]) * int(math.copysign(1, c_s))
                if abs(float(w_c) - c_s) > 1e-9 * abs(c_s):
                    raise ModelError(f"{model.name}: stage {s.name}'s carrier turns {c_s:.12g} per input "
                                     f"revolution, its tooth counts say {float(w_c):.12g} (internal error)")
            frame_speed[s.name] = w_c
        bodies, couplings, springs, gyro, centri, reports_s, reports_b = [], [], [], [], [], [], []
        ref_cycles = float(stages[0].mesh_frequency) / (2 * math.pi)
        for s, part, lam, c_s in parts:
            rotating = part.carrier_ratio != 0.0
            bodies += [replace(b, speed_ratio=b.speed_ratio * abs(lam), frame_ratio=c_s if rotating else 0.0,
                               stage=s.name)
                       for b in part.bodies]
            for c in part.couplings:
                mesh = c.group if s.planetary is not None else c.name
                p, q = rates[mesh]
                kin = abs(sum(coef * u.get(k, 0.0) for k, coef in c.w))
                if abs(kin - ref_cycles * p / q) > 1e-9 * ref_cycles * p / q:
                    raise ModelError(f"{model.name}: mesh '{c.name}' advances {kin:.12g} cycles per radian of the "
                                     f"input, its tooth counts say {ref_cycles * p / q:.12g} (internal error)")
                couplings.append(replace(c, rate=(p, q)))
            springs += list(part.springs)
            # the stage's G and K_W at its own carrier speed W_s = c_s omega_ref (the kernel's W = omega_ref)
            gyro += [(a, b, c_s * v) for a, b, v in part.gyroscopic] if rotating else []
            centri += [(a, b, c_s * c_s * v) for a, b, v in part.centripetal] if rotating else []
            reports_s += list(part.support_reports)
            reports_b += list(part.bearing_reports)
        by_name = {b.name: b for b in bodies}
        by_mesh = {c.name: c for c in couplings}
        stage_of = {m: s for s in stages for m in s.members}
        frame_springs = []
        for sh in _section_of(model).shafts:
            # each member's rotation measured in its sense of rotation (its stage's frame)
            a, b = by_name[sh.member_a], by_name[sh.member_b]
            springs.append(Spring(sh.torsional_stiffness_Nm_per_rad,
                                  rows=((((a.name, a.rotation), a.sense), ((b.name, b.rotation), -b.sense)),)))
            if sh.bending_stiffness_N_per_m > 0:
                turn = {}
                for name in (sh.member_a, sh.member_b):
                    s = stage_of[name]
                    if s.planetary is None and model.gear(name).is_helical:
                        # a helical gear translates in x and y of its pair's own frame
                        turn[name] = _stage_pair_turn(model, s, by_mesh[s.meshes[0]])
                    elif s.planetary is None:
                        # a gear on one mesh translates along its line of action only: give it x and y
                        placed = train_geometry(_fixed_axis_model(model, s))
                        by_name[name], by_mesh = _in_plane(by_name[name], by_mesh, placed)
                fa, fb = (frame_speed[stage_of[x].name] for x in (sh.member_a, sh.member_b))
                if a.sense != b.sense:
                    turn = {1.0: "counter-clockwise", -1.0: "clockwise"}
                    raise ModelError(
                        f"gearbox.shafts '{sh.name}'.bending_stiffness_N_per_m [N/m] = "
                        f"{sh.bending_stiffness_N_per_m:g}: '{a.name}' turns {turn[a.sense]} in stage "
                        f"{stage_of[sh.member_a].name} and '{b.name}' {turn[b.sense]} in stage "
                        f"{stage_of[sh.member_b].name} (each stage's sense follows from its own flanks; the shaft's "
                        "torsion joins them by magnitude), so one of the two stages is built as a mirror image and "
                        "their x and y are not one frame's; a bending spring needs the two members turning alike "
                        "(allowed here: 0, the members' bearings carry them)")
                if fa == fb:
                    springs.append(Spring(sh.bending_stiffness_N_per_m, rows=tuple(
                        _centre_row(by_name[sh.member_a], i, 1.0, turn.get(sh.member_a, 0.0))
                        + _centre_row(by_name[sh.member_b], i, -1.0, turn.get(sh.member_b, 0.0)) for i in (0, 1))))
                else:
                    # the members' frames turn against each other: b's frame turns (fb - fa) / f_ref revolutions
                    # relative to a's per reference mesh cycle (f_ref: reference mesh cycles per input revolution)
                    r = (fb - fa) / stages[0].mesh_frequency
                    frame_springs.append(FrameSpring(
                        sh.name, sh.bending_stiffness_N_per_m,
                        rows_a=tuple(_centre_row(by_name[sh.member_a], i, 1.0, turn.get(sh.member_a, 0.0))
                                     for i in (0, 1)),
                        rows_b=tuple(_centre_row(by_name[sh.member_b], i, 1.0, turn.get(sh.member_b, 0.0))
                                     for i in (0, 1)),
                        rate=(r.numerator, r.denominator)))
        bodies = [by_name[b.name] for b in bodies]
        couplings = [by_mesh[c.name] for c in couplings]
        first, lastp = parts[0][1], parts[-1]
        nominal = {model.operating.torque_gear: (first.nominal_torques_per_Nm or {}).get(
            model.operating.torque_gear, 1.0)}
        s, part, _, _ = lastp
        if held is None:
            tq = (part.nominal_torques_per_Nm or {}).get(s.output)
            if tq is None:
                # a fixed-axis stage's output brakes with the torque its meshes deliver (in its sense of rotation)
                tq = -float(s.speed_in / s.speed_out)
            nominal[s.output] = tq * s.torque_in
        zeta = model.damping.modal_damping_ratio if modal_damping_ratio is None else float(modal_damping_ratio)
        any_rot = any(c_s != 0.0 for _, _, _, c_s in parts)
        return Train(
            name=model.name, kind=self.name, bodies=tuple(bodies), couplings=tuple(couplings), torque_Nm=torque,
            input_gear=model.operating.torque_gear, reference_gear=model.operating.torque_gear,
            modal_damping_ratio=zeta, force_law=force_law, springs=tuple(springs), gyroscopic=tuple(gyro),
            centripetal=tuple(centri), carrier_ratio=1.0 if any_rot else 0.0, rigid_mode=tuple(u.items()),
            held_tolerance=max(p.held_tolerance for _, p, _, _ in parts), mesh_cycles_per_rad=ref_cycles,
            nominal_torques_per_Nm=nominal, support_reports=tuple(reports_s), bearing_reports=tuple(reports_b),
            frame_springs=tuple(frame_springs))

    def extra_outputs(self, model: Any, system: Any) -> tuple[ExtraOutput, ...]:
        """``<shaft>.torque`` of every shaft (:func:`~hacgear_core.kinds.base.shaft_torque_output`)."""
        return tuple(shaft_torque_output(s.name, s.member_a, s.member_b, s.torsional_stiffness_Nm_per_rad)
                     for s in _section_of(model).shafts)
