"""Tests of hacgear_core.geometry against closed forms and the dissertation's numbers."""
from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from hacgear_core.errors import GeometryError, ModelError
from hacgear_core.geometry import (
    REGION_FILLET, REGION_INVOLUTE, REGION_ROOT_LAND, REGION_TIP_ROUNDING, SIDES, fillet_root_curvature_radius_rack,
    fillet_root_curvature_radius_shaper, gear_geometry, involute_function, max_hob_tip_radius_m, mesh_geometry,
    model_geometry,
    zero_backlash_center_distance,
)
from hacgear_core.model import Flank, Gear, Material
from hacgear_core.kinds import load_model

STEEL = Material("steel", 7850.0, 2.0e11, 0.3)


def make_gear(name="g", z=28, m=5e-3, da=None, df=None, s=None, a_d=20.0, a_c=None, rho=None, b=0.015, bore=0.04,
              internal=False, relief=(0.0, 0.0, "none"), relief_c=None, helix=0.0, crown=0.0, edge=0.0, **kw):
    a_c = a_d if a_c is None else a_c
    r = 0.5 * m * z
    if da is None:
        da = 2 * (r + m) if not internal else 2 * (r - m)
    if df is None:
        df = 2 * (r - 1.25 * m) if not internal else 2 * (r + 1.25 * m)
    s = math.pi * m / 2 if s is None else s
    rho = 0.25 * m if rho is None else rho
    rel_c = relief if relief_c is None else relief_c
    fl = {"drive": Flank(math.radians(a_d), relief[0], math.radians(relief[1]), relief[2]),
          "coast": Flank(math.radians(a_c), rel_c[0], math.radians(rel_c[1]), rel_c[2])}
    return Gear(name=name, teeth=z, module_m=m, tip_diameter_m=da, root_diameter_m=df, tooth_thickness_m=s,
                hob_tip_radius_m=rho, face_width_m=b, bore_diameter_m=bore, material=STEEL, flanks=fl,
                internal=internal, helix_angle_rad=math.radians(helix), lead_crowning_m=crown, tip_edge_radius_m=edge,
                **kw)


def polar(xy, side):
    """Local clockwise polar angle of a flank point (drive: +atan2(y, x), coast: -atan2(y, x))."""
    ang = np.arctan2(xy[..., 1], xy[..., 0])
    return ang if side == "drive" else -ang


@pytest.fixture(scope="module")
def asym28():
    return load_model("spur_28t_asym")


@pytest.fixture(scope="module")
def gg28(asym28):
    return gear_geometry(asym28.gear("pinion"))


@pytest.fixture(scope="module")
def ring():
    return gear_geometry(load_model("planetary_65_55_175").gear("ring"))


# ---------------------------------------------------------------------------------------------
# Involute, base circle, thickness
# ---------------------------------------------------------------------------------------------
def test_base_radii_28_tooth(gg28):
    assert gg28.base_radius_m["drive"] == pytest.approx(0.070 * math.cos(math.radians(25)), rel=1e-14)
    assert gg28.base_radius_m["coast"] == pytest.approx(0.070 * math.cos(math.radians(20)), rel=1e-14)
    assert gg28.pitch_radius_m == pytest.approx(0.070)
    # one rack cuts both flanks: s = m (pi/2 + x (tan a_d + tan a_c))
    x = gg28.profile_shift["drive"]
    assert x == gg28.profile_shift["coast"]
    assert 5e-3 * (math.pi / 2 + x * (math.tan(math.radians(25)) + math.tan(math.radians(20)))) == pytest.approx(
        7.64e-3, rel=1e-12)
    # hob addendum from root diameter and shift
    assert gg28.hob_addendum_m == pytest.approx(0.070 + x * 5e-3 - 0.0632, rel=1e-12)


@pytest.mark.parametrize("which", ["gg28", "ring"])
def test_involute_polar_equation(which, request):
    gg = request.getfixturevalue(which)
    for side in SIDES:
        u = np.linspace(gg.form_roll_rad[side], gg.involute_end_roll_rad[side], 50)
        xy, nrm, rc = gg.involute_point(side, u)
        R = np.hypot(xy[:, 0], xy[:, 1])
        rb = gg.base_radius_m[side]
        np.testing.assert_allclose(R, rb * np.sqrt(1 + u * u), rtol=1e-13)
        a = gg.pressure_angle_rad[side]
        a_r = np.arccos(rb / R)
        psi = 0.5 * (7.64e-3 if which == "gg28" else 2e-3) / gg.pitch_radius_m
        sign = -1.0 if gg.internal else 1.0
        expected = psi + sign * (involute_function(a) - involute_function(a_r))
        np.testing.assert_allclose(polar(xy, side), expected, atol=1e-13)
        # normal: unit, perpendicular to the curve, pointing out of the material (away from the tooth centre line)
        np.testing.assert_allclose(np.hypot(nrm[:, 0], nrm[:, 1]), 1.0, rtol=1e-13)
        h = 1e-7
        d = (gg.involute_point(side, u + h)[0] - gg.involute_point(side, u - h)[0]) / (2 * h)
        np.testing.assert_allclose(np.sum(d * nrm, axis=1) / np.hypot(d[:, 0], d[:, 1]), 0.0, atol=1e-7)
        tang_dir = np.array([0.0, 1.0]) if side == "drive" else np.array([0.0, -1.0])
        # moving along +normal increases the local polar angle (leaves the tooth)
        assert np.all(polar(xy + 1e-6 * nrm, side) > polar(xy, side))
        # curvature radius r_b u, convex for external, concave for internal
        np.testing.assert_allclose(rc, sign * rb * u, rtol=1e-13)
        del tang_dir


def test_flank_profile_involute_points_and_thickness(gg28):
    for side in SIDES:
        f = gg28.flank(side, 300)
        assert f.xy.shape == (300, 2) and f.region.shape == (300,)
        inv = f.region == REGION_INVOLUTE
        # with relief the points move inward along the normal by modification_m: undo and check the polar equation
        xy0 = f.xy[inv] + f.modification_m[inv][:, None] * f.normal[inv]
        R = np.hypot(xy0[:, 0], xy0[:, 1])
        rb = gg28.base_radius_m[side]
        a = gg28.pressure_angle_rad[side]
        exp = 7.64e-3 / 0.14 + involute_function(a) - involute_function(np.arccos(rb / R))
        np.testing.assert_allclose(polar(xy0, side), exp, atol=1e-12)
        # s runs from the tip: 0 at the last point, decreasing monotonically
        assert f.s[-1] == 0 and np.all(np.diff(f.s) < 0)
        # regions are ordered root land -> fillet -> involute
        assert list(dict.fromkeys(f.region.tolist())) == [REGION_ROOT_LAND, REGION_FILLET, REGION_INVOLUTE]
    # circular tooth thickness on the reference circle from the profile points
    th = 0.0
    for side in SIDES:
        f = gg28.flank(side, 3000)
        inv = f.region == REGION_INVOLUTE
        th += np.interp(0.070, f.radius[inv], polar(f.xy[inv], side))
    assert 0.070 * th == pytest.approx(7.64e-3, rel=1e-7)


def test_internal_gear_thickness_and_material_outside(ring):
    th = 0.0
    for side in SIDES:
        f = ring.flank(side, 3000)
        inv = f.region == REGION_INVOLUTE
        order = np.argsort(f.radius[inv])
        th += np.interp(ring.pitch_radius_m, f.radius[inv][order], polar(f.xy[inv], side)[order])
        # ordered root (large radius) to tip (small radius)
        assert f.radius[0] > f.radius[-1]
        assert f.radius[0] == pytest.approx(ring.root_radius_m)
        assert f.radius[-1] == pytest.approx(ring.tip_radius_m, abs=2e-5)
        # outward normals of the root land point to the centre (material outside)
        land = f.region == REGION_ROOT_LAND
        np.testing.assert_allclose(np.sum(f.normal[land] * f.xy[land], axis=1) / f.radius[land], -1.0, atol=1e-12)
    assert ring.pitch_radius_m * th == pytest.approx(2e-3, rel=1e-7)
    # ring tooth thickness s = m (pi/2 - 2 x tan a)  (x > 0: tool moved away from the axis)
    x = ring.profile_shift["drive"]
    assert 1.609e-3 * (math.pi / 2 - 2 * x * math.tan(math.radians(15.97))) == pytest.approx(2e-3, rel=1e-12)
    # ring tooth gets thicker towards its root
    assert ring.thickness_at_radius_m(0.142) > ring.thickness_at_radius_m(0.140)


def test_symmetric_vs_asymmetric():
    sym = gear_geometry(make_gear(a_d=20, a_c=20, s=7.64e-3, da=0.1499, df=0.1264, rho=0.4e-3))
    fd, fc = sym.flank("drive", 200), sym.flank("coast", 200)
    np.testing.assert_allclose(fd.xy[:, 0], fc.xy[:, 0], atol=1e-15)
    np.testing.assert_allclose(fd.xy[:, 1], -fc.xy[:, 1], atol=1e-15)
    asym = gear_geometry(make_gear(a_d=25, a_c=20, s=7.64e-3, da=0.1499, df=0.1264, rho=0.4e-3))
    assert asym.base_radius_m["drive"] < asym.base_radius_m["coast"]
    # the 25 deg flank has a smaller base circle: at the tip it is further from the centre line than if it were 20
    th_d = asym.flank("drive", 200)
    th_c = asym.flank("coast", 200)
    assert polar(th_d.xy[-1], "drive") < polar(th_c.xy[-1], "coast")  # steeper 25 deg flank: thinner tip half
    # the symmetric 20/20 coast flank equals the asymmetric gear's 20 deg coast flank except for the shift
    x_sym = sym.profile_shift["drive"]
    x_asym = asym.profile_shift["drive"]
    assert x_sym == pytest.approx((7.64e-3 / 5e-3 - math.pi / 2) / (2 * math.tan(math.radians(20))))
    assert x_asym == pytest.approx((7.64e-3 / 5e-3 - math.pi / 2) / (math.tan(math.radians(25)) +
                                                                      math.tan(math.radians(20))))


