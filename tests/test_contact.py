"""Tests of the static contact solver (hacgear_core.statics.contact).

Physics asserted: complementarity and optimality of the LCP solve, the Hertz closed form recovered
by the same solver on a discretized half-space, kinematics (pitch-point contact, lambda = 1 on the
line of action, periodicity), tip relief = no-load mesh deflection at the tip, premature contact
of unmodified teeth and its removal by relief, equilibrium of the hub reactions, driver/driven
symmetry of identical gears, load/deflection control consistency, mesh stiffness of the
dissertation's 28-tooth pair, and (slow) finite-element mesh convergence and hob tip radius trends.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hacgear_core.statics import (
    ContactOptions,
    make_mesh_solver,
    mesh_stiffness_curve,
    model_variant,
    root_strain_scan,
    solve_contact_lcp,
    solve_strip_contact,
)
from hacgear_core.errors import ModelError, SolverError
from hacgear_core.geometry import mesh_geometry
from hacgear_core.kinds import load_model
from hacgear_core.statics.nearfield import hertz_line_contact

TORQUE = 300.0


# ---------------------------------------------------------------------------------------------- LCP
def _random_problem(n, seed):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    C = (A @ A.T) * 1e-9 / n + np.eye(n) * 2e-9
    g0 = rng.uniform(0, 20e-6, n)
    lam = rng.uniform(0.6, 1.2, n)
    return C, g0, lam


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lcp_load_control_complementarity_and_consistency(seed):
    C, g0, lam = _random_problem(40, seed)
    r = solve_contact_lcp(C, g0, lam, mesh_force_N=5000.0)
    assert r.success, r.message
    F, g = r.force_N, g0 - lam * r.mesh_deflection_m + C @ r.force_N
    assert F.min() >= 0 and g.min() > -1e-12
    assert np.max(F * np.abs(g)) < 1e-12 * 5000
    assert lam @ F == pytest.approx(5000.0, rel=1e-12)
    # deflection control at the found deflection returns the same loads
    r2 = solve_contact_lcp(C, g0, lam, mesh_deflection_m=r.mesh_deflection_m)
    assert r2.success
    np.testing.assert_allclose(r2.force_N, F, atol=1e-6)
    # warm start from another load gives the same answer
    r3 = solve_contact_lcp(C, g0, lam, mesh_force_N=5000.0, warm_start=solve_contact_lcp(
        C, g0, lam, mesh_force_N=800.0).force_N)
    np.testing.assert_allclose(r3.force_N, F, atol=1e-6)


def test_lcp_matches_nnls_minimiser():
    """Deflection control is min ½FᵀCF + qᵀF, F >= 0: compare with scipy's NNLS on the Cholesky form."""
    from scipy.optimize import nnls

    C, g0, lam = _random_problem(30, 7)
    x = 12e-6
    q = g0 - lam * x
    L = np.linalg.cholesky(C)
    F_ref, _ = nnls(L.T, -np.linalg.solve(L, q))
    r = solve_contact_lcp(C, g0, lam, mesh_deflection_m=x)
    assert r.success
    np.testing.assert_allclose(r.force_N, F_ref, rtol=1e-6, atol=1e-6 * F_ref.max())


def test_lcp_zero_load_and_bad_input():
    C, g0, lam = _random_problem(5, 3)
    r = solve_contact_lcp(C, g0, lam, mesh_force_N=0.0)
    assert r.success and r.mesh_deflection_m == pytest.approx(np.min(g0 / lam))
    r = solve_contact_lcp(C, g0, lam, mesh_deflection_m=-1e-6)   # below every gap: open
    assert r.success and np.all(r.force_N == 0)
    with pytest.raises(SolverError, match="exactly one"):
        solve_contact_lcp(C, g0, lam)
    with pytest.raises(SolverError, match="mesh_force_N"):
        solve_contact_lcp(C, g0, lam, mesh_force_N=-1.0)


def test_discrete_contact_reproduces_hertz_two_cylinders():
    """Same LCP solver on a strip-discretized elastic half-space: Hertz peak pressure and
    half-width within 1 %."""
    w, R1, R2, E, nu = 3.2e5, 0.025, 0.018, 201.5e9, 0.3
    h = hertz_line_contact(w, R1, R2, E, nu)
    s = solve_strip_contact(w, R1, R2, E, nu, n_strips=201)
    assert s.lcp.success
    assert s.peak_pressure_Pa == pytest.approx(h.peak_pressure_Pa, rel=0.01)
    assert s.half_width_m == pytest.approx(h.half_width_m, rel=0.01)
    assert np.sum(s.pressure_Pa) * (s.x_m[1] - s.x_m[0]) == pytest.approx(w, rel=1e-9)


# ---------------------------------------------------------------------------------------------- model
@pytest.fixture(scope="module")
def model():
    return load_model("spur_28t_asym")


@pytest.fixture(scope="module")
def solver(model):
    return make_mesh_solver(model, "m12")


@pytest.fixture(scope="module")
def solver_unmod(model):
    return make_mesh_solver(model_variant(model, tip_relief=False), "m12")


def _force(s):
    return TORQUE / s.base_radius_m[0]


