"""Tests of the 12-DOF helical pair dynamics (hacgear_core.kinds.helical_pair, the kernel's LAW_TWIST loop).

Physics asserted: with helix angle 0 and stiff tilting supports the 12-DOF model has the spur pair's natural
frequencies (0.5 %); the compiled kernel's generalized mesh force W r_mesh + M r_twist (trilinear lookup) settles
at zero speed to the static equilibrium of the same force law evaluated through the table API (Newton); the rigid
rotation of the pair loads neither the mesh deflection nor the twist; the tilting inertia is that of a uniform
prism; the axial bearings carry W sin(beta_b); a constant-speed run carries the nominal mesh force on average; the
dynamic strains at the five face gauges show the sign pattern of Fig. 5.12; the Section 5.5 sweep at 200 N*m (no
jumps, up = down, a resonance near 2600 Hz, super-harmonics, 1200 Hz off resonance).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hacgear_core.kinds import assemble, build_system, helical_from_model
from hacgear_core.kinds.helical_pair import coast_vectors, tilting_inertia_kgm2
from hacgear_core.kinds import SpurPairParameters, spur_pair_system
from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.dynamics.simulator import Simulator, strain_of_tooth
from hacgear_core.dynamics.sweep import SweepSpec, run_sweep
from hacgear_core.encodings import ContactState
from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry, mesh_geometry
from hacgear_core.statics import ContactOptions
from hacgear_core.statics.helical import make_helical_solver


@pytest.fixture(scope="module")
def system(helical, table):
    return build_system(helical, {"m12": table})


def test_rigid_rotation_loads_neither_deflection_nor_twist(system):
    """The pair's kinematic rotation (theta_z of both gears at the speed ratio) is free of x and gamma, and the
    twist vector has no theta_z entry: the reference motion is exact."""
    sy = system
    u = np.zeros(12)
    u[5] = 1.0
    u[11] = -sy.V[0, 5] / sy.V[0, 11]
    assert abs(sy.V[0] @ u) < 1e-15
    assert sy.T[0, 5] == 0.0 and sy.T[0, 11] == 0.0
    # speed ratio = -z_a / z_b (external pair): r_b,a cos(beta_b) / r_b,b cos(beta_b)
    assert u[11] == pytest.approx(-28 / 33, rel=1e-3)


def test_tilting_inertia_is_that_of_a_prism(helical, system):
    """I_tilt = I_p/2 + m b^2/12 on the tilting DOFs; the mass on the three translations."""
    g = helical.gears[1]
    gg = gear_geometry(g)
    o = 6
    assert system.M[o + 3, o + 3] == pytest.approx(tilting_inertia_kgm2(gg.mass_kg, gg.inertia_kgm2, g.face_width_m))
    assert system.M[o + 3, o + 3] > 0.5 * gg.inertia_kgm2
    np.testing.assert_allclose(np.diag(system.M)[o:o + 3], gg.mass_kg)
    # Table 5.1 supports: translational, axial, tilting, rotational
    np.testing.assert_allclose(np.diag(system.K)[o:o + 6], [1e9, 1e9, 1e9, 1e6, 1e6, 5e4])


def test_kernel_settles_to_the_static_equilibrium_of_the_generalized_law(system):
    """At zero speed under the nominal loads the compiled kernel (trilinear W and M, generalized force W v + M t
    on the 12 DOFs) comes to rest at the Newton equilibrium of the same law through the table API: f_ext = K q +
    W r_mesh + M r_twist; W near the nominal mesh force, a nonzero twist and twist moment."""
    sy = system
    eq = static_equilibrium(sy, 0.3)
    s = np.zeros(24)
    kin = np.array([0.3, 0.0, 0.0])
    sy.integrate(s, kin, 250_000, 2e-6, sy.fext_speed())   # 0.5 s: 30 decay times of the slowest mode
    assert np.max(np.abs(s[:12] - eq.q)) < 1e-8 * np.max(np.abs(eq.q))
    assert eq.mesh_forces_N[0] == pytest.approx(sy.nominal_forces_N()[0], rel=0.02)
    assert abs(eq.twist_rad[0]) > 1e-8 and abs(eq.twist_moment_Nm[0]) > 0.01
    res = sy.fext_speed() - sy.K @ eq.q - sy.V[0] * eq.mesh_forces_N[0] - sy.T[0] * eq.twist_moment_Nm[0]
    assert np.max(np.abs(res)) < 1e-6 * sy.nominal_forces_N()[0]
    # the axial bearings carry the axial component of the mesh force, W sin(beta_b), equal and opposite
    beta_b = abs(sy.meshes[0].table.twist.base_helix_angle_rad)
    fz = (sy.K @ eq.q)[[2, 8]]
    np.testing.assert_allclose(np.abs(fz), eq.mesh_forces_N[0] * math.sin(beta_b), rtol=1e-6)
    assert fz[0] == pytest.approx(-fz[1], rel=1e-9)


def test_constant_speed_run_carries_the_nominal_force(system):
    """1200 Hz mesh frequency, 200 N*m: the cycle-mean mesh force over the last 20 cycles equals the nominal
    3244 N within 1 %; the recorded twist is gamma = r_twist . q, the twist moment the table's at the state."""
    sim = Simulator(system)
    sim.set_speed_input(mesh_frequency_Hz=1200.0)
    sim.set_torque_set_point(200.0)
    out = sim.run(60 / 1200.0, 1 / 1200.0 / 16)
    f = out["mesh_force_N"][-320:, 0]
    assert f.mean() == pytest.approx(system.nominal_forces_N()[0], rel=0.01)
    q = out["state"][-1, :12]
    assert out["mesh_twist_rad"][-1, 0] == pytest.approx(system.T[0] @ q, rel=1e-12, abs=1e-18)
    wm = system.mesh_law.generalized(0, out["mesh_position"][-1, 0], system.V[0] @ q, system.T[0] @ q)
    assert out["twist_moment_Nm"][-1, 0] == pytest.approx(float(wm[1]), rel=1e-9)
    assert np.all(out["contact_state"] == ContactState.DRIVE_FLANK) and np.all(out["coast_force_N"] == 0)


