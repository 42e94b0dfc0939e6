"""Lead slope deviations, shaft misalignment and axis deviations of meshes with a twist axis: a constant mesh twist offset.

Helical meshes, and spur pairs whose tables have a twist axis (``[statics] twist_points > 1``; helix angle 0, where
the offset is exact: docs/helical.md, "Spur pairs").

The generalized tables of a helical mesh hold the mesh force W and the twist moment M over (position, deflection,
mesh twist ``gamma = (theta_a - theta_b) . e1``), ``e1`` the normal to the plane of action (docs/helical.md,
"Definitions").  A rigid relative rotation ``gamma`` about ``e1`` through the reference point closes the flanks at
the point ``(S, zeta)`` of the plane of action (``S`` along the transverse line of action, ``zeta`` axially from
the reference plane) by ``gamma (S sin beta_b - zeta cos beta_b)`` (normal to the flank).

* **In-plane shaft misalignment** ``psi`` (``[[meshes]] misalignment_in_plane_urad``): the installed relative tilt
  of the axes in the plane of action is exactly such a rotation, so the flanks meet at the mesh twist
  ``gamma + psi``.  A tilt about another axis parallel to ``e1`` adds a translation, whose component along the
  flank normal is a constant approach (taken up by the gears' rotations) and whose other components leave the
  gaps unchanged to first order.
* **Lead slope deviation** ``f_Hbeta,g`` of gear ``g`` (``[gears.errors] lead_slope_um``: over its face width
  ``b_g``, along the transverse line of action, positive = material added at its +z end) moves the flank of every
  transverse section at ``z`` by ``f_g (z - z_g) / b_g`` (transverse), which closes the gap by ``cos beta_b f_g
  zeta / b_g`` (normal) plus a constant.  The twist that gives the same closure along the face is
  ``gamma_0 = -(f_a / b_a + f_b / b_b)``; it differs from the lead slope by the closure ``-gamma_0 S sin beta_b``,
  linear along the path of contact (a profile-slope-like term, zero for spur gears, ``beta_b = 0``): for a helical
  mesh the twist offset is a linearisation of the lead slope, exact in its variation across the face and not in
  its variation along the path of contact (docs/helical.md, "Lead slope and misalignment").

* **Axis parallelism deviations** ``f_Sigma_delta``, ``f_Sigma_beta`` (ISO 10064-4 / ISO 1328; ``[[meshes]]
  axis_deviation_in_axes_plane_urad``, ``axis_deviation_normal_to_axes_plane_urad``, as angles: the deviation
  over the bearing span divided by the span).  In the table's frame (``x`` the line of centres from gear_a to
  gear_b, ``z`` the axes, ``y = z x x`` the normal to the plane of the axes) they are the rotation vector of gear_b's
  axis relative to gear_a's ``omega = f_Sigma_beta x + f_Sigma_delta y`` (right-handed: a positive
  ``f_Sigma_delta`` turns the +z end of gear_b's axis towards +x, away from gear_a, a positive ``f_Sigma_beta``
  towards -y).  Its component on ``e1`` is an in-plane misalignment ``psi_ISO = -omega . e1`` (exact: the twist
  ``(theta_a - theta_b) . e1`` of that rigid rotation); the rest, ``omega_l = omega . e2`` about the transverse
  line of action ``e2 = z x e1``, moves the drive flanks along ``e1``, tangent to them: their gap changes only to
  second order (:func:`out_of_plane_gap_m`) and it is not modelled on the drive side.  The coast flanks see the
  whole rotation on their own twist axis (``omega . e2`` is first order there).

* **Out-of-plane misalignment** ``omega_l`` (``[[meshes]] misalignment_out_of_plane_urad``): the rotation of gear_b's
  axis relative to gear_a's about the transverse line of action ``e2``; it adds to the axis deviations' ``omega_l``
  (second order on the drive flanks, :func:`out_of_plane_gap_m`; first order on the coast flanks' twist axis).

All together: the flanks meet at ``gamma + gamma_0``, ``gamma_0 = psi + psi_ISO - f_a / b_a - f_b / b_b``.  The system's
copy of the mesh table carries ``gamma_0`` as its :attr:`~hacgear_core.tables.table.TwistTable.twist_offset_rad`:
every lookup (the compiled kernel's trilinear rule through the twist origin it is handed, the Python force law,
strains, pressures, the static equilibrium and the FMUs, which build the same system) reads the grid at ``gamma +
gamma_0``.  The coast flanks keep their ideal lead (as for pitch errors); the misalignment reaches them as the
rotation ``(psi + psi_ISO) e1 - omega_l e2`` projected on their own twist axis ``e1_c``.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from hacgear_core.errors import ModelError

__all__ = ["lead_twist_offset_rad", "axis_deviation_rotation", "twist_offsets_rad", "out_of_plane_gap_m",
           "with_twist_offsets", "check_lead_inputs", "MESH_INPUTS"]


def lead_twist_offset_rad(lead_slope_m: tuple[float, float], face_width_m: tuple[float, float],
                          misalignment_rad: float = 0.0) -> float:
    """The mesh twist [rad] at which the flanks of a helical mesh meet at zero rigid twist: ``psi - f_a / b_a -
    f_b / b_b`` (module docstring).

    Parameters
    ----------
    lead_slope_m : (float, float)
        Lead slope deviations ``f_Hbeta`` [m] of gear_a and gear_b (``GearErrors.lead_slope_m``).
    face_width_m : (float, float)
        Their face widths ``b`` [m] (> 0).
    misalignment_rad : float
        In-plane misalignment ``psi`` [rad] (``Mesh.misalignment_in_plane_rad``).
    """
    if not all(b > 0 for b in face_width_m):
        raise ModelError(f"face_width_m [m] must be > 0, got {face_width_m!r}")
    return float(misalignment_rad) - sum(float(f) / float(b) for f, b in zip(lead_slope_m, face_width_m))


def axis_deviation_rotation(in_axes_plane_rad: float, normal_to_axes_plane_rad: float) -> np.ndarray:
    """The rotation vector (3,) [rad] of gear_b's axis relative to gear_a's in a mesh table's frame (``x`` the line
    of centres from gear_a to gear_b, ``z`` the axes, ``y = z x x``) of the ISO axis parallelism deviations:
    ``f_Sigma_beta x + f_Sigma_delta y`` (module docstring).

    Parameters
    ----------
    in_axes_plane_rad : float
        ``f_Sigma_delta`` [rad] (``Mesh.axis_deviation_in_axes_plane_rad``): a rotation about ``y``, the normal to
        the plane of the axes; positive turns the +z end of gear_b's axis towards +x.
    normal_to_axes_plane_rad : float
        ``f_Sigma_beta`` [rad] (``Mesh.axis_deviation_normal_to_axes_plane_rad``): a rotation about ``x``, the line
        of centres; positive turns the +z end of gear_b's axis towards -y.
    """
    return np.array([float(normal_to_axes_plane_rad), float(in_axes_plane_rad), 0.0])


def _plane_axes(r_twist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(e1, e2)`` (3,) of a twist vector ``[0, e1, 0, -e1]``: the normal to the plane of action and the transverse
    line of action ``e2 = z x e1`` (``e1 = e2 x z``, docs/helical.md "Definitions")."""
    e1 = np.asarray(r_twist, float)[3:6]
    return e1, np.array([-e1[1], e1[0], 0.0])