# ---------------------------------------------------------------------------------------------
# Fillet
# ---------------------------------------------------------------------------------------------
def _rack_centre_path(gg, side, phi):
    """Independent rack tip-circle centre path in the gear frame (drive side)."""
    r = gg.pitch_radius_m
    a = r - gg.root_radius_m - gg.hob_tip_radius_m
    al = gg.pressure_angle_rad[side]
    b = r * (7.64e-3 / (2 * r)) + a * math.tan(al) + gg.hob_tip_radius_m / math.cos(al)
    X, Y = b + r * phi, np.full_like(phi, r - a)
    c, s = np.cos(phi), np.sin(phi)
    Xg, Yg = c * X - s * Y, s * X + c * Y
    return np.stack([Yg, Xg if side == "drive" else -Xg], axis=1)


def test_fillet_is_envelope_of_the_hob_tip_circle(gg28):
    """Every fillet point is at distance rho from the tool tip-circle centre path (and never closer)."""
    rho = gg28.hob_tip_radius_m
    phi = np.linspace(-0.4, 0.1, 200001)
    for side in SIDES:
        f = gg28.flank(side, 200)
        pts = f.xy[f.region == REGION_FILLET]
        path = _rack_centre_path(gg28, side, phi)
        for p in pts[::3]:
            d = np.hypot(path[:, 0] - p[0], path[:, 1] - p[1]).min()
            assert d == pytest.approx(rho, abs=2e-9)
        # involute points are never closer than rho either (the tool does not gouge the flank)
        inv = f.xy[f.region == REGION_INVOLUTE]
        for p in inv[:20]:
            assert np.hypot(path[:, 0] - p[0], path[:, 1] - p[1]).min() >= rho - 1e-9


def test_fillet_tangent_to_involute_and_root(gg28):
    for side in SIDES:
        f = gg28.flank(side, 400)
        j = np.flatnonzero(f.region == REGION_INVOLUTE)[0]
        # junction: the first involute point is the fillet end; normals of the neighbours agree
        assert f.radius[j] == pytest.approx(gg28.form_radius_m[side], rel=1e-12)
        # the fillet end is where the curve is tangent: compare the normals of the two curves at the junction
        fil_end = gg28._fillet_local(gg28._flanks[side], np.array([gg28._flanks[side].phi_end]))
        n_fil = gg28._to_gear(side, fil_end[1][0], fil_end[1][1])[0]
        u = gg28.form_roll_rad[side]
        xy_i, n_i, _ = gg28.involute_point(side, u)
        p_fil = gg28._to_gear(side, fil_end[0][0], fil_end[0][1])[0]
        np.testing.assert_allclose(p_fil, xy_i, atol=1e-12)
        np.testing.assert_allclose(n_fil, n_i, atol=1e-9)
        # bottom: the fillet starts on the root circle with a radial normal (tangent to the root circle)
        k = np.flatnonzero(f.region == REGION_FILLET)[0]
        assert f.radius[k] == pytest.approx(gg28.root_radius_m, rel=1e-13)
        np.testing.assert_allclose(np.sum(f.normal[k] * f.xy[k]) / f.radius[k], 1.0, atol=1e-12)
        assert not gg28.undercut[side]


def _three_point_radius(p0, p1, p2):
    a, b, c = np.linalg.norm(p1 - p0), np.linalg.norm(p2 - p1), np.linalg.norm(p2 - p0)
    area2 = abs((p1[0] - p0[0]) * (p2[1] - p0[1]) - (p1[1] - p0[1]) * (p2[0] - p0[0]))
    return a * b * c / (2 * area2)


def test_fillet_root_curvature_closed_form_rack(gg28):
    """At the root point the fillet's curvature radius is rho + a^2/(r + a), not rho
    (a = r - r_f - rho: depth of the hob tip-circle centre below the rolling line)."""
    r, rf, rho = gg28.pitch_radius_m, gg28.root_radius_m, gg28.hob_tip_radius_m
    a = r - rf - rho
    exact = rho + a * a / (r + a)
    assert fillet_root_curvature_radius_rack(r, rf, rho) == pytest.approx(exact)
    assert exact > 2 * rho  # 0.936 mm vs 0.4 mm: the hob radius is NOT the root curvature radius
    for side in SIDES:
        fl = gg28._flanks[side]
        f = gg28.flank(side, 200)
        k = np.flatnonzero(f.region == REGION_FILLET)[0]
        assert f.curvature_radius_m[k] == pytest.approx(-exact, rel=1e-9)  # concave
        # independent: circle through three points of the fillet curve around the bottom
        h = 1e-4
        pts = gg28._fillet_local(fl, np.array([fl.phi_start - h, fl.phi_start, fl.phi_start + h]))[0].T
        assert _three_point_radius(*pts) == pytest.approx(exact, rel=1e-6)
    # the curvature radius tends to rho only when the tip-circle centre is on the rolling line (a -> 0)
    assert fillet_root_curvature_radius_rack(r, r - rho, rho) == pytest.approx(rho)


def test_fillet_root_curvature_closed_form_shaper(ring):
    rho = ring.hob_tip_radius_m
    for side in SIDES:
        fl = ring._flanks[side]
        t = fl.tool
        exact = fillet_root_curvature_radius_shaper(t.r_w, ring.z, ring.shaper_teeth, ring.root_radius_m, rho)
        f = ring.flank(side, 200)
        k = np.flatnonzero(f.region == REGION_FILLET)[0]
        assert f.curvature_radius_m[k] == pytest.approx(-exact, rel=1e-9)
        h = 3e-5
        pts = ring._fillet_local(fl, np.array([fl.phi_start - h, fl.phi_start, fl.phi_start + h]))[0].T
        assert _three_point_radius(*pts) == pytest.approx(exact, rel=1e-6)
        assert f.radius[k] == pytest.approx(ring.root_radius_m, rel=1e-12)
        # tangent continuity at the fillet/involute junction of the ring
        fil_end = ring._fillet_local(fl, np.array([fl.phi_end]))
        n_fil = ring._to_gear(side, fil_end[1][0], fil_end[1][1])[0]
        xy_i, n_i, _ = ring.involute_point(side, ring.form_roll_rad[side])
        np.testing.assert_allclose(ring._to_gear(side, fil_end[0][0], fil_end[0][1])[0], xy_i, atol=1e-11)
        np.testing.assert_allclose(n_fil, n_i, atol=1e-8)


def test_undercut_detected_and_form_point_on_involute():
    gg = gear_geometry(make_gear(z=10, m=5e-3, bore=0.0))  # x = 0, 20 deg: z_min = 17
    assert gg.undercut["drive"] and gg.undercut["coast"]
    assert any("undercut" in w for w in gg.warnings)
    # the junction lies on the involute, above the base circle, and below the rack-flank limit
    for side in SIDES:
        rf = gg.form_radius_m[side]
        rb = gg.base_radius_m[side]
        assert rb < rf < gg.pitch_radius_m
        f = gg.flank(side, 300)
        j = np.flatnonzero(f.region == REGION_INVOLUTE)[0]
        assert f.radius[j] == pytest.approx(rf, rel=1e-9)
    no = gear_geometry(make_gear(z=28))
    assert not no.undercut["drive"]


# ---------------------------------------------------------------------------------------------
# Modifications
# ---------------------------------------------------------------------------------------------
def test_tip_relief_equals_model_value_at_tip(gg28):
    for side, c, start in (("drive", 47e-6, 28.54), ("coast", 52e-6, 22.9)):
        u_tip = gg28.tip_roll_rad[side]
        u0 = math.radians(start)
        assert gg28.relief_m(side, u_tip) == pytest.approx(c, rel=1e-12)
        assert gg28.relief_m(side, u0) == 0.0
        assert gg28.relief_m(side, u0 - 0.05) == 0.0
        # parabolic: a quarter of the tip value half way
        assert gg28.relief_m(side, 0.5 * (u0 + u_tip)) == pytest.approx(0.25 * c, rel=1e-12)
        f = gg28.flank(side, 200)
        assert f.modification_m[-1] == pytest.approx(c, rel=1e-12)
        # the modified tip corner lies c inside the true involute along the normal
        xy_t, n_t, _ = gg28.involute_point(side, u_tip)
        assert np.dot(xy_t - f.xy[-1], n_t) == pytest.approx(c, rel=1e-9)
    lin = gear_geometry(make_gear(relief=(10e-6, 20.9, "linear")))
    u_tip = lin.tip_roll_rad["drive"]
    u0 = math.radians(20.9)
    assert lin.relief_m("drive", u_tip) == pytest.approx(10e-6)
    assert lin.relief_m("drive", 0.5 * (u0 + u_tip)) == pytest.approx(5e-6)


def test_tip_relief_internal_gear_grows_towards_smaller_roll(ring):
    u_tip, u0 = ring.tip_roll_rad["drive"], math.radians(16.0)
    assert u_tip < u0
    assert ring.relief_m("drive", u_tip) == pytest.approx(15e-6)
    assert ring.relief_m("drive", u0 + 0.01) == 0.0
    assert 0 < ring.relief_m("drive", 0.5 * (u0 + u_tip)) < 15e-6


def test_lead_crowning(gg28):
    b = gg28.face_width_m
    assert gg28.crowning_m(0.0) == 0.0
    np.testing.assert_allclose(gg28.crowning_m(np.array([-b / 2, b / 2])), 15e-6, rtol=1e-12)
    assert gg28.crowning_m(b / 4) == pytest.approx(15e-6 / 4)


