"""The batched kernel (hacgear_core.dynamics.batch): every lane equals the single-state kernel bit for bit — lanes at
different speeds and in different contact states (loaded, contact loss, coast-flank impacts), lane counts that are
not a multiple of the vector width, a rotating carrier with coupled supports, the conventional force law — and the
batched sweeps equal the serial ones, in this process and on a process pool, and how their branches become tasks;
a fresh process loads a compiled loop from numba's cache."""
from __future__ import annotations

import dataclasses
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from hacgear_core.dynamics import batch, kernels
from hacgear_core.dynamics.equilibrium import static_state
from hacgear_core.dynamics.batch import Lanes, batch_supported
from hacgear_core.dynamics.sweep import SweepSpec, plan_lanes, read_sweep, run_sweeps
from hacgear_core.dynamics.synthetic import linear_fdf_table
from hacgear_core.kinds import build_system, load_model
from hacgear_core.tables import load_system_tables
from hacgear_core.workers import executor_slots, process_pool

from _dyn import K, params, system

SPC = 128


@pytest.fixture(scope="module")
def spur():
    model = load_model("spur_28t_asym")
    tables = load_system_tables(model.path)
    return model, tables


def _run_both(sy, lanes, cycles, rec_every=1, width=None):
    """Integrate each lane ``(state, mesh frequency [Hz], fext)`` with the batched kernel (all lanes at once, on the
    loop compiled for ``width`` lanes: the spare ones idle, repeating lane 0 without records) and with the
    single-state kernel (one by one); return both results per lane."""
    b = batch.Lanes(sy, width or len(lanes))
    n_steps = cycles * SPC
    n_rec = n_steps // rec_every
    for j, (s, fm, fext) in enumerate(lanes):
        b.load(j, s, [0.0, 0.0, sy.reference_speed(fm)], 1.0 / (fm * SPC), fext, rec_every)
    for j in range(len(lanes), b.B):
        b.copy_lane(j, 0)
    b.run(n_steps, n_rec)
    out = []
    for j, (s0, fm, fext) in enumerate(lanes):
        s = np.array(s0, float)
        kin = np.array([0.0, 0.0, sy.reference_speed(fm)])
        rs = np.zeros((n_rec, 2 * sy.n))
        ro = np.zeros((n_rec, sy.record_width))
        sy.integrate(s, kin, n_steps, 1.0 / (fm * SPC), fext, rec_every=rec_every, rec_state=rs, rec_out=ro)
        assert int(b.nrec[j]) == n_rec
        out.append(((s, kin, rs, ro), (b.state(j).copy(), b.kin(j).copy(), b.rec_state[j, :n_rec].copy(),
                                       b.rec_out[j, :n_rec].copy())))
    return out


def _assert_lanes_equal(results):
    for single, lane in results:
        for a, c in zip(single, lane):
            assert np.array_equal(a, c)


def test_lanes_equal_single_state_kernel_in_every_contact_state(spur):
    """4-DOF spur pair on the committed FE tables, both flanks, 3 lanes (not a multiple of the vector width): a
    loaded lane at 1500 Hz, a lane whose drive flanks part at 1.5 m/s at 700 Hz (contact loss), a lane thrown across the backlash at 2500 Hz (coast-flank impacts).  Each lane equals the single-state
    kernel bit for bit: state, kinematics and every record."""
    model, tables = spur
    sy = build_system(model, tables, bearing_stiffness_N_per_m=200e6)
    assert sy.two_sided
    fext = sy.fext_speed()
    s_static = static_state(sy)
    s_coast = s_static.copy()
    v = sy.V[0]
    s_coast[:sy.n] -= (sy.backlash_m[0] + 60e-6) * v / (v @ v)   # the coast flanks pressed 60 um
    s_loss = s_static.copy()
    s_loss[sy.n:] -= 1.5 * v / (v @ v)                           # the drive flanks parting at 1.5 m/s
    lanes = [(s_static, 1500.0, fext), (s_loss, 700.0, fext), (s_coast, 2500.0, fext)]
    res = _run_both(sy, lanes, cycles=12)
    _assert_lanes_equal(res)
    f = [sy.record_fields(r[1][3]) for r in res]
    assert np.all(f[0]["mesh_force_N"] > 0) and np.all(f[0]["coast_force_N"] == 0)
    assert np.any(f[1]["mesh_force_N"] == 0)                     # contact loss
    assert np.max(f[2]["coast_force_N"]) > 1e3                   # coast-flank impact


