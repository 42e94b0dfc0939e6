"""Manufacturing errors on gear trains and gearboxes (meshes at their own rates p/q): each mesh's error profile is
over its own unwrapped position, so a gear's runout comes back once per revolution of its shaft at its stage's
mesh frequency.  reducer_19_71_23_83 (stage 2 at 23/71 of stage 1's mesh frequency) with a 10 um runout on
pinion2: the hunting period in reference cycles, the static TE (a shaft line of exactly the runout's line-of-action
projection, at the phase the gear's static twist puts it), the mesh force under imposed kinematics (sidebands at
h f_m2 +- f_shaft2 = the runout times the stage's mesh stiffness harmonics); zero errors leave the system as it
was; nrel_5mw_gearbox: runout on its helical stage, and on its planetary stages the profiles of the stage models."""
from __future__ import annotations

import math
from dataclasses import replace
from functools import cache

import numpy as np
import pytest

from hacgear_core.geometry import mesh_geometry
from hacgear_core.kinds import build_system, load_model
from hacgear_core.model import GearErrors, resolve_model_path
from hacgear_core.spectra.records import steady_record

E_RUNOUT = 10e-6
Z2 = 23           # pinion2's teeth (stage 2 of the reducer)
SHAFT2 = 71       # reference (stage 1) mesh cycles per revolution of the intermediate shaft (wheel1's teeth)


@cache
def _load(name):
    from hacgear_core.tables import load_system_tables
    p = resolve_model_path(name)
    return load_model(p), load_system_tables(p)


def _with(name, **errors):
    model, tabs = _load(name)
    gears = tuple(replace(g, errors=errors[g.name]) if g.name in errors else g for g in model.gears)
    return build_system(replace(model, gears=gears), tabs)


def _amplitudes(x):
    """Single-sided amplitudes and phases (cosine) of a record over a whole number of periods, per bin."""
    X = np.fft.rfft(np.asarray(x, float)) / len(x)
    return 2 * np.abs(X), np.angle(X)


