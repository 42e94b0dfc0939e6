"""Runout as FMU parameters: ``<gear>.runout`` [m] and ``<gear>.runout_phase`` [rad] of every gear that may carry
manufacturing errors (:func:`hacgear_core.kinds.error_gears`: fixed-axis gears, a planetary set's sun, planet and
ring, the gears of every stage of a gearbox), their start values the model file's; the FMU's simulator (its
adapter, in process) set to a runout runs the library's system with that runout, and a zero runout the FMU's own
system."""
from __future__ import annotations

import math
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

import hacgear_core.fmu as hf
from hacgear_core.dynamics.simulator import Simulator
from hacgear_core.kinds import build_system, error_gears
from hacgear_core.model import GearErrors

from _fmu_runs import adapter_and_library_forces

ROOT = Path(__file__).resolve().parent.parent


def _start(ad, **changes):
    values = {v.name: v.start for v in ad.variables if v.causality in ("parameter", "input")}
    values.update(changes)
    return values


def _same_profiles_and_arrays(sy, ref, error_free) -> None:
    """``sy`` and ``ref`` carry equal error profiles on the same meshes (none where ``error_free(mesh name)``, a
    varying one elsewhere) and equal kernel arrays."""
    for c, cr in zip(sy.meshes, ref.meshes):
        assert (c.error is None) == (cr.error is None) == error_free(c.name), c.name
        if c.error is not None:
            assert np.array_equal(c.error[0], cr.error[0]) and tuple(c.error[1:]) == tuple(cr.error[1:])
            assert np.ptp(c.error[0]) > 0.0
    for f in fields(sy.arrays):
        assert np.array_equal(np.asarray(getattr(sy.arrays, f.name)), np.asarray(getattr(ref.arrays, f.name))), f.name


def test_runout_parameters_drive_the_simulator():
    """spur_28t_asym: one pair of parameters per gear, in [0, 1 mm] (displayed in um) and [-2 pi, 2 pi] (deg),
    start 0; pinion.runout = 10 um at 0.4 rad gives the system (fingerprint) and the mesh-force trace of the library
    run with that runout (the same simulator: equal); back to 0 the FMU's own system."""
    ad = hf.make_adapter(ROOT / "models" / "spur_28t_asym")
    names = [v.name for v in ad.variables if v.name.endswith((".runout", ".runout_phase"))]
    assert names == ["pinion.runout", "pinion.runout_phase", "wheel.runout", "wheel.runout_phase"]
    r, ph = ad.by_name["pinion.runout"], ad.by_name["pinion.runout_phase"]
    assert (r.unit, r.display_unit, r.min, r.max, r.start) == ("m", "um", 0.0, 1e-3, 0.0)
    assert (ph.unit, ph.display_unit, ph.min, ph.max) == ("rad", "deg", -2 * math.pi, 2 * math.pi)
    assert r.check(2e-3) and not r.check(1e-5)
    ad.configure(_start(ad, **{"pinion.runout": 10e-6, "pinion.runout_phase": 0.4}))
    m = ad.model
    ref = build_system(replace(m, gears=(replace(m.gears[0], errors=GearErrors(runout_m=10e-6, runout_phase_rad=0.4)),)
                               + tuple(m.gears[1:])), ad.tables)
    assert ad.sim.system.has_errors and ad.sim.system.fingerprint() == ref.fingerprint()
    sim = Simulator(ref)
    w = float(ad.by_name["pinion.speed_in"].start)
    sim.reset(speed_rad_s=w)
    sim.set_speed_input(speed_rad_s=w)
    ours, lib = [], []
    for _ in range(40):
        assert ad.advance(2e-5) == ""
        assert sim.advance(2e-5).success
        ours.append(ad.sim.mesh_force_N[0])
        lib.append(sim.mesh_force_N[0])
    assert np.array_equal(ours, lib)
    ad.configure(_start(ad))
    assert ad.sim.system is ad.base_system and not ad.sim.system.has_errors


@pytest.mark.parametrize("system, gears", [("planetary_65_55_175", ("sun", "planet", "ring")),
                                           ("reducer_19_71_23_83", ("pinion1", "wheel1", "pinion2", "wheel2"))])