def test_one_lane_among_idle_ones_and_drive_only_tables(spur):
    """One lane on the 4-lane loop (three idle lanes), the one-sided loop (the tables' coast sides dropped), 2-DOF
    pair: equal to the single-state kernel."""
    model, tables = spur
    drive_only = {name: dataclasses.replace(t, coast=None) for name, t in tables.meshes.items()}
    sy = build_system(model, drive_only)
    assert not sy.two_sided
    _assert_lanes_equal(_run_both(sy, [(static_state(sy), 1800.0, sy.fext_speed())], cycles=10, rec_every=SPC,
                                  width=4))


def test_rotating_carrier_coupled_supports_and_loads_per_lane():
    """Gyroscopic and centripetal terms (each lane's effective stiffness and damping at its own speed), a coupling
    spring between the supports, different external loads per lane: equal to the single-state kernel."""
    base = system(params(bearing_stiffness_N_per_m=(300e6, 250e6)), linear_fdf_table(K))
    n = base.n
    kk = base.K.copy()
    kk[0, 2] = kk[2, 0] = -80e6
    g = np.zeros((n, n))
    g[0, 2], g[2, 0] = 0.7, -0.7
    sy = base.with_changes(stiffness=kk, gyroscopic=g, centripetal=np.diag([0.9, 0.0, 1.1, 0.0]), carrier_ratio=0.4)
    s0 = static_state(base)
    s0[n:] = [0.01, 0.3, -0.02, -0.2]
    lanes = [(s0, 2000.0, sy.fext_speed()), (s0, 900.0, sy.fext_speed(150.0)), (s0, 3100.0, sy.fext_speed(40.0)),
             (static_state(base), 1300.0, sy.fext_speed()), (s0, 2600.0, sy.fext_speed(10.0))]
    _assert_lanes_equal(_run_both(sy, lanes, cycles=6, rec_every=7))


@pytest.mark.parametrize("law", ["ste", "hac"])
def test_force_laws_of_a_synthetic_pair(law):
    """The conventional law (``ste``: LAW_LINEAR) and the table law on a softening synthetic pair, four speeds."""
    xs = 100.0 / 0.0634 / K
    sy = system(params(modal_damping_ratio=0.03, torque_Nm=100.0),
                linear_fdf_table(K, offset_amplitude_m=0.2 * xs, x_max_m=6 * xs), law)
    assert sy.mesh_law.kernel_law == (kernels.LAW_LINEAR if law == "ste" else kernels.LAW_TABLE)
    lanes = [(static_state(sy), fm, sy.fext_speed()) for fm in (1100.0, 1700.0, 2300.0, 2900.0)]
    _assert_lanes_equal(_run_both(sy, lanes, cycles=8, rec_every=3))


def _assert_sweeps_equal(a, b):
    for x, y in zip(a, b):
        for br in x.branches:
            p, q = x.branches[br], y.branches[br]
            assert np.array_equal(p.state, q.state) and np.array_equal(p.cycles_run, q.cycles_run)
            for k in p.metrics:
                assert np.array_equal(p.metrics[k], q.metrics[k], equal_nan=True)
        assert [dataclasses.asdict(j) for j in x.jumps] == [dataclasses.asdict(j) for j in y.jumps]


@pytest.fixture
def wide_vectors(monkeypatch):
    """The sweeps' planner sees a CPU with AVX2 vectors (4 float64), whatever this one has: the tests of the
    default planning hold on a machine (or numba target) with SSE2 only, where it batches nothing."""
    import hacgear_core.dynamics.sweep as sweep_module
    from hacgear_core.cpu import VectorUnits
    monkeypatch.setattr(sweep_module, "vector_units", lambda: VectorUnits("test-avx2", ("avx", "avx2", "fma"), 4))


