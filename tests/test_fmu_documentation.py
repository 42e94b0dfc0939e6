"""Tests of hacgear_core.fmu.documentation: an FMU's documentation/index.html and coupling diagram from its spec."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from hacgear_core.fmu.adapter import make_adapter
from hacgear_core.fmu.build import PYTHON_REQUIREMENT, REQUIREMENTS
from hacgear_core.fmu.documentation import (calculated_values, coupling_diagram, documentation_html,
                                            documented_names)

ROOT = Path(__file__).resolve().parent.parent


def _info(system: str) -> dict:
    return {"system": system, "kind": "spur", "description": "d", "hacgear_version": "0", "guid": "{g}",
            "python": PYTHON_REQUIREMENT, "requirements": dict(REQUIREMENTS)}


@pytest.mark.parametrize("backend", ["native", "pythonfmu"])
def test_documentation_lists_every_variable_requirement_and_status(backend):
    """Every variable of the spec (not time) is a row with its unit and range; the requirements, the coupling
    and the statuses are stated; the backend's runtime notes differ (MSVC runtime for pythonfmu's win64 binary,
    the interpreter search of the native one)."""
    ad = make_adapter(ROOT / "models" / "spur_28t_asym")
    text = documentation_html(ad, _info("spur_28t_asym"), 2, backend)
    assert documented_names(text) == {v.name for v in ad.variables if v.causality != "independent"}
    for v in ad.variables:
        if v.causality == "independent":
            continue
        row = re.search(rf"<tr><td><code>{re.escape(v.name)}</code></td>(.*?)</tr>", text).group(1)
        assert f"<td>{v.unit}" in row or not v.unit, (v.name, row)
        if v.min is not None and v.max is not None:
            assert f"{v.max:.6g}" in row, (v.name, row)
    for word in [f"Python &gt;= {PYTHON_REQUIREMENT}"] + [f"{k} &gt;= {r}" for k, r in REQUIREMENTS.items()]:
        assert word in text, word
    for status in ("OK", "Warning", "Discard", "Error"):
        assert f"<b>{status}</b>" in text
    assert "mode</code> = 1" in text and "drivetrain_step" in text and "pinion.torque_in [N.m]--&gt;" in text
    assert ("MSVCP140.dll" in text) == (backend == "pythonfmu")
    assert ("HACGEAR_FMU_PYTHON" in text) == (backend == "native")
    assert text.count("<html") == 1 and text.rstrip().endswith("</html>")


@pytest.mark.parametrize("system", ["idler_28_33_39", "planetary_65_55_175"])
def test_coupling_diagram_shows_each_port_and_the_ratio(system):
    """Each port's torque input and motion outputs are in the diagram, the input port left; the gear ratio shown
    is the input over the output speed of the rigid train (the calculated parameters at the start values)."""
    ad = make_adapter(ROOT / "models" / system)
    values = calculated_values(ad)
    diagram = coupling_diagram(ad, values)
    inp = ad.spec_system.input_gear
    out = next(g for g in ad.ports if g != inp)
    first = diagram.splitlines()[1]
    assert first.index(f"{inp}.torque_in") < first.index("|") < first.index(f"{out}.torque_in")
    for g in ad.ports:
        for q in ("torque_in [N.m]", "speed [rad/s]", "angle [rad]"):
            assert f"{g}.{q}" in diagram
    assert values["gear_ratio"] == pytest.approx(1.0 / values[f"{out}.speed_ratio"], rel=1e-12)
    assert f"gear_ratio = {values['gear_ratio']:.6g}" in diagram
    assert math.isfinite(values["drivetrain_step"]) and 0 < values["drivetrain_step"] <= 1e-3
