"""Design studies (hacgear_core.studies, `hacgear study`): study files and key paths, the variant model files,
resumable results, a Dask cluster giving the same numbers as the local pool, failing variants, and the tip-relief
physics on the shipped example study."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

from hacgear_core.cpu import VectorUnits
from hacgear_core.errors import GeometryError, ModelError
from hacgear_core.geometry.gear import gear_geometry
from hacgear_core.model import shipped_systems, resolve_model_path
from hacgear_core.kinds import load_model
from hacgear_core.model.toml_writer import dumps as dump_toml
from hacgear_core.studies import apply_key, load_study, parse_study, read_study, run_study
from hacgear_core.studies.design import variant_model_text
from hacgear_core.workers import executor_slots

from _procs import kill_when, session_processes

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "studies" / "spur_28t_asym_relief.toml"
EXAMPLE_RESULTS = ROOT / "docs" / "studies" / "spur_28t_asym_relief.h5"

#: the example study on the analytical reference solver and a small grid (seconds per variant)
QUICK = """
[study]
name = "quick"
base_model = "spur_28t_asym"

[[variables]]
key = "gears[*].drive.tip_relief_um"
values = {relief}

[statics]
positions = 16
loads = 8
deflections = 24
solver = "analytic"

[static]
torques_Nm = [100.0, 200.0, 300.0, 400.0, 500.0]