def test_batched_sweeps_equal_serial(spur, tmp_path, wide_vectors):
    """Sweeps at two torques, up and down (4 branches of one system): by default (``batched=None``) they run as the
    4 lanes of one batched task, and give the serial sweeps' rows bit for bit (continuation in each branch, records
    across calls of unequal length), jumps included; the results file holds the same rows.  Three branches with
    ``batched=True`` run on the 4-lane loop with one lane idle: the same rows again."""
    model, tables = spur
    sy = build_system(model, tables)
    fms = tuple(np.linspace(2600.0, 3600.0, 9))
    specs = [SweepSpec(sy, fms, "both", torque_Nm=t) for t in (sy.torque_Nm, 0.6 * sy.torque_Nm)]
    tasks = [(sp, b) for sp in specs for b in sp.branches]
    assert plan_lanes(tasks, None, 1) == [([0, 1, 2, 3], 4)]
    serial = run_sweeps(specs, progress=False, batched=False)
    _assert_sweeps_equal(serial, run_sweeps(specs, progress=False, out=tmp_path / "s.h5"))
    stored = read_sweep(tmp_path / "s.h5")
    for r in serial:
        for br, x in r.branches.items():
            assert np.array_equal(stored[r.run_id][br].state, x.state)
    three = specs[:1] + [SweepSpec(sy, fms, "up", torque_Nm=0.6 * sy.torque_Nm)]
    assert plan_lanes([(sp, b) for sp in three for b in sp.branches], True, 1) == [([0, 1, 2], 4)]
    part = run_sweeps(three, progress=False, batched=True)
    _assert_sweeps_equal(serial[:1], part[:1])
    up = serial[1].branches["up"]
    assert np.array_equal(part[1].branches["up"].state, up.state)


def test_batched_sweeps_on_a_process_pool(spur, wide_vectors):
    """Four torques x up/down on a pool of 2 processes: two batched tasks of 4 lanes (one per worker), the rows
    of the serial sweeps bit for bit."""
    model, tables = spur
    sy = build_system(model, tables)
    fms = tuple(np.linspace(2800.0, 3400.0, 4))
    specs = [SweepSpec(sy, fms, "both", torque_Nm=f * sy.torque_Nm) for f in (1.0, 0.8, 0.6, 0.4)]
    assert [w for _, w in plan_lanes([(sp, b) for sp in specs for b in sp.branches], None, 2)] == [4, 4]
    with process_pool(2) as ex:
        assert executor_slots(ex) == 2
        pooled = run_sweeps(specs, progress=False, executor=ex)
    _assert_sweeps_equal(run_sweeps(specs, progress=False, batched=False), pooled)


def test_plan_lanes_splits_each_system_over_the_slots(wide_vectors):
    """How the branches become tasks: per system (same kernel arrays, any torque), split over the executor's slots,
    at most 8 lanes per task, compiled lane counts 2, 4 or 8; by default only tasks of >= 4 lanes are batched; an
    executor of unknown size gets no batched tasks by default; ``batched=False`` none; helical systems none."""
    a = system(params(torque_Nm=100.0), linear_fdf_table(K))
    b = system(params(torque_Nm=100.0, bearing_stiffness_N_per_m=(300e6, 250e6)), linear_fdf_table(K))

    def tasks(sy, n):
        return [(SweepSpec(sy, (1000.0, 1100.0), "up", torque_Nm=50.0 + i), "up") for i in range(n)]

    t = tasks(a, 9)
    assert plan_lanes(t, None, 1) == [(list(range(8)), 8), ([8], 0)]
    assert plan_lanes(t, None, 2) == [([0, 1, 2, 3, 4], 8), ([5, 6, 7, 8], 4)]
    assert plan_lanes(t, None, 3) == [([i], 0) for i in range(9)]          # 3 lanes per slot: not worth it
    assert plan_lanes(t, True, 3) == [([0, 1, 2], 4), ([3, 4, 5], 4), ([6, 7, 8], 4)]
    assert plan_lanes(t, None, None) == [([i], 0) for i in range(9)]
    assert plan_lanes(t, True, None) == [(list(range(8)), 8), ([8], 0)]
    assert plan_lanes(t, False, 1) == [([i], 0) for i in range(9)]
    mixed = tasks(a, 2) + tasks(b, 4) + tasks(a, 2)
    assert plan_lanes(mixed, None, 1) == [([0, 1, 6, 7], 4), ([2, 3, 4, 5], 4)]
    helical = [(SimpleNamespace(system=SimpleNamespace(mesh_law=SimpleNamespace(kernel_law=kernels.LAW_TWIST))), "up")]
    assert plan_lanes(helical * 4, True, 1) == [([i], 0) for i in range(4)]


