"""One declaration per FMU variable: every output says how it is read from the running simulator, and the
getters, the slave's fast-path expressions and the guarded (fallible) set are generated from those declarations;
parameter ranges come from the model schema's one table."""
from __future__ import annotations

import gzip
import json
import math
import sys
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

import hacgear_core.fmu as hf
from hacgear_core.encodings import ContactState
from hacgear_core.fmu.build import model_description
from hacgear_core.fmu.spec import FmuVariable, Reading, ranged
from hacgear_core.model import shipped_systems_dir
from hacgear_core.model.schema import RANGES

ROOT = Path(__file__).resolve().parent.parent
#: modelDescription.xml (FMI 2.0 and 3.0) of every shipped system before the variables were declared once: the
#: elements with their attributes, in order (written by ``python tests/test_fmu_declarations.py --write``); written
#: again when the outputs <mesh>.flank_pressure and <mesh>.edge_pressure were added, after a comparison by variable
#: name showed nothing else changed (value references of later variables moved); and when load_share said what it
#: outputs while every mesh of its kind is separated (its description only); and when the coupling variables
#: (calculated parameters <port>.speed_ratio, .inertia, .train_inertia, gear_ratio, drivetrain_step; outputs
#: <port>.power, dissipated_power, kinetic_energy, elastic_energy) were added and the torque range grew from 1e6
#: to 1e8 N.m (<port>.torque_in scaled by the speed ratio of a port slower than the input): by name, nothing else
#: changed; and when the NREL 5 MW stages got their tables (their entries added, the others unchanged); and when
#: the stage-1 ring moved to the published rack A (only nrel_5mw_stage1's nominal values and its two start speeds
#: changed, by name) and the reducers reducer_19_71_23_83 and reducer_helical_19_71_23_83 were added (their entries
#: added, the others unchanged); and when the gearbox nrel_5mw_gearbox was added (its entries added) and the ports'
#: nominal inertias were taken from the free train (a port held at constant speed has no rotation in the
#: constant-speed system, whose value was another DOF's): by name, only the nominal values of <port>.inertia and
#: <port>.train_inertia of the held ports of nrel_5mw_stage1, nrel_5mw_stage2 and the two planetary_65_55_175
#: systems changed; and when the runout parameters <gear>.runout and <gear>.runout_phase were added for every gear
#: that may carry manufacturing errors (every gear of the spur, helical, idler and gear-train systems, wheel3 and
#: pinion3 of nrel_5mw_gearbox; none of the planetary sets and stages): by name, nothing else changed; and when
#: the planetary sets got them for their sun, planet and ring (sun.runout, planet.runout, ring.runout and their
#: _phase of planetary_65_55_175, planetary_65_55_175_unmodified, nrel_5mw_stage1 and nrel_5mw_stage2; the
#: gearbox's planetary stages still none): by name, nothing else changed (value references of later variables moved);
#: and when the gearbox's planetary stages got them (sun1, planet1, ring1, sun2, planet2, ring2 .runout and
#: .runout_phase of nrel_5mw_gearbox): by name, nothing else changed, the model structure's outputs and initial
#: unknowns the same variables (value references and indices of later variables moved); and when the lead and
#: misalignment parameters <gear>.lead_slope and <mesh>.misalignment_in_plane, .misalignment_out_of_plane,
#: .axis_deviation_in_axes_plane, .axis_deviation_normal_to_axes_plane were added for the meshes with a twist axis
#: (helical_28_33, nrel_5mw_stage3, the helical stage of nrel_5mw_gearbox and reducer_helical_19_71_23_83): by
#: name, nothing else changed (unit definitions included), the model structure's outputs and initial unknowns the
#: same variables (value references and indices of later variables moved)
REFERENCE = Path(__file__).resolve().parent / "data" / "model_descriptions.json.gz"


def _description(system: str, fmi_version: int) -> bytes:
    """modelDescription.xml of a shipped system with a fixed GUID and description (what the declarations give)."""
    ad = hf.make_adapter(shipped_systems_dir() / system)
    info = {"system": system, "guid": "{fixed}", "description": "d", "default_experiment": ad.default_experiment()}
    return model_description(ad, info, fmi_version)


def _elements(xml: bytes) -> list:
    """The XML as a list of (tag, attributes) in document order, without the generation date and the package
    version (they change with every build and release)."""
    root = ET.fromstring(xml)
    for key in ("generationDateAndTime", "version", "generationTool"):
        root.attrib.pop(key, None)
    return [[e.tag, dict(e.attrib)] for e in root.iter()]


def _same(a: str, b: str) -> bool:
    """Attribute values equal, numbers within 1e-9 relative (eigenvalues may differ in their last bits)."""
    if a == b:
        return True
    try:
        x, y = float(a), float(b)
    except ValueError:
        return False
    return math.isclose(x, y, rel_tol=1e-9, abs_tol=0.0)


@pytest.fixture(scope="module")
def planetary():
    return hf.make_adapter(ROOT / "models" / "planetary_65_55_175")


def _start(ad, **changes):
    values = {v.name: v.start for v in ad.variables if v.causality in ("parameter", "input")}
    values.update(changes)
    return values


