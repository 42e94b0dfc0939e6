"""Sources of the FMU binaries: ``fmi2.c`` / ``fmi3.c`` (the FMI 2.0 / 3.0 co-simulation entry points) and
``bridge.h`` (the embedded-Python bridge they share), compiled by :mod:`hacgear_core.fmu.build` for every FMU.
Installed as package data ``hacgear_core.fmu.slaves`` (``pyproject.toml``)."""