def _helix_zero(helical, table, k_twist=3400.0):
    """helical_28_33 at helix angle 0 (same transverse geometry, the spur case of the face-resolving solver) with
    a generalized table: W = the committed zero-twist FDF over every twist, M = k_twist * gamma; the mesh vectors
    r_mesh, r_twist of the helix-0 solver's frame (the statics code that writes them into the tables)."""
    gears = tuple(replace(g, helix_angle_rad=0.0) for g in helical.gears)
    spur_model = replace(helical, gears=gears, kind="spur_pair")
    frame = make_helical_solver(spur_model, "m12", options=ContactOptions(face_slices=3, face_coupling="rigid")).frame
    tw = table.twist
    g = np.asarray(tw.twist_rad)
    gf = np.empty(tw.generalized_fdf.shape)
    gf[..., 0] = np.asarray(table.force_N)[:, :, None]
    gf[..., 1] = k_twist * g[None, None, :]
    tw0 = replace(tw, generalized_fdf=gf, r_mesh=frame.r_mesh, r_twist=frame.r_twist,
                  lever_arm_m=np.asarray(table.base_radius_m), base_helix_angle_rad=0.0)
    return spur_model, replace(table, twist=tw0)


def test_helix_zero_with_stiff_tilting_reproduces_the_spur_pair_frequencies(helical, table):
    """Done-when of issue #16: helix angle 0, tilting supports 1e12 N*m/rad: the 12-DOF model's modes that move
    the spur pair's DOFs (translation along the line of action, rotation) have the spur pair's natural
    frequencies (dissertation Eqs. 3.1-3.4 model: spur_pair_system, same masses, inertias, base radii, bearing
    and shaft stiffnesses, the same FDF) within 0.5 %; the other eight are the decoupled bearing modes.
    (Measured: equal within 1e-4 relative.)"""
    model0, table0 = _helix_zero(helical, table)
    sy12 = assemble(helical_from_model(model0, {"m12": table0}, tilting_stiffness_Nm_per_rad=1e12))
    ga, gb = (gear_geometry(g) for g in model0.gears)
    p = SpurPairParameters(mass_kg=(ga.mass_kg, gb.mass_kg), inertia_kg_m2=(ga.inertia_kgm2, gb.inertia_kgm2),
                           base_radius_m=tuple(table.base_radius_m), teeth=(28, 33),
                           bearing_stiffness_N_per_m=(1e9, 1e9), rotational_stiffness_Nm_per_rad=(5e4, 5e4),
                           torque_Nm=200.0)
    sp = spur_pair_system(p, replace(table, twist=None))
    f_spur = sp.natural_frequencies_Hz()
    assert f_spur.size == 4
    # modes of the 12-DOF model by their kinetic energy in the spur DOFs (line-of-action translations, theta_z)
    e2 = np.asarray(table0.twist.frame["e2"])[:2]
    phi = sy12.modal_shapes
    frac = []
    for c in range(12):
        ph = phi[:, c]
        tot = ph @ sy12.M @ ph
        spur_e = sum(sy12.M[o, o] * (ph[o:o + 2] @ e2) ** 2 + sy12.M[o + 5, o + 5] * ph[o + 5] ** 2 for o in (0, 6))
        frac.append(spur_e / tot)
    frac = np.array(frac)
    sel = frac > 0.5
    f12 = np.sort(sy12.modal_omega[sel]) / (2 * math.pi)
    assert f12.size == 4
    np.testing.assert_allclose(f12, np.sort(f_spur), rtol=0.005)
    # and the spur-like modes are pure: the rest has < 1e-3 of its energy in the spur DOFs
    assert np.all(frac[~sel] < 1e-3) and np.all(frac[sel] > 0.999)


