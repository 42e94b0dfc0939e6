"""Wind-turbine drivetrain bench (hacgear_core.fmu.wind_turbine, the Rotor and Generator components,
examples/wind_turbine_bench.py, examples/wind_turbine_*.ssp).

Default suite: the shafts' closed-form stiffnesses, the components' closed forms (as Python objects and as FMUs),
the configuration's refusals, the shipped SSPs (pyssp-standard, the static torque flow and the scenarios' events
in their parameter values).  Behind ``-m slow`` (the gearbox FMU is built, and each scenario runs 1 s of
co-simulation): the steady rated torques equal the static ones, the gust's response, the stop's coast-flank
contact, the SSPs under fmpy and libcosim equal to the Python bench, the shipped SSPs are what the example writes.
"""
from __future__ import annotations

import importlib.util
import math
import zipfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("fmpy")

from hacgear_core.fmu.components import Generator, Rotor  # noqa: E402
from hacgear_core.fmu.ssp import SSD_FILE, read_ssp, ssp_step  # noqa: E402
from hacgear_core.fmu.wind_turbine import SCENARIOS, WindTurbineConfig, shaft_stiffness  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = {s: ROOT / "examples" / f"wind_turbine_{s}.ssp" for s in SCENARIOS}


def _example():
    spec = importlib.util.spec_from_file_location("example_wind_turbine_bench",
                                                  ROOT / "examples" / "wind_turbine_bench.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# ---------------------------------------------------------------------------------------------- closed forms
def test_shaft_stiffnesses_and_rated_torques():
    """k = G pi d^4 / (32 L), G = 206 GPa / 2.6: main shaft (700 mm, 2 m) 9.33804e8 N m/rad, high-speed shaft
    (333 mm, 1 m) 9.56469e7 N m/rad; rated rotor torque 5 MW / 12.1 rpm = 3.94599e6 N m, through 4625/48 the
    HSS's 40 952.98 N m (issue #52's static equilibrium)."""
    cfg = WindTurbineConfig()
    assert cfg.main_shaft_stiffness_Nm_per_rad == pytest.approx(9.33804e8, rel=1e-6)
    assert cfg.hss_stiffness_Nm_per_rad == pytest.approx(9.56469e7, rel=1e-6)
    assert shaft_stiffness(0.7, 2.0, 206e9 / 2.6) == cfg.main_shaft_stiffness_Nm_per_rad
    assert shaft_stiffness(0.7, 1.0, 1.0) == pytest.approx(2 * shaft_stiffness(0.7, 2.0, 1.0), rel=1e-15)
    assert cfg.rated_rotor_torque_Nm == pytest.approx(3.94599e6, rel=1e-6)
    assert cfg.rated_rotor_torque_Nm * 48 / 4625 == pytest.approx(40952.98, abs=0.01)
    with pytest.raises(ValueError, match="diameter"):
        shaft_stiffness(0.0, 1.0, 1.0)


def test_config_refusals():
    for kw, match in (({"rotor_inertia_kg_m2": -1.0}, "rotor_inertia_kg_m2"), ({"shaft_damping_ratio": 1.0},
                      "shaft_damping_ratio"), ({"event_time_s": 2.0}, "event_time_s"), ({"step_s": 0.1}, "step_s"),
                      ({"gust_factor": math.nan}, "gust_factor"), ({"generator_slip": 0.0}, "generator_slip")):
        with pytest.raises(ValueError, match=match):
            WindTurbineConfig(**kw)


def test_rotor_closed_form():
    """Constant aerodynamic torque on a free rotor: w = w0 + n h T / J; the step's torque from step_time on."""
    r = Rotor(inertia=2.0, aero_torque=10.0, step_time=0.05, step_torque=-4.0, speed_start=1.0)
    h = 1e-3
    for _ in range(50):
        r.advance(h)
    assert r.speed == pytest.approx(1.0 + 0.05 * 10.0 / 2.0, rel=1e-12) and r.torque == 10.0
    r.shaft_torque = 1.0
    for _ in range(50):
        r.advance(h)
    assert r.speed == pytest.approx(1.25 + 0.05 * (-4.0 - 1.0) / 2.0, rel=1e-12) and r.torque == -4.0


def test_generator_closed_forms():
    """At rated speed with the shaft carrying the rated torque the generator stays at rated speed; with a larger
    shaft torque it relaxes to the law's new balance w_r + dT / slope, as implicit Euler gives:
    e_n = e_0 / (1 + h slope / J)^n; after reversal_time its torque is reversal_torque (motoring when negative)."""
    tr, wr, d, j = 100.0, 50.0, 40.0, 2.0
    g = Generator(inertia=j, rated_torque=tr, rated_speed=wr, slope=d, reversal_time=1e9, reversal_torque=-tr,
                  speed_start=wr)
    g.shaft_torque = -tr  # the shaft drives the generator (side a) with the rated torque
    for _ in range(100):
        g.advance(1e-3)
    assert g.speed == pytest.approx(wr, rel=1e-14) and g.torque == pytest.approx(tr, rel=1e-14)
    assert g.power == pytest.approx(tr * wr, rel=1e-14)
    g.shaft_torque = -(tr + 20.0)
    n, h = 200, 1e-3
    for _ in range(n):
        g.advance(h)
    w_inf = wr + 20.0 / d
    assert g.speed - w_inf == pytest.approx((wr - w_inf) / (1 + h * d / j) ** n, rel=1e-9)
    # a stiff law on a small inertia (h slope / J = 50) stays bounded: no overshoot
    s = Generator(inertia=1e-3, rated_torque=tr, rated_speed=wr, slope=5e4, reversal_time=1e9, reversal_torque=0.0,
                  speed_start=wr + 1.0)
    s.shaft_torque = -tr
    s.advance(1e-3)
    assert 0 < s.speed - wr < 1.0 / 50
    rv = Generator(inertia=j, rated_torque=tr, rated_speed=wr, slope=d, reversal_time=0.01, reversal_torque=-tr,
                   speed_start=wr)
    rv.shaft_torque = -tr
    for _ in range(20):
        rv.advance(1e-3)
    assert rv.torque == -tr and rv.speed == pytest.approx(wr + 0.01 * 2 * tr / j, rel=1e-12)


def test_component_fmus_validate_and_equal_the_objects(tmp_path):
    """The rotor and generator FMUs pass fmpy's validation and give the Python objects' results."""
    import fmpy
    from fmpy.validation import validate_fmu

    from hacgear_core.fmu import build_component_fmu

    for kind in ("rotor", "generator"):
        assert validate_fmu(str(build_component_fmu(kind, tmp_path))) == [], kind
    r = fmpy.simulate_fmu(str(tmp_path / "hacgear_rotor.fmu"), stop_time=0.1, output_interval=1e-3,
                          start_values={"inertia": 2.0, "aero_torque": 10.0, "step_time": 0.05, "step_torque": -4.0,
                                        "speed_start": 1.0})
    assert r["speed"][-1] == pytest.approx(1.0 + 0.05 * 10.0 / 2.0 - 0.05 * 4.0 / 2.0, rel=1e-9)
    g = fmpy.simulate_fmu(str(tmp_path / "hacgear_generator.fmu"), stop_time=0.1, output_interval=1e-3,
                          start_values={"inertia": 2.0, "rated_torque": 100.0, "rated_speed": 50.0, "slope": 40.0,
                                        "speed_start": 51.0})
    obj = Generator(inertia=2.0, rated_torque=100.0, rated_speed=50.0, slope=40.0, reversal_time=1e9,
                    reversal_torque=-100.0, speed_start=51.0)
    for _ in range(100):
        obj.advance(1e-3)
    assert g["speed"][-1] == pytest.approx(obj.speed, rel=1e-12)


# ---------------------------------------------------------------------------------------------- shipped SSPs
def _validate(ssp: Path) -> list[str]:
    from pyssp_standard.ssp import SSP

    with SSP(ssp, mode="r") as archive:
        ssd = archive.system_structure
        ssd.__check_compliance__()
        return ssd.check_connections(unconnected_inputs=True, connector_not_in_system=True)


def test_shipped_ssps():
    """examples/wind_turbine_<scenario>.ssp: valid under pyssp-standard (every input connected once), structure
    only, gearbox in drivetrain mode; the parameter values hold the static torque flow of rated operation (shafts
    pre-twisted by rated torque / k, the gearbox's port torques in the ratio of its speeds, the generator's rated
    torque x speed = 5 MW), and each scenario's event: the gust steps the aerodynamic torque to 1.2 x rated, the
    stop reverses the generator torque, rated has neither."""
    pytest.importorskip("pyssp_standard")
    cfg = _example().bench_config()
    for sc, ssp in SHIPPED.items():
        assert _validate(ssp) == [], sc
        with zipfile.ZipFile(ssp) as z:
            assert z.namelist() == [SSD_FILE], sc
        comps, cons = read_ssp(ssp)
        assert set(comps) == {"rotor", "main_shaft", "gearbox", "hss", "generator"}, sc
        p = {c: v for c, (_, v) in comps.items()}
        gb = p["gearbox"]
        assert gb["mode"] == 1
        tr = cfg.rated_rotor_torque_Nm
        assert p["rotor"]["aero_torque"] == pytest.approx(tr, rel=1e-12)
        assert p["rotor"]["inertia"] == 57_231_535.0
        k1, k2 = p["main_shaft"]["stiffness"], p["hss"]["stiffness"]
        assert k1 == pytest.approx(9.33804e8, rel=1e-6) and k2 == pytest.approx(9.56469e7, rel=1e-6)
        assert k1 * p["main_shaft"]["twist_start"] == pytest.approx(tr, rel=1e-12)
        ports = [k[: -len(".torque_in")] for k in gb if k.endswith(".torque_in")]
        t_in, t_out = (gb[f"{q}.torque_in"] for q in ports)
        assert t_in == pytest.approx(tr, rel=1e-12)
        assert k2 * p["hss"]["twist_start"] == pytest.approx(t_out, rel=1e-12)
        gen = p["generator"]
        ratio = gen["rated_speed"] / p["rotor"]["speed_start"]
        assert -t_out * ratio == pytest.approx(tr, rel=1e-12)  # lossless: torques in the inverse speed ratio
        assert gen["rated_torque"] * gen["rated_speed"] == pytest.approx(5e6, rel=1e-12)
        assert gen["slope"] == pytest.approx(gen["rated_torque"] / (0.01 * gen["rated_speed"]), rel=1e-12)
        assert gen["inertia"] == pytest.approx(534.116 * (4625 / 48 / ratio) ** 2, rel=1e-12)
        ends = [(c[2], c[3]) for c in cons]
        assert len(ends) == len(set(ends)) == 8, sc
        step, stop = ssp_step(ssp)
        assert stop == pytest.approx(cfg.duration_s, rel=1e-12) and 0 < step <= 5e-5, sc
        gust = p["rotor"]["step_torque"] / tr
        rev = gen["reversal_torque"] / gen["rated_torque"]
        assert (gust, rev) == pytest.approx({"rated": (1.0, 1.0), "gust": (1.2, 1.0), "stop": (1.0, -1.0)}[sc]), sc
        assert (p["rotor"]["step_time"] == 0.2) == (sc == "gust") and (gen["reversal_time"] == 0.2) == (sc == "stop")


# ---------------------------------------------------------------------------------------------- runs (slow)
@pytest.fixture(scope="module")
def gearbox(tmp_path_factory):
    """The example's gearbox FMU (FMI 2.0) and its coupling parameters."""
    from hacgear_core.fmu import build_fmu
    from hacgear_core.fmu.wind_turbine import coupling
    from hacgear_core.model import resolve_model_path

    ex = _example()
    fmu = build_fmu(resolve_model_path(ex.SYSTEM).parent, tmp_path_factory.mktemp("gearbox"))
    return fmu, coupling(fmu, ex.bench_config())


@pytest.mark.slow
def test_scenarios(gearbox):
    """1 s of each scenario (event at 0.2 s).  Rated: the shaft torques' means over the last 0.2 s equal the static
    ones (main shaft 3.94599e6 N m, the HSS the rotor torque over the ratio) within 0.1 %, every mesh on its drive
    flank throughout.  Gust (+20 %): the shaft torques rise above 1.2 x static (the step's overshoot) and end within
    5 % of 1.2 x static; drive flanks throughout.  Stop (generator torque reversed at 0.2 s): drive flanks before the
    event; after it every mesh crosses the backlash onto its coast flank (coast force > 0) and the HSS torque
    reverses."""
    from hacgear_core.fmu.wind_turbine import run_wind_turbine, summary

    fmu, cp = gearbox
    cfg = _example().bench_config()
    out = {}
    for sc in SCENARIOS:
        res = run_wind_turbine(fmu, cfg, sc, cp)
        s = summary(res)
        st = res["layout"].static
        t = res["time_s"]
        out[sc] = s
        meshes = s["meshes"]
        if sc == "rated":
            assert s["main_shaft_mean_Nm"] == pytest.approx(st["rotor_torque_Nm"], rel=1e-3)
            assert s["hss_mean_Nm"] == pytest.approx(st["hss_torque_Nm"], rel=1e-3)
            assert all(m["drive"] == len(t) for m in meshes.values())
        elif sc == "gust":
            assert s["main_shaft_max_Nm"] > 1.2 * st["rotor_torque_Nm"]
            assert s["hss_max_Nm"] > 1.2 * st["hss_torque_Nm"]
            assert s["main_shaft_mean_Nm"] == pytest.approx(1.2 * st["rotor_torque_Nm"], rel=0.05)
            assert s["hss_mean_Nm"] == pytest.approx(1.2 * st["hss_torque_Nm"], rel=0.05)
            assert all(m["drive"] == len(t) for m in meshes.values())
        else:
            before = t < cfg.event_time_s
            for m in meshes:
                code = res[f"gearbox.{m}.contact_code"]
                assert np.all(code[before] == 1), m
                assert np.any(code == 2) and np.max(res[f"gearbox.{m}.coast_force"]) > 0, m
            assert s["first_coast_s"] > cfg.event_time_s
            assert s["hss_min_Nm"] < 0 and s["main_shaft_min_Nm"] < 0
    print(out)


def _short(cfg: WindTurbineConfig) -> WindTurbineConfig:
    """The bench cut to 0.05 s with the event at 0.01 s (before the stop's first backlash crossing)."""
    from dataclasses import replace

    return replace(cfg, duration_s=0.05, event_time_s=0.01)


@pytest.mark.slow
def test_ssps_under_fmpy_and_libcosim_equal_the_python_bench(gearbox, tmp_path):
    """Each scenario, 0.05 s with its event at 0.01 s, as an SSP with its FMUs: under fmpy (run_ssp_fmpy) equal to
    the Python bench bit for bit, under libcosim within 1e-9 of each series' largest value (libcosim's step is a
    whole number of nanoseconds: rounding-level differences, which the backlash crossing of the stop amplifies
    later: the window ends before it)."""
    pytest.importorskip("libcosimpy")
    from hacgear_core.fmu.ssp import run_ssp_fmpy, run_ssp_libcosim
    from hacgear_core.fmu.wind_turbine import run_wind_turbine, write_wind_turbine_ssp

    fmu, cp = gearbox
    cfg = _short(_example().bench_config())
    for sc in SCENARIOS:
        py = run_wind_turbine(fmu, cfg, sc, cp)
        st = py["layout"].static
        ssp = write_wind_turbine_ssp(fmu, tmp_path / f"{sc}.ssp", cfg, sc, cp=cp)
        rec = [r for r in py["layout"].record if not r[1].endswith("contact_code")]
        fm = run_ssp_fmpy(ssp, st["steps"], st["step_s"], py["layout"].record)
        lc = run_ssp_libcosim(ssp, st["steps"], None, rec)
        for c, v in py["layout"].record:
            assert np.array_equal(fm[f"{c}.{v}"], py[f"{c}.{v}"]), (sc, c, v)
        for c, v in rec:
            ref = py[f"{c}.{v}"]
            assert np.max(np.abs(lc[f"{c}.{v}"][1:] - ref[1:])) <= 1e-9 * max(np.max(np.abs(ref)), 1e-300), (sc, c, v)
        assert lc["time_s"][-1] == pytest.approx(cfg.duration_s, rel=1e-9)


@pytest.mark.slow
def test_shipped_ssps_are_what_the_example_writes(gearbox, tmp_path):
    """Regenerating the shipped SSPs from a freshly built gearbox FMU with the example's bench gives the shipped
    SystemStructure.ssd (tree and attributes; numbers within 1e-9).  When this fails, rewrite them with
    `python examples/wind_turbine_bench.py --ssp examples --structure-only`."""
    from test_fmu_ssp import _same_ssd

    from hacgear_core.fmu.wind_turbine import write_wind_turbine_ssp

    fmu, cp = gearbox
    ex = _example()
    for sc, shipped in SHIPPED.items():
        name = ex.SSP_NAME.format(scenario=sc)
        new = write_wind_turbine_ssp(fmu, tmp_path / f"{name}.ssp", ex.bench_config(), sc, fmus=False, name=name,
                                     cp=cp)
        with zipfile.ZipFile(new) as a, zipfile.ZipFile(shipped) as b:
            _same_ssd(a.read(SSD_FILE), b.read(SSD_FILE))