def test_runout_parameters_only_where_errors_are_taken(system, gears):
    """One pair per gear that takes errors: the planetary set's sun, planet (every planet's) and ring, the
    reducer's four gears."""
    ad = hf.make_adapter(ROOT / "models" / system)
    assert error_gears(ad.model) == gears
    assert [v.name for v in ad.variables if v.name.endswith(".runout")] == [f"{g}.runout" for g in gears]
    assert [v.name for v in ad.variables if v.name.endswith(".runout_phase")] == [f"{g}.runout_phase" for g in gears]


def _with_errors(model, errors: dict):
    """``model`` with the errors ``errors`` {gear: GearErrors} (the other gears as the model file gives them)."""
    return replace(model, gears=tuple(replace(g, errors=errors[g.name]) if g.name in errors else g
                                      for g in model.gears))


def test_planetary_sun_runout_parameter_runs_the_library_system():
    """planetary_65_55_175: sun.runout = 10 um at 0.4 rad gives the library's system with that sun runout (the same
    fingerprint, error profiles on the three sun-planet meshes equal to the library's and none on the ring meshes,
    the same kernel arrays) and its mesh forces over a short run (within 1e-12 of their range); with planet_count
    = 4 the library's 4-planet system; back to 0 the FMU's own system.  The parameters' bounds are the fixed-axis
    ones."""
    ad = hf.make_adapter(ROOT / "models" / "planetary_65_55_175")
    r, ph = ad.by_name["sun.runout"], ad.by_name["sun.runout_phase"]
    assert (r.unit, r.display_unit, r.min, r.max, r.start) == ("m", "um", 0.0, 1e-3, 0.0)
    assert (ph.unit, ph.display_unit, ph.min, ph.max) == ("rad", "deg", -2 * math.pi, 2 * math.pi)
    ad.configure(_start(ad, **{"sun.runout": 10e-6, "sun.runout_phase": 0.4}))
    ref = build_system(_with_errors(ad.model, {"sun": GearErrors(runout_m=10e-6, runout_phase_rad=0.4)}), ad.tables)
    sy = ad.sim.system
    assert sy.has_errors and sy.fingerprint() == ref.fingerprint()
    assert sy.mesh_names == ref.mesh_names
    _same_profiles_and_arrays(sy, ref, lambda name: name.startswith("ring_"))
    ours, lib = adapter_and_library_forces(ad, ref)
    assert np.ptp(lib) > 0.0 and np.max(np.abs(ours - lib)) <= 1e-12 * np.ptp(lib)
    ad.configure(_start(ad, planet_count=4, **{"sun.runout": 10e-6, "sun.runout_phase": 0.4}))
    ref4 = build_system(_with_errors(ad.model, {"sun": GearErrors(runout_m=10e-6, runout_phase_rad=0.4)}),
                        ad.tables, planet_count=4)
    assert ad.sim.system.fingerprint() == ref4.fingerprint() and len(ref4.meshes) == 8
    ad.configure(_start(ad))
    assert ad.sim.system is ad.base_system and not ad.sim.system.has_errors


@pytest.fixture(scope="module")
def nrel():
    return hf.make_adapter(ROOT / "models" / "nrel_5mw_gearbox")


def test_gearbox_runout_parameters_of_every_stage(nrel):
    """nrel_5mw_gearbox: one pair per gear of every stage, in the model file's order (the planetary stages' sun,
    planet and ring, the helical stage's wheel and pinion), start 0; a planetary stage's phase turns relative to
    its own stage's carrier (the planet's runout is every planet's of that stage), the fixed-axis stage's in the
    fixed frame."""
    gears = ("sun1", "planet1", "ring1", "sun2", "planet2", "ring2", "wheel3", "pinion3")
    assert error_gears(nrel.model) == gears == tuple(g.name for g in nrel.model.gears)
    assert [v.name for v in nrel.variables if v.name.endswith((".runout", ".runout_phase"))] == [
        f"{g}{s}" for g in gears for s in (".runout", ".runout_phase")]
    for g in gears:
        r, ph = nrel.by_name[f"{g}.runout"], nrel.by_name[f"{g}.runout_phase"]
        assert (r.unit, r.display_unit, r.min, r.max, r.start) == ("m", "um", 0.0, 1e-3, 0.0)
        assert (ph.unit, ph.display_unit, ph.min, ph.max, ph.start) == ("rad", "deg", -2 * math.pi, 2 * math.pi, 0.0)
        stage = {"1": "stage1", "2": "stage2", "3": None}[g[-1]]
        assert ("relative to the carrier" in ph.description) == (stage is not None), g
        assert stage is None or f"in its sense of rotation relative to the carrier of stage {stage} (" in ph.description
        assert r.description.startswith(f"runout of every planet of stage {stage} (gear {g}):"
                                        if g.startswith("planet") else f"runout of gear {g}:"), g


