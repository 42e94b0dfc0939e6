"""Fixed-axis gear trains (kinds ``spur_pair`` and ``idler_chain``): model or lumped parameters -> train description.

Each gear has a rotation DOF (counter-clockwise, fixed frame) and translation DOFs where its bearing is not rigid:
along its mesh's line of action when it has one mesh (the perpendicular translation of a frictionless spur
contact is not coupled to anything, so leaving it out is exact), in the plane (x, y) when it has several.  The
line-of-action vectors, moment arms, phases and tooth passages come from the placed train
(:mod:`hacgear_core.geometry.train`); the static mesh forces from the torque flow through the train.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from hacgear_core.dynamics.parameters import SpurPairParameters
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry, mesh_geometry, nominal_mesh_forces, train_geometry
from hacgear_core.kinds.assembly import assemble
from hacgear_core.kinds.base import Body, Coupling, Dof, Kind, KeyVector, Support, Train, mesh_table
from hacgear_core.kinds.helical_pair import helical_from_model

__all__ = ["FixedAxis", "TrainGear", "TrainMesh", "fixed_axis_train", "SpurPairParameters",
           "spur_pair_system"]


@dataclass(frozen=True)
class TrainGear:
    """A gear of a fixed-axis train for :func:`fixed_axis_train` (SI)."""

    name: str
    teeth: int
    mass_kg: float
    inertia_kgm2: float
    translational_stiffness_N_per_m: float = math.inf
    rotational_stiffness_Nm_per_rad: float = 0.0


@dataclass(frozen=True)
class TrainMesh:
    """A mesh of a fixed-axis train for :func:`fixed_axis_train`: gears, table, line of action ``n`` (2,) along
    which gear_a pushes gear_b, moment arms ``(m_a, m_b)`` [m] (``x = (u_a - u_b) . n + m_a th_a - m_b th_b``),
    ``phase`` [cycles], nominal static force [N], tooth passages; the coast side (opposite flanks):
    ``coast_line_of_action`` (2,) along which the coast contact pushes gear_b, coast moment arms ``(c_a, c_b)``
    (``xc = (u_a - u_b) . n_c + c_a th_a - c_b th_b``, the approach closing the backlash), the static coast force
    [N] when the nominal torque is reversed and the normal backlash [m] (None / 0 / inf: one-sided mesh)."""

    name: str
    gear_a: str
    gear_b: str
    table: object
    line_of_action: tuple[float, float]
    moment_arm_m: tuple[float, float]
    phase: float
    nominal_force_N: float
    tooth_passage: Mapping[str, int]
    coast_line_of_action: tuple[float, float] | None = None
    coast_moment_arm_m: tuple[float, float] | None = None
    nominal_coast_force_N: float = 0.0
    backlash_m: float = math.inf


def _loa_vector(nvec: np.ndarray, arms: tuple[float, float], dofs_a, dofs_b, gear_a: str,
                gear_b: str) -> KeyVector:
    """A mesh deflection ``(u_a - u_b) . n + arm_a th_a - arm_b th_b`` over the gears' DOF keys."""
    out = [((gear_a, d.label), float(np.asarray(d.direction) @ nvec)) for d in dofs_a]
    out += [((gear_b, d.label), -float(np.asarray(d.direction) @ nvec)) for d in dofs_b]
    return tuple(out) + (((gear_a, "theta"), arms[0]), ((gear_b, "theta"), -arms[1]))


