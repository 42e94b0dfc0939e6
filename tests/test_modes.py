"""Tests of hacgear_core.dynamics.modes: closed-form natural frequencies, impulse test, mass-property inversion."""
from __future__ import annotations

import pytest

from _dyn import K, RB, fn_rot, params, system
from hacgear_core.dynamics.modes import contact_positions, identical_pair_mass_properties, impulse_test, modal_analysis
from hacgear_core.dynamics.synthetic import linear_fdf_table, spur_fdf_table, synthetic_28t_parameters
from hacgear_core.errors import ModelError


def test_linear_fdf_natural_frequency_modal_and_impulse():
    tab = linear_fdf_table(K)
    sy = system(params(), tab)
    mr = modal_analysis(sy)
    assert mr.rigid_body_modes == 1
    assert mr.natural_frequencies_Hz == pytest.approx([fn_rot()], rel=1e-9)
    it = impulse_test(sy, positions=(0.0, 0.5))
    assert it.single_contact_Hz[0] == pytest.approx(fn_rot(), rel=2e-3)
    assert it.double_contact_Hz[0] == pytest.approx(fn_rot(), rel=2e-3)


def test_identical_pair_mass_properties_inverts_the_modal_analysis():
    """Mass and inertia of identical gears read back from the rigid-support and supported natural frequencies of
    the linearised 4-DOF model (closed-form inversion vs. the numerical eigenproblem)."""
    m, j, ky = 1.3, 0.0041, 200e6
    tab = linear_fdf_table(K)
    base = dict(mass_kg=(m, m), inertia_kg_m2=(j, j))
    f_rigid = modal_analysis(system(params(**base), tab)).natural_frequencies_Hz[-1]
    f_sup = modal_analysis(system(params(**base, bearing_stiffness_N_per_m=(ky, ky)), tab)).natural_frequencies_Hz[-1]
    assert f_sup > f_rigid
    r = identical_pair_mass_properties(K, f_rigid, f_sup, ky, RB)
    assert r["mass_kg"] == pytest.approx(m, rel=1e-9)
    assert r["inertia_kgm2"] == pytest.approx(j, rel=1e-9)
    assert r["mass_ratio"] == pytest.approx(m * RB**2 / j, rel=1e-9)
    with pytest.raises(ModelError, match="f_supported_Hz"):
        identical_pair_mass_properties(K, f_rigid, 0.9 * f_rigid, ky, RB)
    with pytest.raises(ModelError, match="support_stiffness_N_per_m"):
        identical_pair_mass_properties(K, f_rigid, f_sup, float("nan"), RB)


def test_synthetic_28t_impulse_test_brackets_and_weights():
    tab = spur_fdf_table(tip_relief_m=20e-6, contact_ratio=1.45)
    sy = system(synthetic_28t_parameters(tab), tab)
    ps, pd, eps = contact_positions(sy)
    assert eps == pytest.approx(1.45, abs=2.0 / tab.position.size + 0.03)
    it = impulse_test(sy)
    fs_, fd_ = it.single_contact_Hz[0], it.double_contact_Hz[0]
    assert fs_ < fd_
    assert it.weighted_mean_Hz[0] == pytest.approx((2 - eps) * fs_ + (eps - 1) * fd_)
    # magnitude check only (synthetic table, mean stiffness 150 N/um): dissertation HAC 2775 Hz
    assert 2000 < it.weighted_mean_Hz[0] < 3500
