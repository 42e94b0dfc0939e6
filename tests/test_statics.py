"""Statics grid: the analytical reference solver against closed forms, the grid rules, and the runner
(serial, process pool, Dask, SIGKILL + resume)."""
from __future__ import annotations

import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from _procs import session_processes, wait_for_no_orphans
from hacgear_core.errors import ModelError, SolverError, TableError
from hacgear_core.statics import (
    AnalyticFactory,
    AnalyticPairSolver,
    MeshStaticSolver,
    StaticSolution,
    compute_statics,
    deflection_grid,
    describe_solver,
    load_grid,
    nominal_mesh_forces,
    run_statics,
)

REPO = Path(__file__).resolve().parent.parent
MODEL = REPO / "models" / "spur_28t_asym" / "model.toml"
F_NOM = 300.0 / (0.07 * math.cos(math.radians(25.0)))  # 300 N m on the 28-tooth pinion, 25 deg flank


@pytest.fixture(scope="module")
def solver() -> AnalyticPairSolver:
    return AnalyticPairSolver.spur_28t()


# ----------------------------------------------------------------------------------------------
# analytical reference solver
# ----------------------------------------------------------------------------------------------
def test_follows_protocol(solver):
    assert isinstance(solver, MeshStaticSolver)
    info = describe_solver(solver)
    assert info.tooth_offsets == (-2, -1, 0, 1, 2)
    assert info.gauge_names == ("pinion/SG25", "wheel/SG25", "wheel/SG20")
    assert solver.contact_ratio == pytest.approx(1.45, abs=0.01)  # Table 3.3, 25 deg side


def test_single_pair_at_pitch_point_closed_form(solver):
    # p = 0: only pair 0 at the pitch point (middle of the symmetric path, no relief): x = c0 F + F/k0 + C_h F^(2/3)
    for F in (100.0, F_NOM, 3 * F_NOM):
        sol = solver.solve_load(0.0, F)
        expect = (solver.blank_compliance_m_per_N * F + F / solver.pair_stiffness_N_per_m
                  + solver.hertz_compliance_m_per_N23 * F ** (2 / 3))
        assert sol.success
        assert sol.mesh_deflection_m == pytest.approx(expect, rel=1e-10)
        np.testing.assert_allclose(sol.tooth_load_N, [0, 0, F, 0, 0], atol=1e-9 * F)
        # Hertz line contact: p_max = 2F/(pi a b) and a^2 = 4 F R / (pi b E*)
        rho = solver.base_radius_m[0] * math.tan(solver._alpha)
        e_star = solver.youngs_modulus_Pa / (2 * (1 - solver.poisson_ratio ** 2))
        a = math.sqrt(4 * F * (rho / 2) / (math.pi * solver.face_width_m * e_star))
        assert sol.half_width_m[2] == pytest.approx(a, rel=1e-12)
        assert sol.peak_pressure_Pa[2] == pytest.approx(2 * F / (math.pi * a * solver.face_width_m), rel=1e-12)
        assert sol.contact_roll_deg[2] == pytest.approx(math.degrees(math.tan(solver._alpha)), rel=1e-12)
        assert np.all(np.isnan(sol.contact_roll_deg[[0, 1, 3, 4]]))


def test_mesh_stiffness_order_of_magnitude(solver):
    sol = solver.solve_load(0.0, F_NOM)
    k = F_NOM / sol.mesh_deflection_m
    assert 1.4e8 < k < 1.8e8  # single pair ~1.6e8 N/m (DESIGN.md)


@pytest.mark.parametrize("p", [0.0, 0.13, 0.31, 0.5, 0.62, 0.97])
def test_load_and_deflection_control_are_inverse(solver, p):
    for F in (50.0, F_NOM, 3 * F_NOM):
        s1 = solver.solve_load(p, F)
        s2 = solver.solve_deflection(p, s1.mesh_deflection_m)
        assert s2.mesh_force_N == pytest.approx(F, rel=1e-9)
        np.testing.assert_allclose(s2.tooth_load_N, s1.tooth_load_N, rtol=1e-7, atol=1e-7 * F)
        assert s2.tooth_load_N.sum() == pytest.approx(s2.mesh_force_N, rel=1e-12)
        hub = s2.hub_reaction
        assert hub["pinion"][2] == pytest.approx(-s2.mesh_force_N * solver.base_radius_m[0], rel=1e-12)
        assert hub["pinion"][1] == pytest.approx(-hub["wheel"][1])