def test_gearbox_sun_runout_parameter_runs_the_library_system(nrel):
    """nrel_5mw_gearbox: sun2.runout = 5 um at 0.7 rad gives the library's system of the model file with that
    runout in sun2's [gears.errors] (the same fingerprint, error profiles on stage 2's three sun-planet meshes
    only, equal to the library's, the same kernel arrays) and the same mesh forces over a short run (the same
    simulator on the same arrays: equal); back to 0 the FMU's own error-free system."""
    nrel.configure(_start(nrel, **{"sun2.runout": 5e-6, "sun2.runout_phase": 0.7}))
    ref = build_system(_with_errors(nrel.model, {"sun2": GearErrors(runout_m=5e-6, runout_phase_rad=0.7)}),
                       nrel.tables)
    sy = nrel.sim.system
    assert sy.has_errors and sy.fingerprint() == ref.fingerprint() and sy.mesh_names == ref.mesh_names
    _same_profiles_and_arrays(sy, ref, lambda name: not name.startswith("s2_sun_planet_"))
    ours, lib = adapter_and_library_forces(nrel, ref)
    assert np.ptp(lib) > 0.0 and np.array_equal(ours, lib)
    nrel.configure(_start(nrel))
    assert nrel.sim.system is nrel.base_system and not nrel.sim.system.has_errors


@pytest.mark.parametrize("gear, meshes", [("planet1", ("s1_sun_planet_", "s1_ring_planet_")),
                                         ("ring2", ("s2_ring_planet_",))])
def test_gearbox_planet_and_ring_runout_parameters_are_the_model_files(nrel, gear, meshes):
    """nrel_5mw_gearbox: planet1.runout (every planet of stage 1: its sun and ring meshes) and ring2.runout (stage 2's
    ring meshes), 5 um at 0.7 rad, give the library's system of the model file with that runout (fingerprint and
    kernel arrays equal), profiles on those meshes only."""
    nrel.configure(_start(nrel, **{f"{gear}.runout": 5e-6, f"{gear}.runout_phase": 0.7}))
    ref = build_system(_with_errors(nrel.model, {gear: GearErrors(runout_m=5e-6, runout_phase_rad=0.7)}),
                       nrel.tables)
    sy = nrel.sim.system
    assert sy.has_errors and sy.fingerprint() == ref.fingerprint()
    assert [c.name for c in sy.meshes if c.error is not None] == [c.name for c in sy.meshes
                                                                  if c.name.startswith(meshes)]
    for f in fields(sy.arrays):
        assert np.array_equal(np.asarray(getattr(sy.arrays, f.name)), np.asarray(getattr(ref.arrays, f.name))), f.name
    nrel.configure(_start(nrel))
    assert nrel.sim.system is nrel.base_system


def test_gearbox_zero_runouts_leave_the_error_free_system(nrel):
    """nrel_5mw_gearbox: the parameters' zero start values keep the FMU's own system, and the model with a zero
    runout written into every gear's [gears.errors] (what a runout parameter set to 0 gives) builds a system
    bit-identical to the error-free one (fingerprint and every kernel array): no error profile, no error loop."""
    nrel.configure(_start(nrel))
    assert nrel.sim.system is nrel.base_system and not nrel.base_system.has_errors
    zero = nrel._with_runouts(nrel.model, ((0.0, 0.0),) * len(nrel.runout_gears))
    assert all(g.errors is not None and g.errors.runout_m == 0.0 for g in zero.gears)
    sy, base = build_system(zero, nrel.tables), nrel.base_system
    assert not sy.has_errors and all(c.error is None for c in sy.meshes)
    assert sy.fingerprint() == base.fingerprint()
    for f in fields(sy.arrays):
        assert np.array_equal(np.asarray(getattr(sy.arrays, f.name)), np.asarray(getattr(base.arrays, f.name))), f.name
