"""Manufacturing errors as design-study variables: ``gears[<gear>].errors.<key>`` names a gear's ``[gears.errors]``
key whether or not the base model has that table; the variants share their tables (the errors leave the model
values hash as it is) and differ in the dynamics (the sweeps)."""
from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from hacgear_core.errors import ModelError
from hacgear_core.kinds import parse_model
from hacgear_core.model.provenance import model_values_sha256
from hacgear_core.studies import load_study, parse_study, read_study, run_study
from hacgear_core.studies.design import variant_model_text

STUDY = """
[study]
name = "runout"
base_model = "spur_28t_asym"

[[variables]]
key = "gears[pinion].errors.runout_um"
values = [0.0, 10.0]

[[variables]]
key = "gears[*].errors.{second}"
values = {grades}

[statics]
positions = 16
loads = 8
deflections = 24
solver = "analytic"

[static]
torques_Nm = [300.0]

[dynamic]
torque_Nm = 300.0
mesh_frequency_Hz = [2000.0, 3200.0, {speeds}]
max_cycles = 1500
"""


def test_error_keys_are_study_variables_of_a_model_without_errors():
    """spur_28t_asym has no [gears.errors]: the variables create it in the selected gears; the variant is a valid
    model with those errors, its values hash the base model's (so the tables are the same); a key of another
    table that the model lacks is still refused."""
    spec = parse_study(STUDY.format(second="iso1328_grade", grades=[5, 7], speeds=3))
    text, base = variant_model_text(spec, (10.0, 7))
    raw = tomllib.loads(text)
    assert raw["gears"][0]["errors"] == {"runout_um": 10.0, "iso1328_grade": 7}
    assert raw["gears"][1]["errors"] == {"iso1328_grade": 7}
    model = parse_model(text, file="variant")
    assert model.gears[0].errors.runout_m == pytest.approx(10e-6) and model.gears[1].errors.iso1328_grade == 7
    zero = parse_model(variant_model_text(spec, (0.0, 5))[0], file="variant")
    assert model_values_sha256(zero) == model_values_sha256(model)
    bad = parse_study(STUDY.format(second="iso1328_grade", grades=[5], speeds=3).replace("errors.iso1328_grade",
                                                                                        "web.rim_mm"))
    with pytest.raises(ModelError, match=r"has no table 'gears.web'"):
        variant_model_text(bad, (0.0, 5))


def test_runout_study_shares_the_tables_and_moves_the_sweeps(tmp_path: Path):
    """Two variants (pinion runout 0 and 10 um; a seed alone is no error): one tables file, computed once, the same
    static rows; the sweeps differ (the runout adds to the mesh deflection's RMS at every speed)."""
    p = tmp_path / "s.toml"
    p.write_text(STUDY.format(second="seed", grades=[3], speeds=3))
    rep = run_study(load_study(p), tmp_path / "s.h5", workers=1, progress=False)
    assert [v.status for v in rep.variants] == ["computed"] * 2
    assert rep.variants[0].tables_file == rep.variants[1].tables_file and rep.variants[1].tables_reused
    res = read_study(tmp_path / "s.h5")
    for m, v in res.static.items():
        assert np.array_equal(v[0], v[1], equal_nan=True), m
    for br in ("up", "down"):
        rms = res.dynamic[br]["rms_deflection_m"]
        assert np.all(rms[1] > rms[0]), br
