"""Tests of hacgear_core.dynamics.system and the fixed-axis builder: assembly, closed-form modes, validation."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from _dyn import K, RB, params, system
from hacgear_core.kinds import build_system
from hacgear_core.dynamics.modes import modal_analysis
from hacgear_core.dynamics.synthetic import linear_fdf_table, spur_fdf_table, synthetic_28t_parameters
from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry
from hacgear_core.model import Web
from hacgear_core.kinds import load_model
from hacgear_core.tables import load_system_tables


def test_spur_pair_layout_is_the_dissertation_equation_3_4():
    """q = [y1, th1, y2, th2] with translations along the line of action: x = y1 + r_b1 th1 - y2 + r_b2 th2."""
    sy = system(params(bearing_stiffness_N_per_m=(3e8, 2e8)), linear_fdf_table(K))
    assert sy.dof_names == ("gear1.u_loa", "gear1.theta", "gear2.u_loa", "gear2.theta")
    np.testing.assert_allclose(sy.V[0], [1.0, RB, -1.0, RB], rtol=1e-15)
    np.testing.assert_allclose(np.diag(sy.M), [1.6, 0.0044, 2.1, 0.0061])
    np.testing.assert_allclose(np.diag(sy.K), [3e8, 0.0, 2e8, 0.0])
    # the free rotation of the pair loads no mesh
    assert abs(sy.V[0] @ sy.rigid_mode) < 1e-15 and sy.rigid_mode[sy.iref] == 1.0
    # constant-speed loads balance the nominal mesh force on both gears
    np.testing.assert_allclose(sy.fext_speed(), [0.0, 300.0, 0.0, 300.0], rtol=1e-12)


def test_four_dof_translation_mode_closed_form():
    ky = 200e6
    f = modal_analysis(system(params(mass_kg=(1.7, 1.7), bearing_stiffness_N_per_m=(ky, ky)),
                              linear_fdf_table(K))).natural_frequencies_Hz
    # both gears translating together (y1 = y2) do not strain the mesh: sqrt(k_y / m)
    assert np.min(np.abs(f - math.sqrt(ky / 1.7) / (2 * math.pi))) < 1e-6 * f.max()
    assert f.size == 3


def test_conventional_laws_share_the_mean_stiffness_of_a_constant_stiffness_table():
    tab = linear_fdf_table(K)
    for law in ("hac", "ste", "average_slope", "local_slope"):
        assert system(params(), tab, law).laws[0].mean_stiffness_N_per_m == pytest.approx(K, rel=1e-9)


def test_conventional_laws_differ_on_nonlinear_table():
    tab = spur_fdf_table(tip_relief_m=30e-6)
    p = synthetic_28t_parameters(tab)
    ks = {law: system(p, tab, law).laws[0].mean_stiffness_N_per_m for law in ("hac", "ste", "local_slope")}
    assert ks["hac"] == ks["local_slope"]
    assert ks["ste"] < ks["local_slope"]  # secant (average slope) below the local slope with tip relief


@pytest.mark.parametrize("field,value,match", [
    ("mass_kg", (-1.0, 1.0), "mass_kg \\[kg\\]"),
    ("inertia_kg_m2", (0.01, float("nan")), "inertia_kg_m2"),
    ("teeth", (28, 2.5), "teeth"),
    ("bearing_stiffness_N_per_m", (0.0, 1e8), "bearing_stiffness_N_per_m \\[N/m\\]"),
    ("modal_damping_ratio", 1.5, "modal_damping_ratio"),
    ("torque_Nm", 0.0, "torque_Nm \\[N\\*m\\]"),
])
def test_parameters_validated_with_field_unit_range(field, value, match):
    with pytest.raises(ModelError, match=match):
        params(**{field: value})


def test_table_teeth_mismatch_is_reported():
    with pytest.raises(ModelError, match="teeth"):
        system(params(teeth=(28, 30)), linear_fdf_table(K))


def test_model_builder_maps_the_28_tooth_model():
    model = load_model("spur_28t_asym")
    sy = build_system(model, load_system_tables("spur_28t_asym"))
    rb = 0.5 * 5e-3 * 28 * math.cos(math.radians(25.0))  # the 25 deg flank is loaded
    assert sy.dof_names == ("pinion.theta", "wheel.theta")
    np.testing.assert_allclose(sy.V[0], [rb, rb], rtol=1e-12)
    assert sy.torque_Nm == 300.0 and sy.modal_damping_ratio == 0.02
    assert sy.nominal_forces_N()[0] == pytest.approx(300.0 / rb, rel=1e-12)
    # blank: the generated gear (annulus 40..126.4 mm plus the real teeth), as `hacgear info` reports
    gg = gear_geometry(model.gear("pinion"))
    np.testing.assert_array_equal(np.diag(sy.M), [gg.inertia_kgm2, gg.inertia_kgm2])
    # a webbed blank reaches the lumped model: the web annulus (60..110 mm) loses (1 - 8/15) of its inertia
    web = Web(8e-3, 0.060, 0.110)
    mw = dataclasses.replace(model, gears=tuple(dataclasses.replace(g, web=web) for g in model.gears))
    syw = build_system(mw, load_system_tables("spur_28t_asym"), bearing_stiffness_N_per_m=200e6)
    sy4 = build_system(model, load_system_tables("spur_28t_asym"), bearing_stiffness_N_per_m=200e6)
    dm = 7850 * math.pi / 4 * (0.110**2 - 0.060**2) * (0.015 - 0.008)
    dj = 7850 * math.pi / 32 * (0.110**4 - 0.060**4) * (0.015 - 0.008)
    assert syw.M[0, 0] == pytest.approx(sy4.M[0, 0] - dm, rel=1e-9)
    assert syw.M[3, 3] == pytest.approx(sy4.M[3, 3] - dj, rel=1e-9)


def test_torque_change_scales_the_nominal_forces():
    sy = system(params(), linear_fdf_table(K))
    s2 = sy.with_changes(torque_Nm=150.0)
    assert s2.nominal_forces_N()[0] == pytest.approx(0.5 * sy.nominal_forces_N()[0], rel=1e-12)
    assert s2.fingerprint() != sy.fingerprint()


def test_shafts_do_not_load_the_bearings_twice():
    """Constant-speed experiment with a shaft on the driven gear and elastic bearings: the static bearing deflection
    is the mesh force over the bearing stiffness (the shaft preload acts on the rotations only)."""
    from hacgear_core.kinds import spur_pair_system
    from hacgear_core.dynamics.equilibrium import static_equilibrium
    from hacgear_core.dynamics.synthetic import linear_fdf_table, synthetic_28t_parameters

    tab = linear_fdf_table(150e6, x_max_m=400e-6)
    p = synthetic_28t_parameters(tab, bearing_stiffness_N_per_m=200e6).replace(
        rotational_stiffness_Nm_per_rad=(0.0, 1e5))
    sy = spur_pair_system(p, tab)
    eq = static_equilibrium(sy, 0.0)
    f = sy.nominal_forces_N()[0]
    assert eq.mesh_forces_N[0] == pytest.approx(f, rel=1e-9)
    y = [eq.q[i] for i, d in enumerate(sy.dof_names) if d.endswith("u_loa")]
    np.testing.assert_allclose(np.abs(y), f / 200e6, rtol=1e-9)


def test_integrate_refuses_written_arrays_that_share_memory():
    """The kernel writes the state, the kinematics and the records and is compiled with its arrays marked noalias:
    two of them overlapping in memory is refused by name before any step; views of one buffer that do not overlap
    (records side by side in one array) integrate like separate arrays."""
    sy = system(params(), linear_fdf_table(K))
    n, w = sy.n, sy.record_width
    fext = sy.fext_speed()
    h = 1e-6
    buf = np.zeros(2 * n + 3)
    buf[2 * n + 2] = 100.0
    with pytest.raises(ValueError, match="s and kin share memory"):
        sy.integrate(buf[:2 * n], buf[2 * n - 1:2 * n + 2], 10, h, fext)
    s, kin = buf[:2 * n].copy(), buf[2 * n:].copy()
    with pytest.raises(ValueError, match="s and rec_state share memory"):
        sy.integrate(s, kin, 10, h, fext, rec_every=1, rec_state=s.reshape(1, 2 * n), rec_out=np.zeros((4, w)))
    assert np.array_equal(s, buf[:2 * n]) and np.array_equal(kin, buf[2 * n:])  # refused before any step
    rec = np.zeros(4 * (2 * n + w))
    s2, kin2 = s.copy(), kin.copy()
    assert sy.integrate(s, kin, 10, h, fext, rec_every=1, rec_state=rec[:8 * n].reshape(4, 2 * n),
                        rec_out=rec[8 * n:].reshape(4, w)) == 4
    rs, ro = np.zeros((4, 2 * n)), np.zeros((4, w))
    assert sy.integrate(s2, kin2, 10, h, fext, rec_every=1, rec_state=rs, rec_out=ro) == 4
    assert kin[0] > 0.0 and np.array_equal(s, s2) and np.array_equal(rec[:8 * n].reshape(4, 2 * n), rs)
