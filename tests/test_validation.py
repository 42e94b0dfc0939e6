"""Published numbers of the dissertation, checked on the committed FE tables (hacgear_core.plots.validation).

These run the whole chain that a user runs: model file -> committed tables.h5 (made by our own FE/contact
solver) -> HAC dynamics.  Numbers and tolerances are listed in docs/validation.md."""
from __future__ import annotations

import numpy as np
import pytest

from hacgear_core.plots.validation import flanks_study, natural_frequencies, sweep


def test_28t_natural_frequency_rigid_supports_2800Hz():
    """Dissertation 3.6.1: 2800 Hz (FE/CM), 2775 Hz (HAC), 2825 Hz (experiment), 300 N m, 25 deg flank."""
    r = natural_frequencies("spur_28t_asym", 300.0)
    assert r["linearised_Hz"][0] == pytest.approx(2800.0, rel=0.05)
    assert r["impulse_weighted_Hz"][0] == pytest.approx(2800.0, rel=0.05)
    # single contact is softer than double contact
    assert r["impulse_single_Hz"][0] < r["impulse_weighted_Hz"][0] < r["impulse_double_Hz"][0]


@pytest.mark.xfail(strict=True, reason="measured 3819 Hz (impulse, contact-ratio weighted) / 3780 Hz (linearised): "
                   "-8.0 % / -8.9 % against 4150 Hz; see docs/validation.md")
def test_28t_highest_natural_frequency_with_200MN_per_m_bearings_4150Hz():
    r = natural_frequencies("spur_28t_asym", 300.0, 200e6)
    assert r["impulse_weighted_Hz"][-1] == pytest.approx(4150.0, rel=0.05)


def test_28t_bearing_compliance_adds_two_modes_below_and_one_above():
    rigid = natural_frequencies("spur_28t_asym", 300.0)["linearised_Hz"][0]
    r = natural_frequencies("spur_28t_asym", 300.0, 200e6)["linearised_Hz"]
    assert len(r) == 3 and r[0] < r[1] < rigid < r[2]


def test_50t_icr137_softening_with_jumps_and_superharmonic_peaks():
    """Dissertation Fig. 3.5 (170 N m): double-valued softening region below f_m/f_n = 1 with jump-up on the
    up sweep and jump-down on the down sweep, resonance peaks near f_m/f_n = 1/2 and 1/3."""
    s = sweep("spur_50t_icr137", 170.0, (0.25, 1.3, 106))
    jumps = [(j["kind"], j["branch"], j["fm_over_fn"]) for j in s["jumps"]]
    ups = [f for k, b, f in jumps if k == "jump-up" and b == "up" and 0.6 < f < 1.0]
    downs = [f for k, b, f in jumps if k == "jump-down" and b == "down" and 0.4 < f < 1.0]
    assert ups and downs, jumps
    assert min(downs) < max(ups), "jump-down below jump-up: a double-valued region"
    up = s["branches"]["up"]
    f = np.asarray(up["fm_over_fn"])
    rms = np.asarray(up["rms_deflection_m"])
    base = np.median(rms[(f > 0.36) & (f < 0.45)])
    for lo, hi in ((0.45, 0.55), (0.29, 0.36)):
        sel = (f > lo) & (f < hi)
        assert rms[sel].max() > 1.5 * base, f"no resonance peak in {lo}..{hi}"
    # the large-amplitude branch loses contact for part of the cycle
    down = s["branches"]["down"]
    assert max(down["contact_loss_fraction"]) > 0.1


@pytest.mark.slow
def test_28t_blank_bore_trend_stiffness_mass_and_frequency():
    """docs/validation.md "The unspecified blank": a smaller bore leaves more blank to twist between hub and root,
    so the mean mesh stiffness falls strongly (~-7 % from 40 to 35 mm), the gear gets heavier, and the rigid-support
    natural frequency sqrt(2 k / (J / r_b^2)) falls with it."""
    import dataclasses
    import math

    from hacgear_core.statics.studies import mesh_stiffness_report
    from hacgear_core.geometry import gear_geometry
    from hacgear_core.kinds import load_model

    base = load_model("spur_28t_asym")
    out = {}
    for bore in (0.035, 0.040):
        m = dataclasses.replace(base, gears=tuple(dataclasses.replace(g, bore_diameter_m=bore) for g in base.gears))
        k = mesh_stiffness_report(m, 300.0, positions=16)["meshes"]["m12"]["mean_mesh_stiffness_N_per_m"]
        gg = gear_geometry(m.gears[0])
        rb = gg.base_radius_m["drive"]
        out[bore] = (k, gg.mass_kg, math.sqrt(2 * k / (gg.inertia_kgm2 / rb**2)) / (2 * math.pi))
    (k35, m35, f35), (k40, m40, f40) = out[0.035], out[0.040]
    assert 0.88 < k35 / k40 < 0.97
    assert m35 > m40
    assert f35 < f40
    assert f40 == pytest.approx(2800.0, rel=0.05)


def test_both_flanks_tooth_skipping_and_dynamic_factors(tmp_path):
    """Dissertation Section 2.4.2 on the coast tables: the 28-tooth pair with its 20 deg flanks loaded (negative
    torque).  100 N*m at f_m/f_n = 1.7: the large-amplitude (down-sweep) branch skips teeth (Fig. 2.12: every other
    tooth takes no load) with a root-strain dynamic factor near 3, the up branch does neither; 300 N*m at 0.494: the
    dynamic strain stays close to the static one (Fig. 2.8(c,d)).  50-tooth ICR 1.8 pair at 200 N*m: a softening
    resonance whose peak dynamic factor is near 2 (the dissertation: ~2 at f_m/f_n = 1.0, ~1.5 at 1.069; ours peaks
    below 1.0, listed as a miss in docs/validation.md)."""
    r = flanks_study(tmp_path)
    a = r["spur_28t_asym_20deg_100Nm"]["at_1.7"]
    assert a["down"]["skipped_tooth_fraction"] >= 0.25 and a["down"]["contact_loss_fraction"] > 0.3
    assert 2.4 <= a["down"]["dynamic_factor_strain"] <= 3.6
    assert a["up"]["skipped_tooth_fraction"] == 0.0 and a["up"]["dynamic_factor_strain"] < 2.0
    b = r["spur_28t_asym_20deg_300Nm"]["at_0.494"]
    for br in b.values():
        assert br["contact_loss_fraction"] == 0.0 and 1.0 <= br["dynamic_factor_strain"] <= 1.3
    c = r["spur_50t_icr18_200Nm"]
    peak = max(c["peak_up"], c["peak_down"], key=lambda p: p["dynamic_factor_strain"])
    assert 1.6 <= peak["dynamic_factor_strain"] <= 2.4 and 0.85 <= peak["fm_over_fn"] < 1.0
    assert (tmp_path / "validation_tooth_skipping.png").stat().st_size > 10_000
