"""The kinds registry: a kind's own model section is parsed by the kind at model load (errors with file, key, unit
and range), a table no kind takes is refused, and a kind's train is what the system is assembled from."""
from __future__ import annotations

import math
from dataclasses import dataclass

import pytest

from hacgear_core.errors import ModelError
from hacgear_core.kinds import KINDS, build_system, kind_of, load_model, parse_model
from hacgear_core.kinds.fixed_axis import FixedAxis
from hacgear_core.model import resolve_model_path
from hacgear_core.tables import load_system_tables


@dataclass(frozen=True)
class _Shaft:
    stiffness_Nm_per_rad: float


class _WithSection(FixedAxis):
    """A spur pair kind that reads a ``[shaft]`` section (the way a new kind adds its own parameters)."""

    section = "shaft"

    def parse_section(self, reader):
        if reader is None:
            raise ModelError("kind 'spur_with_shaft' needs a [shaft] table")
        k = reader.number("stiffness_Nm_per_rad", "N*m/rad", 0.0, 1e9, lo_open=True)
        reader.done(("stiffness_Nm_per_rad",))
        return _Shaft(k)


@pytest.fixture
def with_section(monkeypatch):
    monkeypatch.setitem(KINDS, "spur_with_shaft", _WithSection("spur_with_shaft", 1))
    text = resolve_model_path("spur_50t_icr18").read_text().replace('kind = "spur_pair"', 'kind = "spur_with_shaft"')
    assert 'kind = "spur_with_shaft"' in text
    return text


def test_a_kind_parses_its_own_section(with_section):
    m = parse_model(with_section + "\n[shaft]\nstiffness_Nm_per_rad = 2.5e4\n", file="x/model.toml")
    assert m.section == _Shaft(2.5e4) and kind_of(m).name == "spur_with_shaft"


def test_a_kind_section_out_of_range_is_refused_at_load_with_file_key_unit_and_range(with_section):
    with pytest.raises(ModelError, match=r"^x/model\.toml: key 'shaft\.stiffness_Nm_per_rad' \[N\*m/rad\].*1e\+09"):
        parse_model(with_section + "\n[shaft]\nstiffness_Nm_per_rad = 1e12\n", file="x/model.toml")
    with pytest.raises(ModelError, match=r"^x/model\.toml: kind 'spur_with_shaft' needs a \[shaft\] table"):
        parse_model(with_section, file="x/model.toml")


def test_a_table_no_kind_takes_is_refused():
    text = resolve_model_path("spur_50t_icr18").read_text() + "\n[shaft]\nstiffness_Nm_per_rad = 1.0\n"
    with pytest.raises(ModelError, match=r"^x/model\.toml: unknown key 'shaft' in \[top level\]"):
        parse_model(text, file="x/model.toml")


def test_build_system_assembles_the_kinds_train():
    """The fixed-axis kind's rigid bearings drop the translations: a spur pair on rigid bearings has its two
    rotations only, and the mesh vector is the pair of base radii (x = r_b1 th1 + r_b2 th2, Eq. 3.4)."""
    m = load_model("spur_50t_icr18")
    sy = build_system(m, load_system_tables(m.path), bearing_stiffness_N_per_m=math.inf)
    assert sy.dof_names == tuple(f"{g.name}.theta" for g in m.gears)
    rb = sy.meshes[0].base_radius_m
    assert abs(sy.V[0, 0]) == pytest.approx(rb[0], rel=1e-15) and abs(sy.V[0, 1]) == pytest.approx(rb[1], rel=1e-15)
    assert sy.V[0, 0] * sy.V[0, 1] > 0   # counter-rotating gears close the mesh together
