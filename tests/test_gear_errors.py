"""Manufacturing errors (hacgear_core.dynamics.gear_errors; [gears.errors] in model files; the kernel's error loops):
the model section and its ranges, the error profile's closed forms (runout, cumulative pitch), the hunting-tooth
period, and on spur_28t_asym: a 10 um pinion runout in the static TE (a shaft line of exactly the runout's
line-of-action projection, no sidebands) and in the mesh force under imposed kinematics (sidebands at f_m +- f_shaft
= the runout times the mesh stiffness variation), a single pitch error's once-per-revolution pulse whose order
spectrum is the error's Fourier series times the pair's stiffness-share pulse (static and through the kernel); zero
errors leave the system and its kernel as they were."""
from __future__ import annotations

import math
from dataclasses import replace
from functools import cache

import numpy as np
import pytest

from hacgear_core.dynamics import static_equilibrium
from hacgear_core.dynamics.batch import batch_supported
from hacgear_core.dynamics.gear_errors import (cumulative_pitch_deviations_m, iso1328_single_pitch_tolerance_m,
                                               single_pitch_deviations_m)
from hacgear_core.errors import ModelError
from hacgear_core.geometry import mesh_geometry
from hacgear_core.kinds import build_system, load_model, parse_model
from hacgear_core.model import GearErrors, resolve_model_path
from hacgear_core.model.provenance import model_values_sha256
from hacgear_core.spectra.records import system_spectra

from _pitch import share_transform

E_RUNOUT = 10e-6
Z = 28


@cache
def _spur():
    from hacgear_core.tables import load_system_tables
    p = resolve_model_path("spur_28t_asym")
    return load_model(p), load_system_tables(p)


def _with_errors(pinion=None, wheel=None):
    model, tabs = _spur()
    gears = (replace(model.gears[0], errors=pinion), replace(model.gears[1], errors=wheel))
    return build_system(replace(model, gears=gears), tabs)


def _model_text(errors: str) -> str:
    text = resolve_model_path("spur_28t_asym").read_text()
    return text.replace("  [gears.drive]", "  [gears.errors]\n" + errors + "\n  [gears.drive]", 1)


def test_errors_section_is_read_in_si_and_checked():
    m = parse_model(_model_text("  runout_um = 10.0\n  runout_phase_deg = 30.0"))
    ge = m.gears[0].errors
    assert ge.runout_m == pytest.approx(1e-5) and ge.runout_phase_rad == pytest.approx(math.radians(30))
    assert m.gears[1].errors is None and ge.any
    # the tables do not depend on the errors: the same model values hash, so the shipped tables stay valid
    assert model_values_sha256(m) == model_values_sha256(load_model(resolve_model_path("spur_28t_asym")))
    pitch = [0.0] * Z
    pitch[3], pitch[4] = 2.5, -2.5
    m = parse_model(_model_text(f"  single_pitch_deviations_um = {pitch}"))
    assert m.gears[0].errors.single_pitch_deviations_m[3] == pytest.approx(2.5e-6)
    for bad, match in (("  runout_um = -1.0", r"runout_um.*\[um\].*out of range"),
                       ("  runout_mm = 1.0", r"unknown key 'gears\[0\].errors.runout_mm'"),
                       ("  iso1328_grade = 12", r"iso1328_grade.*integer in \[1, 11\]"),
                       (f"  single_pitch_deviations_um = {[1.0] + [0.0] * (Z - 1)}", r"must close"),
                       ("  single_pitch_deviations_um = [1.0, -1.0]", r"one value per tooth \(28\)"),
                       (f"  single_pitch_deviations_um = {pitch}\n  iso1328_grade = 5", r"not both")):
        with pytest.raises(ModelError, match=match):
            parse_model(_model_text(bad))