def test_helical_builder_rejects_a_table_without_twist_axis(helical, table):
    with pytest.raises(ModelError, match="twist axis"):
        helical_from_model(helical, {"m12": replace(table, twist=None)})
    with pytest.raises(ModelError, match="HAC"):
        helical_from_model(helical, {"m12": table}, force_law="ste")


def test_twist_resolved_sdf_at_zero_twist_is_the_tables_sdf(table):
    """sdf_twist at gamma = 0 (a grid point) is the zero-twist strain-deflection function; between two twist
    slices it is linear in the twist."""
    ph = np.linspace(-2.0, 2.9, 41)
    x = np.full(ph.size, 28e-6)
    for gauge in ("wheel/SG1", "wheel/SG3"):
        np.testing.assert_allclose(table.sdf_twist(gauge, ph, x, 0.0), table.sdf(gauge, ph, x), rtol=1e-6,
                                   atol=1e-12)
        g = np.asarray(table.twist.twist_rad)
        a, b = table.sdf_twist(gauge, ph, x, g[5]), table.sdf_twist(gauge, ph, x, g[6])
        np.testing.assert_allclose(table.sdf_twist(gauge, ph, x, 0.25 * g[5] + 0.75 * g[6]), 0.25 * a + 0.75 * b,
                                   rtol=1e-9, atol=1e-15)


def test_dynamic_strains_at_the_five_face_gauges(system):
    """Fig. 5.12 (200 N*m, 1200 Hz, 33-tooth gear, gauges SG1-SG5 across the face at the root circle): the five
    dynamic strains differ from each other, and over one revolution of the tooth they are positive before the
    tooth engages (the preceding tooth loads the blank), largest while it is loaded, negative after it leaves
    the mesh (the following tooth loads the blank).  Face-wise: SG1 (z = -6.3 mm) lies outside the loaded
    overlap (-4 ... +6 mm) and reads the lowest peak and the least compression after the pass, the gauges inside
    it (SG3, SG4) the most of both."""
    sim = Simulator(system)
    sim.set_speed_input(mesh_frequency_Hz=1200.0)
    sim.set_torque_set_point(200.0)
    sim.advance(60 / 1200.0)
    out = sim.run(40 / 1200.0, 1 / 1200.0 / 32)
    tau, x, g = out["mesh_position"], out["mesh_deflection_m"], out["mesh_twist_rad"]
    ph = ((tau[:, 0] + 16.5) % 33) - 16.5                      # pair phase of the wheel's tooth 0
    eps = np.array([strain_of_tooth(system, f"wheel/SG{i}", tau, x, None, g) for i in range(1, 6)])
    peak = eps.max()
    assert np.max(eps.max(axis=0) - eps.min(axis=0)) > 0.1 * peak    # they differ (measured: 22.3 % of the peak)
    peaks = eps.max(axis=1)
    assert np.argmin(peaks) == 0 and peaks[0] < 0.9 * max(peaks[2], peaks[3])
    lows = eps.min(axis=1)                  # after the pass: the loaded tooth before it compresses the shared land
    assert np.argmax(lows) == 0 and lows[0] > 0.85 * min(lows[2], lows[3])   # measured -160 vs -209/-210 ue
    for e in eps:
        before = e[(ph > -1.75) & (ph < -1.0)]
        during = e[(ph > -0.5) & (ph < 0.0)]
        after = e[(ph > 0.6) & (ph < 1.25)]
        assert before.size and during.size and after.size
        assert np.all(before > 0) and np.all(after < 0)
        assert during.mean() > 3 * before.mean() and during.max() > 0.95 * e.max()   # largest while loaded


