"""Lumped-parameter gear dynamics with mesh forces from force-deflection tables (HAC method), one core for every
gear system.

:mod:`.system` (the assembled arrays of a lumped system; :mod:`hacgear_core.kinds` builds them from a model, one
kind each), :mod:`.laws` (the mesh laws: kernel variant, record fields, numpy twin), :mod:`.linear` (linearisation,
modal damping, step bound), :mod:`.parameters` (lumped spur-pair parameters), :mod:`.force_laws` (HAC and
conventional laws), :mod:`.kernels` (the compiled RK4 loop shared with the FMUs), :mod:`.simulator` (time stepping, both experiments), :mod:`.equilibrium` (static equilibrium),
:mod:`.steady` (steady-state detection and response metrics), :mod:`.floquet` (stability of periodic orbits),
:mod:`.sweep` (speed sweeps, jumps, resumable output), :mod:`.modes` (modal analysis, impulse test),
:mod:`.synthetic` (synthetic tables for tests and demonstrations).  The command line's MODEL argument is resolved
in :mod:`hacgear_core.cli.inputs`; the direct contact models HAC is checked against live in
:mod:`hacgear_core.studies`.
"""
from __future__ import annotations

from hacgear_core.dynamics.equilibrium import EquilibriumResult, static_equilibrium, static_state
from hacgear_core.dynamics.floquet import FloquetResult, floquet
from hacgear_core.dynamics.force_laws import FORCE_LAWS, ForceLaw, make_force_law
from hacgear_core.dynamics.modes import (
    ImpulseResult,
    ModalResult,
    identical_pair_mass_properties,
    impulse_test,
    modal_analysis,
)
from hacgear_core.dynamics.parameters import SpurPairParameters
from hacgear_core.dynamics.simulator import (GaugePassage, Simulator, StepResult, gauge_passage,
                                             static_gauge_passage, strain_of_tooth)
from hacgear_core.dynamics.steady import SteadyStateOptions, SteadyStateResult, steady_state
from hacgear_core.dynamics.sweep import SweepResult, SweepSpec, detect_jumps, run_sweep, run_sweeps
from hacgear_core.dynamics.system import GearBody, LumpedSystem, MeshCoupling

__all__ = [
    "FloquetResult",
    "floquet",
    "LumpedSystem",
    "GearBody",
    "MeshCoupling",
    "SpurPairParameters",
    "FORCE_LAWS",
    "ForceLaw",
    "make_force_law",
    "Simulator",
    "StepResult",
    "strain_of_tooth",
    "GaugePassage",
    "gauge_passage",
    "static_gauge_passage",
    "EquilibriumResult",
    "static_equilibrium",
    "static_state",
    "ModalResult",
    "ImpulseResult",
    "modal_analysis",
    "impulse_test",
    "identical_pair_mass_properties",
    "SteadyStateOptions",
    "SteadyStateResult",
    "steady_state",
    "SweepSpec",
    "SweepResult",
    "run_sweep",
    "run_sweeps",
    "detect_jumps",
]