def test_iso1328_grade_and_cumulative_pitch():
    """ISO 1328-1:2013 f_pT = (0.001 d + 0.4 m + 5) sqrt(2)^(A-5) um: 7.14 um for d = 140 mm, m = 5 mm at grade 5,
    doubled two grades coarser; drawn deviations lie within +-f_pT (to the closing shift), close, and repeat
    with their seed; the cumulative deviation of a single displaced tooth is a pulse on that tooth."""
    assert iso1328_single_pitch_tolerance_m(5, 0.14, 0.005) == pytest.approx(7.14e-6, rel=1e-12)
    assert iso1328_single_pitch_tolerance_m(7, 0.14, 0.005) == pytest.approx(14.28e-6, rel=1e-12)
    ge = GearErrors(iso1328_grade=6, seed=3)
    f = single_pitch_deviations_m(ge, Z, 0.14, 0.005)
    fpt = iso1328_single_pitch_tolerance_m(6, 0.14, 0.005)
    assert abs(f.sum()) < 1e-18 and np.max(np.abs(f)) < 1.1 * fpt and np.std(f) > 0.3 * fpt
    assert np.array_equal(f, single_pitch_deviations_m(ge, Z, 0.14, 0.005))
    assert not np.array_equal(f, single_pitch_deviations_m(GearErrors(iso1328_grade=6, seed=4), Z, 0.14, 0.005))
    one = np.zeros(Z)
    one[5], one[6] = 2e-6, -2e-6
    F = cumulative_pitch_deviations_m(one)
    assert np.allclose(F, np.where(np.arange(Z) == 5, 2e-6, 0.0) - 2e-6 / Z, rtol=0, atol=1e-18)


def test_zero_errors_leave_the_system_and_its_kernel():
    """[gears.errors] with nothing in it: no error profile, the error-free kernel, the same fingerprint."""
    ref = _with_errors()
    sy = _with_errors(pinion=GearErrors(runout_m=0.0), wheel=GearErrors())
    assert not sy.has_errors and sy.meshes[0].error is None and sy.kernel is ref.kernel
    assert sy.fingerprint() == ref.fingerprint() and sy.period_cycles == ref.period_cycles == 1
    assert batch_supported(ref) and not batch_supported(_with_errors(pinion=GearErrors(runout_m=E_RUNOUT)))


def test_runout_profile_and_hunting_period():
    """Runout of each gear closes the mesh by e sin(beta_a + alpha_w) for the driving pinion, e sin(alpha_w - beta_b)
    for the driven wheel (beta = 2 pi (c - passage) / z + phase); the profile is the opening, minus that; the system
    repeats after the 28 mesh cycles of a revolution."""
    model, _ = _spur()
    alpha = mesh_geometry(model, model.meshes[0].name).operating_pressure_angle_rad
    for which in (0, 1):
        ge = GearErrors(runout_m=E_RUNOUT, runout_phase_rad=0.7)
        sy = _with_errors(**{("pinion", "wheel")[which]: ge})
        c = sy.meshes[0]
        samples, L, npc = c.error
        assert sy.has_errors and L == Z and sy.period_cycles == Z and "tooth errors" in sy.kernel_label
        pos = np.arange(L * npc) / npc
        beta = 2 * np.pi * (pos - c.tooth_passage[(c.gear_a, c.gear_b)[which]]) / Z + 0.7
        want = -E_RUNOUT * (np.sin(beta + alpha) if which == 0 else np.sin(alpha - beta))
        assert np.allclose(samples, want, rtol=0, atol=1e-18)
        assert np.allclose(sy.mesh_errors_m(pos[:, None] + 0.3 / npc)[:, 0],
                           np.interp(pos + 0.3 / npc, np.append(pos, L), np.append(want, want[0])), atol=1e-18)


