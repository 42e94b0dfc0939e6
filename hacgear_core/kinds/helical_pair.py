"""Helical pairs (kind ``helical_pair``): model + generalized tables -> the 12-DOF train (dissertation Eq. 5.1).

DOFs (global frame of docs/helical.md: x along the line of centres, z along the axes)::

    q = [u_a (x, y, z), theta_a (x, y, z), u_b (x, y, z), theta_b (x, y, z)]      (12,)

translations [m] of each gear's centre ``O_g`` (on its axis, mid-face) and small rotations [rad] about it.  Mesh
deflection ``x = r_mesh . q`` and mesh twist ``gamma = r_twist . q`` with the vectors stored in the table (the
dissertation's Eq. 5.4 with its slips fixed, docs/helical.md); the mesh puts ``W r_mesh + M r_twist`` on the DOFs
(W, M from one trilinear lookup over (position, deflection, twist) in the compiled kernel).  With the coast side
in the table (``table.coast`` with its twist axis) the coast flanks do the same with the coast table's vectors:
coast approach ``xc = r_mesh_c . q``, coast twist ``gamma_c = r_twist_c . q``, ``Wc r_mesh_c + Mc r_twist_c``, so
either torque sign is carried (a negative torque loads the coast flanks).  A drive-only table (an older file, or
one computed without its coast side) gets the coast flanks' vectors from the geometry (:func:`coast_vectors`)
and a force-free coast side that ends at the backlash: the range guard counts every step whose coast approach
passes it (the teeth would pass through each other), and a negative torque is refused.

Masses and polar inertias from :func:`hacgear_core.geometry.gear_geometry` (as ``hacgear info``); the tilting
inertia about a diameter through ``O_g`` is ``I_p / 2 + m b^2 / 12`` (exact for a body of uniform section over
the face width b whose section has >= 3-fold symmetry, as a gear's).  Supports ``[gears.support]`` (Table 5.1):
translational stiffness on x and y, axial on z, tilting on theta_x and theta_y, rotational on theta_z (the shaft;
dropped with ``shafts=False`` for drivetrain coupling).  Gyroscopic terms of the spinning gears are not modelled
(``G = 0``; at 3 kHz mesh frequency the pinion turns at 107 Hz, and the tilting modes lie far above).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from hacgear_core.dynamics.lead import with_twist_offsets
from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry, mesh_geometry, nominal_mesh_forces
from hacgear_core.kinds.base import Body, Coupling, Dof, Kind, KeyVector, Support, Train, mesh_table

__all__ = ["HelicalPair", "helical_from_model", "DOF_LABELS", "RIGID_SUPPORT_STIFFNESS", "tilting_inertia_kgm2",
           "coast_vectors"]

#: labels of a gear's six DOFs, in order
DOF_LABELS = ("x", "y", "z", "theta_x", "theta_y", "theta_z")
#: a rigid translational or tilting support of a helical gear is a spring of this stiffness [N/m or N m/rad]: the
#: gear keeps those DOFs (the table's 12-vectors are over all of them); a held rotation (inf) leaves theta_z out
RIGID_SUPPORT_STIFFNESS = 1e15


def tilting_inertia_kgm2(mass_kg: float, polar_inertia_kgm2: float, face_width_m: float) -> float:
    """Moment of inertia [kg m^2] of a gear about a diameter through its centre: ``I_p / 2 + m b^2 / 12``."""
    return 0.5 * polar_inertia_kgm2 + mass_kg * face_width_m ** 2 / 12.0


def coast_vectors(frame: dict, coast_pressure_angle_rad: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The coast flanks' mesh vectors of a helical mesh from its drive flanks' frame (docs/helical.md, "The coast
    side"): ``(r_mesh_c (12,), r_twist_c (12,), base_helix_angle_c [rad])``.

    At the pitch point the coast line of action is the drive one mirrored about the line of centres (the global
    ``x`` axis) at the coast flanks' operating pressure angle ``alpha_c``: transverse normal
    ``(sign(n_x) sin alpha_c, -sign(n_y) cos alpha_c)``.  Both flanks of a gear lie on helicoids of one lead, so
    the normal's axial component over its transverse length is proportional to the transverse normal's ``y``
    component (the moment arm about gear_a's axis): ``n_z,c / |n_t,c| = (n_z / |n_t|) n_y,c / n_y``.  The vectors
    follow as for the drive side: ``r_mesh = [n, (P_ref - O_a) x n, -n, -(P_ref - O_b) x n]``, ``r_twist = [0, e1,
    0, -e1]`` with ``e1 = e2 x e3``, ``e2`` the transverse line of action; ``xc = r_mesh_c . q`` is the coast
    approach from the drive kinematic position (positive closing the backlash).

    Parameters
    ----------
    frame : dict
        The drive table's ``twist.frame``: ``n_ref`` (3,), ``P_ref`` (3,) [m], ``O_a``, ``O_b`` (3,) [m], ``e3``.
    coast_pressure_angle_rad : float
        Operating transverse pressure angle of the coast flanks [rad] (``mesh_geometry``), in (0, pi/2).
    """
    if not (0.0 < coast_pressure_angle_rad < 0.5 * math.pi):
        raise ModelError(f"coast operating pressure angle [rad] must be in (0, pi/2), got {coast_pressure_angle_rad!r}")
    n = np.asarray(frame["n_ref"], float)
    nt = math.hypot(n[0], n[1])
    sin_c, cos_c = math.sin(coast_pressure_angle_rad), math.cos(coast_pressure_angle_rad)
    t_c = np.array([math.copysign(sin_c, n[0]), -math.copysign(cos_c, n[1])])
    n_c = np.array([t_c[0], t_c[1], (n[2] / nt) * t_c[1] / (n[1] / nt)])
    n_c /= np.linalg.norm(n_c)
    p = np.asarray(frame["P_ref"], float)
    e1 = np.cross(np.array([t_c[0], t_c[1], 0.0]), np.asarray(frame["e3"], float))
    r_mesh = np.concatenate([n_c, np.cross(p - np.asarray(frame["O_a"], float), n_c), -n_c,
                             -np.cross(p - np.asarray(frame["O_b"], float), n_c)])
    r_twist = np.concatenate([np.zeros(3), e1, np.zeros(3), -e1])
    return r_mesh, r_twist, math.asin(float(np.clip(n_c[2], -1.0, 1.0)))


