"""Planetary sets: placement and phasing in the carrier frame (hacgear_core.geometry.planetary) and the lumped
system of the builder (hacgear_core.kinds.planetary): kinematics, torque flow, load sharing, pin errors,
planet phasing suppression, the lumped (table-free) mode, clear errors."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from hacgear_core.kinds import build_system
from hacgear_core.dynamics.equilibrium import load_sharing, static_equilibrium
from hacgear_core.dynamics.simulator import Simulator, system_gauges
from hacgear_core.dynamics.steady import SteadyStateOptions, steady_state
from hacgear_core.errors import GeometryError, ModelError
from hacgear_core.geometry.planetary import planet_positions, planetary_geometry, planetary_torques
from hacgear_core.kinds import load_model, parse_model
from hacgear_core.tables import read_tables

ROOT = Path(__file__).resolve().parent.parent
LUMPED = ROOT / "examples" / "planetary_lumped.toml"


@pytest.fixture(scope="module")
def model():
    return load_model("planetary_65_55_175")


@pytest.fixture(scope="module")
def tables(model):
    return read_tables(model.tables_path, model.path)


@pytest.fixture(scope="module")
def lumped():
    return load_model(LUMPED)


# ------------------------------------------------------------------------------------------- phasing
@pytest.mark.parametrize("n, delays", [(3, (0, 2 / 3, 1 / 3)), (4, (0, 1 / 4, 1 / 2, 3 / 4)), (5, (0,) * 5)])
def test_sun_planet_phases_from_geometry(model, n, delays):
    """Dissertation Section 4.5.2 / Fig. 4.9: the sun meshes of planets 1..N lag planet 1's by {0, 2/3, 1/3},
    {0, 1/4, 1/2, 3/4}, all 0 (65-tooth sun), exactly; the kernel's phases are the negatives; the ring meshes
    follow gamma_ri = -z_r psi_i / 2 pi and keep the sun-ring phase of planet 1."""
    g = planetary_geometry(model, n)
    assert g.sun_delays == delays                                   # exact (no tolerance)
    for i, psi in enumerate(g.positions_rad, start=1):
        assert (g.sun_mesh(i).phase + delays[i - 1]) % 1.0 in (0.0, 1.0)   # phase = -delay (mod 1), exactly
        rd = (-175 * psi / (2 * math.pi)) % 1.0
        assert min(abs(g.ring_delays[i - 1] - rd), 1 - abs(g.ring_delays[i - 1] - rd)) < 1e-12
        d = (g.ring_mesh(i).phase - g.sun_mesh(i).phase - g.ring_sun_phase) % 1.0
        assert min(d, 1.0 - d) < 1e-9


def test_sun_mesh_of_each_planet_reaches_sun_tooth_0_at_its_passage(model):
    """Tooth passages from the geometry: the sun turns z_s psi_i / 2 pi mesh cycles relative to the carrier between
    planet 1's and planet i's pitch point, so sun tooth 0 meets planet i at that many cycles."""
    g = planetary_geometry(model, 3)
    for i, psi in enumerate(g.positions_rad, start=1):
        assert g.sun_mesh(i).tooth_passage["sun"] == round(65 * psi / (2 * math.pi) + g.sun_mesh(i).phase) % 65


def test_unequal_spacing_and_assembly_condition(model):
    """Planets may sit at any multiple of 360 / (z_s + z_r) = 1.5 deg; elsewhere they cannot be assembled."""
    pl = dataclasses.replace(model.planetary, planet_positions_rad=tuple(math.radians(a) for a in (0.0, 118.5, 241.5)))
    m2 = dataclasses.replace(model, planetary=pl)
    g = planetary_geometry(m2)
    assert g.sun_delays[1] == pytest.approx((65 * 118.5 / 360) % 1.0, abs=1e-12)
    bad = dataclasses.replace(model, planetary=dataclasses.replace(
        model.planetary, planet_positions_rad=tuple(math.radians(a) for a in (0.0, 119.0, 240.0))))
    with pytest.raises(ModelError, match=r"planet 2 at 119 deg cannot be assembled.*every 1\.5 deg.*118\.5 or 120"):
        planet_positions(bad)


def test_lumped_placement_matches_the_tooth_geometry(model, lumped):
    """The analytic placement of a lumped model (pressure angle, base radii) gives the lines of action and moment
    arms that our tooth geometry gives for the same set."""
    gg, gl = planetary_geometry(model, 3), planetary_geometry(lumped, 3)
    for name, pm in gg.meshes.items():
        pl = gl.meshes[name]
        np.testing.assert_allclose(pl.line_of_action, pm.line_of_action, atol=2e-6)
        for g, arm in pm.moment_arm_m.items():
            assert pl.moment_arm_m[g] == pytest.approx(arm, rel=2e-6)
        assert pl.phase == pytest.approx(pm.phase, abs=1e-12) if pm.kind == "sun_planet" else True


def test_kinematics_and_torque_flow(model):
    """Willis with the ring fixed: carrier / sun = z_s / (z_s + z_r); torques 1 : z_r/z_s : -(1 + z_r/z_s); each
    planet carries T_s / (N r_bs) on both meshes (equal base radii of the planet's two flanks)."""
    g = planetary_geometry(model, 4)
    ab = g.absolute_ratio
    assert ab["carrier"] / ab["sun"] == pytest.approx(65 / 240, rel=1e-12)
    assert ab["ring"] == 0.0
    fl = planetary_torques(model, g, 200.0)
    t = fl["torque_ccw_Nm"]
    assert (t["sun"], t["ring"], t["carrier"]) == pytest.approx((200.0, 200.0 * 175 / 65, -200.0 * 240 / 65))
    rbs = g.sun_mesh(1).base_radius_m[0]
    for f in fl["force_N"].values():
        assert f == pytest.approx(200.0 / (4 * rbs), rel=1e-12)
    # the torque reversed: the same force magnitudes on the coast flanks, the member torques reversed; 0 refused
    rev = planetary_torques(model, g, -200.0)
    assert fl["flanks"] == "drive" and rev["flanks"] == "coast" and rev["force_N"] == fl["force_N"]
    assert rev["torque_ccw_Nm"] == {k: -v for k, v in t.items()}
    with pytest.raises(ModelError, match=r"torque \[N\*m\] = 0.0 on 'sun'; allowed: finite and not 0"):
        planetary_torques(model, g, 0.0)


def test_driven_gear_a_is_refused(model):
    """The tables' positions advance as gear_a drives: a ring mesh named ring -> planet (the ring is driven relative
    to the carrier with the sun in and the ring fixed) is refused with the fix; a ring mesh whose gear_a names its
    trailing flank is refused naming the flank."""
    from hacgear_core.model import Mesh

    m2 = dataclasses.replace(model, meshes=(model.meshes[0], Mesh("ring_planet", "ring", "planet", "drive", "coast",
                                                                  96.54e-3, math.pi)))
    with pytest.raises(ModelError, match=r"mesh 'ring_planet': with sun in, carrier out, ring fixed .*'ring' is "
                                         r"driven, not driving.*gear_a = \"planet\", gear_b = \"ring\", flank_a = "
                                         r"\"coast\", flank_b = \"drive\""):
        planetary_geometry(m2)
    m3 = dataclasses.replace(model, meshes=(model.meshes[0], Mesh("ring_planet", "planet", "ring", "drive", "drive",
                                                                  96.54e-3, math.pi)))
    with pytest.raises(ModelError, match=r"mesh 'ring_planet': relative to the carrier 'planet' turns clockwise.*"
                                         r"drive flank trails.*flank_a = \"coast\""):
        planetary_geometry(m3)


# ------------------------------------------------------------------------------------------- the system
@pytest.mark.parametrize("n", [3, 4, 5])
def test_dofs_equations_and_mesh_kinematics(model, tables, n):
    """3N+5 DOFs with ring fixed and carrier rotation prescribed (dissertation: 3N+9 less the ring's 3 and th_c);
    G and K_W per unit carrier speed on every translation pair; all meshes advance at z_s (1 - c) / 2 pi cycles
    per radian of the sun; the static equilibrium carries the input torque through the sun meshes."""
    sy = build_system(model, tables, planet_count=n)
    assert sy.n == 3 * n + 5 and sy.m == 2 * n
    assert sy.carrier_ratio == pytest.approx(65 / 240)
    assert sy.mesh_cycles_per_rad == pytest.approx(65 * (1 - 65 / 240) / (2 * math.pi))
    np.testing.assert_allclose(sy.G, -sy.G.T)
    i, j = sy.dof_names.index("sun.x"), sy.dof_names.index("sun.y")
    assert sy.G[i, j] == pytest.approx(-2 * 1.8) and sy.K_W[i, i] == pytest.approx(1.8)
    eq = static_equilibrium(sy, 0.3)
    sun = [k for k, c in enumerate(sy.meshes) if c.group == "sun_planet"]
    rbs = sy.meshes[0].base_radius_m[0]
    assert sum(eq.mesh_forces_N[sun]) * rbs == pytest.approx(200.0, rel=1e-9)


@pytest.mark.parametrize("n", [3, 4, 5])
def test_equal_load_sharing(model, tables, n):
    """Identical, equally spaced planets share the load equally within 0.1 % (cycle mean; five in-phase planets
    at every instant)."""
    ls = load_sharing(build_system(model, tables, planet_count=n), 32)
    np.testing.assert_allclose(ls.factor, 1.0, atol=1e-3)
    if n == 5:
        np.testing.assert_allclose(ls.peak_factor, 1.0, atol=1e-6)


def _pin_error_estimate(k_sp, k_rp, k_p, k_sun, k_car, alpha, n, planet, e_t, torque, r_bs):
    """Closed-form stiffness estimate of the static mesh forces with a tangential pin error ``e_t`` on ``planet``
    (constant mesh stiffnesses, ring fixed, carrier rotation held, equal pressure angles): per planet
    ``F_i (1/k_sp + 1/k_rp + 4 cos^2 a / k_p) = r_bs th_s + u_s . n_si - 2 cos a (e_i + u_c . e_ti)`` with the sun
    and carrier translations ``u_s``, ``u_c`` from their bearings' balance.  Returns F (n,)."""
    c, s = math.cos(alpha), math.sin(alpha)
    k_eq = 1.0 / (1 / k_sp + 1 / k_rp + 4 * c * c / k_p)
    psi = 2 * math.pi * np.arange(n) / n
    e_r, e_t_ = np.stack([np.cos(psi), np.sin(psi)], 1), np.stack([-np.sin(psi), np.cos(psi)], 1)
    n_s = c * e_t_ + s * e_r                              # sun -> planet line of action (sun turning CCW)
    e = np.zeros(n)
    e[planet - 1] = e_t
    # unknowns z = [r_bs th_s, u_s (2), u_c (2)]; F = k_eq (z0 + n_s . u_s - 2c (e + e_t . u_c))
    A = np.zeros((n, 5))
    A[:, 0] = 1.0
    A[:, 1:3] = n_s
    A[:, 3:5] = -2 * c * e_t_
    b = -2 * c * e
    M = np.zeros((5, 5))
    r = np.zeros(5)
    M[0] = k_eq * A.sum(axis=0)
    r[0] = torque / r_bs - k_eq * b.sum()                 # sum F = T / r_bs
    M[1:3] = k_eq * n_s.T @ A                             # k_sun u_s + sum F n_s = 0
    M[1:3, 1:3] += k_sun * np.eye(2)
    r[1:3] = -k_eq * n_s.T @ b
    M[3:5] = -2 * c * k_eq * e_t_.T @ A                   # k_car u_c - sum 2c F e_t = 0
    M[3:5, 3:5] += k_car * np.eye(2)
    r[3:5] = 2 * c * k_eq * e_t_.T @ b
    z = np.linalg.solve(M, r)
    return k_eq * (A @ z + b)


def test_pin_error_load_sharing_lumped_equals_closed_form(lumped):
    """Constant mesh stiffnesses: a tangential pin error of 30 um on planet 1 gives exactly the closed-form
    stiffness estimate (rigid ring and held carrier rotation; floating sun and carrier)."""
    pl = dataclasses.replace(lumped.planetary, carrier_support=dataclasses.replace(
        lumped.planetary.carrier_support, rotational_stiffness_Nm_per_rad=math.inf))
    ring = next(g for g in lumped.gears if g.name == "ring")
    ring = dataclasses.replace(ring, support=dataclasses.replace(ring.support, translational_stiffness_N_per_m=math.inf,
                                                                 rotational_stiffness_Nm_per_rad=math.inf))
    m = dataclasses.replace(lumped, planetary=pl, gears=tuple(ring if g.name == "ring" else g for g in lumped.gears))
    sy = build_system(m, None, pin_errors_m={1: (0.0, 30e-6)})
    f = static_equilibrium(sy, 0.0).mesh_forces_N[::2]
    est = _pin_error_estimate(1e8, 1e8, 1e8, 1e8, 1e8, math.radians(15.97), 3, 1, 30e-6, 200.0, 50.2743e-3)
    np.testing.assert_allclose(f, est, rtol=1e-9)
    assert f[0] < f[1]                                     # pin ahead in the carrier's sense: planet 1 unloads


@pytest.mark.parametrize("e_um", [10.0, 30.0])
def test_pin_error_load_sharing_hac_follows_the_estimate(model, tables, e_um):
    """HAC tables: the cycle-mean load-sharing change of a tangential pin error is the closed-form estimate's with
    the tables' mean mesh stiffnesses, in direction and within 10 % in size; a radial error leaves the sharing
    (equal pressure angles on both meshes)."""
    sy = build_system(model, tables, planet_count=3, pin_errors_m={1: (0.0, e_um * 1e-6)})
    ls = load_sharing(sy, 16)
    k = sy.mesh_stiffness_N_per_m
    kt = {g.name: g.support.translational_stiffness_N_per_m for g in model.gears}
    f = _pin_error_estimate(k[0], k[1], kt["planet"], kt["sun"],
                            model.planetary.carrier_support.translational_stiffness_N_per_m, math.radians(15.97), 3,
                            1, e_um * 1e-6, 200.0, sy.meshes[0].base_radius_m[0])
    est = f / f.mean()
    assert ls.factor[0] < 1.0
    assert (1 - ls.factor[0]) == pytest.approx(1 - est[0], rel=0.10)
    assert (ls.factor[2] - 1) == pytest.approx(est[1] - 1, rel=0.10)
    radial = load_sharing(build_system(model, tables, planet_count=3, pin_errors_m={1: (e_um * 1e-6, 0.0)}), 16)
    np.testing.assert_allclose(radial.factor, 1.0, atol=2e-3)


@pytest.mark.parametrize("n", [3, 4, 5])
def test_planet_phasing_suppression(model, tables, n):
    """Parker (2000): at mesh harmonic l the central members translate only where (l z_s +- 1) / N is an integer
    and rotate only where l z_s / N is; otherwise that motion is absent from the steady-state response spectrum
    (<= 1e-3 of the excited one).  Five planets (z_s / N = 13): rotational only."""
    sy = build_system(model, tables, planet_count=n)
    # 512 RK4 steps per mesh cycle: the phase shifts between the planets (1/3, 1/4 cycle) are not whole steps, so the
    # step's truncation error breaks the symmetry a little (3 planets, l = 4: 1.4e-3 at 256 steps, 8.7e-5 at 512)
    r = steady_state(sy, 1200.0, options=SteadyStateOptions(rtol=1e-9, max_cycles=6000, min_steps_per_cycle=512),
                     keep_trace=True)
    assert r.converged
    st, nsp, per = r.trace["state"], r.steps_per_cycle, r.period_cycles
    d = {name: i for i, name in enumerate(sy.dof_names)}
    rs = sy.gears["sun"].radius_m
    spec = {k: np.abs(np.fft.rfft(v[-nsp * per:])) for k, v in
            (("x", st[:, d["sun.x"]]), ("y", st[:, d["sun.y"]]), ("th", rs * st[:, d["sun.theta"]]),
             ("cx", st[:, d["carrier.x"]]))}
    top = max(float(v[per:].max()) for v in spec.values())
    for l in range(1, 7):
        tr = max(spec["x"][l * per], spec["y"][l * per], spec["cx"][l * per])
        ro = spec["th"][l * per]
        trans_ok = (l * 65 + 1) % n == 0 or (l * 65 - 1) % n == 0
        rot_ok = (l * 65) % n == 0
        big = max(tr, ro)
        if not trans_ok:
            assert tr <= 1e-3 * max(big, 1e-3 * top), (l, tr, ro)
        if not rot_ok:
            assert ro <= 1e-3 * max(big, 1e-3 * top), (l, tr, ro)
        if trans_ok or rot_ok:
            assert big > 1e-4 * top


def test_sun_gauge_superposes_every_planet(model, tables):
    """The sun's mid-space gauge sees every planet's sun mesh once per relative revolution: the strain of tooth 0
    along a trajectory is the sum of the planets' strain-deflection functions at their own pair phases."""
    sy = build_system(model, tables, planet_count=3)
    assert system_gauges(sy) == ("sun/SGmid",)
    sim = Simulator(sy)
    sim.set_speed_input(mesh_frequency_Hz=600.0)
    tr = sim.run(75 / 600.0, 1.0 / (600.0 * 64))
    from hacgear_core.dynamics.simulator import strain_of_tooth

    eps = strain_of_tooth(sy, "sun/SGmid", tr["mesh_position"], tr["mesh_deflection_m"])
    # three strain pulses per relative revolution (65 mesh cycles), one per planet, 65/3 cycles apart (each pulse
    # has the two maxima of the space between tooth 0 and tooth 1 passing the planet)
    tau = tr["mesh_position"][:, 0]
    hot = np.flatnonzero(eps > 0.5 * eps.max())
    clusters = np.split(hot, np.flatnonzero(np.diff(hot) > 64) + 1)
    inner = [c for c in clusters if c[0] > 0 and c[-1] < len(eps) - 1]     # pulses seen whole
    assert len(clusters) >= 3 and len(inner) >= 2
    peaks = [tau[c[np.argmax(eps[c])]] for c in inner]
    np.testing.assert_allclose(np.diff(peaks), 65 / 3, atol=0.1)
    assert eps.min() < 0 < eps.max()


# ------------------------------------------------------------------------------------------- lumped, errors
def test_lumped_model_needs_no_tables(lumped):
    """A lumped model builds without tables: constant mesh stiffness, every planet at its phase."""
    sy = build_system(lumped, None, planet_count=4)
    np.testing.assert_allclose(sy.mesh_stiffness_N_per_m, 1e8, rtol=1e-12)
    assert sy.n == 3 * 4 + 9 and sy.rigid_mode is not None


def test_bad_planetary_inputs_are_clear(model, tables, lumped):
    with pytest.raises(ModelError, match=r"planet count \[-\] = 13; allowed: integer in \[1, 12\]"):
        build_system(model, tables, planet_count=13)
    planet = dataclasses.replace(model.gear("planet"), support=dataclasses.replace(
        model.gear("planet").support, rotational_stiffness_Nm_per_rad=5.0))
    m2 = dataclasses.replace(model, gears=tuple(planet if g.name == "planet" else g for g in model.gears))
    with pytest.raises(ModelError, match=r"rotational_stiffness_Nm_per_rad \[N\*m/rad\] = 5.*turns freely"):
        build_system(m2, tables)
    with pytest.raises(ModelError, match=r"nominal force per planet .* exceeds the tables' largest static load"):
        build_system(model, tables, planet_count=1, torque_Nm=250.0)
    with pytest.raises(GeometryError, match=r"lumped model .* no tooth geometry"):
        from hacgear_core.geometry import gear_geometry

        gear_geometry(lumped.gears[0])
    text = LUMPED.read_text().replace("mesh_stiffness_N_per_m = 1.0e8\npressure_angle_deg = 15.97\n\n[[meshes]]",
                                      "pressure_angle_deg = 15.97\n\n[[meshes]]", 1)
    with pytest.raises(ModelError, match=r"key 'meshes\[0\]\.mesh_stiffness_N_per_m' \[N/m\]: missing required key"):
        parse_model(text, file="l.toml")
    text = LUMPED.read_text().replace("planet_count = 3", "planet_count = 3\nplanet_positions_deg = [0.0, 120.0]")
    with pytest.raises(ModelError, match=r"planet_positions \[deg\]: 2 angles given for planet_count = 3"):
        parse_model(text, file="l.toml")


def test_impulse_test_finds_the_linearised_modes(model, tables):
    """Impulse test of the 3-planet set (free vibration at two frozen mesh positions, the same kernel): every
    spectral peak is a natural frequency of the system linearised at that frozen position (each mesh's local slope
    at its own phased position) within 0.1 %; the modes up to 2.2 kHz are the cycle-mean ones within 2 % (the
    frozen stiffness departs from the cycle mean, and the phased planets split the pairs)."""
    import scipy.linalg as sl

    from hacgear_core.dynamics.modes import gyroscopic_modes, impulse_test

    sy = build_system(model, tables, planet_count=3)
    lin = np.unique(np.round(gyroscopic_modes(sy).natural_frequencies_Hz, 3))
    it = impulse_test(sy)
    for pos, peaks in ((it.single_position, it.single_contact_Hz), (it.double_position, it.double_contact_Hz)):
        assert peaks.size >= 6
        tau_ref = pos - float(sy.phase[0])
        eq = static_equilibrium(sy, tau_ref, sy.fext_speed())
        taus = tau_ref + sy.phase + sy.W @ eq.q
        kk = np.array([float(sy.mesh_slope(k, taus[k], eq.mesh_deflections_m[k])) for k in range(sy.m)])
        w2 = sl.eigh(sy.K + (sy.V.T * kk) @ sy.V, sy.M, eigvals_only=True)
        frozen = np.sqrt(np.clip(w2, 0.0, None)) / (2 * math.pi)
        for f in peaks:
            assert np.min(np.abs(frozen - f)) / f < 1e-3, (f, frozen)
        for f in lin[lin < 2200.0]:
            assert np.min(np.abs(peaks - f)) / f < 0.02, (f, peaks)

def test_load_share_is_zero_while_every_mesh_of_its_kind_is_separated(model, tables):
    """The FMU output sun_planet_i.load_share was NaN whenever all sun-planet meshes separated at once (168 of 501
    points in one run): with no load in the group each mesh carries nothing, 0; with load the shares average 1."""
    sim = Simulator(build_system(model, tables, planet_count=3))
    sun = [k for k, c in enumerate(sim.system.meshes) if c.group == sim.system.meshes[0].group]
    assert len(sun) == 3
    shares = [sim.load_share(k) for k in sun]
    assert all(s > 0 for s in shares) and sum(shares) == pytest.approx(3.0)
    for k in sun:
        sim.mesh_force_N[k] = 0.0
    assert [sim.load_share(k) for k in sun] == [0.0, 0.0, 0.0]


# ------------------------------------------------------------------------------------------- power flow
#: (input, output, fixed): every arrangement of the three members
ARRANGEMENTS = [("sun", "carrier", "ring"), ("carrier", "sun", "ring"), ("sun", "ring", "carrier"),
                ("ring", "sun", "carrier"), ("ring", "carrier", "sun"), ("carrier", "ring", "sun")]


def _willis_closed_form(inp: str, out: str, fixed: str, zs: int, zr: int) -> float:
    """omega_in / omega_out from Willis' equation omega_s - omega_c = -(z_r / z_s) (omega_r - omega_c) with the fixed
    member at rest: ring fixed sun/carrier = 1 + z_r/z_s, carrier fixed sun/ring = -z_r/z_s, sun fixed
    ring/carrier = 1 + z_s/z_r."""
    k = zr / zs
    ratio = {("sun", "carrier"): 1 + k, ("sun", "ring"): -k, ("ring", "carrier"): 1 + 1 / k}
    return ratio[(inp, out)] if (inp, out) in ratio else 1.0 / ratio[(out, inp)]


def _torque_magnitudes(inp: str, torque: float, zs: int, zr: int) -> dict:
    """|T_j| of the torque balance T_s : T_r : T_c = 1 : z_r/z_s : -(1 + z_r/z_s) with |T_in| = torque."""
    k = zr / zs
    r = {"sun": 1.0, "ring": k, "carrier": 1.0 + k}
    return {j: torque * v / r[inp] for j, v in r.items()}


def _with_rotation(model, member: str, k: float):
    """``model`` with the rotational support stiffness of ``member`` (a gear or the carrier) set to ``k``."""
    if member == "carrier":
        pl = model.planetary
        return dataclasses.replace(model, planetary=dataclasses.replace(pl, carrier_support=dataclasses.replace(
            pl.carrier_support, rotational_stiffness_Nm_per_rad=k)))
    gears = tuple(dataclasses.replace(g, support=dataclasses.replace(g.support, rotational_stiffness_Nm_per_rad=k))
                  if g.name == member else g for g in model.gears)
    return dataclasses.replace(model, gears=gears)


def _arranged(model, inp: str, out: str, fixed: str):
    """``model`` run as ``inp`` in, ``out`` out, ``fixed`` fixed: the input and output members free (torque ports),
    the fixed one held."""
    m = dataclasses.replace(model, operating=dataclasses.replace(model.operating, torque_gear=inp),
                            planetary=dataclasses.replace(model.planetary, fixed_member=fixed, output_member=out))
    for member, k in ((inp, 0.0), (out, 0.0), (fixed, math.inf)):
        m = _with_rotation(m, member, k)
    return m


def _assembled_rigid_mode(sy, inp: str) -> np.ndarray:
    """The rotation of the assembled system that loads no mesh and no support: the null vector of ``K + V^T k V``
    (supports and mean mesh stiffnesses) with the input's rotation 1."""
    k = sy.K + (sy.V.T * sy.mesh_stiffness_N_per_m) @ sy.V
    i = sy.gears[inp].rotation
    rest = [j for j in range(sy.n) if j != i]
    u = np.zeros(sy.n)
    u[i] = 1.0
    u[rest] = np.linalg.solve(k[np.ix_(rest, rest)], -k[rest, i])
    return u


def _check_power_flow(sy, inp: str, out: str, fixed: str, zs: int, zr: int, rbs: float, rbr: float, n: int) -> None:
    """Willis from the assembled rigid-body mode, the builder's rigid mode, the power balance of the nominal
    torques and the static mesh forces of the torque balance."""
    u = _assembled_rigid_mode(sy, inp)
    i_in, i_out = sy.gears[inp].rotation, sy.gears[out].rotation
    i_cf = _willis_closed_form(inp, out, fixed, zs, zr)
    assert u[i_in] / u[i_out] == pytest.approx(i_cf, rel=1e-12, abs=0.0)
    # the builder's rigid mode is the assembled one
    uref = sy.rigid_mode / sy.rigid_mode[i_in]
    np.testing.assert_allclose(uref, u, rtol=1e-12, atol=1e-12 * float(np.max(np.abs(u))))
    # the constant-speed experiment's torques: the power enters by the input, leaves by the output, sums to 0
    # (the rigid mode holds counter-clockwise rotations per counter-clockwise one of the input, which turns in its
    # operating sense)
    fe = sy.fext_speed()
    w = sy.rigid_mode * sy.gears[inp].sense
    p_in, p_out = fe[i_in] * w[i_in], fe[i_out] * w[i_out]
    assert p_in > 0 > p_out and p_in + p_out == pytest.approx(0.0, abs=1e-12 * p_in)
    # static mesh forces: F_s = |T_s| / (N r_b,s) on every sun mesh, F_r = |T_r| / (N r_b,r) on every ring mesh
    eq = static_equilibrium(sy, 0.0)
    t = _torque_magnitudes(inp, abs(sy.torque_Nm), zs, zr)
    sun = np.array([c.group == "sun_planet" for c in sy.meshes])
    assert sun.sum() == n and (~sun).sum() == n
    np.testing.assert_allclose(eq.mesh_forces_N[sun], t["sun"] / (n * rbs), rtol=1e-12)
    np.testing.assert_allclose(eq.mesh_forces_N[~sun], t["ring"] / (n * rbr), rtol=1e-12)


#: base radius per tooth of the lumped example's set [mm] (its sun: 50.2743 mm, 65 teeth)
_RB_PER_TOOTH_MM = 50.2743 / 65


def _lumped_text(inp: str, out: str, fixed: str) -> str:
    """The lumped example as ``inp`` in, ``out`` out, ``fixed`` fixed, its base radii made exactly proportional to
    the tooth counts and its carrier radius exactly (r_b,s + r_b,p) / cos(alpha) (the example's are rounded to
    0.1 um: Willis' ratios of its geometry differ from the tooth counts' by 4e-7)."""
    text = LUMPED.read_text()
    for old, z in (("50.2743", 65), ("42.5398", 55), ("135.3539", 175)):
        text = text.replace(f"base_radius_mm = {old}", f"base_radius_mm = {z * _RB_PER_TOOTH_MM!r}", 1)
    rc = (65 + 55) * _RB_PER_TOOTH_MM / math.cos(math.radians(15.97))
    text = text.replace("carrier_radius_mm = 96.54", f"carrier_radius_mm = {rc!r}", 1)
    text = text.replace('fixed_member = "ring"', f'fixed_member = "{fixed}"\noutput_member = "{out}"', 1)
    return text.replace('torque_gear = "sun"', f'torque_gear = "{inp}"', 1)


@pytest.mark.parametrize("inp, out, fixed", ARRANGEMENTS)
def test_power_flow_lumped_willis_and_static_forces(inp, out, fixed):
    """Any member in, any out, any fixed (lumped set, 3 planets, the input and output members free, the fixed one
    held): the assembled system's rigid-body mode turns the input and output members at Willis' ratio (1 + z_r/z_s,
    -z_r/z_s, 1 + z_s/z_r or their inverses) to 1e-12; the power enters by the input and leaves by the output; the
    static solve at 200 N m carries |T_s| / (N r_b,s) on every sun mesh and |T_r| / (N r_b,r) on every ring mesh, on
    the loaded flanks (F > 0); the sun drives the planets relative to the carrier exactly when it is the input or the
    ring the output."""
    m = _arranged(parse_model(_lumped_text(inp, out, fixed), file="l.toml"), inp, out, fixed)
    assert m.planetary.output_member == out
    geo = planetary_geometry(m)
    assert geo.power_flow.sun_drives == (inp == "sun" or out == "ring")
    assert geo.sun_mesh(1).gear_a == "sun" and geo.ring_mesh(1).gear_a == "planet_1"   # the file's order, either way
    sy = build_system(m, None)
    _check_power_flow(sy, inp, out, fixed, 65, 175, m.gear("sun").base_radius_m, m.gear("ring").base_radius_m, 3)


def _swapped(model):
    """``model`` with every mesh named by the other member first (planet -> sun, ring -> planet), the same flanks
    loaded: the drivers relative to the carrier when the ring drives the planets (carrier in, sun out, ring fixed)."""
    from hacgear_core.model import Mesh

    sm, rm = model.mesh("sun_planet"), model.mesh("ring_planet")
    return dataclasses.replace(model, meshes=(
        Mesh("sun_planet", "planet", "sun", sm.flank_b, sm.flank_a, sm.center_distance_m, math.pi),
        Mesh("ring_planet", "ring", "planet", rm.flank_b, rm.flank_a, rm.center_distance_m, 0.0)))


def test_carrier_input_places_the_mirror_image(model):
    """Carrier in, sun out, ring fixed (the wind-turbine stage) with the tooth geometry: the meshes named by their
    drivers (planet -> sun, ring -> planet) place sun and ring on the central axis, and the set is the mirror image
    of sun in / carrier out in time (the same flanks in contact, every member turning the other way relative to
    the carrier): the same pitch points, lines of action and moment arms reversed, phases and Parker's delays
    negated; Willis' sun / carrier = 1 + z_r/z_s; the carrier's torque presses the loaded flanks with |T_s| /
    (N r_b,s), T_s = T_c / (1 + z_r/z_s)."""
    w = dataclasses.replace(_swapped(model), operating=dataclasses.replace(model.operating, torque_gear="carrier"))
    for n in (3, 4):
        a, b = planetary_geometry(model, n), planetary_geometry(w, n)
        assert b.power_flow.arrangement == "carrier in, sun out, ring fixed" and not b.power_flow.sun_drives
        assert {k: -v for k, v in a.relative_sense.items()} == b.relative_sense
        for name, pa in a.meshes.items():
            pb = b.meshes[name]
            assert (pb.gear_a, pb.gear_b) == (pa.gear_b, pa.gear_a)
            np.testing.assert_allclose(pb.pitch_point_m, pa.pitch_point_m, atol=1e-15)
            np.testing.assert_allclose(pb.line_of_action, -pa.line_of_action, atol=1e-15)
            for g, arm in pa.moment_arm_m.items():
                assert pb.moment_arm_m[g] == pytest.approx(-arm, abs=1e-15)
            d = (pa.phase + pb.phase) % 1.0
            assert min(d, 1.0 - d) < 1e-12
            d = (pa.delay + pb.delay) % 1.0
            assert min(d, 1.0 - d) < 1e-12
        assert b.absolute_ratio["sun"] / b.absolute_ratio["carrier"] == pytest.approx(1 + 175 / 65, rel=1e-12)
        assert b.absolute_ratio["ring"] == 0.0
        fl = planetary_torques(w, b, 200.0)
        rbs = b.sun_mesh(1).base_radius_m[1]
        assert fl["flanks"] == "drive" and fl["power_flow"].input == "carrier"
        assert fl["torque_ccw_Nm"]["carrier"] * b.absolute_ratio["carrier"] > 0 > \
            fl["torque_ccw_Nm"]["sun"] * b.absolute_ratio["sun"]                       # power in, power out
        for f in fl["force_N"].values():
            assert f == pytest.approx(200.0 / (1 + 175 / 65) / (n * rbs), rel=1e-12)


def test_gear_order_against_the_power_flow_is_refused_with_the_fix(model):
    """The shipped order (sun -> planet, planet -> ring) with the carrier as input and the sun as output is refused
    naming the arrangement and the mesh lines that fix it; the fixed file loads; an output that is the input or the
    fixed member is refused naming the key."""
    m = dataclasses.replace(model, operating=dataclasses.replace(model.operating, torque_gear="carrier"))
    with pytest.raises(ModelError, match=r"mesh 'sun_planet': with carrier in, sun out, ring fixed .*'sun' is driven, "
                                         r"not driving.*'planet' drives 'sun'.*gear_a = \"planet\", gear_b = \"sun\", "
                                         r"flank_a = \"drive\", flank_b = \"drive\""):
        planetary_geometry(m)
    planetary_geometry(dataclasses.replace(_swapped(model), operating=m.operating))
    with pytest.raises(ModelError, match=r"planetary.output_member = 'carrier' with the input 'carrier'.*allowed: "
                                         r"'sun'"):
        planetary_geometry(dataclasses.replace(m, planetary=dataclasses.replace(model.planetary,
                                                                                output_member="carrier")))
    text = (ROOT / "models" / "planetary_65_55_175" / "model.toml").read_text()
    with pytest.raises(ModelError, match=r"output_member = 'ring' is out of range; allowed: a member other than "
                                         r"fixed_member = 'ring'"):
        parse_model(text.replace('fixed_member = "ring"', 'fixed_member = "ring"\noutput_member = "ring"'),
                    file="p.toml")
    with pytest.raises(ModelError, match=r"planetary.output_member.*unknown value 'planet'"):
        parse_model(text.replace('fixed_member = "ring"', 'fixed_member = "ring"\noutput_member = "planet"'),
                    file="p.toml")


def _constant_tables(model, k: float, torque: float, planets: int = 3) -> dict:
    """Constant-stiffness tables of ``model``'s two meshes (gear order and base radii of the model), the nominal force
    at ``torque`` on ``planets`` planets three deflection steps above contact and within the static load grid: exact
    linear force laws for the tooth geometry's placement (no statics run)."""
    from hacgear_core.kinds.planetary import constant_stiffness_table

    geo = planetary_geometry(model, planets)
    fmax = max(planetary_torques(model, geo, torque)["force_N"].values())
    out = {}
    for kind in ("sun_planet", "ring_planet"):
        mm = geo.meshes[f"{kind}_1"]
        names = tuple("planet" if g.startswith("planet_") else g for g in (mm.gear_a, mm.gear_b))
        t = constant_stiffness_table(kind, names, mm.teeth, mm.base_radius_m, k, 2.0 * fmax / k)
        loads = np.array([0.0, 2.0 * fmax])
        out[kind] = dataclasses.replace(t, load_N=loads, static_deflection_m=np.repeat(loads[None, :] / k, 4, axis=0))
    return out


@pytest.mark.parametrize("inp, out, fixed", ARRANGEMENTS[:4])
def test_power_flow_tooth_geometry_willis_and_static_forces(model, inp, out, fixed):
    """The four arrangements of the issue with our tooth geometry's placement (65/55/175, 3 planets; constant-
    stiffness tables in the gear order each needs: sun -> planet, planet -> ring where the sun drives the planets,
    planet -> sun, ring -> planet where the ring does): Willis' ratio from the assembled rigid-body mode to 1e-12,
    the power balance, and the static mesh forces of the torque balance."""
    m = model if (inp == "sun" or out == "ring") else _swapped(model)
    m = _arranged(m, inp, out, fixed)
    sy = build_system(m, _constant_tables(m, 2e8, 200.0))
    geo = planetary_geometry(m, 3)
    rbs = geo.sun_mesh(1).base_radius_m[0 if geo.sun_mesh(1).gear_a == "sun" else 1]
    rbr = geo.ring_mesh(1).base_radius_m[0 if geo.ring_mesh(1).gear_a == "ring" else 1]
    _check_power_flow(sy, inp, out, fixed, 65, 175, rbs, rbr, 3)
    np.testing.assert_allclose(sy.mesh_stiffness_N_per_m, 2e8, rtol=1e-12)


def test_carrier_input_system_is_the_sun_input_one_run_backwards(model):
    """Carrier in / sun out with the lines planet -> sun, ring -> planet loads the same flanks as sun in / carrier
    out with the shipped lines: the assembled systems (constant-stiffness tables) have the same mesh deflection
    vectors, supports and masses, so the same natural frequencies at rest; only the reference member and its
    sense of rotation differ (the carrier turns clockwise)."""
    from hacgear_core.dynamics.modes import gyroscopic_modes

    a = _arranged(model, "sun", "carrier", "ring")
    b = _arranged(_swapped(model), "carrier", "sun", "ring")
    sa, sb = build_system(a, _constant_tables(a, 2e8, 200.0)), build_system(b, _constant_tables(b, 2e8, 200.0))
    assert sa.dof_names == sb.dof_names and sb.reference_gear == "carrier" and sb.gears["carrier"].sense == -1.0
    np.testing.assert_allclose(sb.V, sa.V, atol=1e-12)
    np.testing.assert_array_equal(sb.K, sa.K)
    np.testing.assert_array_equal(sb.M, sa.M)
    np.testing.assert_allclose(gyroscopic_modes(sb).natural_frequencies_Hz, gyroscopic_modes(sa).natural_frequencies_Hz,
                               rtol=1e-9, atol=1e-6)


def _carrier_in_text(grid: str) -> str:
    """The shipped 65/55/175 file run as carrier in, sun out, ring fixed: its meshes named by their drivers
    (planet -> sun, ring -> planet, the same flanks loaded), the carrier free, the sun's torque port free, the
    statics grid ``grid``."""
    src = (ROOT / "models" / "planetary_65_55_175" / "model.toml").read_text()
    meshes = src[src.index("[[meshes]]"):src.index("[planetary]")]
    swapped = ('[[meshes]]\nname = "sun_planet"\ngear_a = "planet"\ngear_b = "sun"\nflank_a = "drive"\n'
               'flank_b = "drive"\ncenter_distance_mm = 96.54\nline_of_centres_deg = 180.0\n\n'
               '[[meshes]]\nname = "ring_planet"\ngear_a = "ring"\ngear_b = "planet"\nflank_a = "drive"\n'
               'flank_b = "coast"\ncenter_distance_mm = 96.54\n\n')
    text = src.replace(meshes, swapped).replace('fixed_member = "ring"', 'fixed_member = "ring"\noutput_member = "sun"')
    text = text.replace('torque_gear = "sun"', 'torque_gear = "carrier"')
    text = text.replace("rotational_stiffness_Nm_per_rad = inf   # prescribed", "rotational_stiffness_Nm_per_rad = 0.0 #")
    return text.replace("positions = 64\nloads = 32\ndeflections = 64", grid)


def test_carrier_input_tables_are_the_sun_input_tables_mirrored(tmp_path):
    """Our statics on the carrier-in file (planet -> sun, ring -> planet; smallest grid: 8 positions, 4 loads, 16
    deflections, drive side) give the sun-in file's tables (same nominal mesh force) mirrored in mesh position,
    ``T_b(p) = T_a(-p)``: the same flanks in contact, the motion reversed (static deflections to 1e-15 m, FDF to
    1e-9 of its largest force); the carrier-in system on these tables turns the sun at Willis' ratio (1e-12) and its
    static sun and ring mesh forces sum to the torque balance's |T_s| / r_b,s and |T_r| / r_b,r (1e-9: the planets
    share the load by their phases at a frozen position)."""
    from hacgear_core.statics.grid import compute_statics

    grid = "positions = 8\nloads = 4\ndeflections = 16"
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "model.toml").write_text(_carrier_in_text(grid))
    (tmp_path / "a").mkdir()
    src = (ROOT / "models" / "planetary_65_55_175" / "model.toml").read_text()
    (tmp_path / "a" / "model.toml").write_text(src.replace("positions = 64\nloads = 32\ndeflections = 64", grid)
                                               .replace("torque_Nm = 200.0", f"torque_Nm = {200.0 * 65 / 240!r}"))
    tabs = {}
    for k in ("a", "b"):
        compute_statics(tmp_path / k / "model.toml", sides=("drive",), workers=1, progress=False)
        m = load_model(tmp_path / k / "model.toml")
        tabs[k] = (m, read_tables(m.tables_path, m.path))
    (ma, ta), (mb, tb) = tabs["a"], tabs["b"]
    for kind in ("sun_planet", "ring_planet"):
        a, b = ta.mesh(kind), tb.mesh(kind)
        assert b.gear_names == a.gear_names[::-1] and tuple(b.teeth) == tuple(a.teeth)[::-1]
        mirror = [(-i) % a.position.size for i in range(a.position.size)]
        np.testing.assert_array_equal(b.load_N, a.load_N)
        np.testing.assert_allclose(b.static_deflection_m, a.static_deflection_m[mirror], rtol=0, atol=1e-15)
        np.testing.assert_allclose(b.no_load_deflection_m, a.no_load_deflection_m[mirror], rtol=0, atol=1e-15)
        np.testing.assert_allclose(b.force_N, a.force_N[mirror], rtol=0, atol=1e-9 * float(np.max(a.force_N)))
    sy = build_system(mb, tb)
    geo = planetary_geometry(mb)
    u = _assembled_rigid_mode(sy, "carrier")
    assert u[sy.gears["sun"].rotation] / u[sy.gears["carrier"].rotation] == pytest.approx(1 + 175 / 65, rel=1e-12)
    eq = static_equilibrium(sy, 0.3)
    t = _torque_magnitudes("carrier", 200.0, 65, 175)
    sun = np.array([c.group == "sun_planet" for c in sy.meshes])
    rbs, rbr = geo.sun_mesh(1).base_radius_m[1], geo.ring_mesh(1).base_radius_m[0]
    assert np.all(eq.mesh_forces_N > 0)
    assert float(np.sum(eq.mesh_forces_N[sun])) * rbs == pytest.approx(t["sun"], rel=1e-9)
    assert float(np.sum(eq.mesh_forces_N[~sun])) * rbr == pytest.approx(t["ring"], rel=1e-9)


