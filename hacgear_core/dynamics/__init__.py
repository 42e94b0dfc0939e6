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
from hacgear_core.dynamics.spur import (
    SpurPairParameters,
    SpurPairSimulator,
    SpurPairSystem,
    StepResult,
    from_model,
)

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
]
