"""Campbell diagrams (hacgear_core.spectra.campbell; `hacgear campbell`): crossings in closed form where the modes
do not depend on speed, found by bisection on the planetary set's gyroscopic modes, and the command."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hacgear_core.cli import main
from hacgear_core.cli.inputs import load_inputs
from hacgear_core.dynamics.modes import gyroscopic_modes, modal_analysis
from hacgear_core.errors import ModelError
from hacgear_core.spectra.campbell import RPM_PER_RAD_S, campbell


def test_spur_crossings_are_the_closed_form_and_the_mesh_resonance():
    """spur_28t_asym: the crossing of harmonic k with the mode f is at f / (k z) turns per second of the input
    gear, exactly (1e-12); k = 1 meets the 2786 Hz mesh resonance (docs/validation.md) at 60 x 2786.4 / 28 rpm."""
    sy = load_inputs("spur_28t_asym").system
    f = modal_analysis(sy).natural_frequencies_Hz
    res = campbell(sy, np.linspace(0, 10000, 11) / RPM_PER_RAD_S, harmonics=3, shaft_orders=1)
    assert not res.speed_dependent and res.input_gear == "pinion"
    assert res.mesh_hz_per_rad_s == pytest.approx(28 / (2 * math.pi), rel=1e-12)
    mesh = [c for c in res.crossings if c.line.endswith("f_m")]
    assert len(mesh) == 3 * len(f)
    for c in mesh:
        k = int(c.line.split()[0])
        turns = f[c.mode] / (k * 28)
        assert abs(c.input_speed_rad_s / (2 * math.pi) - turns) <= 1e-12 * turns
        assert c.input_speed_rpm == pytest.approx(60 * turns, rel=1e-12) and c.closed_form
        assert c.mesh_frequency_Hz == pytest.approx(f[c.mode] / k, rel=1e-12)
    first = next(c for c in mesh if c.line == "1 x f_m" and c.mode == 0)
    assert abs(first.frequency_Hz - 2786.0) < 0.005 * 2786.0
    assert first.input_speed_rpm == pytest.approx(60 * 2786.37 / 28, rel=1e-4)
    # a shaft line (once per revolution, 2786 Hz = 167 000 rpm) does not cross within 10 000 rpm
    assert not [c for c in res.crossings if "pinion" in c.line]
    assert res.natural_frequencies_Hz.shape == (11, len(f))


def test_idler_and_helical_lines_cross_every_mode_in_range():
    for name in ("idler_28_33_39", "helical_28_33"):
        sy = load_inputs(name).system
        f = modal_analysis(sy).natural_frequencies_Hz
        res = campbell(sy, np.array([0.0, 20000.0]) / RPM_PER_RAD_S, harmonics=2)
        for ln in res.lines:
            want = [fi for fi in f if fi / ln.hz_per_rad_s <= 20000 / RPM_PER_RAD_S]
            got = sorted(c.frequency_Hz for c in res.crossings if c.line == ln.label)
            assert got == pytest.approx(sorted(want), rel=1e-12), (name, ln.label)


def test_planetary_crossings_lie_on_the_gyroscopic_modes():
    """planetary_65_55_175: the modes move with the carrier speed; at each crossing the mode of its rank at that
    speed equals the line's frequency (1e-9), and at speed 0 the modes are the static ones."""
    sy = load_inputs("planetary_65_55_175").system
    res = campbell(sy, np.linspace(0, 3000, 16) / RPM_PER_RAD_S, harmonics=2, shaft_orders=0)
    assert res.speed_dependent and res.crossings
    g0 = gyroscopic_modes(sy, 0.0).natural_frequencies_Hz
    assert res.natural_frequencies_Hz[0] == pytest.approx(np.sort(g0[g0 > 0]), rel=1e-12)
    assert not np.allclose(res.natural_frequencies_Hz[0], res.natural_frequencies_Hz[-1], rtol=1e-3)
    for c in res.crossings:
        wc = sy.carrier_ratio * c.input_speed_rad_s
        g = gyroscopic_modes(sy, wc)
        fm = np.sort(g.natural_frequencies_Hz[np.array([t != "rigid" for t in g.types])])
        assert abs(fm[c.mode] - c.frequency_Hz) <= 1e-9 * c.frequency_Hz
        assert not c.closed_form and 0 <= c.input_speed_rpm <= 3000


def test_campbell_command(tmp_path, capsys):
    out = tmp_path / "c.png"
    assert main(["campbell", "spur_28t_asym", "--speeds", "0:8000:9", "--plot", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["input_gear"] == "pinion" and len(rep["input_speed_rpm"]) == 9
    c1 = next(c for c in rep["crossings"] if c["line"] == "1 x f_m")
    assert c1["input_speed_rpm"] == pytest.approx(60 * c1["frequency_Hz"] / 28, rel=1e-12)
    assert out.stat().st_size > 10_000
    assert main(["campbell", "idler_28_33_39", "--speeds", "0:3000:4"]) == 0
    assert "crossing(s)" in capsys.readouterr().out
    assert main(["campbell", "spur_28t_asym", "--speeds", "100:50:3"]) == 2
    with pytest.raises(ModelError):
        campbell(load_inputs("spur_28t_asym").system, [1.0])