def test_runout_static_te_is_the_ideal_te_plus_the_runout():
    """10 um pinion runout: the static TE (load held by the torque) is the ideal gears' TE less the runout's
    line-of-action closing, e sin(2 pi c / z + phase + alpha_w) (an offset towards the wheel lowers the TE by
    e sin alpha_w): one line at shaft order 1 of amplitude e and phase (phase + alpha_w + pi/2), no sidebands at f_m +- f_shaft (they would need the centre-distance change,
    which the tables do not hold); the mesh harmonics those of the ideal gears."""
    model, _ = _spur()
    alpha = mesh_geometry(model, model.meshes[0].name).operating_pressure_angle_rad
    sy = _with_errors(pinion=GearErrors(runout_m=E_RUNOUT, runout_phase_rad=0.4))
    _, sp = system_spectra(sy, 200.0, "ste", samples_per_cycle=32)
    _, sp0 = system_spectra(_with_errors(), 200.0, "ste", record_cycles=Z, samples_per_cycle=32)
    s, s0 = sp["m12"], sp0["m12"]
    assert s.coherent
    ln = s.line("1 x pinion/wheel")
    assert ln.amplitude == pytest.approx(E_RUNOUT, rel=1e-6)
    assert math.remainder(ln.phase_rad - (0.4 + alpha + math.pi / 2), 2 * math.pi) == pytest.approx(0, abs=1e-6)
    # at the passage of the pinion's tooth 0 with the offset pointing at the pitch point (phase 0), the TE is the
    # ideal TE less e sin(alpha_w): the flanks meet earlier by that much
    sy0 = _with_errors(pinion=GearErrors(runout_m=E_RUNOUT, runout_phase_rad=0.0))
    c0 = float(sy0.meshes[0].tooth_passage["pinion"])
    fext = sy0.fext_speed()
    te = static_equilibrium(sy0, c0, fext).mesh_deflections_m[0]
    te0 = static_equilibrium(_with_errors(), c0, fext).mesh_deflections_m[0]
    assert te - te0 == pytest.approx(-E_RUNOUT * math.sin(alpha), rel=1e-6)
    for lab in ("1-1 pinion/wheel", "1+1 pinion/wheel", "2-1 pinion/wheel", "2+1 pinion/wheel"):
        assert s.line(lab).amplitude < 1e-9 * E_RUNOUT
    for lab in ("1", "2", "3"):
        assert s.line(lab).amplitude == pytest.approx(s0.line(lab).amplitude, rel=1e-9)


def test_runout_moves_the_coast_flanks_and_closes_the_backlash_as_a_shorter_centre_distance():
    """A 10 um pinion runout acts on the coast flanks too (the coast line of action is the drive one mirrored about
    the line of centres).  Under the reversed torque the coast flanks carry, and the static coast approach is the
    ideal one less e sin(alpha_c) with the offset pointing at the wheel (tooth 0's passage) and plus e cos(alpha_c) a
    quarter turn later (the offset along the pinion's rotation opens the coast flanks by what it closes the drive
    ones), 1e-6.  Under the drive torque, pointing at the wheel it is a centre distance shorter by e: the backlash
    left along the coast line of action shrinks by e sin(alpha_w + alpha_c) / cos(alpha_w) (the drive flanks close
    by e sin alpha_w, the coast flanks by e sin alpha_c; for symmetric teeth the textbook j_n = 2 Delta_a sin
    alpha_w; here 25 / 20 deg: 7.80 um).  The kernel at rest on the reversed torque stays at the static equilibrium
    (its coast lookup is the numpy twin's)."""
    model, _ = _spur()
    mg = mesh_geometry(model, model.meshes[0].name)
    aw, ac = mg.operating_pressure_angle_rad, mg.operating_pressure_angle_coast_rad
    sy, sy0 = _with_errors(pinion=GearErrors(runout_m=E_RUNOUT, runout_phase_rad=0.0)), _with_errors()
    assert sy.meshes[0].coast_error is not None and sy0.meshes[0].coast_error is None
    c0 = float(sy.meshes[0].tooth_passage["pinion"])
    rev, rev0 = (s.with_changes(torque_Nm=-s.torque_Nm) for s in (sy, sy0))
    for dc, shift in ((0.0, -E_RUNOUT * math.sin(ac)), (Z / 4, E_RUNOUT * math.cos(ac))):
        e, e0 = (static_equilibrium(s, c0 + dc, s.fext_speed()) for s in (rev, rev0))
        assert e.coast_forces_N[0] == pytest.approx(e0.coast_forces_N[0], rel=1e-9)
        assert e.coast_approach_m[0] - e0.coast_approach_m[0] == pytest.approx(shift, rel=1e-6)
    d, d0 = (static_equilibrium(s, c0) for s in (sy, sy0))
    left, left0 = (x.coast_approach_m[0] - s.coast_errors_m(np.array([c0]))[0] for x, s in ((d, sy), (d0, sy0)))
    assert left - left0 == pytest.approx(E_RUNOUT * math.sin(aw + ac) / math.cos(aw), rel=1e-6)
    # the compiled loop at rest on the reversed torque: its coast lookup holds the static equilibrium
    e = static_equilibrium(rev, c0, rev.fext_speed())
    s = np.concatenate([e.q, np.zeros(rev.n)])
    rev.integrate(s, np.array([c0 % 1.0, math.floor(c0), 0.0]), 400, 2e-6, rev.fext_speed())
    assert np.max(np.abs(s[:rev.n] - e.q)) < 1e-9 * np.max(np.abs(e.q))


