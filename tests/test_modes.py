"""Tests of hacgear_core.dynamics.modes: closed-form natural frequencies, impulse test, mass-property inversion."""
from __future__ import annotations

import numpy as np
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


# ------------------------------------------------------------------------------------------- gyroscopic modes
def _planetary(n, lumped=False):
    from pathlib import Path

    from hacgear_core.kinds import build_system
    from hacgear_core.kinds import load_model
    from hacgear_core.tables import read_tables

    if lumped:
        m = load_model(Path(__file__).resolve().parent.parent / "examples" / "planetary_lumped.toml")
        return build_system(m, None, planet_count=n)
    m = load_model("planetary_65_55_175")
    return build_system(m, read_tables(m.tables_path, m.path), planet_count=n)


def _groups(gm):
    """(type, multiplicity) of each distinct frequency."""
    out = []
    f = gm.natural_frequencies_Hz
    i = 0
    while i < len(f):
        out.append((gm.types[i], int(gm.multiplicity[i])))
        i += int(gm.multiplicity[i])
    return out


@pytest.mark.parametrize("n", [3, 4, 5])
def test_lin_parker_mode_types_and_multiplicities(n):
    """Zero carrier speed, identical equally spaced planets (dissertation parameters, HAC tables' mean stiffness):
    rotational modes single, translational double, planet modes of multiplicity N - 3 (none for 3 planets); with
    the ring fixed and the carrier rotation prescribed: 4 rotational, 5 translational pairs, 3 (N > 3) planet
    frequencies (3N + 5 DOFs).  The 3N+9 lumped set: 1 rigid + 5 rotational, 6 translational pairs, 3 planet."""
    from hacgear_core.dynamics.modes import gyroscopic_modes

    gm = gyroscopic_modes(_planetary(n), 0.0)
    g = _groups(gm)
    assert len(gm.natural_frequencies_Hz) == 3 * n + 5 and "mixed" not in gm.types
    assert [m for t, m in g if t == "rotational"] == [1] * 4
    assert [m for t, m in g if t == "translational"] == [2] * 5
    assert [m for t, m in g if t == "planet"] == ([n - 3] * 3 if n > 3 else [])
    gl = gyroscopic_modes(_planetary(n, lumped=True), 0.0)
    g = _groups(gl)
    assert gl.natural_frequencies_Hz[0] == 0.0 and gl.types[0] == "rigid" and gl.types.count("rigid") == 1
    assert [m for t, m in g if t == "rotational"] == [1] * 5
    assert [m for t, m in g if t == "translational"] == [2] * 6
    assert [m for t, m in g if t == "planet"] == ([n - 3] * 3 if n > 3 else [])


def test_gyroscopic_split_of_translational_pairs_grows_with_carrier_speed():
    """Carrier speed splits every double translational pair; the split grows linearly at low speed (first-order
    gyroscopic perturbation: doubling W_c doubles it within 2 %) while rotational and planet frequencies stay
    (second order) and planet pairs stay double."""
    from hacgear_core.dynamics.modes import gyroscopic_modes

    sy = _planetary(5)
    g0 = gyroscopic_modes(sy, 0.0)
    pairs = [i for i in range(len(g0.types)) if g0.types[i] == "translational" and g0.multiplicity[i] == 2][::2]
    splits = []
    for wc in (10.0, 20.0, 40.0):
        g = gyroscopic_modes(sy, wc)
        assert "mixed" not in g.types
        assert [t for t in g.types] == list(g0.types)
        splits.append([g.natural_frequencies_Hz[i + 1] - g.natural_frequencies_Hz[i] for i in pairs])
        for i, t in enumerate(g0.types):
            if t in ("rotational", "planet"):
                assert g.natural_frequencies_Hz[i] == pytest.approx(g0.natural_frequencies_Hz[i], rel=2e-4)
            if t == "planet":
                assert g.multiplicity[i] == 2
    s = np.array(splits)
    assert np.all(s[0] > 0) and np.all(np.diff(s, axis=0) > 0)
    np.testing.assert_allclose(s[1] / s[0], 2.0, rtol=0.02)
    np.testing.assert_allclose(s[2] / s[1], 2.0, rtol=0.02)


def test_cli_modes_of_a_lumped_planetary_model_need_no_tables(capsys):
    """``hacgear modes MODEL --json`` of a lumped model: every mode ascending, rigid-body modes as 0, a type each."""
    import json
    from pathlib import Path

    from hacgear_core.cli import main

    path = str(Path(__file__).resolve().parent.parent / "examples" / "planetary_lumped.toml")
    assert main(["modes", path, "--json", "--planets", "4"]) == 0
    d = json.loads(capsys.readouterr().out)
    f = d["natural_frequencies_Hz"]
    assert len(f) == 3 * 4 + 9 and f == sorted(f) and f[0] == 0.0 and d["lumped"] is True
    assert [m["type"] for m in d["modes"]].count("planet") == 3 and d["modes"][0]["type"] == "rigid"
    assert "impulse_test" not in d
    assert main(["modes", path, "--carrier-speed", "50", "--fm", "100"]) == 2
