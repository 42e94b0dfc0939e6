"""Tests of hacgear_core.dynamics.sweep: jumps of a softening mesh, jump detection, resume after a kill, executors."""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import re

import h5py
import numpy as np
import pytest

import hacgear_core.dynamics.sweep as sw
from _dyn import fn_rot, softening, system
from hacgear_core.dynamics.sweep import BranchResult, SweepSpec, detect_jumps, run_sweep, run_sweeps
from hacgear_core.errors import ModelError


def test_jump_up_and_down_detected_on_softening_fdf():
    p, tab = softening()
    fn = fn_rot()
    fm = np.linspace(0.6 * fn, 1.2 * fn, 25)
    r = run_sweep(SweepSpec(system(p, tab), tuple(fm), "both"), progress=False)
    conf = [j for j in r.jumps if j.confirmed]
    kinds = sorted((j.kind, j.branch) for j in conf)
    assert kinds == [("jump-down", "down"), ("jump-up", "up")]
    assert {j.mesh for j in conf} == {"linear"}
    ju = next(j for j in conf if j.kind == "jump-up").frequency_Hz
    jd = next(j for j in conf if j.kind == "jump-down").frequency_Hz
    assert jd < ju < fn  # softening: multi-valued region below the linear natural frequency
    up, down = r.branches["up"], r.branches["down"]
    assert np.all(up.converged) and np.all(down.converged)
    # inside the multi-valued region the down sweep is on the large-amplitude branch with contact loss
    f_mid = up.mesh_frequency_Hz[(up.mesh_frequency_Hz > jd) & (up.mesh_frequency_Hz < ju)]
    assert f_mid.size >= 1
    i_up = np.searchsorted(up.mesh_frequency_Hz, f_mid[0])
    i_dn = list(down.mesh_frequency_Hz).index(f_mid[0])
    assert down.metrics["rms_deflection_m"][i_dn, 0] > 1.5 * up.metrics["rms_deflection_m"][i_up, 0]
    assert down.metrics["contact_loss_fraction"][i_dn, 0] > 0


def test_detect_jumps_ignores_monotone_and_flags_unconfirmed():
    f = np.arange(5.0)
    b = BranchResult("up", f, {"rms_deflection_m": np.array([1.0, 1.1, 1.2, 1.3, 1.4])[:, None]}, *[None] * 4)
    assert detect_jumps({"up": b}) == []
    b2 = BranchResult("up", f, {"rms_deflection_m": np.array([1.0, 1.0, 3.0, 3.0, 3.0])[:, None]}, *[None] * 4)
    j = detect_jumps({"up": b2}, mesh_names=("m12",))
    assert len(j) == 1 and j[0].kind == "jump-up" and not j[0].confirmed and j[0].interval_Hz == (1.0, 2.0)
    assert j[0].mesh == "m12"


def test_resume_of_interrupted_sweep_is_identical(tmp_path, monkeypatch):
    p, tab = softening()
    fm = tuple(np.linspace(0.7 * fn_rot(), 1.0 * fn_rot(), 8))
    spec = SweepSpec(system(p, tab), fm, "up")
    ref = run_sweep(spec, out=tmp_path / "ref.h5", progress=False).branches["up"]
    real = sw.drive  # the serial sweep integrates each speed through it
    calls = {"n": 0}

    def dying(*a, **k):
        calls["n"] += 1
        if calls["n"] > 3:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(sw, "drive", dying)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(spec, out=tmp_path / "res.h5", progress=False)
    monkeypatch.setattr(sw, "drive", real)
    # a kill in the middle of writing a row leaves uncommitted data beyond attrs["rows"]: dropped
    part = next((tmp_path / "res.h5.parts").glob("*.h5"))
    with h5py.File(part, "a") as f:
        assert f.attrs["rows"] == 3
        for name in f.keys():
            f[name].resize(4, axis=0)
        f["rms_deflection_m"][3] = 123.0
    res = run_sweep(spec, out=tmp_path / "res.h5", progress=False).branches["up"]
    assert res.recomputed == 5
    for k in ref.metrics:
        np.testing.assert_array_equal(res.metrics[k], ref.metrics[k])
    np.testing.assert_array_equal(res.state, ref.state)
    again = run_sweep(spec, out=tmp_path / "res.h5", progress=False).branches["up"]
    assert again.recomputed == 0
    assert not (tmp_path / "res.h5.parts").exists()
    # an unreadable part file (killed while the file itself was being written) is moved aside
    parts = tmp_path / "bad.h5.parts"
    parts.mkdir()
    (parts / f"{spec.run_id()}_up.h5").write_bytes(b"not hdf5")
    with pytest.warns(RuntimeWarning, match="unreadable"):
        bad = run_sweep(spec, out=tmp_path / "bad.h5", progress=False).branches["up"]
    assert bad.recomputed == 8
    np.testing.assert_array_equal(bad.metrics["rms_deflection_m"], ref.metrics["rms_deflection_m"])


