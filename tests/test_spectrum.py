"""Order spectra (hacgear_core.spectra.spectrum, .records; `hacgear spectrum`): exact amplitudes of a coherent
record, the flat-top window's documented bound on a non-coherent one, sidebands and shaft orders marked per shaft,
the order ratios and common periods of the shipped kinds, and a simulated perfect-gear DTE at mesh harmonics only."""
from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest

from hacgear_core.cli import main
from hacgear_core.cli.inputs import load_inputs
from hacgear_core.errors import ModelError
from hacgear_core.spectra.records import record_cycles_for, steady_record
from hacgear_core.spectra.spectrum import (FLATTOP_SCALLOPING, FLATTOP_SIDELOBE, OrderBasis, order_basis,
                                           order_spectrum)

PAIR = OrderBasis({"pinion": Fraction(1, 28), "wheel": Fraction(1, 28)})


def _signal(c, comps, mean=0.0):
    """mean + sum A cos(2 pi o c + phi) at mesh positions ``c`` [cycles] for comps [(o, A, phi)]."""
    return mean + sum(a * np.cos(2 * np.pi * o * c + p) for o, a, p in comps)


def test_coherent_record_gives_exact_amplitudes_and_marks_the_sidebands():
    """Mesh orders 1 and 2 and sidebands at 1 +- 1/28 (one shaft order of a 28:28 pair) over two common periods
    (56 mesh cycles, 64 samples each): every amplitude and phase within 1e-9, each line marked with its family,
    the mean exact, Parseval's power fractions exact; an unmarked bin holds nothing."""
    spc = 64
    c = np.arange(56 * spc) / spc
    comps = [(1.0, 3.0, 0.3), (2.0, 0.5, -1.0), (1 + 1 / 28, 0.1, 0.7), (1 - 1 / 28, 0.07, -2.0)]
    sp = order_spectrum(_signal(c, comps, mean=1.5), spc, PAIR, harmonics=3, sideband_orders=2,
                        mesh_frequency_Hz=1000.0)
    assert sp.success and sp.coherent and sp.window == "rectangular" and sp.amplitude_error_bound == 0.0
    assert sp.samples_used == c.size and sp.cycles_used == 56 and sp.common_period_cycles == 28
    for label, (o, a, p), fam in (("1", comps[0], "mesh"), ("2", comps[1], "mesh"),
                                  ("1+1 pinion/wheel", comps[2], "sideband"),
                                  ("1-1 pinion/wheel", comps[3], "sideband")):
        ln = sp.line(label)
        assert ln.family == fam and ln.mesh_order == pytest.approx(o, rel=1e-15)
        assert abs(ln.amplitude - a) <= 1e-9 * a, (label, ln.amplitude, a)
        assert abs(ln.phase_rad - p) <= 1e-9
    assert sp.line("1+1 pinion/wheel").harmonic == 1 and sp.line("1-1 pinion/wheel").n == -1
    assert sp.line("1 x pinion/wheel").family == "shaft" and sp.line("1 x pinion/wheel").amplitude < 1e-12
    assert sp.line("3").amplitude < 1e-12 and sp.line("2+2 pinion/wheel").amplitude < 1e-12
    assert abs(sp.mean - 1.5) < 1e-12
    ac = sum(a * a / 2 for _, a, _ in comps)
    assert sp.mesh_harmonic_power_fraction == pytest.approx((9 / 2 + 0.25 / 2) / ac, rel=1e-12)
    assert sp.marked_power_fraction == pytest.approx(1.0, rel=1e-12)
    assert sp.frequency_Hz[sp.line("2").bin] == pytest.approx(2000.0, rel=1e-15)
    assert sp.shaft_order["pinion/wheel"][sp.line("1+1 pinion/wheel").bin] == pytest.approx(29.0, rel=1e-12)
    # the record starts anywhere: a longer record is cut to its last whole common periods
    sp2 = order_spectrum(_signal(np.arange(60 * spc + 7) / spc, comps), spc, PAIR)
    assert sp2.coherent and sp2.samples_used == 56 * spc
    assert abs(sp2.line("1-1 pinion/wheel").amplitude - 0.07) <= 1e-9 * 0.07


