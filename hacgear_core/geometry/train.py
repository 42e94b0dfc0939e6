"""Gears placed in a train: centres, senses of rotation, line-of-action vectors, mesh phases, torque flow.

Frame: the fixed plane, x to the right, y up, angles counter-clockwise (CCW).  The first mesh's gear_a sits
at the origin; every mesh places its gear_b at ``center_distance`` along ``line_of_centres_rad`` (the
direction from gear_a's centre to gear_b's centre), so a tree-shaped train is placed mesh by mesh.

Senses of rotation.  The driver (gear_a of the first mesh) turns CCW when its loaded flank is ``drive``
(the CCW side of its teeth), CW when it is ``coast``; an external mesh reverses the sense, an internal mesh
keeps it.

Line of action.  For a mesh with pitch point ``P`` the unit vector ``n`` along which gear_a pushes gear_b is
``n = cos(a_w) t + sin(a_w) d``: ``t`` the velocity direction of gear_a's material at ``P`` in its sense of
rotation, ``d`` the direction of the separating force on gear_b (away from gear_a for an external mesh),
``a_w`` the operating pressure angle of the loaded flanks.  With the moment arms ``m_g = ((P - O_g) × n)_z``
(``= s_a r_b,a`` and ``-s_a r_b,b`` for an external mesh) the mesh deflection of rigid gears with rotations
``theta`` (CCW) and translations ``u`` is

    x = (u_a - u_b) · n + m_a theta_a - m_b theta_b,

and the mesh force F acts on gear_b as ``+F n`` and on gear_a as ``-F n``.

Mesh positions and phases.  A mesh's position [mesh cycles] is an integer when a tooth pair's loaded flanks
touch at the pitch point (the tables' convention) and grows as gear_a turns in its sense:
``tau = s_a z_a (phi_a - beta + sigma theta_f(r_w)) / (2 pi)`` (mod 1), with ``phi_a`` gear_a's rotation,
``beta`` the direction of ``P`` seen from gear_a's centre, ``theta_f(r_w)`` the polar half-angle of the loaded
flank ``f`` at the operating pitch radius and ``sigma = +1`` for ``drive``, ``-1`` for ``coast``.  The gears
are assembled so that the first mesh is at position 0 (tooth 0 of both gears at its pitch point); the
phase of every other mesh is its position at that instant — from the geometry and the tooth counts, never
typed.  All meshes of a train advance at the same mesh frequency.

Tooth following.  ``tooth_passage[gear][mesh]`` is the position of mesh ``mesh`` (an integer, in that mesh's
cycles) at which tooth 0 of ``gear`` is at that mesh's pitch point; the pair phase of tooth 0 in the mesh is
``tau_mesh - tooth_passage`` (the argument of the strain-deflection function), so the strains of a gear in two
meshes (an idler, whose two flanks are loaded by different meshes) superpose on one physical tooth.

Torque flow.  :func:`nominal_mesh_forces`: the mesh touching the operating torque's gear carries
``T / r_b``; the force propagates through free gears by their torque balance ``F_out r_b,out = F_in r_b,in``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from hacgear_core.errors import GeometryError, ModelError
from hacgear_core.geometry.gear import GearGeometry, gear_geometry
from hacgear_core.geometry.mesh import MeshGeometry, mesh_geometry

__all__ = [
    "MeshPlacement",
    "TrainGeometry",
    "train_geometry",
    "place_mesh",
    "nominal_mesh_forces",
    "rotation_senses",
]

_SIGMA = {"drive": 1.0, "coast": -1.0}


@dataclass(frozen=True)
class MeshPlacement:
    """One mesh of a placed train (SI, fixed frame).

    ``pitch_point_m`` (2,); ``line_of_action`` (2,) unit vector, gear_a pushes gear_b along it;
    ``moment_arm_m`` {gear: m_g} (``x = (u_a - u_b)·n + m_a theta_a - m_b theta_b``); ``pitch_radius_m``
    {gear: operating pitch radius}; ``phase`` [mesh cycles] its position when the first mesh is at 0.
    Coast side (the opposite flanks, in contact when the torque reverses): ``coast_line_of_action`` (2,) the unit
    vector along which the coast contact pushes gear_b, ``coast_moment_arm_m`` {gear: arm}, so that the coast
    approach (closing the backlash) is ``xc = (u_a - u_b)·n_c + c_a theta_a - c_b theta_b``;
    ``backlash_normal_m`` the normal backlash along the coast line of action (circular backlash on the operating
    pitch circle times the cosine of the coast operating pressure angle).
    """

    name: str
    gear_a: str
    gear_b: str
    internal: bool
    teeth: tuple[int, int]
    base_radius_m: tuple[float, float]
    pitch_point_m: np.ndarray
    line_of_action: np.ndarray
    moment_arm_m: Mapping[str, float]
    pitch_radius_m: Mapping[str, float]
    phase: float
    coast_line_of_action: np.ndarray | None = None
    coast_moment_arm_m: Mapping[str, float] | None = None
    backlash_normal_m: float = math.inf


@dataclass(frozen=True)
class TrainGeometry:
    """A placed gear train: ``centre_m`` {gear: (2,)}, ``sense`` {gear: +1 CCW / -1 CW}, ``speed_ratio``
    {gear: signed speed / speed of the first mesh's gear_a}, ``assembly_angle_rad`` {gear: rotation at
    which the first mesh is at position 0}, ``meshes`` {name: :class:`MeshPlacement`} in model order,
    ``tooth_passage`` {gear: {mesh: integer position}} (module docstring)."""

    centre_m: Mapping[str, np.ndarray]
    sense: Mapping[str, float]
    speed_ratio: Mapping[str, float]
    assembly_angle_rad: Mapping[str, float]
    meshes: Mapping[str, MeshPlacement]
    tooth_passage: Mapping[str, Mapping[str, int]]
    reference_gear: str

    def mesh_phase(self, name: str) -> float:
        return self.meshes[name].phase


def rotation_senses(model: Any) -> dict[str, float]:
    """Sense of rotation of every gear (+1 CCW, -1 CW) from the first mesh's driver and the mesh types."""
    gears = {g.name: g for g in model.gears}
    m0 = model.meshes[0]
    sense = {m0.gear_a: _SIGMA[m0.flank_a]}
    todo = list(model.meshes)
    while todo:
        progressed = False
        for m in list(todo):
            internal = gears[m.gear_a].internal or gears[m.gear_b].internal
            flip = 1.0 if internal else -1.0
            if m.gear_a in sense and m.gear_b not in sense:
                sense[m.gear_b] = flip * sense[m.gear_a]
            elif m.gear_b in sense and m.gear_a not in sense:
                sense[m.gear_a] = flip * sense[m.gear_b]
            elif m.gear_a not in sense:
                continue
            elif sense[m.gear_b] != flip * sense[m.gear_a]:
                raise ModelError(f"mesh '{m.name}': the senses of rotation of '{m.gear_a}' and '{m.gear_b}' "
                                 "contradict the other meshes (a closed loop of external meshes cannot turn)")
            todo.remove(m)
            progressed = True
        if not progressed:
            raise ModelError(f"meshes {[m.name for m in todo]} are not connected to the first mesh's gears")
    return sense