def _axis_misalignment(mesh: Any, e1: np.ndarray, e2: np.ndarray) -> tuple[float, float]:
    """``(psi_ISO, omega_l)`` [rad] of ``mesh``'s axis deviations: the in-plane share ``-omega . e1`` and the
    rotation ``omega . e2`` about the transverse line of action."""
    fd = float(getattr(mesh, "axis_deviation_in_axes_plane_rad", 0.0))
    fb = float(getattr(mesh, "axis_deviation_normal_to_axes_plane_rad", 0.0))
    if fd == 0.0 and fb == 0.0:
        return 0.0, 0.0
    # omega = (fb, fd, 0): the two products summed in Python floats (no fused multiply-add), so that a rotation
    # along e1 given as (k e1_x, k e1_y) with k a power of two has omega . e2 exactly 0
    return -(fb * float(e1[0]) + fd * float(e1[1])), fb * float(e2[0]) + fd * float(e2[1])


def twist_offsets_rad(model: Any, mesh: Any, r_twist: np.ndarray, r_twist_coast: np.ndarray | None
                      ) -> tuple[float, float]:
    """``(gamma_0, gamma_0c)`` [rad] of ``mesh`` of ``model``: the drive flanks' twist offset (lead slopes of both
    gears, the in-plane misalignment ``psi`` and the in-plane share ``psi_ISO`` of the axis deviations) and the
    coast flanks' (the relative rotation ``(psi + psi_ISO) e1 - omega_l e2`` on the coast twist axis ``e1_c``,
    ``omega_l`` the axis deviations' share about the transverse line of action plus the out-of-plane
    misalignment; the coast flanks keep their ideal lead).  ``r_twist`` (12,) and ``r_twist_coast`` (12,) the two sides' twist
    vectors ``[0, e1, 0, -e1]`` in the table's frame (None: no coast side)."""
    gears = {g.name: g for g in model.gears}
    ga, gb = gears[mesh.gear_a], gears[mesh.gear_b]
    lead = tuple(getattr(getattr(g, "errors", None), "lead_slope_m", 0.0) for g in (ga, gb))
    e1, e2 = _plane_axes(r_twist)
    psi_iso, omega_l = _axis_misalignment(mesh, e1, e2)
    omega_l += float(getattr(mesh, "misalignment_out_of_plane_rad", 0.0))
    psi = float(getattr(mesh, "misalignment_in_plane_rad", 0.0)) + psi_iso
    g0 = lead_twist_offset_rad(lead, (ga.face_width_m, gb.face_width_m), psi)
    if r_twist_coast is None or (psi == 0.0 and omega_l == 0.0):
        return g0, 0.0
    e1c = np.asarray(r_twist_coast, float)[3:6]
    return g0, psi * float(e1 @ e1c) - omega_l * float(e2 @ e1c)


