"""Lumped-parameter gear dynamics with mesh forces from force-deflection tables (HAC method).

Modules: :mod:`kernels` (compiled force laws and RK4 integrator, shared with the FMUs),
:mod:`fdf` (static quantities from a table), :mod:`conventional` (HAC and conventional force laws),
:mod:`spur` (spur-pair model, parameters, simulator), :mod:`steady` (steady-state detection),
:mod:`sweep` (speed sweeps, jumps, resumable HDF5 output), :mod:`modes` (natural frequencies),
:mod:`synthetic` (synthetic tables for tests and demonstrations).
"""
from __future__ import annotations

from hacgear_core.dynamics.conventional import FORCE_LAWS, ForceLaw, make_force_law
from hacgear_core.dynamics.fdf import StaticStiffness, static_stiffness
from hacgear_core.dynamics.modes import (
    ImpulseResult,
    ModalResult,
    identical_pair_mass_properties,
    impulse_test,
    modal_analysis,
)
from hacgear_core.dynamics.spur import (
    SpurPairParameters,
    SpurPairSimulator,
    SpurPairSystem,
    StepResult,
    from_model,
)
from hacgear_core.dynamics.steady import SteadyStateOptions, SteadyStateResult, steady_state
from hacgear_core.dynamics.sweep import SweepResult, SweepSpec, detect_jumps, run_sweep, run_sweeps

__all__ = [
    "FORCE_LAWS",
    "ForceLaw",
    "make_force_law",
    "StaticStiffness",
    "static_stiffness",
    "SpurPairParameters",
    "SpurPairSimulator",
    "SpurPairSystem",
    "StepResult",
    "from_model",
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
