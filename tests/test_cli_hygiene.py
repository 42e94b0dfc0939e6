"""Command-line hygiene (issues 33 items 4-7, 36 items 3-5): conflicting and ineffective options are errors, negative
values reach their option, values outside the model's own ranges are refused naming option, value and range, one
convention for a rigid bearing (inf) in model files, CLI and FMU, error messages in the file's keys, plain-text
help, and no command that writes into a file of another kind or over a finished table."""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from hacgear_core.cli import build_parser, main
from hacgear_core.kinds import structural_parameters
from hacgear_core.errors import ModelError
from hacgear_core.fmu.adapter import make_adapter
from hacgear_core.fmu.build import _fmt
from hacgear_core.kinds import load_model, parse_model
from hacgear_core.model.schema import RANGES, Support

ROOT = Path(__file__).resolve().parent.parent
SPUR = ROOT / "models" / "spur_28t_asym"


def _run(argv, capsys):
    rc = main(argv)
    out = capsys.readouterr()
    return rc, out.out, out.err


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# ------------------------------------------------------------------------------ 33.4: options
def test_torque_and_torques_exclude_each_other(capsys):
    rc, out, err = _run(["sweep", "spur_28t_asym", "--torque", "300", "--torques", "100,200", "--fm", "1000:2000:3"],
                        capsys)
    assert rc == 2 and out == ""
    assert "--torque 300 and --torques 100,200 exclude each other" in err


@pytest.mark.parametrize("argv, message", [
    (["sweep", "spur_28t_asym", "--fm", "-1000:4000:31"],
     "--fm START and STOP [Hz] = '-1000:4000:31' are out of range; allowed: (0, 100000] each"),
    (["simulate", "spur_28t_asym", "--fm", "-5"], "--fm [Hz] = -5.0 is out of range; allowed: (0, 100000]"),
    (["sweep", "spur_28t_asym", "--fm", "1000:2000:3", "--torque", "-2e9"],
     "--torque [N*m] = -2000000000.0 is out of range; allowed: magnitude (0, 1e+08], either sign"),
])
def test_a_negative_value_reaches_its_option_and_its_range_check(argv, message, capsys):
    """argparse took '-1000:4000:31' for an option ('expected one argument'); now the option gets it and says
    what range it allows."""
    rc, _, err = _run(argv, capsys)
    assert rc == 2 and message in err and "expected one argument" not in err


@pytest.mark.parametrize("option", [["--positions", "-4"], ["--loads", "8"], ["--fresh"], ["--workers", "2"],
                                    ["--solver", "analytic"], ["--max-torque-factor", "4"]])
def test_statics_check_refuses_options_it_would_ignore(option, capsys):
    rc, out, err = _run(["statics", "spur_28t_asym", "--check", *option], capsys)
    assert rc == 2 and out == ""
    assert f"hacgear statics: error: {option[0]}: no effect with --check" in err


def test_ignore_model_hash_needs_check(capsys):
    rc, _, err = _run(["statics", "spur_28t_asym", "--ignore-model-hash", "--positions", "8"], capsys)
    assert rc == 2 and "--ignore-model-hash applies to --check only" in err


def _parsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return [parser] + list(sub.choices.values())


_MARKUP = re.compile(r"``|:(func|mod|class|meth|data|attr):`|%%")


def test_help_is_plain_text():
    """No reStructuredText (double backquotes, roles) and no literal '%%' in any --help of hacgear, build_fmu.py or
    the examples."""
    for p in _parsers():
        text = p.format_help()
        assert not _MARKUP.search(text), f"{p.prog}: {_MARKUP.search(text).group(0)!r} in --help"
    scripts = [ROOT / "build_fmu.py"] + sorted((ROOT / "examples").glob("*.py"))
    for script in scripts:
        r = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True, timeout=300,
                           cwd=ROOT)
        assert r.returncode == 0, f"{script.name} --help: {r.stderr[-2000:]}"
        assert not _MARKUP.search(r.stdout), f"{script.name}: {_MARKUP.search(r.stdout).group(0)!r} in --help"
        if script.parent.name == "examples":  # 33.7: every example states its defaults
            blocks = re.split(r"\n(?=  -)", r.stdout.split("options:", 1)[1])
            for block in blocks:
                if block.startswith("  --"):
                    assert "default:" in block, f"{script.name} {block.split()[0]}: default not shown in --help"