def out_of_plane_gap_m(omega_l_rad: float, zeta_max_m: float, center_distance_m: float,
                       transverse_pressure_angle_rad: float, base_helix_angle_rad: float) -> float:
    """The flank gap change [m] (normal to the flanks, opening) of a rotation ``omega_l`` of gear_b about the
    transverse line of action through its centre, at the axial distance ``zeta_max`` from its centre plane: the
    flanks move along ``e1`` by ``d = omega_l zeta``, tangent to them, and two involute helicoids with normal radii
    of curvature ``rho_t / cos beta_b`` (``rho_ta + rho_tb = a_w sin alpha_wt`` for an external pair) separate by
    ``d^2 cos beta_b / (2 a_w sin alpha_wt)`` (two touching cylinders shifted along their common tangent),
    second order in the angle.

    Parameters
    ----------
    omega_l_rad : float
        The rotation about the line of action [rad].
    zeta_max_m : float
        The largest axial distance of the contact from gear_b's centre plane [m].
    center_distance_m : float
        ``a_w`` [m] (> 0).
    transverse_pressure_angle_rad : float
        ``alpha_wt`` [rad] in (0, pi/2).
    base_helix_angle_rad : float
        ``beta_b`` [rad].
    """
    if not center_distance_m > 0 or not 0.0 < transverse_pressure_angle_rad < 0.5 * math.pi:
        raise ModelError(f"center_distance_m [m] must be > 0 and alpha_wt [rad] in (0, pi/2), got "
                         f"{center_distance_m!r}, {transverse_pressure_angle_rad!r}")
    d = float(omega_l_rad) * float(zeta_max_m)
    return d * d * math.cos(base_helix_angle_rad) / (
        2.0 * center_distance_m * math.sin(transverse_pressure_angle_rad))


#: the mesh inputs that act through the twist offset: (model-file key [urad], Mesh field [rad])
MESH_INPUTS = (("misalignment_in_plane_urad", "misalignment_in_plane_rad"),
                ("misalignment_out_of_plane_urad", "misalignment_out_of_plane_rad"),
                ("axis_deviation_in_axes_plane_urad", "axis_deviation_in_axes_plane_rad"),
                ("axis_deviation_normal_to_axes_plane_urad", "axis_deviation_normal_to_axes_plane_rad"))


