"""Lead slope deviations and in-plane shaft misalignment of helical meshes (hacgear_core.dynamics.lead).

Physics asserted: both are a constant offset of the mesh twist (the flanks meet at gamma + gamma_0 with gamma_0 =
psi - f_a / b_a - f_b / b_b); with independent face slices (a Winkler foundation) the face load factor of the
statics at that twist is the ISO 6336-1 closed form for a linear load distribution, K_Hbeta = 1 + F_betay c_gamma
b / (2 F_m); the twist offset reproduces the face load change of the exact lead slope (a flank deviation in the
statics) and overstates its twist moment change by a measured share; a zero-speed run with gamma_0 rests at the
static equilibrium of the shifted law, whose W and M are the statics' at gamma + gamma_0; the contact pattern
moves towards the face end the error loads; zero errors run on the very same arrays (bit-identical).
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.dynamics.lead import lead_twist_offset_rad, twist_offsets_rad
from hacgear_core.errors import ModelError
from hacgear_core.kinds import build_system, load_model, parse_model
from hacgear_core.model.provenance import model_values_sha256
from hacgear_core.model.schema import GearErrors, Mesh
from hacgear_core.statics import ContactOptions
from hacgear_core.statics.helical import make_helical_solver
from hacgear_core.tables import load_system_tables

MODELS = Path(__file__).resolve().parents[1] / "models"


def _with(model, lead=(0.0, 0.0), psi=0.0):
    gears = tuple(replace(g, errors=GearErrors(lead_slope_m=f)) for g, f in zip(model.gears, lead))
    return replace(model, gears=gears, meshes=(replace(model.meshes[0], misalignment_in_plane_rad=psi),))


def _nominal_pattern(table, force_N, twist_rad):
    """Cycle-mean slice loads (Ns,) [N] of ``table`` at the mesh force ``force_N`` and mesh twist ``twist_rad``
    (the deflection per position found by bisection on the table's W)."""
    tw = table.twist
    pos = np.asarray(table.position, float)
    g = np.full(pos.size, float(twist_rad))
    lo = np.full(pos.size, float(table.deflection_m[0]))
    hi = np.full(pos.size, float(table.deflection_m[-1]))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        up = table.twist_quantity(tw.generalized_fdf, pos, mid, g)[..., 0] >= force_N
        hi, lo = np.where(up, mid, hi), np.where(up, lo, mid)
    return table.twist_quantity(tw.slice_load_N, pos, 0.5 * (lo + hi), g).mean(axis=0)


# ---------------------------------------------------------------- inputs


def test_inputs_are_read_in_micrometres_and_microradians_and_validated():
    text = (MODELS / "helical_28_33" / "model.toml").read_text()
    text = text.replace('center_distance_mm = 152.5', 'center_distance_mm = 152.5\nmisalignment_in_plane_urad = 120.0')
    text = text.replace('  [gears.drive]', '  [gears.errors]\n  lead_slope_um = -3.0\n  [gears.drive]', 1)
    m = parse_model(text, file="t.toml")
    assert m.gears[0].errors.lead_slope_m == pytest.approx(-3e-6)
    assert m.meshes[0].misalignment_in_plane_rad == pytest.approx(1.2e-4)
    with pytest.raises(ModelError, match=r"lead_slope_um.*\[um\]"):
        parse_model(text.replace("lead_slope_um = -3.0", "lead_slope_um = 2000.0"), file="t.toml")
    with pytest.raises(ModelError, match=r"misalignment_in_plane_urad.*\[urad\]"):
        parse_model(text.replace("misalignment_in_plane_urad = 120.0", "misalignment_in_plane_urad = 2e4"),
                    file="t.toml")
    assert parse_model(text.replace("misalignment_in_plane_urad = 120.0", "misalignment_out_of_plane_urad = 50"),
                       file="t.toml").meshes[0].misalignment_out_of_plane_rad == pytest.approx(5e-5)
    with pytest.raises(ModelError, match=r"misalignment_out_of_plane_urad.*\[urad\]"):
        parse_model(text.replace("misalignment_in_plane_urad = 120.0", "misalignment_out_of_plane_urad = -2e4"),
                    file="t.toml")
    with pytest.raises(ModelError, match=r"errors.lead_slope_m \[m\].*\[-0.001, 0.001\]"):
        GearErrors(lead_slope_m=2e-3)
    with pytest.raises(ModelError, match=r"misalignment_in_plane_rad \[rad\].*\[-0.01, 0.01\]"):
        Mesh("m", "a", "b", misalignment_in_plane_rad=0.02)
    # neither enters the values the tables depend on; a lead slope alone is not an error-profile error
    assert model_values_sha256(_with(m, (5e-6, -2e-6), 3e-4)) == model_values_sha256(_with(m))
    assert not GearErrors(lead_slope_m=1e-6).any


def test_twist_offset_of_lead_slopes_and_misalignment(helical, table):
    """gamma_0 = psi - f_a / b_a - f_b / b_b: material added at the +z end of either gear closes the +z end,
    which a negative mesh twist does (closure -gamma zeta cos beta_b); the coast side sees the misalignment's
    rotation on its own twist axis."""
    assert lead_twist_offset_rad((2.5e-6, 0.0), (0.01, 0.016)) == pytest.approx(-2.5e-4, rel=1e-12)
    assert lead_twist_offset_rad((0.0, 4e-6), (0.01, 0.016), 1e-4) == pytest.approx(-1.5e-4, rel=1e-12)
    sy = build_system(_with(helical, (1e-6, 1.6e-6), 3e-4), {"m12": table})
    tw = sy.meshes[0].table.twist
    assert tw.twist_offset_rad == pytest.approx(3e-4 - 1e-4 - 1e-4, rel=1e-12)
    e1, e1c = table.twist.r_twist[3:6], table.coast.twist.r_twist[3:6]
    assert sy.meshes[0].coast_table.twist.twist_offset_rad == pytest.approx(3e-4 * float(e1 @ e1c), rel=1e-12)
    g0, g0c = twist_offsets_rad(_with(helical, (1e-6, 0.0)), helical.meshes[0], table.twist.r_twist,
                                table.coast.twist.r_twist)
    assert (g0, g0c) == (pytest.approx(-1e-4), 0.0)      # the coast flanks keep their ideal lead
    # the kernel reads the grid at gamma + gamma_0: its twist origin is shifted by -gamma_0
    tflt = sy.arrays.tflt                                 # rows m_kernel + k: (g0, 1/dg, g_min, g_max)
    assert tflt[sy.m_kernel, 0] == pytest.approx(float(table.twist.twist_rad[0]) - tw.twist_offset_rad)


def test_offsets_outside_the_twist_axis_and_without_one_are_refused(helical, table):
    with pytest.raises(ModelError, match=r"misalignment_in_plane_urad = 600 urad.*\[-500.0, \+500.0\] urad.*"
                                         r"max_twist_mrad"):
        build_system(_with(helical, psi=6e-4), {"m12": table})
    with pytest.raises(ModelError, match=r"lead_slope_um = 6 um of 'pinion'"):
        build_system(_with(helical, (6e-6, 0.0)), {"m12": table})
    spur = load_model("spur_28t_asym")
    stab = load_system_tables(spur.path)
    bad = replace(spur, gears=(replace(spur.gears[0], errors=GearErrors(lead_slope_m=2e-6)),) + spur.gears[1:])
    with pytest.raises(ModelError, match=r"lead_slope_um.*twist axis.*twist_points"):
        build_system(bad, stab)
    bad = replace(spur, meshes=(replace(spur.meshes[0], misalignment_in_plane_rad=1e-4),))
    with pytest.raises(ModelError, match=r"misalignment_in_plane_urad.*twist axis"):
        build_system(bad, stab)


def test_zero_lead_errors_run_on_the_same_arrays(helical, table):
    """Explicit zero lead slopes and misalignment: the system keeps the very table object, its kernel arrays are
    equal bit for bit and a run is bit-identical."""
    sy0 = build_system(helical, {"m12": table})
    sy1 = build_system(_with(helical), {"m12": table})
    assert sy1.meshes[0].table is table
    for k in ("tab", "tint", "tflt", "vecs", "lin", "lint"):
        assert np.array_equal(getattr(sy0.arrays, k), getattr(sy1.arrays, k)), k
    s0, s1 = np.zeros(24), np.zeros(24)
    kin = np.array([0.3, 0.0, 0.0])
    sy0.integrate(s0, kin, 2000, 2e-6, sy0.fext_speed())
    sy1.integrate(s1, kin, 2000, 2e-6, sy1.fext_speed())
    assert np.array_equal(s0, s1)


# ---------------------------------------------------------------- statics


@pytest.fixture(scope="module")
def slices_solver(helical):
    """helical_28_33 without lead crowning, independent face slices (each slice its own 2D far field: a Winkler
    foundation across the face), 11 slices."""
    m0 = replace(helical, gears=tuple(replace(g, lead_crowning_m=0.0) for g in helical.gears))
    return make_helical_solver(m0, "m12", options=ContactOptions(face_slices=11, face_coupling="slices"))


def _slice_means(solver, force_N, twist_rad=0.0, lead=(0.0, 0.0)):
    """Cycle means over 16 positions under load control: slice loads (Ns,) [N], twist moment [N m] and mesh
    deflections (16,) [m]; ``lead`` (f_a, f_b) [m] applied as the exact flank deviation (transverse, linear over
    each gear's face, material added at its +z end) through the solver's per-slice flank deviations."""
    base = solver.crowning_slices_m.copy()
    z = solver.z_centre_m + solver.slice_z_m
    dev = base.copy()
    for i in range(2):
        dev[i] -= lead[i] * (z - solver.gear_axial_m[i]) / solver.gear_face_width_m[i]
    solver.crowning_slices_m = dev
    solver._setup_cache.clear()
    try:
        sols = [solver.solve_load(float(p), force_N, twist_rad=twist_rad) for p in np.arange(16) / 16]
    finally:
        solver.crowning_slices_m = base
        solver._setup_cache.clear()
    return (np.mean([s.slice_load_N for s in sols], axis=0), float(np.mean([s.twist_moment_Nm for s in sols])),
            np.array([s.mesh_deflection_m for s in sols]))


def test_face_load_factor_of_a_winkler_face_is_the_iso_closed_form(slices_solver):
    """ISO 6336-1 (linear load distribution, K_Hbeta <= 2): K_Hbeta = 1 + F_betay c_gamma b / (2 F_m), here in the
    flank-normal direction: F_betay = |gamma_0| cos(beta_b) b (the closure across the face of the mesh twist),
    c_gamma b = dW/dx of the same statics (load control at +-2 %, 16 positions), F_m = W.  Our K_Hbeta is the peak
    of the linear fit of the cycle-mean line load over the face (11 slices), extrapolated to the face ends, over
    the mean.  Tolerance 5 % on K_Hbeta - 1: the slices are independent (a Winkler foundation); what remains is
    the Hertz near field's nonlinearity (the slices' stiffness changes with their load), the closure's part along
    the path of contact and the solver's tolerance (measured 2026-12-07: K_Hbeta - 1 at 0.970 / 0.982 / 0.988 of
    the closed form at 100 / 250 / -500 urad; docs/validation.md)."""
    s = slices_solver
    W = 200.0 / s.lever_arm_m[0]
    _, _, xp = _slice_means(s, 1.02 * W)
    _, _, xm = _slice_means(s, 0.98 * W)
    k = float(np.mean(0.04 * W / (xp - xm)))
    b = float(s.slice_z_m.size * np.mean(np.diff(s.slice_z_m)))
    cb = math.cos(s.frame.base_helix_angle_rad)
    zeta = s.slice_z_m - s.slice_z_m.mean()
    for g0 in (1e-4, 2.5e-4, -5e-4):
        load, _, _ = _slice_means(s, W, twist_rad=g0)
        w = load / (b / load.size)
        slope, mean = np.polyfit(zeta, w, 1)
        k_ours = 1.0 + abs(slope) * b / 2 / mean          # the fit's mean is the mean line load (zeta centred)
        k_iso = 1.0 + abs(g0) * cb * b * k / (2.0 * W)
        assert k_ours - 1.0 == pytest.approx(k_iso - 1.0, rel=0.05), (g0, k_ours, k_iso)
        # the loaded end is the one the twist closes: -z for a positive twist
        assert (slope < 0) == (g0 > 0)
        assert load.sum() == pytest.approx(W, rel=1e-3)    # contact forces; W = sum lam F (lam ~ 1)


@pytest.mark.slow
def test_elastic_face_redistributes_more_than_the_closed_form(helical):
    """The same check on the shipped face physics (elastic coupling: each gear's 2D far field plus the 3D face-wise
    correction; no lead crowning): the closed form with the mesh stiffness dW/dx is **missed**.  A load that varies
    linearly over the face has no resultant, so the gear body's compliance (rim, blank: most of the far field, a
    uniform deflection) does not resist it; only the tooth's own plate bending and the contact do, and the face
    load changes ~3 x as much as a Winkler face with the total mesh stiffness predicts.  Measured 2026-12-07 (3D
    sectors built in 164 s): K_Hbeta - 1 of the change of the face load at 2.97 / 2.97 / 2.96 x the closed form at
    100 / 250 / 500 urad (dW/dx 157.72e6 N/m); the test keeps the measured ratio within (2.5, 3.5) and its sign."""
    m0 = replace(helical, gears=tuple(replace(g, lead_crowning_m=0.0) for g in helical.gears))
    s = make_helical_solver(m0, "m12", options=ContactOptions(face_slices=11, face_coupling="elastic"))
    W = 200.0 / s.lever_arm_m[0]
    _, _, xp = _slice_means(s, 1.02 * W)
    _, _, xm = _slice_means(s, 0.98 * W)
    k = float(np.mean(0.04 * W / (xp - xm)))
    b = float(s.slice_z_m.size * np.mean(np.diff(s.slice_z_m)))
    cb = math.cos(s.frame.base_helix_angle_rad)
    zeta = s.slice_z_m - s.slice_z_m.mean()
    l0, _, _ = _slice_means(s, W)
    s0 = np.polyfit(zeta, l0 / (b / l0.size), 1)[0]
    for g0 in (1e-4, 2.5e-4, 5e-4):
        load, _, _ = _slice_means(s, W, twist_rad=g0)
        slope, mean = np.polyfit(zeta, load / (b / load.size), 1)
        k_change = 1.0 + abs(slope - s0) * b / 2 / mean
        k_iso = 1.0 + g0 * cb * b * k / (2.0 * W)
        assert slope < s0
        assert 2.5 < (k_change - 1.0) / (k_iso - 1.0) < 3.5, (g0, k_change, k_iso)


def test_shipped_table_face_load_against_the_closed_form(helical, table):
    """The shipped table (elastic coupling, 5 um lead crowning on both gears) at +-250 urad: the face load is not
    uniform at zero twist (peak/mean 1.462); the change of its linear fit over the face is 2.54 / 2.59 x the closed
    form with the table's dW/dx (157.14e6 N/m): a miss for the reason of the elastic face (slow test above).
    Asserted: the measured ratio within (2.0, 3.2) and the loaded end."""
    from hacgear_core.tables.fdf import generalized_stiffness

    tw = table.twist
    W = 200.0 / float(tw.lever_arm_m[0])
    k = generalized_stiffness(table, W).means()["k_xx_N_per_m"]
    z = tw.slice_z_m
    b = float(z.size * np.mean(np.diff(z)))
    zeta = z - z.mean()
    cb = math.cos(tw.base_helix_angle_rad)
    p0 = _nominal_pattern(table, W, 0.0)
    assert p0.max() / p0.mean() == pytest.approx(1.462, abs=0.005)
    s0 = np.polyfit(zeta, p0 / (b / z.size), 1)[0]
    for g0 in (2.5e-4, -2.5e-4):
        p = _nominal_pattern(table, W, g0)
        slope, mean = np.polyfit(zeta, p / (b / z.size), 1)
        ratio = (abs(slope - s0) * b / 2 / mean) / (abs(g0) * cb * b * k / (2.0 * W))
        assert 2.0 < ratio < 3.2, (g0, ratio)
        assert (slope < s0) == (g0 > 0)


def test_twist_offset_linearises_the_exact_lead_slope(slices_solver):
    """A lead slope f on gear_a as the exact flank deviation against its twist offset gamma_0 = -f / b_a: the face
    load change agrees within 2 % of its peak; the twist moment change of the twist offset is 1.37 x the exact
    one (the closure -gamma_0 S sin(beta_b) along the path of contact that the lead slope lacks); the cycle-mean
    approach differs by the rigid part only (< 0.01 um here, gear_a's mid-face at the reference plane)."""
    s = slices_solver
    W = 200.0 / s.lever_arm_m[0]
    l0, m0, x0 = _slice_means(s, W)
    f = 2.5e-6
    g0 = lead_twist_offset_rad((f, 0.0), s.gear_face_width_m)
    le, me, xe = _slice_means(s, W, lead=(f, 0.0))
    lt, mt, xt = _slice_means(s, W, twist_rad=g0)
    de, dt = le - l0, lt - l0
    assert np.max(np.abs(dt - de)) < 0.02 * np.max(np.abs(de))
    assert de[-1] > 0 and de[0] < 0                     # material added at the +z end loads the +z end
    ratio = (mt - m0) / (me - m0)
    assert 1.2 < ratio < 1.55, ratio
    assert abs(np.mean(xe - x0) - np.mean(xt - x0)) < 0.01e-6


def test_contact_pattern_moves_to_the_face_end_the_error_loads(helical, table):
    """Shipped table (elastic face coupling, lead crowning): the cycle-mean load centroid at the nominal force
    moves towards -z for a positive misalignment and towards +z for material added at the +z end of the pinion."""
    W = 200.0 / float(table.twist.lever_arm_m[0])
    z = table.twist.slice_z_m

    def centroid(model):
        t = build_system(model, {"m12": table}).meshes[0].table
        p = _nominal_pattern(t, W, 0.0)
        return float(p @ z / p.sum())

    c0 = centroid(helical)
    assert centroid(_with(helical, psi=2.5e-4)) < c0 - 1e-4
    assert centroid(_with(helical, (2.5e-6, 0.0))) > c0 + 1e-4


# ---------------------------------------------------------------- dynamics


def test_zero_speed_run_rests_at_the_statics_at_the_offset_twist(helical, table):
    """Misalignment 250 urad: the compiled kernel at zero speed comes to rest at the Newton equilibrium of the
    shifted law; its W and M are the statics' (the unshifted table read at gamma_eq + gamma_0), the supports
    carry W r_mesh + M r_twist, and the twist moment exceeds the aligned pair's by about dM/dgamma gamma_0."""
    psi = 2.5e-4
    sy = build_system(_with(helical, psi=psi), {"m12": table})
    sy0 = build_system(helical, {"m12": table})
    eq = static_equilibrium(sy, 0.3)
    eq0 = static_equilibrium(sy0, 0.3)
    s = np.zeros(24)
    sy.integrate(s, np.array([0.3, 0.0, 0.0]), 250_000, 2e-6, sy.fext_speed())
    assert np.max(np.abs(s[:12] - eq.q)) < 1e-8 * np.max(np.abs(eq.q))
    tau = float(sy.unwrapped_positions(0.3)[0] + sy.phase[0] + sy.W[0] @ eq.q)    # the mesh position at rest
    x, g = float(eq.mesh_deflections_m[0]), float(eq.twist_rad[0])
    assert g == pytest.approx(float(sy.T[0] @ s[:12]), rel=1e-6)
    wm = table.twist_quantity(table.twist.generalized_fdf, tau, x, g + psi)
    assert eq.mesh_forces_N[0] == pytest.approx(float(wm[0]), rel=1e-6)
    assert eq.twist_moment_Nm[0] == pytest.approx(float(wm[1]), rel=1e-6)
    res = sy.fext_speed() - sy.K @ eq.q - sy.V[0] * eq.mesh_forces_N[0] - sy.T[0] * eq.twist_moment_Nm[0]
    assert np.max(np.abs(res)) < 1e-6 * sy.nominal_forces_N()[0]
    # the gears barely tilt (mesh twist stiffness ~3.6e3 against tilting supports 1e6 N m/rad): the flanks meet
    # near gamma_0, the moment grows by about dM/dgamma gamma_0 (the table's slope at this position, 25 % margin)
    k_gg = float((table.twist_quantity(table.twist.generalized_fdf, tau, x, g + psi + 1e-5)[1]
                  - table.twist_quantity(table.twist.generalized_fdf, tau, x, g + psi - 1e-5)[1]) / 2e-5)
    assert abs(eq.twist_rad[0] - eq0.twist_rad[0]) < 0.05 * psi
    assert eq.twist_moment_Nm[0] - eq0.twist_moment_Nm[0] == pytest.approx(k_gg * psi, rel=0.25)


def test_fmu_adapter_builds_the_same_shifted_system(helical, table):
    """The FMUs run the generic adapter on ``build_system``: a model with a misalignment gives its constant-speed
    and drivetrain systems the same twist offset and the same kernel twist origin as the library's system."""
    from hacgear_core.fmu.adapter import Adapter
    from hacgear_core.tables import SystemTables

    model = _with(helical, (1e-6, 0.0), 2e-4)
    lib = build_system(model, {"m12": table})
    tables = load_system_tables(helical.path)
    assert isinstance(tables, SystemTables)
    ad = Adapter(model, tables)
    for sy in (ad.base_system, ad._drive_system):
        assert sy.meshes[0].table.twist.twist_offset_rad == pytest.approx(2e-4 - 1e-4, rel=1e-12)
        assert sy.meshes[0].coast_table.twist.twist_offset_rad == lib.meshes[0].coast_table.twist.twist_offset_rad
    assert np.array_equal(ad.base_system.arrays.tflt, lib.arrays.tflt)


def test_helical_stage_of_a_gear_train_takes_the_offset_and_its_spur_stage_refuses_it():
    """reducer_helical_19_71_23_83 (helical m12, spur m34): the helical stage's builder shifts its table; a
    misalignment on the spur stage is refused (its table has no twist axis)."""
    m = load_model("reducer_helical_19_71_23_83")
    t = load_system_tables(m.path)

    def misaligned(name):
        return replace(m, meshes=tuple(replace(x, misalignment_in_plane_rad=1e-4) if x.name == name else x
                                       for x in m.meshes))

    sy = build_system(misaligned("m12"), t)
    assert sy.meshes[sy.mesh_names.index("m12")].table.twist.twist_offset_rad == pytest.approx(1e-4, rel=1e-12)
    with pytest.raises(ModelError, match=r"mesh 'm34' \(\[\[meshes\]\] misalignment_in_plane_urad\).*twist axis"):
        build_system(misaligned("m34"), t)


def test_constant_speed_run_carries_the_static_mean_twist_moment(helical, table):
    """1200 Hz (off resonance), 200 N*m, psi = +250 urad: the cycle means of W, M and gamma over 40 cycles equal the
    means of the static equilibria of the shifted law over 32 positions (measured 2026-12-07: M 3.1198 against
    3.1212 N m, aligned 2.2490 against 2.2507; W 3245.09 against 3245.07 N) within 1 % (M) and 0.1 % (W)."""
    from hacgear_core.dynamics.simulator import Simulator

    sy = build_system(_with(helical, psi=2.5e-4), {"m12": table})
    eqs = [static_equilibrium(sy, float(p)) for p in np.arange(32) / 32]
    sim = Simulator(sy)
    sim.set_speed_input(mesh_frequency_Hz=1200.0)
    sim.set_torque_set_point(200.0)
    out = sim.run(80 / 1200.0, 1 / 1200.0 / 32)
    n = 32 * 40
    assert out["mesh_force_N"][-n:, 0].mean() == pytest.approx(np.mean([e.mesh_forces_N[0] for e in eqs]), rel=1e-3)
    m_static = np.mean([e.twist_moment_Nm[0] for e in eqs])
    assert out["twist_moment_Nm"][-n:, 0].mean() == pytest.approx(m_static, rel=0.01)
    assert m_static > 2.25 + 0.5                        # aligned: 2.2507 N m (docs/helical.md, 1200 Hz run)
    assert out["mesh_twist_rad"][-n:, 0].mean() == pytest.approx(np.mean([e.twist_rad[0] for e in eqs]), abs=0.1e-6)


# ---------------------------------------------------------------- spur pairs (helix angle 0, a twist axis on request)


@pytest.fixture(scope="module")
def spur_slices_solver():
    """spur_28t_asym without lead crowning on the face-resolving solver (helix angle 0), independent face slices,
    11 slices."""
    sp = load_model("spur_28t_asym")
    m0 = replace(sp, gears=tuple(replace(g, lead_crowning_m=0.0) for g in sp.gears))
    return make_helical_solver(m0, "m12", options=ContactOptions(face_slices=11, face_coupling="slices"))


def test_spur_face_load_factor_is_the_iso_closed_form_and_the_lead_slope_is_exact(spur_slices_solver):
    """Spur teeth (beta_b = 0) at the operating torque 300 N m: K_Hbeta - 1 of the statics at the mesh twist is ISO
    6336-1's 1 + F_betay c_gamma b / (2 F_m) within 1 % (measured 0.999 / 0.999 / 1.005 at 100 / 250 / -500 urad),
    and the twist offset gamma_0 = -f / b is the lead slope exactly: the twist's closure -gamma zeta has no part along
    the path of contact (S sin beta_b = 0), so the exact flank deviation and its twist offset give the same face
    loads (3.4e-6 of the change measured), twist moment change (ratio 1 - 3.4e-6) and approach."""
    s = spur_slices_solver
    assert s.frame.base_helix_angle_rad == 0.0
    W = 300.0 / s.lever_arm_m[0]
    _, _, xp = _slice_means(s, 1.02 * W)
    _, _, xm = _slice_means(s, 0.98 * W)
    k = float(np.mean(0.04 * W / (xp - xm)))
    b = float(s.slice_z_m.size * np.mean(np.diff(s.slice_z_m)))
    zeta = s.slice_z_m - s.slice_z_m.mean()
    for g0 in (1e-4, 2.5e-4, -5e-4):
        load, _, _ = _slice_means(s, W, twist_rad=g0)
        slope, mean = np.polyfit(zeta, load / (b / load.size), 1)
        k_ours = 1.0 + abs(slope) * b / 2 / mean
        k_iso = 1.0 + abs(g0) * b * k / (2.0 * W)
        assert k_ours - 1.0 == pytest.approx(k_iso - 1.0, rel=0.01), (g0, k_ours, k_iso)
        assert (slope < 0) == (g0 > 0)
    l0, m0, x0 = _slice_means(s, W)
    for f in (1.5e-6, -3e-6):
        g0 = lead_twist_offset_rad((f, 0.0), s.gear_face_width_m)
        le, me, xe = _slice_means(s, W, lead=(f, 0.0))
        lt, mt, xt = _slice_means(s, W, twist_rad=g0)
        assert np.max(np.abs((lt - l0) - (le - l0))) < 1e-4 * np.max(np.abs(le - l0))
        assert (mt - m0) / (me - m0) == pytest.approx(1.0, abs=1e-4)
        assert np.max(np.abs(xe - xt)) < 1e-12


def _spur_twist_model(tmp_path):
    """A copy of spur_28t_asym asking for a twist axis (``[statics] twist_points = 3`` over +-0.5 mrad, 5 face
    slices, a small grid), its tables computed on independent slices."""
    from hacgear_core.statics.grid import compute_statics

    src = (MODELS / "spur_28t_asym" / "model.toml").read_text()
    start = src.index("[statics]")
    end = src.find("\n[", start + 1)
    grid = ("[statics]\npositions = 8\nloads = 4\ndeflections = 12\nmax_torque_factor = 3.0\nface_slices = 5\n"
            "twist_points = 3\nmax_twist_mrad = 0.5\n")
    text = src[:start] + grid + ("" if end < 0 else src[end:])
    path = tmp_path / "model.toml"
    path.write_text(text)
    rep = compute_statics(path, tmp_path / "tables.h5", workers=1, progress=False, face_coupling="slices")
    assert rep.success, rep.message
    return text, load_system_tables(path)


def test_spur_pair_with_a_twist_axis_takes_lead_slope_and_misalignment(tmp_path):
    """``hacgear statics`` of a spur pair with ``[statics] twist_points > 1`` tabulates the mesh twist (the
    face-resolving solver at helix angle 0, drive and coast sides), the pair is then built with six DOFs per gear on
    the generalized FDF, and a lead slope is its twist offset: a 1.5 um pinion lead slope over the 15 mm face and a
    misalignment of -100 urad shift the drive flanks' twist alike (gamma_0 = psi - f / b = -100 urad, exact for spur
    teeth) and rest at the same static equilibrium, their sum not at all; the misalignment reaches the coast flanks
    too (their own twist axis), the lead slope of the drive flanks does not.  At the static equilibrium the twist
    moment [N m] changes sign with the offset, the mesh force stays the nominal one.  A rigid face with a twist
    axis is refused."""
    from hacgear_core.statics.grid import compute_statics

    text, tables = _spur_twist_model(tmp_path)
    tab = tables.mesh("m12")
    assert tab.twist is not None and tab.coast is not None and tab.coast.twist is not None
    np.testing.assert_allclose(tab.twist.twist_rad, [-5e-4, 0.0, 5e-4])
    assert tab.twist.base_helix_angle_rad == 0.0
    base = parse_model(text, file="spur.toml")

    def system(lead_um=0.0, psi_urad=0.0):
        m = replace(base, gears=(replace(base.gears[0], errors=GearErrors(lead_slope_m=lead_um * 1e-6)),)
                    + base.gears[1:], meshes=(replace(base.meshes[0], misalignment_in_plane_rad=psi_urad * 1e-6),))
        return build_system(m, tables)

    aligned, lead, mis, both = system(), system(lead_um=1.5), system(psi_urad=-100.0), system(1.5, 100.0)
    assert aligned.n == 12 and np.any(aligned.T[0] != 0)

    def offsets(sy):
        t = sy.meshes[0].table
        return t.twist.twist_offset_rad, t.coast.twist.twist_offset_rad
    assert offsets(aligned) == (0.0, 0.0)
    assert offsets(lead)[0] == pytest.approx(-1e-4, rel=1e-12) and offsets(lead)[1] == 0.0
    assert offsets(mis)[0] == pytest.approx(-1e-4, rel=1e-12) and offsets(mis)[1] != 0.0
    assert offsets(both)[0] == pytest.approx(0.0, abs=1e-18) and offsets(both)[1] == -offsets(mis)[1]
    eqs = {}
    for key, sy in (("aligned", aligned), ("lead", lead), ("mis", mis), ("lead-", system(lead_um=-1.5))):
        eq = static_equilibrium(sy)
        assert eq.success
        assert eq.mesh_forces_N[0] == pytest.approx(sy.nominal_forces_N()[0], rel=1e-6)
        eqs[key] = (eq.q, float(sy.mesh_law.generalized(0, 0.0, sy.V[0] @ eq.q, sy.T[0] @ eq.q)[1]))
    np.testing.assert_allclose(eqs["lead"][0], eqs["mis"][0], rtol=1e-9, atol=1e-15)
    m0, mp, mm = eqs["aligned"][1], eqs["lead"][1], eqs["lead-"][1]
    assert (mp - m0) * (mm - m0) < 0
    with pytest.raises(ModelError, match=r"face_coupling = 'rigid' with \[statics\] twist_points = 3 on a spur pair"):
        compute_statics(tmp_path / "model.toml", tmp_path / "rigid.h5", workers=1, progress=False,
                        face_coupling="rigid")