def test_periodic_with_offset_shift(solver):
    for p in (0.1, 0.45, 0.8):
        a = solver.solve_deflection(p, 40e-6)
        b = solver.solve_deflection(p + 1.0, 40e-6)
        assert b.mesh_force_N == pytest.approx(a.mesh_force_N, rel=1e-12)
        np.testing.assert_allclose(b.tooth_load_N[1:], a.tooth_load_N[:-1], rtol=1e-10, atol=1e-9)
        assert solver.no_load_deflection(p + 1.0) == pytest.approx(solver.no_load_deflection(p), abs=1e-18)


def test_nlmd_is_tip_relief(solver):
    plain = AnalyticPairSolver.spur_28t(tip_relief_m=(0.0, 0.0))
    ps = np.linspace(0, 1, 41)
    assert all(plain.no_load_deflection(p) == 0.0 for p in ps)
    nl = np.array([solver.no_load_deflection(p) for p in ps])
    assert nl.min() == 0.0 and nl.max() > 5e-6
    # at p = 0.5 the two pairs sit symmetrically at s = ±pb/2: gap = relief of one tip at that roll distance
    s = 0.5 * solver._pb
    rho_a = solver._L[0] + s
    u = (rho_a - solver._rho_relief[0]) / (solver._rho_tip[0] - solver._rho_relief[0])
    assert solver.no_load_deflection(0.5) == pytest.approx(47e-6 * u ** 2, rel=1e-12)


def test_double_contact_region_widens_with_load(solver):
    ps = np.arange(200) / 200
    counts = []
    for F in (0.2 * F_NOM, F_NOM, 3 * F_NOM):
        n2 = sum(np.count_nonzero(solver.solve_load(p, F).tooth_load_N > 1e-6 * F) >= 2 for p in ps)
        counts.append(n2 / ps.size)
    assert counts[0] < counts[1] < counts[2]
    plain = AnalyticPairSolver.spur_28t(tip_relief_m=(0.0, 0.0), overrun_gap_curvature_per_m=1e6)
    n2 = sum(np.count_nonzero(plain.solve_load(p, 10.0).tooth_load_N > 1e-6) >= 2 for p in ps) / ps.size
    assert n2 == pytest.approx(plain.contact_ratio - 1, abs=0.011)  # unmodified, light load: ICR - 1


def test_force_monotone_in_deflection(solver):
    xs = np.linspace(-5e-6, 150e-6, 120)
    for p in (0.0, 0.3, 0.5, 0.77):
        f = np.array([solver.solve_deflection(p, x).mesh_force_N for x in xs])
        assert np.all(np.diff(f) >= 0)
        assert np.all(f[xs <= solver.no_load_deflection(p)] == 0)


def test_bad_parameters_name_the_field():
    with pytest.raises(ModelError, match="center_distance_m"):
        AnalyticPairSolver.spur_28t(center_distance_m=0.1)
    with pytest.raises(ModelError, match="stiffness_drop"):
        AnalyticPairSolver.spur_28t(stiffness_drop=0.9)
    with pytest.raises(ModelError, match="base_radius_m"):
        AnalyticPairSolver.spur_28t(teeth=(28, 29))
    sol = AnalyticPairSolver.spur_28t().solve_load(0.2, -1.0)
    assert not sol.success and "mesh force" in sol.message


def test_from_model_matches_preset():
    from hacgear_core.kinds import load_model

    a = AnalyticPairSolver.from_model(load_model(MODEL), "m12")
    b = AnalyticPairSolver.spur_28t()
    assert a.contact_ratio == pytest.approx(b.contact_ratio, rel=1e-12)
    assert a.solve_load(0.37, F_NOM).mesh_deflection_m == pytest.approx(b.solve_load(0.37, F_NOM).mesh_deflection_m,
                                                                        rel=1e-12)
    assert set(a.gauge_names) == {"pinion/SG25", "pinion/SG20", "wheel/SG25", "wheel/SG20"}


