"""ISO 10064-4 axis parallelism deviations f_Sigma_delta, f_Sigma_beta as mesh inputs (hacgear_core.dynamics.lead).

Physics asserted: the deviations are the rotation omega = f_Sigma_beta x + f_Sigma_delta y of gear_b's axis relative
to gear_a's (x the line of centres, y the normal to the plane of the axes); its share about the normal e1 to the
plane of action is an in-plane misalignment psi_ISO = -omega . e1 (f_Sigma_delta sin alpha_wt, -f_Sigma_beta cos
alpha_wt on helical_28_33), equal to the mesh twist of the rigid rotation of gear_b in the 12-DOF model and to the
linear part of its exact flank closure over the plane of action; the rest (about the line of action) moves the
drive flanks tangent to themselves (no first-order closure; second-order gap bound); a combination with no
out-of-plane part builds the same system as the direct misalignment input; zero inputs change nothing.
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hacgear_core.dynamics.lead import axis_deviation_rotation, out_of_plane_gap_m, twist_offsets_rad
from hacgear_core.errors import ModelError
from hacgear_core.geometry.mesh import mesh_geometry
from hacgear_core.kinds import build_system, load_model, parse_model
from hacgear_core.model.provenance import model_values_sha256
from hacgear_core.model.schema import Mesh
from hacgear_core.tables import load_system_tables

MODELS = Path(__file__).resolve().parents[1] / "models"


def _iso(model, f_delta=0.0, f_beta=0.0, psi=0.0, name=None):
    return replace(model, meshes=tuple(
        replace(m, misalignment_in_plane_rad=psi, axis_deviation_in_axes_plane_rad=f_delta,
                axis_deviation_normal_to_axes_plane_rad=f_beta) if name in (None, m.name) else m
        for m in model.meshes))


def test_deviations_project_on_the_normal_to_the_plane_of_action(helical, table):
    """f_Sigma_delta alone: psi = f sin alpha_wt; f_Sigma_beta alone: psi = -f cos alpha_wt (alpha_wt of the mesh
    geometry; e1 = (cos alpha_wt, -sin alpha_wt, 0) in the table); the coast side takes the whole rotation."""
    aw = mesh_geometry(helical, "m12").operating_pressure_angle_rad
    e1 = table.twist.r_twist[3:6]
    assert e1 == pytest.approx([math.cos(aw), -math.sin(aw), 0.0], abs=1e-9)
    r, rc = table.twist.r_twist, table.coast.twist.r_twist
    f = 2e-4
    g0, g0c = twist_offsets_rad(_iso(helical, f_delta=f), _iso(helical, f_delta=f).meshes[0], r, rc)
    assert g0 == pytest.approx(f * math.sin(aw), rel=1e-9)
    w = np.array([0.0, f, 0.0])
    assert g0c == pytest.approx(-float(w @ rc[3:6]), rel=1e-12)
    g0, g0c = twist_offsets_rad(_iso(helical, f_beta=f), _iso(helical, f_beta=f).meshes[0], r, rc)
    assert g0 == pytest.approx(-f * math.cos(aw), rel=1e-9)
    assert g0c == pytest.approx(-f * float(rc[3]), rel=1e-12)
    # the offsets add to the direct misalignment and the lead slopes, one offset on the system's table
    sy = build_system(_iso(helical, 1e-4, 1e-4, 5e-5), {"m12": table})
    assert sy.meshes[0].table.twist.twist_offset_rad == pytest.approx(
        5e-5 + 1e-4 * (math.sin(aw) - math.cos(aw)), rel=1e-9)


def test_rigid_rotation_of_gear_b_gives_the_converted_twist(helical, table):
    """omega applied as a rigid rotation of gear_b (its theta DOFs) in the 12-DOF model: gamma = r_twist . q is the
    conversion's psi_ISO, and the exact rigid closure -(omega x (P - O_b)) . n_ref at points P = P_ref + S e2 +
    zeta e3 of the plane of action is x + gamma (S sin beta_b - zeta cos beta_b) (x = r_mesh . q): the rotation
    about the line of action adds nothing to first order."""
    tw = table.twist
    fr = tw.frame
    n, p, ob = (np.asarray(fr[k], float) for k in ("n_ref", "P_ref", "O_b"))
    e2, e3 = np.asarray(fr["e2"], float), np.asarray(fr["e3"], float)
    sb = math.sin(tw.base_helix_angle_rad)
    cb = math.cos(tw.base_helix_angle_rad)
    for f_d, f_b in ((3e-4, 0.0), (0.0, -2e-4), (1.5e-4, 2.5e-4)):
        w = axis_deviation_rotation(f_d, f_b)
        q = np.zeros(12)
        q[9:12] = w
        gamma = float(tw.r_twist @ q)
        g0, _ = twist_offsets_rad(_iso(helical, f_d, f_b), _iso(helical, f_d, f_b).meshes[0], tw.r_twist, None)
        assert gamma == pytest.approx(g0, rel=1e-12, abs=1e-18)
        x = float(tw.r_mesh @ q)
        for s in (-0.01, 0.0, 0.012):
            for zeta in (-0.005, 0.0, 0.005):
                pt = p + s * e2 + zeta * e3
                closure = -float(np.cross(w, pt - ob) @ n)
                assert closure == pytest.approx(x + gamma * (s * sb - zeta * cb), abs=1e-15)
    # a rotation about the line of action alone: no twist, no closure varying over the plane of action
    w = float(np.hypot(*e2[:2])) ** -1 * 1e-3 * e2
    q = np.zeros(12)
    q[9:12] = w
    assert abs(float(tw.r_twist @ q)) < 1e-18


def test_out_of_plane_part_is_second_order(helical, table):
    """The share about the line of action of 1 mrad over helical_28_33's contact face (axial distance from gear_b's
    centre plane up to 7 mm): gap change (omega zeta)^2 cos beta_b / (2 a_w sin alpha_wt) = 0.37 nm, against the
    in-plane share's first-order closure of the same angle over the face (10 um): 4e-5 of it."""
    g = mesh_geometry(helical, "m12")
    tw = table.twist
    z = tw.slice_z_m
    dz = float(np.mean(np.diff(z)))
    zeta_b = np.array([z[0] - dz / 2, z[-1] + dz / 2]) - float(tw.frame["O_b"][2])     # slice_z_m: global z
    zmax = float(np.max(np.abs(zeta_b)))
    assert zmax == pytest.approx(0.007, abs=1e-6)
    gap = out_of_plane_gap_m(1e-3, zmax, g.center_distance_m, g.operating_pressure_angle_rad,
                             tw.base_helix_angle_rad)
    assert gap == pytest.approx(0.37e-9, abs=0.005e-9)
    # exact: two cylinders of radii summing to a_w sin alpha_wt / cos beta_b shifted along their tangent by d
    rsum = g.center_distance_m * math.sin(g.operating_pressure_angle_rad) / math.cos(tw.base_helix_angle_rad)
    d = 1e-3 * zmax
    assert gap == pytest.approx(math.hypot(rsum, d) - rsum, rel=1e-6)
    assert gap < 1e-4 * 1e-3 * (z[-1] - z[0] + dz)


