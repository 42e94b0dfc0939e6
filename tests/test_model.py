"""Model files: every shipped model parses; malformed files are rejected with a message that names
the file, the key, its unit and the allowed range."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from hacgear_core.errors import ModelError
from hacgear_core.kinds import KINDS
from hacgear_core.model import model_sha256
from hacgear_core.kinds import load_model, parse_model

MODELS = Path(__file__).resolve().parent.parent / "models"
SYSTEMS = ["spur_50t_icr137", "spur_50t_icr18", "spur_28t_asym", "idler_28_33_39", "planetary_65_55_175",
           "helical_28_33"]
BASE = (MODELS / "spur_28t_asym" / "model.toml").read_text()


@pytest.mark.parametrize("system", SYSTEMS)
def test_shipped_models_parse(system):
    m = load_model(MODELS / system / "model.toml")
    assert m.name == system
    assert m.kind in KINDS
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
     r"gear 'pinion': external gear \(internal = false\) needs root_diameter < reference diameter \(module_mm x teeth = 5 x 28\) "
     r"140\.000 mm < tip_diameter; got root_diameter_mm 141\.000"),
    ("bore larger than root",
     lambda t: _replace_once(t, "bore_diameter_mm = 40.0", "bore_diameter_mm = 130.0"),
     r"gear 'pinion': bore_diameter_mm = 130 must be smaller than root_diameter_mm = 126\.4 \(allowed: \[0, 126\.4\) mm\)"),
    ("mesh names a missing gear",
     lambda t: _replace_once(t, 'gear_b = "wheel"', 'gear_b = "whee1"'),
     r"meshes\.m12\.gear_b = 'whee1' names no gear \(no \[\[gears\]\] with that name\); allowed: \['pinion', 'wheel'\]"),
    ("unknown material",
     lambda t: _replace_once(t, 'material = "steel"', 'material = "bronze"'),
     r"key 'gears\[0\]\.material': unknown material 'bronze'; allowed: steel"),
    ("unknown system kind",
     lambda t: _replace_once(t, 'kind = "spur_pair"', 'kind = "worm_pair"'),
     r"key 'system\.kind': unknown value 'worm_pair'; allowed: spur_pair \| idler_chain \| planetary \| helical_pair"),
    ("negative damping ratio",
     lambda t: _replace_once(t, "modal_damping_ratio = 0.02", "modal_damping_ratio = -0.1"),
     r"key 'damping\.modal_damping_ratio' \[-\]: value -0\.1 out of range; allowed: \[0, 1\)"),
    ("critical damping ratio: refused at load, not at build",
     lambda t: _replace_once(t, "modal_damping_ratio = 0.02", "modal_damping_ratio = 1.0"),
     r"key 'damping\.modal_damping_ratio' \[-\]: value 1 out of range; allowed: \[0, 1\)"),
    ("zero torque",
     lambda t: _replace_once(t, "torque_Nm = 300.0", "torque_Nm = 0.0"),
     r"key 'operating\.torque_Nm' \[N\*m\]: value 0 out of range; allowed: \(0, 1e\+08\]"),
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
     lambda t: _replace_once(t, "positions = 256", "positions = 2"),
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
     r"gear 'pinion': tooth_thickness_mm = 15 must lie within \(0\.1, 0\.9\) x circular pitch"),
    ("subnormal twist range (found by the fuzz test: 1e-3 x it underflowed to 0 rad past the parser)",
     lambda t: _replace_once(t, "deflections = 64\n", "deflections = 64\nmax_twist_mrad = 5e-324\n"),
     r"key 'statics\.max_twist_mrad' \[mrad\]: value 4\.94066e-324 out of range; allowed: \[1e-06, 10\]"),
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


# ----------------------------------------------------------------------------------------------
# property-based fuzzing: malformed and extreme model files (hypothesis)
# ----------------------------------------------------------------------------------------------
import copy  # noqa: E402
import tomllib  # noqa: E402

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from _fuzz import count, dumps  # noqa: E402
from hacgear_core.errors import HacgearError  # noqa: E402

FUZZ_BASES = {s: tomllib.loads((MODELS / s / "model.toml").read_text()) for s in SYSTEMS}
_UNIT = re.compile(r"_(mm|um|deg|GPa|Nm_per_rad|N_per_m|Nm|kg_per_m3|kgm2|kg)$")
_FUZZ = dict(deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

FUZZ_VALUES = st.one_of(
    st.integers(min_value=-2 ** 63, max_value=2 ** 63 - 1),
    st.floats(),
    st.sampled_from([0.0, -0.0, 1e308, -1e308, 5e-324, math.nan, math.inf, -math.inf, 1e-12, 1e12, 0.5, 1.0]),
    st.booleans(),
    st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=12),
    st.sampled_from(["pinion", "wheel", "drive", "coast", "steel", "m12", "none", "parabolic", ""]),
    st.lists(st.integers(-5, 5), max_size=3),
    st.dictionaries(st.sampled_from(["a", "name", "teeth"]), st.integers(-3, 3), max_size=2),
    st.dates(),
)
GEOMETRY_SCALES = [0.0, 0.1, 0.5, 0.8, 0.9, 0.95, 0.99, 1.01, 1.05, 1.1, 1.25, 2.0, 10.0]
SCALES = [0.0, -1.0, 1e-9, 1e-3, 0.1, 0.5, 0.9, 0.999, 1.001, 1.1, 2.0, 10.0, 1e3, 1e9]


def _nodes(d, prefix=()):
    """Every node of a parsed TOML document: (path, value); paths hold keys and array indices."""
    items = d.items() if isinstance(d, dict) else enumerate(d)
    for k, v in items:
        p = prefix + (k,)
        yield p, v
        if isinstance(v, dict) or (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)):
            yield from _nodes(v, p)


def _parent(doc, path):
    node = doc
    for k in path[:-1]:
        node = node[k]
    return node


def _stem(path) -> str:
    """The name a message must contain for a change at ``path``: its last key without the unit suffix."""
    last = next(k for k in reversed(path) if isinstance(k, str))
    return _UNIT.sub("", last)


def _mutate(data, doc: dict) -> list[str]:
    """Apply 1-3 random mutations to ``doc`` in place; returns the names an error message may cite."""
    names = []
    for _ in range(data.draw(st.integers(1, 3), label="n_mutations")):
        nodes = list(_nodes(doc))
        if not nodes:
            break
        op = data.draw(st.sampled_from(["replace", "replace", "scale", "scale", "delete", "unknown"]), label="op")
        if op == "scale":
            nums = [(p, v) for p, v in nodes if isinstance(v, (int, float)) and not isinstance(v, bool)]
            if not nums:
                continue
            path, v = data.draw(st.sampled_from(nums), label="number")
            f = data.draw(st.sampled_from(SCALES), label="factor")
            new = v * f
            _parent(doc, path)[path[-1]] = int(new) if isinstance(v, int) and abs(new) < 2 ** 63 else float(new)
        elif op == "unknown":
            tables = [((), doc)] + [(p, v) for p, v in nodes if isinstance(v, dict)]
            path, t = data.draw(st.sampled_from(tables), label="table")
            t["fuzz_key"] = 1
            names.append("fuzz_key")
            continue
        else:
            path, _ = data.draw(st.sampled_from(nodes), label="node")
            parent = _parent(doc, path)
            if op == "delete":  # the error may name the deleted key or the table that held it
                del parent[path[-1]]
                if len(path) > 1:
                    names.append(_stem(path[:-1]))
            else:
                parent[path[-1]] = data.draw(FUZZ_VALUES, label="value")
        names.append(_stem(path))
    return names


def _model_file_case(data, campaign: str) -> None:
    system = data.draw(st.sampled_from(SYSTEMS), label="system")
    doc = copy.deepcopy(FUZZ_BASES[system])
    names = _mutate(data, doc)
    text = dumps(doc)
    try:
        tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:  # the writer must only produce valid TOML
        raise AssertionError(f"test writer produced invalid TOML: {exc}") from None
    try:
        parse_model(text, file="fuzz.toml")
    except ModelError as exc:
        msg = str(exc)
        assert msg.startswith("fuzz.toml"), msg
        assert "\n" not in msg and len(msg) < 2000, msg
        assert any(n.lower() in msg.lower() for n in names), f"message names none of {names}: {msg}"
        count(campaign, "ModelError naming the key")
    except Exception as exc:  # noqa: BLE001 - the property: nothing but ModelError
        count(campaign, f"unexpected {type(exc).__name__}")
        raise AssertionError(f"{system} mutated at {names}: {type(exc).__name__}: {exc}") from exc
    else:
        count(campaign, "valid after mutation")


@settings(max_examples=2000, **_FUZZ)
@given(st.data())
def test_fuzz_malformed_model_files_give_a_model_error_naming_the_key(data):
    """2,000 model files, each a shipped model with 1-3 random mutations (deleted keys, values of every TOML type
    including NaN, inf, huge and negative numbers, numbers scaled to extremes, unknown keys): each parses, or
    gives a one-line ModelError that names the file and a mutated key; never another exception."""
    _model_file_case(data, "model files (malformed)")


@pytest.mark.slow
@settings(max_examples=30000, **_FUZZ)
@given(st.data())
def test_fuzz_malformed_model_files_long(data):
    _model_file_case(data, "model files (malformed, slow)")


def _text_case(data, campaign: str) -> None:
    system = data.draw(st.sampled_from(SYSTEMS), label="system")
    text = (MODELS / system / "model.toml").read_text()
    for _ in range(data.draw(st.integers(1, 3), label="n_edits")):
        i = data.draw(st.integers(0, len(text)), label="at")
        j = data.draw(st.integers(i, min(len(text), i + 40)), label="to")
        text = text[:i] + data.draw(st.text(max_size=8), label="insert") + text[j:]
    try:
        parse_model(text, file="fuzz.toml")
    except ModelError as exc:
        assert str(exc).startswith("fuzz.toml") and "\n" not in str(exc), str(exc)
        count(campaign, "ModelError")
    except Exception as exc:  # noqa: BLE001
        count(campaign, f"unexpected {type(exc).__name__}")
        raise AssertionError(f"{system}: {type(exc).__name__}: {exc}") from exc
    else:
        count(campaign, "valid after edit")


@settings(max_examples=300, **_FUZZ)
@given(st.data())
def test_fuzz_corrupted_model_text_gives_a_model_error(data):
    """300 model files with random character edits (truncations, insertions, broken quotes and brackets)."""
    _text_case(data, "model files (text edits)")


def _geometry_case(data, campaign: str) -> None:
    from hacgear_core.cli.info import info_dict

    system = data.draw(st.sampled_from(SYSTEMS), label="system")
    doc = copy.deepcopy(FUZZ_BASES[system])
    nums = [(p, v) for p, v in _nodes(doc) if isinstance(v, (int, float)) and not isinstance(v, bool)]
    for _ in range(data.draw(st.integers(1, 2), label="n")):
        path, v = data.draw(st.sampled_from(nums), label="number")
        f = data.draw(st.sampled_from(GEOMETRY_SCALES), label="factor")
        _parent(doc, path)[path[-1]] = max(1, round(v * f)) if isinstance(v, int) else v * f
    try:
        model = parse_model(dumps(doc), file="fuzz.toml")
        info_dict(model, strict=data.draw(st.booleans(), label="strict"))
    except HacgearError as exc:
        assert "\n" not in str(exc), str(exc)
        count(campaign, type(exc).__name__)
    except Exception as exc:  # noqa: BLE001
        count(campaign, f"unexpected {type(exc).__name__}")
        raise AssertionError(f"{system}: {type(exc).__name__}: {exc}") from exc
    else:
        count(campaign, "valid geometry")


@settings(max_examples=200, **_FUZZ)
@given(st.data())
def test_fuzz_extreme_values_through_the_geometry(data):
    """200 well-typed model files with numbers scaled by 0 ... 10 through `hacgear info`'s
    geometry: a report, or a ModelError / GeometryError; never another exception."""
    _geometry_case(data, "model files through the geometry")


@pytest.mark.slow
@settings(max_examples=5000, **_FUZZ)
@given(st.data())
def test_fuzz_extreme_values_through_the_geometry_long(data):
    _geometry_case(data, "model files through the geometry (slow)")


LUMPED = Path(__file__).resolve().parent.parent / "examples" / "planetary_lumped.toml"


def test_shipped_lumped_planetary_reaches_its_carrier_radius():
    """The example's carrier radius 96.54 mm is what its base radii need: (50.2743 + 42.5398) / cos 15.97 deg =
    135.3539 - 42.5398 ... = 92.8141 / 0.96140 = 96.540 mm (within 1e-4 relative); it loads."""
    m = load_model(LUMPED)
    need = (50.2743 + 42.5398) / math.cos(math.radians(15.97)) * 1e-3
    assert abs(m.planetary.carrier_radius_m - need) < 1e-4 * need


def test_unreachable_carrier_radius_is_refused_at_load(tmp_path):
    """A carrier radius the sun and planet base radii cannot reach (150 mm instead of 96.54 mm) is refused when the
    file loads, with the file, the key, its unit, the value, the radius the base radii need and the tolerance."""
    bad = tmp_path / "model.toml"
    bad.write_text(LUMPED.read_text().replace("carrier_radius_mm = 96.54", "carrier_radius_mm = 150"))
    with pytest.raises(ModelError) as info:
        load_model(bad)
    msg = str(info.value)
    assert msg.startswith(str(bad)) and "key 'planetary.carrier_radius_mm' [mm]" in msg
    assert "value 150" in msg and "mesh 'sun_planet'" in msg
    need = (50.2743 + 42.5398) / math.cos(math.radians(15.97))
    assert f"{need:.4f} mm within 0.0001 relative" in msg


def test_a_duplicate_gear_name_is_named_as_such():
    """Two [[gears]] named 'pinion' said 'gear_a and gear_b must differ' (the mesh saw one gear twice)."""
    text = (MODELS / "spur_28t_asym" / "model.toml").read_text()
    bad = text.replace('name = "wheel"', 'name = "pinion"', 1).replace('gear_b = "wheel"', 'gear_b = "pinion"')
    with pytest.raises(ModelError, match=r"key 'gears\[1\]\.name': 'pinion' is already the name of gears\[0\]"):
        parse_model(bad)


def test_a_byte_order_mark_is_read(tmp_path):
    """A model file saved with a UTF-8 byte-order mark (as Windows editors do) loads like the one without; it
    said 'Invalid statement (line 1, column 1)'."""
    src = MODELS / "spur_28t_asym" / "model.toml"
    bom = tmp_path / "model.toml"
    bom.write_bytes(b"\xef\xbb\xbf" + src.read_bytes())
    a, b = load_model(bom), load_model(src)
    assert a.gears == b.gears and a.meshes == b.meshes and a.sha256 != b.sha256


# ----------------------------------------------------------------------------------------------
# ISO 21771 form of [[gears]] (normal_module_mm ...): converted once, at load, to the transverse form
# ----------------------------------------------------------------------------------------------
ISO_PAIR = '''
[system]
name = "iso_pair"
kind = "helical_pair"

[materials.steel]
density_kg_per_m3 = 7830.0
youngs_modulus_GPa = 206.0
poisson_ratio = 0.3

[[gears]]
name = "pinion"
teeth = 24
normal_module_mm = 14.0
normal_pressure_angle_deg = 20.0
helix_angle_deg = 10.0
hand = "right"
profile_shift = 0.48
tip_alteration_mm = -0.938
basic_rack = "A"
thickness_allowance_upper_mm = -0.1
thickness_allowance_lower_mm = -0.3
face_width_mm = 360.0
bore_diameter_mm = 150.0
material = "steel"

[[gears]]
name = "ring"
teeth = 95
internal = true
normal_module_mm = 14.0
normal_pressure_angle_deg = 20.0
helix_angle_deg = 10.0
hand = "right"
profile_shift = -0.3
tip_diameter_mm = 1330.0
rack_addendum_coefficient = 1.0
rack_dedendum_coefficient = 1.4
rack_root_radius_coefficient = 0.2
face_width_mm = 360.0
bore_diameter_mm = 1500.0
material = "steel"

[[meshes]]
name = "m12"
gear_a = "pinion"
gear_b = "ring"

[damping]
modal_damping_ratio = 0.02

[operating]
torque_Nm = 1.0e4
'''


def test_iso_form_is_converted_to_the_transverse_form_by_iso21771():
    m = parse_model(ISO_PAIR, file="iso.toml")
    p, r = m.gear("pinion"), m.gear("ring")
    m_n, beta, alpha_n = 14e-3, math.radians(10.0), math.radians(20.0)
    m_t = m_n / math.cos(beta)
    alpha_t = math.atan(math.tan(alpha_n) / math.cos(beta))
    rel = 1e-12
    for g in (p, r):
        assert g.module_m == pytest.approx(m_t, rel=rel)
        assert g.flanks["drive"].pressure_angle_rad == pytest.approx(alpha_t, rel=rel)
        assert g.flanks["coast"] == g.flanks["drive"] and not g.flanks["drive"].has_relief
        assert g.helix_angle_rad == pytest.approx(beta, rel=rel)                  # right hand: positive
    # external: d_a = d + 2 m_n (h_aP* + x + k), d_f = d - 2 m_n (h_fP* - x), s_t = (s_n + mean allowance) / cos(beta)
    d = 24 * m_t
    assert p.tip_diameter_m == pytest.approx(d + 2 * m_n * (1.0 + 0.48) - 2 * 0.938e-3, rel=rel)
    assert p.root_diameter_m == pytest.approx(d - 2 * m_n * (1.25 - 0.48), rel=rel)
    s_n = m_n * (math.pi / 2 + 2 * 0.48 * math.tan(alpha_n)) - 0.2e-3
    assert p.tooth_thickness_m == pytest.approx(s_n / math.cos(beta), rel=rel)
    assert p.hob_tip_radius_m == pytest.approx(0.38 * m_n, rel=rel)               # ISO 53 rack A
    assert p.iso.basic_rack == "A" and p.iso.thickness_allowance_lower_m == pytest.approx(-0.3e-3)
    # internal, ISO sign: x > 0 towards the tips (the axis); d_f = d + 2 m_n (h_fP* - x); k from the tip diameter
    d = 95 * m_t
    assert r.root_diameter_m == pytest.approx(d + 2 * m_n * (1.4 - (-0.3)), rel=rel)
    assert r.tip_diameter_m == pytest.approx(1.330, rel=rel)
    assert r.iso.tip_alteration == pytest.approx((d - 1.330) / (2 * m_n) - 1.0 + 0.3, rel=rel)
    assert r.tooth_thickness_m == pytest.approx(m_n * (math.pi / 2 - 2 * 0.3 * math.tan(alpha_n)) / math.cos(beta),
                                                rel=rel)
    assert r.hob_tip_radius_m == pytest.approx(0.2 * m_n, rel=rel) and r.iso.basic_rack == "custom"
    d = {k: (v, meaning) for k, v, meaning in m.defaults_applied}
    assert d["gears[1] (ring).thickness_allowance_upper_mm"][0] == "0"


def test_iso_form_flank_tables_hold_tip_relief_only():
    """An ISO-form gear's [gears.drive] holds tip relief; its pressure angle is the transverse one of alpha_n, beta."""
    m = parse_model(ISO_PAIR.replace('material = "steel"\n\n[[gears]]\nname = "ring"',
                                     'material = "steel"\n  [gears.drive]\n  tip_relief_um = 20.0\n'
                                     '  tip_relief_start_roll_deg = 25.0\n\n[[gears]]\nname = "ring"', 1),
                    file="iso.toml")
    p = m.gear("pinion")
    assert p.flanks["drive"].tip_relief_m == pytest.approx(20e-6) and p.flanks["coast"] == p.flanks["drive"]
    assert p.flanks["drive"].tip_relief_shape == "parabolic"
    assert p.flanks["drive"].pressure_angle_rad == pytest.approx(math.atan(math.tan(math.radians(20.0)) /
                                                                           math.cos(math.radians(10.0))), rel=1e-12)