def test_sweeps_in_parallel_through_an_executor(tmp_path):
    p, tab = softening()
    fm = tuple(np.linspace(0.7 * fn_rot(), 1.0 * fn_rot(), 4))
    specs = [SweepSpec(system(p, tab), fm, "both", torque_Nm=t) for t in (80.0, 120.0)]
    with ThreadPoolExecutor(2) as ex:
        par = run_sweeps(specs, out=tmp_path / "p.h5", executor=ex, progress=False)
    ser = run_sweeps(specs, progress=False)
    for a, b in zip(par, ser):
        assert a.spec.system.torque_Nm in (80.0, 120.0)
        for br in ("up", "down"):
            np.testing.assert_array_equal(a.branches[br].metrics["rms_deflection_m"],
                                          b.branches[br].metrics["rms_deflection_m"])


def test_systems_travel_to_worker_processes():
    """A process pool pickles the system: the kernel is reselected on the other side, results identical."""
    import pickle

    p, tab = softening()
    sy = system(p, tab)
    sy2 = pickle.loads(pickle.dumps(sy))
    assert sy2.kernel is sy.kernel and sy2.fingerprint() == sy.fingerprint()


def _branches(f_up, up, down):
    f = np.asarray(f_up, float)
    return {"up": BranchResult("up", f, {"rms_deflection_m": np.asarray(up, float)[:, None]}, *[None] * 4),
            "down": BranchResult("down", f[::-1], {"rms_deflection_m": np.asarray(down, float)[::-1, None]},
                                 *[None] * 4)}


def test_confirmed_jumps_come_from_the_hysteresis_not_from_the_step_size():
    """On a fine grid the up branch climbs the steep flank before its fold and jumps by only 18 %: still the
    jump-up at the upper end of the multi-valued region, found where the branches rejoin."""
    f = np.arange(10.0)
    up = [1.0, 1.1, 1.2, 1.4, 1.6, 1.8, 2.0, 2.2, 2.7, 2.5]   # folds between 7 and 8 (2.2 -> 2.7: 18 %)
    down = [1.0, 1.1, 1.2, 2.9, 2.85, 2.8, 2.75, 2.72, 2.7, 2.5]  # falls between 3 and 2
    j = detect_jumps(_branches(f, up, down), mesh_names=("m12",))
    conf = sorted((x.kind, x.branch, x.interval_Hz) for x in j if x.confirmed)
    assert conf == [("jump-down", "down", (2.0, 3.0)), ("jump-up", "up", (7.0, 8.0))]
    assert not [x for x in j if not x.confirmed and x.interval_Hz == (2.0, 3.0)]  # reported once, confirmed
    # a region reaching the end of the grid has no jump at that end
    j = detect_jumps(_branches(f[:8], up[:8], down[:8]))
    assert [(x.kind, x.branch) for x in j if x.confirmed] == [("jump-down", "down")]


