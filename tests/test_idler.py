"""The idler chain (dissertation Section 4.2.1, Table 4.1, Fig. 4.7) on the gear-train core and its FE tables."""
from __future__ import annotations

import math

import numpy as np
import pytest

from _dyn import params
from hacgear_core.kinds import TrainGear, TrainMesh, assemble, build_system, fixed_axis_train, spur_pair_system
from hacgear_core.dynamics.equilibrium import static_state
from hacgear_core.dynamics.modes import modal_analysis
from hacgear_core.dynamics.simulator import Simulator, strain_of_tooth
from hacgear_core.dynamics.steady import steady_state
from hacgear_core.dynamics.sweep import SweepSpec, run_sweep
from hacgear_core.dynamics.synthetic import linear_fdf_table, spur_fdf_table
from hacgear_core.kinds import load_model
from hacgear_core.tables import load_system_tables


@pytest.fixture(scope="module")
def idler():
    model = load_model("idler_28_33_39")
    return build_system(model, load_system_tables("idler_28_33_39"))


def test_idler_layout_and_loads(idler):
    sy = idler
    assert sy.dof_names == ("gear1.theta", "gear2.theta", "gear3.theta") and sy.m == 2
    # x1 = r11 th1 + r12 th2, x2 = -r21 th2 - r22 th3 (dissertation Eq. 4.3b: counter-clockwise rotations)
    r11, r12 = sy.V[0, 0], sy.V[0, 1]
    r21, r22 = -sy.V[1, 1], -sy.V[1, 2]
    assert min(r11, r12, r21, r22) > 0 and sy.V[0, 2] == 0 and sy.V[1, 0] == 0
    assert r12 == pytest.approx(82.5e-3 * math.cos(math.radians(25)), rel=1e-9)
    assert r21 == pytest.approx(82.5e-3 * math.cos(math.radians(20)), rel=1e-9)
    # T1 on gear 1, nothing on the idler, T3 = F_s2 r22 braking gear 3 (plus the shafts' static twist)
    f = sy.nominal_forces_N()
    assert f[0] * r12 == pytest.approx(f[1] * r21, rel=1e-12)
    fe = sy.fext_speed()
    assert fe[1] == pytest.approx(0.0, abs=1e-9)
    q = static_state(sy)[:3]
    np.testing.assert_allclose(fe, [300.0, 0.0, -f[1] * r22] + sy.K @ sy.preload_state(), rtol=1e-9, atol=1e-9)
    assert sy.K[0, 0] == 5e4 and sy.K[1, 1] == 0 and sy.K[2, 2] == 5e4
    assert np.all(np.isfinite(q))


def test_idler_mode_shapes_are_those_of_the_dissertation(idler):
    """Section 4.2.1: mode 1 low, gears 1 and 3 in phase with the idler out of phase (the train turning against the
    shafts, energy in the shafts); mode 2 gears 1 and 3 out of phase, the idler small; mode 3 all in phase."""
    mr = modal_analysis(idler)
    f = mr.natural_frequencies_Hz
    assert mr.rigid_body_modes == 0 and len(f) == 3
    s1, s2, s3 = mr.mode_shapes.T
    assert np.sign(s1[0]) == np.sign(s1[2]) != np.sign(s1[1])
    assert np.sign(s2[0]) != np.sign(s2[2]) and abs(s2[1]) < 0.5 * max(abs(s2[0]), abs(s2[2]))
    assert np.sign(s3[0]) == np.sign(s3[1]) == np.sign(s3[2])
    # mode 1: the strain energy is in the shafts
    phi = idler.modal_shapes[:, np.argsort(idler.modal_omega)[0]]
    e_shaft = 0.5 * phi @ idler.K @ phi
    e_mesh = 0.5 * phi @ ((idler.V.T * idler.mesh_stiffness_N_per_m) @ idler.V) @ phi
    assert e_shaft > e_mesh
    assert f[0] < 0.3 * f[1]


def test_chain_with_a_decoupled_third_gear_reproduces_the_spur_pair():
    """Gear 3 behind a mesh of vanishing stiffness that carries a constant force: gears 1 and 2 see exactly the
    spur pair's loads, so the first mesh responds as the spur pair does (to the steady-state detection tolerance,
    1e-5 of the static deflection per Poincare sample)."""
    tab = spur_fdf_table(tip_relief_m=20e-6)
    p = params(teeth=tuple(tab.teeth), base_radius_m=tuple(tab.base_radius_m))
    pair = spur_pair_system(p, tab)
    rb1, rb2 = p.base_radius_m
    f2 = p.static_force_N  # the force the wheel passes on
    weak = linear_fdf_table(1e-2, teeth=(28, 28), base_radius_m=(rb2, rb2), offset_mean_m=-f2 / 1e-2 + 1e-4,
                            x_max_m=1e-3, name="m23")
    gears = [TrainGear("gear1", 28, 1.6, p.inertia_kg_m2[0]), TrainGear("gear2", 28, 2.1, p.inertia_kg_m2[1]),
             TrainGear("gear3", 28, 1.0, 0.01)]
    meshes = [TrainMesh("m12", "gear1", "gear2", tab, (0.0, 1.0), (rb1, -rb2), 0.0, f2, {}),
              TrainMesh("m23", "gear2", "gear3", weak, (0.0, -1.0), (-rb2, rb2), 0.3, f2, {})]
    chain = assemble(fixed_axis_train("chain", "idler_chain", gears, meshes, torque_Nm=p.torque_Nm,
                                      input_gear="gear1", modal_damping_ratio=p.modal_damping_ratio))
    assert chain.natural_frequencies_Hz()[-1] == pytest.approx(pair.natural_frequencies_Hz()[0], rel=1e-6)
    for fm in (1500.0, 2600.0):
        a = steady_state(pair, fm)
        b = steady_state(chain, fm)
        for k in ("rms_deflection_m", "mean_deflection_m", "peak_force_N", "contact_loss_fraction"):
            assert b.metrics[k][0] == pytest.approx(a.metrics[k][0], rel=1e-4, abs=1e-12), k
        assert b.metrics["peak_force_N"][1] == pytest.approx(f2, rel=1e-6)