def _flank_angle(gg: GearGeometry, side: str, r: float) -> float:
    """Polar angle [rad] of tooth 0's flank ``side`` at radius ``r`` in the gear frame (drive > 0, coast < 0)."""
    return _SIGMA[side] * float(gg._form.theta(side, r))


def place_mesh(ga: GearGeometry, gb: GearGeometry, mg: MeshGeometry, sense_a: float, centre_a, centre_b) -> dict:
    """One mesh placed in the fixed frame: gear_a at ``centre_a`` turning in ``sense_a`` (+1 CCW), gear_b at
    ``centre_b`` (at the centre distance).  Returns ``pitch_point_m`` (2,), ``line_of_action`` (2,) (unit, gear_a
    pushes gear_b along it), moment arms ``arm_a``/``arm_b`` [m] (``x = (u_a - u_b)·n + arm_a th_a - arm_b th_b``),
    the direction ``beta_a``/``beta_b`` [rad] and distance ``r_wa``/``r_wb`` [m] of the pitch point from each centre,
    the loaded-flank base radii, ``angle_a``/``angle_b`` [rad]: the rotations at which tooth 0 of each gear
    has its loaded flank at the pitch point (pitch-point contact, mesh position 0), and the coast side
    (:class:`MeshPlacement`): ``coast_line_of_action``, ``coast_arm_a``/``coast_arm_b``, ``backlash_normal_m``."""
    oa, ob = np.asarray(centre_a, float), np.asarray(centre_b, float)
    e = (ob - oa) / np.linalg.norm(ob - oa)
    rwa, rwb = mg.operating_pitch_radius_m[ga.name], mg.operating_pitch_radius_m[gb.name]
    if not mg.internal:
        p, d = oa + rwa * e, e
    elif gb.internal:  # a pinion inside ring b: pitch point beyond the pinion, away from the ring centre
        p, d = oa - rwa * e, -e
    else:  # a ring, b pinion inside it
        p, d = oa + rwa * e, -e
    ra = (p - oa) / np.linalg.norm(p - oa)
    t = sense_a * np.array([-ra[1], ra[0]])
    aw = mg.operating_pressure_angle_rad
    n = math.cos(aw) * t + math.sin(aw) * d
    arm = {}
    for name, o in (("a", oa), ("b", ob)):
        r = p - o
        arm[name] = float(r[0] * n[1] - r[1] * n[0])
    rba, rbb = mg.base_radius_m[ga.name], mg.base_radius_m[gb.name]
    if abs(abs(arm["a"]) - rba) > 1e-9 or abs(abs(arm["b"]) - rbb) > 1e-9:
        raise GeometryError(f"mesh '{mg.name}': line of action does not touch the base circles "
                            f"(arms {arm}, base radii {rba}, {rbb})")
    # coast side: the other common tangent through P; its contact pushes gear_b back (-t) and apart (+d)
    awc = mg.operating_pressure_angle_coast_rad
    coast = {}
    if math.isfinite(awc):
        nc = -math.cos(awc) * t + math.sin(awc) * d
        for name, o in (("a", oa), ("b", ob)):
            r = p - o
            coast[name] = float(r[0] * nc[1] - r[1] * nc[0])
        coast["n"] = nc
        coast["backlash"] = float(mg.backlash_m * math.cos(awc))
    ba = math.atan2(*(p - oa)[::-1])
    bb = math.atan2(*(p - ob)[::-1])
    return dict(pitch_point_m=p, line_of_action=n, arm_a=arm["a"], arm_b=arm["b"], beta_a=ba, beta_b=bb,
                r_wa=float(np.linalg.norm(p - oa)), r_wb=float(np.linalg.norm(p - ob)), base_radius_m=(rba, rbb),
                angle_a=ba - _flank_angle(ga, mg.flank_a, rwa), angle_b=bb - _flank_angle(gb, mg.flank_b, rwb),
                coast_line_of_action=coast.get("n"), coast_arm_a=coast.get("a", math.nan),
                coast_arm_b=coast.get("b", math.nan), backlash_normal_m=coast.get("backlash", math.inf))