def test_fine_and_coarse_speed_grids_find_the_same_jumps():
    """A softening mesh swept on a 25-speed and a 121-speed grid: the same confirmed jumps, the fine grid's
    intervals inside the coarse grid's (within one coarse step)."""
    p, tab = softening()
    fn = fn_rot()
    found = {}
    for n in (25, 121):
        fm = np.linspace(0.6 * fn, 1.2 * fn, n)
        r = run_sweep(SweepSpec(system(p, tab), tuple(fm), "both"), progress=False)
        found[n] = {(j.kind, j.branch): j.interval_Hz for j in r.jumps if j.confirmed}
    assert set(found[25]) == set(found[121]) == {("jump-up", "up"), ("jump-down", "down")}
    step = 0.6 * fn / 24
    for key, (lo, hi) in found[121].items():
        clo, chi = found[25][key]
        assert clo - step <= lo and hi <= chi + step, (key, (lo, hi), (clo, chi))


def test_fine_and_coarse_grids_find_the_same_jumps_on_the_fe_tables():
    """The issue's case on the committed FE tables of spur_28t_asym at 300 N*m: 21 speeds over 2200-3200 Hz and
    ~2 Hz steps (a 15 % jump-up only) give the same confirmed jumps, within the coarse grid's 50 Hz."""
    from hacgear_core.cli.inputs import load_inputs

    sy = load_inputs("spur_28t_asym").system
    found = {}
    for fm in (np.linspace(2200.0, 3200.0, 21), np.linspace(2250.0, 2700.0, 217)):
        r = run_sweep(SweepSpec(sy, tuple(fm), "both"), progress=False)
        found[len(fm)] = {(j.kind, j.branch): j.interval_Hz for j in r.jumps if j.confirmed}
    assert set(found[21]) == set(found[217]) == {("jump-up", "up"), ("jump-down", "down")}, found
    for key, (lo, hi) in found[217].items():
        clo, chi = found[21][key]
        assert clo - 50.0 <= lo and hi <= chi + 50.0, (key, (lo, hi), (clo, chi))


def test_stability_checked_sweep_stores_the_multipliers(tmp_path):
    """With ``options.stability`` every row carries its orbit's largest Floquet multiplier: both branches of the
    softening region are stable orbits (< 1), the file holds the same numbers as the run, a plain sweep NaN."""
    from hacgear_core.dynamics.steady import SteadyStateOptions

    p, tab = softening()
    fn = fn_rot()
    fm = tuple(np.linspace(0.6 * fn, 1.2 * fn, 13))
    out = tmp_path / "s.h5"
    r = run_sweep(SweepSpec(system(p, tab), fm, "both", options=SteadyStateOptions(stability=True)), out=out,
                  progress=False)
    for b in ("up", "down"):
        mu = r.branches[b].max_multiplier
        assert mu.shape == (13,) and np.all((mu > 0) & (mu < 1))
        stored = sw.read_sweep(out, r.run_id)[b].max_multiplier
        assert np.array_equal(stored, mu)
    assert "max_multiplier" in r.to_json()["branches"]["up"]
    plain = run_sweep(SweepSpec(system(p, tab), fm[:2], "up"), progress=False)
    assert np.all(np.isnan(plain.branches["up"].max_multiplier))


@pytest.mark.parametrize("text, message", [
    ("1000:3000:1", "gives one speed but START != STOP"),
    ("3000:1000:5", "START [Hz] = 3000 > STOP = 1000"),
])
def test_fm_range_refuses_what_it_would_ignore_or_reorder(text, message):
    """`--fm 1000:3000:1` ran 1000 Hz only and `3000:1000:5` ran ascending, both silently."""
    from hacgear_core.dynamics.sweep import parse_fm
    with pytest.raises(ModelError, match=re.escape(message)):
        parse_fm(text)
    assert parse_fm("1500:1500:1").tolist() == [1500.0]
    assert parse_fm("1000:3000:3").tolist() == [1000.0, 2000.0, 3000.0]