@pytest.mark.parametrize("inp, out, fixed", ARRANGEMENTS[:4])
def test_output_held_grounds_the_train_in_every_arrangement(model, inp, out, fixed):
    """The constant-speed experiment's supports (the output member's rotation held, as the shipped file holds the
    carrier): the held output grounds the train through the meshes even where no support or shaft joins it to the
    driven members (carrier in, sun held: the builder reported a rigid-body mode, so the static solve pinned the
    input and found no equilibrium, residual = the input torque), so there is no rigid-body mode and the static
    mesh forces are the torque balance's (1e-12)."""
    m = model if (inp == "sun" or out == "ring") else _swapped(model)
    m = _with_rotation(_arranged(m, inp, out, fixed), out, math.inf)
    sy = build_system(m, _constant_tables(m, 2e8, 200.0))
    assert sy.rigid_mode is None and not sy.rigid_modes.any()
    geo = planetary_geometry(m, 3)
    rbs = geo.sun_mesh(1).base_radius_m[0 if geo.sun_mesh(1).gear_a == "sun" else 1]
    rbr = geo.ring_mesh(1).base_radius_m[0 if geo.ring_mesh(1).gear_a == "ring" else 1]
    eq = static_equilibrium(sy, 0.0)
    t = _torque_magnitudes(inp, abs(sy.torque_Nm), 65, 175)
    sun = np.array([c.group == "sun_planet" for c in sy.meshes])
    np.testing.assert_allclose(eq.mesh_forces_N[sun], t["sun"] / (3 * rbs), rtol=1e-12)
    np.testing.assert_allclose(eq.mesh_forces_N[~sun], t["ring"] / (3 * rbr), rtol=1e-12)
