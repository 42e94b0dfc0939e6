"""Builder of fixed-axis gear trains (spur pairs, idler chains): model or lumped parameters → :class:`LumpedSystem`.

Each gear has a rotation DOF (counter-clockwise, fixed frame) and, where its bearing is not rigid, translation
DOFs: along its mesh's line of action when it has one mesh (the perpendicular translation of a frictionless spur
contact is not coupled to anything, so leaving it out is exact), in the plane (x, y) when it has several.  The
line-of-action vectors, moment arms, phases and tooth passages come from the placed train
(:mod:`hacgear_core.geometry.train`); the static mesh forces from the torque flow through the train.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Mapping, Sequence

import numpy as np

from hacgear_core.dynamics.system import GearBody, LumpedSystem, MeshCoupling
from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry, mesh_geometry, nominal_mesh_forces, train_geometry
from hacgear_core.model.schema import RANGES

__all__ = ["TrainGear", "TrainMesh", "assemble_train", "train_from_model", "SpurPairParameters", "spur_pair_system"]


@dataclass(frozen=True)
class TrainGear:
    """A gear of a fixed-axis train for :func:`assemble_train` (SI)."""

    name: str
    teeth: int
    mass_kg: float
    inertia_kgm2: float
    translational_stiffness_N_per_m: float = math.inf
    rotational_stiffness_Nm_per_rad: float = 0.0


@dataclass(frozen=True)
class TrainMesh:
    """A mesh of a fixed-axis train for :func:`assemble_train`: gears, table, line of action ``n`` (2,) along
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


def _loa_vector(n: int, nvec: np.ndarray, arms: tuple[float, float], dirs_a, dirs_b, rot_a: int,
                rot_b: int) -> np.ndarray:
    """The vector (n,) of a mesh deflection ``(u_a - u_b) . n + arm_a th_a - arm_b th_b`` over the DOFs."""
    v = np.zeros(n)
    for i, d in dirs_a:
        v[i] += float(d @ nvec)
    for i, d in dirs_b:
        v[i] -= float(d @ nvec)
    v[rot_a] += arms[0]
    v[rot_b] -= arms[1]
    return v