def _shifted(table: Any, offset: float, side: str, mesh_name: str, what: str) -> Any:
    tw = table.twist
    lo, hi = float(tw.twist_rad[0]), float(tw.twist_rad[-1])
    if not lo <= offset <= hi:
        raise ModelError(
            f"mesh '{mesh_name}': {what} make the {side} flanks meet at the mesh twist {offset * 1e6:+.1f} urad, "
            f"outside the table's twist axis [{lo * 1e6:+.1f}, {hi * 1e6:+.1f}] urad; recompute the tables with "
            f"[statics] max_twist_mrad [mrad] above {abs(offset) * 1e3:.3g} (with margin for the dynamic twist) and "
            "hacgear statics, or reduce the error")
    return replace(table, twist=replace(tw, twist_offset_rad=offset))


def with_twist_offsets(table: Any, model: Any, mesh: Any, r_twist_coast: np.ndarray | None = None) -> Any:
    """``table`` (a :class:`~hacgear_core.tables.MeshTable` with a twist axis) as the system uses it for ``mesh``
    of ``model``: a copy whose drive side (and coast side with its twist axis) reads the grid at the mesh twist
    plus the offsets of :func:`twist_offsets_rad`; ``table`` itself when both are 0 (so a model without lead
    errors or misalignment runs on the very same arrays).  An offset outside the table's twist axis is a
    ModelError naming the inputs, the axis and the fix.  ``r_twist_coast``: the coast twist vector (12,) (default
    the coast table's)."""
    tw = table.twist
    coast = getattr(table, "coast", None)
    ctw = getattr(coast, "twist", None)
    if r_twist_coast is None and ctw is not None:
        r_twist_coast = ctw.r_twist
    g0, g0c = twist_offsets_rad(model, mesh, tw.r_twist, r_twist_coast)
    if g0 == 0.0 and g0c == 0.0:
        return table
    gears = {g.name: g for g in model.gears}
    parts = [f"[gears.errors] lead_slope_um = {g.errors.lead_slope_m * 1e6:g} um of '{g.name}' (face width "
             f"{g.face_width_m * 1e3:g} mm)" for g in (gears[mesh.gear_a], gears[mesh.gear_b])
             if getattr(getattr(g, "errors", None), "lead_slope_m", 0.0) != 0.0]
    for key, attr in MESH_INPUTS:
        if getattr(mesh, attr, 0.0) != 0.0:
            parts.append(f"[[meshes]] {key} = {getattr(mesh, attr) * 1e6:g} urad")
    what = " and ".join(parts)
    out = _shifted(table, g0, "drive", mesh.name, what) if g0 != 0.0 else table
    if g0c != 0.0 and ctw is not None:
        out = replace(out, coast=_shifted(coast, g0c, "coast", mesh.name, what))
    return out


def check_lead_inputs(model: Any, system: Any) -> None:
    """Refuse lead slope deviations, in-plane misalignment and axis deviations on meshes that do not run on a table
    with a twist axis (spur meshes without one, lumped models, planetary sets): ModelError naming the inputs and what
    they need."""
    gears = {g.name: g for g in getattr(model, "gears", ())}
    twist = {c.name: c.t is not None and getattr(getattr(c, "table", None), "twist", None) is not None
             for c in system.meshes}
    bad = []
    for m in getattr(model, "meshes", ()):
        lead = [n for n in (m.gear_a, m.gear_b) if n in gears
                and getattr(getattr(gears[n], "errors", None), "lead_slope_m", 0.0) != 0.0]
        mis = [key for key, attr in MESH_INPUTS if getattr(m, attr, 0.0) != 0.0]
        if (lead or mis) and not twist.get(m.name, False):
            what = [f"[gears.errors] lead_slope_um of {lead}"] if lead else []
            what += [f"[[meshes]] {key}" for key in mis]
            bad.append(f"mesh '{m.name}' ({' and '.join(what)})")
    if bad:
        raise ModelError(
            f"{model.path or model.name}: {', '.join(bad)}: lead slope deviations and shaft misalignment act "
            "through the mesh twist, which needs the mesh's table with a twist axis; hacgear statics computes it "
            "for helical meshes and spur pairs ([statics] twist_points > 1, max_twist_mrad), not for idler chains, "
            "the spur stages of gear trains and gearboxes, lumped models or planetary sets: leave these keys out "
            "there")
