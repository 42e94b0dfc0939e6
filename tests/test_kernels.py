"""Tests of the compiled RK4 kernel (hacgear_core.dynamics.kernels): conservation, order, contact loss, precision."""
from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction

import numpy as np
import pytest

from _dyn import K, params, simulator, system
from hacgear_core.dynamics import kernels
from hacgear_core.dynamics.equilibrium import static_state
from hacgear_core.dynamics.steady import steady_state
from hacgear_core.dynamics.synthetic import linear_fdf_table, spur_fdf_table, synthetic_28t_parameters
from hacgear_core.tables.interp import bilinear_many


def test_undamped_energy_conserved_to_rk4_order():
    tab = linear_fdf_table(K)
    p = params(modal_damping_ratio=0.0, bearing_stiffness_N_per_m=(300e6, 250e6))
    drift = []
    for spc in (32, 64):
        sy = system(p, tab)
        s = static_state(sy)
        n = sy.n
        s[n + sy.gears["gear1"].rotation] += 0.05  # rad/s
        s[n + 0] += 0.02  # y1 rate m/s
        fext = sy.fext_speed()
        m, kd, v = np.diag(sy.M), np.diag(sy.K), sy.V[0]

        def energy(s):
            q, qd = s[:n], s[n:]
            x = v @ q
            return 0.5 * np.sum(m * qd**2) + 0.5 * np.sum(kd * q**2) + 0.5 * K * x**2 - fext @ q

        e0 = energy(s)
        h = 1.0 / (spc * sy.max_frequency_Hz)
        kin = np.array([0.0, 0.0, 500.0])
        sy.integrate(s, kin, int(300 * spc), h, fext)
        drift.append(abs(energy(s) - e0) / abs(e0 - energy(static_state(sy))))
    assert drift[0] < 1e-2
    assert drift[0] / drift[1] > 16  # RK4 energy error per step ~ (w h)^6 -> global ~ h^5


def test_rk4_fourth_order_convergence():
    tab = linear_fdf_table(K)
    p = params(bearing_stiffness_N_per_m=(300e6, 300e6))
    out = []
    for h in (4e-6, 2e-6, 1e-6):  # below the default internal step (1/32 of the shortest period)
        sim = simulator(p, tab, internal_step_s=h)
        sim.s[sim.system.n + sim.system.iref] += 0.1
        sim.set_speed_input(mesh_frequency_Hz=1000.0)
        assert sim.advance(0.004).success
        out.append(sim.s.copy())
    e1 = np.linalg.norm(out[0] - out[1])
    e2 = np.linalg.norm(out[1] - out[2])
    assert 12 < e1 / e2 < 20


def test_contact_loss_gives_zero_force():
    tab = spur_fdf_table(tip_relief_m=20e-6, stiffness_variation=0.1)
    sy = system(synthetic_28t_parameters(tab, torque_Nm=100.0), tab)
    dx = tab.deflection_m[1] - tab.deflection_m[0]
    tau = np.linspace(0, 1, 500, endpoint=False)
    nl = np.interp(tau, np.append(tab.position, 1.0), np.append(tab.no_load_deflection_m, tab.no_load_deflection_m[0]))
    # the force law (the kernel's rule: the one interpolation, clipped at 0) below the no-load deflection
    assert np.all(sy.mesh_force(0, tau, nl - 2 * dx) == 0.0)
    assert np.all(sy.mesh_force(0, tau, np.full(tau.size, -1e-3)) == 0.0)
    # the tables' grid rule (first two columns below every no-load deflection): the extrapolation below is 0
    out = np.empty(tau.size)
    bilinear_many(np.ascontiguousarray(tab.force_N), tab.deflection_m[0], 1 / dx, tau, np.full(tau.size, -1e-3), out)
    assert np.all(out == 0.0)
    # a resonant steady state with contact loss: zero force exactly where the teeth separate
    r = steady_state(sy, 2300.0, keep_trace=True)
    f = r.trace["mesh_force_N"][:, 0]
    assert r.metrics["contact_loss_fraction"][0] > 0.1
    x = r.trace["mesh_deflection_m"][:, 0]
    t = r.trace["mesh_position"][:, 0] % 1.0
    nl_t = np.interp(t, np.append(tab.position, 1.0), np.append(tab.no_load_deflection_m, tab.no_load_deflection_m[0]))
    assert np.all(f[x < nl_t - 2 * dx] == 0.0)
    assert np.all(f[x > tab.no_load_deflection_m.max() + 2 * dx] > 0.0)