def test_train_hunting_periods_count_each_mesh_at_its_rate():
    """A mesh at rate p/q whose profile spans L of its cycles repeats after L q / gcd(L q, p) reference cycles:
    pinion2 (23 teeth, stage 2 at 23/71) turns once in 71 reference cycles (the shafts' period, unchanged); wheel1
    (71, stage 1) likewise; wheel2 (83) once in 83 x 71 / 23 reference cycles, whole after 5893.  nrel_5mw_gearbox:
    pinion3 (24 teeth, stage 3 at 4625/112) once per 24 x 112 / 4625 reference cycles, with the system's 2128 the
    lcm 51072."""
    base = build_system(*_load("reducer_19_71_23_83"))
    assert base.period_cycles == SHAFT2
    for gear, mesh, L, period in (("pinion2", "m34", Z2, SHAFT2), ("wheel1", "m12", 71, SHAFT2),
                                  ("wheel2", "m34", 83, 5893)):
        sy = _with("reducer_19_71_23_83", **{gear: GearErrors(runout_m=E_RUNOUT)})
        c = sy.meshes[sy.mesh_names.index(mesh)]
        assert c.error[1] == L and sy.period_cycles == period, gear
        assert all(o.error is None for o in sy.meshes if o is not c)
    box = build_system(*_load("nrel_5mw_gearbox"))
    sy = _with("nrel_5mw_gearbox", pinion3=GearErrors(runout_m=E_RUNOUT))
    (c,) = [o for o in sy.meshes if o.error is not None]
    p, q = c.rate
    assert c.name == "s3_wheel_pinion" and c.error[1] == 24
    assert sy.period_cycles == math.lcm(box.period_cycles, 24 * q // math.gcd(24 * q, p)) == 51072


def test_zero_errors_leave_the_train_as_it_was():
    """Empty [gears.errors] on every gear of the reducer: no profile, the error-free kernel, the same fingerprint
    and period."""
    ref = build_system(*_load("reducer_19_71_23_83"))
    model, _ = _load("reducer_19_71_23_83")
    sy = _with("reducer_19_71_23_83", **{g.name: GearErrors() for g in model.gears})
    assert not sy.has_errors and sy.kernel is ref.kernel and sy.fingerprint() == ref.fingerprint()
    assert sy.period_cycles == ref.period_cycles


def test_reducer_runout_static_te_is_a_shaft_line_at_stage_2():
    """10 um runout on pinion2 (phase 0.4 rad): stage 2's static TE over the shaft's revolution (71 reference
    cycles) is the ideal one less the runout's closing e sin(2 pi (c_2 - passage) / 23 + phase + alpha_w), c_2 =
    (23/71) c_ref + phase_2 + w.q the stage's own position (its static w.q: the shaft's twist under load turns
    pinion2's teeth): one line at bin 1 (the shaft order) of amplitude e (within 1e-4; measured 1 - 7e-7), at that phase (within 2e-4 rad;
    measured 5e-5), no sidebands at 23 +- 1, 46 +- 1 (below 1e-4 e; measured 2e-5), the mesh harmonics (bins 23,
    46) the ideal gears' (1e-4; measured 1e-9)."""
    from hacgear_core.dynamics.equilibrium import static_equilibrium
    model, tabs = _load("reducer_19_71_23_83")
    sy = _with("reducer_19_71_23_83", pinion2=GearErrors(runout_m=E_RUNOUT, runout_phase_rad=0.4))
    k = sy.mesh_names.index("m34")
    c = sy.meshes[k]
    alpha = mesh_geometry(model, "m34").operating_pressure_angle_rad
    rec = steady_record(sy, 200.0, "ste", SHAFT2, samples_per_cycle=16)
    rec0 = steady_record(build_system(model, tabs), 200.0, "ste", SHAFT2, samples_per_cycle=16)
    a, ph = _amplitudes(rec.channels["m34"])
    a0, _ = _amplitudes(rec0.channels["m34"])
    wq = float(sy.W[k] @ static_equilibrium(sy, 0.0).q)
    want = 0.4 + alpha + math.pi / 2 + 2 * math.pi * (float(sy.phase[k]) + wq - c.tooth_passage["pinion2"]) / Z2
    assert a[1] == pytest.approx(E_RUNOUT, rel=1e-4)
    assert math.remainder(ph[1] - want, 2 * math.pi) == pytest.approx(0.0, abs=2e-4)
    for b in (Z2 - 1, Z2 + 1, 2 * Z2 - 1, 2 * Z2 + 1):
        assert a[b] < 1e-4 * E_RUNOUT
    for b in (Z2, 2 * Z2):
        assert a[b] == pytest.approx(a0[b], rel=1e-4)


def test_reducer_runout_force_sidebands_at_stage_2_mesh_frequency():
    """Imposed kinematics (inertias x 1e8; modal damping 0.5; the reference mesh at 2000 Hz, so the shaft's 28 Hz
    is 25 x the highest natural frequency, 1.13 Hz: the bodies stand still) with a 10 um runout on pinion2: stage
    2's mesh force F(tau_2, x - e(c_2)) ~ F(tau_2, x_bar) - k(tau_2) e(c_2) puts k_0 e at the shaft order (bin 1 of
    the 71-cycle record) and K_h e at h f_m2 +- f_shaft2 (bins 23 h +- 1; K_h the h-th harmonic of the stage's
    secant stiffness over x_bar +- e).  Within 5 % (measured: shaft +0.04 %, h = 1: -0.05 / -0.04 %, h = 2: +0.01
    / +0.02 %, h = 3: +0.21 / +0.22 %; at 200 Hz the shaft order is 2.5 x the highest mode and every line is
    +2.6 %: the bodies follow)."""
    from scipy.optimize import brentq
    sy = _with("reducer_19_71_23_83", pinion2=GearErrors(runout_m=E_RUNOUT, runout_phase_rad=0.4))
    k = sy.mesh_names.index("m34")
    heavy = sy.with_changes(mass=sy.M * 1e8, modal_damping_ratio=0.5)
    assert heavy.natural_frequencies_Hz().max() < 0.05 * 2000.0 / SHAFT2
    rec = steady_record(heavy, 2000.0, "force", SHAFT2, samples_per_cycle=64, settle_cycles=50000)
    a, _ = _amplitudes(rec.channels["m34"])
    tau = np.arange(256) / 256
    f0 = sy.meshes[k].nominal_force_N
    assert 0.5 * a[0] == pytest.approx(f0, rel=1e-3)
    xbar = brentq(lambda x: np.mean(sy.mesh_force(k, tau, np.full(tau.size, x))) - f0, -1e-4, 2e-4)
    st = (sy.mesh_force(k, tau, np.full(tau.size, xbar + E_RUNOUT))
          - sy.mesh_force(k, tau, np.full(tau.size, xbar - E_RUNOUT))) / (2 * E_RUNOUT)
    K = np.abs(np.fft.rfft(st)) / tau.size
    assert a[1] == pytest.approx(K[0] * E_RUNOUT, rel=0.05)
    for h in (1, 2, 3):
        for b in (Z2 * h - 1, Z2 * h + 1):
            assert a[b] == pytest.approx(K[h] * E_RUNOUT, rel=0.05), (h, b)


def test_gearbox_helical_stage_runout():
    """nrel_5mw_gearbox: a 10 um runout on pinion3 gives the helical stage 3 a profile along the flank normal (its
    largest sample e cos(beta_b)) over pinion3's 24 cycles, the kernel's error loop."""
    model, tabs = _load("nrel_5mw_gearbox")
    sy = _with("nrel_5mw_gearbox", pinion3=GearErrors(runout_m=E_RUNOUT))
    g = next(g for g in model.gears if g.name == "pinion3")
    cos_bb = math.cos(math.atan(math.tan(abs(g.helix_angle_rad)) * math.cos(g.flanks["drive"].pressure_angle_rad)))
    (c,) = [o for o in sy.meshes if o.error is not None]
    assert c.error[0].max() == pytest.approx(E_RUNOUT * cos_bb, rel=1e-5)
    assert "tooth errors" in sy.kernel_label


@pytest.mark.parametrize("stage", [1, 2])
def test_gearbox_planetary_stage_errors_are_the_stage_models(stage):
    """nrel_5mw_gearbox with a 10 um runout on a planetary stage's sun (stage 2 runs at 6975/1064 of stage 1's mesh
    frequency): each sun-planet mesh instance of that stage gets the error profile the stage's own model
    (nrel_5mw_stage<n>, the same set) gives it, over its own mesh positions (samples equal within 1e-15 m), no
    other mesh gets one; the gearbox's period is still the lcm of its rates (2128 reference cycles: the sun's
    teeth divide it), and its static equilibrium solves."""
    ge = GearErrors(runout_m=E_RUNOUT, runout_phase_rad=0.3)
    sun = f"sun{stage}"
    box = _with("nrel_5mw_gearbox", **{sun: ge})
    own = _with(f"nrel_5mw_stage{stage}", sun=ge)
    prefix = f"s{stage}_"
    with_err = {c.name for c in box.meshes if c.error is not None}
    assert with_err == {c.name for c in box.meshes if c.name.startswith(prefix + "sun")} and len(with_err) == 3
    for c in own.meshes:
        b = next(x for x in box.meshes if x.name == prefix + c.name)
        if c.error is None:
            assert b.error is None
            continue
        assert b.error[1:] == c.error[1:]
        np.testing.assert_allclose(b.error[0], c.error[0], rtol=0, atol=1e-15)
    assert box.period_cycles == 2128 and "tooth errors" in box.kernel_label
    from hacgear_core.dynamics.equilibrium import static_equilibrium
    q = static_equilibrium(box, 3.7)
    assert q.success and np.all(np.isfinite(q.mesh_forces_N))


def test_reducer_runout_steady_state_repeats_over_the_hunting_period():
    """The steady state of the reducer with a pinion2 runout at 800 Hz is found (converged) over the 71-cycle
    period, sampled once per period."""
    from hacgear_core.dynamics.steady import steady_state
    sy = _with("reducer_19_71_23_83", pinion2=GearErrors(runout_m=E_RUNOUT))
    r = steady_state(sy, 800.0)
    assert r.converged and r.period_cycles == SHAFT2 and r.cycles_run % SHAFT2 == 0