def test_non_coherent_record_stays_within_the_flattop_bound():
    """A record that is no whole number of common periods (and whose lines fall between bins) is windowed
    (flat-top) and each resolved line's amplitude is within the documented bound eps_s A + lam sum(others);
    the bound itself is the window's: 0.1 % < eps_s < 0.12 %, side lobe < 1e-4."""
    assert 0.001 < FLATTOP_SCALLOPING < 0.0012 and FLATTOP_SIDELOBE < 1e-4
    spc = 50.3
    n = 9001                      # 178.9 mesh cycles: neither whole mesh cycles nor common periods
    c = np.arange(n) / spc
    comps = [(1.0, 3.0, 0.3), (2.0, 0.5, -1.0), (1 + 3 / 28, 0.1, 0.7), (1 - 3 / 28, 0.07, -2.0), (3 / 28, 0.2, 1.0)]
    sp = order_spectrum(_signal(c, comps, mean=-0.4), spc, PAIR, harmonics=2, sideband_orders=3)
    assert sp.success and not sp.coherent and sp.window == "flattop" and "not coherent" in sp.message
    assert sp.amplitude_error_bound == FLATTOP_SCALLOPING and math.isnan(sp.mesh_harmonic_power_fraction)
    total = sum(a for _, a, _ in comps)
    worst = 0.0
    for label, (o, a, _) in zip(("1", "2", "1+3 pinion/wheel", "1-3 pinion/wheel", "3 x pinion/wheel"), comps):
        ln = sp.line(label)
        assert ln.resolved
        err = abs(ln.amplitude - a)
        assert err <= FLATTOP_SCALLOPING * a + FLATTOP_SIDELOBE * (total - a), (label, err)
        worst = max(worst, err / a)
    assert worst > 1e-5                           # the window's error is real, the bound is not idle
    assert sp.mean == pytest.approx(-0.4, abs=1e-3)
    # lines within the main lobe of another are not resolved: 1 +- 1/28 at 6 bins per shaft order? here 6.4 bins
    near = order_spectrum(_signal(c, comps), spc, PAIR, harmonics=1, sideband_orders=1)
    assert all(ln.resolved for ln in near.lines)
    short = order_spectrum(_signal(np.arange(2000) / spc, comps), spc, PAIR, harmonics=1, sideband_orders=1)
    assert not short.line("1+1 pinion/wheel").resolved          # 1.4 bins from harmonic 1
    forced = order_spectrum(_signal(np.arange(28 * 64) / 64, comps[:2]), 64, PAIR, window="flattop")
    assert not forced.coherent and "window='flattop' asked" in forced.message


def test_sidebands_and_shaft_orders_are_marked_per_shaft():
    """Three shafts of different ratios (the idler chain's 28, 33, 39 teeth): common period lcm = 12012 mesh
    cycles; a sideband at 2 - 1/33 and a once-per-revolution line of the 39-tooth gear land on their own labels."""
    b = OrderBasis({"gear1": Fraction(1, 28), "gear2": Fraction(1, 33), "gear3": Fraction(1, 39)})
    assert b.common_period_cycles() == 12012
    spc = 16
    c = np.arange(12012 * spc) / spc
    sp = order_spectrum(_signal(c, [(1.0, 1.0, 0.0), (2 - 1 / 33, 0.01, 0.2), (1 / 39, 0.02, 0.0)]), spc, b)
    assert sp.coherent
    ln = sp.line("2-1 gear2")
    assert ln.family == "sideband" and ln.shaft == "gear2" and abs(ln.amplitude - 0.01) < 1e-11
    assert sp.line("1 x gear3").family == "shaft" and abs(sp.line("1 x gear3").amplitude - 0.02) < 1e-11
    assert sp.line("2-1 gear1").amplitude < 1e-12
    # a ratio with no fraction: no common period, so the window
    odd = OrderBasis({"x": math.pi / 100})
    assert odd.common_period_cycles() is None
    assert not order_spectrum(np.cos(2 * np.pi * np.arange(640) / 64), 64, odd).coherent


