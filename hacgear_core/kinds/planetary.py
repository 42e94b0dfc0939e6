"""Planetary sets (kind ``planetary``): model (or lumped model) -> train description in the rotating carrier frame.

Coordinates (dissertation Eq. 4.5b, in the frame rotating with the nominal carrier motion at ``W_c``)::

    q = [x_c, y_c, th_c, x_r, y_r, th_r, x_s, y_s, th_s, zeta_1, eta_1, th_1, ..., zeta_N, eta_N, th_N]

central members' translations ``x, y`` (carrier frame), rotations ``th`` (deviations from the kinematic motion,
counter-clockwise), planet ``i``'s radial ``zeta_i`` and tangential ``eta_i`` translations along
``e_r = (cos psi_i, sin psi_i)``, ``e_t = (-sin psi_i, cos psi_i)`` and rotation ``th_i``.  A coordinate is left
out where its support is rigid: translations of a member with ``translational_stiffness = inf``, the rotation of
a member with ``rotational_stiffness = inf`` (held: the fixed member; prescribed: a turning member that follows
the kinematics, the dissertation's carrier).  Rotational stiffness 0 leaves the member free (a torque port),
a finite one springs it to its kinematic motion.  Equations (Eq. 4.5a)::

    M q'' + (C + W_c G) q' + (K_b - W_c^2 K_W) q + sum_k F_k(tau_k, v_k . q) v_k = f_ext

* ``G`` and ``K_W`` (Appendix A): per body with translations, ``G = [[0, -2m], [2m, 0]]`` and ``K_W = diag(m, m)``
  on its (x, y) or (zeta, eta) pair (the frames of the planets are fixed in the carrier frame); the constant
  centrifugal force ``m_p W_c^2 r_c`` on a planet is left out, as in the dissertation (its static bearing
  deflection does not load the meshes at first order).  Our ``K_W`` is the dissertation's ``K_Omega`` with its
  ``M_Omega`` typo read as ``K_Omega``.  Where the carrier rotation is a DOF, ``K_W`` also carries the geometric
  stiffness of the planet bearings' centrifugal preload turning with the carrier, ``-N m_p r_c^2`` on ``th_c``
  (the consistent linearisation about the centrifugally loaded state; without it a free carrier's rigid rotation
  would have the spurious stiffness ``-N m_p r_c^2 W_c^2``, with it the rotation is neutral to ``O(m_p W_c^2 /
  k_p)``).  The bearing forces reported include the centrifugal load ``m_p W_c^2 r_c``.
* ``K_b``: isotropic supports of the central members (``k_j`` on x and y: frame-independent), their rotational
  springs, and the planet bearings ``k_p`` (radial and tangential, no rotational bearing stiffness) between the
  planet and its pin on the carrier: bearing deflection ``d_i = [zeta_i - u_c . e_r,  eta_i - u_c . e_t - r_c
  th_c] - e_i`` (``e_i`` the pin position error), energy ``k_p |d_i|^2 / 2``.  A pin error preloads the bearing:
  the constant force ``k_p B_i^T e_i`` acts in every experiment.
* mesh vectors from our own placement of the gears (:mod:`hacgear_core.geometry.planetary`): ``x = (u_a - u_b) . n
  + m_a th_a - m_b th_b``, not the dissertation's printed sign convention (Appendix B); mesh position ``tau =
  tau_ref + phase + z_a s_a (th_a - eta_i / r_c) / 2 pi`` (gear_a's rotation relative to its line of centres).
* reference motion: the input member (``[operating] torque_gear``); mesh cycles per radian of it ``z_s / (2 pi
  |omega_ref / Omega|)``; ``W_c`` = the carrier's kinematic speed.

Loads of the constant-speed experiment: the nominal torques ``T_s : T_r : T_c = 1 : z_r/z_s : -(1 + z_r/z_s)`` on
the members that have a rotation DOF (plus the pin-error preloads); the static mesh forces then follow from the
equilibrium (equal sharing for identical, equally spaced planets).
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Mapping

import numpy as np

from hacgear_core.errors import GeometryError, ModelError
from hacgear_core.geometry import gear_geometry
from hacgear_core.geometry.planetary import PlanetaryGeometry, planetary_geometry, planetary_torques
from hacgear_core.kinds.base import Body, Coupling, Dof, Kind, Spring, StructuralParameter, Support, Train, mesh_table
from hacgear_core.model.schema import RANGES
from hacgear_core.tables import MeshTable

__all__ = ["PlanetaryKind", "planetary_from_model", "constant_stiffness_table", "PLANETARY_DOF_ORDER",
           "planetary_error_inputs"]

#: order of the central members in q (dissertation Eq. 4.5b)
PLANETARY_DOF_ORDER = ("carrier", "ring", "sun")


def constant_stiffness_table(name: str, gear_names: tuple[str, str], teeth: tuple[int, int],
                             base_radius_m: tuple[float, float], stiffness_N_per_m: float,
                             x_max_m: float) -> MeshTable:
    """Force-deflection table of a constant mesh stiffness ``F = k max(0, x)`` (lumped models: no tooth geometry;
    the table's linear extrapolation keeps it exact beyond ``x_max_m``)."""
    k = float(stiffness_N_per_m)
    pos = np.arange(4) / 4.0
    nd = 8
    dx = x_max_m / (nd - 2)
    xd = -dx + dx * np.arange(nd)
    force = np.maximum(k * xd, 0.0)[None, :].repeat(4, axis=0)
    z = np.zeros((4, nd, 1))
    return MeshTable(
        name=name, gear_names=tuple(gear_names), teeth=tuple(teeth), base_radius_m=tuple(base_radius_m),
        position=pos, deflection_m=xd, force_N=np.ascontiguousarray(force), no_load_deflection_m=np.zeros(4),
        load_N=np.array([0.0]), static_deflection_m=np.zeros((4, 1)), tooth_offsets=np.array([0]),
        tooth_load_N=force[:, :, None], contact_roll_deg=z + np.nan, peak_pressure_Pa=np.zeros_like(force),
        strain={}, solver=f"lumped: constant mesh stiffness {k:.6g} N/m (no tooth geometry)")


def _member_properties(model: Any, geo: PlanetaryGeometry, bearing_override: float | None):
    """{member: (mass, inertia, k_translational, k_rotational, characteristic radius)} of sun, ring, carrier
    and the planet (shared by the planet instances)."""
    mem = geo.members
    pl = model.planetary
    out = {}
    for name in (mem.sun, mem.ring, mem.planet):
        g = model.gear(name)
        if getattr(model, "lumped", False):
            m, j, rb = g.mass_kg, g.inertia_kgm2, g.base_radius_m
        else:
            gg = gear_geometry(g)
            m, j = gg.mass_kg, gg.inertia_kgm2
            rb = None
            for mm in (geo.sun_mesh(1), geo.ring_mesh(1)):
                for k, gn in enumerate((mm.gear_a, mm.gear_b)):
                    if gn == name or (name == mem.planet and gn == geo.planets[0]):
                        rb = mm.base_radius_m[k]
                        break
                if rb is not None:
                    break
        kt = g.support.translational_stiffness_N_per_m if bearing_override is None else float(bearing_override)
        out[name] = (float(m), float(j), float(kt), float(g.support.rotational_stiffness_Nm_per_rad), float(rb))
    cs = pl.carrier_support
    kt = cs.translational_stiffness_N_per_m if bearing_override is None else float(bearing_override)
    out["carrier"] = (float(pl.carrier_mass_kg), float(pl.carrier_inertia_kgm2), float(kt),
                      float(cs.rotational_stiffness_Nm_per_rad), geo.carrier_radius_m)
    return out


def planetary_from_model(model: Any, tables: Any = None, *, force_law: str = "hac", torque_Nm: float | None = None,
                         bearing_stiffness_N_per_m: float | None = None, modal_damping_ratio: float | None = None,
                         shafts: bool = True, planet_count: int | None = None,
                         pin_errors_m: Mapping[int, tuple[float, float]] | None = None) -> Train:
    """The train description of a planetary model in the carrier frame (module docstring).

    Parameters
    ----------
    model : Model
        ``kind = "planetary"``; a lumped model (``[system] lumped = true``) needs no ``tables``.
    tables : SystemTables or {mesh: MeshTable}
        The model's two mesh tables (sun-planet, planet-ring), shared by every planet at its own phase.
    torque_Nm : float, optional
        Torque on the input member [N m] (default ``[operating] torque_Nm``).
    bearing_stiffness_N_per_m : float, optional
        Overrides every translational support stiffness (central members and planet bearings; inf: rigid).
    shafts : bool
        True: the rotational supports as given (constant-speed experiment).  False (drivetrain coupling): the
        turning members are free (the drivetrain owns their shafts); the fixed member keeps its support.
    planet_count : int, optional
        Overrides the model's planet count (equally spaced planets; the tables are per mesh kind).
    pin_errors_m : {planet (1-based): (radial [m], tangential [m])}, optional
        Planet pin position errors (default: the model's ``[[planetary.pin_errors]]``).

    Raises
    ------
    ModelError
        Inconsistent model, tables of another model, a member without mass where it has a DOF, a planet with a
        rotational bearing stiffness, loads beyond the tables.
    """
    geo = planetary_geometry(model, planet_count)
    mem = geo.members
    n_pl = geo.planet_count
    torque = model.operating.torque_Nm if torque_Nm is None else float(torque_Nm)
    flow = planetary_torques(model, geo, torque)
    props = _member_properties(model, geo, bearing_stiffness_N_per_m)
    fixed = {"sun": mem.sun, "ring": mem.ring, "carrier": "carrier"}[geo.fixed_member]  # its name
    inp = flow["input"]
    if props[mem.planet][3] != 0.0:
        raise ModelError(f"gear '{mem.planet}': rotational_stiffness_Nm_per_rad [N*m/rad] = {props[mem.planet][3]:g}; "
                         "a planet turns freely on its pin (allowed: 0)")
    kp = props[mem.planet][2]
    if not (kp > 0 and math.isfinite(kp)):
        raise ModelError(f"gear '{mem.planet}': the planet bearing's translational_stiffness_N_per_m [N/m] = {kp!r}; "
                         "allowed: finite > 0 (the planets sit on the carrier through their bearings)")

    # ---------------------------------------------------------------- DOFs
    central = {"carrier": "carrier", "ring": mem.ring, "sun": mem.sun}
    dofs: dict[str, tuple[Dof, ...]] = {}
    trans: dict[str, list[tuple[str, np.ndarray]]] = {}
    krot: dict[str, float] = {}
    for role in PLANETARY_DOF_ORDER:
        name = central[role]
        m, j, kt, kr, _ = props[name]
        if not (kt >= 0):
            raise ModelError(f"'{name}': translational_stiffness_N_per_m [N/m] must be >= 0 (0 floating, inf rigid), "
                             f"got {kt!r}")
        if not shafts and name != fixed:
            kr = 0.0   # drivetrain coupling: the shafts of the turning members belong to the drivetrain model
        tr = [] if math.isinf(kt) else [("x", np.array((1.0, 0.0))), ("y", np.array((0.0, 1.0)))]
        trans[name] = tr
        krot[name] = kr
        dofs[name] = tuple(Dof(lab, m, Support(kt), (float(d[0]), float(d[1]))) for lab, d in tr) \
            + (Dof("theta", j, Support(kr)),)
    for i, p in enumerate(geo.planets):
        psi = geo.positions_rad[i]
        er = np.array([math.cos(psi), math.sin(psi)])
        et = np.array([-math.sin(psi), math.cos(psi)])
        m, j = props[mem.planet][:2]
        trans[p] = [("zeta", er), ("eta", et)]
        krot[p] = 0.0
        dofs[p] = (Dof("zeta", m, Support(0.0), (float(er[0]), float(er[1]))),
                   Dof("eta", m, Support(0.0), (float(et[0]), float(et[1]))), Dof("theta", j, Support(0.0)))
    rot = {b: "theta" for b in dofs if not math.isinf(krot[b])}
    if inp not in rot:
        raise ModelError(f"the input member '{inp}' has no rotation DOF (rotational_stiffness inf: held or "
                         "prescribed); the input member must turn (rotational stiffness 0 or finite)")

    def props_of(body):
        return props[mem.planet] if body in geo.planets else props[body]

    # ---------------------------------------------------------------- G, K_W, planet bearings
    gyro, centri = [], []
    for body in list(central.values()) + list(geo.planets):
        m = props_of(body)[0]
        tr = trans[body]
        for lab, _d in tr:
            centri.append(((body, lab), (body, lab), m))
        if len(tr) == 2:
            (lx, _), (ly, _) = tr
            gyro += [((body, lx), (body, ly), -2.0 * m), ((body, ly), (body, lx), 2.0 * m)]
    rc = geo.carrier_radius_m
    if "carrier" in rot:
        centri.append((("carrier", "theta"), ("carrier", "theta"), -(n_pl * props[mem.planet][0] * rc * rc)))
    errors = {e.planet: (e.radial_m, e.tangential_m) for e in model.planetary.pin_errors} \
        if pin_errors_m is None else {int(k): tuple(v) for k, v in pin_errors_m.items()}
    for k in errors:
        if not 1 <= k <= n_pl:
            raise ModelError(f"pin error of planet {k}: allowed planets 1..{n_pl}")
    springs = []
    for i, p in enumerate(geo.planets):
        (lz, er), (le, et) = trans[p]
        rows = [[((p, lz), 1.0)], [((p, le), 1.0)]]
        for lab, d in trans["carrier"]:
            rows[0].append((("carrier", lab), -float(d @ er)))
            rows[1].append((("carrier", lab), -float(d @ et)))
        rows[1].append((("carrier", "theta"), -rc))
        e = tuple(float(x) for x in errors.get(i + 1, (0.0, 0.0)))
        # the planet's force on its pin, in the carrier frame's (x, y); its centrifugal load per unit W_c^2
        cf = props[mem.planet][0] * rc * er
        springs.append(Spring(kp, rows=(tuple(rows[0]), tuple(rows[1])), preload=e, reports=p,
                              frame=np.column_stack([er, et]), centrifugal=(float(cf[0]), float(cf[1]))))

    # ---------------------------------------------------------------- meshes
    tabs = {}
    base_of = {}
    for kind in (mem.sun_mesh, mem.ring_mesh):
        mm = geo.meshes[f"{kind}_1"]
        names = tuple(mem.planet if g in geo.planets else g for g in (mm.gear_a, mm.gear_b))
        if getattr(model, "lumped", False):
            k = float(model.mesh(kind).mesh_stiffness_N_per_m)
            fmax = max(flow["force_N"].values())
            tabs[kind] = constant_stiffness_table(kind, names, mm.teeth, mm.base_radius_m, k, 4.0 * fmax / k)
        else:
            if tables is None:
                raise ModelError(f"{model.name}: the planetary set needs its mesh tables (`hacgear statics "
                                 f"{model.name}`), or a lumped model")
            t = mesh_table(tables, kind, single=False)
            tz = tuple(int(z) for z in getattr(t, "teeth", ()))
            if tz != tuple(mm.teeth):
                raise ModelError(f"mesh '{kind}': the table's teeth {tz} differ from the model's {tuple(mm.teeth)} "
                                 "(table of another model, or the gear order of the mesh changed?)")
            rb = tuple(float(r) for r in getattr(t, "base_radius_m", ()))
            if len(rb) != 2 or not np.allclose(rb, mm.base_radius_m, rtol=1e-3):
                raise ModelError(f"mesh '{kind}': the table's base radii {rb} m differ from the model's "
                                 f"{tuple(mm.base_radius_m)} m (table of another model?)")
            # the loaded side's table: the coast side for a negative torque, at the coast base radius
            side = t if flow["flanks"] == "drive" else getattr(t, "coast", None)
            fnom = flow["force_N"][f"{kind}_1"]
            if side is not t:
                if side is None:
                    raise ModelError(f"mesh '{kind}': a negative torque ({torque:g} N*m) loads the coast flanks and "
                                     "the tables have no coast side (regenerate them: `hacgear statics`)")
                fnom *= mm.base_radius_m[0] / mm.coast_base_radius_m[0]
            lmax = float(np.max(getattr(side, "load_N", [np.inf])))
            if fnom > lmax * (1 + 1e-9):
                raise ModelError(f"mesh '{kind}': the nominal force per planet {fnom:.6g} N at {torque:g} N*m with "
                                 f"{n_pl} planets exceeds the tables' largest static load {lmax:.6g} N"
                                 f"{'' if side is t else ' (coast side)'}; generate the tables for this torque and "
                                 "planet count (`hacgear statics`)")
            tabs[kind] = t
        base_of[kind] = mm.base_radius_m
    couplings = []
    for mn, pm in geo.meshes.items():
        nvec = np.asarray(pm.line_of_action, float)
        v, vr = [], []
        for g_, sgn in ((pm.gear_a, 1.0), (pm.gear_b, -1.0)):
            v += [((g_, lab), sgn * float(d @ nvec)) for lab, d in trans.get(g_, [])]
            if g_ in rot:
                v.append(((g_, "theta"), sgn * pm.moment_arm_m[g_]))
                vr.append(((g_, "theta"), sgn * pm.moment_arm_m[g_]))
        # coast side (opposite flanks): the same form along the coast line of action with the coast arms
        vc, fc = None, 0.0
        if pm.coast_line_of_action is not None and getattr(tabs[pm.kind], "coast", None) is not None:
            vc = []
            for g_, sgn in ((pm.gear_a, 1.0), (pm.gear_b, -1.0)):
                vc += [((g_, lab), sgn * float(d @ pm.coast_line_of_action)) for lab, d in trans.get(g_, [])]
                if g_ in rot:
                    vc.append(((g_, "theta"), sgn * pm.coast_moment_arm_m[g_]))
            vc = tuple(vc)
            # the reversed torque through gear_a's coast flank (exact where each mesh's gears share their pressure
            # angles)
            fc = float(flow["force_N"][mn]) * pm.base_radius_m[0] / pm.coast_base_radius_m[0]
        # mesh position: gear_a's rotation relative to the line of centres through the planet's centre
        p_name = geo.planets[pm.planet - 1]
        za = geo.teeth[pm.gear_a]
        sa = geo.relative_sense[pm.gear_a]
        cyc = sa * za / (2 * math.pi)
        w = [((pm.gear_a, "theta"), cyc)] if pm.gear_a in rot else []
        w.append(((p_name, "eta"), -(cyc / rc)))
        alias = {g: (mem.planet if g in geo.planets else g) for g in (pm.gear_a, pm.gear_b)}
        couplings.append(Coupling(
            name=mn, gear_a=pm.gear_a, gear_b=pm.gear_b, table=tabs[pm.kind], v=tuple(v), w=tuple(w), v_rot=tuple(vr),
            phase=pm.phase, nominal_force_N=float(flow["force_N"][mn]), teeth=tuple(pm.teeth),
            base_radius_m=(abs(pm.moment_arm_m[pm.gear_a]), abs(pm.moment_arm_m[pm.gear_b])),
            tooth_passage=dict(pm.tooth_passage), line_of_action=tuple(nvec), group=pm.kind, gear_alias=alias,
            v_c=vc, nominal_coast_force_N=fc, backlash_m=float(pm.backlash_normal_m)))

    # ---------------------------------------------------------------- bodies, reference, rigid mode
    ab = geo.absolute_ratio
    w_ref = ab[inp]
    bodies = []
    u = []
    for body in list(central.values()) + list(geo.planets):
        m, j, kt, kr, radius = props_of(body)
        ratio = ab[body] / abs(w_ref)
        sense = math.copysign(1.0, ab[body]) if abs(ab[body]) > 1e-12 else geo.relative_sense.get(body, 1.0)
        z = geo.teeth.get(body, 0)
        kr_eff = krot.get(body, math.inf)
        bodies.append(Body(name=body, dofs=dofs[body], teeth=int(z), sense=float(sense), speed_ratio=float(ratio),
                           radius_m=float(radius), mass_kg=m, inertia_kgm2=j,
                           support=(kt if body not in geo.planets else kp, kr_eff)))
        if body in rot:
            u.append(((body, "theta"), ab[body] / w_ref))
    for p in geo.planets:
        u.append(((p, "eta"), rc * ab["carrier"] / w_ref))
    cycles_per_rad = geo.mesh_cycles_per_relative_rad / abs(w_ref)
    for pm in geo.meshes.values():  # every mesh advances z_s / 2 pi cycles per radian of the sun relative to the carrier
        rate = geo.relative_sense[pm.gear_a] * geo.teeth[pm.gear_a] * (ab[pm.gear_a] - ab["carrier"]) / (2 * math.pi)
        if abs(rate - geo.mesh_cycles_per_relative_rad) > 1e-9 * rate:
            raise ModelError(f"{model.name}: mesh '{pm.name}' does not advance with the kinematics (internal error)")
    torques = {}
    for body, t_ccw in flow["torque_ccw_Nm"].items():
        if body in rot:
            gb = next(b for b in bodies if b.name == body)
            torques[body] = gb.sense * t_ccw / torque
    zeta = model.damping.modal_damping_ratio if modal_damping_ratio is None else float(modal_damping_ratio)
    return Train(
        name=model.name, kind=PlanetaryKind.name, bodies=tuple(bodies), couplings=tuple(couplings), torque_Nm=torque,
        input_gear=inp, reference_gear=inp, modal_damping_ratio=zeta, force_law=force_law, springs=tuple(springs),
        gyroscopic=tuple(gyro), centripetal=tuple(centri), carrier_ratio=ab["carrier"] / abs(w_ref),
        rigid_mode=tuple(u), held_tolerance=1e-9, mesh_cycles_per_rad=cycles_per_rad, nominal_torques_per_Nm=torques,
        support_reports=tuple(b for b in central.values() if trans[b]),
        bearing_reports=() if trans["carrier"] else ("carrier",))


def planetary_error_inputs(model: Any, planet_count: int) -> dict:
    """What :func:`~hacgear_core.dynamics.gear_errors.with_gear_errors` needs for the manufacturing errors
    (``[gears.errors]``) of a planetary set with ``planet_count`` equally spaced planets, in the carrier frame.

    Every gear instance is its own gear of the carrier-frame train (``sun``, ``ring``, ``planet_1 .. planet_N``),
    each mesh instance (``sun_planet_i``, ``ring_planet_i``) its own coupling, so the teeth are tracked by the
    instances' tooth passages (:func:`~hacgear_core.geometry.planetary.planetary_geometry`): the sun's tooth at
    planet ``i``'s mesh is ``z_s psi_i / 2 pi`` teeth on from planet 1's, the ring's likewise in its sense, and a
    planet's teeth at its sun and ring meshes are half a revolution apart.  The planet gear's errors apply to every
    planet alike, each counted from its own tooth 0 (identical planets, mounted alike), but for the planets
    ``[[planetary.planet_errors]]`` gives errors of their own.  Runout direction
    (``runout_phase_rad`` from tooth 0's centre line in the gear's sense of rotation *relative to the carrier*): the
    sun's offset turns with the sun relative to the carrier, a planet's with the planet, the ring's with the ring
    (a fixed ring's at minus the carrier speed); at each mesh instance its line-of-action component is that of
    the offset's direction from the gear's centre to that mesh's pitch point (an internal ring: an offset towards
    the pitch point moves its teeth away from the planet, :func:`~hacgear_core.dynamics.gear_errors.
    mesh_error_profile` ``internal``).  The direction is counted from each instance's exact (fractional) tooth
    passage ``tp_g,k = tp_g,ref + (phase_k - phase_ref) + s_g z_g (theta_k - theta_ref) / 2 pi`` (``ref`` the
    gear's first mesh, ``theta`` the direction of the pitch point from the gear's centre, ``s_g`` its sense), not
    the integer one the pitch errors use: a planet's ring-mesh passage is a fraction of a cycle off the integer.

    Returns ``{"gears": {instance: (GearErrors, reference radius [m], normal module [m])}, "coast_pressure_angles_rad"
    (as "pressure_angles_rad", of the coast flanks), "pressure_angles_rad":
    {mesh: rad}, "internal_gears": (ring,), "runout_passage": {mesh: {gear: cycles}}}``.

    Raises
    ------
    ModelError
        A lumped model (no tooth geometry to count teeth on).
    """
    from hacgear_core.geometry import mesh_geometry
    if getattr(model, "lumped", False):
        raise ModelError(f"{model.path or model.name}: [gears.errors] need the tooth geometry; a lumped planetary "
                         "model has none")
    geo = planetary_geometry(model, planet_count)
    mem = geo.members
    rc = geo.carrier_radius_m
    gd = {g.name: g for g in model.gears}

    def data(name):
        g = gd[name]
        return g.errors, 0.5 * g.module_m * g.teeth, g.module_m * math.cos(g.helix_angle_rad)

    gears = {mem.sun: data(mem.sun), mem.ring: data(mem.ring), **{p: data(mem.planet) for p in geo.planets}}
    zp = gd[mem.planet].teeth
    for pe in model.planetary.planet_errors:    # a single planet's own errors in place of the planet gear's
        if pe.planet > len(geo.planets):
            raise ModelError(f"planetary.planet_errors: planet {pe.planet} [-] is not one of the {len(geo.planets)} "
                             f"planets; allowed: 1 .. {len(geo.planets)}")
        if pe.errors.single_pitch_deviations_m and len(pe.errors.single_pitch_deviations_m) != zp:
            raise ModelError(f"planetary.planet_errors (planet {pe.planet}): single_pitch_deviations_um [um] needs one "
                             f"value per tooth of '{mem.planet}' ({zp}), got "
                             f"{len(pe.errors.single_pitch_deviations_m)}")
        gears[geo.planets[pe.planet - 1]] = (pe.errors,) + gears[geo.planets[pe.planet - 1]][1:]
    mgeo = {kind: mesh_geometry(model, kind) for kind in (mem.sun_mesh, mem.ring_mesh)}
    alpha = {kind: g.operating_pressure_angle_rad for kind, g in mgeo.items()}
    alpha_c = {kind: g.operating_pressure_angle_coast_rad for kind, g in mgeo.items()}
    centre = {mem.sun: np.zeros(2), mem.ring: np.zeros(2)}
    for i, p in enumerate(geo.planets):
        centre[p] = rc * np.array([math.cos(geo.positions_rad[i]), math.sin(geo.positions_rad[i])])
    ref: dict[str, tuple] = {}
    passage: dict[str, dict[str, float]] = {}
    for mn, pm in geo.meshes.items():
        passage[mn] = {}
        for g in (pm.gear_a, pm.gear_b):
            d = np.asarray(pm.pitch_point_m, float) - centre[g]
            theta = math.atan2(d[1], d[0])
            tp = float(pm.tooth_passage[g])
            if g not in ref:
                ref[g] = (tp, float(pm.phase), theta)
                passage[mn][g] = tp
                continue
            tp0, ph0, th0 = ref[g]
            z = geo.teeth[g]
            exact = tp0 + (float(pm.phase) - ph0) + geo.relative_sense[g] * z * (theta - th0) / (2 * math.pi)
            off = exact - tp
            off -= z * round(off / z)
            # the integer passage where the exact one is whole (the sun, the ring), the exact one where it is a
            # fraction of a cycle off (a planet's far side)
            passage[mn][g] = tp + off if 1e-9 < abs(off) < 0.5 - 1e-9 else tp
    return {"gears": gears, "pressure_angles_rad": {mn: alpha[pm.kind] for mn, pm in geo.meshes.items()},
            "coast_pressure_angles_rad": {mn: alpha_c[pm.kind] for mn, pm in geo.meshes.items()},
            "internal_gears": (mem.ring,), "runout_passage": passage}


def _planets_fit(model: Any, count: int) -> bool:
    """Whether ``count`` equally spaced planets can be assembled in ``model``'s set without overlapping."""
    try:
        planetary_geometry(model, count)
    except (ModelError, GeometryError):
        return False
    return True


class PlanetaryKind(Kind):
    """Planetary sets: sun, ring, carrier and equally spaced planets (two table meshes, one per mesh kind)."""

    name = "planetary"
    section = "planetary"
    lumped = True
    rotating_carrier = True
    mesh_count = 2

    def members(self, model: Any) -> tuple[str, ...]:
        return tuple(g.name for g in model.gears) + ("carrier",)

    def bearing_stiffness(self, model: Any, member: str) -> float:
        if member == "carrier":
            return float(model.planetary.carrier_support.translational_stiffness_N_per_m)
        return super().bearing_stiffness(model, member)

    def with_bearing_stiffness(self, model: Any, stiffness: Mapping[str, float]) -> Any:
        model = super().with_bearing_stiffness(model, stiffness)
        if "carrier" not in stiffness:
            return model
        pl = model.planetary
        return replace(model, planetary=replace(pl, carrier_support=replace(
            pl.carrier_support, translational_stiffness_N_per_m=float(stiffness["carrier"]))))

    def check(self, model: Any) -> None:
        if model.planetary is None:
            raise ModelError(f"system.kind = '{self.name}' needs a [planetary] table (planet_count)")
        super().check(model)

    def nominal_mesh_forces(self, model: Any, base_radii: Mapping[str, tuple[float, float]]) -> dict[str, float]:
        # per-planet forces of the planetary torque flow (any input member; tables are per mesh kind)
        flow = planetary_torques(model, planetary_geometry(model))
        return {m.name: flow["force_N"][f"{m.name}_1"] for m in model.meshes}

    def train(self, model: Any, tables: Any, **options) -> Train:
        return planetary_from_model(model, tables, **options)

    def structural_parameters(self, model: Any) -> tuple[StructuralParameter, ...]:
        """``planet_count``: every count of :data:`~hacgear_core.model.schema.RANGES` ``planet_count`` up to the
        largest whose equally spaced planets the set can assemble without overlapping (the range the command
        line's ``--planets`` has too)."""
        n = model.planetary.planet_count
        r = RANGES["planet_count"]
        n_max = max([k for k in range(int(r.lo), int(r.hi) + 1) if _planets_fit(model, k)] + [n])
        return (StructuralParameter(
            "planet_count", n, int(r.lo), n_max,
            f"number of equally spaced planets (1 to {n_max}"
            + (": more do not fit this set" if n_max < r.hi else "") + "); outputs of planets beyond it "
            "read 0 (the tables are per mesh kind: one FMU serves every count its tables' load range allows)"),)