def test_example_help_shows_ramp_and_rpm_defaults():
    r = subprocess.run([sys.executable, str(ROOT / "examples" / "drivetrain_bench.py"), "--help"],
                       capture_output=True, text=True, timeout=300, cwd=ROOT)
    text = " ".join(r.stdout.split())
    assert "ramp duration [s] (default: 1.5)" in text and "[rpm] (default: 4000:7500)" in text


# ------------------------------------------------------------------------------ 33.5: rigid bearing = inf
def test_rigid_bearing_is_inf_in_model_cli_and_fmu(capsys):
    """One convention: inf is a rigid bearing in model files (the default), on the command line and in the FMU
    parameter <gear>.bearing_stiffness (its start value, its description, its check); 0 is no bearing."""
    model = load_model("spur_28t_asym")
    assert all(math.isinf(g.support.translational_stiffness_N_per_m) for g in model.gears)
    rc, out, _ = _run(["modes", "spur_28t_asym", "--bearing-stiffness", "inf", "--no-impulse", "--json"], capsys)
    assert rc == 0 and json.loads(out)["bearing_stiffness_N_per_m"] == {"pinion": "inf", "wheel": "inf"}
    ad = make_adapter(SPUR)
    v = ad.by_name["pinion.bearing_stiffness"]
    assert v.start == math.inf and "inf = rigid" in v.description and "0 = rigid" not in v.description
    assert v.check(math.inf) == "" and v.check(2e8) == ""
    assert "= nan is outside the allowed range [0, 1e+15] or inf" in v.check(float("nan"))
    assert (v.min, v.max) == (RANGES["translational_stiffness_N_per_m"].lo, RANGES["translational_stiffness_N_per_m"].hi)
    assert _fmt(math.inf) == "INF" and _fmt(-math.inf) == "-INF" and _fmt(2.5) == "2.5"  # xs:double in the XML
    values = {x.name: x.start for x in ad.variables if x.start is not None}
    ad.configure(values)                       # inf: rigid, the model's own bearings
    assert not any(g.translations for g in ad.sim.system.gears.values())
    values["pinion.bearing_stiffness"] = values["wheel.bearing_stiffness"] = 2e8
    ad.configure(values)                       # finite: the gears translate
    assert all(g.translations for g in ad.sim.system.gears.values())
    values["pinion.bearing_stiffness"] = 0.0   # 0 is no bearing, not rigid: a spur pair needs one
    with pytest.raises(ModelError, match=r"bearing_stiffness \[N/m\] must be > 0 \(inf: rigid\), got 0\.0"):
        ad.configure(values)


def test_fmu_torque_error_names_the_fmu_parameter():
    ad = make_adapter(SPUR)
    values = {x.name: x.start for x in ad.variables if x.start is not None}
    values["torque"] = 0.0
    with pytest.raises(ModelError) as info:
        ad.configure(values)
    assert "parameter 'torque' [N.m]" in str(info.value) and "torque_Nm" not in str(info.value)


# ------------------------------------------------------------------------------ 33.6: error wording
BASE = (SPUR / "model.toml").read_text()


@pytest.mark.parametrize("old, new, message", [
    ("bore_diameter_mm = 40.0", "bore_diameter_mm = 130.0",
     "bore_diameter_mm = 130 must be smaller than root_diameter_mm = 126.4 (allowed: [0, 126.4) mm)"),
    ("tooth_thickness_mm = 7.64", "tooth_thickness_mm = 15.0",
     "tooth_thickness_mm = 15 must lie within (0.1, 0.9) x circular pitch (pi x module_mm = 15.708 mm); allowed: "
     "(1.5708, 14.1372) mm"),
    ("module_mm", "modul_mm", "unknown key 'gears[0].modul_mm' in [gears[0]]; did you mean 'module_mm'?"),
    ("modal_damping_ratio", "modal_damping", "unknown key 'damping.modal_damping' in [damping]; did you mean "
     "'modal_damping_ratio'?"),
    ("torque_gear", "torque_gaer", "unknown key 'operating.torque_gaer' in [operating]; did you mean 'torque_gear'?"),
])
def test_model_errors_speak_in_the_files_keys(old, new, message):
    assert old in BASE
    with pytest.raises(ModelError) as info:
        parse_model(BASE.replace(old, new, 1), file="bad/model.toml")
    text = str(info.value)
    assert text.startswith("bad/model.toml: ") and message in text
    assert "_m [m]" not in text and "missing required key" not in text.split(";")[0]