[dynamic]
torque_Nm = 300.0
mesh_frequency_Hz = [2000.0, 3200.0, {speeds}]
max_cycles = 1500
"""


def _quick(tmp_path: Path, relief=(0.0, 30.0, 60.0), speeds: int = 5, name: str = "quick.toml") -> Path:
    p = tmp_path / name
    p.write_text(QUICK.format(relief=list(relief), speeds=speeds))
    return p


def _datasets(path: Path) -> dict:
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name != "tables_file":
                out[name] = obj[()]
        f.visititems(visit)
    return out


def _assert_same_results(a: Path, b: Path) -> None:
    da, db = _datasets(a), _datasets(b)
    assert set(da) == set(db)
    for k in da:
        x, y = da[k], db[k]
        if x.dtype.kind == "f":
            assert np.array_equal(x, y, equal_nan=True), k
        else:
            assert np.array_equal(x, y), k


# ------------------------------------------------------------------------------------------------ study files
@pytest.mark.parametrize("system", shipped_systems())
def test_dump_toml_round_trips_every_shipped_model(system):
    raw = tomllib.loads(resolve_model_path(system).read_text())
    assert tomllib.loads(dump_toml(raw, "a header")) == raw


def test_key_paths_select_gears_by_star_name_and_index():
    raw = tomllib.loads(resolve_model_path("spur_28t_asym").read_text())
    assert apply_key(raw, "gears[*].drive.tip_relief_um", 10.0) == 2
    assert [g["drive"]["tip_relief_um"] for g in raw["gears"]] == [10.0, 10.0]
    assert apply_key(raw, "gears[wheel].lead_crowning_um", 5.0) == 1
    assert [g["lead_crowning_um"] for g in raw["gears"]] == [15.0, 5.0]
    assert apply_key(raw, "gears[0].coast.tip_relief_um", 1.0) == 1 and raw["gears"][0]["coast"]["tip_relief_um"] == 1
    assert apply_key(raw, "operating.torque_Nm", 123.0) == 1 and raw["operating"]["torque_Nm"] == 123.0
    for key, msg in (("gears.drive.tip_relief_um", r"array of tables; select"),
                     ("gears[idler].drive.tip_relief_um", r"no element named 'idler'"),
                     ("gears[*].web.thickness_mm", r"no table 'gears.web'"),
                     ("gears[*].drive", r"is a table, not a numeric key"),
                     ("system.name", r"is not numeric"),
                     ("gears[*].drive.tip relief", r"segment 'tip relief'")):
        with pytest.raises(ModelError, match=msg):
            apply_key(raw, key, 1.0)


def test_study_file_errors_name_the_key_unit_and_range(tmp_path):
    ok = QUICK.format(relief=[0.0], speeds=3)
    spec = parse_study(ok)
    assert len(spec.variants) == 1 and spec.frequencies_Hz() == [2000.0, 2600.0, 3200.0]
    for bad, msg in ((ok.replace("torques_Nm = [100.0", "torques_Nm = [-100.0"), r"\[static\] torques_Nm \[N\*m\]"),
                     (ok.replace('solver = "analytic"', 'solver = "magic"'), r"solver = 'magic'; allowed: fe"),
                     (ok.replace("positions = 16", "positions = 1"), r"positions \[-\] = 1; allowed: integer 2"),
                     (ok.replace("[dynamic]", "[dynamic]\nspeed = 3"), r"unknown key\(s\) \['speed'\]"),
                     (ok.replace("values = [0.0]", "values = [0.0, 0.0]"), r"values repeat"),
                     (ok.replace("3200.0, 3]", "3200.0, 0]"), r"mesh_frequency_Hz \[Hz\]"),
                     (ok.replace("torque_Nm = 300.0", "torque_Nm = 300.0\ntorques_Nm = [200.0]"),
                      r"\[dynamic\] torque_Nm and torques_Nm \[N\*m\] exclude each other"),
                     (ok.replace("torque_Nm = 300.0", "torques_Nm = [300.0, 300.0]"),
                      r"\[dynamic\] torques_Nm \[N\*m\] = \[300.0, 300.0\]; allowed: a non-empty list of distinct "
                      r"torques"),
                     # descending: every variant failed with 'frequencies differ from the study's'
                     (ok.replace("[2000.0, 3200.0, 3]", "[3200.0, 2000.0, 3]"),
                      r"mesh_frequency_Hz \[Hz\] = \[3200.0, 2000.0, 3\]; allowed: \[start, stop, count\]: start <= "
                      r"stop"),
                     (ok.replace("[2000.0, 3200.0, 3]", "[2000.0, 3200.0, 1]"), r"count >= 1 \(1: start = stop\)"),
                     (ok + "\n[load_spectrum]\ntorques_Nm = [100.0, 200.0]\nweights = [0.3, 0.5]\n",
                      r"weights \[-\] = \[0.3, 0.5\]; allowed: one time share >= 0 per torque, the shares summing "
                      r"to 1")):
        with pytest.raises(ModelError, match=msg):
            parse_study(bad, file="s.toml")


def test_variant_model_file_sets_the_variables_and_the_study_grid():
    spec = load_study(EXAMPLE)
    assert len(spec.variants) == 5
    text, base = variant_model_text(spec, (15.0,))
    assert base == resolve_model_path("spur_28t_asym")
    raw = tomllib.loads(text)
    assert [g["drive"]["tip_relief_um"] for g in raw["gears"]] == [15.0, 15.0]
    assert [g["coast"]["tip_relief_um"] for g in raw["gears"]] == [52.0, 52.0]  # untouched
    assert raw["statics"]["positions"] == 64 and raw["statics"]["deflections"] == 48


def test_geometry_refuses_relief_and_crowning_that_leave_no_tip():
    gear = load_model("spur_28t_asym").gears[0]
    from dataclasses import replace

    s_tip = gear_geometry(gear).tip_thickness_m
    flank = replace(gear.flanks["drive"], tip_relief_m=1e-3)
    crown = 0.5 * (s_tip - 1e-3 - gear.flanks["coast"].tip_relief_m)      # 0.98 mm: relief + crowning = s_tip
    with pytest.raises(GeometryError, match=r"remove more than the tooth thickness at the tip circle"):
        gear_geometry(replace(gear, flanks={**gear.flanks, "drive": flank}, lead_crowning_m=crown + 1e-7))
    gear_geometry(replace(gear, flanks={**gear.flanks, "drive": flank}, lead_crowning_m=crown - 1e-7))  # a tooth


# ------------------------------------------------------------------------------------------------ runs
def test_quick_study_harris_map_and_relief_lowers_the_resonance(tmp_path):
    """The analytical reference solver's tables: without relief the STE p-p grows with torque from the start (the
    premature contact of the unrelieved tips adds to it), each relief has its own design load where STE p-p is
    smallest and that load grows with the relief (the Harris map); near the main resonance the relieved pair's
    force dynamic factor is lower."""
    spec = load_study(_quick(tmp_path))
    rep = run_study(spec, tmp_path / "q.h5", workers=1, progress=False)
    assert [v.status for v in rep.variants] == ["computed"] * 3
    res = read_study(tmp_path / "q.h5")
    ste = res.static["ste_peak_to_peak_m"]
    assert np.all(np.diff(ste[0]) > 0)                       # no relief: rises with torque
    best_torque = res.torque_Nm[np.argmin(ste, axis=1)]
    assert best_torque[0] < best_torque[1] <= best_torque[2]
    assert ste[1, 2] < 0.6 * ste[0, 2]                       # 30 um at 300 N*m: far below no relief
    df = np.fmax(res.dynamic["up"]["dynamic_factor_force"],
                 res.dynamic["down"]["dynamic_factor_force"]).max(axis=(1, 2))
    assert df[1] < df[0] and df[2] < df[0]
    k = res.static["mean_mesh_stiffness_N_per_m"]
    assert np.all((k > 5e7) & (k < 1e9))
    assert np.all(res.static["max_root_strain"] > 0) and np.all(np.diff(res.static["max_root_strain"], axis=1) > 0)
    # a second run reuses every finished variant; --fresh recomputes the results on the same tables
    again = run_study(spec, tmp_path / "q.h5", workers=1, progress=False)
    assert [v.status for v in again.variants] == ["reused"] * 3
    fresh = run_study(spec, tmp_path / "q.h5", workers=1, progress=False, fresh=True)
    assert [(v.status, v.tables_reused) for v in fresh.variants] == [("computed", True)] * 3
    _assert_same_results(tmp_path / "q.h5", tmp_path / "q.h5")


def test_sweeps_at_several_torques_run_as_batched_lanes(tmp_path, monkeypatch):
    """``[dynamic] torques_Nm``: each variant is swept at every torque; its 4 branches (2 torques x up/down) run as
    the lanes of one batched task (``workers = 1``) and the rows at 300 N*m equal, bit for bit, those of the study
    swept at 300 N*m alone (serial, single-state kernel).  The peak root strain is the strain dynamic factor times
    the static peak strain at each torque; the best variant by the sweeps' peak root strain is taken over both
    torques; a sweep torque beyond a variant's tables fails that variant, naming the torque and the range."""
    import hacgear_core.dynamics.sweep as sweep_module
    from hacgear_core.studies import best_variants

    one = load_study(_quick(tmp_path, relief=(0.0, 45.0), speeds=4, name="one.toml"))
    run_study(one, tmp_path / "one.h5", workers=1, progress=False)
    two_file = tmp_path / "two.toml"
    two_file.write_text(QUICK.format(relief=[0.0, 45.0], speeds=4).replace("torque_Nm = 300.0",
                                                                            "torques_Nm = [200.0, 300.0]"))
    two = load_study(two_file)
    assert two.dynamic_torques_Nm(123.0) == [200.0, 300.0] and one.dynamic_torques_Nm(123.0) == [300.0]
    calls = []

    def spy(system, lanes, width=None, **kw):
        calls.append((len(lanes), width))
        return run_lanes(system, lanes, width, **kw)

    run_lanes = sweep_module.run_lanes
    monkeypatch.setattr(sweep_module, "run_lanes", spy)
    # the planner batches by default on CPUs with vectors of 4+ float64 (AVX and wider): seen as one here
    monkeypatch.setattr(sweep_module, "vector_units", lambda: VectorUnits("test-avx2", ("avx2", "fma"), 4))
    rep = run_study(two, tmp_path / "two.h5", workers=1, progress=False)
    assert calls == [(4, 4), (4, 4)]                     # per variant: its 4 branches as one batched task
    assert [v.status for v in rep.variants] == ["computed"] * 2
    a, b = read_study(tmp_path / "one.h5"), read_study(tmp_path / "two.h5")
    assert a.dynamic_torque_Nm.tolist() == [[300.0]] * 2 and b.dynamic_torque_Nm.tolist() == [[200.0, 300.0]] * 2
    for br in ("up", "down"):
        for m, v in b.dynamic[br].items():
            assert v.shape == (2, 2, 4)
            assert np.array_equal(v[:, 1], a.dynamic[br][m][:, 0], equal_nan=True), (br, m)
    assert [j[1] for j in b.jumps] == [j[0] for j in a.jumps]
    # strain: dynamic factor x static peak strain at the sweep's torque (the static rows hold it at 200 and 300)
    i200, i300 = (int(np.flatnonzero(b.torque_Nm == t)[0]) for t in (200.0, 300.0))
    for d, it in ((0, i200), (1, i300)):
        np.testing.assert_allclose(b.dynamic["up"]["peak_root_strain"][:, d],
                                   b.dynamic["up"]["dynamic_factor_strain"][:, d]
                                   * b.static["max_root_strain"][:, it][:, None], rtol=1e-12)
    best = best_variants(b)["sweep_max_peak_root_strain"]
    worst = np.fmax(b.dynamic["up"]["peak_root_strain"], b.dynamic["down"]["peak_root_strain"]).max(axis=(1, 2))
    assert best["values"] == worst.tolist() and best["index"] == int(np.argmin(worst))
    # beyond the tables (operating 300 N*m x max_torque_factor 3 = 900 N*m)
    high = tmp_path / "high.toml"
    high.write_text(QUICK.format(relief=[45.0], speeds=2).replace("torque_Nm = 300.0", "torques_Nm = [300.0, 950.0]"))
    with pytest.raises(ModelError, match=r"every variant fails .* \[dynamic\] torque 950 N\*m lies beyond the load "
                                         r"range of the variant's tables, 0 … 900 N\*m"):   # its only variant: the study's
        run_study(load_study(high), tmp_path / "high.h5", workers=1, progress=False)