def test_a_displaced_tooth_moves_its_coast_flank_the_other_way():
    """One pinion tooth (tooth 5) displaced 5 um late, both flanks alike: under the drive torque the static TE rises
    by F r_b / r where that tooth carries alone (F = 5 um x 27/28 once the mean is removed); under the reversed
    torque its coast flank, on the back of the tooth, meets its partner that much earlier: the static coast
    approach falls by F r_bc / r where it carries alone (coast base radius r_bc: the 20 deg side), half a cycle
    after the drive zone (the coast side's pairing, statics/coast.py); elsewhere the other teeth's -5/28 um shows
    with the opposite sign on each side.  1e-4."""
    model, _ = _spur()
    d = 5e-6
    f = [0.0] * Z
    f[5], f[6] = d, -d
    sy, sy0 = _with_errors(pinion=GearErrors(single_pitch_deviations_m=tuple(f))), _with_errors()
    c = sy.meshes[0]
    assert c.coast_error is not None
    r = 0.5 * model.gears[0].module_m * model.gears[0].teeth
    rb, rbc = float(c.base_radius_m[0]), float(c.coast_table.base_radius_m[0])
    tp = float(c.tooth_passage["pinion"])
    rev, rev0 = (s.with_changes(torque_Nm=-s.torque_Nm) for s in (sy, sy0))
    cs = tp + np.arange(0.0, 10.0, 0.25)
    coast = np.array([static_equilibrium(rev, x, rev.fext_speed()).coast_approach_m[0]
                      - static_equilibrium(rev0, x, rev0.fext_speed()).coast_approach_m[0] for x in cs])
    drive = np.array([static_equilibrium(sy, x).mesh_deflections_m[0] - static_equilibrium(sy0, x).mesh_deflections_m[0]
                      for x in cs])
    assert drive.max() == pytest.approx(d * 27 / 28 * rb / r, rel=1e-3)
    assert coast.min() == pytest.approx(-d * 27 / 28 * rbc / r, rel=1e-4)
    assert np.median(coast) == pytest.approx(d / 28 * rbc / r, rel=1e-4)
    assert np.median(drive) == pytest.approx(-d / 28 * rb / r, rel=1e-3)
    lone_c, lone_d = cs[coast < -0.9 * d * rbc / r] - tp, cs[drive > 0.9 * d * rb / r] - tp
    assert lone_d.min() >= 4.5 and lone_d.max() <= 5.5 and lone_c.min() >= 5.0 and lone_c.max() <= 6.0