def test_results_file_is_written_whole_and_a_stub_is_replaced(tmp_path):
    """The results file changes by one rename per finished branch: the stub a write killed at its start leaves
    (96 bytes of HDF5 superblock, which every later run refused, --fresh included) is recognised and replaced; a
    file missing a branch is named by missing_branches (the plot says so)."""
    p, tab = softening()
    spec = SweepSpec(system(p, tab), tuple(np.linspace(0.7 * fn_rot(), 1.0 * fn_rot(), 4)), "both")
    out = tmp_path / "s.h5"
    out.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(88))
    from hacgear_core.h5files import file_kind
    assert file_kind(out) == "stub"
    with pytest.warns(RuntimeWarning, match="stub of a write killed at its start"):
        res = run_sweep(spec, out=out, progress=False)
    assert sorted(sw.read_sweep(out, res.run_id)) == ["down", "up"] and sw.missing_branches(out) == {}
    assert not list(tmp_path.glob("*.writing")) and not (tmp_path / "s.h5.parts").exists()
    with h5py.File(out, "a") as f:
        del f[f"sweeps/{res.run_id}/down"]
    assert sw.missing_branches(out) == {res.run_id: ["down"]}
    again = run_sweep(spec, out=out, progress=False)   # completes the missing branch only
    assert again.branches["up"].recomputed == 0 and again.branches["down"].recomputed == 4
    assert sw.missing_branches(out) == {}


def test_a_kill_while_the_results_file_is_written_leaves_it_whole(tmp_path):
    """written_whole: a process killed inside the block (os._exit, as kill -9) leaves the target as it was and
    only the temporary file, which the next write replaces; an exception removes the temporary file."""
    import subprocess
    import sys
    from hacgear_core.outpaths import written_whole
    target = tmp_path / "r.h5"
    target.write_bytes(b"old")
    code = (f"import os\nfrom hacgear_core.outpaths import written_whole\n"
            f"with written_whole({str(target)!r}, start_from_existing=True) as t:\n"
            f"    open(t, 'ab').write(b'half')\n    os._exit(9)\n")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 9
    assert target.read_bytes() == b"old" and (tmp_path / "r.h5.writing").read_bytes() == b"oldhalf"
    with pytest.raises(ZeroDivisionError):
        with written_whole(target) as t:
            t.write_bytes(b"new")
            1 / 0
    assert target.read_bytes() == b"old" and not (tmp_path / "r.h5.writing").exists()
    with written_whole(target) as t:
        t.write_bytes(b"new")
    assert target.read_bytes() == b"new" and not (tmp_path / "r.h5.writing").exists()


def test_no_jumps_between_amplitudes_of_numerical_noise():
    """A lumped planetary sweep reported 'confirmed' jumps between two RMS amplitudes of 0.000 µm: values below
    1 nm (JUMP_FLOOR) are noise, their relative changes no jumps; the same pattern at micrometres still jumps."""
    f = np.arange(10.0)
    up = np.array([1.0, 1.1, 1.2, 1.4, 1.6, 1.8, 2.0, 2.2, 2.7, 2.5])
    down = np.array([1.0, 1.1, 1.2, 2.9, 2.85, 2.8, 2.75, 2.72, 2.7, 2.5])
    real = detect_jumps(_branches(f, 1e-6 * up, 1e-6 * down))
    assert sorted((x.kind, x.branch) for x in real if x.confirmed) == [("jump-down", "down"), ("jump-up", "up")]
    assert detect_jumps(_branches(f, 1e-12 * up, 1e-12 * down)) == []
    # tiny values beside a large response: below 1e-3 of the largest, no jump either
    big_up, big_dn = 1e-6 * up, 1e-6 * down
    big_up[:3], big_dn[:3] = [1e-12, 3e-12, 1e-12], [1e-12, 3e-12, 1e-12]
    assert not [x for x in detect_jumps(_branches(f, big_up, big_dn)) if x.interval_Hz[1] <= 2.0]
