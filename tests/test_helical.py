"""Tests of the face-resolving (helical) static contact solver (hacgear_core.statics.helical) and of the 3D face
influence (hacgear_core.statics.fe3d).

Physics asserted: helix angle 0 reproduces the spur solver; the 12-DOF projections x = r_mesh·q and
gamma = r_twist·q see no rigid-body motion of the pair and reproduce the generalized coordinates of the static
solve; the generalized forces on the two gears balance and equal W r_mesh + M r_twist for involute contacts;
a mesh twist moves the contact pattern across the face (edge to edge at ±2 mrad, 200 N·m); an integer face
contact ratio makes the STE ripple small; the twist axis of the tables round-trips and interpolates trilinearly;
the statics grid writes the twist axis.  Slow: the 3D influence reproduces a 3D finite-element solve of a loaded
tooth within 5 %, slice convergence of the elastic coupling (< 0.5 %).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry, mesh_geometry
from hacgear_core.kinds import load_model
from hacgear_core.statics import ContactOptions, make_mesh_solver, mesh_stiffness_curve, model_variant
from hacgear_core.statics.helical import make_helical_solver

RIGID = ContactOptions(face_slices=11, face_coupling="rigid")


@pytest.fixture(scope="module")
def helical():
    return load_model("helical_28_33")


@pytest.fixture(scope="module")
def rigid_solver(helical):
    return make_helical_solver(helical, "m12", options=RIGID)


def _variant(model, beta_rad, face_m=None, axial=True):
    """Copy of a two-gear model with helix angle +-beta (gear_a right hand) and optionally another face width."""
    gears = []
    for i, g in enumerate(model.gears):
        kw = {"helix_angle_rad": (1.0 if i == 0 else -1.0) * beta_rad}
        if face_m is not None:
            kw["face_width_m"] = face_m
        if not axial:
            kw["axial_position_m"] = 0.0
        gears.append(replace(g, **kw))
    return replace(model, gears=tuple(gears), kind="helical_pair" if beta_rad else "spur_pair")


# ------------------------------------------------------------------------------------------ helix angle 0
def test_helix_zero_reproduces_the_spur_solver(helical):
    """Same transverse geometry, helix angle 0: the face-resolving solver's FDF and static deflections equal the
    spur solver's (done-when: within 0.5 %; they agree to round-off)."""
    spur_model = _variant(helical, 0.0)
    spur = make_mesh_solver(spur_model, "m12", options=RIGID)
    hel = make_helical_solver(spur_model, "m12", options=RIGID)
    assert hel.frame.base_helix_angle_rad == pytest.approx(0.0, abs=1e-12)
    for p in (0.0, 0.21, 0.5, 0.77):
        for x in (20e-6, 45e-6):
            a, b = spur.solve_deflection(p, x).mesh_force_N, hel.solve_deflection(p, x).mesh_force_N
            assert b == pytest.approx(a, rel=5e-3)
            assert b == pytest.approx(a, rel=1e-9)
        a, b = spur.solve_load(p, 3000.0), hel.solve_load(p, 3000.0)
        assert b.mesh_deflection_m == pytest.approx(a.mesh_deflection_m, rel=1e-9)
        np.testing.assert_allclose(b.tooth_load_N, a.tooth_load_N, rtol=1e-9, atol=1e-9)
        for g in a.strain:
            np.testing.assert_allclose(b.strain[g], a.strain[g], rtol=1e-9, atol=1e-15)
        for g in a.hub_reaction:
            np.testing.assert_allclose(b.hub_reaction[g], a.hub_reaction[g], rtol=1e-9, atol=1e-9)
        assert math.isfinite(b.twist_moment_Nm) and b.generalized_force.shape == (12,)