def test_centre_distance_error_names_the_file(tmp_path, capsys):
    (tmp_path / "model.toml").write_text(BASE.replace("center_distance_mm = 140.0", "center_distance_mm = 120.0"))
    rc, _, err = _run(["info", str(tmp_path)], capsys)
    assert rc == 2 and f"hacgear info: error: {tmp_path / 'model.toml'}: mesh 'm12': negative backlash" in err


# ------------------------------------------------------------------------------ 36.3: never another kind of file
def test_sweep_refuses_to_write_into_a_tables_file(tmp_path, capsys):
    t = tmp_path / "tables.h5"
    shutil.copy(SPUR / "tables.h5", t)
    before = _sha(t)
    rc, out, err = _run(["sweep", "spur_28t_asym", "--fm", "1000:2000:3", "--out", str(t)], capsys)
    assert rc == 2 and out == ""
    assert (f"--out '{t}' is a hacgear tables file (root attribute format = 'hacgear-tables', from `hacgear "
            "statics`); refusing to write sweep results into it") in err
    assert _sha(t) == before and not (tmp_path / "tables.h5.parts").exists()


@pytest.mark.parametrize("kind", ["sweep", "foreign", "text"])
def test_statics_refuses_to_write_over_another_kind_of_file(kind, tmp_path, capsys):
    f = tmp_path / "results.h5"
    if kind == "text":
        f.write_text("not hdf5")
    else:
        with h5py.File(f, "w") as h:
            if kind == "sweep":
                h.attrs["format"] = "hacgear-sweep"
            h.create_dataset("x", data=[1.0, 2.0])
    before = _sha(f)
    rc, _, err = _run(["statics", "spur_28t_asym", "--out", str(f), "--solver", "analytic", "--workers", "1",
                       "--no-progress"], capsys)
    what = {"sweep": "a hacgear sweep results file (from `hacgear sweep --out`)", "foreign": "an HDF5 file that hacgear did not write",
            "text": "not an HDF5 file"}[kind]
    assert rc == 2 and f"--out '{f}' is {what}; refusing to write a tables file into it" in err
    assert _sha(f) == before and not (tmp_path / "results.h5.partial").exists()


# ------------------------------------------------------------------------------ 36.4: finished tables are kept
def test_statics_with_other_grid_options_keeps_a_finished_table(tmp_path, capsys):
    t = tmp_path / "tables.h5"
    shutil.copy(SPUR / "tables.h5", t)
    before = _sha(t)
    rc, _, err = _run(["statics", "spur_28t_asym", "--out", str(t), "--positions", "8", "--loads", "4",
                       "--deflections", "8", "--solver", "analytic", "--workers", "1", "--no-progress"], capsys)
    assert rc == 2
    assert f"hacgear statics: error: {t} is a finished table made with other settings (differs: " in err
    assert "it is kept. Write the new grid to another file with --out, or replace this one with --fresh" in err
    assert _sha(t) == before and not (tmp_path / "tables.h5.partial").exists()


