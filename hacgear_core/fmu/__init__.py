"""FMI 2.0 and FMI 3.0 co-simulation FMUs of gear systems: :mod:`.spec` (variables declared once), :mod:`.adapter`
(the one adapter of every kind: FMI variables <-> simulator), :mod:`.slave` (the FMI state machine and statuses
the FMU's binary calls), :mod:`.bootstrap` (the loader that runs in the importer's Python), :mod:`.numba_cache` (the compiled code an FMU
ships: collected at build time, installed at instantiation), ``fmu_src/`` of the checkout
(the C sources of the FMU binaries, installed as ``hacgear_core.fmu.slaves``), :mod:`.build` (FMU build, modelDescription.xml),
:mod:`.pythonfmu_backend` (the FMUs written by pythonfmu / pythonfmu3, their slave :mod:`.pythonfmu_slave`), :mod:`.components` (motor, shaft,
load of the benches), :mod:`.bench` (drivetrain benches of any number of gear stages), :mod:`.ssp` (the benches as
SSP files, run under fmpy and libcosim).

Only the run-time modules are imported here; the build-time names (``build_fmu``, ``synthetic_system_folder``,
...) load :mod:`.build` on first use.
"""
from __future__ import annotations

from hacgear_core.encodings import Experiment
from hacgear_core.fmu.adapter import Adapter, make_adapter, variables_for
from hacgear_core.fmu.slave import FMU_INFO_FILE, FmuInstance, fmu_info, value_references
from hacgear_core.fmu.spec import DISPLAY_UNITS, ENUMERATIONS, UNITS, FmuVariable

__all__ = [
    "FMU_INFO_FILE",
    "UNITS",
    "DISPLAY_UNITS",
    "ENUMERATIONS",
    "FmuVariable",
    "Adapter",
    "FmuInstance",
    "Experiment",
    "make_adapter",
    "variables_for",
    "fmu_info",
    "value_references",
    "build_fmu",
    "build_component_fmu",
    "model_description",
    "synthetic_system_folder",
    "fmu_file_name",
]

_BUILD_NAMES = ("build_fmu", "build_component_fmu", "model_description", "synthetic_system_folder", "fmu_file_name", "bundle_package",
                "compile_binary")


def __getattr__(name: str):
    if name in _BUILD_NAMES:
        from hacgear_core.fmu import build

        return getattr(build, name)
    raise AttributeError(f"module 'hacgear_core.fmu' has no attribute {name!r}")