def test_order_basis_of_the_shipped_kinds():
    """Shaft order ratios from the kinematics: 1/z for every gear (relative to the carrier in a planetary set,
    the carrier itself at its absolute speed, grouped with the fixed ring), and their common periods."""
    expect = {"spur_28t_asym": ({"pinion/wheel": 1 / 28}, 28),
              "idler_28_33_39": ({"gear1": 1 / 28, "gear2": 1 / 33, "gear3": 1 / 39}, 12012),
              "helical_28_33": ({"pinion": 1 / 28, "wheel": 1 / 33}, 924),
              "planetary_65_55_175": ({"carrier/ring": 1 / 175, "sun": 1 / 65,
                                       "planet_1/planet_2/planet_3": 1 / 55}, 25025)}
    for name, (groups, period) in expect.items():
        sy = load_inputs(name).system
        b = order_basis(sy)
        got = dict(b.groups)
        assert set(got) == set(groups), name
        for k, r in groups.items():
            assert got[k] == pytest.approx(r, rel=1e-12), (name, k)
        assert b.common_period_cycles() == period
        assert record_cycles_for(sy, 1, max_record_cycles=30000) == period
    with pytest.raises(ModelError, match="common period"):
        record_cycles_for(load_inputs("idler_28_33_39").system, 3, max_record_cycles=30000)


def test_bad_records_fail_with_a_message():
    assert not order_spectrum(np.ones(8), 4).success
    r = order_spectrum(np.r_[np.ones(40), np.nan], 4)
    assert not r.success and "non-finite" in r.message and r.amplitude.size == 0
    assert "shorter than one mesh cycle" in order_spectrum(np.ones(20), 64).message
    for bad in (dict(harmonics=0), dict(sideband_orders=-1), dict(window="hann")):
        with pytest.raises(ModelError):
            order_spectrum(np.ones(64), 16, **bad)
    with pytest.raises(ModelError, match="shaft order ratio"):
        OrderBasis({"a": -1.0})


def test_simulated_perfect_gear_dte_is_at_mesh_harmonics():
    """spur_28t_asym (perfect gears) at f_m = 2000 Hz: one common period (28 mesh cycles) of the steady DTE has
    more than 99.99 % of its AC power at mesh harmonics; its static TE (the same positions, no dynamics) is
    periodic per mesh cycle to the equilibrium solver's tolerance."""
    sy = load_inputs("spur_28t_asym").system
    b = order_basis(sy)
    rec = steady_record(sy, 2000.0, "dte", 28, samples_per_cycle=64, settle_cycles=400)
    assert rec.periodicity_error < 1e-3 and set(rec.channels) == {"m12"}
    sp = order_spectrum(rec.channels["m12"], rec.samples_per_cycle, b, mesh_frequency_Hz=2000.0)
    assert sp.coherent and sp.mesh_harmonic_power_fraction > 0.9999
    assert 1e-6 < sp.line("1").amplitude < 1e-4                   # micrometres of DTE at the mesh frequency
    ste = steady_record(sy, 2000.0, "ste", 28, samples_per_cycle=16)
    sps = order_spectrum(ste.channels["m12"], 16, b)
    assert 1 - sps.mesh_harmonic_power_fraction < 1e-12
    bf = steady_record(sy, 2000.0, "bearing_force", 1, samples_per_cycle=16, settle_cycles=10)
    assert set(bf.channels) == {"pinion.x", "pinion.y", "wheel.x", "wheel.y"}
    assert np.allclose(bf.channels["pinion.x"], -bf.channels["wheel.x"], rtol=1e-12, atol=0)
    with pytest.raises(ModelError, match="quantity"):
        steady_record(sy, 2000.0, "noise", 1)