# ------------------------------------------------------------------------------------------ definitions
def test_projections_ignore_rigid_body_motion_and_match_the_static_patterns(rigid_solver):
    fr = rigid_solver.frame
    assert np.linalg.norm(fr.n_ref) == pytest.approx(1.0)
    assert np.linalg.norm(fr.r_twist[3:6]) == pytest.approx(1.0)
    assert abs(fr.base_helix_angle_rad) == pytest.approx(
        math.atan(math.tan(math.radians(15)) * math.cos(math.radians(25))), rel=1e-6)
    rng = np.random.default_rng(3)
    for _ in range(5):   # a rigid motion of the whole pair: translation t and small rotation w about the origin
        t, w = rng.normal(size=3) * 1e-5, rng.normal(size=3) * 1e-4
        q = np.concatenate([t + np.cross(w, fr.O[0]), w, t + np.cross(w, fr.O[1]), w])
        x, g = fr.projections(q)
        assert abs(x) < 1e-12 and abs(g) < 1e-15
    # the static x-pattern: hubs turned about their axes, equal shares of x; the twist pattern about e1 at P_ref
    x = 30e-6
    cb = math.cos(fr.base_helix_angle_rad)
    rb_a, rb_b = rigid_solver.base_radius_m
    q = np.zeros(12)
    q[5] = x / (2 * rb_a * cb)          # gear_a counter-clockwise (drives)
    q[11] = x / (2 * rb_b * cb)         # gear_b: + about z closes an external mesh on this side (checked below)
    assert fr.projections(q)[0] == pytest.approx(x, rel=1e-6)
    assert fr.projections(q)[1] == pytest.approx(0.0, abs=1e-15)
    gam = 1e-4
    qg = np.concatenate([np.cross(gam / 2 * fr.e1, fr.O[0] - fr.P_ref), gam / 2 * fr.e1,
                         np.cross(-gam / 2 * fr.e1, fr.O[1] - fr.P_ref), -gam / 2 * fr.e1])
    assert fr.projections(qg) == pytest.approx((0.0, gam), abs=1e-15)


def test_generalized_forces_balance_and_equal_the_slice_resultant(helical, rigid_solver):
    W = 200.0 / rigid_solver.lever_arm_m[0]
    st = rigid_solver.state_load(0.37, W, twist_rad=1e-4)
    gf = rigid_solver.generalized_forces(st)
    assert gf["mesh_force_N"] == pytest.approx(W, rel=1e-9)
    fa, fb = gf["wrench"][rigid_solver.gear_names[0]], gf["wrench"][rigid_solver.gear_names[1]]
    scale = np.abs(fa[:3]).max()
    assert np.abs(fa[:3] + fb[:3]).max() < 1e-6 * scale
    Oa, Ob = rigid_solver.frame.O
    # moments about a common point (O_a): M_a + M_b + (O_b - O_a) x F_b = 0
    assert np.abs(fa[3:] + fb[3:] + np.cross(Ob - Oa, fb[:3])).max() < 1e-6 * scale * 0.1
    # the torques: mesh force x lever arm on both gears (involute contacts)
    assert -fa[5] == pytest.approx(W * rigid_solver.lever_arm_m[0], rel=2e-3)
    # f_d = W r_mesh + M r_twist up to the relieved (non-involute) contacts
    assert gf["identity_residual"] < 2e-3
    plain = make_helical_solver(model_variant(helical, tip_relief=False, lead_crowning=False), "m12", options=RIGID)
    st = plain.state_load(0.37, W, twist_rad=1e-4)
    assert plain.generalized_forces(st)["identity_residual"] < 1e-4      # sampled flank normals: ~2e-5
    sol = rigid_solver.solve_load(0.37, W, twist_rad=1e-4)
    assert sol.slice_load_N.sum() == pytest.approx(sol.tooth_load_N.sum(), rel=1e-9)
    assert sol.twist_rad == 1e-4


# ------------------------------------------------------------------------------------------ twist
def test_twist_moves_the_contact_pattern_across_the_face(rigid_solver):
    s = rigid_solver
    W = 200.0 / s.lever_arm_m[0]
    zs = s.z_centre_m + s.slice_z_m

    def centroid_and_edges(tw):
        c, first, last = [], [], []
        for p in np.arange(4) / 4:
            pat = s.pattern(s.state_load(p, W, twist_rad=tw))["load_N"].sum(axis=0)
            c.append(pat @ zs / pat.sum())
            first.append(pat[0] / pat.sum())
            last.append(pat[-1] / pat.sum())
        return np.mean(c), np.max(first), np.max(last)

    c_neg, f_neg, l_neg = centroid_and_edges(-2e-3)
    c0, _, _ = centroid_and_edges(0.0)
    c_pos, f_pos, l_pos = centroid_and_edges(2e-3)
    # +gamma closes the -z side: the pattern moves from the +z edge (-2 mrad) to the -z edge (+2 mrad)
    assert c_neg > c0 > c_pos
    assert f_neg == 0.0 and l_neg > 0.05
    assert l_pos == 0.0 and f_pos > 0.05
    # the dissertation's +-0.002 deg barely moves it (0.35 um of gap across the face against 5 um crowning)
    c_small, _, _ = centroid_and_edges(math.radians(0.002))
    assert abs(c_small - c0) < 0.1e-3
    # twist stiffness: the twist moment grows with the twist at fixed deflection
    st = s.state_load(0.25, W)
    m = [s.generalized_forces(s.state_deflection(0.25, st.mesh_deflection_m, twist_rad=g))["twist_moment_Nm"]
         for g in (-1e-4, 0.0, 1e-4)]
    assert m[0] < m[1] < m[2]