def test_runout_mesh_force_sidebands_follow_the_stiffness_variation():
    """Imposed kinematics (gear inertias x 1e8: the gears turn at constant speed) with a 10 um pinion runout:
    the mesh force is F(tau, x - e(t)) ~ F(tau, x_bar) - k(tau) e(t), so the runout puts k_0 e at shaft order 1 and
    K_h e / 2 at each sideband h +- 1 (K_h the h-th mesh harmonic of the stiffness k(tau), here the table's secant
    stiffness over x_bar +- e).  Kernel against the closed form within 5 % (measured: shaft line +0.06 %, 1 +- 1
    +0.04 / +0.10 %, 2 +- 1 +1.7 / +1.8 %)."""
    from scipy.optimize import brentq
    sy = _with_errors(pinion=GearErrors(runout_m=E_RUNOUT))
    sy = sy.with_changes(mass=sy.M * 1e8, modal_damping_ratio=0.5)
    _, sp = system_spectra(sy, 200.0, "force", samples_per_cycle=64, settle_cycles=2000, sideband_orders=1)
    s = sp["m12"]
    tau = np.arange(256) / 256
    f0 = sy.meshes[0].nominal_force_N
    xbar = brentq(lambda x: np.mean(sy.mesh_force(0, tau, np.full(tau.size, x))) - f0, 0.0, 2e-4)
    k = (sy.mesh_force(0, tau, np.full(tau.size, xbar + E_RUNOUT))
         - sy.mesh_force(0, tau, np.full(tau.size, xbar - E_RUNOUT))) / (2 * E_RUNOUT)
    K = np.abs(np.fft.rfft(k)) / tau.size
    assert s.line("1 x pinion/wheel").amplitude == pytest.approx(K[0] * E_RUNOUT, rel=0.05)
    for h in (1, 2):
        for side in "-+":
            assert s.line(f"{h}{side}1 pinion/wheel").amplitude == pytest.approx(K[h] * E_RUNOUT, rel=0.05)


@pytest.mark.parametrize("d, rtol", [(0.5e-6, 3e-3), (5e-6, 0.05)])
def test_single_pitch_error_spectrum_is_its_fourier_series(d, rtol):
    """One displaced pinion tooth (f_p = +d before it, -d after it): a once-per-revolution pulse
    e(c) = sum_j E_j g(c - passage - j) with E_j = (r_b / r) F_j (a late driving tooth opens the mesh) and g the
    stiffness share of a tooth pair over
    its pair phase (first order in the error); its line at shaft order k is 2 |E^(k) G(k / z)| / z (E^ the DFT of
    the tooth errors, G the Fourier transform of g) with phase arg(E^(k) G(k/z)) - 2 pi k passage / z.  The static
    TE and the kernel's DTE at f_m = 100 Hz (quasi-static: 1/28 of the resonance) against it, shaft orders 1-10:
    within 0.3 % for d = 0.5 um (measured 0.08 %; the DTE 0.95 %, tolerance 1 %), within 5 % for d = 5 um (measured
    0.63 %, the DTE 4.3 %: the pairs' own approaches make the profile nonlinear in the error); the pulse sits where
    the tooth passes (its pair phases)."""
    model, _ = _spur()
    f = np.zeros(Z)
    j0 = 5
    f[j0], f[j0 + 1] = d, -d
    sy = _with_errors(pinion=GearErrors(single_pitch_deviations_m=tuple(f)))
    c = sy.meshes[0]
    tp = c.tooth_passage["pinion"]
    samples, L, npc, nd = c.error                      # a profile over (position, approach)
    assert nd == c.table.n_deflections
    pos = np.arange(L * npc) / npc
    x_s = float(np.mean(c.table.static_deflection(pos[:npc], c.nominal_force_N)))
    e_s = sy.mesh_errors_m(pos[:, None], np.full((pos.size, 1), x_s))[:, 0]
    peak = pos[np.argmax(np.abs(e_s - np.median(e_s)))]
    assert L == Z and -2 <= peak - tp - j0 < 3
    E = (c.base_radius_m[0] / (0.5 * model.gears[0].module_m * Z)) * cumulative_pitch_deviations_m(f)
    G = share_transform(c.table, c.nominal_force_N)

    def closed(k):
        return np.sum(E * np.exp(-2j * np.pi * k * np.arange(Z) / Z)) * G(k / Z) * np.exp(-2j * np.pi * k * tp / Z) / Z

    for q, fm, settle in (("ste", 100.0, 0), ("dte", 100.0, 200)):
        _, sp = system_spectra(sy, fm, q, samples_per_cycle=32, settle_cycles=settle, sideband_orders=10)
        s = sp["m12"]
        for k in range(1, 11):
            ln = s.line(f"{k} x pinion/wheel")
            want = closed(k)
            # the DTE of a 0.5 um error carries the decaying transient of the mesh harmonics: 1 % there
            assert ln.amplitude == pytest.approx(2 * abs(want), rel=max(rtol, 0.01) if q == "dte" else rtol), (q, k)
            if q == "ste":
                assert math.remainder(ln.phase_rad - np.angle(want), 2 * math.pi) == pytest.approx(0, abs=rtol)