def test_tip_edge_rounding():
    sharp = gear_geometry(make_gear())
    rnd = gear_geometry(make_gear(edge=0.5e-3))
    f = rnd.flank("drive", 200)
    e = f.region == REGION_TIP_ROUNDING
    assert e.sum() >= 4
    np.testing.assert_allclose(f.curvature_radius_m[e], 0.5e-3)
    assert f.radius[-1] == pytest.approx(rnd.tip_radius_m, rel=1e-12)
    # arc of radius 0.5 mm: all its points at the same distance from one centre
    pts = f.xy[e]
    c = pts - 0.5e-3 * f.normal[e]
    np.testing.assert_allclose(c - c[0], 0.0, atol=1e-12)
    assert rnd.involute_end_roll_rad["drive"] < sharp.involute_end_roll_rad["drive"]
    # contact ratio drops with the rounding (the involute ends lower)
    assert rnd.tip_thickness_m == sharp.tip_thickness_m


# ---------------------------------------------------------------------------------------------
# Mesh: centre distance, contact ratios, roll angles
# ---------------------------------------------------------------------------------------------
def _closed_form_eps(ra1, rb1, ra2, rb2, a, pb, internal=False):
    if not internal:
        aw = math.acos((rb1 + rb2) / a)
        return (math.sqrt(ra1 ** 2 - rb1 ** 2) + math.sqrt(ra2 ** 2 - rb2 ** 2) - a * math.sin(aw)) / pb
    aw = math.acos((rb2 - rb1) / a)
    return (math.sqrt(ra1 ** 2 - rb1 ** 2) - math.sqrt(ra2 ** 2 - rb2 ** 2) + a * math.sin(aw)) / pb


def test_contact_ratio_28_tooth_dissertation(asym28):
    mg = mesh_geometry(asym28)
    assert mg.center_distance_m == pytest.approx(0.140)
    assert mg.contact_ratio == pytest.approx(1.45, abs=0.02)  # 25 deg flank, loaded
    assert mg.contact_ratio_coast == pytest.approx(1.63, abs=0.02)  # 20 deg flank
    ra = 0.14990 / 2
    for side, eps in (("drive", mg.contact_ratio), ("coast", mg.contact_ratio_coast)):
        rb = 0.070 * math.cos(math.radians(25 if side == "drive" else 20))
        assert eps == pytest.approx(_closed_form_eps(ra, rb, ra, rb, 0.14, 2 * math.pi * rb / 28), rel=1e-12)
    # roll angles (deg of tan(alpha)) on the loaded flank: closed forms
    rb = 0.070 * math.cos(math.radians(25))
    pb = 2 * math.pi * rb / 28
    l_tip = math.sqrt(ra ** 2 - rb ** 2)
    l_sap = 0.14 * math.sin(math.acos(2 * rb / 0.14)) - l_tip
    exp = {"SAP": l_sap, "LPSTC": l_tip - pb, "HPSTC": l_sap + pb, "EAP": l_tip}
    for g in ("pinion", "wheel"):
        for k, v in exp.items():
            assert mg.roll_angle_deg[g][k] == pytest.approx(math.degrees(v / rb), rel=1e-12)
    # the relief start roll angles lie in the single-tooth-contact zone (the design intent)
    assert mg.roll_angle_deg["pinion"]["LPSTC"] < 28.54 < mg.roll_angle_deg["pinion"]["HPSTC"]


def test_contact_ratio_50_tooth_tables():
    mg = mesh_geometry(load_model("spur_50t_icr137"))
    assert mg.contact_ratio == pytest.approx(1.37, abs=0.03)
    # Table 3.2 states 1.8; its diameters give 1.773 at the 150 mm centre distance (reported, not 1.8)
    mg18 = mesh_geometry(load_model("spur_50t_icr18"))
    rb = 0.075 * math.cos(math.radians(20))
    assert mg18.contact_ratio == pytest.approx(_closed_form_eps(0.07803, rb, 0.07804, rb, 0.15, 2 * math.pi * rb / 50),
                                               rel=1e-12)
    assert 1.76 < mg18.contact_ratio < 1.78


def test_internal_mesh_contact_ratio_closed_form():
    model = load_model("planetary_65_55_175")
    mg = mesh_geometry(model, "ring_planet")
    assert mg.internal
    ring, planet = model.gear("ring"), model.gear("planet")
    rbr = ring.reference_radius_m * math.cos(ring.flanks["drive"].pressure_angle_rad)
    rbp = planet.reference_radius_m * math.cos(planet.flanks["coast"].pressure_angle_rad)
    exp = _closed_form_eps(planet.tip_diameter_m / 2, rbp, ring.tip_diameter_m / 2, rbr, mg.center_distance_m,
                           2 * math.pi * rbp / 55, internal=True)
    assert mg.contact_ratio == pytest.approx(exp, rel=1e-12)
    # ring: root at large radius -> SAP has the largest roll angle
    r = mg.roll_angle_deg["ring"]
    assert r["SAP"] > r["EAP"]


def test_zero_backlash_center_distance_closed_form():
    g1 = gear_geometry(make_gear(z=20, s=math.pi * 5e-3 / 2))
    g2 = gear_geometry(make_gear(z=37, s=math.pi * 5e-3 / 2))
    assert zero_backlash_center_distance(g1._form, g2._form) == pytest.approx(0.5 * 5e-3 * 57, rel=1e-12)
    # shifted: inv a_w = inv a + 2 tan a (x1 + x2)/(z1 + z2)
    s1 = 5e-3 * (math.pi / 2 + 2 * 0.3 * math.tan(math.radians(20)))
    s2 = 5e-3 * (math.pi / 2 - 2 * 0.1 * math.tan(math.radians(20)))
    h1 = gear_geometry(make_gear(z=20, s=s1, da=0.1 + 2 * 1.3 * 5e-3, df=0.1 - 2 * 0.95 * 5e-3))
    h2 = gear_geometry(make_gear(z=37, s=s2))
    al = math.radians(20)
    target = involute_function(al) + 2 * math.tan(al) * 0.2 / 57
    aw = brent_inv(target)
    assert zero_backlash_center_distance(h1._form, h2._form) == pytest.approx(0.5 * 5e-3 * 57 * math.cos(al) /
                                                                             math.cos(aw), rel=1e-11)
    # internal: inv a_w = inv a + 2 tan a (x2 - x1)/(z2 - z1) with x2 the ring shift (KHK sign convention)
    ringg = gear_geometry(make_gear(z=80, s=5e-3 * (math.pi / 2 - 2 * 0.2 * math.tan(al)), internal=True, bore=0.45))
    pin = gear_geometry(make_gear(z=20))
    aw = brent_inv(involute_function(al) + 2 * math.tan(al) * 0.2 / 60)
    assert zero_backlash_center_distance(pin._form, ringg._form) == pytest.approx(
        0.5 * 5e-3 * 60 * math.cos(al) / math.cos(aw), rel=1e-11)


def brent_inv(target):
    from scipy.optimize import brentq
    return brentq(lambda a: involute_function(a) - target, 1e-6, 1.2, xtol=1e-16)


def test_center_distance_derived_when_absent():
    import dataclasses
    model = load_model("spur_28t_asym")
    mesh = dataclasses.replace(model.meshes[0], center_distance_m=None)
    m2 = dataclasses.replace(model, meshes=(mesh,))
    mg = mesh_geometry(m2)
    assert mg.center_distance_source == "zero backlash"
    assert mg.backlash_m == pytest.approx(0.0, abs=1e-12)
    assert mg.center_distance_m < 0.140  # negative shift: thinner teeth close up


def test_helical_face_contact_ratio_and_lead():
    model = load_model("helical_28_33")
    mg = mesh_geometry(model)
    # overlap of [1 +- 5] and [-1 +- 8] mm = [-4, 6] mm
    assert mg.face_width_overlap_m == pytest.approx(0.010)
    assert mg.face_contact_ratio == pytest.approx(0.010 * math.tan(math.radians(15)) / (math.pi * 5e-3), rel=1e-12)
    assert mg.total_contact_ratio == pytest.approx(mg.contact_ratio + mg.face_contact_ratio)
    gg = gear_geometry(model.gear("pinion"))
    assert gg.lead_m == pytest.approx(2 * math.pi * 0.070 / math.tan(math.radians(15)))
    assert gg.section_rotation_rad(0.005) == pytest.approx(0.005 * math.tan(math.radians(15)) / 0.070)


# ---------------------------------------------------------------------------------------------
# Errors and warnings
# ---------------------------------------------------------------------------------------------
def test_pointed_tip_is_an_error_thin_tip_a_warning():
    with pytest.raises(GeometryError, match="pointed"):
        gear_geometry(make_gear(z=12, da=0.5 * 5e-3 * 12 * 2 + 2 * 1.9 * 5e-3))
    thin = gear_geometry(make_gear(z=28, da=0.14 + 2 * 1.52 * 5e-3, df=0.14 - 2 * 1.25 * 5e-3))
    assert 0 < thin.tip_thickness_m < 0.2 * 5e-3
    assert any("thin tip" in w for w in thin.warnings)