def test_idler_sweeps_softening_regions_superharmonics_and_contact_loss(idler):
    """Fig. 4.7 at 300 N*m on gear 1: double-valued regions near 1800 and 3400 Hz (jump-up on the up sweep, jump-down
    on the down sweep), contact loss in both meshes on the upper branch near 3400 Hz, super-harmonic resonances at
    1/2 and 1/3 of the natural frequencies."""
    fm = np.concatenate([np.arange(1400.0, 2000.1, 30.0), np.arange(3100.0, 4000.1, 30.0)])
    r = run_sweep(SweepSpec(idler, tuple(fm), "both"), progress=False)
    conf = [j for j in r.jumps if j.confirmed]
    for centre in (1800.0, 3400.0):
        near = [j for j in conf if abs(j.frequency_Hz - centre) < 0.15 * centre]
        ups = [j.frequency_Hz for j in near if j.kind == "jump-up" and j.branch == "up"]
        downs = [j.frequency_Hz for j in near if j.kind == "jump-down" and j.branch == "down"]
        assert ups and downs, (centre, [(j.mesh, j.kind, j.branch, j.frequency_Hz) for j in conf])
        assert min(downs) < max(ups)  # a double-valued region
        assert min(downs) <= 1.1 * centre and max(ups) >= 0.9 * centre  # ... that overlaps centre +-10 %
    down = r.branches["down"]
    sel = (down.mesh_frequency_Hz > 3300) & (down.mesh_frequency_Hz < 3500)
    assert np.all(down.metrics["contact_loss_fraction"][sel].max(axis=0) > 0.05)  # both meshes
    # super-harmonic resonances: RMS peaks of the up sweep within 5 % of f_n/2 and f_n/3 (modes 2 and 3)
    fn = idler.natural_frequencies_Hz()[1:]
    f2 = np.arange(500.0, 1800.0, 20.0)
    up = run_sweep(SweepSpec(idler, tuple(f2), "up"), progress=False).branches["up"]
    rms = up.metrics["rms_deflection_m"].max(axis=1)
    peaks = [f2[i] for i in range(1, len(f2) - 1) if rms[i] >= rms[i - 1] and rms[i] > rms[i + 1]]
    for target in (fn[0] / 2, fn[0] / 3, fn[1] / 2, fn[1] / 3):
        assert min(abs(p - target) / target for p in peaks) < 0.05, (target, peaks)


def test_idler_root_strain_superposes_both_meshes(idler):
    """The idler's tooth is loaded on its drive side by m12 and on its coast side by m23: the followed tooth's strain
    is the sum of both meshes' strain-deflection functions at its pair phase in each mesh."""
    sim = Simulator(idler)
    sim.set_speed_input(mesh_frequency_Hz=300.0)
    z = 33
    rec = sim.run(z / 300.0, 1.0 / (300.0 * 32))  # one revolution of the idler
    tau, x = rec["mesh_position"], rec["mesh_deflection_m"]
    eps = strain_of_tooth(idler, "gear2/SG25", tau, x)
    m12, m23 = idler.meshes
    parts = []
    for k, c in enumerate((m12, m23)):
        ph = ((tau[:, k] - c.tooth_passage["gear2"] + 0.5 * z) % z) - 0.5 * z
        parts.append(c.table.sdf("gear2/SG25", ph, x[:, k]))
    np.testing.assert_allclose(eps, parts[0] + parts[1], rtol=1e-12, atol=1e-15)
    # the drive-side gauge is pulled when m12 loads that side and pushed when m23 loads the other side
    assert parts[0].max() > 1e-4 and parts[1].min() < -1e-5
    t12 = tau[np.argmax(parts[0]), 0] - m12.tooth_passage["gear2"]
    t23 = tau[np.argmin(parts[1]), 1] - m23.tooth_passage["gear2"]
    assert abs(((t12 + 16.5) % 33) - 16.5) < 1.5 and abs(((t23 + 16.5) % 33) - 16.5) < 1.5