def test_profile_over_the_approach_is_the_pairs_own_solve_at_every_load():
    """One pinion tooth displaced 5 um: the static approach the kernel's rule gives (the table's force at
    x - e(c, x) equal to F) against each tooth pair at its own approach (sum_o P_o(tau, x - e_o) = F, the table's
    tooth loads), both less their error-free values, at 0.5, 1 and 1.5 x the nominal force over the tooth's pass:
    RMS within 2 % of the pulse, largest difference within 5 % (measured 0.3-0.6 % / 0.9-2.2 %,
    examples/gear_errors_linearisation.py).  A profile built at the nominal force alone missed by 20 % RMS at 0.5
    and 1.5 x."""
    from scipy.optimize import brentq
    model, _ = _spur()
    f = np.zeros(Z)
    f[5], f[6] = 5e-6, -5e-6
    sy = _with_errors(pinion=GearErrors(single_pitch_deviations_m=tuple(f)))
    c = sy.meshes[0]
    tab, fn, tp = c.table, c.nominal_force_N, c.tooth_passage["pinion"]
    E = (c.base_radius_m[0] / (0.5 * model.gears[0].module_m * Z)) * cumulative_pitch_deviations_m(f)
    offs = [int(o) for o in tab.tooth_offsets]
    for fac in (0.5, 1.0, 1.5):
        ours, pairs = [], []
        for cc in np.arange(3 * 16) / 16 + 3.0:
            n, tau = int(cc), cc - int(cc)
            eo = [E[(n - tp + o) % Z] for o in offs]

            def p(x, ee):
                return sum(float(tab.tooth_load(tau, x - e, o)) for o, e in zip(offs, ee)) - fn * fac

            def k(x, err):
                de = sy.mesh_errors_m(np.array([[cc]]), np.array([[x]]))[0, 0] if err else 0.0
                return float(sy.mesh_force(0, tau, x - de)) - fn * fac

            pairs.append(brentq(p, -5e-5, 2e-4, args=(eo,), xtol=1e-14)
                         - brentq(p, -5e-5, 2e-4, args=([0.0] * len(offs),), xtol=1e-14))
            ours.append(brentq(k, -5e-5, 2e-4, args=(True,), xtol=1e-14) - brentq(k, -5e-5, 2e-4, args=(False,), xtol=1e-14))
        ours, pairs = np.array(ours), np.array(pairs)
        span = np.ptp(pairs)
        assert span > 4e-6
        assert np.sqrt(np.mean((ours - pairs) ** 2)) < 0.02 * span and np.max(np.abs(ours - pairs)) < 0.05 * span, fac


