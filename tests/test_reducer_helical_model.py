"""The reducer 19:71 | 23:83 with a helical first stage (models/reducer_helical_19_71_23_83; issue #52 item 2):
a helical and a spur mesh in one gear_train, each on its own law (the helical mesh's generalized table, the spur
mesh's force table lifted to a constant twist axis) and at its own rate.  Static torques equal the ratios times the
input torque, the helical stage carries its twist moment while the spur stage carries none, a sweep resonates where
the spur stage's mesh frequency meets the shaft mode, and the FMU equals the library with each mesh's own outputs."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from _fmu_runs import fmu_and_library_runs
from hacgear_core.cli import main
from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.dynamics.laws import TwistTableLaw
from hacgear_core.kinds import build_system, load_model
from hacgear_core.model import resolve_model_path
from hacgear_core.tables import load_system_tables

SYSTEM = "reducer_helical_19_71_23_83"


@pytest.fixture(scope="module")
def system():
    path = resolve_model_path(SYSTEM)
    return build_system(load_model(path), load_system_tables(path))


def test_a_helical_and_a_spur_stage_each_on_its_law_and_rate(system):
    assert isinstance(system.mesh_law, TwistTableLaw)
    helical, spur = system.mesh_law.meshes
    assert helical.table.twist.twist_rad.size == 5 and np.any(system.T[0])      # the generalized table
    assert spur.table.twist.twist_rad.tolist() == [-1.0, 0.0, 1.0] and not np.any(system.T[1])   # lifted
    np.testing.assert_array_equal(system.rate, [[1, 1], [23, 71]])
    assert system.period_cycles == 71
    # 6 DOFs per helical gear, u and theta per spur gear
    assert len(system.dof_names) == 16
    sp = {g: system.gears[g].speed_ratio for g in ("pinion1", "wheel1", "pinion2", "wheel2")}
    assert abs(sp["wheel1"] / sp["pinion1"]) == pytest.approx(19 / 71, rel=1e-12)
    assert abs(sp["wheel2"] / sp["pinion1"]) == pytest.approx(19 / 71 * 23 / 83, rel=1e-12)
    assert sp["wheel1"] * sp["pinion2"] > 0         # one shaft: one sense


@pytest.mark.parametrize("tau_ref", [0.0, 0.37, 40.2])
def test_static_torques_follow_the_stage_ratios(system, tau_ref):
    """The intermediate shaft twists by 200 (71/19) N m over its stiffness (the helical pair's torque ratio is its
    lever arms', r_b cos(beta_b), the tooth ratio), the output takes 200 (71/19)(83/23) N m; the helical mesh
    carries a twist moment, the spur one none."""
    eq = static_equilibrium(system, tau_ref)
    assert eq.success
    np.testing.assert_allclose(eq.mesh_forces_N, system.nominal_forces_N(), rtol=1e-6)
    g = system.gears
    k_shaft = 1.34e5    # model.toml, shaft2
    names = list(system.dof_names)
    o1 = names.index("wheel1.theta_z")
    o2 = names.index("pinion2.theta")
    torque = k_shaft * abs(eq.q[o1] * g["wheel1"].sense - eq.q[o2] * g["pinion2"].sense)
    assert torque == pytest.approx(200.0 * 71 / 19, rel=1e-6)
    assert abs(system.fext_speed()[g["wheel2"].rotation]) == pytest.approx(200.0 * 71 / 19 * 83 / 23, rel=1e-9)
    assert abs(eq.twist_moment_Nm[0]) > 0 and eq.twist_moment_Nm[1] == 0.0


def test_sweep_resonates_where_the_spur_stage_meets_the_shaft_mode(system, capsys):
    """The lowest mode (the intermediate shaft's torsion) is met by the spur stage's mesh frequency, 23/71 of the
    input mesh frequency: the m34 RMS DTE peaks within 2 % of f_1 71/23."""
    f1 = float(system.natural_frequencies_Hz()[0])
    pred = f1 * 71 / 23
    lo, hi = 0.93 * pred, 1.07 * pred
    assert main(["sweep", SYSTEM, "--fm", f"{lo:.1f}:{hi:.1f}:15", "--direction", "up", "--json",
                 "--no-progress"]) == 0
    b = json.loads(capsys.readouterr().out)["branches"]["up"]
    f = np.array(b["mesh_frequency_Hz"])
    rms = np.array(b["meshes"]["m34"]["dte_rms_m"])
    assert all(b["converged"])
    assert f[np.argmax(rms)] == pytest.approx(pred, rel=0.02)
    assert rms.max() > 1.5 * max(rms[0], rms[-1])


def test_fmu_equals_the_library_with_each_mesh_its_own_outputs(tmp_path):
    """The native FMI 2.0 FMU against the library's Simulator step for step (1e-9); the helical mesh declares its
    twist and twist moment, the spur mesh does not."""
    pytest.importorskip("fmpy")
    from fmpy import read_model_description

    speed = 2 * math.pi * 2000.0 / 19
    names = ["m12.force", "m34.force", "m12.twist_moment", "m34.position", "shaft2.torque"]

    def read(sim):
        return sim.mesh_force_N[0], sim.mesh_force_N[1], sim.twist_moment_Nm[0], sim.mesh_position[1], None
    path, res, lib = fmu_and_library_runs(SYSTEM, tmp_path, names, read, speed, 60)
    md = {v.name for v in read_model_description(str(path)).modelVariables}
    assert {"m12.twist", "m12.twist_moment"} <= md and not {"m34.twist", "m34.twist_moment"} & md
    for k in names[:-1]:
        v = np.asarray(lib[k])
        assert np.max(np.abs(res[k][1:] - v)) <= 1e-9 * np.max(np.abs(v)), k
    assert np.mean(res["shaft2.torque"]) == pytest.approx(200.0 * 71 / 19, rel=0.02)
