"""Pitch errors on helical meshes (helical_28_33, beta 15 deg): the tooth pairs in contact over the face are the
table's tooth offsets; the error profile is the static shift of the pairs at their own approaches at the nominal
force and zero twist (:func:`~hacgear_core.dynamics.gear_errors.pair_solve_shift` on the table's tooth loads, which
are its zero-twist slice), along the flank normal (cos beta_b).  The single pitch error's static TE is its Fourier
series times the pairs' stiffness-share pulse (the spur pair's closed form, tests/test_gear_errors.py), and the
linearisation in the load is measured against the pair solve at 0.5 and 1.5 x the nominal force."""
from __future__ import annotations

import math
from dataclasses import replace
from functools import cache

import numpy as np
import pytest

from hacgear_core.dynamics.gear_errors import cumulative_pitch_deviations_m, pair_solve_shift
from hacgear_core.kinds import build_system, load_model
from hacgear_core.model import GearErrors, resolve_model_path
from hacgear_core.spectra.records import system_spectra

from _pitch import share_transform

Z = 28


@cache
def _helical():
    from hacgear_core.tables import load_system_tables
    p = resolve_model_path("helical_28_33")
    return load_model(p), load_system_tables(p)


def _cos_beta_b(gear) -> float:
    return math.cos(math.atan(math.tan(abs(gear.helix_angle_rad)) * math.cos(gear.flanks["drive"].pressure_angle_rad)))


def test_helical_table_tooth_loads_are_its_zero_twist_slice():
    """The helical table's tooth loads (the pair solve's input) are its twist table's at twist 0, and sum to its
    force at the static deflection within 0.2 % of the nominal force; the static twist at the nominal torque is a
    small fraction of the twist grid's step (the zero-twist pair solve is taken where the mesh works)."""
    from hacgear_core.dynamics.equilibrium import static_equilibrium
    model, tabs = _helical()
    sy = build_system(model, tabs)
    tab, fn = sy.meshes[0].table, sy.meshes[0].nominal_force_N
    tw = tab.twist
    scale = np.abs(tab.tooth_load_N).max()
    assert np.abs(tab.tooth_load_N - tw.tooth_load_N[:, :, tw.zero_index, :]).max() < 1e-6 * scale
    pos = np.arange(16) / 16
    x = tab.static_deflection(pos, np.full(pos.size, fn))
    total = sum(tab.tooth_load(pos, x, int(o)) for o in tab.tooth_offsets)
    assert np.max(np.abs(total - fn)) < 2e-3 * fn
    assert abs(float(static_equilibrium(sy, 0.0).twist_rad[0])) < 0.1 * float(tw.twist_rad[1] - tw.twist_rad[0])


@pytest.mark.parametrize("d, rtol", [(0.5e-6, 0.02), (5e-6, 0.05)])
def test_helical_single_pitch_error_static_te_is_its_fourier_series(d, rtol):
    """One displaced pinion tooth (f_p = +d before it, -d after it): the opening E_j = (r_b / r) F_j cos(beta_b)
    along the flank normal (a late driving tooth meets later), the line at shaft order k is 2 |E^(k) G(k / z)| / z (G the Fourier transform of the pairs'
    stiffness shares over their pair phases, :func:`load_shares`) times k / (k + k_sh), the share of the approach
    change the mesh takes against the shaft springs (5e4 N m/rad on both gears; as the helical runout test).  The
    static TE over the revolution, shaft orders 1-10: within 2 % for d = 0.5 um (measured -1.05 ... -0.09 %; the
    factor is the mean stiffness's), within 5 % for d = 5 um (measured -2.5 ... -1.3 %: the pairs' own approaches
    make the shift nonlinear in the error), phases within 3e-3 rad (measured 2e-3)."""
    model, tabs = _helical()
    f = np.zeros(Z)
    f[5], f[6] = d, -d
    g = model.gears
    sy = build_system(replace(model, gears=(replace(g[0], errors=GearErrors(single_pitch_deviations_m=tuple(f))),)
                              + tuple(g[1:])), tabs)
    c = sy.meshes[0]
    assert c.error[1] == Z and len(c.error) == 3 and "tooth errors" in sy.kernel_label   # a profile over c only
    tp = c.tooth_passage["pinion"]
    E = (c.base_radius_m[0] / (0.5 * g[0].module_m * Z)) * cumulative_pitch_deviations_m(f) * _cos_beta_b(g[0])
    G = share_transform(c.table, c.nominal_force_N)

    arms = [sy.V[0][sy.gears[name].rotation] for name in ("pinion", "wheel")]
    k_sh = 1.0 / sum(a * a / 5e4 for a in arms)
    k = float(sy.mesh_stiffness_N_per_m[0])
    _, sp = system_spectra(sy, 100.0, "ste", samples_per_cycle=16, sideband_orders=10)
    s = sp["m12"]
    for order in range(1, 11):
        want = (np.sum(E * np.exp(-2j * np.pi * order * np.arange(Z) / Z)) * G(order / Z)
                * np.exp(-2j * np.pi * order * tp / Z) / Z)
        ln = s.line(f"{order} x pinion")
        assert ln.amplitude == pytest.approx(2 * abs(want) * k / (k + k_sh), rel=rtol), order
        assert math.remainder(ln.phase_rad - np.angle(want), 2 * math.pi) == pytest.approx(0.0, abs=3e-3), order


def test_helical_pitch_profile_linearisation_in_the_load():
    """The profile takes the pairs' static shift at the nominal force: one pinion tooth 5 um ahead, over its pass,
    against the pair solve at 0.5 and 1.5 x the nominal force: RMS within 10 % of the pulse, largest difference
    within 45 % (measured 8.6 / 5.5 % RMS, 38 / 30 % largest, where the pair count changes; the spur pair's table
    gives 7.3 / 6.4 % and 41 / 37 % by the same rule, which its force tables avoid with the profile over the
    approach)."""
    model, tabs = _helical()
    c = build_system(model, tabs).meshes[0]
    tab, fn = c.table, c.nominal_force_N
    offs = [int(o) for o in tab.tooth_offsets]
    cc = np.arange(6 * 32) / 32 + 2.0
    n = cc.astype(int)
    tau = cc - n
    E = np.zeros(Z)
    E[5] = 5e-6
    eo = np.stack([E[(n + o) % Z] for o in offs], axis=1)
    ours = pair_solve_shift(tab, fn, tau, eo)
    for fac in (0.5, 1.5):
        truth = pair_solve_shift(tab, fac * fn, tau, eo)
        span = np.ptp(truth)
        assert span == pytest.approx(5e-6, rel=1e-3)
        assert np.sqrt(np.mean((ours - truth) ** 2)) < 0.10 * span and np.max(np.abs(ours - truth)) < 0.45 * span