def test_every_output_is_read_from_its_declaration(planetary):
    """Getters exist for exactly the declared outputs; every fast-path expression, evaluated on the simulator,
    equals its getter; the guarded outputs are the table post-processings (pressures, strains)."""
    ad = planetary
    ad.configure(_start(ad, planet_count=3))
    assert ad.advance(2e-4) == ""
    outputs = [v.name for v in ad.variables if v.causality == "output"]
    assert all(isinstance(ad.by_name[n].read, Reading) for n in outputs)
    get = ad.getters()
    calculated = [v.name for v in ad.variables if v.causality == "calculatedParameter"]
    assert sorted(get) == sorted(outputs + calculated) and calculated
    exprs = ad.output_expressions()
    assert set(exprs) < set(outputs) and {"sun_planet_1.force", "sun.speed", "ring_planet_2.dte"} <= set(exprs)
    for name, src in exprs.items():
        assert eval(src, {"s": ad.sim}) == get[name](), name
    assert ad.fallible == {n for n in outputs if n.endswith((".peak_pressure", ".flank_pressure", ".edge_pressure",
                                                             ".root_strain"))}
    assert {"sun_planet_1.flank_pressure", "ring_planet_2.edge_pressure"} <= set(outputs)
    assert ad.fallible
    # contact states of the one encoding; the set runs on its drive flanks
    assert get["sun_planet_1.contact"]() == ContactState.DRIVE_FLANK == get["sun_planet_1.contact_code"]()


def test_parts_the_structure_lacks_read_their_absent_value(planetary):
    """With 3 planets, the declared outputs of planets 4-6 read their declared ``absent`` value, in the getters and
    in the fast-path expressions alike."""
    ad = planetary
    ad.configure(_start(ad, planet_count=3))
    get, exprs = ad.getters(), ad.output_expressions()
    assert get["sun_planet_5.force"]() == 0.0 and exprs["sun_planet_5.force"] == "0.0"
    assert get["ring_planet_6.contact"]() == ContactState.SEPARATED
    assert get["sun_planet_4.out_of_range"]() is False
    assert get["sun_planet_1.force"]() > 0.0


def test_parameter_ranges_are_the_schema_ranges(planetary):
    """The FMU's parameter bounds are RANGES': modal damping [0, 1) (1.0 refused by the FMU as by model files and
    the system), bearing stiffness with inf, speeds."""
    by = planetary.by_name
    zeta = by["modal_damping_ratio"]
    r = RANGES["modal_damping_ratio"]
    assert (zeta.min, zeta.max, zeta.max_open) == (r.lo, r.hi, r.hi_open) == (0.0, 1.0, True)
    assert zeta.check(0.99) == "" and "[0, 1)" in zeta.check(1.0)
    k = by["sun.bearing_stiffness"]
    assert k.check(math.inf) == "" and k.max == RANGES["translational_stiffness_N_per_m"].hi
    w = by["sun.speed_in"]
    assert (w.min, w.max) == (RANGES["speed_rad_s"].lo, RANGES["speed_rad_s"].hi)


def test_open_bounds_and_readings_are_checked():
    """An open lower bound refuses the bound itself; a Reading needs exactly one source; only outputs are read."""
    v = FmuVariable("torque", "Real", "parameter", "fixed", "N.m", "a torque", 1.0, **ranged("torque_Nm"))
    assert "(0, 1e+08]" in v.check(0.0) and v.check(1e-9) == ""
    with pytest.raises(ValueError, match="exactly one"):
        Reading()
    with pytest.raises(ValueError, match="exactly one"):
        Reading(attr="mesh_force_N", call=lambda s, k: 0.0)
    with pytest.raises(ValueError, match="only outputs"):
        FmuVariable("x", "Real", "parameter", "fixed", "m", "x", 0.0, read=Reading(attr="x"))


def _reference() -> dict:
    with gzip.open(REFERENCE, "rt", encoding="utf-8") as f:
        return json.load(f)


@pytest.mark.parametrize("key", sorted(_reference()))
def test_model_description_of_every_shipped_system_is_unchanged(key):
    """Every shipped system's modelDescription.xml (both FMI versions) has the variables, value references, units,
    display units, ranges, nominal and start values and descriptions it had before the declarations were unified
    (numbers within 1e-9 relative)."""
    system, version = key.rsplit("_fmi", 1)
    got = _elements(_description(system, int(version)))
    ref = _reference()[key]
    assert [t for t, _ in got] == [t for t, _ in ref]
    for (tag, a), (_, b) in zip(got, ref):
        assert sorted(a) == sorted(b), (tag, a.get("name"))
        bad = {k: (a[k], b[k]) for k in a if not _same(a[k], b[k])}
        assert not bad, (tag, a.get("name"), bad)


if __name__ == "__main__" and sys.argv[1:] == ["--write"]:
    from hacgear_core.model import shipped_systems

    data = {f"{s}_fmi{v}": _elements(_description(s, v)) for s in shipped_systems()
            if (shipped_systems_dir() / s / "tables.h5").exists() for v in (2, 3)}
    REFERENCE.parent.mkdir(exist_ok=True)
    with gzip.open(REFERENCE, "wt", encoding="utf-8") as f:
        json.dump(data, f, indent=0, sort_keys=True)
    print(f"wrote {REFERENCE}: {len(data)} modelDescriptions")