def test_conventional_laws_equal_hac_for_constant_stiffness():
    tab = linear_fdf_table(K)
    res = {}
    for law in ("hac", "ste", "average_slope", "local_slope"):
        sy = system(params(), tab, law)
        s = static_state(sy)
        s[sy.n + sy.iref] += 0.2
        kin = np.array([0.0, 0.0, 300.0])
        sy.integrate(s, kin, 5000, 2e-6, sy.fext_speed())
        res[law] = s
    for law in ("ste", "average_slope", "local_slope"):
        np.testing.assert_allclose(res[law], res["hac"], rtol=1e-9, atol=1e-15)


def test_long_runs_keep_precision():
    """The reference rotation is (integer cycles, fraction): after 1e12 mesh cycles the dynamics are bit-identical
    to those at cycle 0 (an absolute angle in float64 would have lost the mesh position entirely by then)."""
    tab = spur_fdf_table(tip_relief_m=20e-6)
    sy = system(synthetic_28t_parameters(tab), tab)
    out = []
    for cycles0 in (0.0, 1e12):
        s = static_state(sy)
        kin = np.array([0.25, cycles0, 1500.0 / sy.zref_2pi])
        sy.integrate(s, kin, 128 * 50, 1.0 / (1500.0 * 128), sy.fext_speed())
        out.append((s.copy(), kin[0], kin[1] - cycles0))
    np.testing.assert_array_equal(out[0][0], out[1][0])
    assert out[0][1] == out[1][1] and out[0][2] == out[1][2] == 50.0


@pytest.mark.parametrize("n_dof", [2, 4])
def test_specialised_and_generic_loops_agree(n_dof):
    """The loops specialised on (n, m) and the generic loop are the same arithmetic."""
    from hacgear_core.dynamics import kernels

    tab = spur_fdf_table(tip_relief_m=20e-6)
    p = synthetic_28t_parameters(tab, bearing_stiffness_N_per_m=200e6 if n_dof == 4 else float("inf"))
    sy = system(p, tab)
    assert sy.n == n_dof and sy.kernel is not kernels._GENERIC[(kernels.LAW_TABLE, False)]
    res = []
    for kern in (sy.kernel, kernels._GENERIC[(kernels.LAW_TABLE, False)]):
        sy.kernel = kern
        s = static_state(sy)
        kin = np.array([0.0, 0.0, 2000.0 / sy.zref_2pi])
        sy.integrate(s, kin, 128 * 20, 1.0 / (2000.0 * 128), sy.fext_speed())
        res.append(s)
    np.testing.assert_allclose(res[0], res[1], rtol=1e-12, atol=1e-18)


