"""FMI 2.0 co-simulation FMUs of gear systems (pythonfmu): :mod:`.spec` (variables declared once), :mod:`.adapter`
(the one adapter of every kind: FMI variables <-> simulator), :mod:`.slave` (the pythonfmu slave, requirement
checks, pythonfmu workarounds), :mod:`.build` (FMU build and modelDescription post-processing), :mod:`.bench`
(drivetrain bench on fmpy's low-level API).  The slave sources (``fmu_src/``) are installed as
``hacgear_core.fmu.slaves``.

The importer's Python runs the slave and this package: the compiled kernels are imported from the installed
package's stable path (numba's disk cache hits), and two different hacgear FMUs in one importer share this code
while each FMU's own slave module has a unique name (``hacgear_<system>``).
"""
from __future__ import annotations

from hacgear_core.fmu.adapter import MODE_SPEED, MODE_TORQUE, Adapter, make_adapter, variables_for
from hacgear_core.fmu.build import build_fmu, postprocess_model_description, slave_source, synthetic_system_folder
from hacgear_core.fmu.slave import FMU_INFO_FILE, HacgearSlave, check_requirements, fmu_info, requirements
from hacgear_core.fmu.spec import UNITS, FmuVariable

__all__ = [
    "FMU_INFO_FILE",
    "UNITS",
    "FmuVariable",
    "Adapter",
    "HacgearSlave",
    "MODE_SPEED",
    "MODE_TORQUE",
    "make_adapter",
    "variables_for",
    "fmu_info",
    "check_requirements",
    "requirements",
    "build_fmu",
    "postprocess_model_description",
    "slave_source",
    "synthetic_system_folder",
]