def test_sweep_at_200_Nm_section_5_5(system):
    """Section 5.5, 200 N*m, up and down sweeps 1000-3000 Hz in 20 Hz steps: every speed a period-1 steady state,
    no confirmed jumps and up/down within 5 % (the dissertation finds no jumps or softening); several resonances,
    among them a primary one within 10 % of 2600 Hz (the 2529 Hz mode) and super-harmonic ones at half a natural
    frequency (2131 Hz / 2 = 1066 Hz); 1200 Hz is off resonance (its RMS deflection below half the largest).
    Measured (400-4000 Hz, `hacgear sweep helical_28_33 --fm 400:4000:181`): up/down within 0.011 %, peaks at
    1060, 1260, 1760, 2120, 2520, 2720, 3540 Hz.  (202 steady states, about 5 s.)"""
    fm = np.arange(1000.0, 3000.0 + 1e-9, 20.0)
    res = run_sweep(SweepSpec(system, tuple(fm), "both"), progress=False)
    up, dn = res.branches["up"], res.branches["down"]
    assert np.all(up.converged) and np.all(dn.converged)
    assert not [j for j in res.jumps if j.confirmed]
    ru = np.asarray(up.metrics["rms_deflection_m"])[:, 0]
    rd = np.asarray(dn.metrics["rms_deflection_m"])[:, 0][np.argsort(dn.mesh_frequency_Hz)]
    np.testing.assert_allclose(ru, rd, rtol=0.05)
    f = np.asarray(up.mesh_frequency_Hz)
    peaks = [f[i] for i in range(1, f.size - 1) if ru[i] > ru[i - 1] and ru[i] >= ru[i + 1] and ru[i] > 1.5 * ru.min()]
    assert len(peaks) >= 4
    assert any(2340.0 <= p <= 2860.0 for p in peaks)
    f_nat = system.natural_frequencies_Hz()
    assert any(abs(p - fn / 2) <= 0.03 * fn / 2 for p in peaks for fn in f_nat if fn / 2 > 1000.0)
    assert ru[np.argmin(abs(f - 1200.0))] < 0.5 * ru.max()


# ------------------------------------------------------------------------------------------ coast side
@pytest.fixture(scope="module")
def reversed_system(helical, table):
    assert table.coast is not None and table.coast.twist is not None, "the committed table is two-sided"
    return build_system(helical, {"m12": table}, torque_Nm=-200.0)


def test_reversed_torque_loads_the_coast_flanks_and_balances_the_torque(reversed_system):
    """-200 N*m on the pinion: the static equilibrium has the drive flanks apart and the coast flanks carrying the
    nominal coast force (200 N*m over the coast lever arm r_bc cos(beta_bc), 2 %); the generalized coast force
    Wc r_mesh_c + Mc r_twist_c balances the loads (1e-6 of the force), the pinion torque included."""
    sy = reversed_system
    assert sy.mesh_law.coast and sy.m_kernel == 2
    eq = static_equilibrium(sy, 0.3)
    wc, mc = eq.coast_forces_N[0], None
    assert eq.mesh_forces_N[0] == 0.0
    assert wc == pytest.approx(sy.nominal_coast_forces_N()[0], rel=0.02)
    xc, gc = sy.Vc[0] @ eq.q, sy.Tc[0] @ eq.q
    mc = float(sy.mesh_law.generalized(0, 0.3 + sy.W[0] @ eq.q, xc, gc, coast=True)[1])
    res = sy.fext_speed() - sy.K @ eq.q - sy.Vc[0] * wc - sy.Tc[0] * mc
    assert np.max(np.abs(res)) < 1e-6 * wc
    # the pinion's torque: the coast force's moment about its axis is the applied -200 N*m
    lever = abs(float(sy.meshes[0].coast_table.twist.lever_arm_m[0]))
    assert abs((sy.Vc[0] * wc + sy.Tc[0] * mc)[5]) == pytest.approx(200.0, rel=0.02)
    assert wc * lever == pytest.approx(200.0, rel=0.02)