def test_integer_face_contact_ratio_makes_the_ste_ripple_small(helical):
    """Helical theory: with face contact ratio 1 the total contact-line length is constant, so the STE ripple
    falls to a small fraction of the spur case's (unmodified teeth, same transverse geometry and face)."""
    base = model_variant(helical, tip_relief=False, lead_crowning=False)
    beta = math.radians(15.0)
    b = math.pi * 5e-3 / math.tan(beta)                        # eps_beta = b tan(beta) / (pi m_t) = 1
    hv, sv = _variant(base, beta, b, axial=False), _variant(base, 0.0, b, axial=False)
    assert mesh_geometry(hv, "m12").face_contact_ratio == pytest.approx(1.0, rel=1e-9)
    hs = make_helical_solver(hv, "m12", options=ContactOptions(face_slices=24, face_coupling="rigid"))
    ss = make_mesh_solver(sv, "m12", options=ContactOptions(face_slices=1, face_coupling="rigid"))
    ch = mesh_stiffness_curve(hs, 200.0 / hs.lever_arm_m[0], positions=16)
    cs = mesh_stiffness_curve(ss, 200.0 / ss.base_radius_m[0], positions=16)
    ratio = np.ptp(ch.ste_m) / np.ptp(cs.ste_m)
    assert ratio < 0.3
    # and a non-integer face contact ratio (0.5) keeps much more of it
    hh = make_helical_solver(_variant(base, beta, b / 2, axial=False), "m12",
                             options=ContactOptions(face_slices=12, face_coupling="rigid"))
    sh = make_mesh_solver(_variant(base, 0.0, b / 2, axial=False), "m12",
                          options=ContactOptions(face_slices=1, face_coupling="rigid"))
    r_half = np.ptp(mesh_stiffness_curve(hh, 200.0 / hh.lever_arm_m[0], positions=16).ste_m) / np.ptp(
        mesh_stiffness_curve(sh, 200.0 / sh.base_radius_m[0], positions=16).ste_m)
    assert r_half > 2 * ratio


def test_helices_that_do_not_mesh_are_refused(helical):
    gears = (helical.gears[0], replace(helical.gears[1], helix_angle_rad=helical.gears[0].helix_angle_rad))
    with pytest.raises(ModelError, match="opposite helix angles"):
        make_helical_solver(replace(helical, gears=gears), "m12", options=RIGID)


def test_gauges_across_the_face(helical, tmp_path):
    wheel = {g.name: g for g in helical.gears}["wheel"]
    fr = {x.name: x.face_fraction for x in wheel.gauges}
    assert fr["SG1"] == pytest.approx(0.1667) and fr["SG5"] == pytest.approx(0.8333) and fr["SG25"] == 0.5
    gg = gear_geometry(wheel)
    from hacgear_core.statics.fe import Gauge, _gauge_location

    p, t, n, s, reg = _gauge_location(gg, Gauge("SG3", "drive", 75.70e-3), 800)
    assert np.hypot(*p) == pytest.approx(75.70e-3, abs=1e-7) and reg == 1     # fillet end on the root circle
    assert abs(math.atan2(p[1], p[0])) < math.pi / gg.z * 0.99                 # not the mid-space root land
    bad = tmp_path / "m.toml"
    bad.write_text(helical.path.read_text().replace("face_fraction = 0.1667", "face_fraction = 1.5"))
    with pytest.raises(ModelError, match="face_fraction"):
        load_model(bad)


# ------------------------------------------------------------------------------------------ tables
class _RigidHelical:
    """Picklable factory of the rigid-coupling helical solver (no 3D build in the default suite)."""

    def __init__(self, path):
        self.path = str(path)

    def __call__(self):
        return make_helical_solver(load_model(self.path), "m12", options=RIGID)