def fixed_axis_train(name: str, kind: str, gears: Sequence[TrainGear], meshes: Sequence[TrainMesh], *,
                     torque_Nm: float, input_gear: str, modal_damping_ratio: float, force_law: str = "hac",
                     shafts: bool = True) -> Train:
    """The train description of a fixed-axis train.

    ``shafts``: keep the rotational support stiffnesses (constant-speed experiment); False drops them (in
    drivetrain coupling the shafts belong to the drivetrain model) and gives the train its free rotation.
    """
    gd = {g.name: g for g in gears}
    mesh_of: dict[str, list[TrainMesh]] = {g.name: [] for g in gears}
    for mm in meshes:
        for g in (mm.gear_a, mm.gear_b):
            if g not in gd:
                raise ModelError(f"mesh '{mm.name}' names unknown gear {g!r}; gears: {sorted(gd)}")
            mesh_of[g].append(mm)
    # operating sense of rotation of each gear: the sign of its moment arm (gear_a: m_a = s_a r_b,a; gear_b of
    # an external mesh: m_b = -s_a r_b,b = s_b r_b,b; of an internal mesh: m_b = s_a r_b,b = s_b r_b,b)
    sense: dict[str, float] = {}
    for mm in meshes:
        for g, arm in ((mm.gear_a, mm.moment_arm_m[0]), (mm.gear_b, mm.moment_arm_m[1])):
            s = math.copysign(1.0, arm)
            if sense.setdefault(g, s) != s:
                raise ModelError(f"{name}: gear '{g}' turns both ways in its meshes (check line_of_action and "
                                 "moment arms)")
    # translations: along the line of action of a gear's one mesh (the perpendicular one is not coupled), in the
    # plane (x, y) for a gear with several meshes; rigid bearings drop them
    trans: dict[str, tuple[Dof, ...]] = {}
    for g in gears:
        sup = Support(g.translational_stiffness_N_per_m)
        if len(mesh_of[g.name]) == 1:
            n_ = np.asarray(mesh_of[g.name][0].line_of_action, float)
            d = n_ / np.linalg.norm(n_)
            trans[g.name] = (Dof("u_loa", g.mass_kg, sup, (float(d[0]), float(d[1]))),)
        else:
            trans[g.name] = tuple(Dof(lab, g.mass_kg, sup, d) for lab, d in (("x", (1.0, 0.0)), ("y", (0.0, 1.0))))
    kept = {g.name: tuple(d for d in trans[g.name] if not d.support.rigid) for g in gears}
    ref = meshes[0].gear_a
    couplings = []
    for mm in meshes:
        nvec = np.asarray(mm.line_of_action, float)
        v = _loa_vector(nvec, mm.moment_arm_m, kept[mm.gear_a], kept[mm.gear_b], mm.gear_a, mm.gear_b)
        vc = None
        if mm.coast_line_of_action is not None:
            vc = _loa_vector(np.asarray(mm.coast_line_of_action, float), mm.coast_moment_arm_m, kept[mm.gear_a],
                             kept[mm.gear_b], mm.gear_a, mm.gear_b)
        ma, mb = mm.moment_arm_m
        za = gd[mm.gear_a].teeth
        couplings.append(Coupling(
            name=mm.name, gear_a=mm.gear_a, gear_b=mm.gear_b, table=mm.table, v=v,
            w=(((mm.gear_a, "theta"), sense[mm.gear_a] * za / (2 * math.pi)),),
            v_rot=(((mm.gear_a, "theta"), ma), ((mm.gear_b, "theta"), -mb)), phase=float(mm.phase),
            nominal_force_N=float(mm.nominal_force_N), teeth=(za, gd[mm.gear_b].teeth), base_radius_m=(abs(ma), abs(mb)),
            tooth_passage=dict(mm.tooth_passage), line_of_action=tuple(nvec / np.linalg.norm(nvec)), v_c=vc,
            nominal_coast_force_N=float(mm.nominal_coast_force_N), backlash_m=float(mm.backlash_m)))
    # kinematic rotation of the train per radian of the reference gear in its sense
    u_rot = {ref: 1.0}
    todo = list(meshes)
    while todo:
        prog = False
        for mm in list(todo):
            ma, mb = mm.moment_arm_m
            if mm.gear_a in u_rot and mm.gear_b not in u_rot:
                u_rot[mm.gear_b] = ma * u_rot[mm.gear_a] / -(-mb)
            elif mm.gear_b in u_rot and mm.gear_a not in u_rot:
                u_rot[mm.gear_a] = -mb * u_rot[mm.gear_b] / -ma
            elif mm.gear_a not in u_rot:
                continue
            todo.remove(mm)
            prog = True
        if not prog:
            raise ModelError(f"{name}: meshes {[mm.name for mm in todo]} are not connected to '{ref}'")
    bodies = []
    for g in gears:
        krot = g.rotational_stiffness_Nm_per_rad if shafts else 0.0
        radius = next((abs(arm) for mm in meshes for gn, arm in ((mm.gear_a, mm.moment_arm_m[0]),
                                                                 (mm.gear_b, -mm.moment_arm_m[1]))
                       if gn == g.name and arm != 0), 1.0)
        bodies.append(Body(name=g.name, dofs=trans[g.name] + (Dof("theta", g.inertia_kgm2, Support(krot)),),
                           teeth=g.teeth, sense=float(sense[g.name]), speed_ratio=float(u_rot[g.name] * sense[ref]),
                           radius_m=float(radius), mass_kg=g.mass_kg, inertia_kgm2=g.inertia_kgm2,
                           support=(g.translational_stiffness_N_per_m, krot)))
    return Train(name=name, kind=kind, bodies=tuple(bodies), couplings=tuple(couplings), torque_Nm=torque_Nm,
                 input_gear=input_gear, reference_gear=ref, modal_damping_ratio=modal_damping_ratio,
                 force_law=force_law, rigid_mode=tuple(((g, "theta"), val) for g, val in u_rot.items()))


