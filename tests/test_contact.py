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