def test_statics_grid_writes_the_twist_axis(helical, tmp_path):
    from hacgear_core.statics import run_statics
    from hacgear_core.tables import FORMAT_VERSION, read_tables

    twists = np.array([-2e-4, 0.0, 2e-4])
    out = tmp_path / "t.h5"
    kw = dict(n_positions=4, n_deflections=6, loads_N={"m12": np.array([0.0, 1500.0, 4500.0])}, workers=1,
              progress=False, twists_rad=twists)
    rep = run_statics({"m12": _RigidHelical(helical.path)}, out, **kw)
    assert rep.success
    t = read_tables(out)
    assert t.format_version == FORMAT_VERSION
    m = t.mesh("m12")
    tw = m.twist
    np.testing.assert_array_equal(tw.twist_rad, twists)
    np.testing.assert_array_equal(tw.generalized_fdf[:, :, 1, 0], m.force_N)          # gamma = 0 slice
    np.testing.assert_array_equal(tw.no_load_deflection_m[:, 1], m.no_load_deflection_m)
    # one trilinear lookup gives W and M at grid nodes and linear blends between them
    i, j = 1, 4
    np.testing.assert_allclose(m.generalized(m.position[i], m.deflection_m[j], twists[2]), tw.generalized_fdf[i, j, 2])
    mid = m.generalized(m.position[i], m.deflection_m[j], 1e-4)
    np.testing.assert_allclose(mid, 0.5 * (tw.generalized_fdf[i, j, 1] + tw.generalized_fdf[i, j, 2]), rtol=1e-12)
    fd = m.generalized_force(m.position[i], m.deflection_m[j], 0.0)
    W, M = tw.generalized_fdf[i, j, 1]
    assert np.linalg.norm(fd - (W * tw.r_mesh + M * tw.r_twist)) < 2e-3 * np.linalg.norm(fd)
    # the contact pattern sums to the tooth loads; +twist loads the -z side more
    np.testing.assert_allclose(tw.slice_load_N.sum(axis=-1), tw.tooth_load_N.sum(axis=-1), rtol=1e-5, atol=1e-3)  # float32
    zc = (tw.slice_load_N[:, j] @ tw.slice_z_m) / tw.slice_load_N[:, j].sum(axis=-1)
    assert np.all(zc[:, 0] > zc[:, 2])
    # deterministic and resumable: a second run with resume finds the finished file
    rep2 = run_statics({"m12": _RigidHelical(helical.path)}, out, resume=True, **kw)
    assert rep2.tasks_computed == 0


# ------------------------------------------------------------------------------------------ slow: 3D
@pytest.mark.slow
def test_face_influence_reproduces_a_3d_solve(helical):
    """The cached 3D influence coefficients (grid + interpolation + superposition) reproduce a direct solve of
    the same 3D model for loads off the grid: a point load, and a load along an inclined contact line."""
    from hacgear_core.statics import fe3d

    wheel = {g.name: g for g in helical.gears}["wheel"]
    gg = gear_geometry(wheel)
    fe = fe3d.ToothSectorFE(gg, fe3d.material_of(wheel))
    fi = fe3d.face_influence(gg, fe3d.material_of(wheel), "drive", fe=fe)
    for name, r in fe3d.influence_check(fi, fe, gg).items():
        assert abs(r["under_load_rel"]) < 0.05, name                  # under the load (measured -1.95 / +0.13 %)
        assert r["spread_rel"] < 0.05, name                           # its spread along the face (2.56 / 1.37 %)


@pytest.mark.slow
def test_elastic_coupling_converges_with_the_slice_count(helical):
    res = []
    for ns in (11, 22):
        s = make_helical_solver(helical, "m12", options=ContactOptions(face_slices=ns, face_coupling="elastic"))
        c = mesh_stiffness_curve(s, 200.0 / s.lever_arm_m[0], positions=16)
        res.append((c.mean_mesh_stiffness_N_per_m, c.ste_m.mean()))
    assert res[1][0] == pytest.approx(res[0][0], rel=5e-3)
    assert res[1][1] == pytest.approx(res[0][1], rel=5e-3)


def test_committed_tables_double_contact_widens_with_deflection():
    """Fig. 5.4: at zero twist the double-contact region of the FDF widens as the deflection grows."""
    from hacgear_core.tables import load_system_tables

    t = load_system_tables("helical_28_33").mesh("m12")
    assert t.twist is not None and t.twist.twist_rad.size == 9   # [statics] twist_points
    tl = t.tooth_load_N                                             # zero-twist slice (Np, Nd, Nw)
    frac = []
    for j in range(t.n_deflections):
        F = t.force_N[:, j]
        loaded = tl[:, j, :] > 1e-3 * np.maximum(F[:, None], 1e-9)
        frac.append(np.mean(loaded.sum(axis=1) >= 2))
    frac = np.asarray(frac)
    j0 = int(np.argmax(t.deflection_m > t.no_load_deflection_m.max()))
    assert np.all(np.diff(frac[j0:]) >= -1.0 / t.n_positions)      # non-decreasing (one grid position of slack)
    assert frac[-1] > frac[j0] + 0.2
    # the generalized FDF: W at zero twist equals the spur-compatible force_N; f_d identity within 1e-3
    g = t.twist.generalized_fdf
    np.testing.assert_array_equal(g[:, :, t.twist.zero_index, 0], t.force_N)
    fd = t.twist.generalized_force
    ident = g[..., :1] * t.twist.r_mesh + g[..., 1:] * t.twist.r_twist
    norm = np.linalg.norm(fd, axis=-1)
    big = norm > 0.05 * norm.max()
    assert np.max(np.linalg.norm(fd - ident, axis=-1)[big] / norm[big]) < 5e-3


