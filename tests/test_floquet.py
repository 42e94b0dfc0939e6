"""Tests of hacgear_core.dynamics.floquet: multipliers of linear systems against the matrix exponential, the damped
Mathieu equation (parametric instability), shooting onto unstable orbits, the steady-state stability check."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sl
from scipy.integrate import solve_ivp

from _dyn import K, fn_rot, params, system
from hacgear_core.kinds import build_system
from hacgear_core.dynamics.floquet import floquet
from hacgear_core.dynamics.steady import SteadyStateOptions, steady_state
from hacgear_core.dynamics.synthetic import linear_fdf_table
from hacgear_core.errors import ModelError
from hacgear_core.kinds import load_model

ROOT = Path(__file__).resolve().parent.parent
ZETA = 0.02


def _mathieu_system(eps: float):
    """Spur pair whose mesh stiffness varies as K (1 + eps cos 2 pi tau): under load its mesh deflection obeys the
    damped Mathieu equation x'' + 2 zeta w0 x' + w0^2 (1 + eps cos W t) x = F_s / m_eff."""
    tab = linear_fdf_table(K)
    kt = K * (1 + eps * np.cos(2 * np.pi * tab.position))
    f = np.ascontiguousarray(np.maximum(kt[:, None] * tab.deflection_m[None, :], 0.0))
    tab = dataclasses.replace(tab, force_N=f, tooth_load_N=f[:, :, None])
    return system(params(modal_damping_ratio=ZETA), tab)


def _mathieu_multipliers(eps: float, fm: float) -> np.ndarray:
    """Floquet multipliers of the damped Mathieu equation over one mesh period, by an independent integration."""
    w0, w = 2 * math.pi * fn_rot(), 2 * math.pi * fm

    def rhs(t, y):
        return [y[1], -2 * ZETA * w0 * y[1] - w0**2 * (1 + eps * math.cos(w * t)) * y[0]]

    cols = [solve_ivp(rhs, (0.0, 1.0 / fm), e, rtol=1e-12, atol=1e-14).y[:, -1] for e in ([1.0, 0.0], [0.0, 1.0])]
    return np.sort(np.abs(np.linalg.eigvals(np.column_stack(cols))))[::-1]


def test_linear_planetary_multipliers_equal_the_matrix_exponential():
    """Constant mesh stiffness (lumped planetary set, carrier turning at the speed of f_m: gyroscopic and
    centripetal terms in): the multipliers are the eigenvalues of expm(A T)."""
    m = load_model(ROOT / "examples" / "planetary_lumped.toml")
    pl = dataclasses.replace(m.planetary, carrier_support=dataclasses.replace(
        m.planetary.carrier_support, rotational_stiffness_Nm_per_rad=math.inf))
    sy = build_system(dataclasses.replace(m, planetary=pl), None)
    fm = 1000.0
    r = steady_state(sy, fm)
    fq = floquet(sy, fm, r.state, r.period_cycles)
    assert fq.success and fq.residual < 1e-9 and fq.rigid.size == 0
    oc = sy.carrier_ratio * sy.reference_speed(fm)
    assert oc > 0
    kt = sy.K - oc**2 * sy.K_W + (sy.V.T * sy.mesh_stiffness_N_per_m) @ sy.V
    ct = sy.C + oc * sy.G
    mi = np.linalg.inv(sy.M)
    n = sy.n
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-mi @ kt, -mi @ ct]])
    ref = np.linalg.eigvals(sl.expm(a / fm))
    ours = fq.multipliers
    assert ours.size == 2 * n
    # every multiplier matched (complex), not only the moduli; the difference is the RK4 truncation error of the
    # stiffest mode (>= 32 steps per period): 3.9e-6
    for mu in ref:
        assert np.min(np.abs(ours - mu)) < 2e-5
    assert fq.stable and fq.max_multiplier == pytest.approx(np.max(np.abs(ref)), rel=1e-6)


@pytest.mark.parametrize("eps, unstable", [(0.2, True), (0.04, False)])
def test_mathieu_parametric_instability(eps, unstable):
    """Principal parametric resonance f_m = 2 f_n: unstable when eps > 4 zeta (first order: |mu| = exp(pi (eps/4 -
    zeta))); the multipliers equal those of the Mathieu equation integrated independently (the mesh position's
    dependence on the gear rotation is the only difference, 1e-5 here)."""
    sy = _mathieu_system(eps)
    fm = 2 * fn_rot()
    r = steady_state(sy, fm)
    fq = floquet(sy, fm, r.state, 1)
    assert fq.success and fq.residual < 1e-9
    assert fq.rigid.size == 2 and np.all(np.abs(fq.rigid - 1) < 1e-4)  # the pair's free rotation, set apart
    ref = _mathieu_multipliers(eps, fm)
    assert np.sort(np.abs(fq.multipliers))[::-1] == pytest.approx(ref, rel=1e-4)
    assert fq.max_multiplier == pytest.approx(math.exp(math.pi * (eps / 4 - ZETA)), rel=3e-3)
    assert fq.stable is (not unstable)
    # the growing perturbation is the mesh mode (the pair's one elastic mode)
    assert fq.dominant_modes(0, 1)[0][0] == pytest.approx(fn_rot(), rel=1e-6)


def test_stability_check_leaves_an_unstable_orbit():
    """Started exactly on the unstable period-1 orbit, plain detection accepts it (the perturbation starts at
    rounding); with the stability check the orbit is left and the response settles on the stable period-2 orbit
    with contact loss."""
    sy = _mathieu_system(0.2)
    fm = 2 * fn_rot()
    fq = floquet(sy, fm, steady_state(sy, fm).state, 1)
    assert not fq.stable
    plain = steady_state(sy, fm, fq.state)
    assert plain.converged and plain.period_cycles == 1 and math.isnan(plain.max_multiplier)
    checked = steady_state(sy, fm, fq.state, SteadyStateOptions(stability=True))
    assert checked.converged and checked.period_cycles == 2 and checked.kicks >= 1
    assert checked.max_multiplier < 1
    assert checked.metrics["contact_loss_fraction"][0] > 0 and plain.metrics["contact_loss_fraction"][0] == 0


def test_bad_input_is_refused():
    sy = _mathieu_system(0.04)
    s = steady_state(sy, 1000.0).state
    with pytest.raises(ModelError, match="mesh frequency"):
        floquet(sy, -1.0, s)
    with pytest.raises(ModelError, match="period_cycles"):
        floquet(sy, 1000.0, s, 0)
    with pytest.raises(ModelError, match="shape"):
        floquet(sy, 1000.0, s[:-1])
    with pytest.raises(ModelError, match="kick"):
        SteadyStateOptions(kick=2.0)