def test_kinematics_pitch_point_and_line_of_action(model, solver_unmod):
    mg = mesh_geometry(model, "m12")
    s = solver_unmod.setup(0.0)
    i0 = int(np.flatnonzero(s.pairs == 0)[0])
    ns = solver_unmod.options.face_slices
    centre = i0 * ns + ns // 2
    assert s.g0[centre] == pytest.approx(0.0, abs=2e-9)            # pitch-point contact, no crowning at centre
    rw = solver_unmod.operating_pitch_radius_m[1]
    rb = solver_unmod.base_radius_m[1]
    assert math.degrees(s.roll_b_rad[i0]) == pytest.approx(math.degrees(math.sqrt(rw**2 / rb**2 - 1)), abs=0.02)
    assert s.point[i0] == pytest.approx([solver_unmod.operating_pitch_radius_m[0], 0.0], abs=2e-5)
    # every involute contact inside the path of contact closes at the rate of the mesh deflection
    for p in np.linspace(0, 1, 9):
        st = solver_unmod.setup(p)
        inside = (~st.tip_contact) & (np.abs(st.g0[ns // 2::ns]) < 1e-8)
        assert np.any(inside)
        np.testing.assert_allclose(st.lam[ns // 2::ns][inside], 1.0, atol=2e-3)
    assert mg.contact_ratio == pytest.approx(1.45, abs=0.01)


def test_periodicity(solver):
    W = _force(solver)
    a = solver.solve_load(0.3, W)
    b = solver.solve_load(1.3, W)
    assert b.mesh_deflection_m == pytest.approx(a.mesh_deflection_m, rel=1e-9)
    np.testing.assert_allclose(b.tooth_load_N[1:], a.tooth_load_N[:-1], atol=1e-6 * W)


def _eap_position(model, solver):
    """Mesh position where pair 0's contact reaches gear_a's tip (wheel roll = its SAP)."""
    mg = mesh_geometry(model, "m12")
    rw, rb = solver.operating_pitch_radius_m[1], solver.base_radius_m[1]
    roll_pitch = math.sqrt(rw**2 / rb**2 - 1)
    return (roll_pitch - math.radians(mg.roll_angle_deg["wheel"]["SAP"])) / (2 * math.pi / solver.teeth[1])


def _pair0_closure(solver, tau):
    s = solver.setup(tau)
    i0 = int(np.flatnonzero(s.pairs == 0)[0])
    c = i0 * solver.options.face_slices + solver.options.face_slices // 2     # centre slice: no crowning
    return s.g0[c] / s.lam[c]


def test_relief_equals_no_load_deflection_at_the_tip(model, solver, solver_unmod):
    """At the position where pair 0's contact reaches the pinion's tip (EAP) the rigid closure that
    pair needs is the pinion's 47 µm tip relief (the wheel's relief is 0 at its SAP).  The relieved
    flank's closest point sits slightly below the tip (the relief tilts the common normal), so the
    closure is a little less than the relief; unmodified teeth need none."""
    tau = _eap_position(model, solver)
    relief = model.gears[0].flanks["drive"].tip_relief_m
    assert 0.93 * relief < _pair0_closure(solver, tau) <= relief
    assert abs(_pair0_closure(solver_unmod, tau)) < 0.2e-6


def _pair0_history(solver, positions):
    W = _force(solver)
    load, tip = [], []
    for p in positions:
        st = solver.state_load(p, W)
        assert st.success, st.message
        pr = solver.pair_results(st)
        i0 = int(np.flatnonzero(st.setup.pairs == 0)[0])
        load.append(pr["load_N"][i0])
        tip.append(bool(pr["tip_contact"][i0]))
    return np.array(load), np.array(tip)


def test_premature_contact_unmodified_and_removed_by_relief(model, solver, solver_unmod):
    mg = mesh_geometry(model, "m12")
    rw, rb = solver.operating_pitch_radius_m[1], solver.base_radius_m[1]
    roll_pitch = math.sqrt(rw**2 / rb**2 - 1)
    step = 2 * math.pi / solver.teeth[1]
    t_first = (roll_pitch - math.radians(mg.roll_angle_deg["wheel"]["EAP"])) / step   # wheel tip enters
    t_last = (roll_pitch - math.radians(mg.roll_angle_deg["wheel"]["SAP"])) / step    # pinion tip leaves
    pos = np.linspace(-1.0, 1.0, 97)
    outside = (pos < t_first - 1e-3) | (pos > t_last + 1e-3)
    load_u, tip_u = _pair0_history(solver_unmod, pos)
    load_r, tip_r = _pair0_history(solver, pos)
    # unmodified: pair 0 carries load before its SAP (tip-edge contact off the line of action)
    assert np.any((load_u > 0.02 * _force(solver)) & outside & tip_u)
    # 47 µm relief: no load outside the path of contact, no tip-edge contact at all
    assert not np.any((load_r > 0) & outside)
    assert not np.any(tip_r & (load_r > 0))


def test_equilibrium_hub_reactions(solver):
    W = _force(solver)
    for p in (0.0, 0.37, 0.55):
        st = solver.state_load(p, W)
        sol = solver.to_solution(st)
        ha, hb = sol.hub_reaction["pinion"], sol.hub_reaction["wheel"]
        # forces on the two gears are equal and opposite
        np.testing.assert_allclose(ha[:2], -hb[:2], atol=2e-3 * W)
        # torques: W = ½(T_a/r_b1 + T_b/r_b2), and the mesh torque opposes the drive on both gears
        s = st.setup
        rb1, rb2 = solver.base_radius_m
        assert 0.5 * (-ha[2] / rb1 - hb[2] / rb2) == pytest.approx(W, rel=2e-3)
        # resultant of the contact forces (point, normal) agrees with the finite-element reaction
        Fp = np.bincount(s.pair_index, weights=st.force_N, minlength=len(s.pairs))
        ok = Fp > 0
        f_on_b = (Fp[ok, None] * s.normal[ok]).sum(axis=0)
        np.testing.assert_allclose(hb[:2], f_on_b, atol=3e-3 * W)


def test_symmetry_identical_gears(solver):
    """Identical gears: the driven gear's strain at mesh position p equals the driver's at -p."""
    W = _force(solver)
    for p in (0.15, 0.42, 0.61, 0.8):
        a, b = solver.state_load(p, W), solver.state_load(-p, W)
        ea, eb = solver.strains(a, offsets=[0, 1]), solver.strains(b, offsets=[0, -1])
        scale = abs(ea["wheel/SG25"]).max() + 1e-6
        np.testing.assert_allclose(ea["wheel/SG25"], eb["pinion/SG25"], atol=5e-3 * scale)
        np.testing.assert_allclose(ea["wheel/SG20"], eb["pinion/SG20"], atol=5e-3 * scale)


def test_load_and_deflection_control_agree(solver):
    W = _force(solver)
    loads, defl = solver.solve_position(0.45, [0.3 * W, W, 2 * W], [])
    assert all(s.success for s in loads)
    x = [s.mesh_deflection_m for s in loads]
    assert x[0] < x[1] < x[2]
    _, back = solver.solve_position(0.45, [], x)
    for s, Wi in zip(back, (0.3 * W, W, 2 * W)):
        assert s.mesh_force_N == pytest.approx(Wi, rel=1e-5)
    # below the no-load deflection the teeth separate
    x0 = solver.no_load_deflection(0.45)
    assert solver.solve_deflection(0.45, x0 - 1e-6).mesh_force_N == 0.0
    assert solver.solve_deflection(0.45, x0 + 1e-6).mesh_force_N > 0.0


def test_relief_raises_max_root_strain(solver, solver_unmod):
    W = _force(solver)
    pos = np.linspace(-1, 1, 65)
    m_r = max(solver.strains(solver.state_load(p, W), offsets=[0])["wheel/SG25"][0] for p in pos)
    m_u = max(solver_unmod.strains(solver_unmod.state_load(p, W), offsets=[0])["wheel/SG25"][0] for p in pos)
    assert m_r > m_u > 0


def test_mean_mesh_stiffness(model, solver):
    """Dissertation Section 3.6.2: mean mesh stiffness ≈ 150e6 N/m at 300 N m (15 mm face, 15 µm
    crowning, 47 µm relief).  Unmodified, uncrowned teeth agree with the prototype FE measurement in
    DESIGN.md (187e6 N/m, 8.3 µm peak-to-peak) within 5 %; relief and crowning lower the mean
    stiffness."""
    c = mesh_stiffness_curve(solver, _force(solver), positions=32)
    assert c.secant_mesh_stiffness_N_per_m < c.mean_mesh_stiffness_N_per_m
    plain = make_mesh_solver(model_variant(model, tip_relief=False, lead_crowning=False), "m12")
    cp = mesh_stiffness_curve(plain, _force(plain), positions=32)
    assert cp.mean_mesh_stiffness_N_per_m == pytest.approx(187e6, rel=0.05)
    assert np.ptp(cp.ste_m) == pytest.approx(8.3e-6, rel=0.1)
    assert c.mean_mesh_stiffness_N_per_m < 0.92 * cp.mean_mesh_stiffness_N_per_m


def test_mean_mesh_stiffness_within_10_percent_of_150e6(solver):
    """Issue #3's criterion as asked: dissertation Section 3.6.2, 150e6 N/m +/- 10 % at 300 N m.

    Measured 164.5e6 N/m (+9.7 %) with the model's 21 face slices and 40 mm bore: inside the band by
    only 0.3 points, less than the blank's own uncertainty (docs/validation.md, 'The unspecified
    blank'); with 5 face slices (under-resolved crowning) it was 165.8e6 (+10.5 %)."""
    c = mesh_stiffness_curve(solver, _force(solver), positions=32)
    assert c.mean_mesh_stiffness_N_per_m == pytest.approx(150e6, rel=0.10)


def test_face_slices_resolve_lead_crowning(model):
    """The face discretisation is converged at the default: 21 vs 41 slices change the mean
    local-slope stiffness and the mean STE of the crowned 28-tooth pair by < 0.3 %, while 5 slices
    (one sample of the parabola per 3 mm) are off by more than that."""
    def curve(ns):
        s = make_mesh_solver(model, "m12", options=ContactOptions(face_slices=ns))
        return mesh_stiffness_curve(s, _force(s), positions=32)

    assert model.statics.face_slices == 21
    c5, c21, c41 = curve(5), curve(21), curve(41)
    k5, k21, k41 = (c.mean_mesh_stiffness_N_per_m for c in (c5, c21, c41))
    assert k21 == pytest.approx(k41, rel=0.003)
    assert np.mean(c21.ste_m) == pytest.approx(np.mean(c41.ste_m), rel=0.003)
    assert abs(k5 / k41 - 1) > 0.003


def test_solution_protocol(solver):
    from hacgear_core.statics import MeshStaticSolver, describe_solver

    assert isinstance(solver, MeshStaticSolver)
    info = describe_solver(solver)
    assert info.gauge_names == ("pinion/SG25", "pinion/SG20", "wheel/SG25", "wheel/SG20")
    sol = solver.solve_load(0.2, _force(solver))
    assert sol.success and sol.tooth_load_N.shape == (len(solver.tooth_offsets),)
    # gauge stresses: surface stress along the profile = E eps_t (plane stress, steel of Table 3.3)
    assert set(sol.stress) == set(sol.strain)
    for name in sol.strain:
        np.testing.assert_allclose(sol.stress[name], 201.5e9 * sol.strain[name], rtol=1e-12)
    with pytest.raises(ModelError, match="no gauge"):
        solver.surface_modulus_Pa("pinion/nope")
    # contact location: profile coordinate on both flanks where loaded, NaN where not; the pinion's contact
    # lies between its tip (s = 0) and the end of its flank
    loaded = sol.tooth_load_N > 0
    assert sol.contact_s_m.shape == (len(solver.tooth_offsets), 2)
    assert np.all(np.isfinite(sol.contact_s_m[loaded])) and np.all(np.isnan(sol.contact_s_m[~loaded]))
    assert np.all((sol.contact_s_m[loaded] >= 0) & (sol.contact_s_m[loaded] < 0.02))
    assert np.nansum(sol.tooth_load_N) == pytest.approx(_force(solver), rel=0.02)
    assert np.all(sol.half_width_m[sol.tooth_load_N > 0] > 0)
    # 300 N m on 15 mm: contact pressure of a few hundred MPa to ~1.5 GPa
    assert 3e8 < sol.peak_pressure_Pa.max() < 2.5e9
    import pickle

    clone = pickle.loads(pickle.dumps(solver))
    assert clone.solve_load(0.2, _force(solver)).mesh_deflection_m == pytest.approx(sol.mesh_deflection_m)


def test_bad_input_messages(model):
    with pytest.raises(ModelError, match="face_slices"):
        ContactOptions(face_slices=0)
    with pytest.raises(ModelError, match="face_coupling"):
        ContactOptions(face_coupling="glue")
    with pytest.raises(ModelError, match="unknown mesh"):
        make_mesh_solver(model, "nope")
    with pytest.raises((ModelError, SolverError), match="flank"):
        bad = replace(model, meshes=(replace(model.meshes[0], flank_a="coast"),))
        make_mesh_solver(bad, "m12")


def test_coast_flank_mesh(model):
    """Loading the 20° flanks (mirrored frames): torque balance and a higher contact ratio
    (smoother transmission error) than the 25° flanks at the same torque."""
    mc = replace(model, meshes=(replace(model.meshes[0], flank_a="coast", flank_b="coast"),))
    s = make_mesh_solver(mc, "m12")
    W = TORQUE / s.base_radius_m[0]
    st = s.state_load(0.1, W)
    h = s.hub_reactions(st)
    assert h["pinion"][2] == pytest.approx(-TORQUE, rel=2e-3)
    assert h["wheel"][2] == pytest.approx(-TORQUE, rel=2e-3)


@pytest.mark.parametrize("driver", ["ring", "planet"])
def test_internal_mesh(driver):
    """Internal mesh, either gear driving (the shipped planetary model: planet = gear_a drives the ring with its
    coast flank; the variant: ring = gear_a drives the planet), both turning the same way: conjugate contact at
    the pitch point, lambda = 1 on the line of action, torque balance on both gears."""
    import dataclasses

    from hacgear_core.model import Mesh

    m = load_model("planetary_65_55_175")
    if driver == "ring":
        ring_mesh = Mesh("ring_planet", "ring", "planet", "drive", "coast", 96.54e-3)
        m = dataclasses.replace(m, meshes=(m.meshes[0], ring_mesh))
    s = make_mesh_solver(m, "ring_planet")
    assert s.internal and s.gear_names[0] == driver
    ns = s.options.face_slices
    st0 = s.setup(0.0)
    i0 = int(np.flatnonzero(st0.pairs == 0)[0])
    assert abs(st0.g0[i0 * ns + ns // 2]) < 0.1e-6
    assert st0.lam[i0 * ns + ns // 2] == pytest.approx(1.0, abs=1e-3)
    W = 2000.0
    driven = "planet" if driver == "ring" else "ring"
    for p in (0.1, 0.6):
        st = s.state_load(p, W)
        assert st.success, st.message
        h = s.hub_reactions(st)
        rb1, rb2 = s.base_radius_m
        assert h[driver][2] == pytest.approx(-W * rb1, rel=0.01)      # opposes the driver's drive
        assert h[driven][2] == pytest.approx(W * rb2, rel=0.01)       # drives the other gear the same way round
        np.testing.assert_allclose(h[driver][:2], -h[driven][:2], atol=1e-9 * W)
        assert s.solve_deflection(p, st.mesh_deflection_m).mesh_force_N == pytest.approx(W, rel=1e-5)


# ---------------------------------------------------------------------------------------------- slow
@pytest.mark.slow
def test_fe_mesh_convergence(model):
    """Refining the finite-element mesh twice changes the STE and the mean mesh stiffness by < 1 %."""
    from hacgear_core.statics.fe import MeshOptions

    out = []
    for f in (1.0, 2.0):
        s = make_mesh_solver(model, "m12", fe_options=MeshOptions().refined(f))
        c = mesh_stiffness_curve(s, _force(s), positions=32)
        out.append((c.ste_m.mean(), c.mean_mesh_stiffness_N_per_m, c.ste_m))
    assert out[1][0] == pytest.approx(out[0][0], rel=0.01)
    assert out[1][1] == pytest.approx(out[0][1], rel=0.01)
    assert np.max(np.abs(out[1][2] - out[0][2])) < 0.01 * out[0][0]


def test_root_strain_scan_arc_sampling_and_gauge_grid(model):
    """root_strain_scan options: ``sampling="arc"`` spaces the points equally in arc length over the
    radius-sampling range (root circle + 2 % to SAP); a gauge grid (``gauge_length_m``) is the mean
    of the point strains at its sub-points, centred on the point -- checked against point gauges
    placed independently at those radii on a separately built solver."""
    from hacgear_core.geometry import gear_geometry
    from hacgear_core.model import Gauge

    W = TORQUE / 0.0634415450925655
    kw = dict(n_gauges=4, positions=5, span=(-0.45, -0.2))
    a = root_strain_scan(model, "m12", W, sampling="arc", **kw)
    L, n = 1.0e-3, 3
    g = root_strain_scan(model, "m12", W, sampling="arc", gauge_length_m=L, gauge_points=n, **kw)
    gg = gear_geometry(model.gears[1])
    mg = mesh_geometry(model, "m12")
    r_sap = gg.base_radius_m["drive"] * math.sqrt(1 + math.radians(mg.roll_angle_deg["wheel"]["SAP"]) ** 2)
    r_lo = gg.root_radius_m + 0.02 * (r_sap - gg.root_radius_m)
    assert a.sampling == "arc" and g.gauge_length_m == L
    assert a.radius_m[0] == pytest.approx(r_lo, abs=1e-7) and a.radius_m[-1] == pytest.approx(r_sap, abs=1e-7)
    ds = np.diff(a.s_m)
    assert np.ptp(ds) < 1e-3 * abs(ds).mean()                   # equal arc steps (to the profile sampling)
    assert np.ptp(np.diff(a.radius_m)) > 0.2 * abs(np.diff(a.radius_m)).mean()   # ... not equal radius steps
    np.testing.assert_allclose(g.s_m, a.s_m, atol=2e-6)       # grids centred on the points
    # independent point gauges at the grid's sub-points
    p = gg.flank("drive", 4000)
    s, r, reg = np.asarray(p.s), np.asarray(p.radius), np.asarray(p.region)
    o = np.argsort(s[reg != 0])
    u = ((np.arange(n) + 0.5) / n - 0.5) * L
    sub = np.interp(a.s_m[:, None] + u[None, :], s[reg != 0][o], r[reg != 0][o])
    gauges = [("wheel", Gauge(f"P{i}{j}", "drive", float(sub[i, j]))) for i in range(4) for j in range(n)]
    gauges += [("wheel", Gauge(f"C{i}", "drive", float(a.radius_m[i]))) for i in range(4)]
    sv = make_mesh_solver(model, "m12", gauges=gauges)
    for k, pos in enumerate(g.position):
        e = sv.strains(sv.state_load(pos, W), offsets=[0])
        mean = [np.mean([e[f"wheel/P{i}{j}"][0] for j in range(n)]) for i in range(4)]
        # (the FE locates gauges on its own 800-point profile: sub-micrometre differences in place)
        np.testing.assert_allclose(g.strain[k], mean, rtol=5e-4)
        np.testing.assert_allclose(a.strain[k], [e[f"wheel/C{i}"][0] for i in range(4)], rtol=5e-4)
    # a 1 mm grid on the loaded root averages a curved strain distribution: it differs from the point value
    assert np.max(np.abs(g.strain - a.strain)) > 1e-3 * np.max(np.abs(a.strain))


def test_root_strain_scan_bad_options(model):
    for kw, word in ((dict(sampling="angle"), "sampling"), (dict(gauge_length_m=-1e-3), "gauge_length_m"),
                     (dict(gauge_length_m=1e-2), "gauge_length_m"), (dict(gauge_points=1), "gauge_points")):
        with pytest.raises(ModelError, match=word):
            root_strain_scan(model, "m12", 1000.0, **kw)


@pytest.mark.slow
def test_hob_tip_radius_trend(model):
    """Dissertation Fig. 2.7: max root strain over the fillet +10.0 % for a 0.01 mm hob tip radius
    and -13.2 % for 1.8 mm (the largest radius the tool allows), relative to 0.4 mm (±4 points).
    Measured with the converged point strain (48 points equally spaced in arc length, 0.1 mm elements
    along the fillets; docs/static_contact.md "Hob tip radius"): +11.4 % and -20.6 %.  0.01 mm is
    checked against the dissertation's band; for 1.8 mm the trend is asserted -- monotone in the
    radius and a reduction at least the dissertation's lower bound (9.2 %); the dissertation's band
    for 1.8 mm is the strict xfail below."""
    m = _hob_max_strains(model)
    assert m[0.01e-3] / m[0.4e-3] - 1 == pytest.approx(0.100, abs=0.04)
    assert m[0.01e-3] > m[0.4e-3] > m[1.3e-3] > m[1.8e-3]
    assert m[1.8e-3] / m[0.4e-3] - 1 < -0.132 + 0.04


def _hob_max_strains(model, _cache={}):
    if not _cache:
        from hacgear_core.statics.fe import MeshOptions

        W = TORQUE / 0.0634415450925655
        _cache.update({r: root_strain_scan(model_variant(model, hob_tip_radius_m=r), "m12", W, positions=96,
                                           sampling="arc", n_gauges=48,
                                           fe_options=MeshOptions(fillet_size_m=0.1e-3)).max_strain
                       for r in (0.01e-3, 0.4e-3, 1.3e-3, 1.8e-3)})
    return _cache


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="measured -20.6 % for 1.8 mm vs the dissertation's -13.2 % +/- 4 points; "
                   "geometry, FE convergence, gauge definition and location checked (docs/static_contact.md)")
def test_hob_tip_radius_18mm_matches_dissertation_band(model):
    m = _hob_max_strains(model)
    assert m[1.8e-3] / m[0.4e-3] - 1 == pytest.approx(-0.132, abs=0.04)


def test_tip_edge_and_flank_pressures_are_told_apart():
    """The unmodified 50-tooth pair at its nominal load (2412 N): at mesh position 0.25 the next tooth pair
    touches early at the tip edge (a corner on the mating flank: 3.6 GPa with the 0.1 mm edge radius) while the
    loaded pair's flank carries 0.45 GPa; the solution gives both per pair, and the peak is the larger of the two.
    At the pitch point region (0.5, two pairs on their flanks) there is no edge contact."""
    from hacgear_core.statics.helical import make_solver
    s = make_solver(load_model("spur_50t_icr137"), "m12")
    sol = s.solve_load(0.25, 2412.0)
    k = list(s.tooth_offsets)
    i0, i1 = k.index(0), k.index(1)
    assert sol.tooth_load_N[i1] > 0.1 * 2412.0
    assert sol.edge_pressure_Pa[i1] > 2e9 and sol.flank_pressure_Pa[i1] == 0.0
    assert 0.3e9 < sol.flank_pressure_Pa[i0] < 0.6e9 and sol.edge_pressure_Pa[i0] == 0.0
    np.testing.assert_array_equal(np.maximum(sol.flank_pressure_Pa, sol.edge_pressure_Pa), sol.peak_pressure_Pa)
    mid = s.solve_load(0.5, 2412.0)
    assert np.all(mid.edge_pressure_Pa == 0.0) and np.all(mid.flank_pressure_Pa == mid.peak_pressure_Pa)


# ------------------------------------------------------------------------------ pitch point off a flank
# NREL 5 MW reference gearbox, stage 2 (Nejad et al. 2016, Wind Energy 19, doi 10.1002/we.1884) in the ISO form:
# m_n 21 mm, z 18 / 36 / 93 (ring internal), x 0.389 / 0.504 / 0.117, k m_n -1.75 / -1.75 / 0 mm, a_w 584 mm.  The
# ring's tip circle (d_a 1906.086 mm) lies outside the ring-planet operating pitch circle (d_w 1905.684 mm): the
# pitch point is off the ring's flank.  Thickness allowances (-0.1 / -0.2 mm on the sun and the planet) give the
# set its backlash (with nominal thicknesses the sun-planet teeth overlap at 584 mm).
_NREL2 = """
[system]
name = "nrel_stage2_ring_planet"
kind = "planetary"
[materials.steel]
density_kg_per_m3 = 7830.0
youngs_modulus_GPa = 206.0
poisson_ratio = 0.3
{gears}
[[meshes]]
name = "sun_planet"
gear_a = "sun"
gear_b = "planet"
[[meshes]]
name = "ring_planet"
gear_a = "planet"
gear_b = "ring"
flank_a = "coast"
flank_b = "drive"
[planetary]
planet_count = 3
carrier_radius_mm = 584.0
fixed_member = "ring"
[damping]
modal_damping_ratio = 0.02
[operating]
torque_Nm = 100000.0
torque_gear = "sun"
"""
_NREL2_GEARS = (("sun", 18, 0.389, -1.75, 100.0, ""), ("planet", 36, 0.504, -1.75, 95.0, ""),
                ("ring", 93, 0.117, 0.0, 2200.0, "internal = true\n"))


def _nrel2_toml(ring_tip_alteration_mm: float = 0.0) -> str:
    gears = ""
    for name, z, x, k, bore, extra in _NREL2_GEARS:
        k = ring_tip_alteration_mm if name == "ring" else k
        gears += (f'[[gears]]\nname = "{name}"\nteeth = {z}\n{extra}normal_module_mm = 21.0\n'
                  f'normal_pressure_angle_deg = 20.0\nbasic_rack = "A"\nprofile_shift = {x}\n'
                  f'tip_alteration_mm = {k}\nface_width_mm = 550.0\nbore_diameter_mm = {bore}\nmaterial = "steel"\n')
        if name != "ring":
            gears += "thickness_allowance_upper_mm = -0.1\nthickness_allowance_lower_mm = -0.2\n"
    return _NREL2.format(gears=gears)


def _coarse_fe(factor: float = 20.0):
    """The default finite-element sizes x ``factor`` (all five lengths: a module-21 gear meshed like a module-1 one)."""
    from hacgear_core.statics.fe import MeshOptions

    o = MeshOptions()
    return replace(o, **{k: getattr(o, k) * factor for k in ("flank_size_m", "fillet_size_m", "body_size_m",
                                                              "fine_layer_m", "growth_length_m")})


def _nrel2_model(folder, ring_tip_alteration_mm: float = 0.0):
    path = folder / "model.toml"
    path.write_text(_nrel2_toml(ring_tip_alteration_mm))
    return load_model(path)


def _nrel2_ring_force(model) -> float:
    """Nominal ring-mesh force [N]: the sun torque over 3 planets and the sun's base radius (planet base radius
    alike in both meshes)."""
    return model.operating.torque_Nm / (3 * mesh_geometry(model, "sun_planet").base_radius_m["sun"])


@pytest.fixture(scope="module")
def nrel2(tmp_path_factory):
    return _nrel2_model(tmp_path_factory.mktemp("nrel2"))


@pytest.fixture(scope="module")
def nrel2_solver(nrel2):
    return make_mesh_solver(nrel2, "ring_planet", fe_options=_coarse_fe(), options=ContactOptions(face_slices=1))


def test_pitch_point_off_the_ring_flank_statics_completes(nrel2, nrel2_solver, tmp_path):
    """NREL stage 2's ring-planet mesh (the pitch point 0.2 mm inside the ring's tip circle; the statics stopped
    with 'operating pitch radius 0.952842 m lies outside the involute'): the solver places the gears by the ring's
    involute continued to the pitch point, and `statics` on a tiny grid (4 positions, both sides) completes.  The
    contact path lies wholly after the pitch point, from the ring's tip circle (closed form) over the contact ratio
    of the geometry; with no load the drive flanks touch at 0 and the coast flanks at the normal backlash of the
    geometry (which takes each tooth's thickness on the operating pitch circle from the involute function)."""
    import functools

    from hacgear_core.statics.coast import make_coast_solver
    from hacgear_core.statics.grid import load_grid, run_statics

    s = nrel2_solver
    mg = mesh_geometry(nrel2, "ring_planet")
    assert s.pitch_point_off_flank == ("ring",)
    rb_r, rw_r = s.base_radius_m[1], s.operating_pitch_radius_m[1]
    ra_r = 0.5 * (93 * 21e-3 - 2 * 21e-3 * (1.0 + 0.117))            # ISO 21771 internal tip diameter / 2
    assert ra_r > rw_r
    p_b = 2 * math.pi * rb_r / 93
    lo, hi = s.active_path_phases()
    assert lo == pytest.approx((math.sqrt(ra_r**2 - rb_r**2) - math.sqrt(rw_r**2 - rb_r**2)) / p_b, rel=1e-6)
    assert 0.0 < lo < 0.02
    assert hi - lo == pytest.approx(mg.contact_ratio, rel=1e-9)
    F = _nrel2_ring_force(nrel2)
    fac = {"ring_planet": functools.partial(make_mesh_solver, nrel2, "ring_planet", fe_options=_coarse_fe(),
                                            options=ContactOptions(face_slices=1)),
           "ring_planet/coast": functools.partial(make_coast_solver, nrel2, "ring_planet", fe_options=_coarse_fe(),
                                                  options=ContactOptions(face_slices=1))}
    rep = run_statics(fac, tmp_path / "tables.h5", n_positions=4, n_deflections=4,
                      loads_N={k: load_grid(3 * F, 3) for k in fac}, workers=1, progress=False)
    assert rep.success, rep.message
    drive, coast = rep.meshes["ring_planet"], rep.meshes["ring_planet/coast"]
    assert abs(drive["no_load_deflection_min_m"]) < 0.05e-6
    assert coast["no_load_deflection_min_m"] == pytest.approx(mg.backlash_normal_m, abs=0.05e-6)
    assert drive["fdf_max_decrease_N"] == 0.0 and coast["fdf_max_decrease_N"] == 0.0


def test_pitch_point_off_the_flank_is_the_continued_involute(nrel2, nrel2_solver, tmp_path):
    """The reference (mesh position 0: tooth pair 0 at the pitch point) off the ring's flank is the ring's exact
    involute continued (the geometry's involute point at the pitch radius), and the contacts then follow the
    conjugate kinematics: at a light load the ring's contact roll angle of pair k at position tau is
    tan(alpha_w) + (tau - k) p_b / r_b (within the flank sampling); the same positions of a ring whose tip
    alteration (+0.3 mm) brings its tip inside the pitch circle (pitch point on its flank: the unchanged path) give
    the same rolls (1e-5 deg) and, at the nominal load at positions away from the tip, the same pair loads within
    0.2 % of the mesh force and the same mesh deflection within 0.2 % (measured 0.15 % and 0.08 %: the ring teeth
    differ by the 0.3 mm)."""
    from hacgear_core.geometry import gear_geometry
    from hacgear_core.statics.contact import _extended_involute_polar

    s = nrel2_solver
    fl = s._flank[1]
    rb_r, rw_r = s.base_radius_m[1], s.operating_pitch_radius_m[1]
    u = math.sqrt(rw_r**2 / rb_r**2 - 1.0)
    xy, _, _ = gear_geometry(nrel2.gear("ring")).involute_point("drive", u)
    exact = math.atan2(-xy[1] if s._mirror else xy[1], xy[0])
    inv = fl.region == 2
    o = np.argsort(fl.radius[inv])
    rr, ang = fl.radius[inv][o], np.arctan2(fl.xy0[inv, 1], fl.xy0[inv, 0])[o]
    assert rr[0] > rw_r
    assert _extended_involute_polar(rr, ang, rb_r, rw_r) == pytest.approx(exact, abs=1e-12)
    assert s._theta_P_b - s._phi0[1] == pytest.approx(exact, abs=1e-12)
    # inside the samples the continuation is the involute too (the sampled polar angles, 1e-12 rad)
    mid = len(rr) // 2
    assert _extended_involute_polar(rr[:mid], ang[:mid], rb_r, float(rr[-1])) == pytest.approx(ang[-1], abs=1e-12)
    # conjugate kinematics at a light load; the same positions with the pitch point on the ring's flank
    alpha_w = math.acos(rb_r / rw_r)
    p_b = 2 * math.pi * rb_r / 93
    k = list(s.tooth_offsets)
    light, nominal = 0.05 * _nrel2_ring_force(nrel2), _nrel2_ring_force(nrel2)
    control = make_mesh_solver(_nrel2_model(tmp_path, ring_tip_alteration_mm=0.3), "ring_planet",
                               fe_options=_coarse_fe(), options=ContactOptions(face_slices=1))
    assert control.pitch_point_off_flank == ()
    assert control.operating_pitch_radius_m == s.operating_pitch_radius_m
    for tau in (0.25, 0.5):
        sol = s.solve_load(tau, light)
        for kk in (-1, 0):
            roll = math.tan(alpha_w) + (tau - kk) * p_b / rb_r
            # within 0.02 deg (0.3 mm on the ring, 5 flank samples; measured <= 0.009 deg).  A reference clamped to
            # the ring's tip circle instead of the continued involute turns the ring by 0.0034 deg: the exact
            # involute point above (1e-12 rad) and the on-flank ring below (1e-5 deg) tell it apart
            assert sol.contact_roll_deg[k.index(kk)] == pytest.approx(math.degrees(roll), abs=0.02)
        a, b = s.solve_load(tau, nominal), control.solve_load(tau, nominal)
        assert np.count_nonzero(a.tooth_load_N) == 2
        np.testing.assert_allclose(a.contact_roll_deg, b.contact_roll_deg, atol=1e-5)     # measured 2e-7 deg
        np.testing.assert_allclose(a.tooth_load_N, b.tooth_load_N, rtol=0, atol=2e-3 * nominal)
        assert a.mesh_deflection_m == pytest.approx(b.mesh_deflection_m, rel=2e-3)


def test_contact_path_beyond_the_pair_window_is_refused_naming_the_fix(nrel2):
    """With the pitch point off a flank the contact path lies to one side of it; a path reaching beyond the pairs
    the solver examines on each side (here pair_window = 1 < 1.63 base pitches) is refused, naming the gear, the
    keys and the diameter that puts the pitch point on its flank."""
    from hacgear_core.errors import GeometryError

    with pytest.raises(GeometryError) as exc:
        make_mesh_solver(nrel2, "ring_planet", fe_options=_coarse_fe(),
                         options=ContactOptions(face_slices=1, pair_window=1))
    msg = str(exc.value)
    assert "'ring_planet'" in msg and "off the involute of 'ring'" in msg and "pair_window = 1" in msg
    assert "tip circle of 'ring' (d = 1906.0860 mm)" in msg and "d_w = 1905.6842 mm" in msg
    assert "tip_alteration_mm" in msg and "1.630 base pitches" in msg


# the models whose tables were computed before the contact solver continued an involute to an off-flank pitch point
_TABLED_MODELS = ("gear_train_2stage", "helical_28_33", "idler_28_33_39", "planetary_65_55_175",
                  "planetary_65_55_175_unmodified", "spur_28t_asym", "spur_50t_icr137", "spur_50t_icr18")


@pytest.mark.parametrize("system", _TABLED_MODELS)
def test_shipped_meshes_have_the_pitch_point_on_both_flanks(system):
    """Every mesh of the models with committed tables, both sides, has its operating pitch point strictly inside
    both loaded flanks' sampled involutes, so the solver takes the interpolation it always took (their tables stay
    bit for bit); only an off-flank pitch point reaches the continued involute."""
    from hacgear_core.geometry import gear_geometry
    from hacgear_core.statics.contact import _canonical_flank

    other = {"drive": "coast", "coast": "drive"}
    model = load_model(system)
    opts = ContactOptions()
    gears = {g.name: g for g in model.gears}
    for mesh in model.meshes:
        ga, gb = gear_geometry(gears[mesh.gear_a]), gear_geometry(gears[mesh.gear_b])
        C = mesh_geometry(model, mesh.name).center_distance_m
        for flanks in ((mesh.flank_a, mesh.flank_b), (other[mesh.flank_a], other[mesh.flank_b])):
            rb_a, rb_b = ga.base_radius_m[flanks[0]], gb.base_radius_m[flanks[1]]
            internal = ga.internal or gb.internal
            rw_a = C * rb_a / (abs(rb_b - rb_a) if internal else rb_a + rb_b)
            rw_b = C * rb_b / abs(rb_b - rb_a) if internal else C - rw_a
            for gg, side, rw in ((ga, flanks[0], rw_a), (gb, flanks[1], rw_b)):
                fl = _canonical_flank(gg, side, opts.n_profile, opts.corner_radius_m, (0.0, 1.0), flanks[0] == "coast")
                rr = fl.radius[fl.region == 2]
                assert rr.min() < rw < rr.max(), (system, mesh.name, flanks, gg.name)


def test_pitch_point_on_the_flanks_keeps_the_interpolated_reference(solver_unmod):
    """The 28-tooth pair (pitch point on both flanks): no gear is off its flank and the frame angles are the
    sampled involutes' polar angles interpolated at the pitch radii, bit for bit (the code path of every shipped
    table)."""
    s = solver_unmod
    assert s.pitch_point_off_flank == ()
    ref = []
    for fl, rw in zip(s._flank, s.operating_pitch_radius_m):
        inv = fl.region == 2
        o = np.argsort(fl.radius[inv])
        ref.append(float(np.interp(rw, fl.radius[inv][o], np.arctan2(fl.xy0[inv, 1], fl.xy0[inv, 0])[o])))
    assert s._phi0 == (-ref[0], s._theta_P_b - ref[1])