def train_from_model(model: Any, tables: Any, *, force_law: str = "hac", torque_Nm: float | None = None,
                     bearing_stiffness_N_per_m: float | None = None, modal_damping_ratio: float | None = None,
                     shafts: bool = True) -> Train:
    """The train description of a spur pair or idler chain model with its mesh tables.

    Masses and inertias: those of :func:`hacgear_core.geometry.gear_geometry` (a gear's ``mass_kg`` /
    ``inertia_kgm2`` when given, else its blank with teeth, as ``hacgear info`` reports).  Base radii: the
    tables' (they define each FDF's deflection; checked against the geometry).  Torque: ``[operating]
    torque_Nm`` on ``torque_gear`` unless ``torque_Nm`` is given (same gear).  ``bearing_stiffness_N_per_m``
    overrides every gear's translational support stiffness (inf: rigid).
    """
    gg = {g.name: gear_geometry(g) for g in model.gears}
    mg = {m.name: mesh_geometry(model, m.name, gears=gg) for m in model.meshes}
    tg = train_geometry(model, gears=gg, meshes=mg)
    torque = model.operating.torque_Nm if torque_Nm is None else float(torque_Nm)
    tabs = {m.name: mesh_table(tables, m.name) for m in model.meshes}
    rb_tab = {}
    for m in model.meshes:
        t = tabs[m.name]
        tz = tuple(int(z) for z in getattr(t, "teeth", ()))
        if tz != (gg[m.gear_a].z, gg[m.gear_b].z):
            raise ModelError(f"mesh '{m.name}': the table's teeth {tz} differ from the model's "
                             f"{(gg[m.gear_a].z, gg[m.gear_b].z)} (table of another model?)")
        rb = tuple(float(r) for r in getattr(t, "base_radius_m", ()))
        geo = (mg[m.name].base_radius_m[m.gear_a], mg[m.name].base_radius_m[m.gear_b])
        if len(rb) != 2 or not np.allclose(rb, geo, rtol=1e-3):
            raise ModelError(f"mesh '{m.name}': the table's base radii {rb} m differ from the model's {geo} m "
                             "(table of another model?)")
        rb_tab[m.name] = rb
    rb_coast = {m.name: (mg[m.name].base_radius_coast_m[m.gear_a], mg[m.name].base_radius_coast_m[m.gear_b])
                for m in model.meshes}
    for m in model.meshes:
        ct = getattr(tabs[m.name], "coast", None)
        if ct is not None:
            rb = tuple(float(r) for r in getattr(ct, "base_radius_m", ()))
            if len(rb) != 2 or not np.allclose(rb, rb_coast[m.name], rtol=1e-3):
                raise ModelError(f"mesh '{m.name}': the coast table's base radii {rb} m differ from the model's "
                                 f"coast flanks' {rb_coast[m.name]} m (table of another model?)")
    forces = nominal_mesh_forces(model, rb_tab, torque_Nm=abs(torque))
    coast_forces = nominal_mesh_forces(model, rb_coast, torque_Nm=abs(torque))
    gears = []
    for g in model.gears:
        kt = g.support.translational_stiffness_N_per_m if bearing_stiffness_N_per_m is None \
            else float(bearing_stiffness_N_per_m)
        if not (kt > 0):
            raise ModelError(f"gear '{g.name}': translational_stiffness_N_per_m [N/m] must be > 0 (inf: rigid), "
                             f"got {kt!r}")
        gears.append(TrainGear(name=g.name, teeth=g.teeth, mass_kg=gg[g.name].mass_kg,
                               inertia_kgm2=gg[g.name].inertia_kgm2, translational_stiffness_N_per_m=kt,
                               rotational_stiffness_Nm_per_rad=g.support.rotational_stiffness_Nm_per_rad))
    meshes = []
    for m in model.meshes:
        pl = tg.meshes[m.name]
        rb = rb_tab[m.name]
        ma = math.copysign(rb[0], pl.moment_arm_m[m.gear_a])
        mb = math.copysign(rb[1], pl.moment_arm_m[m.gear_b])
        coast = {}
        if pl.coast_line_of_action is not None:
            rc = rb_coast[m.name]
            coast = dict(coast_line_of_action=tuple(pl.coast_line_of_action),
                         coast_moment_arm_m=(math.copysign(rc[0], pl.coast_moment_arm_m[m.gear_a]),
                                             math.copysign(rc[1], pl.coast_moment_arm_m[m.gear_b])),
                         nominal_coast_force_N=coast_forces[m.name], backlash_m=pl.backlash_normal_m)
        meshes.append(TrainMesh(name=m.name, gear_a=m.gear_a, gear_b=m.gear_b, table=tabs[m.name],
                                line_of_action=tuple(pl.line_of_action), moment_arm_m=(ma, mb), phase=pl.phase,
                                nominal_force_N=forces[m.name],
                                tooth_passage={m.gear_a: tg.tooth_passage[m.gear_a][m.name],
                                               m.gear_b: tg.tooth_passage[m.gear_b][m.name]}, **coast))
    zeta = model.damping.modal_damping_ratio if modal_damping_ratio is None else float(modal_damping_ratio)
    return fixed_axis_train(model.name, model.kind, gears, meshes, torque_Nm=torque,
                          input_gear=model.operating.torque_gear, modal_damping_ratio=zeta, force_law=force_law,
                          shafts=shafts)