# ----------------------------------------------------------------------------------------------
# grid rules
# ----------------------------------------------------------------------------------------------
def test_deflection_grid_rule():
    nl = np.array([2e-6, 0.0, 5e-6])
    sd = np.array([[2e-6, 30e-6], [0.0, 40e-6], [5e-6, 35e-6]])
    g = deflection_grid(nl, sd, 10, margin=0.5)
    dx = g[1] - g[0]
    np.testing.assert_allclose(np.diff(g), dx, rtol=1e-12)
    assert g[0] < nl.min() and g[1] == pytest.approx(0.0, abs=1e-18)
    assert g[-1] == pytest.approx(40e-6 * 1.5)
    g2 = deflection_grid(nl - 1e-6, sd, 10, margin=0.0)  # a negative NLMD moves the base below zero
    assert g2[1] == pytest.approx(-1e-6) and g2[-1] == pytest.approx(40e-6)
    with pytest.raises(ModelError, match="deflections"):
        deflection_grid(nl, sd, 3)
    with pytest.raises(SolverError, match="NaN"):
        deflection_grid(nl, sd * np.nan, 10)
    # coast side: ideal flanks touch at the backlash, the grid starts one step below min(backlash, NLMD)
    jn = 400e-6
    g3 = deflection_grid(nl + jn, sd + jn, 10, margin=0.5, contact_deflection_m=jn)
    assert g3[1] == pytest.approx(jn) and g3[-1] == pytest.approx(jn + 40e-6 * 1.5)
    g4 = deflection_grid(nl + jn - 1e-6, sd + jn, 10, margin=0.0, contact_deflection_m=jn)
    assert g4[1] == pytest.approx(jn - 1e-6)


def test_region_keys_and_sides(tmp_path):
    from hacgear_core.statics import region_key, region_mesh

    assert (region_key("m12"), region_key("m12", "coast")) == ("m12", "m12/coast")
    assert region_mesh("m12/coast") == ("m12", "coast") and region_mesh("m12") == ("m12", "drive")
    with pytest.raises(ModelError, match="side"):
        region_key("m12", "back")
    with pytest.raises(ModelError, match="region key 'm12/coast'"):   # a coast side needs its drive side
        run_statics({"m12/coast": AnalyticFactory()}, tmp_path / "t.h5", n_positions=4, n_deflections=8,
                    loads_N={"m12/coast": load_grid(1e3, 3)}, workers=1, progress=False)
    with pytest.raises(SolverError, match="side 'drive'"):              # the factory must build a coast solver
        run_statics({"m12": AnalyticFactory(), "m12/coast": AnalyticFactory()}, tmp_path / "t.h5", n_positions=4,
                    n_deflections=8, loads_N={"m12": load_grid(1e3, 3), "m12/coast": load_grid(1e3, 3)}, workers=1,
                    progress=False)
    shutil.copy(MODEL, tmp_path / "model.toml")
    with pytest.raises(ModelError, match="sides"):
        compute_statics(tmp_path / "model.toml", solver="analytic", sides=("coast",), workers=1, progress=False)
    rep = compute_statics(tmp_path / "model.toml", tmp_path / "one.h5", positions=4, loads=3, deflections=8,
                          solver="analytic", sides=("drive",), workers=1, progress=False)
    assert set(rep.meshes) == {"m12"} and rep.tasks_computed == 8


def test_load_grid_and_nominal_forces():
    np.testing.assert_allclose(load_grid(300.0, 4), [0, 100, 200, 300])
    with pytest.raises(ModelError, match="loads"):
        load_grid(1.0, 1)
    M = SimpleNamespace
    chain = M(kind="idler_chain", operating=M(torque_Nm=100.0, torque_gear="a"), planetary=None,
              meshes=[M(name="m1", gear_a="a", gear_b="b"), M(name="m2", gear_a="b", gear_b="c")])
    f = nominal_mesh_forces(chain, {"m1": (0.02, 0.03), "m2": (0.025, 0.04)})
    assert f["m1"] == pytest.approx(100 / 0.02)
    assert f["m2"] == pytest.approx(f["m1"] * 0.03 / 0.025)  # torque balance of the idler b
    # the train's torque flow shares the torque among the planets of a [planetary] section
    planet = M(kind="idler_chain", operating=M(torque_Nm=90.0, torque_gear="sun"), planetary=M(planet_count=3),
               meshes=[M(name="sp", gear_a="sun", gear_b="p"), M(name="rp", gear_a="ring", gear_b="p")])
    f = nominal_mesh_forces(planet, {"sp": (0.03, 0.02), "rp": (0.1, 0.02)})
    assert f["sp"] == pytest.approx(1000.0) and f["rp"] == pytest.approx(1000.0)