def test_combination_without_out_of_plane_part_is_the_direct_misalignment(helical, table):
    """omega along e1 (built with a power-of-two factor so that omega . e2 is exactly 0 in floating point): the
    system equals the one with psi = -omega . e1 given directly, bit for bit (twist offsets, kernel arrays)."""
    e1 = table.twist.r_twist[3:6]
    e2 = np.array([-e1[1], e1[0], 0.0])
    k = 2.0 ** -12                                      # 244 urad
    f_b, f_d = k * e2[1], -k * e2[0]                    # omega = k (e2y, -e2x) = k e1
    assert f_b * e2[0] + f_d * e2[1] == 0.0             # omega . e2, as lead.py sums it
    psi = -(f_b * e1[0] + f_d * e1[1])
    assert psi == pytest.approx(-k, rel=1e-12)
    s_iso = build_system(_iso(helical, f_d, f_b), {"m12": table})
    s_psi = build_system(_iso(helical, psi=psi), {"m12": table})
    assert s_iso.meshes[0].table.twist.twist_offset_rad == s_psi.meshes[0].table.twist.twist_offset_rad
    assert (s_iso.meshes[0].coast_table.twist.twist_offset_rad
            == s_psi.meshes[0].coast_table.twist.twist_offset_rad)
    for key in ("tab", "tint", "tflt", "vecs", "lin", "lint"):
        assert np.array_equal(getattr(s_iso.arrays, key), getattr(s_psi.arrays, key)), key