def _wrap01(v: float) -> float:
    f = v - math.floor(v)
    return 0.0 if f >= 1.0 - 1e-12 else f


def train_geometry(model: Any, *, gears: Mapping[str, GearGeometry] | None = None,
                   meshes: Mapping[str, MeshGeometry] | None = None) -> TrainGeometry:
    """Place the gears of ``model`` (spur pairs, idler chains; any tree of fixed-axis meshes).

    Raises
    ------
    ModelError
        A mesh not connected to the first one, a gear placed twice at different centres.
    """
    gg = dict(gears) if gears is not None else {g.name: gear_geometry(g) for g in model.gears}
    mg = dict(meshes) if meshes is not None else {m.name: mesh_geometry(model, m.name, gears=gg) for m in model.meshes}
    sense = rotation_senses(model)
    m0 = model.meshes[0]
    centre: dict[str, np.ndarray] = {m0.gear_a: np.zeros(2)}
    todo = list(model.meshes)
    while todo:
        progressed = False
        for m in list(todo):
            a = mg[m.name].center_distance_m
            e = np.array([math.cos(m.line_of_centres_rad), math.sin(m.line_of_centres_rad)])
            if m.gear_a in centre:
                pos_b = centre[m.gear_a] + a * e
                if m.gear_b in centre and np.linalg.norm(centre[m.gear_b] - pos_b) > 1e-9:
                    raise ModelError(f"mesh '{m.name}': gear '{m.gear_b}' is placed at two different centres "
                                     f"({centre[m.gear_b]} m and {pos_b} m); check line_of_centres_deg")
                centre[m.gear_b] = pos_b
            elif m.gear_b in centre:
                centre[m.gear_a] = centre[m.gear_b] - a * e
            else:
                continue
            todo.remove(m)
            progressed = True
        if not progressed:  # pragma: no cover - rotation_senses already refused this
            raise ModelError(f"meshes {[m.name for m in todo]} are not connected to the first mesh's gears")

    placements: dict[str, dict] = {}
    pitch: dict[str, dict[str, tuple[float, float]]] = {}  # mesh -> gear -> (beta, r_w)
    for m in model.meshes:
        pl = place_mesh(gg[m.gear_a], gg[m.gear_b], mg[m.name], sense[m.gear_a], centre[m.gear_a],
                        centre[m.gear_b])
        pitch[m.name] = {m.gear_a: (pl["beta_a"], pl["r_wa"]), m.gear_b: (pl["beta_b"], pl["r_wb"])}
        placements[m.name] = dict(name=m.name, gear_a=m.gear_a, gear_b=m.gear_b, internal=mg[m.name].internal,
                                  teeth=(gg[m.gear_a].z, gg[m.gear_b].z), base_radius_m=pl["base_radius_m"],
                                  pitch_point_m=pl["pitch_point_m"], line_of_action=pl["line_of_action"],
                                  moment_arm_m={m.gear_a: pl["arm_a"], m.gear_b: pl["arm_b"]},
                                  pitch_radius_m={m.gear_a: pl["r_wa"], m.gear_b: pl["r_wb"]},
                                  coast_line_of_action=pl["coast_line_of_action"],
                                  coast_moment_arm_m={m.gear_a: pl["coast_arm_a"], m.gear_b: pl["coast_arm_b"]},
                                  backlash_normal_m=pl["backlash_normal_m"])

    # assembly: the first mesh at position 0 (tooth 0 of both its gears at its pitch point); every other
    # gear turned so that it meshes with an already placed gear at that mesh's position
    angle: dict[str, float] = {}
    phase: dict[str, float] = {}
    for gear, side in ((m0.gear_a, m0.flank_a), (m0.gear_b, m0.flank_b)):
        beta, rw = pitch[m0.name][gear]
        angle[gear] = beta - _flank_angle(gg[gear], side, rw)
    phase[m0.name] = 0.0
    todo = list(model.meshes[1:])
    while todo:
        progressed = False
        for m in list(todo):
            za, zb = gg[m.gear_a].z, gg[m.gear_b].z
            if m.gear_a in angle:
                beta, rw = pitch[m.name][m.gear_a]
                tau = sense[m.gear_a] * za * (angle[m.gear_a] - beta + _flank_angle(gg[m.gear_a], m.flank_a, rw)) \
                    / (2 * math.pi)
                ph = _wrap01(tau)
                if m.gear_b not in angle:
                    bb, rwb = pitch[m.name][m.gear_b]
                    angle[m.gear_b] = (bb - _flank_angle(gg[m.gear_b], m.flank_b, rwb)
                                       + sense[m.gear_b] * 2 * math.pi * ph / zb)
            elif m.gear_b in angle:
                bb, rwb = pitch[m.name][m.gear_b]
                tau = sense[m.gear_b] * zb * (angle[m.gear_b] - bb + _flank_angle(gg[m.gear_b], m.flank_b, rwb)) \
                    / (2 * math.pi)
                ph = _wrap01(tau)
                beta, rw = pitch[m.name][m.gear_a]
                angle[m.gear_a] = (beta - _flank_angle(gg[m.gear_a], m.flank_a, rw)
                                   + sense[m.gear_a] * 2 * math.pi * ph / za)
            else:
                continue
            phase[m.name] = ph
            todo.remove(m)
            progressed = True
        if not progressed:  # pragma: no cover
            raise ModelError(f"meshes {[m.name for m in todo]} are not connected to the first mesh's gears")

    # tooth passage: position of each mesh at which tooth 0 of each of its gears is at its pitch point
    passage: dict[str, dict[str, int]] = {g.name: {} for g in model.gears}
    for m in model.meshes:
        for gear, side in ((m.gear_a, m.flank_a), (m.gear_b, m.flank_b)):
            beta, rw = pitch[m.name][gear]
            z = gg[gear].z
            turn = sense[gear] * (beta - (angle[gear] + _flank_angle(gg[gear], side, rw)))
            turn -= 2 * math.pi * math.floor(turn / (2 * math.pi))
            d = z * turn / (2 * math.pi)  # mesh cycles until tooth 0 reaches the pitch point
            n = d + phase[m.name]
            if abs(n - round(n)) > 1e-6:
                raise GeometryError(f"mesh '{m.name}': tooth 0 of '{gear}' reaches the pitch point at mesh position "
                                    f"{n:.9f}, not at an integer (inconsistent assembly)")
            passage[gear][m.name] = int(round(n)) % z

    ref = m0.gear_a
    zref = gg[ref].z
    ratio = {g: sense[g] * zref / gg[g].z for g in sense}
    mp = {name: MeshPlacement(phase=phase[name], **kw) for name, kw in placements.items()}
    return TrainGeometry(centre_m=centre, sense=sense, speed_ratio=ratio, assembly_angle_rad=angle, meshes=mp,
                         tooth_passage=passage, reference_gear=ref)


