"""Manufacturing errors on planetary sets (planetary_65_55_175: sun 65, planets 55, ring 175 teeth, 3 equally
spaced, sequentially phased planets) and what a transducer fixed on the housing sees.

Errors: each gear instance of the carrier-frame train tracked by its tooth passages (the sun's tooth at planet i's
mesh z_s psi_i / 2 pi teeth on, a planet's ring-mesh tooth half a revolution from its sun-mesh tooth); zero errors
leave the system as it was; the hunting periods; a sun runout absorbed by a floating sun (equal load sharing, the
sun following the offset) and shared out by a rigidly supported one as the closed form of the planet branches'
stiffnesses says.  Transducer: the windowed sum of the ring-planet forces holds the sidebands m f_m + k f_c the
planet-sum factor allows (McFadden & Smith's rule, :mod:`hacgear_core.spectra.transducer`), and a pin error fills
the others."""
from __future__ import annotations

import math
from dataclasses import replace
from functools import cache

import numpy as np
import pytest

from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.geometry.planetary import planetary_geometry
from hacgear_core.errors import ModelError
from hacgear_core.kinds import build_system, load_model, parse_model
from hacgear_core.kinds.planetary import planetary_error_inputs
from hacgear_core.model import GearErrors, resolve_model_path
from hacgear_core.spectra.transducer import (carrier_order_amplitudes, fixed_transducer_signal, planet_sum_factor,
                                             transducer_window)

ZS, ZP, ZR, N = 65, 55, 175, 3


@cache
def _planetary():
    from hacgear_core.tables import load_system_tables
    p = resolve_model_path("planetary_65_55_175")
    return load_model(p), load_system_tables(p)


def _model(errors=None, kt=None, carrier_kt=None):
    """planetary_65_55_175 with ``errors`` {gear: GearErrors} and translational support stiffnesses ``kt``
    {gear: N/m}, the carrier's ``carrier_kt``."""
    model, _ = _planetary()
    errors, kt = errors or {}, kt or {}
    gears = tuple(replace(g, errors=errors.get(g.name), support=replace(
        g.support, translational_stiffness_N_per_m=kt.get(g.name, g.support.translational_stiffness_N_per_m)))
        for g in model.gears)
    pl = model.planetary
    if carrier_kt is not None:
        pl = replace(pl, carrier_support=replace(pl.carrier_support, translational_stiffness_N_per_m=carrier_kt))
    return replace(model, gears=gears, planetary=pl)


def _system(errors=None, kt=None, carrier_kt=None, **options):
    return build_system(_model(errors, kt, carrier_kt), _planetary()[1], **options)


def test_zero_errors_leave_the_planetary_system():
    """Empty [gears.errors] on every gear: no profile, the error-free kernel, the same fingerprint and period."""
    ref = _system()
    sy = _system({"sun": GearErrors(), "planet": GearErrors(runout_m=0.0), "ring": GearErrors()})
    assert not sy.has_errors and all(c.error is None for c in sy.meshes)
    assert sy.kernel is ref.kernel and sy.fingerprint() == ref.fingerprint() and sy.period_cycles == 1