def test_spectrum_command_on_a_model_with_runout(tmp_path, capsys):
    """A copy of the model folder with [gears.errors] uses the perfect gears' tables (the values hash leaves the
    errors out): `hacgear spectrum --quantity ste --json` reports the 10 um runout at shaft order 1."""
    import json

    from hacgear_core.cli import main
    src = resolve_model_path("spur_28t_asym").parent
    (tmp_path / "tables.h5").symlink_to(src / "tables.h5")
    (tmp_path / "model.toml").write_text(_model_text("  runout_um = 10.0"))
    assert main(["spectrum", str(tmp_path), "--fm", "500", "--quantity", "ste", "--steps-per-cycle", "16",
                 "--sidebands", "1", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    lines = {ln["label"]: ln["amplitude"] for ln in rep["channels"]["m12"]["lines"]}
    assert rep["record_cycles"] == Z and lines["1 x pinion/wheel"] == pytest.approx(E_RUNOUT, rel=1e-6)


@cache
def _idler():
    from hacgear_core.tables import load_system_tables
    p = resolve_model_path("idler_28_33_39")
    return load_model(p), load_system_tables(p)


def test_idler_chain_hunting_periods():
    """Idler chain 28-33-39: a runout on the idler gives both meshes a 33-cycle profile (the idler is the driven gear
    of one mesh and the driving gear of the other) and a steady state of period 33; errors on the outer gears give
    lcm(28, 39) = 1092 cycles."""
    from hacgear_core.dynamics.steady import steady_state
    model, tabs = _idler()
    g = list(model.gears)
    sy = build_system(replace(model, gears=(g[0], replace(g[1], errors=GearErrors(runout_m=E_RUNOUT)), g[2])), tabs)
    assert [c.error[1] for c in sy.meshes] == [33, 33] and sy.period_cycles == 33
    r = steady_state(sy, 800.0)
    assert r.converged and r.period_cycles == 33
    ge = GearErrors(runout_m=2e-6)
    sy = build_system(replace(model, gears=(replace(g[0], errors=ge), g[1], replace(g[2], errors=ge))), tabs)
    assert [c.error[1] for c in sy.meshes] == [28, 39] and sy.period_cycles == 28 * 39


@cache
def _helical():
    from hacgear_core.tables import load_system_tables
    p = resolve_model_path("helical_28_33")
    return load_model(p), load_system_tables(p)


def _helical_runout():
    model, tabs = _helical()
    g = model.gears
    return model, build_system(replace(model, gears=(replace(g[0], errors=GearErrors(runout_m=E_RUNOUT)),)
                                       + tuple(g[1:])), tabs)


def test_helical_runout_moves_the_static_approach_along_the_normal():
    """helical_28_33 (beta 15 deg) with a 10 um pinion runout: the mesh deflection is along the flank normal, so the
    runout's transverse line-of-action component enters times cos(beta_b); the shaft springs (5e4 N m/rad on both
    gears) take their share: the static approach changes by e_n k / (k + k_sh), k the mean mesh stiffness, k_sh =
    1 / sum (R_i^2 / k_s,i) the shafts' stiffness along the mesh (R_i the rotations' mesh arms).  At 8 positions over
    the revolution within 1 % of the runout (measured 0.42 %; k / (k + k_sh) = 0.966)."""
    from hacgear_core.dynamics.equilibrium import static_equilibrium
    model, sy = _helical_runout()
    base = build_system(*_helical())
    g = model.gears[0]
    cos_bb = math.cos(math.atan(math.tan(abs(g.helix_angle_rad)) * math.cos(g.flanks["drive"].pressure_angle_rad)))
    assert sy.meshes[0].error[0].max() == pytest.approx(E_RUNOUT * cos_bb, rel=1e-5)   # the largest sample
    assert sy.period_cycles == Z and "tooth errors" in sy.kernel_label
    arms = [sy.V[0][sy.gears[n].rotation] for n in ("pinion", "wheel")]
    k_sh = 1.0 / sum(a * a / 5e4 for a in arms)
    k = float(sy.mesh_stiffness_N_per_m[0])
    for c in np.arange(8) * Z / 8:
        dx = static_equilibrium(sy, c).mesh_deflections_m[0] - static_equilibrium(base, c).mesh_deflections_m[0]
        e_n = float(sy.mesh_errors_m(np.array([[c]]))[0, 0])
        assert dx == pytest.approx(e_n * k / (k + k_sh), abs=0.01 * E_RUNOUT)


@pytest.mark.slow
def test_helical_runout_through_the_kernel():
    """The same through the helical error loop (_twist_s_e) at 500 Hz: the DTE's shaft-order-1 line within 3 % of
    the static TE's (measured 9.255 against 9.389 um, -1.4 %: 500 Hz is not quasi-static for the 12-DOF model)."""
    _, sy = _helical_runout()
    _, st = system_spectra(sy, 500.0, "ste", samples_per_cycle=8)
    _, dy = system_spectra(sy, 500.0, "dte", samples_per_cycle=32, settle_cycles=200)
    a_s = st["m12"].line("1 x pinion").amplitude
    assert dy["m12"].line("1 x pinion").amplitude == pytest.approx(a_s, rel=0.03)
