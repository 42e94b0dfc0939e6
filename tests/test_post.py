"""Tests of hacgear_core.post: interpolation along trajectories, tooth following, stiffness, dynamic factor."""
from __future__ import annotations

import numpy as np
import pytest

from hacgear_core import post
from hacgear_core.dynamics.fdf import static_deflection, table_arrays
from hacgear_core.dynamics.synthetic import linear_fdf_table, spur_fdf_table
from hacgear_core.errors import TableError


def test_interpolation_is_exact_for_bilinear_data_and_periodic():
    tab = spur_fdf_table(n_positions=64, n_deflections=40)
    p = tab.position[:, None]
    x = tab.deflection_m[None, :]
    vals = 3.0 + 2.0 * p + 5e4 * x + 7e4 * p * x  # bilinear in each cell
    rng = np.random.default_rng(1)
    tq = rng.uniform(0, 63 / 64, 200)
    xq = rng.uniform(tab.deflection_m[0], tab.deflection_m[-1], 200)
    got = post.interpolate_table(tab, vals, tq, xq)
    np.testing.assert_allclose(got, 3.0 + 2.0 * tq + 5e4 * xq + 7e4 * tq * xq, rtol=1e-12)
    np.testing.assert_allclose(post.interpolate_table(tab, vals, tq + 3.0, xq), got, rtol=1e-12)
    with pytest.raises(TableError, match="shape"):
        post.interpolate_table(tab, vals[:, :5], tq, xq)


def test_followed_tooth_strain_is_continuous_across_cycles():
    tab = spur_fdf_table(tip_relief_m=10e-6, n_positions=256)
    fs = 300.0 / tab.base_radius_m[0]
    xs = static_deflection(table_arrays(tab), fs)
    # a static trajectory over three mesh cycles, starting one cycle before the reference pair's pitch point
    tau = np.linspace(-1.0, 2.0, 3 * 256, endpoint=False)
    x = np.interp(tau % 1.0, tab.position, xs, period=1.0)
    g = "wheel/SG"
    eps = post.dynamic_root_strain(tab, g, tau, x, tooth=0)
    # the followed tooth carries load for ~contact ratio cycles, and its strain has no jump at the
    # cycle boundaries where it changes offset
    loaded = np.mean(eps > 0.05 * eps.max()) * 3.0  # tensile: own load (neighbour loads compress)
    assert 1.3 < loaded < 1.8
    # ... and that is where its pair phase tau (the tooth is the reference pair at tau in [0, 1))
    # lies in the path of contact, -eps/2 <= tau <= eps/2 with eps = 1.45
    on = tau[eps > 0.05 * eps.max()]
    assert -0.75 < on.min() < -0.6 and 0.6 < on.max() < 0.75
    step = np.abs(np.diff(eps))
    typical = np.percentile(step[step > 0], 90)
    for b in (0.0, 1.0):
        i = np.searchsorted(tau, b)
        assert step[i - 1] < 5 * typical


def test_dynamic_mesh_stiffness_equals_linear_stiffness_and_zero_without_contact():
    k = 180e6
    tab = linear_fdf_table(k, offset_amplitude_m=5e-6)
    tau = np.linspace(0, 1, 50, endpoint=False)
    np.testing.assert_allclose(post.dynamic_mesh_stiffness(tab, tau, np.full(50, 40e-6)), k, rtol=1e-9)
    np.testing.assert_array_equal(post.dynamic_mesh_stiffness(tab, tau, np.full(50, -6e-6)), 0.0)


def test_static_stiffness_of_synthetic_table():
    tab = spur_fdf_table(mean_stiffness_N_per_m=150e6, stiffness_variation=0.15)
    st = post.static_mesh_stiffness(tab, 300.0)
    # no relief: the local slope is the summed pair stiffness, whose cycle mean was prescribed
    assert st.mean_local_slope_N_per_m == pytest.approx(150e6, rel=0.01)
    np.testing.assert_allclose(st.average_slope_N_per_m, st.local_slope_N_per_m, rtol=1e-6)
    tab2 = spur_fdf_table(tip_relief_m=30e-6)
    st2 = post.static_mesh_stiffness(tab2, 300.0)
    assert st2.mean_average_slope_N_per_m < st2.mean_local_slope_N_per_m
    assert st2.no_load_deflection_m.max() > 0 and st.no_load_deflection_m.max() == 0


def test_strain_dynamic_factor_is_one_for_the_static_trajectory():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    fs = 300.0 / tab.base_radius_m[0]
    xs = static_deflection(table_arrays(tab), fs)
    df = post.strain_dynamic_factor(tab, tab.position, xs, fs)
    assert set(df) == {"pinion/SG", "wheel/SG"}
    for v in df.values():
        assert v == pytest.approx(1.0, rel=1e-12)
    df2 = post.strain_dynamic_factor(tab, tab.position, 1.5 * xs, fs)
    assert all(v > 1.3 for v in df2.values())


def test_pressure_and_tooth_loads_vanish_without_contact_and_sum_to_force():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    tau = np.linspace(0, 1, 40, endpoint=False)
    x = np.full(40, 30e-6)
    tl = post.tooth_loads(tab, tau, x)
    from hacgear_core.dynamics.kernels import table_force_many

    f = np.empty(40)
    ta = table_arrays(tab)
    table_force_many(ta.ftab, ta.x0, ta.inv_dx, tau, x, f)
    np.testing.assert_allclose(tl.sum(axis=1), f, rtol=1e-9)
    assert np.all(post.dynamic_contact_pressure(tab, tau, np.full(40, -5e-6)) == 0.0)
    assert np.all(post.dynamic_contact_pressure(tab, tau, x) > 0.0)
    with pytest.raises(TableError, match="gauge"):
        post.dynamic_root_strain(tab, "nope/SG", tau, x)


def test_pair_interpolation_agrees_with_the_tables_module_off_grid():
    tab = spur_fdf_table(tip_relief_m=20e-6, n_positions=32)
    if not hasattr(tab, "sdf"):
        pytest.skip("hacgear_core.tables.MeshTable not available")
    rng = np.random.default_rng(3)
    # phases inside the tabulated window, many in the last position cell of an offset block
    phase = np.concatenate([rng.uniform(-1.9, 2.9, 300), np.arange(-2, 3) + 31.5 / 32])
    x = rng.uniform(tab.deflection_m[1], tab.deflection_m[-2], phase.size)
    mine = post.pair_interpolate(tab, tab.strain["wheel/SG"], phase, x)
    theirs = tab.sdf("wheel/SG", phase, x)
    ok = np.isfinite(theirs)
    assert ok.sum() > 250
    np.testing.assert_allclose(mine[ok], theirs[ok], rtol=1e-10, atol=1e-15)


def test_strain_below_the_deflection_grid_is_not_extrapolated():
    tab = spur_fdf_table(tip_relief_m=20e-6)
    x0 = tab.deflection_m[0]
    a = post.pair_interpolate(tab, tab.strain["wheel/SG"], [0.1], [x0])
    b = post.pair_interpolate(tab, tab.strain["wheel/SG"], [0.1], [x0 - 50e-6])
    assert b[0] == a[0]