def test_rotating_frame_terms_match_the_equations_of_motion():
    """Gyroscopic and centripetal terms and an off-diagonal support stiffness (the planetary case): the kernel
    integrates M q'' + (C + W_c G) q' + (K - W_c^2 K_W) q + F v = f with W_c = c_ratio omega_ref, checked against
    scipy's adaptive RK45 of the same equations written out with dense matrices."""
    from scipy.integrate import solve_ivp

    tab = linear_fdf_table(K)
    base = system(params(bearing_stiffness_N_per_m=(300e6, 250e6)), tab)
    n = base.n
    kk = base.K.copy()
    kk[0, 2] = kk[2, 0] = -80e6  # a coupling spring between the two bearings
    g = np.zeros((n, n))
    g[0, 2], g[2, 0] = 0.7, -0.7  # skew-symmetric gyroscopic coupling [kg]
    kw = np.diag([0.9, 0.0, 1.1, 0.0])  # centripetal stiffness per (rad/s)^2 [kg]
    sy = base.with_changes(stiffness=kk, gyroscopic=g, centripetal=kw, carrier_ratio=0.4)
    omega = 2000.0 / sy.zref_2pi
    wc = 0.4 * omega
    s0 = static_state(base)
    s0[n:] = [0.01, 0.3, -0.02, -0.2]
    fext = sy.fext_speed()
    keff, ceff, minv, v = kk - wc**2 * kw, sy.C + wc * g, np.linalg.inv(sy.M), sy.V[0]

    def rhs(t, y):
        q, qd = y[:n], y[n:]
        tau = sy.phase[0] + sy.zref_2pi * omega * t + sy.W[0] @ q
        f = float(sy.mesh_force(0, np.array([tau % 1.0]), np.array([v @ q]))[0])
        return np.concatenate([qd, minv @ (fext - ceff @ qd - keff @ q - f * v)])

    t_end = 5.0 / 2000.0
    ref = solve_ivp(rhs, (0.0, t_end), s0, method="DOP853", rtol=1e-11, atol=1e-16).y[:, -1]
    scale = np.abs(ref).reshape(2, n).max(axis=1).repeat(n)
    err = []
    for steps in (5 * 128, 5 * 256):
        s = s0.copy()
        sy.integrate(s, np.array([0.0, 0.0, omega]), steps, t_end / steps, fext)
        err.append(np.max(np.abs(s - ref) / scale))
    assert err[1] < 1e-6 and 12 < err[0] / err[1] < 20  # RK4: fourth order towards the same solution
    # and the rotating terms matter at this speed: without them the answer is far off
    s_fixed = s0.copy()
    base.with_changes(stiffness=kk).integrate(s_fixed, np.array([0.0, 0.0, omega]), steps, t_end / steps, fext)
    assert np.max(np.abs(s_fixed - ref) / scale) > 1e-3


def _two_sided_pair(kc=120e6, backlash=150e-6):
    tab = linear_fdf_table(K, coast_stiffness_N_per_m=kc, backlash_m=backlash)
    sy = system(params(modal_damping_ratio=0.0), tab)
    assert sy.two_sided and sy.kernel is not system(params(), linear_fdf_table(K)).kernel
    return sy, tab


def test_two_sided_mesh_conserves_energy_across_impacts():
    """Undamped pair with a gap: the teeth fly across the backlash and hit both flanks; the energy (kinetic plus
    the work stored in both flanks' force laws) is conserved to the integrator's accuracy, better with a finer
    step."""
    sy, tab = _two_sided_pair()
    n = sy.n
    def stored(law, nodes):
        """Exact potential of a force law that is linear between ``nodes`` (the table's grid): quadratic per cell."""
        xs = np.union1d(np.linspace(-1e-3, 1e-3, 2001), nodes)
        f = law(0, 0.0, xs)
        e = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(xs))])

        def pot(x):
            i = np.clip(np.searchsorted(xs, x) - 1, 0, xs.size - 2)
            d = x - xs[i]
            return e[i] + f[i] * d + 0.5 * (f[i + 1] - f[i]) / (xs[i + 1] - xs[i]) * d * d
        return pot

    pd = stored(sy.mesh_force, tab.deflection_m)
    pc = stored(sy.coast_force, tab.coast.deflection_m)

    def energy(s):
        q, qd = s[:n], s[n:]
        return 0.5 * qd @ sy.M @ qd + pd(sy.V[0] @ q) + pc(sy.Vc[0] @ q)

    drift = []
    for spc in (400, 800):
        s = np.zeros(2 * n)
        s[n + sy.iref] = 0.4  # rad/s: 25 mm/s along the line of action, across the 150 um gap
        e0 = energy(s)
        rec_s = np.zeros((4000, 2 * n))
        rec_o = np.zeros((4000, 6 * sy.m + 1))
        h = 1.0 / (spc * 3000.0)
        sy.integrate(s, np.zeros(3), 4000 * 8 * spc // 100, h, np.zeros(n), rec_every=8 * spc // 100,
                     rec_state=rec_s, rec_out=rec_o)
        fc = rec_o[:, 5]
        assert np.sum(np.diff((fc > 0).astype(int)) == 1) >= 5  # several back-side impacts
        assert np.sum(np.diff((rec_o[:, 2] > 0).astype(int)) == 1) >= 5  # and drive-side ones
        drift.append(max(abs(energy(r) - e0) for r in rec_s) / e0)
    assert drift[0] < 1e-4
    assert drift[1] < drift[0] / 3