ISO_MALFORMED = [
    ("a transverse-form key in an ISO-form gear",
     lambda t: _replace_once(t, "profile_shift = 0.48\n", "profile_shift = 0.48\nroot_diameter_mm = 300.0\n"),
     r"key 'gears\[0\]\.root_diameter_mm'.*a transverse-form key in an ISO-form gear.*d_f = d - 2 m_n"),
    ("neither a named rack nor the rack coefficients",
     lambda t: _replace_once(t, 'basic_rack = "A"\n', ""),
     r"key 'gears\[0\]\.basic_rack'.*missing.*A \| B \| C \| D"),
    ("a named rack and a rack coefficient",
     lambda t: _replace_once(t, 'basic_rack = "A"\n', 'basic_rack = "A"\nrack_root_radius_coefficient = 0.3\n'),
     r"rack_root_radius_coefficient.*ISO 53 profile A fixes"),
    ("an unknown rack", lambda t: _replace_once(t, 'basic_rack = "A"', 'basic_rack = "E"'),
     r"key 'gears\[0\]\.basic_rack': unknown value 'E'; allowed: A \| B \| C \| D"),
    ("both tip keys",
     lambda t: _replace_once(t, "tip_alteration_mm = -0.938\n", "tip_alteration_mm = -0.938\ntip_diameter_mm = 380.0\n"),
     r"tip_diameter_mm.*both tip keys"),
    ("a helical gear without hand", lambda t: _replace_once(t, 'hand = "right"\n', ""),
     r"key 'gears\[0\]\.hand': missing required key; allowed: right \| left"),
    ("an internal pair of opposite hands", lambda t: t.replace('hand = "right"\nprofile_shift = -0.3',
                                                               'hand = "left"\nprofile_shift = -0.3'),
     r"mesh 'm12': hand = 'right' on 'pinion' and 'left' on 'ring'; allowed: the same hand \(internal pair\)"),
    ("lower allowance above the upper one",
     lambda t: _replace_once(t, "thickness_allowance_lower_mm = -0.3", "thickness_allowance_lower_mm = 0.0"),
     r"thickness_allowance_lower \[mm\] = 0 exceeds thickness_allowance_upper \[mm\] = -0.1"),
    ("a pressure angle in an ISO-form flank table",
     lambda t: _replace_once(t, 'material = "steel"\n', 'material = "steel"\n  [gears.drive]\n  pressure_angle_deg = 25.0\n'),
     r"key 'gears\[0\]\.drive\.pressure_angle_deg'.*normal_pressure_angle_deg"),
    ("a tip inside the reference circle",
     lambda t: _replace_once(t, "tip_alteration_mm = -0.938", "tip_alteration_mm = -21.0"),
     r"tip addendum h_aP\* \+ x \+ k = .* puts the tip circle inside the reference circle"),
    ("different normal modules",
     lambda t: _replace_once(t, "normal_module_mm = 14.0", "normal_module_mm = 12.0"),
     r"mesh 'm12': normal_module_mm \[mm\] differs between 'pinion' \(12\) and 'ring' \(14\)"),
    ("a tip diameter far from the reference circle",
     lambda t: _replace_once(t, "tip_diameter_mm = 1330.0", "tip_diameter_mm = 1000.0"),
     r"key 'gears\[1\]\.tip_diameter_mm' \[mm\]: value 1000 gives the tip alteration k = 11\.8185; allowed: "
     r"\[1246\.92, 1414\.92\] \(k in \[-3, 3\]\)"),
]


@pytest.mark.parametrize("what,transform,pattern", ISO_MALFORMED, ids=[m[0] for m in ISO_MALFORMED])
def test_iso_form_errors_name_the_key(what, transform, pattern):
    with pytest.raises(ModelError, match=pattern):
        parse_model(transform(ISO_PAIR), file="iso.toml")