def test_reversed_torque_run_stays_on_the_coast_flanks_within_the_tables(reversed_system):
    """1200 Hz, -200 N*m: the coast flanks carry the load in every sample (mean = nominal coast force, 1 %), the
    drive flanks are apart, the coast approach stays inside the coast table's deflection grid (so the drive
    deflection stays within the backlash plus the coast table's range) and no step leaves the tables."""
    sy = reversed_system
    sim = Simulator(sy)
    sim.set_speed_input(mesh_frequency_Hz=1200.0)
    out = sim.run(30 / 1200.0, 1 / 1200.0 / 16)
    ct = sy.meshes[0].coast_table
    assert np.all(out["contact_state"] == ContactState.COAST_FLANK) and np.all(out["mesh_force_N"] == 0)
    assert out["coast_force_N"][-160:, 0].mean() == pytest.approx(sy.nominal_coast_forces_N()[0], rel=0.01)
    xc = out["coast_approach_m"][:, 0]
    assert ct.deflection_m[0] < xc.min() and xc.max() < ct.deflection_m[-1]
    assert np.all(np.abs(out["coast_twist_rad"]) < ct.twist.twist_rad[-1])
    assert sim.out_of_range_steps == [0]
    q = out["state"][-1, :12]
    assert out["coast_approach_m"][-1, 0] == pytest.approx(sy.Vc[0] @ q, rel=1e-12)
    assert out["coast_twist_rad"][-1, 0] == pytest.approx(sy.Tc[0] @ q, rel=1e-12, abs=1e-18)


def test_reversed_drive_torques_and_the_range_guard(helical, table):
    """Drivetrain coupling with the torques of issue 36 (-200 N*m on the pinion, +235.7 N*m on the wheel) from the
    drive-loaded equilibrium: the teeth cross the 407 um backlash and the coast flanks take the load.  The impact
    of the crossing overshoots the coast table's top (3 x nominal) by a few um for a few steps (measured: 515.1 um
    against 511.7 um, 6 steps): the range guard counts them; afterwards the pair rests on the coast flanks inside
    the coast table (no further step counted) with the deflection within the backlash plus the coast table's range.
    Ten times those torques drive the state beyond the coast table for good: the count grows."""
    sim = Simulator(build_system(helical, {"m12": table}, shafts=False))
    w = 2 * math.pi * 1200.0 / 28
    sim.reset(speed_rad_s=w)
    sim.set_torque_inputs({"pinion": -200.0, "wheel": 235.7})
    out = sim.run(0.02, 1e-5)
    ct = table.coast
    xc = out["coast_approach_m"][:, 0]
    assert 0 < sim.out_of_range_steps[0] < 20 and xc.max() > ct.deflection_m[-1]
    assert xc.max() < ct.deflection_m[-1] + 0.05 * (ct.deflection_m[-1] - ct.deflection_m[0])
    n_impact = sim.out_of_range_steps[0]
    out = sim.run(0.02, 1e-4)
    assert sim.out_of_range_steps[0] == n_impact
    assert np.all(out["contact_state"][:, 0] == ContactState.COAST_FLANK) and np.all(out["coast_force_N"][:, 0] > 0)
    # rigid rotations: x = -xc (drive lever arm / coast lever arm); the tilts and translations add little
    ratio = float(table.twist.lever_arm_m[0]) / float(ct.twist.lever_arm_m[0])
    assert np.all(out["mesh_deflection_m"][:, 0] > -1.2 * ratio * ct.deflection_m[-1])
    assert np.all((ct.deflection_m[0] < out["coast_approach_m"][:, 0]) & (out["coast_approach_m"][:, 0] < ct.deflection_m[-1]))
    sim.set_torque_inputs({"pinion": -2000.0, "wheel": 2357.0})
    sim.run(0.005, 1e-4)
    assert sim.out_of_range_steps[0] > n_impact + 10


# ------------------------------------------------------------------------------------------ drive-only table
@pytest.fixture(scope="module")
def drive_only(table):
    """The committed table without its coast side (what an older file or a drive-only statics run holds)."""
    return replace(table, coast=None)