def test_inputs_read_validated_refused_on_spur_and_zero_is_identical(helical, table):
    text = (MODELS / "helical_28_33" / "model.toml").read_text()
    text = text.replace("center_distance_mm = 152.5", "center_distance_mm = 152.5\n"
                        "axis_deviation_in_axes_plane_urad = 80.0\naxis_deviation_normal_to_axes_plane_urad = -40.0")
    m = parse_model(text, file="t.toml")
    assert m.meshes[0].axis_deviation_in_axes_plane_rad == pytest.approx(8e-5)
    assert m.meshes[0].axis_deviation_normal_to_axes_plane_rad == pytest.approx(-4e-5)
    with pytest.raises(ModelError, match=r"axis_deviation_in_axes_plane_urad.*\[urad\]"):
        parse_model(text.replace("= 80.0", "= 2e4"), file="t.toml")
    with pytest.raises(ModelError, match=r"axis_deviation_normal_to_axes_plane_urad.*\[urad\]"):
        parse_model(text.replace("= -40.0", "= -1.5e4"), file="t.toml")
    with pytest.raises(ModelError, match=r"axis_deviation_in_axes_plane_rad \[rad\].*\[-0.01, 0.01\]"):
        Mesh("m", "a", "b", axis_deviation_in_axes_plane_rad=0.02)
    with pytest.raises(ModelError, match=r"axis_deviation_normal_to_axes_plane_rad \[rad\].*\[-0.01, 0.01\]"):
        Mesh("m", "a", "b", axis_deviation_normal_to_axes_plane_rad=float("nan"))
    # outside the table values; zero inputs: the very table object, equal arrays
    assert model_values_sha256(m) == model_values_sha256(helical)
    sy0 = build_system(helical, {"m12": table})
    sy1 = build_system(_iso(helical), {"m12": table})
    assert sy1.meshes[0].table is table
    for key in ("tab", "tint", "tflt", "vecs", "lin", "lint"):
        assert np.array_equal(getattr(sy0.arrays, key), getattr(sy1.arrays, key)), key
    # an offset outside the twist axis names the inputs; spur meshes refuse them
    with pytest.raises(ModelError, match=r"axis_deviation_normal_to_axes_plane_urad = 600 urad.*max_twist_mrad"):
        build_system(_iso(helical, f_beta=6e-4), {"m12": table})
    spur = load_model("spur_28t_asym")
    with pytest.raises(ModelError, match=r"axis_deviation_in_axes_plane_urad.*twist axis"):
        build_system(_iso(spur, f_delta=1e-4), load_system_tables(spur.path))


def test_out_of_plane_misalignment_is_the_iso_rotation_about_the_line_of_action(helical, table):
    """misalignment_out_of_plane = w is the rotation w e2 about the transverse line of action: the ISO deviations
    whose rotation is w e2 (f_Sigma_beta = w e2_x, f_Sigma_delta = w e2_y, nothing about e1) give the same offsets
    (drive 0: second order there; coast -w e2 . e1_c, first order) within rounding; both together with opposite
    signs cancel; on its own it moves the coast offset by -w e2 . e1_c."""
    e1 = table.twist.r_twist[3:6]
    e2 = np.array([-e1[1], e1[0], 0.0])
    e1c = table.coast.twist.r_twist[3:6]
    w = 3e-4
    s_oop = build_system(replace(helical, meshes=(replace(helical.meshes[0], misalignment_out_of_plane_rad=w),)),
                         {"m12": table})
    s_iso = build_system(_iso(helical, w * e2[1], w * e2[0]), {"m12": table})
    drive = [s.meshes[0].table.twist.twist_offset_rad for s in (s_oop, s_iso)]
    coast = [s.meshes[0].coast_table.twist.twist_offset_rad for s in (s_oop, s_iso)]
    assert drive[0] == 0.0 and abs(drive[1]) < 1e-18
    assert coast[0] == pytest.approx(-w * float(e2 @ e1c), rel=1e-12) and abs(coast[0]) > 0.1 * w
    assert coast[1] == pytest.approx(coast[0], rel=1e-12)
    both = replace(_iso(helical, -w * e2[1], -w * e2[0]),
                   meshes=(replace(_iso(helical, -w * e2[1], -w * e2[0]).meshes[0], misalignment_out_of_plane_rad=w),))
    s_both = build_system(both, {"m12": table})
    assert abs(s_both.meshes[0].coast_table.twist.twist_offset_rad) < 1e-18