def test_oscillation_across_the_backlash_has_the_piecewise_linear_period():
    """Free rattle of an unloaded pair: half a period in drive contact (pi / w_d), a flight across the gap
    (j / V), half a period in coast contact (pi / w_c), the flight back: T = pi/w_d + pi/w_c + 2 j / V."""
    kc, j = 80e6, 150e-6
    sy, tab = _two_sided_pair(kc=kc, backlash=j)
    n = sy.n
    m_eff = 1.0 / (sy.V[0] @ np.linalg.solve(sy.M, sy.V[0]))
    np.testing.assert_allclose(sy.Vc[0], -sy.V[0], rtol=1e-12)  # equal base radii: xc = -x
    vel = 0.2  # m/s along the line of action
    s = np.zeros(2 * n)
    s[n + sy.iref] = vel / sy.V[0, sy.iref]
    h = 2e-7
    nrec = 60000
    rec_s, rec_o = np.zeros((nrec, 2 * n)), np.zeros((nrec, 6 * sy.m + 1))
    sy.integrate(s, np.zeros(3), nrec, h, np.zeros(n), rec_every=1, rec_state=rec_s, rec_out=rec_o)
    x = rec_o[:, 1]
    t = rec_o[:, -1]
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))  # entries into drive contact
    tc = t[up] - x[up] * h / (x[up + 1] - x[up])
    period = np.diff(tc)
    closed = math.pi * math.sqrt(m_eff / K) + math.pi * math.sqrt(m_eff / kc) + 2 * j / vel
    assert len(period) >= 3
    np.testing.assert_allclose(period, closed, rtol=2e-4)
    assert x.min() < -j  # the teeth crossed the gap into coast contact


