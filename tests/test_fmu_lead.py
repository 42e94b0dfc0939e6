"""Lead slopes and shaft misalignment as FMU parameters: ``<gear>.lead_slope`` [m] of the gears of every mesh whose
system mesh runs on a table with a twist axis, and that mesh's ``<mesh>.misalignment_in_plane``,
``.misalignment_out_of_plane``, ``.axis_deviation_in_axes_plane`` and ``.axis_deviation_normal_to_axes_plane``
[rad] (:mod:`hacgear_core.dynamics.lead`: offsets of the mesh twist), their start values the model file's.  The
FMU's simulator (its adapter, in process) set to them runs the library's system of the model file with those
values; an offset beyond the table's twist axis is the FMU's error status with the builder's message."""
from __future__ import annotations

import json
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

import hacgear_core.fmu as hf
from hacgear_core.errors import ModelError
from hacgear_core.fmu.slave import ERROR, OK
from hacgear_core.kinds import build_system
from hacgear_core.model import GearErrors

from _fmu_runs import adapter_and_library_forces

ROOT = Path(__file__).resolve().parent.parent
MESH_PARAMETERS = ("misalignment_in_plane", "misalignment_out_of_plane", "axis_deviation_in_axes_plane",
                   "axis_deviation_normal_to_axes_plane")
LEAD = tuple(MESH_PARAMETERS) + ("lead_slope",)


def _start(ad, **changes):
    values = {v.name: v.start for v in ad.variables if v.causality in ("parameter", "input")}
    values.update(changes)
    return values


def _lead_names(ad):
    return [v.name for v in ad.variables if v.name.endswith(tuple(f".{p}" for p in LEAD))]


@pytest.fixture(scope="module")
def helical():
    return hf.make_adapter(ROOT / "models" / "helical_28_33")


def test_helical_lead_parameters_declared(helical):
    """helical_28_33: pinion.lead_slope and wheel.lead_slope in [-1, 1] mm (displayed in um), the four mesh inputs of
    m12 in [-0.01, 0.01] rad, start values the model file's (0); the descriptions name the
    model-file key, the sign convention and the mesh twist."""
    ad = helical
    assert _lead_names(ad) == ["pinion.lead_slope", "wheel.lead_slope"] + [f"m12.{p}" for p in MESH_PARAMETERS]
    m = ad.model
    for g in ("pinion", "wheel"):
        v = ad.by_name[f"{g}.lead_slope"]
        start = next(x.errors.lead_slope_m if x.errors else 0.0 for x in m.gears if x.name == g)
        assert (v.type, v.causality, v.variability, v.unit, v.display_unit, v.min, v.max, v.start) == (
            "Real", "parameter", "fixed", "m", "um", -1e-3, 1e-3, start)
        assert "lead_slope_um" in v.description and "+z face end" in v.description
        assert "offset of the mesh twist of m12" in v.description
    for p in MESH_PARAMETERS:
        v = ad.by_name[f"m12.{p}"]
        assert (v.type, v.causality, v.variability, v.unit, v.display_unit, v.min, v.max, v.start) == (
            "Real", "parameter", "fixed", "rad", "", -0.01, 0.01, getattr(m.meshes[0], f"{p}_rad"))
        assert f"[[meshes]] {p}_urad" in v.description and "offset of the" in v.description
        assert "mesh twist" in v.description and "positive" in v.description
        assert v.check(0.011) and not v.check(-1e-4)


def test_helical_lead_parameters_run_the_library_system(helical):
    """helical_28_33: pinion.lead_slope = 2.5 um and m12.misalignment_in_plane = 100 urad give the library's system of
    the model file with those values (the same fingerprint, the same kernel arrays, the mesh table's twist offset
    100 urad - 2.5 um / b_pinion) and the same mesh forces over a 40-step run (the same simulator on the same arrays:
    equal); back to the model's values the FMU's own system."""
    ad = helical
    ad.configure(_start(ad, **{"pinion.lead_slope": 2.5e-6, "m12.misalignment_in_plane": 1e-4}))
    m = ad.model
    pinion = m.gears[[g.name for g in m.gears].index("pinion")]
    model = replace(m, gears=tuple(replace(g, errors=replace(g.errors or GearErrors(), lead_slope_m=2.5e-6))
                                   if g.name == "pinion" else g for g in m.gears),
                    meshes=(replace(m.meshes[0], misalignment_in_plane_rad=1e-4),) + tuple(m.meshes[1:]))
    ref = build_system(model, ad.tables)
    sy = ad.sim.system
    assert sy is not ad.base_system and sy.fingerprint() == ref.fingerprint()
    assert sy.fingerprint() != ad.base_system.fingerprint()
    offset = sy.meshes[0].table.twist.twist_offset_rad
    assert offset == pytest.approx(1e-4 - 2.5e-6 / pinion.face_width_m, rel=1e-12)
    assert ad.base_system.meshes[0].table.twist.twist_offset_rad == 0.0
    for f in fields(sy.arrays):
        assert np.array_equal(np.asarray(getattr(sy.arrays, f.name)), np.asarray(getattr(ref.arrays, f.name))), f.name
    ours, lib = adapter_and_library_forces(ad, ref)
    assert np.ptp(lib) > 0.0 and np.array_equal(ours, lib)
    ad.configure(_start(ad))
    assert ad.sim.system is ad.base_system