def spur_pair_system(params: SpurPairParameters, table, force_law: str = "hac", *,
                     shafts: bool = True) -> LumpedSystem:
    """The lumped system of a spur pair from :class:`SpurPairParameters` and its mesh table (dissertation
    Eqs. 3.1-3.4: ``q = [y1, th1, y2, th2]``, translations along the line of action where the bearing is
    finite, ``x = y1 + r_b1 th1 - y2 + r_b2 th2``)."""
    tz = tuple(int(z) for z in getattr(table, "teeth", params.teeth))
    if tz != params.teeth:
        raise ModelError(f"teeth {params.teeth} do not match the table's teeth {tz}")
    rb_t = tuple(float(r) for r in getattr(table, "base_radius_m", params.base_radius_m))
    if not np.allclose(rb_t, params.base_radius_m, rtol=1e-3):
        raise ModelError(f"base_radius_m {params.base_radius_m} m does not match the table's {rb_t} m")
    p = params
    names = tuple(getattr(table, "gear_names", ("gear1", "gear2")))
    gears = [TrainGear(names[i], p.teeth[i], p.mass_kg[i], p.inertia_kg_m2[i], p.bearing_stiffness_N_per_m[i],
                       p.rotational_stiffness_Nm_per_rad[i]) for i in range(2)]
    rb1, rb2 = p.base_radius_m
    coast = {}
    ct = getattr(table, "coast", None)
    if ct is not None:
        rc1, rc2 = (float(r) for r in ct.base_radius_m)
        ang = math.radians(sum(p.pressure_angles_deg))
        backlash = getattr(ct, "backlash_normal_m", None)
        coast = dict(coast_line_of_action=(math.sin(ang), -math.cos(ang)), coast_moment_arm_m=(-rc1, rc2),
                     nominal_coast_force_N=abs(p.torque_Nm) / rc1,
                     backlash_m=float(np.min(ct.no_load_deflection_m)) if backlash is None else float(backlash))
    mesh = TrainMesh(name=str(getattr(table, "name", "m12")), gear_a=names[0], gear_b=names[1], table=table,
                     line_of_action=(0.0, 1.0), moment_arm_m=(rb1, -rb2), phase=p.mesh_phase,
                     nominal_force_N=p.static_force_N, tooth_passage={names[0]: 0, names[1]: 0}, **coast)
    return assemble(fixed_axis_train("spur_pair", FixedAxis.SPUR_PAIR, gears, [mesh], torque_Nm=p.torque_Nm,
                                     input_gear=names[0], modal_damping_ratio=p.modal_damping_ratio,
                                     force_law=force_law, shafts=shafts))


class FixedAxis(Kind):
    """Fixed-axis trains: ``spur_pair`` (two gears, one mesh) and ``idler_chain`` (any number of meshes)."""

    SPUR_PAIR = "spur_pair"

    def __init__(self, name: str, mesh_count: int | None) -> None:
        self.name = name
        self.mesh_count = mesh_count
        self.synthetic_tables = mesh_count == 1
        self.face_twist = mesh_count == 1

    def nominal_mesh_forces(self, model: Any, base_radii: Mapping[str, tuple[float, float]]) -> dict[str, float]:
        return nominal_mesh_forces(model, base_radii)

    def train(self, model: Any, tables: Any, **options) -> Train:
        """The spur pair or idler chain's train; a spur pair on a table with a twist axis (``face_twist``) is built
        as a helical pair at helix angle 0: six DOFs per gear, the generalized FDF over the mesh twist."""
        if self.face_twist and getattr(mesh_table(tables, model.meshes[0].name), "twist", None) is not None:
            return helical_from_model(model, tables, **options)
        return train_from_model(model, tables, **options)
