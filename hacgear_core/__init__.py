"""hacgear: hybrid analytical-computational (HAC) gear dynamics.

Pipeline stages, one module each: :mod:`model` (TOML → validated dataclasses),
:mod:`geometry`, :mod:`fe`, :mod:`contact`, :mod:`statics`, :mod:`tables`,
:mod:`dynamics`, :mod:`post`, :mod:`plots`, :mod:`cli`.  Everything inside is SI.
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