# ----------------------------------------------------------------------------------------------
# runner
# ----------------------------------------------------------------------------------------------
def _loads(n: int = 6) -> dict:
    return {"m12": load_grid(3 * F_NOM, n)}


def _datasets(path: Path) -> tuple[dict, dict]:
    data, attrs = {}, {}
    with h5py.File(path, "r") as f:
        attrs["/"] = {k: v for k, v in f.attrs.items() if k != "created"}

        def visit(name, obj):
            attrs[name] = dict(obj.attrs)
            if isinstance(obj, h5py.Dataset):
                data[name] = obj[()]
        f.visititems(visit)
    return data, attrs


def _assert_same_file(a: Path, b: Path) -> None:
    da, aa = _datasets(a)
    db, ab = _datasets(b)
    assert sorted(da) == sorted(db)
    for k in da:
        assert da[k].dtype == db[k].dtype and da[k].shape == db[k].shape, k
        np.testing.assert_array_equal(da[k], db[k], err_msg=k)
    assert sorted(aa) == sorted(ab)
    for k in aa:
        assert sorted(aa[k]) == sorted(ab[k]), k
        for n in aa[k]:
            np.testing.assert_array_equal(aa[k][n], ab[k][n], err_msg=f"{k}@{n}")


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("serial") / "tables.h5"
    rep = run_statics({"m12": AnalyticFactory()}, out, n_positions=12, n_deflections=16, loads_N=_loads(),
                      workers=1, progress=False, model_sha256="abc")
    assert rep.success and rep.tasks_computed == 24 and rep.tasks_resumed == 0
    assert rep.meshes["m12"]["fdf_max_decrease_N"] == 0.0
    assert not out.with_name("tables.h5.partial").exists()
    return out


def test_process_pool_equals_serial(serial_run, tmp_path):
    out = tmp_path / "t.h5"
    run_statics({"m12": AnalyticFactory()}, out, n_positions=12, n_deflections=16, loads_N=_loads(), workers=2,
                progress=True, model_sha256="abc")
    _assert_same_file(serial_run, out)


