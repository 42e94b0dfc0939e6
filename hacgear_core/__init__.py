"""hacgear: hybrid analytical-computational (HAC) gear dynamics.

The pipeline, one subpackage per stage: :mod:`.model` (model files → validated SI dataclasses, the one table of
parameter ranges; the kind's own rules are added by :mod:`.kinds`), :mod:`.geometry` (tooth profiles, gears, meshes, trains, planetary sets), :mod:`.statics`
(finite-element and contact analysis → force-deflection grids), :mod:`.tables` (the HDF5 tables and their
interpolation), :mod:`.kinds` (gear kinds as plug-ins: the registry, each kind's train description, the one
assembly into a lumped system; the full model loader ``kinds.load_model``), :mod:`.dynamics` (the lumped model:
system arrays, compiled kernel, simulator, steady states, sweeps, modes), :mod:`.fmu` (FMI 2.0 / 3.0
co-simulation FMUs and SSP benches).  Beside it: :mod:`.response` (root strain, contact pressure and mesh stiffness through the tables), :mod:`.studies` (the direct contact models HAC
is checked against, the validity map), :mod:`.plots` (figures), :mod:`.cli` (the ``hacgear`` command), and the
shared modules :mod:`.encodings` (experiment modes, contact states), :mod:`.errors`, :mod:`.jsonio`,
:mod:`.h5files`, :mod:`.outpaths`, :mod:`.workers`.  Everything inside is SI; no import cycle between modules or
subpackages, and nothing in the pipeline imports the command line, the plots or the studies
(``tests/test_imports.py``).
"""
from __future__ import annotations

__version__ = "0.1.0"

from hacgear_core.errors import GeometryError, HacgearError, ModelError, SolverError, TableError

__all__ = [
    "__version__",
    "HacgearError",
    "ModelError",
    "GeometryError",
    "TableError",
    "SolverError",
]
