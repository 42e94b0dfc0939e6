"""Model files: every shipped model parses; malformed files are rejected with a message that names
the file, the key, its unit and the allowed range."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from hacgear_core.errors import ModelError
from hacgear_core.model import SYSTEM_KINDS, load_model, model_sha256, parse_model

MODELS = Path(__file__).resolve().parent.parent / "models"
SYSTEMS = ["spur_50t_icr137", "spur_50t_icr18", "spur_28t_asym", "idler_28_33_39", "planetary_65_55_175",
           "helical_28_33"]
BASE = (MODELS / "spur_28t_asym" / "model.toml").read_text()


@pytest.mark.parametrize("system", SYSTEMS)
def test_shipped_models_parse(system):
    m = load_model(MODELS / system / "model.toml")
    assert m.name == system
    assert m.kind in SYSTEM_KINDS
    assert m.sha256 == model_sha256(MODELS / system / "model.toml")
    assert (MODELS / system / "readme.md").exists(), "each model folder documents its sources and choices"
    for g in m.gears:  # SI inside
        assert 1e-4 < g.module_m < 0.1
        assert g.face_width_m < 0.1


def test_28t_values_are_si():
    m = load_model("spur_28t_asym")
    g = m.gear("pinion")
    assert g.module_m == pytest.approx(5e-3)
    assert g.tip_diameter_m == pytest.approx(0.1499)
    assert g.flanks["drive"].pressure_angle_rad == pytest.approx(math.radians(25))
    assert g.flanks["coast"].pressure_angle_rad == pytest.approx(math.radians(20))
    assert g.flanks["drive"].tip_relief_m == pytest.approx(47e-6)
    assert g.flanks["drive"].tip_relief_start_roll_rad == pytest.approx(math.radians(28.54))
    assert g.lead_crowning_m == pytest.approx(15e-6)
    assert g.material.youngs_modulus_Pa == pytest.approx(201.5e9)
    assert math.isinf(g.support.translational_stiffness_N_per_m)
    assert m.meshes[0].center_distance_m == pytest.approx(0.140)
    assert m.operating.torque_Nm == 300.0


def test_load_by_name_folder_and_file_agree():
    a = load_model("spur_28t_asym")
    b = load_model(MODELS / "spur_28t_asym")
    c = load_model(MODELS / "spur_28t_asym" / "model.toml")
    assert a == b == c


def _replace_once(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def _with_web(text: str, gear: int = 0, **over) -> str:
    """Add a [gears.web] table to gear ``gear`` of ``text`` (keys in mm; None drops a key)."""
    keys = dict(thickness_mm=5.0, inner_diameter_mm=60.0, outer_diameter_mm=110.0)
    keys.update(over)
    table = "  [gears.web]\n" + "".join(f"  {k} = {v}\n" for k, v in keys.items() if v is not None)
    parts = text.split('material = "steel"\n')
    assert len(parts) == 3, "expected two gears"
    parts[gear + 1] = table + parts[gear + 1]
    return 'material = "steel"\n'.join(parts)


# (description, transformation of the base file, regex the message must match)
MALFORMED = [
    ("unknown key in a gear",
     lambda t: _replace_once(t, "teeth = 28\n", "teeth = 28\nteeth_count = 28\n"),
     r"unknown key 'gears\[0\]\.teeth_count'.*allowed keys: .*module_mm"),
    ("unknown top-level table",
     lambda t: t + "\n[solver]\ntolerance = 1e-6\n",
     r"unknown key 'solver' in \[top level\]"),
    ("missing required key",
     lambda t: _replace_once(t, "module_mm = 5.0\n", ""),
     r"key 'gears\[0\]\.module_mm' \[mm\]: missing required key; allowed: \[0\.1, 100\]"),
    ("wrong type (string for number)",
     lambda t: _replace_once(t, "face_width_mm = 15.0", 'face_width_mm = "15"'),
     r"key 'gears\[0\]\.face_width_mm' \[mm\]: wrong type str"),
    ("wrong type (float teeth)",
     lambda t: _replace_once(t, "teeth = 28", "teeth = 28.0"),
     r"key 'gears\[0\]\.teeth' \[-\]: wrong type float.*integer in \[6, 1000\]"),
    ("pressure angle out of range",
     lambda t: _replace_once(t, "pressure_angle_deg = 25.0", "pressure_angle_deg = 55.0"),
     r"key 'gears\[0\]\.drive\.pressure_angle_deg' \[deg\]: value 55 out of range; allowed: \[5, 40\]"),
    ("negative relief",
     lambda t: _replace_once(t, "tip_relief_um = 47.0", "tip_relief_um = -5.0"),
     r"key 'gears\[0\]\.drive\.tip_relief_um' \[um\]: value -5 out of range; allowed: \[0, 1000\]"),
    ("unknown relief shape",
     lambda t: _replace_once(t, 'tip_relief_shape = "parabolic"', 'tip_relief_shape = "cubic"'),
     r"key 'gears\[0\]\.drive\.tip_relief_shape': unknown value 'cubic'; allowed: none \| linear \| parabolic"),
    ("root diameter above reference diameter (impossible geometry)",
     lambda t: _replace_once(t, "root_diameter_mm = 126.4", "root_diameter_mm = 141.0"),
     r"gear 'pinion': external gear needs root_diameter < reference diameter 140\.000 mm"),
    ("bore larger than root",
     lambda t: _replace_once(t, "bore_diameter_mm = 40.0", "bore_diameter_mm = 130.0"),
     r"gear 'pinion': bore_diameter_m \[m\] = 0\.13 must be smaller than the root diameter"),
    ("mesh names a missing gear",
     lambda t: _replace_once(t, 'gear_b = "wheel"', 'gear_b = "whee1"'),
     r"meshes\.m12\.gear_b = 'whee1' names no gear; allowed: \['pinion', 'wheel'\]"),
    ("unknown material",
     lambda t: _replace_once(t, 'material = "steel"', 'material = "bronze"'),
     r"key 'gears\[0\]\.material': unknown material 'bronze'; allowed: steel"),
    ("unknown system kind",
     lambda t: _replace_once(t, 'kind = "spur_pair"', 'kind = "worm_pair"'),
     r"key 'system\.kind': unknown value 'worm_pair'; allowed: spur_pair \| idler_chain \| planetary \| helical_pair"),
    ("negative damping ratio",
     lambda t: _replace_once(t, "modal_damping_ratio = 0.02", "modal_damping_ratio = -0.1"),
     r"key 'damping\.modal_damping_ratio' \[-\]: value -0\.1 out of range; allowed: \[0, 1\]"),
    ("zero torque",
     lambda t: _replace_once(t, "torque_Nm = 300.0", "torque_Nm = 0.0"),
     r"key 'operating\.torque_Nm' \[N\*m\]: value 0 out of range; allowed: \(0, 1e\+07\]"),
    ("nan value",
     lambda t: _replace_once(t, "face_width_mm = 15.0", "face_width_mm = nan"),
     r"key 'gears\[0\]\.face_width_mm' \[mm\]: value nan out of range"),
    ("mismatched pressure angles in a mesh",
     lambda t: t.replace("pressure_angle_deg = 25.0", "pressure_angle_deg = 22.0", 1),
     r"mesh 'm12': pressure_angle_deg of pinion\.drive \(22 deg\) differs from wheel\.drive \(25 deg\)"),
    ("relief without start roll angle",
     lambda t: _replace_once(t, "  tip_relief_start_roll_deg = 28.54\n", ""),
     r"key 'gears\[0\]\.drive\.tip_relief_start_roll_deg' \[deg\]: missing or zero while tip_relief_um > 0"),
    ("statics grid not an integer",
     lambda t: _replace_once(t, "positions = 64", "positions = 2"),
     r"key 'statics\.positions' \[-\]: value 2 out of range; allowed: integer in \[4, 4096\]"),
    ("not TOML",
     lambda t: t + "\nthis is = = not toml\n",
     r"not valid TOML"),
    ("web thicker than the face width",
     lambda t: _with_web(t, thickness_mm=16.0),
     r"key 'gears\[0\]\.web\.thickness_mm' \[mm\]: value 16 out of range; allowed: \(0, face_width_mm = 15\]"),
    ("web of zero thickness",
     lambda t: _with_web(t, thickness_mm=0.0),
     r"key 'gears\[0\]\.web\.thickness_mm' \[mm\]: value 0 out of range; allowed: \(0, face_width_mm = 15\]"),
    ("web inside the bore",
     lambda t: _with_web(t, inner_diameter_mm=40.0),
     r"key 'gears\[0\]\.web\.inner_diameter_mm' \[mm\]: value 40 out of range; allowed: "
     r"\(bore_diameter_mm = 40, root_diameter_mm - 2 = 124\.4\)"),
    ("web inner above outer",
     lambda t: _with_web(t, inner_diameter_mm=100.0, outer_diameter_mm=90.0),
     r"key 'gears\[0\]\.web\.outer_diameter_mm' \[mm\]: value 90 out of range; allowed: "
     r"\(web\.inner_diameter_mm = 100, root_diameter_mm - 2 = 124\.4\]"),
    ("web leaves no rim",
     lambda t: _with_web(t, outer_diameter_mm=125.0),
     r"key 'gears\[0\]\.web\.outer_diameter_mm' \[mm\]: value 125 out of range; allowed: .*124\.4\] "
     r"\(a rim of at least 1 mm must remain below the root circle\)"),
    ("web key missing",
     lambda t: _with_web(t, thickness_mm=None),
     r"key 'gears\[0\]\.web\.thickness_mm' \[mm\]: missing required key"),
    ("web wrong type",
     lambda t: _with_web(t, thickness_mm='"5"'),
     r"key 'gears\[0\]\.web\.thickness_mm' \[mm\]: wrong type str"),
    ("unknown key in the web",
     lambda t: _with_web(t, fillet_mm=2.0),
     r"unknown key 'gears\[0\]\.web\.fillet_mm' in \[gears\[0\]\.web\]; allowed keys: inner_diameter_mm, "
     r"outer_diameter_mm, thickness_mm"),
    ("tooth thickness impossible",
     lambda t: _replace_once(t, "tooth_thickness_mm = 7.64", "tooth_thickness_mm = 15.0"),
     r"gear 'pinion': tooth_thickness_m \[m\] = 0\.015 must lie within \(0\.1, 0\.9\) x circular pitch"),
]


@pytest.mark.parametrize("desc,transform,pattern", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_model_rejected_with_clear_message(desc, transform, pattern):
    text = transform(BASE)
    with pytest.raises(ModelError) as info:
        parse_model(text, file="bad/model.toml")
    msg = str(info.value)
    assert msg.startswith("bad/model.toml"), f"message must name the file: {msg}"
    assert re.search(pattern, msg), f"{desc}: message was\n{msg}"


def test_error_is_one_line_without_numpy_noise():
    with pytest.raises(ModelError) as info:
        parse_model(BASE.replace("module_mm = 5.0", "module_mm = -5.0", 1), file="x.toml")
    assert "\n" not in str(info.value)
    assert "Traceback" not in str(info.value)


def test_cli_reports_model_error_without_traceback(tmp_path, capsys):
    from hacgear_core.cli import main

    bad = tmp_path / "model.toml"
    bad.write_text(BASE.replace("teeth = 28\n", "teeth = 3\n", 1))
    rc = main(["info", str(bad)])
    err = capsys.readouterr().err
    assert rc == 2
    assert "gears[0].teeth" in err and "integer in [6, 1000]" in err
    assert "Traceback" not in err


def test_web_parses_to_si_and_is_optional():
    from hacgear_core.model import Web

    base = parse_model(BASE, file="m.toml")
    assert all(g.web is None for g in base.gears)            # absent: solid blank
    m = parse_model(_with_web(BASE, 1, thickness_mm=4.5, inner_diameter_mm=62.0, outer_diameter_mm=104.0),
                    file="m.toml")
    assert m.gear("pinion").web is None
    w = m.gear("wheel").web
    assert isinstance(w, Web)
    assert (w.thickness_m, w.inner_diameter_m, w.outer_diameter_m) == pytest.approx((4.5e-3, 62e-3, 104e-3))
    assert (w.inner_radius_m, w.outer_radius_m) == pytest.approx((31e-3, 52e-3))
    # thickness equal to the face width and the largest allowed outer diameter are accepted
    m2 = parse_model(_with_web(BASE, thickness_mm=15.0, outer_diameter_mm=124.4), file="m.toml")
    assert m2.gear("pinion").web.thickness_m == pytest.approx(15e-3)


def test_web_rejected_on_internal_gear():
    text = (MODELS / "planetary_65_55_175" / "model.toml").read_text()
    gears = text.split("[[gears]]")
    idx = next(i for i, g in enumerate(gears) if "internal = true" in g)
    gears[idx] = gears[idx].replace('material = "steel"\n',
                                    'material = "steel"\n  [gears.web]\n  thickness_mm = 5.0\n'
                                    '  inner_diameter_mm = 60.0\n  outer_diameter_mm = 100.0\n', 1)
    with pytest.raises(ModelError) as info:
        parse_model("[[gears]]".join(gears), file="ring.toml")
    msg = str(info.value)
    assert msg.startswith("ring.toml") and "web" in msg and "not supported for internal" in msg


def test_web_dataclass_validation():
    """The frozen dataclasses check the web on their own (programmatic use, no TOML)."""
    import dataclasses

    from hacgear_core.model import Web

    g = parse_model(BASE, file="m.toml").gear("pinion")
    with pytest.raises(ModelError, match=r"web\.thickness_m \[m\] = -0\.001 is out of range; allowed: \(0, 2\]"):
        Web(-1e-3, 60e-3, 100e-3)
    with pytest.raises(ModelError, match=r"web\.inner_diameter_m \[m\] = 0\.1 must be smaller than web\.outer_diameter_m"):
        Web(5e-3, 100e-3, 90e-3)
    with pytest.raises(ModelError, match=r"gear 'pinion': web\.thickness \[mm\] = 20 exceeds the face width; "
                                         r"allowed: \(0, face_width = 15\] mm"):
        dataclasses.replace(g, web=Web(20e-3, 60e-3, 100e-3))
    with pytest.raises(ModelError, match=r"web\.inner_diameter \[mm\] = 30 must exceed the bore diameter 40 mm"):
        dataclasses.replace(g, web=Web(5e-3, 30e-3, 100e-3))
    with pytest.raises(ModelError, match=r"web\.outer_diameter \[mm\] = 126 leaves no rim below the root circle; "
                                         r"allowed: \(web\.inner_diameter, root_diameter - 2 mm\] = \(60, 124\.4\] mm"):
        dataclasses.replace(g, web=Web(5e-3, 60e-3, 126e-3))
    ok = dataclasses.replace(g, web=Web(5e-3, 60e-3, 100e-3))
    assert ok.web.outer_radius_m == pytest.approx(0.05)


@pytest.mark.parametrize("key, line, pattern", [
    ("bore_diameter_mm", "bore_diameter_mm = 40.0\n", r"key 'gears\[0\]\.bore_diameter_mm' \[mm\]: missing required key"),
    ("hob_tip_radius_mm", "hob_tip_radius_mm = 0.4\n", r"key 'gears\[0\]\.hob_tip_radius_mm' \[mm\]: missing required"),
    ("poisson_ratio", "poisson_ratio = 0.3\n", r"key 'materials\.steel\.poisson_ratio' \[-\]: missing required key"),
    ("[damping]", "[damping]\nmodal_damping_ratio = 0.02\n", r"key 'damping': missing required key"),
])
def test_keys_that_change_the_physics_are_never_defaulted(key, line, pattern):
    """A missing bore used to become a solid disk (pinion 1.629 -> 1.777 kg) without a word."""
    assert line in BASE, line
    with pytest.raises(ModelError, match=pattern):
        parse_model(BASE.replace(line, "", 1), file="m.toml")


def test_solid_blank_is_said_explicitly():
    from hacgear_core.geometry import gear_geometry

    m = parse_model(BASE.replace("bore_diameter_mm = 40.0", "bore_diameter_mm = 0.0", 1), file="m.toml")
    assert m.gear("pinion").bore_diameter_m == 0.0
    solid = gear_geometry(m.gear("pinion")).mass_kg
    bored = gear_geometry(parse_model(BASE, file="m.toml").gear("pinion")).mass_kg
    assert bored == pytest.approx(1.629, abs=0.001) and solid == pytest.approx(1.777, abs=0.001)


def test_defaults_are_recorded_and_echoed_by_info(capsys):
    from hacgear_core.cli import main
    from hacgear_core.cli.info import info_dict

    text = BASE.replace("lead_crowning_um = 15.0\n", "", 1)
    m = parse_model(text, file="m.toml")
    d = {k: (v, meaning) for k, v, meaning in m.defaults_applied}
    assert d["gears[0] (pinion).lead_crowning_um"] == ("0", "no lead crowning")
    assert "gears[1] (wheel).lead_crowning_um" not in d  # given in the file
    assert d["gears[0] (pinion).web"] == ("absent", "solid blank from the bore to the root")
    assert d["meshes[0].line_of_centres_deg"][0] == "0"
    assert all(meaning for _, _, meaning in m.defaults_applied)
    assert {"key": "gears[0] (pinion).lead_crowning_um", "value": "0", "meaning": "no lead crowning"} in \
        info_dict(m)["defaults_applied"]
    assert main(["info", "spur_28t_asym"]) == 0
    out = capsys.readouterr().out
    assert "Defaults applied" in out and "tip_edge_radius_mm = 0  (sharp tip edge)  [pinion, wheel]" in out


def test_every_default_is_listed_in_the_readme():
    from hacgear_core.model.toml import DEFAULT_MEANINGS

    readme = (MODELS.parent / "README.md").read_text()
    section = readme[readme.index("## Model files"):]
    section = section[:section.index("\n## ", 5)]
    missing = [k for k in DEFAULT_MEANINGS if f"`{k}`" not in section]
    assert not missing, f"defaults not listed in README 'Model files': {missing}"
