"""The multi-stage parallel-axis gearbox (``kind = "gear_train"``): gears on shafts, any number of meshes in series.

A *shaft* (``[[gear_train.shafts]]``) joins two gears on one axis: its torsional stiffness acts between their
rotations, its bending stiffness (optional) between their translations (x and y), and ``mounting_angle_deg`` is
how gear_b is turned on the shaft relative to gear_a (tooth 0 of each, counter-clockwise).  A shaft carrying three
gears is two entries.  Gears joined by shafts form an *axis*: one centre, one sense of rotation.  Meshes join gears
of different axes; the axes form one chain (each axis meshes with at most two others, no loops), so the torque
flows in series from the torque gear at one end to the gear at the other end.

Model section::

    [[gear_train.shafts]]
    name = "shaft2"
    gear_a = "wheel1"                          # upstream gear (any order is accepted)
    gear_b = "pinion2"
    torsional_stiffness_Nm_per_rad = 1.0e4     # (0, 1e12]
    bending_stiffness_N_per_m = 0.0            # [0, 1e15]; 0: the gears' own bearings only (default)
    mounting_angle_deg = 0.0                   # (-360, 360); default 0

Each gear keeps its own ``[gears.support]`` (its bearing: translational stiffness; the rotational stiffness must
be 0: the input and output shafts belong to the drivetrain, FMU mode 1).  Placement: every group of meshed gears
is placed by :func:`hacgear_core.geometry.train_geometry`; an axis puts the gears of two groups on one centre and
turns the second group by the mounting angle, so every mesh phase follows from the geometry.

A stage may be helical: a group of two gears with a helix angle and one mesh is built by
:func:`~hacgear_core.kinds.helical_pair.helical_from_model` (six DOFs per gear in the pair's own frame, its
generalized table); the shafts join its gears' rotations about the axis (``theta_z``, oriented as the model's
counter-clockwise rotation by the placement's senses).  A train with spur and helical stages runs the twist law,
the spur meshes on their tables lifted to a constant twist axis (:mod:`hacgear_core.dynamics.laws`).  A shaft's
bending spring to a helical gear joins its x and y, which live in its pair's own frame, turned into the train's frame
(:func:`pair_frame_turn`).  The helical mesh's phase is the
transverse placement's.

Tooth counts are free: each mesh runs at its own mesh frequency, ``p/q`` times the first [[meshes]] entry's (the
reference mesh; :func:`mesh_rates`, a reduced fraction of the tooth counts along the chain), and the kernel derives
each mesh's position from the one reference position (:func:`hacgear_core.dynamics.kernels.mesh_base`).  The
system repeats after ``period_cycles`` reference mesh cycles (the lcm of the ``q``), the period of its steady state.

Constant-speed experiment: the torque gear carries ``[operating] torque_Nm``, the gear at the other end of the
chain brakes with the torque the meshes deliver (nominal torques per gear); every shaft between them carries its
static torque through its twist.  Extra output per shaft: ``<shaft>.torque`` (the elastic torque k (theta_a -
theta_b) in the axis's sense of rotation, positive when gear_a drives gear_b).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from fractions import Fraction
from types import SimpleNamespace
from typing import Any, Mapping

import numpy as np

from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry, mesh_geometry, train_geometry
from hacgear_core.geometry.train import MeshPlacement, TrainGeometry
from hacgear_core.kinds.base import Body, Coupling, Dof, ExtraOutput, Kind, Spring, Train, shaft_torque_output
from hacgear_core.kinds.fixed_axis import train_from_model
from hacgear_core.kinds.helical_pair import helical_from_model

__all__ = ["Shaft", "GearTrainSection", "GearTrain", "place_gear_train", "mesh_forces", "centre_row",
           "pair_frame_turn"]

_SHAFT_KEYS = ("name", "gear_a", "gear_b", "torsional_stiffness_Nm_per_rad", "bending_stiffness_N_per_m",
               "mounting_angle_deg")


@dataclass(frozen=True)
class Shaft:
    """A shaft between two gears on one axis (SI): torsional stiffness [N m/rad] between their rotations, bending
    stiffness [N/m] between their translations (0: none), mounting angle [rad] of gear_b's tooth 0 from gear_a's."""

    name: str
    gear_a: str
    gear_b: str
    torsional_stiffness_Nm_per_rad: float
    bending_stiffness_N_per_m: float = 0.0
    mounting_angle_rad: float = 0.0

    def __post_init__(self) -> None:
        where = f"gear_train.shafts '{self.name}'"
        if self.gear_a == self.gear_b:
            raise ModelError(f"{where}: gear_a and gear_b must differ, both are {self.gear_a!r}")
        k = float(self.torsional_stiffness_Nm_per_rad)
        if not (0.0 < k <= 1e12):
            raise ModelError(f"{where}: torsional_stiffness_Nm_per_rad [N*m/rad] must be in (0, 1e12], got {k!r}")
        kb = float(self.bending_stiffness_N_per_m)
        if not (0.0 <= kb <= 1e15):
            raise ModelError(f"{where}: bending_stiffness_N_per_m [N/m] must be in [0, 1e15], got {kb!r}")
        a = float(self.mounting_angle_rad)
        if not abs(a) < 2 * math.pi:
            raise ModelError(f"{where}: mounting_angle_deg [deg] must be in (-360, 360), got {math.degrees(a)!r}")
        object.__setattr__(self, "torsional_stiffness_Nm_per_rad", k)
        object.__setattr__(self, "bending_stiffness_N_per_m", kb)
        object.__setattr__(self, "mounting_angle_rad", a)


@dataclass(frozen=True)
class GearTrainSection:
    """The ``[gear_train]`` section: its shafts."""

    shafts: tuple[Shaft, ...] = ()


@dataclass(frozen=True)
class _Chain:
    """The topology of a gear train: ``axes`` (tuple of gear names per axis, along the chain from the torque gear's
    axis), ``axis`` {gear: index of its axis in ``axes``}, ``meshes`` (mesh names along the chain), ``into`` /
    ``out_of`` {axis index: gear that receives / passes on the torque}, ``torque`` {axis index: static torque per
    N m on the torque gear}."""

    axis: Mapping[str, int]
    axes: tuple[tuple[str, ...], ...]
    meshes: tuple[str, ...]
    into: Mapping[int, str]
    out_of: Mapping[int, str]
    torque: Mapping[int, float]


def _section_of(model: Any) -> GearTrainSection:
    sec = getattr(model, "section", None)
    return sec if isinstance(sec, GearTrainSection) else GearTrainSection()


def _chain(model: Any, base_radii: Mapping[str, tuple[float, float]] | None = None) -> _Chain:
    """The axes, the series order of the meshes and the static torque of every axis (per N m on the torque gear)
    of ``model`` (``base_radii`` {mesh: (r_b of gear_a, r_b of gear_b)} [m]; default from the geometry)."""
    shafts = _section_of(model).shafts
    names = [g.name for g in model.gears]
    parent = {g: g for g in names}

    def root(g: str) -> str:
        while parent[g] != g:
            g = parent[g]
        return g

    for s in shafts:
        for attr in ("gear_a", "gear_b"):
            if getattr(s, attr) not in parent:
                raise ModelError(f"gear_train.shafts '{s.name}'.{attr} = {getattr(s, attr)!r} names no gear; "
                                 f"allowed: {names}")
        ra, rb = root(s.gear_a), root(s.gear_b)
        if ra == rb:
            raise ModelError(f"gear_train.shafts '{s.name}' closes a loop of shafts between '{s.gear_a}' and "
                             f"'{s.gear_b}' (a shaft carrying n gears is n - 1 entries)")
        parent[rb] = ra
    groups: dict[str, list[str]] = {}
    for g in names:
        groups.setdefault(root(g), []).append(g)
    axis_list = list(groups.values())
    axis = {g: i for i, gs in enumerate(axis_list) for g in gs}
    meshed = {g: [] for g in names}
    for m in model.meshes:
        if axis[m.gear_a] == axis[m.gear_b]:
            raise ModelError(f"mesh '{m.name}': '{m.gear_a}' and '{m.gear_b}' are on one axis (joined by "
                             "gear_train.shafts); meshing gears need axes of their own")
        meshed[m.gear_a].append(m)
        meshed[m.gear_b].append(m)
    lonely = [g for g in names if not meshed[g]]
    if lonely:
        raise ModelError(f"gears {lonely} mesh with no gear (every gear of a gear_train needs a [[meshes]] entry)")
    start = axis[model.operating.torque_gear]
    axis_meshes = {i: sorted({m.name for g in gs for m in meshed[g]}) for i, gs in enumerate(axis_list)}
    busy = {i: ms for i, ms in axis_meshes.items() if len(ms) > 2}
    if busy:
        i, ms = next(iter(busy.items()))
        raise ModelError(f"the axis of gears {axis_list[i]} takes part in meshes {ms}: a gear_train is a chain in "
                         "series (each axis meshes with at most two others)")
    if len(axis_meshes[start]) != 1:
        raise ModelError(f"operating.torque_gear = {model.operating.torque_gear!r} must be at an end of the chain "
                         f"(its axis takes part in meshes {axis_meshes[start]}; the torque flows in series)")
    mesh_by = {m.name: m for m in model.meshes}
    if base_radii is None:
        gg = {g.name: gear_geometry(g) for g in model.gears}
        base_radii = {m.name: (gg[m.gear_a].base_radius_m[m.flank_a], gg[m.gear_b].base_radius_m[m.flank_b])
                      for m in model.meshes}
    order, axes, into, out_of, torque = [], [start], {start: model.operating.torque_gear}, {}, {start: 1.0}
    cur = start
    while True:
        nxt = [n for n in axis_meshes[cur] if n not in order]
        if not nxt:
            break
        m = mesh_by[nxt[0]]
        out_gear, in_gear = (m.gear_a, m.gear_b) if axis[m.gear_a] == cur else (m.gear_b, m.gear_a)
        rb_out, rb_in = base_radii[m.name] if out_gear == m.gear_a else base_radii[m.name][::-1]
        out_of[cur] = out_gear
        nxt_axis = axis[in_gear]
        if nxt_axis in torque:
            raise ModelError(f"mesh '{m.name}' closes a loop of meshes: a gear_train is a chain in series")
        torque[nxt_axis] = torque[cur] * rb_in / rb_out
        into[nxt_axis] = in_gear
        order.append(m.name)
        axes.append(nxt_axis)
        cur = nxt_axis
    missing = [m.name for m in model.meshes if m.name not in order]
    if missing:
        raise ModelError(f"meshes {missing} are not connected to operating.torque_gear = "
                         f"{model.operating.torque_gear!r} through meshes and gear_train.shafts")
    return _Chain(axis={g: axes.index(i) for g, i in axis.items()}, axes=tuple(tuple(axis_list[i]) for i in axes),
                  meshes=tuple(order),
                  into={axes.index(i): g for i, g in into.items()},
                  out_of={axes.index(i): g for i, g in out_of.items()},
                  torque={axes.index(i): t for i, t in torque.items()})


def mesh_rates(model: Any, chain: _Chain | None = None) -> dict[str, tuple[int, int]]:
    """Each mesh's mesh frequency over the first [[meshes]] entry's (the reference mesh), as a reduced fraction
    ``(p, q)``, from the tooth counts along the chain (a gear and the gears on its axis turn together)."""
    chain = _chain(model) if chain is None else chain
    teeth = {g.name: g.teeth for g in model.gears}
    speed = {0: Fraction(1)}  # axis speed over the first axis's, magnitude
    freq = {}
    for k, name in enumerate(chain.meshes):
        g_out, g_in = chain.out_of[k], chain.into[k + 1]
        freq[name] = speed[k] * teeth[g_out]
        speed[k + 1] = freq[name] / teeth[g_in]
    ref = freq[model.meshes[0].name]
    return {n: ((f / ref).numerator, (f / ref).denominator) for n, f in freq.items()}


def place_gear_train(model: Any, gears: Mapping | None = None, meshes: Mapping | None = None) -> TrainGeometry:
    """The placed train of a gear_train ``model``: every group of meshed gears placed by
    :func:`~hacgear_core.geometry.train_geometry`, groups joined along the shafts (one centre and sense per
    axis; gear_b turned by the shaft's mounting angle from gear_a), every mesh phase and tooth passage in the
    frame where the first mesh is at position 0 (the module docstring of :mod:`hacgear_core.geometry.train`)."""
    gg = dict(gears) if gears is not None else {g.name: gear_geometry(g) for g in model.gears}
    mg = dict(meshes) if meshes is not None else {m.name: mesh_geometry(model, m.name, gears=gg)
                                                    for m in model.meshes}
    groups = _mesh_groups(model)
    local = []
    for grp in groups:
        names = {x for m in grp for x in (m.gear_a, m.gear_b)}
        sub = SimpleNamespace(gears=tuple(g for g in model.gears if g.name in names), meshes=tuple(grp))
        local.append((grp, train_geometry(sub, gears=gg, meshes=mg)))
    centre, sense, angle, placed, passage = {}, {}, {}, {}, {g.name: {} for g in model.gears}

    def adopt(k: int, shift: np.ndarray, delta: float) -> None:
        """Take group ``k`` shifted by ``shift`` [m] with its meshes advanced by ``delta`` [cycles]."""
        grp, tg = local[k]
        for g, c in tg.centre_m.items():
            centre[g] = np.asarray(c, float) + shift
            sense[g] = tg.sense[g]
            angle[g] = tg.assembly_angle_rad[g] + sense[g] * 2 * math.pi * delta / gg[g].z
        for m in grp:
            raw = tg.meshes[m.name].phase + delta
            ph = raw - math.floor(raw)
            ph = 0.0 if ph >= 1.0 - 1e-12 else ph
            for g in (m.gear_a, m.gear_b):
                passage[g][m.name] = int(round(tg.tooth_passage[g][m.name] + ph - raw)) % gg[g].z
            pl = tg.meshes[m.name]
            placed[m.name] = MeshPlacement(**{**pl.__dict__, "pitch_point_m": pl.pitch_point_m + shift,
                                              "phase": ph})

    adopt(0, np.zeros(2), 0.0)
    todo = list(range(1, len(local)))
    shafts = _section_of(model).shafts
    while todo:
        for k in list(todo):
            tg = local[k][1]
            link = next(((s, s.gear_b, s.gear_a, s.mounting_angle_rad) for s in shafts
                         if s.gear_b in tg.centre_m and s.gear_a in angle), None) or next(
                ((s, s.gear_a, s.gear_b, -s.mounting_angle_rad) for s in shafts
                 if s.gear_a in tg.centre_m and s.gear_b in angle), None)
            if link is None:
                continue
            s, g, h, mount = link
            if tg.sense[g] != sense[h]:
                raise ModelError(f"gear_train.shafts '{s.name}': the loaded flanks make '{g}' turn "
                                 f"{'counter-' if tg.sense[g] > 0 else ''}clockwise and '{h}' the other way; "
                                 "gears on one shaft turn together (check flank_a / flank_b of their meshes)")
            delta = tg.sense[g] * gg[g].z * (angle[h] + mount - tg.assembly_angle_rad[g]) / (2 * math.pi)
            adopt(k, centre[h] - np.asarray(tg.centre_m[g], float), delta)
            todo.remove(k)
            break
        else:
            raise ModelError(f"meshes {[m.name for k in todo for m in local[k][0]]} are not joined to the first "
                             "mesh's gears by meshes or gear_train.shafts")
    ref = model.meshes[0].gear_a
    zref = gg[ref].z
    ratio = {g: sense[g] * zref / gg[g].z for g in sense}
    return TrainGeometry(centre_m=centre, sense=sense, speed_ratio=ratio, assembly_angle_rad=angle,
                         meshes={m.name: placed[m.name] for m in model.meshes}, tooth_passage=passage,
                         reference_gear=ref)


def mesh_forces(model: Any, base_radii: Mapping[str, tuple[float, float]], torque_Nm: float) -> dict[str, float]:
    """Static force [N] of every mesh at ``torque_Nm`` on the torque gear: the torque of the axis passing it on
    over that gear's base radius (``base_radii`` {mesh: (r_b of gear_a, r_b of gear_b)} [m], the flanks loaded)."""
    chain = _chain(model, base_radii)
    mesh_by = {m.name: m for m in model.meshes}
    out = {}
    for k, name in enumerate(chain.meshes):
        m = mesh_by[name]
        rb = base_radii[name][0 if chain.out_of[k] == m.gear_a else 1]
        out[name] = abs(float(torque_Nm)) * chain.torque[k] / rb
    return out


class GearTrain(Kind):
    """``kind = "gear_train"``: gears on shafts, meshes in series (module docstring)."""

    name = "gear_train"
    section = "gear_train"
    helical = None       # spur and helical stages

    def parse_section(self, reader: Any) -> GearTrainSection:
        if reader is None:
            return GearTrainSection()
        shafts = []
        for ssec in reader.array_of_tables("shafts", required=False):
            values = dict(
                name=ssec.string("name"), gear_a=ssec.string("gear_a"), gear_b=ssec.string("gear_b"),
                torsional_stiffness_Nm_per_rad=ssec.number("torsional_stiffness_Nm_per_rad", "N*m/rad", 0.0, 1e12,
                                                           lo_open=True),
                bending_stiffness_N_per_m=ssec.number("bending_stiffness_N_per_m", "N/m", 0.0, 1e15, required=False,
                                                      default=0.0),
                mounting_angle_rad=math.radians(ssec.number("mounting_angle_deg", "deg", -360.0, 360.0,
                                                            required=False, default=0.0, lo_open=True,
                                                            hi_open=True)))
            ssec.done(_SHAFT_KEYS)
            try:
                shafts.append(Shaft(**values))
            except ModelError as exc:
                raise ModelError(f"{reader.file}: [{ssec.path}] {exc}") from None
        reader.done(("shafts",))
        names = [s.name for s in shafts]
        if len(set(names)) != len(names):
            raise reader.error(f"{reader.path}.shafts.name", "", "unique names", names, problem="names repeat")
        return GearTrainSection(tuple(shafts))

    def check(self, model: Any) -> None:
        super().check(model)
        held = [g.name for g in model.gears if g.support.rotational_stiffness_Nm_per_rad != 0]
        if held:
            raise ModelError(f"gears {held}: support.rotational_stiffness_Nm_per_rad [N*m/rad] must be 0 for kind "
                             "'gear_train' (shafts between gears go in [[gear_train.shafts]]; the input and output "
                             "shafts belong to the drivetrain: FMU mode 1, examples/drivetrain_bench.py)")
        _chain(model)
        gears = {g.name: g for g in model.gears}
        for grp in _mesh_groups(model):
            names = sorted({x for m in grp for x in (m.gear_a, m.gear_b)})
            helical = [n for n in names if gears[n].is_helical]
            if helical and len(grp) != 1:
                raise ModelError(f"gears {helical} are helical: a helical stage of a gear_train is one pair (one mesh), "
                                 f"got meshes {[m.name for m in grp]} in one group")

    def placement(self, model: Any, gears: Mapping, meshes: Mapping) -> TrainGeometry:
        return place_gear_train(model, gears, meshes)

    def nominal_mesh_forces(self, model: Any, base_radii: Mapping[str, tuple[float, float]]) -> dict[str, float]:
        return mesh_forces(model, base_radii, model.operating.torque_Nm)

    def train(self, model: Any, tables: Any, *, force_law: str = "hac", torque_Nm: float | None = None,
              bearing_stiffness_N_per_m: float | None = None, modal_damping_ratio: float | None = None,
              shafts: bool = True) -> Train:
        """Each group of meshed gears by :func:`~hacgear_core.kinds.fixed_axis.train_from_model` (its tables checked,
        its torque the one the chain brings to it), in the placement of :func:`place_gear_train`; the groups joined
        by the shafts' springs; the torque gear driven and the chain's last gear braked by their nominal torques."""
        torque = model.operating.torque_Nm if torque_Nm is None else float(torque_Nm)
        gg = {g.name: gear_geometry(g) for g in model.gears}
        mg = {m.name: mesh_geometry(model, m.name, gears=gg) for m in model.meshes}
        placed = place_gear_train(model, gg, mg)
        chain = _chain(model, {m.name: placed.meshes[m.name].base_radius_m for m in model.meshes})
        rates = mesh_rates(model, chain)
        shafts_ = _section_of(model).shafts
        bodies: dict[str, Body] = {}
        couplings: dict[str, Coupling] = {}
        u: dict[str, float] = {}   # kinematic rotation per radian of the reference gear (CCW, fixed frame)
        orient: dict[str, float] = {}
        for grp in _mesh_groups(model):
            names = {x for m in grp for x in (m.gear_a, m.gear_b)}
            k = min(chain.meshes.index(m.name) for m in grp)  # the group's first mesh along the chain
            sub = replace(model, gears=tuple(g for g in model.gears if g.name in names), meshes=tuple(grp),
                          operating=replace(model.operating, torque_gear=chain.out_of[k]))
            build = helical_from_model if any(g.is_helical for g in sub.gears) else train_from_model
            part = build(sub, tables, force_law=force_law, torque_Nm=torque * chain.torque[k],
                         bearing_stiffness_N_per_m=bearing_stiffness_N_per_m,
                         modal_damping_ratio=modal_damping_ratio, shafts=shafts)
            # a helical pair's rotations are about its own frame's axis: orient[g] = +1 where that turns as the
            # model's counter-clockwise rotation, -1 where against it (the placement's senses against the pair's)
            orient.update({b.name: placed.sense[b.name] * b.sense if b.rotation != "theta" else 1.0
                           for b in part.bodies})
            local = {key[0]: c * orient[key[0]] for key, c in part.rigid_mode}
            scale = next((u[s.gear_a] / local[s.gear_b] for s in shafts_ if s.gear_b in names and s.gear_a in u),
                         None) or next((u[s.gear_b] / local[s.gear_a] for s in shafts_
                                        if s.gear_a in names and s.gear_b in u), 1.0)
            u.update({g: c * scale for g, c in local.items()})
            bodies.update({b.name: b for b in part.bodies})
            couplings.update({c.name: replace(c, phase=placed.meshes[c.name].phase, rate=rates[c.name], tooth_passage={
                g: placed.tooth_passage[g][c.name] for g in (c.gear_a, c.gear_b)}) for c in part.couplings})
        springs = []
        for s in shafts_:
            ra, rb = bodies[s.gear_a].rotation, bodies[s.gear_b].rotation
            springs.append(Spring(s.torsional_stiffness_Nm_per_rad,
                                  rows=((((s.gear_a, ra), orient[s.gear_a]), ((s.gear_b, rb), -orient[s.gear_b])),)))
            if s.bending_stiffness_N_per_m > 0:
                turn = {}
                for g in (s.gear_a, s.gear_b):
                    pair = next((c for c in couplings.values() if g in (c.gear_a, c.gear_b) and c.t is not None), None)
                    if pair is not None:
                        # a helical gear translates in x and y of its pair's own frame
                        turn[g] = pair_frame_turn(placed, pair, model.name)
                    else:
                        bodies[g], couplings = _in_plane(bodies[g], couplings, placed)
                springs.append(Spring(s.bending_stiffness_N_per_m, rows=tuple(
                    centre_row(bodies[s.gear_a], i, 1.0, turn.get(s.gear_a, 0.0))
                    + centre_row(bodies[s.gear_b], i, -1.0, turn.get(s.gear_b, 0.0)) for i in (0, 1))))
        ref = model.meshes[0].gear_a
        last = len(chain.axes) - 1
        # each body's kinematic speed in its own rotation coordinate, per radian of the reference gear's
        uc = {g: u[g] * orient[g] / (u[ref] * orient[ref]) for g in u}
        return Train(
            name=model.name, kind=self.name,
            bodies=tuple(replace(bodies[g.name], speed_ratio=uc[g.name] * bodies[ref].sense) for g in model.gears),
            couplings=tuple(couplings[m.name] for m in model.meshes), torque_Nm=torque,
            input_gear=model.operating.torque_gear, reference_gear=ref,
            modal_damping_ratio=model.damping.modal_damping_ratio if modal_damping_ratio is None
            else float(modal_damping_ratio), force_law=force_law, springs=tuple(springs),
            rigid_mode=tuple(((g.name, bodies[g.name].rotation), uc[g.name]) for g in model.gears),
            nominal_torques_per_Nm={model.operating.torque_gear: 1.0, chain.into[last]: -chain.torque[last]})

    def extra_outputs(self, model: Any, system: Any) -> tuple[ExtraOutput, ...]:
        """``<shaft>.torque`` of every shaft (:func:`~hacgear_core.kinds.base.shaft_torque_output`: positive when
        gear_a drives gear_b)."""
        return tuple(shaft_torque_output(s.name, s.gear_a, s.gear_b, s.torsional_stiffness_Nm_per_rad)
                     for s in _section_of(model).shafts)


def _mesh_groups(model: Any) -> list[list]:
    """The model's meshes grouped by shared gears (each group connected through gears alone), each group and the
    groups in model order."""
    groups: list[list] = []
    for m in model.meshes:
        hit = [grp for grp in groups if any({m.gear_a, m.gear_b} & {x.gear_a, x.gear_b} for x in grp)]
        for grp in hit:
            groups.remove(grp)
        groups.append(sorted([x for grp in hit for x in grp] + [m], key=model.meshes.index))
    return sorted(groups, key=lambda grp: model.meshes.index(grp[0]))


def centre_row(body: Any, axis: int, sign: float = 1.0, turn_rad: float = 0.0) -> tuple:
    """The KeyVector of ``body``'s centre displacement along the fixed frame's ``axis`` (0: x, 1: y), times
    ``sign``: its translation DOFs weighted by their directions (a rigidly held centre has none), the directions
    turned by ``turn_rad`` into the fixed frame (a helical pair's own frame, :func:`pair_frame_turn`)."""
    c, s = math.cos(turn_rad), math.sin(turn_rad)
    out = []
    for d in body.dofs:
        if d.direction is None:
            continue
        x, y = d.direction
        w = (c * x - s * y, s * x + c * y)[axis] if turn_rad else d.direction[axis]
        if w != 0.0:
            out.append(((body.name, d.label), sign * w))
    return tuple(out)


def pair_frame_turn(placed: TrainGeometry, coupling: Any, name: str = "") -> float:
    """The angle [rad] from a helical pair's own frame (its table's: gear_a at ``O_a``, gear_b at ``O_b``) to the
    fixed frame of ``placed`` (the gears placed by their meshes' ``line_of_centres_deg``): the turn that takes the
    line of centres ``O_b - O_a`` onto the placed one; checked to take the table's line of action ``e2`` onto the
    placed line of action too (a rotation, not a mirror image; ModelError otherwise)."""
    fr = coupling.table.twist.frame
    ob = np.asarray(fr["O_b"], float)[:2] - np.asarray(fr["O_a"], float)[:2]
    d = np.asarray(placed.centre_m[coupling.gear_b], float) - np.asarray(placed.centre_m[coupling.gear_a], float)
    turn = math.atan2(d[1], d[0]) - math.atan2(ob[1], ob[0])
    c, s = math.cos(turn), math.sin(turn)
    e2 = np.asarray(fr["e2"], float)[:2]
    e2 = e2 / np.linalg.norm(e2)
    loa = np.asarray(placed.meshes[coupling.name].line_of_action, float)
    if np.max(np.abs(np.array([c * e2[0] - s * e2[1], s * e2[0] + c * e2[1]]) - loa)) > 1e-9:
        raise ModelError(f"{name}: mesh '{coupling.name}': its table's frame is not the placed pair turned by "
                         f"{math.degrees(turn):.6g} deg (line of action {e2.tolist()} against {loa.tolist()}; a "
                         "mirror image: its bending spring would be in the wrong frame)")
    return turn


def _in_plane(body: Body, couplings: dict, placed: TrainGeometry) -> tuple[Body, dict]:
    """``body`` with its translation along its one mesh's line of action replaced by x and y (a shaft's bending
    spring couples it to another gear), and the couplings' vectors over x and y (unchanged for a rigid bearing)."""
    loa = [d for d in body.dofs if d.label == "u_loa"]
    if not loa:
        return body, couplings
    d = loa[0]
    dofs = tuple(Dof(lab, d.inertia, d.support, e) for lab, e in (("x", (1.0, 0.0)), ("y", (0.0, 1.0))))
    body = replace(body, dofs=dofs + tuple(x for x in body.dofs if x.label != "u_loa"))
    out = dict(couplings)
    for name, c in couplings.items():
        if body.name not in (c.gear_a, c.gear_b):
            continue
        sign = 1.0 if body.name == c.gear_a else -1.0
        pl = placed.meshes[name]

        def planar(kv, n):
            rest = tuple(e for e in kv if e[0] != (body.name, "u_loa"))
            return rest + (((body.name, "x"), sign * float(n[0])), ((body.name, "y"), sign * float(n[1])))
        out[name] = replace(c, v=planar(c.v, pl.line_of_action),
                            v_c=None if c.v_c is None else planar(c.v_c, pl.coast_line_of_action))
    return body, out
