"""Tests of the level-2 direct model (hacgear_core.studies.direct_elastic): its static limit is the static solver,
without body modes it is level 1, and at a low mesh frequency the elastic bodies stay quasi-static."""
from __future__ import annotations

import numpy as np
import pytest

from hacgear_core.studies.direct import DirectEquations, SolverMeshForce, contact_load, integrate_direct
from hacgear_core.studies.direct_elastic import (ElasticMesh, _load, elastic_equations, initial_state)
from hacgear_core.cli.inputs import load_inputs
from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry
from hacgear_core.statics.bodymodes import BodyModeOptions, gear_body_modes
from hacgear_core.statics.contact import make_mesh_solver
from hacgear_core.statics.fe import MeshOptions

MODEL = "models/spur_28t_asym/model.toml"
COARSE = MeshOptions(flank_size_m=1.2e-3, fillet_size_m=1.0e-3, body_size_m=6e-3)
GAUGE = "pinion/SG25"


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("HACGEAR_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))   # both (identical) gears: one solve
    inp = load_inputs(MODEL)
    solver = make_mesh_solver(inp.model, "m12", fe_options=COARSE)
    gears = {g.name: g for g in inp.model.gears}
    modes = []
    for name, fc in zip(solver.gear_names, solver.compliance):
        g = gears[name]
        modes.append(gear_body_modes(gear_geometry(g), g.material, g.material.density_kg_per_m3, fc,
                                     BodyModeOptions(max_frequency_Hz=13e3)))
    mp.undo()
    return inp.system, solver, tuple(modes)


def test_static_limit_is_the_static_solver(setup):
    """Modes at their quasi-static value q = phi^T F / omega^2: the level-2 contact (residual compliance + modal
    gap) gives the static solver's forces and root strains (done-when: 0.5 %; by construction: round-off)."""
    system, solver, modes = setup
    em = ElasticMesh(solver, modes, 0.02)
    assert em.n_modes == (3, 3)
    worst_f = worst_e = 0.0
    for pos in (0.05, 0.37, 0.81):
        for x in (18e-6, 32e-6):
            st0 = solver.state_deflection(pos, x)
            Ps = em.candidate_modes(solver.setup(pos))
            q = np.concatenate([(P @ st0.force_N) / om ** 2 for P, om in zip(Ps, em._omega)])
            st, Q, _ = em.contact(pos, x, q)
            worst_f = max(worst_f, abs(st.mesh_force_N / st0.mesh_force_N - 1))
            eps0 = float(np.max(solver.strains(st0, st0.setup.pairs[1:-1])[GAUGE]))
            worst_e = max(worst_e, abs(em.root_strain(st, q, Q, GAUGE) / eps0 - 1))
            # the modes carry a real share of the approach: without the modal gap the force is far off
            dC = -sum((P / om[:, None] ** 2).T @ P for P, om in zip(Ps, em._omega))
            st_bad = solver.state_deflection(pos, x, compliance_offset_m_N=dC)
            assert st_bad.mesh_force_N > 1.05 * st0.mesh_force_N
    assert worst_f < 1e-9 and worst_e < 1e-9


def test_without_modes_level2_is_level1(setup):
    """No body modes: the same solver calls and RK4 as level 1 (studies/direct.py), to round-off."""
    system, solver, modes = setup
    em = ElasticMesh(solver, tuple(m.truncated(0) for m in modes), 0.02)
    eqs2, _ = elastic_equations(system, em)
    eqs1 = DirectEquations.from_system(system)
    s0 = np.concatenate([system.preload_state(), np.zeros(system.n)])
    fm, nsp = 2000.0, 64
    h = 1.0 / (fm * nsp)
    s1, _, tr1 = integrate_direct(eqs1, contact_load(eqs1, [SolverMeshForce(solver)]), s0, mesh_frequency_Hz=fm,
                                  n_steps=6, h=h)
    s2, _, tr2 = integrate_direct(eqs2, _load(eqs2, em, system.n, [0]), initial_state(eqs2, em, s0, system.n),
                                  mesh_frequency_Hz=fm, n_steps=6, h=h)
    assert np.allclose(tr2.mesh_force_N, tr1.mesh_force_N, rtol=1e-12, atol=0)
    assert np.allclose(s2, s1, rtol=1e-12, atol=1e-20)


def test_low_speed_bodies_stay_quasi_static(setup):
    """Mesh frequency 10x below the first body mode, modes started quasi-static: the level-2 mesh force follows
    level 1 within 0.2 % (force) and 0.1 % (deflection): the modes follow the contact quasi-statically."""
    system, solver, modes = setup
    f1 = modes[0].frequency_Hz[0]
    fm = f1 / 10.0
    h = 5.0e-6
    eqs1 = DirectEquations.from_system(system)
    # start in static equilibrium of this solver at the nominal force (rotations share the deflection)
    v = eqs1.V[0]
    x0 = solver.state_load(float(eqs1.phase[0]), float(system.nominal_forces_N()[0])).mesh_deflection_m
    s0 = np.concatenate([v * x0 / (v @ v), np.zeros(system.n)])
    em = ElasticMesh(solver, modes, 0.02)
    eqs2, _ = elastic_equations(system, em)
    n = 32
    _, _, tr1 = integrate_direct(eqs1, contact_load(eqs1, [SolverMeshForce(solver)]), s0, mesh_frequency_Hz=fm,
                                 n_steps=n, h=h)
    _, _, tr2 = integrate_direct(eqs2, _load(eqs2, em, system.n, [0]), initial_state(eqs2, em, s0, system.n),
                                 mesh_frequency_Hz=fm, n_steps=n, h=h)
    f1_, f2_ = tr1.mesh_force_N[:, 0], tr2.mesh_force_N[:, 0]
    x1, x2 = tr1.mesh_deflection_m[:, 0], tr2.mesh_deflection_m[:, 0]
    # measured: 0.08 % (force), 0.02 % (deflection) over 32 steps
    assert np.max(np.abs(f2_ - f1_)) < 2e-3 * np.max(f1_)
    assert np.max(np.abs(x2 - x1)) < 1e-3 * np.max(x1)
    assert np.all(np.isfinite(tr2.state))


def test_coupled_mass_and_validation(setup):
    """The hub-mode coupling keeps the coupled mass symmetric positive definite and the gear inertia unchanged;
    a sliced face coupling is refused."""
    system, solver, modes = setup
    em = ElasticMesh(solver, modes, 0.02)
    eqs, rot = elastic_equations(system, em)
    assert eqs.n == system.n + 6
    assert np.allclose(eqs.M, eqs.M.T)
    assert np.allclose(eqs.M[:system.n, :system.n], system.M)
    assert np.min(np.linalg.eigvalsh(eqs.M)) > 0
    with pytest.raises(ModelError, match="damping_ratio"):
        ElasticMesh(solver, modes, 1.5)


def test_free_hub_frequency_closed_form_and_step_rule(setup):
    """One mode per gear, free hubs: the hub-against-body frequency is omega_1 sqrt(J / (J - L^2)) (the
    coupled mass [[J, L], [L, 1]] against diag(0, omega^2)); run_level2's step keeps omega h <= max_omega_h."""
    import math

    from hacgear_core.studies.direct_elastic import Level2Options, highest_frequency_Hz

    system, solver, modes = setup
    em = ElasticMesh(solver, tuple(m.truncated(1) for m in modes), 0.02)
    eqs, rot = elastic_equations(system, em)
    J = system.M[rot[0], rot[0]]
    L = modes[0].rotation_participation[0] * math.sqrt(solver.face_width_m)
    f_expected = modes[0].frequency_Hz[0] * math.sqrt(J / (J - L * L))
    assert highest_frequency_Hz(eqs) == pytest.approx(f_expected, rel=1e-9)
    assert f_expected > 3 * modes[0].frequency_Hz[0]        # the hub keeps little of the gear's inertia
    opt = Level2Options(steps_per_cycle=8)
    fm = 2000.0
    nsp = max(opt.steps_per_cycle, math.ceil(f_expected * 2 * math.pi / (opt.max_omega_h * fm)))
    assert 2 * math.pi * f_expected / (fm * nsp) <= opt.max_omega_h