# ------------------------------------------------------------------------------ 36.5: one range per quantity
@pytest.mark.parametrize("argv, message", [
    (["statics", "spur_28t_asym", "--positions", "2"], "--positions [-] = 2 is out of range; allowed: integer in [4, 4096]"),
    (["statics", "spur_28t_asym", "--loads", "5000"], "--loads [-] = 5000 is out of range; allowed: integer in [2, 1024]"),
    (["statics", "spur_28t_asym", "--max-torque-factor", "2"],
     "--max-torque-factor [-] = 2.0 is out of range; allowed: [3, 20]"),
    (["simulate", "spur_28t_asym", "--fm", "1e9"], "--fm [Hz] = 1000000000.0 is out of range; allowed: (0, 100000]"),
    (["simulate", "spur_28t_asym", "--fm", "1000", "--fm-end", "2e5"], "--fm-end [Hz] = 200000.0 is out of range"),
    (["modes", "spur_28t_asym", "--damping-ratio", "2"], "--damping-ratio [-] = 2.0 is out of range; allowed: [0, 1)"),
    (["modes", "spur_28t_asym", "--bearing-stiffness", "-1"],
     "--bearing-stiffness [N/m] = -1.0 is out of range; allowed: [0, 1e+15] or inf"),
    (["modes", "planetary_65_55_175", "--planets", "13"], "--planets [-] = 13 is out of range; allowed: integer in [1, 12]"),
    (["sweep", "spur_28t_asym", "--fm", "1000:2000:3", "--torques", "100,2e9"],
     "--torques [N*m] = 2000000000.0 is out of range; allowed: magnitude (0, 1e+08], either sign"),
    (["stiffness", "spur_28t_asym", "--positions", "2"], "--positions [-] = 2 is out of range; allowed: integer in [4, 4096]"),
])
def test_out_of_range_options_name_option_value_and_range(argv, message, capsys):
    rc, out, err = _run(argv, capsys)
    assert rc == 2 and out == "" and message in err


def test_the_same_ranges_in_model_files():
    for key, old, new, message in [
        ("positions", "positions = 256", "positions = 2", "key 'statics.positions' [-]: value 2 out of range; allowed: "
         "integer in [4, 4096]"),
        ("max_torque_factor", "max_torque_factor = 3.0", "max_torque_factor = 2.0",
         "key 'statics.max_torque_factor' [-]: value 2 out of range; allowed: [3, 20]"),
    ]:
        assert old in BASE, key
        with pytest.raises(ModelError, match=re.escape(message)):
            parse_model(BASE.replace(old, new, 1), file="m.toml")
    with pytest.raises(ModelError, match=re.escape("translational_stiffness_N_per_m [N/m] = -1.0 is out of range; "
                                                   "allowed: [0, 1e+15] or inf")):
        Support(-1.0)


def test_gauge_off_the_tooth_is_refused(tmp_path, capsys):
    assert "radius_mm = 64.051" in BASE
    (tmp_path / "model.toml").write_text(BASE.replace("radius_mm = 64.051", "radius_mm = 90.0", 1))
    rc, _, err = _run(["info", str(tmp_path)], capsys)
    assert rc == 2
    assert "radius_mm = 90 does not lie on the tooth; allowed: [63.2, 74.95] mm" in err


def test_a_model_toml_folder_is_a_clear_error(tmp_path, capsys):
    (tmp_path / "model.toml").mkdir()
    rc, _, err = _run(["info", str(tmp_path)], capsys)
    assert rc == 2 and "is not a file (a folder?)" in err and "Traceback" not in err


def test_planet_count_range_is_the_same_on_the_cli_and_in_the_fmu(capsys):
    """The FMU's planet_count range is every count of RANGES that the set can assemble without overlapping planets
    (6 for the 65/55/175 set: 7 cannot be assembled, 8 overlap); the CLI refuses the same counts."""
    (p,) = structural_parameters(load_model("planetary_65_55_175"))
    assert (p.min, p.max) == (1, 6)
    rc, _, err = _run(["modes", "planetary_65_55_175", "--planets", "8", "--no-impulse"], capsys)
    assert rc == 2 and "overlap" in err and "at most 6 equally spaced planets fit this set" in err
    rc, _, err = _run(["modes", "planetary_65_55_175", "--planets", "7", "--no-impulse"], capsys)
    assert rc == 2 and "cannot be assembled" in err


