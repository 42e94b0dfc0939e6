"""Mesh laws (hacgear_core.dynamics.laws): a system that mixes spur and helical meshes runs the generalized (twist)
law, its spur meshes on their tables lifted to a constant twist axis with zero twist vectors; the lift changes
nothing: the spur reducer on the twist law equals itself on the table law."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.dynamics.laws import TableLaw, TwistTableLaw
from hacgear_core.kinds import kind_of, load_model
from hacgear_core.kinds.assembly import assemble
from hacgear_core.model import resolve_model_path
from hacgear_core.tables import load_system_tables

SPUR = "reducer_19_71_23_83"


@pytest.fixture(scope="module")
def pair():
    """The spur reducer assembled as shipped (table law) and with every coupling given a zero twist vector (so the
    system takes the twist law and lifts the spur tables)."""
    path = resolve_model_path(SPUR)
    model, tables = load_model(path), load_system_tables(path)
    train = kind_of(model).train(model, tables)
    twisted = dataclasses.replace(train, couplings=tuple(dataclasses.replace(c, t=(), law="twist") for c in train.couplings))
    return assemble(train), assemble(twisted)


def test_spur_meshes_on_the_twist_law_are_lifted_with_zero_twist(pair):
    table_sy, twist_sy = pair
    assert isinstance(table_sy.mesh_law, TableLaw) and isinstance(twist_sy.mesh_law, TwistTableLaw)
    assert twist_sy.mesh_law.coast and twist_sy.m_kernel == 2 * twist_sy.m
    assert not np.any(twist_sy.T) and not np.any(twist_sy.Tc)
    assert all(c.table.twist is not None for c in twist_sy.mesh_law.meshes)
    assert all(c.table.twist is None for c in twist_sy.meshes)   # the system keeps its own tables


@pytest.mark.parametrize("tau_ref", [0.0, 0.4, 33.3])
def test_static_equilibrium_is_the_same_on_both_laws(pair, tau_ref):
    a, b = (static_equilibrium(sy, tau_ref) for sy in pair)
    np.testing.assert_allclose(b.mesh_forces_N, a.mesh_forces_N, rtol=1e-12)
    np.testing.assert_allclose(b.q, a.q, rtol=1e-10, atol=1e-12 * np.max(np.abs(a.q)))
    assert np.all(b.twist_moment_Nm == 0.0)


@pytest.mark.parametrize("fm", [1190.0, 2600.0])
def test_a_run_is_the_same_on_both_laws(pair, fm):
    """Both flanks, both stages at their own rates, one system period (71 reference mesh cycles) from the static
    equilibrium, undamped (longer undamped runs near a resonance amplify the rounding differences): the twist loop (4 kernel meshes: the coast sides as meshes 2, 3) gives the table loop's run
    (mesh forces, deflections and positions within 1e-9 of their range: the lookups round alike, the loops'
    operation orders differ)."""
    out = []
    for sy in pair:
        # undamped: the two laws linearise the spur tables their own way (below), so their modal damping matrices
        # differ by 5e-5; without damping the runs differ only by rounding
        sy = sy.with_changes(modal_damping_ratio=0.0)
        s = np.concatenate([static_equilibrium(sy, 0.0).q, np.zeros(sy.n)])
        kin = np.array([0.0, 0.0, sy.reference_speed(fm)])
        nsp = 256
        ro = np.zeros((71 * 8, sy.record_width))
        sy.integrate(s, kin, 71 * nsp, 1.0 / (fm * nsp), sy.fext_speed(), rec_every=nsp // 8,
                     rec_state=np.zeros((71 * 8, 2 * sy.n)), rec_out=ro)
        f = sy.record_fields(ro)
        out.append({k: np.asarray(f[k])[:, :sy.m] for k in ("mesh_force_N", "mesh_deflection_m", "mesh_position")})
    a, b = out
    for k in a:
        np.testing.assert_allclose(b[k], a[k], rtol=0, atol=1e-9 * np.ptp(a[k]), err_msg=k)
    assert np.ptp(a["mesh_force_N"][:, 1]) > 0.05 * np.mean(a["mesh_force_N"][:, 1])   # a dynamic run


def test_the_twist_law_linearises_a_lifted_spur_mesh_by_its_generalized_stiffness(pair):
    """The table law's linearised mesh stiffness and the twist law's (cycle mean of dW/dx at the static deflection,
    :func:`hacgear_core.tables.fdf.generalized_stiffness`) are two readings of one table: within 0.5 %, and so the
    natural frequencies within 0.1 %."""
    a, b = pair
    np.testing.assert_allclose(b.mesh_stiffness_N_per_m, a.mesh_stiffness_N_per_m, rtol=5e-3)
    np.testing.assert_allclose(b.natural_frequencies_Hz(), a.natural_frequencies_Hz(), rtol=1e-3)