def test_every_lead_parameter_sets_its_model_field(helical):
    """helical_28_33: wheel.lead_slope and each of the four mesh inputs (distinct small values, within the twist
    axis) give the library's system of the model file with those values in [gears.errors] and [[meshes]] (the same
    fingerprint); a system that differs from the FMU's own."""
    ad = helical
    mesh = {"misalignment_in_plane": 3e-5, "misalignment_out_of_plane": -4e-5, "axis_deviation_in_axes_plane": 5e-5,
            "axis_deviation_normal_to_axes_plane": -6e-5}
    ad.configure(_start(ad, **{"wheel.lead_slope": -1.5e-6}, **{f"m12.{p}": x for p, x in mesh.items()}))
    m = ad.model
    model = replace(m, gears=tuple(replace(g, errors=replace(g.errors or GearErrors(), lead_slope_m=-1.5e-6))
                                   if g.name == "wheel" else g for g in m.gears),
                    meshes=(replace(m.meshes[0], **{f"{p}_rad": x for p, x in mesh.items()}),) + tuple(m.meshes[1:]))
    ref = build_system(model, ad.tables)
    assert ad.sim.system.fingerprint() == ref.fingerprint() != ad.base_system.fingerprint()
    ad.configure(_start(ad))
    assert ad.sim.system is ad.base_system


def test_helical_lead_parameter_beyond_the_twist_axis_is_a_model_error(helical):
    """helical_28_33 (twist axis +-500 urad): m12.misalignment_in_plane = 600 urad is a ModelError naming the
    parameter and the axis; the system stays usable (the start values build the FMU's own system again)."""
    ad = helical
    with pytest.raises(ModelError) as exc:
        ad.configure(_start(ad, **{"m12.misalignment_in_plane": 6e-4}))
    msg = str(exc.value)
    assert msg.startswith("parameters m12.misalignment_in_plane = 0.0006 rad (offsets of the mesh twist): ")
    assert "outside the table's twist axis [-500.0, +500.0] urad" in msg and "max_twist_mrad" in msg
    ad.configure(_start(ad))
    assert ad.sim.system is ad.base_system


def test_helical_lead_parameter_beyond_the_twist_axis_is_the_fmu_error_status(helical, tmp_path):
    """The FMU instance (in process, on resources holding the model and tables): m12.misalignment_in_plane = 600
    urad makes exitInitializationMode return Error with the message naming the parameter (no traceback); 400 urad
    initializes and steps."""
    res = tmp_path / "resources"
    res.mkdir()
    for name in ("model.toml", "tables.h5"):
        (res / name).symlink_to(ROOT / "models" / "helical_28_33" / name)
    info = {"system": "helical_28_33", "kind": helical.kind, "guid": "{test}",
            "variables": [v.name for v in helical.variables]}
    (res / hf.FMU_INFO_FILE).write_text(json.dumps(info), encoding="utf-8")
    vr = hf.value_references(helical.variables)["m12.misalignment_in_plane"]
    for value, status in ((6e-4, ERROR), (4e-4, OK)):
        inst = hf.FmuInstance(res, "lead", "{test}")
        assert inst.set_real([vr], [value]) == OK
        assert inst.enter_initialization_mode(0.0) == OK
        assert inst.exit_initialization_mode() == status
        text = " ".join(m for _, _, m in inst.messages)
        if status == ERROR:
            assert "invalid parameters or start values: parameters m12.misalignment_in_plane = 0.0006 rad" in text
            assert "outside the table's twist axis" in text and "Traceback" not in text
        else:
            assert inst.do_step(0.0, 1e-5) == OK


def test_lead_parameters_only_on_meshes_with_a_twist_axis():
    """nrel_5mw_gearbox: only its helical stage (mesh s3_wheel_pinion, gears wheel3 and pinion3); spur_28t_asym (a
    spur pair without a twist axis): none."""
    ad = hf.make_adapter(ROOT / "models" / "nrel_5mw_gearbox")
    assert ad.lead_meshes == ("s3_wheel_pinion",) and ad.lead_gears == ("wheel3", "pinion3")
    assert _lead_names(ad) == ["wheel3.lead_slope", "pinion3.lead_slope"] + [
        f"s3_wheel_pinion.{p}" for p in MESH_PARAMETERS]
    spur = hf.make_adapter(ROOT / "models" / "spur_28t_asym")
    assert spur.lead_meshes == () and spur.lead_gears == () and _lead_names(spur) == []