def test_dask_local_cluster_gives_the_local_pool_results_bit_for_bit(tmp_path):
    distributed = pytest.importorskip("distributed")
    spec = load_study(_quick(tmp_path, relief=(0.0, 45.0), speeds=3))
    run_study(spec, tmp_path / "pool.h5", workers=2, progress=False)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        ex = client.get_executor()
        assert executor_slots(ex) == 2               # the cluster's threads: the sweeps size batched tasks by it
        rep = run_study(spec, tmp_path / "dask.h5", executor=ex, progress=False)
    assert [v.status for v in rep.variants] == ["computed"] * 2
    assert not any(v.tables_reused for v in rep.variants)       # own tables folder: computed on the cluster
    _assert_same_results(tmp_path / "pool.h5", tmp_path / "dask.h5")


def test_scheduler_without_dask_names_the_missing_package(tmp_path, monkeypatch):
    import hacgear_core.cli.study as cli_study

    monkeypatch.setitem(sys.modules, "distributed", None)      # import fails as if not installed
    with pytest.raises(ModelError, match=r"--scheduler needs the optional package dask\[distributed\]"):
        cli_study.dask_executor("tcp://127.0.0.1:8786")


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_killed_study_reruns_without_recomputing_finished_variants(tmp_path):
    """`hacgear study` SIGKILLed after its first variant is written: the rerun reuses that variant (and says so),
    computes the others, and the file equals an uninterrupted run's."""
    study = _quick(tmp_path, relief=(0.0, 20.0, 40.0), speeds=7)
    ref = run_study(load_study(study), tmp_path / "ref.h5", workers=1, progress=False)
    assert all(v.status == "computed" for v in ref.variants)
    out = tmp_path / "s.h5"
    cmd = [sys.executable, "-c", "import sys; from hacgear_core.cli import main; sys.exit(main())", "study", str(study),
           "--out", str(out), "--tables-dir", str(tmp_path / "tables"), "--workers", "1", "--no-progress"]
    proc = subprocess.Popen(cmd, cwd=tmp_path, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)

    def first_variant_written() -> bool:
        if not out.exists():
            return False
        with h5py.File(out, "r", locking=False) as f:
            return bool(f["status"][0] == 1)

    orphans = kill_when(proc, first_variant_written)
    assert proc.returncode == -signal.SIGKILL, proc.stderr.read().decode()
    assert not orphans, orphans
    with h5py.File(out, "r") as f:
        at_kill = f["status"][()]
    assert at_kill[0] == 1 and at_kill[2] == 0, at_kill
    mtime = {p: p.stat().st_mtime_ns for p in (tmp_path / "tables").rglob("tables_*.h5")}
    res = subprocess.run(cmd + ["--json"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    rep = json.loads(res.stdout)
    assert rep["variants"][0]["status"] == "reused" and rep["variants_reused"] == int(np.sum(at_kill == 1))
    assert rep["variants_computed"] == 3 - rep["variants_reused"]
    for p, t in mtime.items():                              # finished variants' tables were not rewritten
        assert p.stat().st_mtime_ns == t
    _assert_same_results(tmp_path / "ref.h5", out)
    assert not session_processes(proc.pid)


def test_failing_variants_are_named_and_the_others_complete(tmp_path):
    lumped = ROOT / "examples" / "planetary_lumped.toml"
    tables = resolve_model_path("spur_28t_asym").parent / "tables.h5"
    study = QUICK.format(relief=[30.0, 1000.0, 1500.0], speeds=2).replace(
        'base_model = "spur_28t_asym"', 'base_model = "spur_28t_asym"\nmesh = "m12"') + f"""
[[variables]]
key = "gears[*].lead_crowning_um"
values = [1000.0]

[[variables]]
key = "model"
values = ["spur_28t_asym", "{lumped}", "{tables}"]
"""
    p = tmp_path / "bad.toml"
    p.write_text(study)
    spec = load_study(p)
    rep = run_study(spec, tmp_path / "bad.h5", workers=1, progress=False)
    st = {v.label: v for v in rep.variants}
    assert len(st) == 9
    good = [v for v in rep.variants if v.status == "computed"]
    assert [v.label.split(", ")[0] for v in good] == ["gears[*].drive.tip_relief_um=30"]
    spur = "model=spur_28t_asym"
    geo = st[f"gears[*].drive.tip_relief_um=1000, gears[*].lead_crowning_um=1000, {spur}"].error
    assert "tip_relief_um=1000" in geo and "remove more than the tooth thickness at the tip circle" in geo
    rng = st[f"gears[*].drive.tip_relief_um=1500, gears[*].lead_crowning_um=1000, {spur}"].error
    assert "tip_relief_um=1500" in rng and "'gears[0].drive.tip_relief_um' [um]: value 1500 out of range" in rng
    for v in rep.variants:
        if str(lumped) in v.label:
            assert v.status == "failed" and "no table 'gears.drive'" in v.error
        if str(tables) in v.label:
            assert v.status == "failed" and "is not a model file (TOML)" in v.error
    res = read_study(tmp_path / "bad.h5")
    assert res.status.tolist().count(1) == 1 and res.status.tolist().count(2) == 8
    assert all(e for e, s in zip(res.errors, res.status) if s == 2)
    # torques beyond a variant's tables: an operating torque of 50 N*m gives tables up to 150 N*m only
    low = QUICK.format(relief=[30.0], speeds=2) + (
        '\n[[variables]]\nkey = "operating.torque_Nm"\nvalues = [300.0, 50.0]\n')
    p2 = tmp_path / "low.toml"
    p2.write_text(low)
    rep2 = run_study(load_study(p2), tmp_path / "low.h5", workers=1, progress=False)
    assert [v.status for v in rep2.variants] == ["computed", "failed"]
    err = rep2.variants[1].error
    assert "operating.torque_Nm=50" in err and "static torque 200 N*m lies beyond the load range" in err
    assert "0 … 150 N*m" in err and rep2.variants[1].tables_file == ""        # refused before any table


def test_cli_study_json_and_plot(tmp_path, capsys):
    from hacgear_core.cli import main

    study = _quick(tmp_path, relief=(0.0, 30.0), speeds=3)
    out = tmp_path / "q.h5"
    assert main(["study", str(study), "--out", str(out), "--workers", "1", "--no-progress"]) == 0
    err = capsys.readouterr().err   # --no-progress: a line per stage of each variant, not silence until the end
    v1, v2 = "variant 1/2 (gears[*].drive.tip_relief_um=0)", "variant 2/2 (gears[*].drive.tip_relief_um=30)"
    for stage in (f"{v1}: tables", f"{v1}: statics: building the contact solvers", f"{v2}: sweeps over 3 speeds",
                  f"{v2}: done in"):
        assert f"hacgear study: {stage}" in err, err[-3000:]
    assert main(["plot", str(out), "--out", str(tmp_path / "map.png")]) == 0
    for name in ("map.png", "map_dynamic.png", "map_best.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    assert main(["study", str(study), "--out", str(tmp_path / "map.png"), "--no-progress"]) == 2   # not .h5
    with h5py.File(tmp_path / "tables.h5", "w") as f:                     # never written over: another kind
        f.attrs["format"] = "hacgear-tables"
    assert main(["study", str(study), "--out", str(tmp_path / "tables.h5"), "--no-progress"]) == 2
    assert "refusing to write study results into it" in capsys.readouterr().err
    assert main(["study", str(study), "--out", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["variants_reused"] == 2 and rep["best"]["spectrum_mean_ste_peak_to_peak_m"]["index"] in (0, 1)
    assert rep["variants"][1]["static"]["ste_peak_to_peak_m"][2] == read_study(out).static["ste_peak_to_peak_m"][1, 2]
    assert rep["variants"][0]["sweep_max"]["dynamic_factor_force"] >= 1.0
    # a results file of another study is kept, not overwritten
    other = _quick(tmp_path, relief=(0.0, 10.0), speeds=3, name="other.toml")
    assert main(["study", str(other), "--out", str(out), "--workers", "1", "--no-progress"]) == 2


# ------------------------------------------------------------------------------------------------ the example
def test_example_study_tip_relief_statement():
    """Dissertation chapter 3 on the shipped example's committed results (FE tables, docs/studies.md): tip relief
    removes the premature-contact peak of the transmission error (the unrelieved pair's STE p-p rises with torque
    from the lowest torque; a relieved pair has a minimum at its design load, far below) and lowers the dynamic
    response near the main resonance (the largest force dynamic factor and peak root strain of the sweep)."""
    if not EXAMPLE_RESULTS.exists():
        pytest.skip(f"{EXAMPLE_RESULTS} not generated (docs/studies.md says how)")
    res = read_study(EXAMPLE_RESULTS)
    assert res.done.all() and res.spec == load_study(EXAMPLE).canonical()
    relief = np.array(res.variables[0]["values"])
    ste = res.static["ste_peak_to_peak_m"]
    assert np.all(np.diff(ste[relief == 0][0]) > 0)
    i300 = int(np.flatnonzero(res.torque_Nm == 300.0)[0])
    assert ste[:, i300].argmin() != 0 and ste[:, i300].min() < 0.5 * ste[0, i300]
    # the premature (tip-edge) contact of the unrelieved teeth: contact pressure several times the relieved flanks'
    p = res.static["max_contact_pressure_Pa"]
    assert np.all(p[relief == 0][0] > 3.0 * p[relief >= 30].max(axis=0))
    df = np.fmax(res.dynamic["up"]["dynamic_factor_force"],
                 res.dynamic["down"]["dynamic_factor_force"]).max(axis=(1, 2))
    assert df[relief > 0].min() < df[relief == 0][0]


@pytest.mark.slow
def test_example_study_reproduces_the_committed_results(tmp_path):
    """The whole shipped example on the FE solver (about 4 min on 2 cores): every variant completes and its results
    equal the committed file's (docs/studies.md) to rounding; the statement test then holds on them."""
    from hacgear_core.cli import main

    out = tmp_path / "example.h5"
    assert main(["study", str(EXAMPLE), "--out", str(out), "--no-progress"]) == 0
    new, ref = _datasets(out), _datasets(EXAMPLE_RESULTS)
    assert set(new) == set(ref)
    for k, v in ref.items():
        if v.dtype.kind == "f":
            np.testing.assert_allclose(new[k], v, rtol=1e-6, atol=1e-12, err_msg=k)
        elif k == "dynamic/jumps_json":  # (variant, torque): each entry a JSON list of the sweep's jumps
            key = [[(j["kind"], j["branch"], j["interval_Hz"]) for j in json.loads(x)] for x in v.ravel()]
            assert new[k].shape == v.shape
            assert [[(j["kind"], j["branch"], j["interval_Hz"]) for j in json.loads(x)]
                    for x in new[k].ravel()] == key
        else:
            assert np.array_equal(new[k], v), k


def test_a_problem_of_every_variant_is_one_study_error(tmp_path):
    """A study whose every variant fails the same way before any computation (a mesh the model lacks) is refused
    once, naming the problem, before any results file is written (the error was repeated per variant); a study
    where only some variants fail still runs the others."""
    from hacgear_core.studies.design import _study_wide_problem
    bad = tmp_path / "bad.toml"
    bad.write_text(QUICK.format(relief=[0.0, 30.0], speeds=3).replace('base_model = "spur_28t_asym"',
                                                                       'base_model = "spur_28t_asym"\nmesh = "m99"'))
    spec = load_study(bad)
    assert _study_wide_problem(spec, [0, 1]).startswith("[study] mesh = 'm99' is not a mesh")
    with pytest.raises(ModelError, match=r"every variant fails before any computation with the same problem.*m99"):
        run_study(spec, tmp_path / "bad.h5", workers=1, progress=False)
    assert not (tmp_path / "bad.h5").exists()
    assert _study_wide_problem(load_study(_quick(tmp_path, relief=(0.0, 30.0), speeds=3)), [0, 1]) == ""