def test_interference_and_low_contact_ratio_are_errors():
    from hacgear_core.model import Mesh, Model, Damping, Operating, StaticsGrid
    def pair(g1, g2, cd=None):
        return Model(name="t", kind="spur_pair", title="", source="", gears=(g1, g2),
                     meshes=(Mesh("m", g1.name, g2.name, "drive", "drive", cd),), damping=Damping(),
                     operating=Operating(10.0, g1.name), statics=StaticsGrid())
    # undercut pinion (z=10) with a large wheel: the wheel tip reaches below the pinion's form circle
    p = make_gear("p", z=10, bore=0.0)
    w = make_gear("w", z=60, bore=0.0)
    with pytest.raises(GeometryError, match="interference"):
        mesh_geometry(pair(p, w))
    mg = mesh_geometry(pair(p, w), strict=False)
    assert any("interference" in x for x in mg.warnings)
    # short teeth: contact ratio < 1
    a = make_gear("a", z=20, da=0.1 + 2 * 0.4e-3 * 5, df=0.1 - 2 * 1.25 * 5e-3, bore=0.0)
    b = make_gear("b", z=20, da=0.1 + 2 * 0.4e-3 * 5, df=0.1 - 2 * 1.25 * 5e-3, bore=0.0)
    with pytest.raises(GeometryError, match="contact ratio"):
        mesh_geometry(pair(a, b))
    # teeth overlapping (centre distance below zero backlash)
    c = make_gear("c", z=20, bore=0.0)
    d = make_gear("d", z=20, bore=0.0)
    with pytest.raises(GeometryError, match="negative backlash"):
        mesh_geometry(pair(c, d, cd=0.0995))


def test_bad_side_and_n():
    gg = gear_geometry(make_gear())
    with pytest.raises(ModelError, match="drive \\| coast"):
        gg.flank("left")
    with pytest.raises(ModelError, match="n = 3"):
        gg.flank("drive", 3)


# ---------------------------------------------------------------------------------------------
# Boundaries and mass properties
# ---------------------------------------------------------------------------------------------
def test_tooth_and_gear_boundary(gg28, ring):
    for gg in (gg28, ring):
        tb = gg.tooth_boundary(60)
        ang = np.unwrap(np.arctan2(tb.xy[:, 1], tb.xy[:, 0]))
        assert ang[0] == pytest.approx(-math.pi / gg.z, abs=1e-12)
        assert ang[-1] == pytest.approx(math.pi / gg.z, abs=1e-12)
        assert np.hypot(*tb.xy[0]) == pytest.approx(np.hypot(*tb.xy[-1]), rel=1e-12)
        gb = gg.gear_boundary(60)
        assert len(gb.xy) == gg.z * (len(tb.xy) - 1)
        # closed, counter-clockwise (positive signed area)
        x, y = gb.xy[:, 0], gb.xy[:, 1]
        assert 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0
        assert set(np.unique(gb.tooth)) == set(range(gg.z))


def _teeth_area_polar(gg, n=4000):
    """Independent teeth area and polar moment: z * sum over both flanks of the Stieltjes integrals
    int theta d(R^2/2) and int theta d(R^4/4) along the flank curve from the root circle to the tip."""
    area = j = 0.0
    for side in SIDES:
        f = gg.flank(side, n)
        k = f.region != REGION_ROOT_LAND
        rad, th = f.radius[k], polar(f.xy[k], side)
        thm = 0.5 * (th[1:] + th[:-1])
        sgn = -1.0 if gg.internal else 1.0  # internal: the flank runs from large to small radius
        area += sgn * np.sum(thm * np.diff(rad ** 2 / 2))
        j += sgn * np.sum(thm * np.diff(rad ** 4 / 4))
        # tip land: the corner angle times the annulus slice is already covered by theta at the tip
    return gg.z * area, gg.z * j


def test_mass_and_inertia_against_annulus_plus_teeth(gg28, ring):
    rho_b = 7850.0 * 0.015
    a_t, j_t = _teeth_area_polar(gg28)
    assert gg28.teeth_area_m2 == pytest.approx(a_t, rel=1e-5)
    rf, ri = 0.0632, 0.020
    m_exp = rho_b * (math.pi * (rf ** 2 - ri ** 2) + a_t)
    i_exp = rho_b * (0.5 * math.pi * (rf ** 4 - ri ** 4) + j_t)
    assert gg28.mass_kg == pytest.approx(m_exp, rel=1e-5)
    assert gg28.inertia_kgm2 == pytest.approx(i_exp, rel=1e-5)
    assert gg28.diametral_inertia_kgm2 == pytest.approx(0.5 * gg28.inertia_kgm2 + gg28.mass_kg * 0.015 ** 2 / 12)
    # teeth area is between the involute-only estimate bounds: a fraction of the tooth annulus
    ann = math.pi * (0.07495 ** 2 - rf ** 2)
    assert 0.4 * ann < gg28.teeth_area_m2 < 0.7 * ann
    # internal gear: rim annulus between root circle and outer rim plus the teeth inside
    a_t, j_t = _teeth_area_polar(ring)
    rho_b = 7595.0 * 0.010
    ro, rf = 0.155, 0.144
    assert ring.mass_kg == pytest.approx(rho_b * (math.pi * (ro ** 2 - rf ** 2) + a_t), rel=1e-5)
    assert ring.inertia_kgm2 == pytest.approx(rho_b * (0.5 * math.pi * (ro ** 4 - rf ** 4) + j_t), rel=1e-5)


def test_webbed_blank_mass_and_inertia_closed_form(asym28, gg28):
    """Webbed blank = hub annulus (bore..r_i, width b) + web annulus (r_i..r_o, thickness t) + rim annulus
    (r_o..r_f, width b) + teeth (width b), summed piece by piece; thickness = face width is the solid blank."""
    from hacgear_core.model import Web

    rho, b = 7850.0, 0.015
    r_bore, r_i, r_o, rf = 0.020, 0.030, 0.055, 0.0632
    a_t, j_t = _teeth_area_polar(gg28)
    for t in (2e-3, 5e-3, 10e-3):
        gg = gear_geometry(dataclasses.replace(asym28.gear("pinion"), web=Web(t, 2 * r_i, 2 * r_o)))
        m_exp = rho * (b * math.pi * (r_i ** 2 - r_bore ** 2) + t * math.pi * (r_o ** 2 - r_i ** 2)
                       + b * math.pi * (rf ** 2 - r_o ** 2) + b * a_t)
        j_exp = rho * 0.5 * math.pi * (b * (r_i ** 4 - r_bore ** 4) + t * (r_o ** 4 - r_i ** 4)
                                       + b * (rf ** 4 - r_o ** 4)) + rho * b * j_t
        assert gg.mass_kg == pytest.approx(m_exp, rel=1e-5)
        assert gg.inertia_kgm2 == pytest.approx(j_exp, rel=1e-5)
        assert (gg.blank_mass_kg, gg.blank_inertia_kgm2) == (gg.mass_kg, gg.inertia_kgm2)
        # diametral inertia of thin slices: rim/hub/teeth of width b, web of width t
        m_web = rho * t * math.pi * (r_o ** 2 - r_i ** 2)
        assert gg.diametral_inertia_kgm2 == pytest.approx(
            0.5 * j_exp + (m_exp - m_web) * b ** 2 / 12 + m_web * t ** 2 / 12, rel=1e-5)
        assert gg.mass_kg < gg28.mass_kg and gg.inertia_kgm2 < gg28.inertia_kgm2
        w = gg.web
        assert (w.thickness_m, w.inner_radius_m, w.outer_radius_m) == pytest.approx((t, r_i, r_o))
        assert w.relative_thickness == pytest.approx(t / b)
    assert gg28.web is None
    full = gear_geometry(dataclasses.replace(asym28.gear("pinion"), web=Web(b, 2 * r_i, 2 * r_o)))
    assert (full.mass_kg, full.inertia_kgm2, full.blank_mass_kg, full.blank_inertia_kgm2) == (
        gg28.mass_kg, gg28.inertia_kgm2, gg28.blank_mass_kg, gg28.blank_inertia_kgm2)
    assert full.diametral_inertia_kgm2 == pytest.approx(gg28.diametral_inertia_kgm2, rel=1e-14)
    assert full.web.relative_thickness == 1.0


def test_webbed_blank_explicit_mass_and_inertia_win():
    from hacgear_core.model import Web

    web = Web(5e-3, 60e-3, 110e-3)
    own = gear_geometry(make_gear(z=28, m=5e-3, web=web))
    gg = gear_geometry(make_gear(z=28, m=5e-3, web=web, mass_kg=2.5, inertia_kgm2=4e-3))
    assert (gg.mass_kg, gg.inertia_kgm2) == (2.5, 4e-3)
    assert (gg.blank_mass_kg, gg.blank_inertia_kgm2) == (own.mass_kg, own.inertia_kgm2)   # the webbed blank's
    assert own.mass_kg < gear_geometry(make_gear(z=28, m=5e-3)).mass_kg
    assert gg.diametral_inertia_kgm2 == pytest.approx(0.5 * 4e-3 + 2.5 * 0.015 ** 2 / 12)


def test_mass_override(asym28):
    model = load_model("planetary_65_55_175")
    sun = gear_geometry(model.gear("sun"))
    assert sun.mass_kg == 1.8 and sun.inertia_kgm2 == pytest.approx(2.1e-3)
    assert sun.blank_mass_kg != sun.mass_kg


def test_all_six_models_build():
    for name in ("spur_28t_asym", "spur_50t_icr137", "spur_50t_icr18", "idler_28_33_39", "planetary_65_55_175",
                 "helical_28_33"):
        gears, meshes = model_geometry(load_model(name))
        for mg in meshes.values():
            assert mg.contact_ratio > 1
            for g, d in mg.roll_angle_deg.items():
                assert set(d) == {"SAP", "LPSTC", "HPSTC", "EAP"}