@pytest.mark.parametrize("bearing", [math.inf, 200e6])
def test_coast_side_changes_nothing_while_the_drive_flanks_carry_the_load(bearing):
    """A coast table that is never reached leaves the drive-flank dynamics bit-identical (the coast terms add
    exact zeros), with rigid and with elastic bearings."""
    one = linear_fdf_table(K, offset_amplitude_m=2e-6)
    two = linear_fdf_table(K, offset_amplitude_m=2e-6, coast_stiffness_N_per_m=100e6, backlash_m=150e-6)
    out = []
    for tab in (one, two):
        sy = system(params(bearing_stiffness_N_per_m=(bearing, bearing)), tab)
        s = static_state(sy)
        rec_o = np.zeros((500, 6 * sy.m + 1))
        sy.integrate(s, np.array([0.0, 0.0, 1800.0 / sy.zref_2pi]), 128 * 50, 1.0 / (1800.0 * 128), sy.fext_speed(),
                     rec_every=128 // 10, rec_state=np.zeros((500, 2 * sy.n)), rec_out=rec_o)
        out.append((s, rec_o[:, :4]))
    assert not system(params(), one).two_sided and system(params(), two).two_sided
    np.testing.assert_array_equal(out[0][0], out[1][0])
    np.testing.assert_array_equal(out[0][1], out[1][1])


def test_coast_terms_skipped_only_where_they_are_zero():
    """A two-sided loop stages a step without its coast terms only when every coast approach of the step stays
    below the coast table's onset; forcing the coast terms into every step (onset at -inf) gives the same rattle
    bit for bit, while the teeth cross the backlash many times (steps near and inside coast contact)."""
    out = []
    for force_coast in (False, True):
        sy, _ = _two_sided_pair()
        tflt = sy.kernel_constants[9]
        assert np.isfinite(tflt[1, 2])
        if force_coast:
            tflt[1, 2] = -math.inf
        n = sy.n
        s = np.zeros(2 * n)
        s[n + sy.iref] = 0.4
        rec_s, rec_o = np.zeros((2000, 2 * n)), np.zeros((2000, 6 * sy.m + 1))
        sy.integrate(s, np.zeros(3), 2000 * 64, 1.0 / (400 * 3000.0), np.zeros(n), rec_every=64,
                     rec_state=rec_s, rec_out=rec_o)
        out.append((s, rec_o))
    fc = out[0][1][:, 5]
    assert np.sum(np.diff((fc > 0).astype(int)) == 1) >= 3
    np.testing.assert_array_equal(out[0][0], out[1][0])
    np.testing.assert_array_equal(out[0][1][:, :-1], out[1][1][:, :-1])


def test_prepare_kernel_announces_a_compile_and_nothing_else():
    """prepare_kernel calls the notice once, before numba compiles (the notice sees no compiled overload yet), and
    not again when the specialisation is in memory; a different argument type compiles (and announces) anew."""
    from numba import njit

    from hacgear_core.dynamics.kernels import prepare_kernel

    @njit
    def twice(a, b):
        return 2.0 * a[0] + b

    seen = []
    kern = twice
    x = np.ones(3)
    note = lambda msg: seen.append((msg, len(kern.overloads)))  # noqa: E731
    compiled, sec = prepare_kernel(kern, (x, 1.0), "the test kernel", note)
    assert compiled and sec > 0
    assert len(seen) == 1 and seen[0][1] == 0 and seen[0][0].startswith("compiling the test kernel: once per machine")
    assert prepare_kernel(kern, (x, 1.0), "the test kernel", note) == (False, 0.0)
    assert len(seen) == 1 and twice(x, 1.0) == 3.0
    compiled, _ = prepare_kernel(kern, (x, 1), "the test kernel", note)  # int64 b: a second specialisation
    assert compiled and len(seen) == 2 and seen[1][1] == 1


def test_integrate_prepares_the_kernel_once_through_the_compile_logger(caplog):
    """LumpedSystem.integrate makes its kernel ready on its first call (the notice, if it compiles, goes to the
    COMPILE_LOGGER logger) and not on later calls; the kernel label names DOFs, meshes and flanks."""
    import logging

    from hacgear_core.dynamics import kernels

    tab = spur_fdf_table()
    sy = system(synthetic_28t_parameters(tab), tab)
    assert sy.kernel_label == "the integration kernel for 2 DOF x 1 mesh (force tables)"
    calls = []
    real = sy.prepare_kernel
    sy.prepare_kernel = lambda notice=None: calls.append(1) or real(notice)
    s, kin = static_state(sy), np.array([0.0, 0.0, 1000.0 / sy.zref_2pi])
    with caplog.at_level(logging.INFO, logger=kernels.COMPILE_LOGGER):
        for _ in range(3):
            sy.integrate(s, kin, 16, 1e-6, sy.fext_speed())
    assert calls == [1]
    assert all(r.name == kernels.COMPILE_LOGGER
               and r.getMessage().startswith("compiling the integration kernel for 2 DOF") for r in caplog.records)
    assert kernels.kernel_label(kernels.LAW_TWIST, 12, 1) == "the integration kernel for 12 DOF x 1 mesh (helical)"
    assert kernels.kernel_label(kernels.LAW_TABLE, 14, 6, True).endswith(
        "14 DOF x 6 meshes (force tables, both flanks)")


@pytest.mark.parametrize("p, q", [(1, 1), (23, 71), (71, 23), (13, 11), (1, 96), (4625, 48)])
def test_mesh_base_is_the_exact_fraction_of_the_rate_times_the_reference_position(p, q):
    """A mesh at rate p/q sits at frac((p/q) (cycles + tau_ref)) with (p/q)(cycles + tau_ref) - frac whole cycles:
    the kernel's rule and the system's numpy twin against exact rational arithmetic, over runs up to 1e9 reference
    cycles (both directions); rate 1 returns (tau_ref, cycles) themselves."""
    from fractions import Fraction

    from hacgear_core.dynamics.kernels import mesh_base
    rng = np.random.default_rng(p * 1000 + q)
    for cycles in [0.0, 1.0, 70.0, 71.0, -1.0, -72.0, 12345.0, 1e9, -3e8] + list(rng.integers(-10**6, 10**6, 20)):
        cycles = float(cycles)
        for tau in (0.0, 0.5, 0.999999, float(rng.random())):
            exact = Fraction(p, q) * (Fraction(cycles) + Fraction(tau))
            whole = exact.numerator // exact.denominator
            base, n = mesh_base(float(p), float(q), cycles, tau)
            assert n == whole
            assert 0.0 <= base < 1.0
            assert base == pytest.approx(float(exact - whole), abs=4e-16 * max(1.0, p / q) * 4)
            if p == q:
                assert (base, n) == (tau, cycles)


def test_an_open_helical_side_beyond_its_twist_grid_is_not_out_of_range():
    """NREL stage 3 under its rated torque: the coast side's twist coordinate sits at 2.6 mrad, beyond the tables'
    +-0.5 mrad, while its flanks are apart (no force, no moment): no step counts as beyond the tables (before the
    count looked at open sides too, every step counted)."""
    from hacgear_core.dynamics import Simulator
    from hacgear_core.kinds import build_system, load_model
    from hacgear_core.tables import load_system_tables

    sy = build_system(load_model("nrel_5mw_stage3"), load_system_tables("nrel_5mw_stage3"))
    sim = Simulator(sy)
    sim.reset(speed_rad_s=30.8)
    rec = sim.run(0.005, 1e-3)
    assert np.all(np.abs(rec["coast_twist_rad"][:, 0]) > 2e-3)
    assert np.all(rec["coast_approach_m"][:, 0] < 0.0) and np.all(rec["coast_force_N"][:, 0] == 0.0)   # open
    assert sim.out_of_range_steps == [0]


def test_frame_coupling_matches_the_fixed_frame_closed_form():
    """Two point masses on isotropic springs, each seen from its own frame turning at its own speed (gyroscopic and
    centripetal terms), joined by a spring across the frames (a frame coupling, the stiffness periodic in the
    frames' relative angle): turned back into the fixed frame, the kernel's free vibration is the fixed-frame
    closed form of two masses and three springs, which knows nothing of frames.  The frames' relative angle D is
    held at each step's middle, so the error is of second order in the angle a step turns, below (h D')^2
    (here h D' = 2.8e-3 and 1.4e-3; in a gearbox h D' is ~1e-4 or less: docs/dynamics.md "Frame couplings")."""
    from scipy.linalg import eigh
    from hacgear_core.dynamics.system import FrameCoupling

    base = system(params(modal_damping_ratio=0.0), linear_fdf_table(K))
    n0 = base.n
    n = n0 + 4
    ma, mb, ka, kb, kab = 8.0, 12.0, 1.1e8, 0.7e8, 0.9e8
    ca, cb = 0.3, -0.5                           # frame speeds over the reference speed (counter-clockwise)
    z = base.zref_2pi * 2 * math.pi              # reference mesh cycles per reference revolution
    rate = Fraction(cb - ca).limit_denominator(10) / Fraction(z).limit_denominator(1000)
    assert float(rate) == pytest.approx((cb - ca) / z, rel=1e-12)
    pad = np.zeros(4)
    J = np.array([[0.0, -1.0], [1.0, 0.0]])
    M = np.zeros((n, n))
    M[:n0, :n0] = base.M
    M[n0:, n0:] = np.diag([ma, ma, mb, mb])
    Kt = np.zeros((n, n))
    Kt[:n0, :n0] = base.K
    Kt[n0:, n0:] = np.diag([ka + kab, ka + kab, kb + kab, kb + kab])
    Kt[n0:n0 + 2, n0 + 2:] = Kt[n0 + 2:, n0:n0 + 2] = -kab * np.eye(2)       # the coupling at the assembly angle
    Ba, Bb = np.zeros((2, n)), np.zeros((2, n))
    Ba[:, n0:n0 + 2] = np.eye(2)
    Bb[:, n0 + 2:] = np.eye(2)
    fc = FrameCoupling("shaft", kc=-kab * (Ba.T @ Bb + Bb.T @ Ba), ks=-kab * (Ba.T @ J @ Bb + Bb.T @ J.T @ Ba),
                       rate=(rate.numerator, rate.denominator))
    G = np.zeros((n, n))
    G[:n0, :n0] = base.G
    G[n0:n0 + 2, n0:n0 + 2] = 2 * ma * ca * J
    G[n0 + 2:, n0 + 2:] = 2 * mb * cb * J
    KW = np.zeros((n, n))
    KW[n0:, n0:] = np.diag([ma * ca ** 2, ma * ca ** 2, mb * cb ** 2, mb * cb ** 2])
    meshes = tuple(replace(c, v=np.concatenate([c.v, pad]), w=np.concatenate([c.w, pad]),
                           v_rot=np.concatenate([c.v_rot, pad])) for c in base.meshes)
    sy = base.with_changes(dof_names=base.dof_names + ("xa", "ya", "xb", "yb"), mass=M, stiffness=Kt, meshes=meshes,
                           gyroscopic=G, centripetal=KW, carrier_ratio=1.0, frame_couplings=(fc,),
                           rigid_mode=None if base.rigid_mode is None else np.concatenate([base.rigid_mode, pad]),
                           reference_motion=np.concatenate([base.reference_motion, pad]),
                           static_forces=np.concatenate([base.static_forces, pad]), bearing_maps={})
    assert sy.kernel is kernels._GENERIC[(kernels.LAW_TABLE, False)]
    omega = 2000.0 / sy.zref_2pi
    t_end = 40.0 / 2000.0                        # the frames turn 0.8 * omega * t_end = 5.0 rad against each other
    s0 = np.zeros(2 * n)
    s0[:n0] = static_state(base)[:n0]
    qa, qb, va, vb = np.array([2e-5, -1e-5]), np.array([-0.5e-5, 1.5e-5]), np.array([0.02, 0.01]), np.array([0.0, -0.03])
    s0[n0:n] = np.concatenate([qa, qb])
    s0[n + n0:] = np.concatenate([va, vb])

    # fixed frame: r = R(c omega t) q, r' = R (q' + c omega J q); per axis two masses, three springs
    w2, phi = eigh(np.array([[ka + kab, -kab], [-kab, kb + kab]]), np.diag([ma, mb]))
    w = np.sqrt(w2)

    def rot(a):
        return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    r0 = np.array([qa, qb])
    v0 = np.array([va + ca * omega * J @ qa, vb + cb * omega * J @ qb])
    eta0, etad0 = phi.T @ np.diag([ma, mb]) @ r0, phi.T @ np.diag([ma, mb]) @ v0
    eta = eta0 * np.cos(w * t_end)[:, None] + (etad0 / w[:, None]) * np.sin(w * t_end)[:, None]
    r_end = phi @ eta
    exact = np.concatenate([rot(-ca * omega * t_end) @ r_end[0], rot(-cb * omega * t_end) @ r_end[1]])
    err, hd = [], []
    for steps in (40 * 64, 40 * 128):
        s = s0.copy()
        sy.integrate(s, np.array([0.0, 0.0, omega]), steps, t_end / steps, sy.fext_speed())
        err.append(np.max(np.abs(s[n0:n] - exact)) / np.max(np.abs(exact)))
        hd.append(t_end / steps * abs(cb - ca) * omega)
    assert err[0] < hd[0] ** 2 and err[1] < hd[1] ** 2 and 3.5 < err[0] / err[1] < 6.0, (err, hd)
    # the frames matter: without the periodic term (the coupling frozen at the assembly angle) it is far off
    s = s0.copy()
    sy.with_changes(frame_couplings=()).integrate(s, np.array([0.0, 0.0, omega]), steps, t_end / steps,
                                                  sy.fext_speed())
    assert np.max(np.abs(s[n0:n] - exact)) / np.max(np.abs(exact)) > 0.1