# ------------------------------------------------------------------------------ 33.7: the two-stage figure
def test_two_stage_figure_names_its_shafts_and_plots_over_mesh_frequency(tmp_path):
    """plot_stages: each shaft named by what it connects, forces over each stage's own mesh frequency (input speed /
    input speed ratio x reference teeth / 2 pi), the figure written."""
    from types import SimpleNamespace

    import numpy as np

    from hacgear_core.fmu.bench import plot_stages, shaft_labels, stage_mesh_frequency_Hz

    t = np.linspace(0.0, 0.1, 2001)
    info = {"s1": {"system": "idler_28_33_39", "input": "gear1", "output": "gear3", "reference_teeth": 28,
                   "ports": {"gear1": {"speed_ratio": 1.0, "nominal_torque_Nm": 300.0}},
                   "meshes": {"m12": {"nominal_force_N": 1000.0}}, "resonance_mesh_frequency_Hz": 2800.0},
            "s2": {"system": "spur_28t_asym", "input": "pinion", "output": "wheel", "reference_teeth": 28,
                   "ports": {"pinion": {"speed_ratio": -0.5, "nominal_torque_Nm": 300.0}},
                   "meshes": {"m12": {"nominal_force_N": 2000.0}}, "resonance_mesh_frequency_Hz": 2786.0}}
    lay = SimpleNamespace(infos=info, static={"input_torque_Nm": [300.0, 300.0]})
    w = np.linspace(600.0, 1000.0, t.size)
    res = {"layout": lay, "time_s": t, "motor.speed_reference": w, "motor.speed": w, "load.speed": w,
           "s1.gear1.speed": w, "s1.gear3.speed": w, "s2.pinion.speed": -w, "s2.wheel.speed": w,
           "s1.m12.force": 1000.0 + 100 * np.sin(t * 1e4), "s2.m12.force": 2000.0 + 100 * np.sin(t * 1e4),
           **{f"shaft{k}.torque": np.full(t.size, 300.0) for k in range(3)}}
    assert shaft_labels(res) == ["shaft0: motor -> s1 gear1", "shaft1: s1 gear3 -> s2 pinion", "shaft2: s2 wheel -> load"]
    np.testing.assert_allclose(stage_mesh_frequency_Hz(res, "s2"), w / 0.5 * 28 / (2 * math.pi))
    out = plot_stages(res, tmp_path / "two.png")
    assert out.stat().st_size > 10_000


def test_stiffness_negative_torque_loads_the_coast_flanks(capsys):
    """`stiffness --torque -300` was refused ('must be finite and > 0') while sweep and simulate take a negative
    torque as the coast side: it is now --side coast at 300 N*m, bit for bit, and says so."""
    rc, neg, err = _run(["stiffness", "spur_28t_asym", "--torque", "-300", "--positions", "4", "--json"], capsys)
    assert rc == 0 and "loads the coast flanks: --side coast at 300 N*m" in err
    rc, pos, _ = _run(["stiffness", "spur_28t_asym", "--torque", "300", "--side", "coast", "--positions", "4",
                       "--json"], capsys)
    a, b = json.loads(neg)["meshes"], json.loads(pos)["meshes"]
    for d in (a, b):
        for m in d.values():
            m.pop("seconds", None)   # wall time of the solve
    assert rc == 0 and a == b
    rc, _, err = _run(["stiffness", "spur_28t_asym", "--torque", "-300", "--side", "coast"], capsys)
    assert rc == 2 and "the coast side is the torque reversed already" in err


def test_out_folder_is_named_as_a_folder_and_demo_stays_out_of_models(tmp_path, capsys):
    """`simulate --out somedir` said 'must end in .csv'; `demo --out models/` wrote 8 files among the shipped
    systems."""
    rc, _, err = _run(["simulate", "spur_28t_asym", "--fm", "1000", "--out", str(tmp_path)], capsys)
    assert rc == 2 and "is a folder; give a file name ending in" in err
    for folder in (ROOT / "models", ROOT / "models" / "spur_28t_asym"):
        before = sorted(p.name for p in folder.iterdir())
        rc, _, err = _run(["demo", "--out", str(folder), "--quick"], capsys)
        assert rc == 2 and "is the shipped systems' folder or a system folder" in err
        assert sorted(p.name for p in folder.iterdir()) == before