# ---------------------------------------------------------------------------------------------
# CLI: info and plot-geometry
# ---------------------------------------------------------------------------------------------
def test_info_json_keys(capsys):
    import json

    from hacgear_core.cli import main

    assert main(["info", "spur_28t_asym", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    m = d["meshes"]["m12"]
    assert m["contact_ratio"] == pytest.approx(1.4505, abs=1e-4)
    assert m["contact_ratio_coast"] == pytest.approx(1.6239, abs=1e-4)
    assert m["center_distance_m"] == pytest.approx(0.140)
    assert m["base_radius_m"] == {"pinion": pytest.approx(0.070 * math.cos(math.radians(25))),
                                  "wheel": pytest.approx(0.070 * math.cos(math.radians(25)))}
    for k in ("SAP", "LPSTC", "HPSTC", "EAP"):
        assert set(m["roll_angle_deg"][k]) == {"pinion", "wheel"}
    assert m["roll_angle_deg"]["SAP"]["pinion"] < m["roll_angle_deg"]["EAP"]["pinion"]
    for g in ("pinion", "wheel"):
        assert d["gears"][g]["mass_kg"] > 0 and d["gears"][g]["inertia_kgm2"] > 0
        assert d["gears"][g]["web"] is None
    assert main(["info", "planetary_65_55_175"]) == 0
    out = capsys.readouterr()
    assert "ring_planet" in out.out and "contact ratio" in out.out and "[kg]" in out.out


def test_plot_geometry_mesh_position_no_overlap(tmp_path):
    from matplotlib.path import Path as MPath

    from hacgear_core.cli import main
    from hacgear_core.plots.geometry import _rot, mesh_position

    for name, mesh in (("spur_28t_asym", "m12"), ("planetary_65_55_175", "ring_planet"),
                       ("idler_28_33_39", "m23")):
        model = load_model(name)
        me = model.mesh(mesh)
        ga, gb = gear_geometry(model.gear(me.gear_a)), gear_geometry(model.gear(me.gear_b))
        mg = mesh_geometry(model, mesh)
        pos = mesh_position(ga, gb, mg)
        # the loaded flanks of tooth 0 of both gears pass exactly through the pitch point
        for g, side, phi, c in ((ga, me.flank_a, pos["phi_a"], np.zeros(2)), (gb, me.flank_b, pos["phi_b"],
                                                                            pos["centre_b"])):
            rw = mg.operating_pitch_radius_m[g.name]
            u = math.sqrt(rw ** 2 / g.base_radius_m[side] ** 2 - 1)
            p = _rot(g.involute_point(side, u)[0], phi) + c
            np.testing.assert_allclose(p, pos["pitch"], atol=1e-12)
        a_xy = _rot(ga.gear_boundary(100).xy, pos["phi_a"])
        b_xy = _rot(gb.gear_boundary(100).xy, pos["phi_b"]) + pos["centre_b"]
        in_a = MPath(a_xy).contains_points(b_xy)
        in_b = MPath(b_xy).contains_points(a_xy)
        in_a = ~in_a if ga.internal else in_a
        in_b = ~in_b if gb.internal else in_b
        near_b = np.hypot(*(b_xy - pos["pitch"]).T) < 6 * ga.module_m
        near_a = np.hypot(*(a_xy - pos["pitch"]).T) < 6 * ga.module_m
        assert not (in_a & near_b).any() and not (in_b & near_a).any()
    out = tmp_path / "g.png"
    assert main(["plot-geometry", "spur_28t_asym", "--out", str(out), "--exaggerate", "50"]) == 0
    assert out.stat().st_size > 10000


def test_hob_tip_radius_limit_is_the_tool_tip_not_the_mid_space_angle(asym28):
    """Dissertation 2.4.1: 1.8 mm is "the maximum hob tip radius allowed by geometry" for the 28-tooth
    asymmetric gear.  The limit is the tool: its two tip circles touch (zero root land).  Up to it the
    gear builds, with the land (and the sector cut) off the mid-space angle; beyond it the error names
    the field, the unit and the maximum."""
    import dataclasses

    g = asym28.gear("wheel")
    rho_max = max_hob_tip_radius_m(g)
    assert 1.75e-3 < rho_max < 1.85e-3
    gg = gear_geometry(dataclasses.replace(g, hob_tip_radius_m=1.8e-3))
    half = math.pi / gg.z
    assert gg.sector_offset_rad > 0
    tb = gg.tooth_boundary(100)
    a = np.arctan2(tb.xy[:, 1], tb.xy[:, 0])
    assert a[0] == pytest.approx(-half + gg.sector_offset_rad, abs=1e-12)
    assert a[-1] == pytest.approx(half + gg.sector_offset_rad, abs=1e-12)
    assert np.all(np.diff(a) > 0)                                     # simple, counter-clockwise
    r = np.hypot(tb.xy[:, 0], tb.xy[:, 1])
    assert r.min() == pytest.approx(gg.root_radius_m, rel=1e-9)      # fillets stay above the root circle
    # the cut lies on the root land, between the drive bottom and the next tooth's coast bottom
    land = tb.region == REGION_ROOT_LAND
    assert land[-1] and land[0]
    assert np.allclose(r[land], gg.root_radius_m, rtol=1e-12)
    # closed gear boundary: tooth k ends where tooth k+1 starts
    gb = gg.gear_boundary(100)
    seg = np.hypot(*np.diff(np.vstack([gb.xy, gb.xy[:1]]), axis=0).T)
    assert seg.max() < 5 * np.median(seg) + 1e-4
    # just below the limit: the two fillets meet (vanishing land); above it: a clear error
    gg_lim = gear_geometry(dataclasses.replace(g, hob_tip_radius_m=rho_max * (1 - 1e-6)))
    fd, fc = gg_lim.flank("drive", 200), gg_lim.flank("coast", 200)
    assert (fd.region == REGION_ROOT_LAND).sum() + (fc.region == REGION_ROOT_LAND).sum() <= 4
    with pytest.raises(GeometryError, match=r"hob_tip_radius_mm = 1\.9 mm too large.*<= 1\.81"):
        gear_geometry(dataclasses.replace(g, hob_tip_radius_m=1.9e-3))
    # the nominal 0.4 mm tooth keeps the symmetric cut (unchanged FE/contact results)
    assert gear_geometry(g).sector_offset_rad == 0.0


def test_symmetric_tooth_max_hob_radius_closed_form():
    """Symmetric rack: the tip land vanishes when rho = (p/4 - h tan a) cos a / (1 - sin a), with h the
    tool addendum (here 1.25 m, zero shift); the fillets then meet on the mid-space line."""
    m, a = 5e-3, math.radians(20.0)
    g = make_gear()
    expect = (math.pi * m / 4 - 1.25 * m * math.tan(a)) * math.cos(a) / (1 - math.sin(a))
    assert max_hob_tip_radius_m(g) == pytest.approx(expect, rel=1e-6)
    gg = gear_geometry(make_gear(rho=0.999 * expect))
    assert gg.sector_offset_rad == 0.0


def test_info_json_reports_a_web(tmp_path, capsys):
    import json

    from hacgear_core.cli import main

    from pathlib import Path

    text = (Path(__file__).resolve().parent.parent / "models" / "spur_28t_asym" / "model.toml").read_text(encoding="utf-8")
    web = '  [gears.web]\n  thickness_mm = 8.0\n  inner_diameter_mm = 60.0\n  outer_diameter_mm = 110.0\n'
    text = text.replace('material = "steel"\n', 'material = "steel"\n' + web)
    (tmp_path / "model.toml").write_text(text, encoding="utf-8")
    assert main(["info", str(tmp_path / "model.toml"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for g in ("pinion", "wheel"):
        assert d["gears"][g]["web"] == {"thickness_m": pytest.approx(8e-3), "inner_radius_m": pytest.approx(0.030),
                                        "outer_radius_m": pytest.approx(0.055)}
        assert d["gears"][g]["mass_kg"] < 1.4  # lighter than the solid 40 mm-bore blank (1.63 kg)


def _rack_envelope_tooth_thickness(g, radii, n_phi=1201, n_pts=800):
    """Tooth thickness [m of arc] at ``radii`` of the gear cut by the generating rack of ``g`` (tool tooth
    thickness p - s on the pitch line, flank angles of both flanks, tip at the root circle with corner radius
    rho), found by brute force: the union of the tool outline over ``n_phi`` rolling positions, independent of
    the analytical trochoid in hacgear_core.geometry."""
    m, z, r = g.module_m, g.teeth, 0.5 * g.module_m * g.teeth
    r_f, rho, s = 0.5 * g.root_diameter_m, g.hob_tip_radius_m, g.tooth_thickness_m
    a_r, a_l = g.flanks["drive"].pressure_angle_rad, g.flanks["coast"].pressure_angle_rad
    w = 0.5 * (math.pi * m - s)  # tool half-width on the pitch line y = r

    def edge(y, a, sign):  # tool flank line x(y); the tool narrows toward its tip (smaller y)
        return sign * (w - (r - y) * math.tan(a))

    pieces = []  # per tool flank: corner arc from the tip line up to the tangency point, then the flank line
    for a, sign in ((a_r, 1.0), (a_l, -1.0)):
        yc = r_f + rho  # corner circle centre: tangent to the tip line y = r_f and to the flank line
        xc = edge(yc, a, sign) - sign * rho / math.cos(a)
        ang = np.linspace(-0.5 * math.pi, -a, n_pts)  # the flank's outward normal points at -a (mirrored left)
        arc = np.c_[xc + sign * rho * np.cos(ang), yc + rho * np.sin(ang)]
        y = np.linspace(arc[-1, 1], r + 1.3 * m, n_pts)
        pieces.append(np.vstack([arc, np.c_[edge(y, a, sign), y]]))
    land = np.c_[np.linspace(pieces[1][0, 0], pieces[0][0, 0], n_pts), np.full(n_pts, r_f)]
    outline = np.vstack([pieces[1][::-1], land, pieces[0]])
    lo = np.full(len(radii), np.inf)
    hi = np.full(len(radii), -np.inf)
    for phi in np.linspace(-0.4, 0.4, n_phi):
        c, sn = math.cos(phi), math.sin(phi)
        x0, y0 = outline[:, 0] - r * phi, outline[:, 1]
        x, y = c * x0 + sn * y0, -sn * x0 + c * y0  # into the gear's frame (gear turned by phi)
        rad, th = np.hypot(x, y), np.arctan2(x, y)
        for k, rr in enumerate(radii):
            i = np.flatnonzero((rad[:-1] - rr) * (rad[1:] - rr) <= 0)
            if i.size:
                f = (rr - rad[i]) / (rad[i + 1] - rad[i])
                t = th[i] + f * (th[i + 1] - th[i])
                lo[k], hi[k] = min(lo[k], t.min()), max(hi[k], t.max())
    return np.asarray(radii) * (2 * math.pi / z - (hi - lo))


@pytest.mark.parametrize("rho_mm, tol_um", [(0.4, 0.2), (1.8, 0.2), (0.01, 1.5)])
def test_fillet_matches_brute_force_rack_envelope(asym28, rho_mm, tol_um):
    """The generated root (trochoid of the rounded tool tip) and involute give the same tooth thickness as a
    brute-force envelope of the rack outline, in the fillet, across the fillet-involute junction and on the
    involute, for the nominal 0.4 mm, the largest (1.8 mm) and a nearly sharp (0.01 mm) hob tip radius of the
    28-tooth asymmetric gear (measured: < 0.03 µm; < 0.7 µm for the nearly sharp corner, where the brute-force
    envelope itself converges slowly)."""
    g = dataclasses.replace(asym28.gear("pinion"), hob_tip_radius_m=rho_mm * 1e-3)
    gg = gear_geometry(g)
    radii = gg.root_radius_m + np.array([0.1, 0.3, 0.6, 1.0, 1.6, 2.0, 2.5, 2.8, 3.0, 5.0]) * 1e-3
    env = _rack_envelope_tooth_thickness(g, radii)
    ang = {}
    for side in ("drive", "coast"):
        pr = gg.flank(side, 4000)
        xy = np.asarray(pr.xy)
        rad, th = np.hypot(xy[:, 0], xy[:, 1]), np.unwrap(np.arctan2(xy[:, 1], xy[:, 0]))
        keep = np.r_[True, np.diff(rad) > 0]  # root to tip, radius increasing
        ang[side] = np.interp(radii, rad[keep], th[keep])
    geo = radii * np.abs(ang["drive"] - ang["coast"])
    assert np.all(np.isfinite(env))
    assert np.max(np.abs(geo - env)) < tol_um * 1e-6, (geo - env) * 1e6


# ----------------------------------------------------------------------------------------------
# backlash (issue #13): closed form and placed flank polylines
# ----------------------------------------------------------------------------------------------
def _textbook_backlash(model, mesh_name):
    """j_t = p_w - s_w1 - s_w2 with s_w from the reference-circle thickness by the involute function of each flank:
    s(R) = R [s/r +- sum_f (inv a_f - inv a_f(R))], cos a_f(R) = r cos a_f / R (- for an internal gear's tooth)."""
    mesh = model.mesh(mesh_name)
    ga, gb = model.gear(mesh.gear_a), model.gear(mesh.gear_b)
    internal = ga.internal or gb.internal
    a = mesh.center_distance_m if mesh.center_distance_m is not None else model.planetary.carrier_radius_m
    k = a / (abs(gb.teeth - ga.teeth) if internal else ga.teeth + gb.teeth)
    s_w = []
    for g in (ga, gb):
        r, rw = 0.5 * g.module_m * g.teeth, k * g.teeth
        d = sum(involute_function(f.pressure_angle_rad) - involute_function(math.acos(r * math.cos(f.pressure_angle_rad)
                                                                                       / rw))
                for f in (g.flanks["drive"], g.flanks["coast"]))
        s_w.append(rw * (g.tooth_thickness_m / r + (-d if g.internal else d)))
    return 2 * math.pi * k - s_w[0] - s_w[1]     # p_w = 2 pi r_w / z = 2 pi k


@pytest.mark.parametrize("system,mesh,expect_um", [("spur_28t_asym", "m12", 427.96), ("spur_50t_icr18", "m12", 144.78),
                                                   ("idler_28_33_39", "m23", 432.96),
                                                   ("planetary_65_55_175", "ring_planet", 1054.82)])
def test_backlash_closed_form(system, mesh, expect_um):
    model = load_model(system)
    mg = mesh_geometry(model, mesh, strict=False)
    jt = _textbook_backlash(model, mesh)
    assert mg.backlash_circular_m == pytest.approx(jt, abs=1e-10) == pytest.approx(expect_um * 1e-6, abs=0.01e-6)
    assert mg.backlash_m == mg.backlash_circular_m
    rw = mg.operating_pitch_radius_m[mg.gear_a]
    cos_aw = mg.base_radius_coast_m[mg.gear_a] / rw
    assert mg.backlash_normal_m == pytest.approx(jt * cos_aw, rel=1e-12)
    assert mg.operating_pressure_angle_coast_rad == pytest.approx(math.acos(cos_aw), rel=1e-12)
    from hacgear_core.cli.info import info_dict

    d = info_dict(model, strict=False)["meshes"][mesh]
    assert (d["backlash_circular_m"], d["backlash_normal_m"]) == (mg.backlash_circular_m, mg.backlash_normal_m)


@pytest.mark.parametrize("system,mesh,gear,thickness_m", [("spur_28t_asym", "m12", "pinion", 7.9e-3),
                                                          ("planetary_65_55_175", "ring_planet", "planet", 2.2e-3)])
def test_backlash_and_coast_offset_match_placed_flanks(system, mesh, gear, thickness_m):
    """Gears placed at drive positions, closed on the coast side from their flank polylines: the first touch comes
    after j_n at every position (ideal involutes) and, at drive position c0, on the pitch point (external and
    internal mesh, unequal tooth thicknesses so that c0 != -1/2)."""
    import sys
    from pathlib import Path

    from hacgear_core.statics import model_variant

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from _coast_brute import CoastClosure, thickness_variant

    model = thickness_variant(model_variant(load_model(system), tip_relief=False), gear, thickness_m)
    brute = CoastClosure(model, mesh)
    mg = brute.mg
    assert abs(mg.coast_position_offset + 0.5) > 0.005
    for tau in (0.23, mg.coast_position_offset):
        x, touching = brute.close(tau)
        assert x == pytest.approx(mg.backlash_normal_m, abs=0.05e-6)
    assert min(np.linalg.norm(pt - brute.P) for pt, _ in touching.values()) < 20e-6


# ---------------------------------------------------------------------------------------------
# ISO 21771 gear input (the ISO form of [[gears]]): closed forms against `info`, published pairs
# ---------------------------------------------------------------------------------------------
def _iso_model(gears, meshes, kind="spur_pair", planetary=""):
    """A model of ISO-form gears: ``gears`` = [(name, {key: value})], ``meshes`` = [(name, a, b, {key: value})]."""
    from hacgear_core.model import parse_model

    def val(v):
        return f'"{v}"' if isinstance(v, str) else ("true" if v is True else repr(v))

    lines = ['[system]', 'name = "iso"', f'kind = "{kind}"', '[materials.steel]', 'density_kg_per_m3 = 7830.0',
             'youngs_modulus_GPa = 206.0', 'poisson_ratio = 0.3']
    for name, kv in gears:
        kv = {"normal_pressure_angle_deg": 20.0, "basic_rack": "A", "face_width_mm": 20.0, "bore_diameter_mm": 0.0,
              "material": "steel", **kv}
        lines += ["[[gears]]", f'name = "{name}"'] + [f"{k} = {val(v)}" for k, v in kv.items()]
    for name, a, b, kv in meshes:
        lines += ["[[meshes]]", f'name = "{name}"', f'gear_a = "{a}"', f'gear_b = "{b}"'] + \
                 [f"{k} = {val(v)}" for k, v in kv.items()]
    lines += ["[damping]", "modal_damping_ratio = 0.02", "[operating]", "torque_Nm = 100.0", planetary]
    return parse_model("\n".join(lines), file="iso.toml")


def _iso_closed_forms(z, m_n, alpha_n_deg, beta_deg, x, k, h_ap=1.0, h_fp=1.25, internal=False):
    """ISO 21771 d, d_a, d_f, d_b, alpha_t [rad] of one gear (diameters positive, internal gears too)."""
    beta, alpha_n = math.radians(beta_deg), math.radians(alpha_n_deg)
    alpha_t = math.atan(math.tan(alpha_n) / math.cos(beta))
    d = z * m_n / math.cos(beta)
    sgn = -1.0 if internal else 1.0
    return dict(d=d, d_a=d + sgn * 2 * m_n * (h_ap + x + k), d_f=d - sgn * 2 * m_n * (h_fp - x),
                d_b=d * math.cos(alpha_t), alpha_t=alpha_t)


def _iso_check_pair(info, model, names, z, x, m_n, alpha_n_deg, beta_deg, internal=(False, False), b=None):
    """Assert the ISO 21771 closed forms (per gear and for the mesh) equal ``info`` within 1e-9 relative."""
    from hacgear_core.model.iso21771 import involute

    rel = 1e-9
    cf = []
    for name, zi, xi, inte in zip(names, z, x, internal):
        g = info["gears"][name]["iso"]
        iso = model.gear(name).iso
        c = _iso_closed_forms(zi, m_n, alpha_n_deg, beta_deg, xi, iso.tip_alteration, iso.addendum_coefficient,
                              iso.dedendum_coefficient, inte)
        cf.append(c)
        assert g["profile_shift"] == xi                      # ISO sign, internal gears included
        assert g["reference_diameter_m"] == pytest.approx(c["d"], rel=rel)
        assert g["tip_diameter_m"] == pytest.approx(c["d_a"], rel=rel)
        assert g["root_diameter_m"] == pytest.approx(c["d_f"], rel=rel)
        assert g["base_diameter_m"]["drive"] == pytest.approx(c["d_b"], rel=rel)
        assert g["transverse_pressure_angle_deg"]["drive"] == pytest.approx(math.degrees(c["alpha_t"]), rel=rel)
        assert g["normal_module_m"] == pytest.approx(m_n, rel=rel)
        assert g["transverse_module_m"] == pytest.approx(m_n / math.cos(math.radians(beta_deg)), rel=rel)
        s_n = m_n * (math.pi / 2 + 2 * xi * math.tan(math.radians(alpha_n_deg))) + iso.thickness_allowance_mean_m
        assert g["normal_tooth_thickness_m"] == pytest.approx(s_n, rel=rel)
    mg = next(iter(info["meshes"].values()))
    mi = mg["iso"]
    zs = [-zi if inte else zi for zi, inte in zip(z, internal)]
    alpha_t, alpha_n = cf[0]["alpha_t"], math.radians(alpha_n_deg)
    # a_w from the sum of the profile shifts: inv(alpha_wt) = inv(alpha_t) + 2 tan(alpha_n) (x1 + x2) / (z1 + z2)
    inv_wt = involute(alpha_t) + 2 * math.tan(alpha_n) * sum(x) / sum(zs)
    a_ref = 0.5 * m_n / math.cos(math.radians(beta_deg)) * abs(sum(zs))
    a_w_x = a_ref * math.cos(alpha_t) / math.cos(brent_inv(inv_wt))
    assert mi["center_distance_from_profile_shifts_m"] == pytest.approx(a_w_x, rel=rel)
    assert mg["zero_backlash_center_distance_m"] == pytest.approx(a_w_x, rel=rel)   # the geometry's own solve
    a_w = mi["center_distance_m"]
    alpha_wt = math.acos(a_ref * math.cos(alpha_t) / a_w)
    assert math.radians(mi["operating_transverse_pressure_angle_deg"]) == pytest.approx(alpha_wt, rel=rel)
    # contact ratios: eps_alpha from the tip and base diameters, eps_beta = b sin(beta) / (pi m_n)
    ga, gb = cf
    la = 0.5 * math.sqrt(ga["d_a"] ** 2 - ga["d_b"] ** 2)
    lb = 0.5 * math.sqrt(gb["d_a"] ** 2 - gb["d_b"] ** 2)
    p_bt = math.pi * m_n / math.cos(math.radians(beta_deg)) * math.cos(alpha_t)
    if any(internal):
        eps_a = (la - lb + a_w * math.sin(alpha_wt)) / p_bt if internal[1] else (lb - la + a_w * math.sin(alpha_wt)) / p_bt
    else:
        eps_a = (la + lb - a_w * math.sin(alpha_wt)) / p_bt
    assert mi["transverse_contact_ratio"] == pytest.approx(eps_a, rel=rel)
    eps_b = (b or 0.0) * math.sin(math.radians(beta_deg)) / (math.pi * m_n)
    assert mi["overlap_ratio"] == pytest.approx(eps_b, rel=rel, abs=1e-15)
    assert mi["total_contact_ratio"] == pytest.approx(eps_a + eps_b, rel=rel)
    return mi


def test_iso_form_spur_pair_khk_example_matches_closed_forms_and_published_values():
    """KHK Gear Technical Reference (also SDP/SI 'Elements of Metric Gear Technology', Table 4-4): profile-shifted
    spur pair m = 3 mm, alpha = 20 deg, z = 12 / 24, x = 0.6 / 0.36: inv alpha_w = 0.034316, alpha_w = 26.0886 deg,
    a = 56.4999 mm; tip diameters 44.840 / 79.400 mm, root 32.100 / 66.660 mm, base 33.8289 / 67.6579 mm,
    contact ratio 1.202."""
    from hacgear_core.cli.info import info_dict
    from hacgear_core.model.iso21771 import involute

    model = _iso_model([("pinion", dict(teeth=12, normal_module_mm=3.0, profile_shift=0.6, tip_diameter_mm=44.840)),
                        ("wheel", dict(teeth=24, normal_module_mm=3.0, profile_shift=0.36, tip_diameter_mm=79.400))],
                       [("m12", "pinion", "wheel", {})])
    info = info_dict(model)
    mi = _iso_check_pair(info, model, ("pinion", "wheel"), (12, 24), (0.6, 0.36), 3e-3, 20.0, 0.0)
    assert info["meshes"]["m12"]["center_distance_source"].startswith("ISO 21771")
    assert mi["center_distance_m"] * 1e3 == pytest.approx(56.4999, abs=5e-5)
    assert mi["operating_transverse_pressure_angle_deg"] == pytest.approx(26.0886, abs=5e-5)
    assert involute(math.radians(mi["operating_transverse_pressure_angle_deg"])) == pytest.approx(0.034316, abs=5e-7)
    g = {n: info["gears"][n]["iso"] for n in ("pinion", "wheel")}
    assert [round(g[n]["root_diameter_m"] * 1e3, 3) for n in g] == [32.100, 66.660]
    assert [round(g[n]["base_diameter_m"]["drive"] * 1e3, 4) for n in g] == [33.8289, 67.6579]
    assert round(mi["transverse_contact_ratio"], 3) == 1.202
    assert mi["backlash_circular_m"] == pytest.approx(0.0, abs=1e-12)   # nominal teeth at a_w from sum x


def test_iso_form_helical_pair_iso21771_example():
    """ISO 21771:2007 worked example (Eq. 62; as tabulated in 'Gear Generating Profile Shift Calculations'): z = 31 / 30,
    m_n = 3.5 mm, alpha_n = 20 deg, beta = 21 deg, a_w = 116.5 mm: reference centre distance 114.3447280708 mm,
    alpha_t = 21.2990642859 deg, alpha_wt = 23.8707609654 deg, sum of profile shifts 0.651877131252 (x1 = 0.291)."""
    from hacgear_core.cli.info import info_dict

    sum_x, x1 = 0.651877131252, 0.291
    x2 = sum_x - x1
    y = (116.5 - 114.3447280708) / 3.5        # tip alteration k = y - sum x keeps the standard tip clearance
    common = dict(normal_module_mm=3.5, helix_angle_deg=21.0, tip_alteration_mm=(y - sum_x) * 3.5, face_width_mm=40.0)
    model = _iso_model([("pinion", dict(teeth=31, hand="right", profile_shift=x1, **common)),
                        ("wheel", dict(teeth=30, hand="left", profile_shift=x2, **common))],
                       [("m12", "pinion", "wheel", dict(center_distance_mm=116.5))], kind="helical_pair")
    assert model.gear("pinion").helix_angle_rad == pytest.approx(math.radians(21.0))   # right hand: positive
    assert model.gear("wheel").helix_angle_rad == pytest.approx(-math.radians(21.0))
    info = info_dict(model)
    mi = _iso_check_pair(info, model, ("pinion", "wheel"), (31, 30), (x1, x2), 3.5e-3, 20.0, 21.0, b=0.040)
    g = info["gears"]["pinion"]["iso"]
    assert g["transverse_pressure_angle_deg"]["drive"] == pytest.approx(21.2990642859, abs=1e-10)
    assert 0.5 * (g["reference_diameter_m"] + info["gears"]["wheel"]["iso"]["reference_diameter_m"]) * 1e3 == \
        pytest.approx(114.3447280708, abs=1e-10)
    assert mi["operating_transverse_pressure_angle_deg"] == pytest.approx(23.8707609654, abs=1e-10)
    assert mi["center_distance_from_profile_shifts_m"] == pytest.approx(0.1165, rel=1e-10)
    assert mi["sum_profile_shift"] == pytest.approx(sum_x, rel=1e-12)


def test_iso_form_internal_pair_takes_the_iso_sign():
    """Internal pair z = 17 / 96, m = 14 mm, alpha = 20 deg, x_pinion = 0.2, ring shift 0.5 in the tool's sign
    ('Centre distance of profile shifted internal gear calculation', inv alpha_w from (x2 - x1) / (z2 - z1)):
    alpha_w = 21.1251 deg, a_w = 557.0887 mm.  In ISO 21771's sign the ring's x is -0.5 (z_ring counts negative),
    and the geometry's own zero-backlash centre distance agrees (the ring's tip shortened by k m_n = -1.4 mm keeps it
    out of the pinion's fillet)."""
    from hacgear_core.cli.info import info_dict

    model = _iso_model([("pinion", dict(teeth=17, normal_module_mm=14.0, profile_shift=0.2, face_width_mm=100.0,
                                        bore_diameter_mm=60.0)),
                        ("ring", dict(teeth=96, normal_module_mm=14.0, profile_shift=-0.5, internal=True,
                                      tip_alteration_mm=-1.4, face_width_mm=100.0, bore_diameter_mm=1600.0,
                                      basic_rack="C"))],
                       [("m12", "pinion", "ring", {})])
    info = info_dict(model)
    mi = _iso_check_pair(info, model, ("pinion", "ring"), (17, 96), (0.2, -0.5), 14e-3, 20.0, 0.0,
                         internal=(False, True))
    assert mi["center_distance_m"] * 1e3 == pytest.approx(557.0887, abs=5e-5)
    assert mi["operating_transverse_pressure_angle_deg"] == pytest.approx(21.1251, abs=5e-5)
    ring = info["gears"]["ring"]
    assert ring["iso"]["profile_shift"] == -0.5 and ring["iso"]["generating_profile_shift"] == pytest.approx(-0.5)
    assert ring["profile_shift"] == pytest.approx(0.5)   # the geometry's tool-displacement value keeps its sign
    # a negative ISO shift thins the ring's teeth: s_n = m_n (pi/2 + 2 x tan(alpha_n))
    assert ring["iso"]["normal_tooth_thickness_m"] < 0.5 * math.pi * 14e-3


def test_iso_sign_of_a_transverse_form_ring():
    """`info` reports a ring given in the transverse form with ISO 21771's sign: x_ISO = -(x of the tool's
    displacement) / cos(beta), from its tooth thickness s = m (pi/2 + 2 x_ISO tan(alpha))."""
    from hacgear_core.cli.info import info_dict

    model = load_model("planetary_65_55_175")
    info = info_dict(model)
    ring = model.gear("ring")
    alpha = ring.flanks["drive"].pressure_angle_rad
    x_iso = (ring.tooth_thickness_m / ring.module_m - math.pi / 2) / (2 * math.tan(alpha))
    assert info["gears"]["ring"]["iso"]["profile_shift"] == pytest.approx(x_iso, rel=1e-12)
    assert info["gears"]["ring"]["iso"]["profile_shift"] == pytest.approx(-info["gears"]["ring"]["profile_shift"],
                                                                          rel=1e-12)
    assert info["gears"]["ring"]["iso"]["form"] == "transverse"


def test_nrel_5mw_stage3_in_iso_form():
    """NREL 5 MW reference gearbox stage 3 (Nejad et al. 2016, issue #51 table): m_n = 14 mm, beta = 10 deg, z = 24 / 95,
    x = 0.480 / 0.669, k m_n = -0.938 mm, b = 360 mm, a_w = 861 mm: m_t = 14.215973 mm, alpha_t = 20.283559 deg."""
    from hacgear_core.cli.info import info_dict

    common = dict(normal_module_mm=14.0, helix_angle_deg=10.0, tip_alteration_mm=-0.938, face_width_mm=360.0)
    model = _iso_model([("pinion", dict(teeth=24, hand="right", profile_shift=0.480, bore_diameter_mm=150.0, **common)),
                        ("wheel", dict(teeth=95, hand="left", profile_shift=0.669, bore_diameter_mm=400.0, **common))],
                       [("m12", "pinion", "wheel", dict(center_distance_mm=861.0))], kind="helical_pair")
    info = info_dict(model)
    mi = _iso_check_pair(info, model, ("pinion", "wheel"), (24, 95), (0.480, 0.669), 14e-3, 20.0, 10.0, b=0.360)
    g = info["gears"]["pinion"]["iso"]
    assert round(g["transverse_module_m"] * 1e3, 6) == 14.215973
    assert round(g["transverse_pressure_angle_deg"]["drive"], 6) == 20.283559
    assert info["gears"]["pinion"]["profile_shift"] == pytest.approx(0.480 * math.cos(math.radians(10.0)))  # x_t
    assert mi["center_distance_m"] == 0.861 and mi["backlash_circular_m"] > 0


def test_nrel_5mw_stage1_planet_set_has_no_common_carrier_radius_at_nominal_thickness():
    """NREL stage 1 (m = 45 mm, z = 19 / 17 / 56, x = 0.617 / 0.802 / -0.501, k m_n = -10.861 / -10.861 / 0): with
    nominal ISO thicknesses the sun-planet mesh needs a_w >= 862.9956 mm, the ring-planet mesh a_w <= 862.9909 mm
    (the issue's numbers); at the paper's 863 mm the ring-planet teeth overlap and the refusal names the allowance
    that fixes it; with that allowance the set meshes with zero backlash there."""
    from hacgear_core.cli.info import info_dict
    from hacgear_core.model.iso21771 import working_center_distance

    r = math.radians(20.0)
    assert round(working_center_distance(45e-3, r, 0.0, 19, 17, 0.617, 0.802) * 1e3, 4) == 862.9956
    assert round(working_center_distance(45e-3, r, 0.0, 17, -56, 0.802, -0.501) * 1e3, 4) == 862.9909

    def model(ring_upper=None):
        extra = {} if ring_upper is None else {"thickness_allowance_upper_mm": ring_upper}
        return _iso_model(
            [("sun", dict(teeth=19, normal_module_mm=45.0, profile_shift=0.617, tip_alteration_mm=-10.861,
                          bore_diameter_mm=200.0, face_width_mm=491.0)),
             ("planet", dict(teeth=17, normal_module_mm=45.0, profile_shift=0.802, tip_alteration_mm=-10.861,
                             bore_diameter_mm=200.0, face_width_mm=491.0)),
             ("ring", dict(teeth=56, normal_module_mm=45.0, profile_shift=-0.501, internal=True, basic_rack="C",
                           bore_diameter_mm=2900.0, face_width_mm=491.0, **extra))],
            [("sun_planet", "sun", "planet", {}), ("planet_ring", "planet", "ring", {})], kind="planetary",
            planetary="[planetary]\nplanet_count = 3\ncarrier_radius_mm = 863.0")

    with pytest.raises(GeometryError, match="negative backlash") as exc:
        info_dict(model())
    msg = str(exc.value)
    assert "'planet' and 'ring'" in msg and "thickness_allowance_upper_mm" in msg
    fix = float(re.search(r"thickness_allowance_upper_mm = (-?[0-9.]+) on 'planet'", msg).group(1))
    assert fix < 0
    # the named allowance (on the other gear of the pair, the same sum) meshes: backlash >= 0, ~0 at its rounding
    info = info_dict(model(ring_upper=fix))
    j = info["meshes"]["planet_ring"]["iso"]["backlash_circular_min_m"]
    assert 0.0 <= j < 2e-9


def test_iso_tip_too_thin_is_refused_with_the_tip_alteration_that_fixes_it():
    from hacgear_core.cli.info import info_dict

    def model(k_mm):
        return _iso_model([("pinion", dict(teeth=12, normal_module_mm=3.0, profile_shift=0.8, tip_alteration_mm=k_mm)),
                           ("wheel", dict(teeth=40, normal_module_mm=3.0))], [("m12", "pinion", "wheel", {})])

    with pytest.raises(GeometryError, match="too thin at the tip") as exc:
        info_dict(model(0.0))
    msg = str(exc.value)
    k_fix = float(re.search(r"tip_alteration_mm <= (-?[0-9.]+)", msg).group(1))
    g = info_dict(model(k_fix - 1e-6))["gears"]["pinion"]["iso"]
    assert g["tip_normal_thickness_m"] == pytest.approx(0.2 * 3e-3, rel=1e-5)


def test_iso_ring_rack_root_radius_too_large_for_the_shaper_takes_its_full_radius():
    """An ISO-form ring whose rack A root radius (0.38 m_n) does not fit the tip of the shaper that cuts it (#51
    item 2: it was refused): the shaper's tip is its full radius (zero root land, max_hob_tip_radius_m), said in
    the warnings; the transverse form given that radius is still refused, naming the allowed range."""
    from dataclasses import replace

    from hacgear_core.geometry import gear_geometry, max_hob_tip_radius_m

    model = _iso_model([("pinion", dict(teeth=20, normal_module_mm=3.0)),
                        ("ring", dict(teeth=56, normal_module_mm=3.0, profile_shift=-0.5, internal=True,
                                      bore_diameter_mm=200.0))], [("m12", "pinion", "ring", {})])
    ring = model.gear("ring")
    assert ring.hob_tip_radius_m == pytest.approx(0.38 * 3e-3, rel=1e-12)
    gg = gear_geometry(ring)
    rho_full = max_hob_tip_radius_m(ring)
    assert rho_full < ring.hob_tip_radius_m
    assert gg.hob_tip_radius_m == pytest.approx(rho_full, rel=1e-8) and gg.hob_tip_radius_m <= rho_full
    assert any("full radius" in w and "0.38 m_n" in w for w in gg.warnings)
    with pytest.raises(GeometryError, match="hob_tip_radius_mm = 1.14 mm too large"):
        gear_geometry(replace(ring, iso=None))


def test_iso_tip_fillet_interference_names_the_tip_alteration_that_removes_it():
    """The internal pair of the published example with the ring's tip unshortened (k = 0): its tip reaches 0.03 mm
    into the pinion's fillet; the refusal names the ring's tip alteration that ends contact at the pinion's form
    diameter, and with it the pair meshes without interference."""
    from hacgear_core.cli.info import info_dict

    def model(k_mm, **pinion):
        return _iso_model([("pinion", {**dict(teeth=17, normal_module_mm=14.0, profile_shift=0.2, face_width_mm=100.0,
                                              bore_diameter_mm=60.0), **pinion}),
                           ("ring", dict(teeth=96, normal_module_mm=14.0, profile_shift=-0.5, internal=True,
                                         tip_alteration_mm=k_mm, face_width_mm=100.0, bore_diameter_mm=1600.0,
                                         basic_rack="C"))], [("m12", "pinion", "ring", {})])

    with pytest.raises(GeometryError, match="tip-fillet interference, the tip of 'ring'") as exc:
        info_dict(model(0.0))
    k = float(re.search(r"tip_alteration_mm of 'ring' <= (-?[0-9.]+)", str(exc.value)).group(1))
    assert -0.2 < k < 0
    # the pinion's rack is the other fix named (rack B: rho_fP* 0.30 < rack A's 0.38); a larger profile shift of the
    # pinion is not named, since it does not remove this interference (x = 0.3 is refused as well)
    assert "smaller rack_root_radius_coefficient / larger rack_dedendum_coefficient of 'pinion'" in str(exc.value)
    assert "profile_shift" not in str(exc.value)
    assert not info_dict(model(0.0, basic_rack="B"))["warnings"]
    with pytest.raises(GeometryError, match="tip-fillet interference, the tip of 'ring'"):
        info_dict(model(0.0, profile_shift=0.3))
    info = info_dict(model(k - 1e-6))
    assert not info["warnings"]
    # the contact now starts at the pinion's form point: r = r_b sqrt(1 + u^2) at the SAP roll angle u
    u = math.radians(info["meshes"]["m12"]["roll_angle_deg"]["SAP"]["pinion"])
    g = info["gears"]["pinion"]
    r_sap = g["base_radius_m"]["drive"] * math.sqrt(1 + u * u)
    assert 0.0 <= r_sap - g["form_radius_m"]["drive"] < 1e-7
