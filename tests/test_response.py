"""Tests of hacgear_core.response: interpolation along trajectories, tooth following, stiffness, dynamic factor."""
from __future__ import annotations

import numpy as np
import pytest

from hacgear_core import response as post
from hacgear_core.dynamics.synthetic import linear_fdf_table, spur_fdf_table
from hacgear_core.tables.fdf import static_deflection, table_arrays
from hacgear_core.errors import TableError


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
    np.testing.assert_allclose(tl.sum(axis=1), tab.force(tau, x), rtol=1e-9)
    assert np.all(post.dynamic_contact_pressure(tab, tau, np.full(40, -5e-6)) == 0.0)
    assert np.all(post.dynamic_contact_pressure(tab, tau, x) > 0.0)
    with pytest.raises(TableError, match="gauge"):
        post.dynamic_root_strain(tab, "nope/SG", tau, x)


def test_helical_pressure_and_stiffness_are_read_at_the_mesh_twist():
    """A helical table (twist axis): at zero twist the twisted reads equal the zero-twist ones; at a twist node
    the pressure is the twist-resolved static solution's (the pattern moves towards a face edge: the peak
    pressure at +0.5 mrad is above the untwisted one); the stiffness is dW/dx of the generalized FDF at that twist."""
    from hacgear_core.tables import load_system_tables

    t = load_system_tables("helical_28_33").mesh("m12")
    tau = np.asarray(t.position, float)
    xs = static_deflection(table_arrays(t), 3244.1)
    zero = np.zeros(tau.size)
    np.testing.assert_allclose(post.dynamic_contact_pressure(t, tau, xs, zero), post.dynamic_contact_pressure(t, tau, xs),
                               rtol=1e-6)
    np.testing.assert_allclose(post.dynamic_mesh_stiffness(t, tau, xs, zero), post.dynamic_mesh_stiffness(t, tau, xs),
                               rtol=1e-9, atol=1e-6)
    # at grid nodes (position i, deflection j, twist k) the stored twist-resolved pressure comes back
    gk = np.asarray(t.twist.twist_rad)
    j = int(np.argmin(np.abs(np.asarray(t.deflection_m) - xs.mean())))
    xj = np.full(tau.size, t.deflection_m[j])
    top = post.dynamic_contact_pressure(t, tau, xj, np.full(tau.size, gk[-1]))
    np.testing.assert_allclose(top, np.asarray(t.twist.peak_pressure_Pa)[:, j, -1], rtol=1e-6)
    assert top.max() > 1.02 * post.dynamic_contact_pressure(t, tau, xj).max()     # measured +2.4 %
    # stiffness at a twist: the slope of W over the deflection cell at that twist
    g = np.full(tau.size, 0.3e-3)
    k = post.dynamic_mesh_stiffness(t, tau, xs, g)
    h = 1e-3 / t.inv_dx
    w = lambda x: t.generalized(tau, x, g)[:, 0]                               # noqa: E731
    inside = np.abs(((xs - t.x0_m) * t.inv_dx) % 1.0 - 0.5) < 0.49             # away from cell edges
    np.testing.assert_allclose(k[inside], ((w(xs + h) - w(xs - h)) / (2 * h))[inside], rtol=1e-6)
    assert np.all(k > 0)