def nominal_mesh_forces(model: Any, base_radii: Mapping[str, tuple[float, float]] | None = None,
                        torque_Nm: float | None = None) -> dict[str, float]:
    """Nominal static force [N] of every mesh under ``torque_Nm`` (default ``model.operating.torque_Nm``) on
    ``model.operating.torque_gear``.

    The mesh touching ``torque_gear`` carries ``T / r_b`` (divided by the planet count for planetary sets,
    whose planets share the torque); the force then propagates through free gears (idlers, planets) by their
    torque balance ``F_out = F_in · r_b,in / r_b,out``.  ``base_radii[mesh]`` are the loaded-flank base radii
    ``(r_b of gear_a, r_b of gear_b)`` [m] (default: from the geometry).
    """
    if base_radii is None:
        gg = {g.name: gear_geometry(g) for g in model.gears}
        base_radii = {m.name: (gg[m.gear_a].base_radius_m[m.flank_a], gg[m.gear_b].base_radius_m[m.flank_b])
                      for m in model.meshes}
    T = model.operating.torque_Nm if torque_Nm is None else float(torque_Nm)
    g0 = model.operating.torque_gear
    share = model.planetary.planet_count if getattr(model, "planetary", None) is not None else 1
    meshes = {m.name: m for m in model.meshes}
    force: dict[str, float] = {}
    frontier: list[tuple[str, float | None, float | None]] = [(g0, None, None)]  # gear, F_in, r_b,in
    seen = {g0}
    while frontier:
        gear, f_in, rb_in = frontier.pop(0)
        for name, m in meshes.items():
            if name in force or gear not in (m.gear_a, m.gear_b):
                continue
            rb = base_radii[name][0 if m.gear_a == gear else 1]
            f = T / rb / share if f_in is None else f_in * rb_in / rb
            force[name] = f
            other = m.gear_b if m.gear_a == gear else m.gear_a
            if other not in seen:
                seen.add(other)
                frontier.append((other, f, base_radii[name][1 if m.gear_a == gear else 0]))
    missing = [n for n in meshes if n not in force]
    if missing:
        raise ModelError(f"meshes {missing} carry no load from operating.torque_gear = '{g0}' (not connected)")
    return force