def assemble_train(name: str, kind: str, gears: Sequence[TrainGear], meshes: Sequence[TrainMesh], *,
                   torque_Nm: float, input_gear: str, modal_damping_ratio: float, force_law: str = "hac",
                   shafts: bool = True) -> LumpedSystem:
    """Assemble the lumped system of a fixed-axis train.

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
    dofs: list[str] = []
    dirs: dict[str, list[tuple[int, np.ndarray]]] = {}
    rot: dict[str, int] = {}
    for g in gears:
        dirs[g.name] = []
        if math.isfinite(g.translational_stiffness_N_per_m):
            if len(mesh_of[g.name]) == 1:
                n_ = np.asarray(mesh_of[g.name][0].line_of_action, float)
                dirs[g.name].append((len(dofs), n_ / np.linalg.norm(n_)))
                dofs.append(f"{g.name}.u_loa")
            else:
                for lab, d in (("x", (1.0, 0.0)), ("y", (0.0, 1.0))):
                    dirs[g.name].append((len(dofs), np.array(d)))
                    dofs.append(f"{g.name}.{lab}")
        rot[g.name] = len(dofs)
        dofs.append(f"{g.name}.theta")
    n = len(dofs)
    M = np.zeros((n, n))
    K = np.zeros((n, n))
    for g in gears:
        for i, _ in dirs[g.name]:
            M[i, i] = g.mass_kg
            K[i, i] = g.translational_stiffness_N_per_m
        M[rot[g.name], rot[g.name]] = g.inertia_kgm2
        K[rot[g.name], rot[g.name]] = g.rotational_stiffness_Nm_per_rad if shafts else 0.0
    if np.any(np.diag(M) <= 0):
        bad = [dofs[i] for i in range(n) if M[i, i] <= 0]
        raise ModelError(f"{name}: masses and inertias must be > 0 (kg, kg*m^2); zero for {bad}")
    couplings = []
    ref = meshes[0].gear_a
    for mm in meshes:
        nvec = np.asarray(mm.line_of_action, float)
        v = _loa_vector(n, nvec, mm.moment_arm_m, dirs[mm.gear_a], dirs[mm.gear_b], rot[mm.gear_a], rot[mm.gear_b])
        vc = None
        if mm.coast_line_of_action is not None:
            vc = _loa_vector(n, np.asarray(mm.coast_line_of_action, float), mm.coast_moment_arm_m, dirs[mm.gear_a],
                             dirs[mm.gear_b], rot[mm.gear_a], rot[mm.gear_b])
        w = np.zeros(n)
        vr = np.zeros(n)
        ma, mb = mm.moment_arm_m
        vr[rot[mm.gear_a]] = ma
        vr[rot[mm.gear_b]] = -mb
        za = gd[mm.gear_a].teeth
        w[rot[mm.gear_a]] = sense[mm.gear_a] * za / (2 * math.pi)
        rb = (abs(ma), abs(mb))
        couplings.append(MeshCoupling(name=mm.name, gear_a=mm.gear_a, gear_b=mm.gear_b, table=mm.table, v=v, w=w,
                                      v_rot=vr, phase=float(mm.phase), nominal_force_N=float(mm.nominal_force_N),
                                      teeth=(za, gd[mm.gear_b].teeth), base_radius_m=rb,
                                      tooth_passage=dict(mm.tooth_passage),
                                      line_of_action=tuple(nvec / np.linalg.norm(nvec)), v_c=vc,
                                      nominal_coast_force_N=float(mm.nominal_coast_force_N),
                                      backlash_m=float(mm.backlash_m)))
    # kinematic rotation of the train per radian of the reference gear in its sense
    u_rot = {ref: 1.0}
    todo = list(couplings)
    while todo:
        prog = False
        for c in list(todo):
            ia, ib = rot[c.gear_a], rot[c.gear_b]
            if c.gear_a in u_rot and c.gear_b not in u_rot:
                u_rot[c.gear_b] = c.v[ia] * u_rot[c.gear_a] / -c.v[ib]
            elif c.gear_b in u_rot and c.gear_a not in u_rot:
                u_rot[c.gear_a] = c.v[ib] * u_rot[c.gear_b] / -c.v[ia]
            elif c.gear_a not in u_rot:
                continue
            todo.remove(c)
            prog = True
        if not prog:
            raise ModelError(f"{name}: meshes {[c.name for c in todo]} are not connected to '{ref}'")
    u = np.zeros(n)
    for g, val in u_rot.items():
        u[rot[g]] = val
    bodies = []
    for g in gears:
        idx = [i for i, _ in dirs[g.name]]
        dd = np.array([d for _, d in dirs[g.name]]).reshape(-1, 2)
        radius = abs(next((c.v_rot[rot[g.name]] for c in couplings if c.v_rot[rot[g.name]] != 0), 1.0))
        bodies.append(GearBody(name=g.name, teeth=g.teeth, sense=float(sense[g.name]),
                               speed_ratio=float(u_rot[g.name] * sense[ref]), rotation=rot[g.name], translations=tuple(idx),
                               directions=dd, radius_m=float(radius), mass_kg=g.mass_kg,
                               inertia_kgm2=g.inertia_kgm2,
                               support=(g.translational_stiffness_N_per_m,
                                        g.rotational_stiffness_Nm_per_rad if shafts else 0.0)))
    held = bool(np.any(np.abs(K @ u) > 0))
    return LumpedSystem(name=name, kind=kind, dof_names=dofs, mass=M, stiffness=K, gears=bodies,
                        meshes=couplings, torque_Nm=torque_Nm, input_gear=input_gear,
                        modal_damping_ratio=modal_damping_ratio, force_law=force_law, reference_gear=ref,
                        rigid_mode=None if held else u)


def mesh_table(tables: Any, name: str, single: bool = True):
    """Mesh ``name``'s table from ``tables``: a :class:`~hacgear_core.tables.SystemTables`, a {mesh: MeshTable}
    mapping or (``single``) one table used as it is."""
    if hasattr(tables, "mesh"):
        return tables.mesh(name)
    if isinstance(tables, Mapping):
        if name not in tables:
            raise ModelError(f"no table for mesh '{name}'; tables for {sorted(tables)}")
        return tables[name]
    if not single:
        raise ModelError(f"no tables for mesh '{name}' (give SystemTables or {{mesh: MeshTable}})")
    return tables


def train_from_model(model: Any, tables: Any, *, force_law: str = "hac", torque_Nm: float | None = None,
                     bearing_stiffness_N_per_m: float | None = None, modal_damping_ratio: float | None = None,
                     shafts: bool = True) -> LumpedSystem:
    """The lumped system of a spur pair or idler chain model with its mesh tables.

    Masses and inertias: those of :func:`hacgear_core.geometry.gear_geometry` (a gear's ``mass_kg`` /
    ``inertia_kgm2`` when given, else its blank with teeth, as ``hacgear info`` reports).  Base radii: the
    tables' (they define each FDF's deflection; checked against the geometry).  Torque: ``[operating]
    torque_Nm`` on ``torque_gear`` unless ``torque_Nm`` is given (same gear).  ``bearing_stiffness_N_per_m``
    overrides every gear's translational support stiffness (inf: rigid).
    """
    if model.kind not in ("spur_pair", "idler_chain"):
        raise ModelError(f"fixed-axis train builder: model kind must be spur_pair | idler_chain, got {model.kind!r}")
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
    return assemble_train(model.name, model.kind, gears, meshes, torque_Nm=torque,
                          input_gear=model.operating.torque_gear, modal_damping_ratio=zeta, force_law=force_law,
                          shafts=shafts)


def _pair(name, value, unit, lo, hi, *, lo_open=True, allow_inf=False, integer=False):
    try:
        a, b = value
    except (TypeError, ValueError):
        raise ModelError(f"{name} [{unit}] must be a pair (gear 1, gear 2), got {value!r}") from None
    out = []
    for v in (a, b):
        if integer:
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise ModelError(f"{name} [{unit}] must be integers in [{lo}, {hi}], got {value!r}")
            out.append(int(v))
            continue
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise ModelError(f"{name} [{unit}] must be numbers, got {value!r}") from None
        if math.isnan(v) or (math.isinf(v) and not allow_inf):
            raise ModelError(f"{name} [{unit}] must be finite{' or inf' if allow_inf else ''}, got {value!r}")
        bad_lo = v <= lo if lo_open else v < lo
        if bad_lo or (not math.isinf(v) and v > hi):
            br = "(" if lo_open else "["
            raise ModelError(f"{name} [{unit}] must be in {br}{lo:g}, {hi:g}]"
                             f"{' or inf' if allow_inf else ''}, got {value!r}")
        out.append(v)
    return tuple(out)


@dataclass(frozen=True)
class SpurPairParameters:
    """Lumped parameters of a spur pair without a model file (SI).  Pairs are (gear 1 = driver, gear 2).

    Attributes
    ----------
    mass_kg, inertia_kg_m2 : (float, float)
        Masses [kg] (used for translations with finite bearing stiffness) and polar inertias [kg m^2].
    base_radius_m : (float, float)
        Base radii of the loaded flanks [m].
    teeth : (int, int)
    bearing_stiffness_N_per_m : (float, float)
        Translational support stiffness along the line of action [N/m]; ``inf`` = rigid.
    rotational_stiffness_Nm_per_rad : (float, float)
        Rotational support stiffness [N m/rad]; 0 = free rotation.
    modal_damping_ratio : float in [0, 1)
    torque_Nm : float
        Nominal torque on gear 1 [N m] (nonzero; negative loads the coast flanks, which needs a coast table).
    mesh_phase : float
        Mesh position [cycles] at zero rotation of gear 1.
    pressure_angles_deg : (float, float)
        Operating pressure angles of the drive and the coast flanks [deg]: the coast line of action makes their sum
        with the drive one (used when the table has a coast side and the bearings are elastic).
    """

    mass_kg: tuple[float, float]
    inertia_kg_m2: tuple[float, float]
    base_radius_m: tuple[float, float]
    teeth: tuple[int, int]
    bearing_stiffness_N_per_m: tuple[float, float] = (math.inf, math.inf)
    rotational_stiffness_Nm_per_rad: tuple[float, float] = (0.0, 0.0)
    modal_damping_ratio: float = 0.02
    torque_Nm: float = 300.0
    mesh_phase: float = 0.0
    pressure_angles_deg: tuple[float, float] = (25.0, 20.0)

    def __post_init__(self) -> None:
        s = object.__setattr__
        s(self, "mass_kg", _pair("mass_kg", self.mass_kg, "kg", 0.0, 1e6))
        s(self, "inertia_kg_m2", _pair("inertia_kg_m2", self.inertia_kg_m2, "kg*m^2", 0.0, 1e6))
        s(self, "base_radius_m", _pair("base_radius_m", self.base_radius_m, "m", 0.0, 20.0))
        s(self, "teeth", _pair("teeth", self.teeth, "-", 6, 1000, integer=True))
        k_range = RANGES["translational_stiffness_N_per_m"]  # > 0 here: a spur pair's gears need a bearing
        s(self, "bearing_stiffness_N_per_m",
          _pair("bearing_stiffness_N_per_m", self.bearing_stiffness_N_per_m, "N/m", k_range.lo, k_range.hi,
                allow_inf=k_range.allow_inf))
        s(self, "rotational_stiffness_Nm_per_rad",
          _pair("rotational_stiffness_Nm_per_rad", self.rotational_stiffness_Nm_per_rad, "N*m/rad", 0.0, 1e12,
                lo_open=False))
        for name, unit in (("modal_damping_ratio", "-"), ("torque_Nm", "N*m")):
            v = getattr(self, name)
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise ModelError(f"{name} [{unit}] must be a number, got {v!r}") from None
            r = RANGES[name]
            if not r.contains(abs(v) if name == "torque_Nm" else v):
                rng = r.text if name == "modal_damping_ratio" else f"[-{r.hi:g}, {r.hi:g}] without 0"
                raise ModelError(f"{name} [{unit}] must be in {rng}, got {getattr(self, name)!r}")
            s(self, name, v)
        ph = float(self.mesh_phase)
        if not math.isfinite(ph):
            raise ModelError(f"mesh_phase [cycles] must be finite, got {self.mesh_phase!r}")
        s(self, "mesh_phase", ph)
        s(self, "pressure_angles_deg", _pair("pressure_angles_deg", self.pressure_angles_deg, "deg", 0.0, 60.0))

    @property
    def static_force_N(self) -> float:
        """Nominal static force of the drive flanks F_s = |T_1| / r_b1 [N] (a magnitude: the torque's sign picks
        the flanks)."""
        return abs(self.torque_Nm) / self.base_radius_m[0]

    def replace(self, **changes) -> "SpurPairParameters":
        return replace(self, **changes)


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
    return assemble_train("spur_pair", "spur_pair", gears, [mesh], torque_Nm=p.torque_Nm, input_gear=names[0],
                          modal_damping_ratio=p.modal_damping_ratio, force_law=force_law, shafts=shafts)