def test_helical_meshes_are_refused():
    with pytest.raises(ValueError, match="LAW_TABLE and LAW_LINEAR"):
        batch.select_batch_kernel(kernels.LAW_TWIST, 12, 1, False, False, 2)


def test_a_fresh_process_loads_the_batched_loop_from_the_cache():
    """Once compiled (here by the tests above: the 2-DOF pair's two-sided 4-lane loop), a batched loop is loaded
    from numba's on-disk cache by every later process, not compiled again: the loop's cache key (its closure
    variables) is the same in every process."""
    code = ("from hacgear_core.dynamics import batch\n"
            "from hacgear_core.kinds import build_system, load_model\n"
            "from hacgear_core.tables import load_system_tables\n"
            "model = load_model('spur_28t_asym')\n"
            "sy = build_system(model, load_system_tables(model.path))\n"
            "print(batch.Lanes(sy, 4).prepare()[0])\n")
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
            for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), [r.stderr[-2000:] for r in runs]
    assert runs[1].stdout.split() == ["False"], runs[1].stdout


def test_narrow_vectors_batch_nothing_by_default(monkeypatch):
    """With SSE2 only (2 float64 per vector, numba's generic target) the batched loop gained nothing (0.67-0.97 x
    the single-state speed): by default the branches then run one by one; ``batched=True`` still batches them."""
    import hacgear_core.dynamics.sweep as sweep_module
    from hacgear_core.cpu import VectorUnits
    a = system(params(torque_Nm=100.0), linear_fdf_table(K))
    t = [(SweepSpec(a, (1000.0, 1100.0), "up", torque_Nm=50.0 + i), "up") for i in range(8)]
    monkeypatch.setattr(sweep_module, "vector_units", lambda: VectorUnits("generic", ("sse2",), 2))
    assert plan_lanes(t, None, 1) == [([i], 0) for i in range(8)]
    assert plan_lanes(t, True, 1) == [(list(range(8)), 8)]
    monkeypatch.setattr(sweep_module, "vector_units", lambda: VectorUnits("test-avx512", ("avx512f",), 8))
    assert plan_lanes(t, None, 1) == [(list(range(8)), 8)]


def test_lanes_equal_the_single_state_loop_with_meshes_at_their_own_rates():
    """The reducer 19:71 | 23:83 (stage 2 at 23/71): lanes at three speeds equal the single-state loop bit for bit
    over 3 system periods (213 reference mesh cycles), records included."""
    from hacgear_core.kinds import build_system, load_model
    from hacgear_core.model import resolve_model_path
    from hacgear_core.tables import load_system_tables

    path = resolve_model_path("reducer_19_71_23_83")
    sy = build_system(load_model(path), load_system_tables(path))
    assert not sy.unit_rates and batch_supported(sy)
    speeds = [1200.0, 2600.0, 4300.0]
    nsp = 256
    lanes = Lanes(sy, len(speeds))
    ref = []
    for j, fm in enumerate(speeds):
        s0 = np.zeros(2 * sy.n)
        kin = np.array([0.0, 0.0, sy.reference_speed(fm)])
        h = 1.0 / (fm * nsp)
        lanes.load(j, s0, kin, h, sy.fext_speed(), nsp)
        s, k = s0.copy(), kin.copy()
        rs, ro = np.zeros((213, 2 * sy.n)), np.zeros((213, sy.record_width))
        sy.integrate(s, k, 213 * nsp, h, sy.fext_speed(), rec_every=nsp, rec_state=rs, rec_out=ro)
        ref.append((s, k, ro))
    lanes.run(213 * nsp, 213)
    for j, (s, k, ro) in enumerate(ref):
        np.testing.assert_array_equal(lanes.state(j), s)
        np.testing.assert_array_equal(lanes.kin(j)[:3], k[:3])
        np.testing.assert_array_equal(lanes.rec_out[j, :213], ro)