def test_coast_vectors_of_a_drive_only_table_are_the_coast_solvers(helical, table, drive_only, system):
    """The coast flanks' vectors the builder derives from the drive frame and the coast pressure angle (line of
    action mirrored about the line of centres, one lead for both flanks) are those the coast solver computed for
    the committed coast table (1e-14), and the guard's backlash is the coast approach at first contact
    (j_n cos beta_bc, the two-sided system's)."""
    mg = mesh_geometry(helical, "m12", strict=False)
    rm, rt, bc = coast_vectors(table.twist.frame, mg.operating_pressure_angle_coast_rad)
    ctw = table.coast.twist
    np.testing.assert_allclose(rm, ctw.r_mesh, rtol=0, atol=1e-14)
    np.testing.assert_allclose(rt, ctw.r_twist, rtol=0, atol=1e-14)
    assert bc == pytest.approx(ctw.base_helix_angle_rad, abs=1e-14)
    sy = build_system(helical, {"m12": drive_only})
    assert sy.mesh_law.coast and not sy.two_sided and sy.m_kernel == 2
    np.testing.assert_allclose(sy.Vc, system.Vc, rtol=0, atol=1e-14)
    np.testing.assert_allclose(sy.Tc, system.Tc, rtol=0, atol=1e-14)
    assert sy.backlash_m[0] == pytest.approx(system.backlash_m[0], rel=1e-12)
    assert sy.backlash_m[0] == pytest.approx(table.coast.backlash_normal_m * math.cos(bc), rel=1e-12)
    with pytest.raises(ModelError, match="no coast side"):
        build_system(helical, {"m12": drive_only}, torque_Nm=-200.0)


def test_drive_only_table_runs_the_drive_flanks_as_the_two_sided_one(helical, table, drive_only, system):
    """Under the nominal torque the coast flanks stay apart: the drive-only table's run is bit-identical to the
    two-sided table's (states and drive records), with no step out of range and zero coast force."""
    outs = []
    for tab in (table, drive_only):
        sim = Simulator(build_system(helical, {"m12": tab}))
        sim.set_speed_input(mesh_frequency_Hz=1200.0)
        outs.append((sim.run(10 / 1200.0, 1 / 1200.0 / 32), sim.out_of_range_steps))
    (a, na), (b, nb) = outs
    assert na == nb == [0]
    for k in ("state", "mesh_deflection_m", "mesh_force_N", "mesh_twist_rad", "twist_moment_Nm"):
        assert np.array_equal(a[k], b[k]), k
    # the coast vectors from the geometry equal the table's within 1e-15: the coast approach within rounding
    np.testing.assert_allclose(b["coast_approach_m"], a["coast_approach_m"], rtol=1e-12)
    assert np.all(b["coast_force_N"] == 0) and np.all(b["contact_state"] == ContactState.DRIVE_FLANK)


def test_drive_only_table_flags_the_teeth_crossing_the_backlash(helical, table, drive_only):
    """Drivetrain coupling, torques of issue 36 reversed (-200 N*m on the pinion, +235.7 N*m on the wheel) from
    the drive-loaded equilibrium, on the drive-only table: the run is the two-sided table's (bit-identical) until
    the coast flanks meet; no step is counted while the coast approach stays below the backlash; beyond it the
    teeth pass through each other (no coast table carries them) and every step counts, growing with the run."""
    b = None
    sims = []
    for tab in (table, drive_only):
        sy = build_system(helical, {"m12": tab}, shafts=False)
        b = sy.backlash_m[0]
        sim = Simulator(sy)
        sim.reset(speed_rad_s=2 * math.pi * 1200.0 / 28)
        sim.set_torque_inputs({"pinion": -200.0, "wheel": 235.7})
        sims.append(sim)
    n_cross = None
    for _ in range(100):
        two, one = (s.run(1e-4, 1e-5) for s in sims)
        xc = one["coast_approach_m"][:, 0]
        if np.all(two["coast_force_N"] == 0):
            assert np.array_equal(two["state"], one["state"])
        if n_cross is not None:
            # every recorded sample beyond the backlash: each is the start of a counted step
            assert np.all(xc > b) and np.all(one["contact_state"][:, 0] == ContactState.SEPARATED)
            assert sims[1].out_of_range_steps[0] >= n_cross + xc.size
            break
        if xc.max() <= b:
            assert sims[1].out_of_range_steps == [0]
        else:
            n_cross = sims[1].out_of_range_steps[0]
    assert n_cross is not None, "the coast approach never reached the backlash"
    assert np.all(one["coast_force_N"] == 0) and np.all(one["mesh_force_N"] == 0)