def test_tooth_tracking_of_every_gear_instance():
    """Runout passages: the sun's and ring's are the train's integer passages (z psi_i / 2 pi teeth apart, less the
    mesh phase difference, a whole number for an assembled set); a planet's ring-mesh passage is its sun-mesh
    passage plus the mesh phase difference plus half a revolution (z_p / 2), fractional, within half a cycle of
    the integer passage the pitch errors use.  Every planet carries the planet gear's errors."""
    model, _ = _planetary()
    geo = planetary_geometry(model)
    inp = planetary_error_inputs(_model({"planet": GearErrors(runout_m=1e-6)}), N)
    rp = inp["runout_passage"]
    assert set(inp["gears"]) == {"sun", "ring", "planet_1", "planet_2", "planet_3"}
    assert all(inp["gears"][f"planet_{i}"][0].runout_m == 1e-6 for i in (1, 2, 3))
    assert inp["internal_gears"] == ("ring",)
    for i in (1, 2, 3):
        sm, rm = geo.meshes[f"sun_planet_{i}"], geo.meshes[f"ring_planet_{i}"]
        psi = geo.positions_rad[i - 1]
        # sun: counter-clockwise relative to the carrier; ring: clockwise
        want_s = (rp["sun_planet_1"]["sun"] + sm.phase - geo.meshes["sun_planet_1"].phase + ZS * psi / (2 * math.pi))
        assert math.remainder(rp[sm.name]["sun"] - want_s, ZS) == pytest.approx(0, abs=1e-9)
        want_r = (rp["ring_planet_1"]["ring"] + rm.phase - geo.meshes["ring_planet_1"].phase - ZR * psi / (2 * math.pi))
        assert math.remainder(rp[rm.name]["ring"] - want_r, ZR) == pytest.approx(0, abs=1e-9)
        assert rp[sm.name]["sun"] == sm.tooth_passage["sun"] and rp[rm.name]["ring"] == rm.tooth_passage["ring"]
        p = f"planet_{i}"
        half = rp[rm.name][p] - rp[sm.name][p] - (rm.phase - sm.phase)
        assert math.remainder(half - ZP / 2, ZP) == pytest.approx(0, abs=1e-9)
        assert abs(rp[rm.name][p] - rm.tooth_passage[p]) < 0.5


@pytest.mark.parametrize("errors, period", [({"sun": GearErrors(runout_m=5e-6)}, ZS),
                                            ({"planet": GearErrors(iso1328_grade=6, seed=2)}, ZP),
                                            ({"ring": GearErrors(runout_m=5e-6)}, ZR),
                                            ({"sun": GearErrors(runout_m=5e-6), "ring": GearErrors(runout_m=5e-6)},
                                             math.lcm(ZS, ZR))])
def test_planetary_hunting_periods(errors, period):
    """In the carrier frame a sun error repeats after a sun revolution relative to the carrier (z_s mesh cycles), a
    planet's after a planet revolution (z_p), a fixed ring's after a carrier revolution (z_r); together after the
    lcm.  Only the meshes of the gears with errors carry profiles."""
    sy = _system(errors)
    assert sy.has_errors and sy.period_cycles == period
    for c in sy.meshes:
        assert (c.error is not None) == bool({c.gear_a.split("_")[0], c.gear_b.split("_")[0]} & set(errors))


def test_floating_sun_absorbs_a_sun_runout():
    """A floating sun (translational stiffness 0) with a 10 um runout: the sun's translation takes it up, the
    three planets share the load exactly as without the error (to 1e-9 of the force), at any position.  The sun's
    teeth turn about a centre offset by e in the direction Phi = 2 pi c / z_s + phase (c the sun's mesh position at
    planet 1, whose pitch point lies on the carrier frame's x axis): the sun's body takes it up by translating by
    -e in that direction, which puts its teeth where a perfect sun's are."""
    e, phase = 10e-6, 0.5
    s0 = _system(kt={"sun": 0.0})
    s1 = _system({"sun": GearErrors(runout_m=e, runout_phase_rad=phase)}, kt={"sun": 0.0})
    ix, iy = s0.dof_names.index("sun.x"), s0.dof_names.index("sun.y")
    for tau in (0.3, 7.6, 40.45):
        q0, q1 = static_equilibrium(s0, tau), static_equilibrium(s1, tau)
        assert np.allclose(q1.mesh_forces_N, q0.mesh_forces_N, rtol=1e-9, atol=0)
        phi = 2 * math.pi * tau / ZS + phase
        du = (q1.q[[ix, iy]] - q0.q[[ix, iy]]) / e
        assert du == pytest.approx([-math.cos(phi), -math.sin(phi)], abs=2e-3)


