"""pythonfmu slave of a hacgear gear system of kind planetary (FMI 2.0 co-simulation).

Thin on purpose: all behaviour (variables, checks, stepping the compiled kernel) is in the installed
package: :class:`hacgear_core.fmu.slave.HacgearSlave` with the generic :class:`hacgear_core.fmu.adapter.Adapter`.
``build_fmu.py`` copies this file into each FMU under the unique module name ``hacgear_<system>``.
Every kind has a file like this one; they differ only in ``KIND``.
"""
import ctypes
import json
import os

# pythonfmu 0.7.0's C wrapper (findClass) re-executes this module's source in its __dict__ on every
# fmi2Instantiate and then Py_DECREFs that dict although it holds only a borrowed reference.  A slave module
# whose dict has few other owners (this one defines no functions) is then freed under the live module:
# use-after-free, heap corruption, an abort at importer exit or a failed second instantiation.  Each
# execution of this line adds the reference that the wrapper will take away.
ctypes.pythonapi.Py_IncRef(ctypes.py_object(globals()))

from pythonfmu import Fmi2Slave  # noqa: F401  (pythonfmu's class finder needs it in this module)

try:
    from hacgear_core.fmu.slave import HacgearSlave
except ImportError as _exc:  # the importer's Python lacks hacgear: say what to install
    _here = os.path.dirname(os.path.abspath(__file__))
    try:
        with open(os.path.join(_here, "hacgear_fmu.json"), encoding="utf-8") as _f:
            _req = json.load(_f).get("requirements", {})
    except (OSError, ValueError):
        _req = {"hacgear": ""}
    raise ImportError(
        "this hacgear FMU runs its model in the importer's Python and needs the packages "
        + ", ".join(f"{k}{v}" for k, v in _req.items()) + f" ({_exc})") from _exc


class GearSystemSlave(HacgearSlave):
    """A hacgear gear system: constant-speed experiment (mode 0) or drivetrain coupling (mode 1)."""

    KIND = "planetary"