def helical_from_model(model: Any, tables: Any, *, force_law: str = "hac", torque_Nm: float | None = None,
                       bearing_stiffness_N_per_m: float | None = None, modal_damping_ratio: float | None = None,
                       shafts: bool = True, tilting_stiffness_Nm_per_rad: float | None = None) -> Train:
    """The 12-DOF train description of a helical pair model on its generalized mesh table.

    Parameters
    ----------
    model : Model
        A ``helical_pair`` model (two gears, one mesh); a ``spur_pair`` with a table with a twist axis (the
        face-resolving solver's, helix angle 0) gets the same 12-DOF model.
    tables : SystemTables, {mesh: MeshTable} or MeshTable
        The mesh's table with a twist axis (format version 2).
    force_law : str
        ``hac`` only (the generalized FDF).
    torque_Nm : float, optional
        Nominal torque on ``[operating] torque_gear`` [N m] (> 0; default the model's).
    bearing_stiffness_N_per_m : float, optional
        Overrides the translational (x, y) support stiffness of both gears [N/m] (inf: rigid, the DOFs stay with
        a stiffness of 1e15 N/m: every gear keeps its six DOFs).
    modal_damping_ratio : float, optional
        Default ``[damping] modal_damping_ratio``.
    shafts : bool
        Keep the rotational (theta_z) support stiffnesses (constant-speed experiment); False gives the pair its
        free rotation (drivetrain coupling).
    tilting_stiffness_Nm_per_rad : float, optional
        Overrides both gears' tilting stiffness [N m/rad].

    Returns
    -------
    Train
        12 DOFs, one coupling with its twist vector (mesh law ``twist``).
    """
    if len(model.gears) != 2 or len(model.meshes) != 1:
        raise ModelError(f"helical builder: a pair of two gears and one mesh, got {len(model.gears)} gears, "
                         f"{len(model.meshes)} meshes")
    if force_law != "hac":
        raise ModelError(f"helical pairs take the HAC generalized force law only, got force_law={force_law!r}")
    mesh = model.meshes[0]
    table = mesh_table(tables, mesh.name)
    tw = getattr(table, "twist", None)
    if tw is None:
        raise ModelError(f"mesh '{mesh.name}': the table has no twist axis (a helical pair needs its generalized "
                         "table: hacgear statics)")
    gears = {g.name: g for g in model.gears}
    names = (mesh.gear_a, mesh.gear_b)
    tz = tuple(int(z) for z in table.teeth)
    if tz != (gears[names[0]].teeth, gears[names[1]].teeth):
        raise ModelError(f"mesh '{mesh.name}': the table's teeth {tz} differ from the model's "
                         f"{(gears[names[0]].teeth, gears[names[1]].teeth)} (table of another model?)")
    torque = float(model.operating.torque_Nm if torque_Nm is None else torque_Nm)
    ctw = getattr(getattr(table, "coast", None), "twist", None)
    if not (math.isfinite(torque) and torque != 0):
        raise ModelError(f"torque_Nm [N*m] must be finite and nonzero (negative: the coast flanks carry it), "
                         f"got {torque!r}")
    if torque < 0 and ctw is None:
        raise ModelError(f"torque_Nm = {torque!r} N*m loads the coast flanks, but the table of mesh '{mesh.name}' "
                         "has no coast side with a twist axis (regenerate it: hacgear statics)")
    tgear = getattr(model.operating, "torque_gear", names[0]) or names[0]
    if tgear not in names:
        raise ModelError(f"[operating] torque_gear {tgear!r} is not a gear of the pair {names}")
    zeta = float(model.damping.modal_damping_ratio if modal_damping_ratio is None else modal_damping_ratio)
    # lead slope deviations and in-plane misalignment: the system's table reads the grid at the mesh twist plus
    # their offset (dynamics/lead.py); the coast side gets the misalignment on its own twist axis
    table = with_twist_offsets(table, model, mesh)
    tw = table.twist
    r_mesh = np.asarray(tw.r_mesh, float)
    r_twist = np.asarray(tw.r_twist, float)
    lever = np.asarray(tw.lever_arm_m, float)
    keys = [(g, lab) for g in names for lab in DOF_LABELS]
    bodies = []
    sense = (math.copysign(1.0, r_mesh[5]), math.copysign(1.0, -r_mesh[11]))
    u = (1.0, -r_mesh[5] / r_mesh[11])
    for gi, name in enumerate(names):
        g = gears[name]
        gg = gear_geometry(g)
        m, ip = float(gg.mass_kg), float(gg.inertia_kgm2)
        it = tilting_inertia_kgm2(m, ip, g.face_width_m)
        sup = g.support
        kt = sup.translational_stiffness_N_per_m if bearing_stiffness_N_per_m is None else bearing_stiffness_N_per_m
        ktilt = sup.tilting_stiffness_Nm_per_rad if tilting_stiffness_Nm_per_rad is None \
            else tilting_stiffness_Nm_per_rad
        krot = sup.rotational_stiffness_Nm_per_rad if shafts else 0.0
        kdiag = [kt, kt, sup.axial_stiffness_N_per_m, ktilt, ktilt]
        # rigid bearings as very stiff springs; a rotation held (inf) follows the kinematics (its DOF left out)
        kdiag = [min(float(k), RIGID_SUPPORT_STIFFNESS) for k in kdiag] + [float(krot)]
        o = 6 * gi
        bodies.append(Body(name=name, dofs=tuple(Dof(lab, mi, Support(k), d) for lab, mi, k, d in zip(
                               DOF_LABELS, (m, m, m, it, it, ip), kdiag, ((1.0, 0.0), (0.0, 1.0), None, None, None,
                                                                           None))),
                           teeth=g.teeth, sense=sense[gi], speed_ratio=float(u[gi] * sense[0]), rotation="theta_z",
                           radius_m=float(abs(r_mesh[o + 5])), mass_kg=m, inertia_kgm2=ip, support=(kdiag[0], krot)))
    # nominal mesh force: the torque on its gear over that gear's lever arm (r_b cos beta_b); the nominal forces
    # are magnitudes, the torque's sign picks the flanks
    w_nom = abs(torque) / float(lever[names.index(tgear)])
    coast = {}
    if ctw is not None:
        cb = math.cos(float(ctw.base_helix_angle_rad))
        coast = dict(v_c=_over(keys, ctw.r_mesh), t_c=_over(keys, ctw.r_twist),
                     nominal_coast_force_N=abs(torque) / float(np.asarray(ctw.lever_arm_m, float)[names.index(tgear)]),
                     backlash_m=float(table.coast.backlash_normal_m) * cb)
    else:
        # drive-only table: the coast flanks' vectors from the geometry, a force-free coast side up to the backlash
        mg = mesh_geometry(model, mesh.name, strict=False)
        if math.isfinite(mg.backlash_normal_m) and mg.backlash_normal_m >= 0:
            vc, tc, bc = coast_vectors(tw.frame, float(mg.operating_pressure_angle_coast_rad))
            coast = dict(v_c=_over(keys, vc), t_c=_over(keys, tc), backlash_m=float(mg.backlash_normal_m) * math.cos(bc))
    coupling = Coupling(name=mesh.name, gear_a=names[0], gear_b=names[1], table=table, v=_over(keys, r_mesh),
                        w=((keys[5], sense[0] * tz[0] / (2 * math.pi)),),
                        v_rot=((keys[5], r_mesh[5]), (keys[11], r_mesh[11])), phase=0.0, nominal_force_N=float(w_nom),
                        teeth=tz, base_radius_m=tuple(float(r) for r in table.base_radius_m), law="twist",
                        tooth_passage={names[0]: 0, names[1]: 0},
                        line_of_action=tuple(float(c) for c in np.asarray(tw.frame["e2"], float)[:2]),
                        t=_over(keys, r_twist), **coast)
    return Train(name=model.name, kind=HelicalPair.name, bodies=tuple(bodies), couplings=(coupling,),
                 torque_Nm=torque, input_gear=tgear, reference_gear=names[0], modal_damping_ratio=zeta,
                 force_law=force_law, rigid_mode=((keys[5], u[0]), (keys[11], u[1])))


def _over(keys, values) -> KeyVector:
    """The KeyVector of a (12,) vector over the pair's DOF keys."""
    return tuple(zip(keys, (float(x) for x in np.asarray(values, float))))


class HelicalPair(Kind):
    """Helical pairs: two gears on six-DOF supports, one mesh on its generalized table."""

    name = "helical_pair"
    helical = True
    mesh_count = 1

    def nominal_mesh_forces(self, model: Any, base_radii) -> dict[str, float]:
        return nominal_mesh_forces(model, base_radii)

    def train(self, model: Any, tables: Any, **options) -> Train:
        return helical_from_model(model, tables, **options)
