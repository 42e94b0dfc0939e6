"""Slave sources of the hacgear FMUs, one per system kind (installed as the package data
``hacgear_core.fmu.slaves``; :func:`hacgear_core.fmu.build.slave_source`).  The files differ only in the kind."""