def test_spectrum_command_json_and_figure(tmp_path, capsys):
    out = tmp_path / "s.png"
    assert main(["spectrum", "spur_28t_asym", "--fm", "1500", "--quantity", "force", "--settle-cycles", "100",
                 "--steps-per-cycle", "32", "--harmonics", "3", "--plot", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["quantity"] == "force" and rep["unit"] == "N" and rep["record_cycles"] == 28
    ch = rep["channels"]["m12"]
    assert ch["coherent"] and ch["mesh_harmonic_power_fraction"] > 0.999
    families = {ln["family"] for ln in ch["lines"]}
    assert families == {"mesh", "sideband", "shaft"}
    assert rep["shaft_order_ratios"]["pinion/wheel"] == pytest.approx(1 / 28)
    assert out.stat().st_size > 10_000
    assert main(["spectrum", "spur_28t_asym", "--fm", "1500", "--quantity", "root_strain", "--settle-cycles", "20",
                 "--steps-per-cycle", "16", "--record-cycles", "20"]) == 0
    text = capsys.readouterr().out
    assert "pinion/SG20" in text and "flat-top window" in text
    assert main(["spectrum", "spur_28t_asym", "--fm", "1500", "--periods", "0"]) == 2


def test_waterfall_tracks_the_orders_of_each_segment():
    """Segments of whole common periods: each row's order amplitudes are the segment's own (exact: an amplitude
    held constant over each segment and stepped between them is read back within 1e-12), at the mean mesh
    frequency of the segment."""
    from hacgear_core.spectra.waterfall import resonance_of_track, waterfall

    spc, seg = 32, 28
    amps = np.array([1.0, 2.0, 5.0, 3.0, 0.5])
    c = np.arange(amps.size * seg * spc) / spc
    a = np.repeat(amps, seg * spc)
    x = a * np.cos(2 * np.pi * c) + 0.1 * np.cos(2 * np.pi * 2 * c + 0.3)
    fm = 1000.0 + 10.0 * np.floor(c)
    wf = waterfall(x, spc, fm, PAIR, segment_cycles=seg, hop_cycles=seg, harmonics=2)
    assert wf.coherent and wf.amplitude.shape[0] == amps.size
    assert np.max(np.abs(wf.tracks["1"] - amps)) < 1e-12 and np.max(np.abs(wf.tracks["2"] - 0.1)) < 1e-12
    assert wf.mesh_frequency_Hz[0] == pytest.approx(1000 + 10 * 13.5)
    assert resonance_of_track(wf, "1") == (pytest.approx(wf.mesh_frequency_Hz[2]), pytest.approx(5.0))
    half = waterfall(x, spc, fm, PAIR, segment_cycles=seg, harmonics=1)          # hop: half a segment
    assert half.amplitude.shape[0] == 2 * amps.size - 1
    with pytest.raises(ModelError, match="shorter than one segment"):
        waterfall(x[:100], spc, fm[:100], PAIR, segment_cycles=seg)


def test_runup_waterfall_of_the_spur_pair_peaks_at_its_mesh_resonance(capsys):
    """spur_28t_asym run up from f_m = 2000 to 3500 Hz in 2800 mesh cycles: the first mesh harmonic's track peaks
    within 8 % below the 2786 Hz linear mesh resonance (the contact loss softens it: the jump of
    docs/dynamics.md), and the command's JSON carries the tracks per segment."""
    assert main(["spectrum", "spur_28t_asym", "--fm", "2000", "--fm-end", "3500", "--cycles", "2800",
                 "--steps-per-cycle", "32", "--settle-cycles", "100", "--harmonics", "2", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    wf = rep["channels"]["m12"]
    assert wf["coherent"] and wf["segment_cycles"] == 28 and len(wf["mesh_frequency_Hz"]) == 199
    i = int(np.argmax(wf["tracks"]["1"]))
    assert 0.92 * 2786.4 < wf["mesh_frequency_Hz"][i] < 2786.4 * 1.01
    assert main(["spectrum", "spur_28t_asym", "--fm", "2000", "--fm-end", "3500", "--cycles", "60",
                 "--quantity", "ste"]) == 2


@pytest.mark.parametrize("name", ["spur_28t_asym", "planetary_65_55_175", "helical_28_33"])
def test_recorded_bearing_forces_are_the_simulators(name):
    """bearing_forces over a recorded run equal Simulator.bearing_force_N stepped sample by sample (1e-12 of the
    force): bearing maps with the carrier's angle (planetary), support springs (helical), mesh forces (spur)."""
    from hacgear_core.dynamics.simulator import Simulator
    from hacgear_core.spectra.records import bearing_forces

    sy = load_inputs(name).system
    sim = Simulator(sy)
    sim.set_speed_input(mesh_frequency_Hz=1500.0)
    sim.advance(0.005)
    twin = Simulator(sy)
    twin.set_state(sim.get_state())
    dt = 1 / (1500.0 * 16)
    raw = sim.run(32 * dt, dt)
    bf = bearing_forces(sy, raw, sim.kin[2])
    assert bf
    for j in range(32):
        assert twin.advance(dt).success
        for g, f in bf.items():
            ref = twin.bearing_force_N(g)
            assert np.max(np.abs(f[j] - ref)) <= 1e-12 * max(1.0, np.max(np.abs(ref))), (g, j)


def test_gallery_example_puts_the_run_up_peak_at_the_mesh_mode(tmp_path):
    """examples/spectra_gallery.py on spur_28t_asym (docs/spectra.md "Gallery"): the three figures and the
    numbers; the perfect pair's steady DTE is at mesh harmonics only (> 99.99 % of the AC power), its operating
    point is 0.8 x the mesh mode (2786 Hz), and the run-up's first-harmonic peak lies within 10 % below that mode
    (contact loss softens the mesh: docs/dynamics.md)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "spectra_gallery.py"
    spec = importlib.util.spec_from_file_location("example_spectra_gallery", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.main(["--systems", "spur_28t_asym", "--out", str(tmp_path), "--runup-cycles", "600"]) == 0
    for what in ("spectrum", "waterfall", "campbell"):
        assert (tmp_path / f"spur_28t_asym_{what}.png").stat().st_size > 10_000
    entry = json.loads((tmp_path / "gallery.json").read_text())["systems"]["spur_28t_asym"]
    f_mode, share = mod.mesh_mode_Hz(load_inputs("spur_28t_asym").system)
    assert f_mode == pytest.approx(2786.4, rel=1e-3) and share > 0.9
    assert entry["mesh_frequency_Hz"] == pytest.approx(0.8 * f_mode, rel=1e-12)
    m = entry["meshes"]["m12"]
    assert entry["coherent"] and m["harmonic_power_fraction"] > 0.9999
    assert 0.9 * f_mode < m["runup_peak_mesh_frequency_Hz"] < f_mode


def test_each_mesh_rate_has_its_own_harmonics_marked():
    """A record of two meshes at unequal rates (the reducer's m34 at 23/71 of m12): each rate's harmonics are mesh
    lines ("1", "1 m34", "2 m34"), read exactly over a common period, and the mesh-harmonic power share counts both
    meshes' harmonics; the reducer's and the NREL gearbox's bases name their rates by mesh or by stage."""
    basis = OrderBasis({"pinion1": Fraction(1, 19), "wheel1/pinion2": Fraction(1, 71),
                        "wheel2": Fraction(23, 71 * 83)}, {"m34": Fraction(23, 71)})
    assert basis.common_period_cycles() == 19 * 71 * 83 / math.gcd(19 * 71 * 83, 23)
    spc = 16
    period = int(basis.common_period_cycles())
    c = np.arange(period * spc) / spc
    comps = [(1.0, 2.0, 0.1), (23 / 71, 1.5, -0.4), (46 / 71, 0.25, 0.9)]
    sp = order_spectrum(_signal(c, comps), spc, basis, harmonics=2, sideband_orders=1)
    assert sp.coherent
    for label, (o, a, p) in zip(("1", "1 m34", "2 m34"), comps):
        ln = sp.line(label)
        assert ln.family == "mesh" and ln.mesh_order == pytest.approx(o, rel=1e-12)
        assert ln.amplitude == pytest.approx(a, rel=1e-9) and ln.phase_rad == pytest.approx(p, abs=1e-9)
    assert sp.mesh_harmonic_power_fraction == pytest.approx(1.0, abs=1e-12)
    assert sp.line("1 m34+1 wheel2").mesh_order == pytest.approx(23 / 71 * (1 + 1 / 83), rel=1e-12)
    reducer = order_basis(load_inputs("reducer_19_71_23_83").system)
    assert dict(reducer.meshes) == {"m34": Fraction(23, 71)}
    gearbox = order_basis(load_inputs("nrel_5mw_gearbox").system)
    assert dict(gearbox.meshes) == {"stage2": Fraction(6975, 1064), "s3_wheel_pinion": Fraction(4625, 112)}
    with pytest.raises(ModelError, match="equal the reference mesh's"):
        OrderBasis({}, {"m": 1.0})