def test_floating_ring_absorbs_a_ring_runout_as_an_internal_gear():
    """A floating ring (translational stiffness 0, held in rotation) with a 10 um runout: the ring's translation
    takes it up (mesh forces within 1e-9 of the force without it) by translating by -e in its offset direction
    -(2 pi c_r / z_r + phase) (the ring turns clockwise relative to the carrier; c_r its mesh position at planet 1),
    as the sun does: the internal gear's line-of-action closing -e sin(alpha_w + beta) is the projection of that
    offset (an external gear's e sin(alpha_w - beta) would send the ring along the mirrored direction)."""
    e, phase = 10e-6, 0.5
    model, _ = _planetary()
    c1 = planetary_geometry(model).meshes["ring_planet_1"].phase
    s0 = _system(kt={"ring": 0.0})
    s1 = _system({"ring": GearErrors(runout_m=e, runout_phase_rad=phase)}, kt={"ring": 0.0})
    ix, iy = s0.dof_names.index("ring.x"), s0.dof_names.index("ring.y")
    for tau in (0.3, 7.6, 40.45):
        q0, q1 = static_equilibrium(s0, tau), static_equilibrium(s1, tau)
        assert np.allclose(q1.mesh_forces_N, q0.mesh_forces_N, rtol=1e-9, atol=0)
        phi = -(2 * math.pi * (tau + c1) / ZR + phase)
        du = (q1.q[[ix, iy]] - q0.q[[ix, iy]]) / e
        assert du == pytest.approx([-math.cos(phi), -math.sin(phi)], abs=2e-3)


def _branch_load_changes(s0, s1, tau, both_meshes=False):
    """(got, want, branch openings) at reference position ``tau``: planet i's sun-mesh load change from ``s0`` to
    ``s1`` (rigid sun and carrier) and the closed form dF_i = -k_i (R_i - R_bar), k_i the branch stiffness (sun and
    ring mesh tangent stiffnesses in series, at s0's static state), R_i the branch's opening in ``s1`` at its sun
    mesh (``both_meshes``: sun plus ring mesh), R_bar = sum k_i R_i / sum k_i."""
    h = 0.5e-6
    q0, q1 = static_equilibrium(s0, tau), static_equilibrium(s1, tau)
    pos = s0.unwrapped_positions(tau) + s0.phase + s0.W @ q0.q
    x = q0.mesh_deflections_m
    k = np.array([(s0.mesh_force(j, [pos[j] % 1], [x[j] + h]) - s0.mesh_force(j, [pos[j] % 1], [x[j] - h]))[0]
                  / (2 * h) for j in range(2 * N)])
    kb = 1.0 / (1.0 / k[0::2] + 1.0 / k[1::2])
    r = s1.mesh_errors_m(pos[None, :])[0]
    branch = r[0::2] + (r[1::2] if both_meshes else 0.0)
    want = -kb * (branch - np.sum(kb * branch) / np.sum(kb))
    return (q1.mesh_forces_N - q0.mesh_forces_N)[0::2], want, branch, q1


def test_rigid_sun_runout_loads_the_planets_unequally_as_the_closed_form():
    """A rigidly supported sun (and carrier; planet bearings 1e12 N/m) with a 1 um runout: planet i's load changes
    by dF_i = -k_i (R_i - R_bar), R_i the runout's line-of-action component at its sun mesh, k_i its branch
    stiffness (sun mesh and ring mesh in series through the planet's rotation, each the table's tangent stiffness
    at its own position), R_bar = sum k_i R_i / sum k_i (the sun's rotation keeps the total).  Within 1 % at
    positions away from a change of the number of tooth pairs (measured: <= 0.4 % of the largest change); the
    pattern turns with the sun relative to the carrier (period z_s mesh cycles), planet to planet shifted by the
    planet angle."""
    kt = {"sun": math.inf, "planet": 1e12}
    s0 = _system(kt=kt, carrier_kt=math.inf)
    s1 = _system({"sun": GearErrors(runout_m=1e-6, runout_phase_rad=0.5)}, kt=kt, carrier_kt=math.inf)
    for tau in (0.3, 7.6, 30.2, 52.2):
        got, want, _, q1 = _branch_load_changes(s0, s1, tau)
        assert np.max(np.abs(want)) > 20.0                      # N: a load change well above the solver's
        assert got == pytest.approx(want, rel=0.01, abs=0.01 * np.max(np.abs(want)))
        assert np.allclose(q1.mesh_forces_N[0::2], q1.mesh_forces_N[1::2], rtol=1e-9)   # each planet's two meshes