def test_dask_cluster_executor_equals_serial(serial_run, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cl, \
            distributed.Client(cl) as client:
        out = tmp_path / "t.h5"
        rep = run_statics({"m12": AnalyticFactory()}, out, n_positions=12, n_deflections=16, loads_N=_loads(),
                          executor=client.get_executor(), progress=False, model_sha256="abc")
        assert rep.tasks_computed == 24
    _assert_same_file(serial_run, out)


def test_resume_complete_partial_and_mismatch(serial_run, tmp_path):
    out = tmp_path / "t.h5"
    partial = tmp_path / "t.h5.partial"
    shutil.copy(serial_run, partial)
    with h5py.File(partial, "r+") as f:  # pretend positions 3..11 of phase 2 never finished
        f["meshes/m12/done_deflections"][3:] = 0
        f["meshes/m12/force_N"][3:] = np.nan
    rep = run_statics({"m12": AnalyticFactory()}, out, n_positions=12, n_deflections=16, loads_N=_loads(),
                      workers=1, progress=False, model_sha256="abc")  # resume is the default
    assert (rep.tasks_computed, rep.tasks_resumed) == (9, 15)
    _assert_same_file(serial_run, out)
    again = run_statics({"m12": AnalyticFactory()}, out, n_positions=12, n_deflections=16, loads_N=_loads(),
                        workers=1, progress=False, model_sha256="abc", resume=True)
    assert (again.tasks_computed, again.tasks_resumed) == (0, 24) and "nothing to do" in again.message
    shutil.copy(serial_run, partial)
    with pytest.raises(TableError, match=r"interrupted run \(24 position task\(s\) done\).*load_N.*--fresh"):
        run_statics({"m12": AnalyticFactory()}, out, n_positions=12, n_deflections=16, loads_N=_loads(7),
                    workers=1, progress=False, model_sha256="abc")
    with pytest.raises(TableError, match="model_values_sha256"):
        run_statics({"m12": AnalyticFactory()}, out, n_positions=12, n_deflections=16, loads_N=_loads(),
                    workers=1, progress=False, model_sha256="abc", model_values='{"other": 1}')
    assert partial.exists()  # refused, never replaced silently
    # another model file with the same values (a comment, the damping...) continues the partial file
    rep = run_statics({"m12": AnalyticFactory()}, out, n_positions=12, n_deflections=16, loads_N=_loads(),
                      workers=1, progress=False, model_sha256="def", resume=True)
    assert rep.tasks_computed == 0 and "resumed t.h5.partial: 24 position task(s) already done" in rep.message
    # --fresh (resume=False) discards it and says so
    shutil.copy(serial_run, partial)
    rep = run_statics({"m12": AnalyticFactory()}, out, n_positions=12, n_deflections=16, loads_N=_loads(7),
                      workers=1, progress=False, model_sha256="abc", resume=False)
    assert rep.tasks_computed == 24 and "discarded t.h5.partial (24 position task(s) done)" in rep.message


class _FailingFactory:
    """Solver that fails at one position (a non-converged contact solve)."""

    def __call__(self):
        return _Failing()


class _Failing(AnalyticPairSolver):
    def __init__(self):
        super().__init__(**{k: getattr(AnalyticPairSolver.spur_28t(), k) for k in AnalyticPairSolver.__dataclass_fields__})

    def solve_deflection(self, position, x):
        if abs(position - 0.5) < 1e-9:
            return StaticSolution(False, "did not converge", 99, position, math.nan, x, *([np.full(5, np.nan)] * 4))
        return super().solve_deflection(position, x)


@pytest.mark.parametrize("workers", [1, 2])
def test_solver_failure_is_reported_and_resumable(tmp_path, workers):
    out = tmp_path / "t.h5"
    with pytest.raises(SolverError, match=r"position 0\.5 \(index 4\).*did not converge"):
        run_statics({"m12": _FailingFactory()}, out, n_positions=8, n_deflections=10, loads_N=_loads(4),
                    workers=workers, progress=False)
    assert not out.exists()
    with h5py.File(out.with_name("t.h5.partial"), "r") as f:
        assert f["meshes/m12/done_loads"][()].all()
        done = f["meshes/m12/done_deflections"][()]
        assert done[4] == 0 and (workers > 1 or done[:4].all())
    # the solver is fixed: resume computes only what is missing
    rep = run_statics({"m12": AnalyticFactory()}, out, n_positions=8, n_deflections=10, loads_N=_loads(4),
                      workers=1, progress=False, resume=True)
    assert rep.tasks_computed == 8 - int(done.sum())


def test_partial_file_killed_during_creation_starts_again(tmp_path):
    out = tmp_path / "t.h5"
    with h5py.File(tmp_path / "t.h5.partial", "w") as f:  # a layout interrupted half-way
        f.attrs["format"] = "hacgear-tables"
        f.create_group("meshes/m12")
    rep = run_statics({"m12": AnalyticFactory()}, out, n_positions=4, n_deflections=8, loads_N=_loads(3),
                      workers=1, progress=False, resume=True)
    assert rep.tasks_computed == 8 and "interrupted while being created" in rep.message


def test_cli_refuses_small_torque_factor(tmp_path):
    shutil.copy(MODEL, tmp_path / "model.toml")
    with pytest.raises(ModelError, match="max_torque_factor"):
        compute_statics(tmp_path / "model.toml", solver="analytic", max_torque_factor=2.0, workers=1, progress=False)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_sigkill_midway_leaves_no_workers_and_rerun_resumes_equal_to_uninterrupted(tmp_path):
    """A real `hacgear statics --workers 2` process (both sides of the mesh) is SIGKILLed (the main process only,
    as `kill -9 PID` does) in the middle of the coast side's phase 2: its worker processes must end by themselves
    within seconds; running the same command again (no flag) continues the partial file, says so, computes
    exactly the positions not flagged done, and the result equals an uninterrupted run, both sides."""
    model = tmp_path / "model.toml"
    shutil.copy(MODEL, model)
    grid = ["--positions", "32", "--loads", "16", "--deflections", "64"]
    ref = compute_statics(model, tmp_path / "ref.h5", positions=32, loads=16, deflections=64, solver="analytic",
                          workers=1, progress=False)
    assert ref.tasks_computed == 128 and set(ref.meshes) == {"m12", "m12/coast"}
    out = tmp_path / "tables.h5"
    partial = tmp_path / "tables.h5.partial"
    cmd = [sys.executable, "-c", "import sys; from hacgear_core.cli import main; sys.exit(main())", "statics", str(model), "--solver", "analytic",
           "--workers", "2", "--no-progress", *grid]
    proc = subprocess.Popen(cmd, cwd=tmp_path, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    t0 = time.monotonic()
    workers_seen = []
    try:
        while time.monotonic() - t0 < 120 and proc.poll() is None:
            time.sleep(0.02)
            if not partial.exists():
                continue
            try:
                with h5py.File(partial, "r", locking=False) as f:
                    n2 = int(f["meshes/m12/coast/done_deflections"][()].sum())
            except (OSError, KeyError):
                continue
            if n2 >= 6:
                workers_seen = [p for p, _ in session_processes(proc.pid) if p != proc.pid]
                os.kill(proc.pid, signal.SIGKILL)
                break
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        orphans = wait_for_no_orphans(proc.pid)
    assert proc.returncode == -signal.SIGKILL, proc.stderr.read().decode()
    assert len(workers_seen) >= 2, "the pool's worker processes were not seen"
    assert not orphans, f"processes left behind by the killed run: {orphans}"
    assert partial.exists() and not out.exists()
    with h5py.File(partial, "r") as f:
        done_at_kill = sum(int(f[f"meshes/{r}/{d}"][()].sum()) for r in ("m12", "m12/coast")
                           for d in ("done_loads", "done_deflections"))
        coast_done = int(f["meshes/m12/coast/done_deflections"][()].sum())
    assert 64 + 6 <= done_at_kill < 128 and 6 <= coast_done < 32
    cmd[cmd.index("--workers") + 1] = "1"  # the resumed run in-process (cheaper; the pool ran above)
    res = subprocess.run(cmd + ["--json"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    import json

    rep = json.loads(res.stdout)
    assert f"resumed tables.h5.partial: {done_at_kill} position task(s) already done" in rep["message"]
    assert rep["tasks_resumed"] == done_at_kill
    assert rep["tasks_computed"] == 128 - done_at_kill
    _assert_same_file(tmp_path / "ref.h5", out)
    with h5py.File(out, "r") as f:
        assert f["meshes/m12"].attrs["side"] == "drive" and f["meshes/m12/coast"].attrs["side"] == "coast"
    again = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert "already complete for these settings; nothing to do" in again.stdout
    fresh = subprocess.run(cmd + ["--fresh", "--positions", "8"], cwd=tmp_path, capture_output=True, text=True,
                           timeout=300)
    assert fresh.returncode == 0 and "32 position task(s) computed" in fresh.stdout, fresh.stderr


def test_worker_pool_ends_when_its_parent_is_killed(tmp_path):
    """hacgear_core.workers.process_pool: a parent killed with SIGKILL leaves no workers (a plain
    ProcessPoolExecutor leaves them waiting forever)."""
    script = (
        "import os, sys, time\n"
        "from hacgear_core.workers import process_pool\n"
        "ex = process_pool(2, start_method=sys.argv[1])\n"
        "print(sum(ex.map(abs, range(-4, 4))), flush=True)\n"
        "time.sleep(60)\n")
    for method in ("spawn", "fork", "forkserver"):
        proc = subprocess.Popen([sys.executable, "-c", script, method], start_new_session=True,
                                stdout=subprocess.PIPE, text=True)
        try:
            assert proc.stdout.readline().strip() == "16"
            assert len(session_processes(proc.pid)) >= 3  # parent + 2 workers (+ helpers)
        finally:
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait(timeout=30)
            orphans = wait_for_no_orphans(proc.pid)
        assert not orphans, f"{method}: processes left behind: {orphans}"


def test_a_killed_pool_leaves_no_leaked_semaphore_warning():
    """After kill -9 of a process that ran a pool, multiprocessing's resource tracker cleaned up the pool's
    semaphores and printed 'There appear to be 5 leaked semaphore objects to clean up at shutdown' on the user's
    terminal; the tracker is now started quiet about a clean-up that succeeded."""
    script = (
        "import os, signal, sys, time\n"
        "from hacgear_core.workers import process_pool\n"
        "ex = process_pool(2, start_method='spawn')\n"
        "print(sum(ex.map(abs, range(-4, 4))), flush=True)\n"
        "futs = [ex.submit(time.sleep, 30) for _ in range(2)]\n"
        "time.sleep(1)\n"
        "os.kill(os.getpid(), signal.SIGKILL)\n")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert r.returncode == -signal.SIGKILL
    assert "leaked semaphore" not in r.stderr and "resource_tracker" not in r.stderr, r.stderr


@pytest.mark.slow
def test_fe_contact_solver_small_grid(tmp_path):
    """The real FE contact solver through the grid: process pool equals serial, monotone FDF, the FDF
    reproduces the load-control results."""
    pytest.importorskip("hacgear_core.statics.contact")
    model = tmp_path / "model.toml"
    shutil.copy(MODEL, model)
    a = compute_statics(model, tmp_path / "a.h5", positions=8, loads=4, deflections=16, workers=1, progress=False)
    b = compute_statics(model, tmp_path / "b.h5", positions=8, loads=4, deflections=16, workers=2, progress=False)
    _assert_same_file(tmp_path / "a.h5", tmp_path / "b.h5")
    s = a.meshes["m12"]
    assert s["fdf_max_decrease_N"] < 1e-6 * s["force_max_N"]
    assert s["fdf_reproduces_static_rel_err"] < 0.05
    # two phases (loads, then deflections) x 8 positions x both sides (the model's coast flanks have tables too)
    assert b.tasks_computed == b.tasks_total == 2 * 8 * 2


def test_partial_file_in_use_by_another_process_is_not_touched(tmp_path):
    out = tmp_path / "t.h5"
    partial = tmp_path / "t.h5.partial"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import h5py, sys, time\n"
        f"f = h5py.File({str(partial)!r}, 'w'); f.attrs['x'] = 1; f.flush()\n"
        "print('ready', flush=True); time.sleep(60)\n")], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "ready"
        for resume in (False, True):
            with pytest.raises(TableError, match="open in another process"):
                run_statics({"m12": AnalyticFactory()}, out, n_positions=4, n_deflections=8, loads_N=_loads(3),
                            workers=1, progress=False, resume=resume)
        assert partial.exists()
    finally:
        holder.kill()
        holder.wait()


@pytest.mark.parametrize("system", ["spur_28t_asym", "spur_50t_icr137", "spur_50t_icr18"])
def test_committed_tables_agree_with_a_coarse_regeneration(tmp_path, system):
    """The committed models/<system>/tables.h5 (>= 64 positions, both sides) belong to their model file, and a
    coarse regeneration with the current solver agrees with them where the grids coincide, drive and coast side:
    static deflection per (position, load) and NLMD exactly at shared positions (same loads), the FDF at the
    committed (position, deflection) nodes by interpolation of the coarse deflection grid."""
    pytest.importorskip("hacgear_core.statics.contact")
    from hacgear_core.kinds import load_model
    from hacgear_core.tables import load_system_tables, read_tables

    root = Path(__file__).resolve().parent.parent / "models" / system
    committed = load_system_tables(root / "model.toml")          # refuses a table of another model
    model = load_model(root / "model.toml")
    mesh = model.meshes[0].name
    ref = committed.meshes[mesh]
    assert len(ref.position) >= 64
    n_loads = len(ref.load_N)
    shutil.copy(root / "model.toml", tmp_path / "model.toml")
    compute_statics(tmp_path / "model.toml", tmp_path / "coarse.h5", positions=8, loads=n_loads, deflections=48,
                    workers=1, progress=False)
    coarse_d = read_tables(tmp_path / "coarse.h5", tmp_path / "model.toml").meshes[mesh]
    step = len(ref.position) // 8
    for ref, coarse in ((ref, coarse_d), (ref.require_coast(), coarse_d.require_coast())):
        np.testing.assert_allclose(coarse.load_N, ref.load_N, rtol=1e-12)
        # deflections relative to where ideal flanks touch (0 drive, the normal backlash coast)
        x_k = 0.0 if ref.side == "drive" else ref.backlash_normal_m
        scale = float(np.max(ref.static_deflection_m)) - x_k
        np.testing.assert_allclose(coarse.static_deflection_m, ref.static_deflection_m[::step], atol=1e-3 * scale)
        np.testing.assert_allclose(coarse.no_load_deflection_m, ref.no_load_deflection_m[::step], atol=1e-3 * scale)
        # FDF: compare at committed deflection nodes inside both grids, 2 % of the largest force
        x = ref.deflection_m
        inside = (x >= coarse.deflection_m[0]) & (x <= coarse.deflection_m[-1])
        for ic in range(8):
            f_ref = ref.force_N[ic * step, inside]
            f_coarse = np.interp(x[inside], coarse.deflection_m, coarse.force_N[ic])
            np.testing.assert_allclose(f_coarse, f_ref, atol=0.02 * float(ref.force_N.max()))