def test_stiffness_cli_reports_twist_quantities(capsys):
    import json

    from hacgear_core.cli import main

    assert main(["stiffness", "helical_28_33", "--torque", "200", "--twist", "1e-4", "--positions", "4",
                 "--face-coupling", "rigid", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)["meshes"]["m12"]
    h = d["helical"]
    assert d["mesh_force_N"] == pytest.approx(200.0 / h["lever_arm_m"][0])
    assert h["twist_rad"] == 1e-4 and len(h["slice_load_N"][0]) == 11
    assert h["mean_twist_stiffness_Nm_per_rad"] > 0
    assert len(h["r_mesh"]) == 12 and len(h["r_twist"]) == 12


# ------------------------------------------------------------------------------------------ coast side
def _symmetric_flanks(model):
    """A copy of a two-gear helical model whose coast flanks equal its drive flanks (pressure angle and relief)
    and whose gears are centred at z = 0: the coast flank pair is then the drive pair's mirror image."""
    gears = tuple(replace(g, flanks={"drive": g.flanks["drive"], "coast": g.flanks["drive"]}, axial_position_m=0.0)
                  for g in model.gears)
    return replace(model, gears=gears)


def test_coast_side_of_symmetric_flanks_is_the_mirrored_drive_side(helical):
    """Symmetric flanks: the helical coast side (mirrored canonical picture with the helix hand reversed, drive
    positions tau_c = c0 - tau, normal deflection offset j_n cos(beta_bc)) reproduces the drive side at the
    mirrored position: the same NLMD (1e-14 relative, measured) and static deflection above the coast contact
    (measured 2e-5 … 1.3e-4 relative at 200 N*m: the two flanks' finite-element meshes differ; asserted 5e-4), the
    twist moment mirrored (z -> -z: opposite sign, sizes within 0.0073 N*m, asserted 0.02 N*m), the same base helix
    angle and lever arms; its mesh vector turns the gears the other way."""
    from hacgear_core.statics import make_coast_solver

    sym = _symmetric_flanks(helical)
    opts = ContactOptions(face_slices=5, face_coupling="rigid")
    drive = make_helical_solver(sym, "m12", options=opts)
    coast = make_coast_solver(sym, "m12", options=opts)
    assert coast.side == "coast" and coast.flanks == ("coast", "coast")
    bc = coast.frame.base_helix_angle_rad
    assert abs(bc) == pytest.approx(abs(drive.frame.base_helix_angle_rad), rel=1e-12)
    assert coast.contact_deflection_m == pytest.approx(coast.backlash_normal_m * math.cos(bc), rel=1e-12)
    np.testing.assert_allclose(coast.lever_arm_m, drive.lever_arm_m, rtol=1e-12)
    # the coast line of action turns the gears against their operating sense
    assert coast.frame.r_mesh[5] == pytest.approx(-drive.frame.r_mesh[5], rel=1e-9)
    assert coast.frame.r_mesh[11] == pytest.approx(-drive.frame.r_mesh[11], rel=1e-9)
    F = 3244.1
    for tau in (0.0, 0.3, 0.65):
        tc = coast.position_offset - tau            # the coast position whose mirrored picture is drive's tau
        sd, sc = drive.solve_load(tau, F), coast.solve_load(tc, F)
        assert sc.mesh_deflection_m - coast.contact_deflection_m == pytest.approx(sd.mesh_deflection_m, rel=5e-4)
        assert sc.twist_moment_Nm == pytest.approx(-sd.twist_moment_Nm, abs=0.02)
        assert coast.no_load_deflection(tc) - coast.contact_deflection_m == pytest.approx(
            drive.no_load_deflection(tau), rel=1e-9, abs=1e-15)
        # deflection control at a coast twist returns to the same force
        back = coast.solve_deflection(tc, sc.mesh_deflection_m)
        assert back.mesh_force_N == pytest.approx(F, rel=1e-4)