def test_sun_runout_reaches_each_planet_a_planet_angle_later():
    """Dynamics (steady state at f_m = 1000 Hz, 400 settling cycles, one sun revolution relative to the carrier =
    65 mesh cycles at 48 samples per cycle) with a 20 um sun runout: every mesh force of planet i is planet 1's
    delayed by the z_s psi_i / 2 pi = 65 (i - 1) / 3 mesh cycles the sun takes to turn its runout from planet 1 to
    planet i (within 1e-4 of the force's span; measured 5.6e-5), and the modulation at the sun's order 1 / 65 has
    the same size at every planet (363.3 N)."""
    from hacgear_core.spectra.records import steady_record
    sy = _system({"sun": GearErrors(runout_m=20e-6, runout_phase_rad=0.5)})
    spc = 48
    rec = steady_record(sy, 1000.0, "force", ZS, samples_per_cycle=spc, settle_cycles=400)
    assert rec.periodicity_error < 1e-4
    for kind in ("sun_planet", "ring_planet"):
        f = [rec.channels[f"{kind}_{i}"] for i in (1, 2, 3)]
        span = np.ptp(f[0])
        for i in (2, 3):
            assert np.max(np.abs(f[i - 1] - np.roll(f[0], (i - 1) * ZS * spc // N))) < 1e-4 * span
            assert np.max(np.abs(f[i - 1] - np.roll(f[0], -(i - 1) * ZS * spc // N))) > 0.1 * span
        sun_order = [np.abs(np.fft.rfft(x))[1] * 2 / x.size for x in f]
        assert sun_order == pytest.approx([sun_order[0]] * N, rel=1e-6) and sun_order[0] > 100.0


def test_transducer_window_and_planet_sum_rule_on_synthetic_forces():
    """Identical forces, each planet at its ring mesh's phase: the windowed sum over one carrier revolution holds
    exactly the carrier orders m z_r + k whose planet-sum factor |P(m, k)| is not 0 (here: m z_r + k a multiple
    of 3); every other order < 1e-10 of the largest."""
    model, _ = _planetary()
    geo = planetary_geometry(model)
    psi = np.array(geo.positions_rad)
    ph = np.array([geo.meshes[f"ring_planet_{i}"].phase for i in (1, 2, 3)])
    assert transducer_window([0.0, math.pi / 3, math.pi], 2 * math.pi / 3) == pytest.approx([1.0, 0.5, 0.0])
    spc = 32
    c = np.arange(ZR * spc) / spc
    force = lambda u: 1000 + 80 * np.cos(2 * np.pi * u) + 30 * np.sin(4 * np.pi * u + 0.4)   # noqa: E731
    f = np.column_stack([force(c + p) for p in ph])
    a = carrier_order_amplitudes(fixed_transducer_signal(f, 2 * np.pi * c / ZR, psi), 1)
    big = a[ZR - 10:2 * ZR + 11].max()
    for m in (1, 2):
        for k in range(-8, 9):
            p = abs(planet_sum_factor(ph, psi, m, k))
            assert p == pytest.approx(1.0 if (m * ZR + k) % N == 0 else 0.0, abs=1e-12)
            if p < 0.5:
                assert a[m * ZR + k] < 1e-10 * big


@cache
def _transducer_orders(case: str, samples_per_cycle: int = 64):
    """Carrier-order amplitudes [N] of the fixed transducer's signal (window half width one planet spacing) over
    one carrier revolution (175 mesh cycles) of the steady state at mesh frequency 1000 Hz after 400 cycles."""
    from hacgear_core.spectra.records import steady_record
    model, _ = _planetary()
    geo = planetary_geometry(model)
    opts = {"pin_errors_m": {1: (0.0, 20e-6)}} if case == "pin" else {}
    sy = _system({"ring": GearErrors(runout_m=20e-6)} if case == "ring_runout" else None, **opts)
    r = sy.carrier_ratio / (2 * math.pi * sy.mesh_cycles_per_rad)           # carrier revolutions per mesh cycle
    assert r * ZR == pytest.approx(1.0, rel=1e-12)
    rec = steady_record(sy, 1000.0, "force", ZR, samples_per_cycle=samples_per_cycle, settle_cycles=400)
    f = np.column_stack([rec.channels[f"ring_planet_{i}"] for i in (1, 2, 3)])
    c = 400 + np.arange(1, f.shape[0] + 1) / samples_per_cycle
    s = fixed_transducer_signal(f, 2 * math.pi * r * c, np.array(geo.positions_rad))
    return carrier_order_amplitudes(s, 1)


def test_transducer_sideband_patterns_of_the_planetary_set():
    """Fixed transducer on planetary_65_55_175 (z_r = 175 = 1 mod 3: sequentially phased), docs/validation.md
    "Planetary sideband patterns".  Identical planets: the mesh harmonics m = 1, 2 are suppressed and only the
    sidebands k with 175 m + k a multiple of 3 are there (m = 1: k = -1, +2; m = 2: k = -2, +1), each other line
    within |k| <= 4 below 1 % of the largest.  A 20 um tangential pin error on planet 1 (unequal load sharing)
    fills them: the mesh frequency itself rises to the size of the dominant sideband.  A 20 um ring runout (fixed
    in the housing, seen by every planet at the same fixed-frame angle) keeps the rule."""
    allowed = {1: (-4, -1, 2), 2: (-2, 1, 4)}
    perfect, pin, ring = (_transducer_orders(c) for c in ("perfect", "pin", "ring_runout"))
    for a in (perfect, ring):
        for m in (1, 2):
            top = max(a[m * ZR + k] for k in allowed[m])
            for k in range(-4, 5):
                if k not in allowed[m]:
                    assert a[m * ZR + k] < 0.01 * top, (m, k)
    assert perfect[ZR - 1] > 2 * perfect[ZR + 2] > 0 and perfect[2 * ZR + 1] > 2 * perfect[2 * ZR - 2] > 0
    for m in (1, 2):
        top = max(pin[m * ZR + k] for k in allowed[m])
        assert pin[m * ZR] > 0.5 * top and pin[m * ZR] > 50 * perfect[m * ZR]
        assert pin[m * ZR + (1 if m == 1 else -1)] > 0.1 * top


def test_sun_runout_sidebands_turn_with_the_sun():
    """A 20 um sun runout in the fixed transducer's signal (13 carrier revolutions = lcm(65, 175) mesh cycles):
    planet i's ring force is planet 1's delayed by the z_s psi_i / 2 pi mesh cycles the sun takes to bring the
    runout from one planet to the next (the sun's tooth tracking), so the lines m f_m + l f_s + k f_c (f_s = f_m /
    z_s the sun's frequency relative to the carrier) add over the planets with exp(j 2 pi (i - 1) (k - m z_s -
    l) / N): present where k = m z_s + l (mod 3), each other line within |k| <= 4 below 2 % of the largest
    (measured: l = +1: k = 0 9.07 N, others <= 0.009 N; l = -1: k = +1 1.67 N, k = -2 0.60 N, others <= 0.010
    N), and the runout's lines at l = +-1 of the size of the mesh sidebands."""
    from hacgear_core.spectra.records import steady_record
    model, _ = _planetary()
    geo = planetary_geometry(model)
    sy = _system({"sun": GearErrors(runout_m=20e-6)})
    cyc, spc = math.lcm(ZS, ZR), 64
    rec = steady_record(sy, 1000.0, "force", cyc, samples_per_cycle=spc, settle_cycles=400)
    f = np.column_stack([rec.channels[f"ring_planet_{i}"] for i in (1, 2, 3)])
    c = 400 + np.arange(1, f.shape[0] + 1) / spc
    s = fixed_transducer_signal(f, 2 * math.pi * c / ZR, np.array(geo.positions_rad))
    amp = np.abs(np.fft.rfft(s)) * 2 / s.size                  # bin b: b / cyc per mesh cycle
    m = 1
    for ll in (-1, 1):
        a = {k: amp[int(round(cyc * (m + ll / ZS + k / ZR)))] for k in range(-4, 5)}
        on = [k for k in a if (k - m * ZS - ll) % N == 0]
        top = max(a[k] for k in on)
        assert top > 1.0                                       # N
        assert all(a[k] < 0.02 * top for k in a if k not in on), (ll, a)


def test_one_planet_with_its_own_runout_loads_the_planets_as_the_closed_form():
    """``[[planetary.planet_errors]]``: a 1 um runout on planet 2 alone (rigid sun and carrier, planet bearings 1e12
    N/m).  Only planet 2's two meshes get profiles, each equal to the one the planet gear's runout gives planet 2
    when every planet carries it; its branch (sun mesh, planet rotation, ring mesh in series) opens by R = R_s +
    R_r and the loads change by dF_i = -k_i (R_i - R_bar) (R_i = 0 on planets 1 and 3, k_i the branch stiffness,
    R_bar = sum k_i R_i / sum k_i), within 1 % of the largest change (measured <= 0.2 %) at positions away from a
    change of the number of tooth pairs; the period is the planet's 55 mesh cycles."""
    from hacgear_core.model import PlanetErrors
    kt = {"sun": math.inf, "planet": 1e12}
    ge = GearErrors(runout_m=1e-6, runout_phase_rad=0.5)
    base = _model(kt=kt, carrier_kt=math.inf)
    one = replace(base, planetary=replace(base.planetary, planet_errors=(PlanetErrors(2, ge),)))
    s0 = build_system(base, _planetary()[1])
    s1 = build_system(one, _planetary()[1])
    every = _system({"planet": ge}, kt=kt, carrier_kt=math.inf)
    assert [c.name for c in s1.meshes if c.error is not None] == ["sun_planet_2", "ring_planet_2"]
    assert s1.period_cycles == ZP
    for c in s1.meshes:
        if c.error is not None:
            ref = next(x for x in every.meshes if x.name == c.name)
            assert c.error[1:] == ref.error[1:] and np.array_equal(c.error[0], ref.error[0])
    for tau in (0.3, 7.6, 30.2, 52.2):
        got, want, branch, _ = _branch_load_changes(s0, s1, tau, both_meshes=True)
        assert branch[0] == branch[2] == 0.0 and abs(branch[1]) > 0.3e-6
        assert got == pytest.approx(want, rel=0.01, abs=0.01 * np.max(np.abs(want)))


def test_planet_errors_are_read_and_checked():
    """``[[planetary.planet_errors]]`` takes a planet number and the keys of ``[gears.errors]``; a planet beyond
    planet_count, a planet given twice and a pitch list of the wrong length are refused naming the key."""
    text = resolve_model_path("planetary_65_55_175").read_text()
    m = parse_model(text + "\n[[planetary.planet_errors]]\nplanet = 3\nrunout_um = 5.0\nrunout_phase_deg = 90.0\n",
                    file="p.toml")
    (pe,) = m.planetary.planet_errors
    assert pe.planet == 3 and pe.errors.runout_m == pytest.approx(5e-6) and pe.errors.runout_phase_rad == \
        pytest.approx(math.pi / 2)
    for extra, words in (("planet = 4\nrunout_um = 1.0\n", "planet_errors.planet"),
                         ("planet = 1\nrunout_um = 1.0\n[[planetary.planet_errors]]\nplanet = 1\n", "given twice"),
                         ("planet = 1\nrunout_um = 2000.0\n", "runout_um"),
                         ("planet = 1\nwobble_um = 1.0\n", "wobble_um")):
        with pytest.raises(ModelError) as exc:
            parse_model(text + "\n[[planetary.planet_errors]]\n" + extra, file="p.toml")
        assert words in str(exc.value), (words, str(exc.value))
    bad = parse_model(text + "\n[[planetary.planet_errors]]\nplanet = 1\nsingle_pitch_deviations_um = [1.0, -1.0]\n",
                      file="p.toml")
    with pytest.raises(ModelError, match=r"single_pitch_deviations_um \[um\] needs one value per tooth"):
        build_system(bad, _planetary()[1])
