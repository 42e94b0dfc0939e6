"""Exception types shared by all stages.  Every error a user can cause by input
(model file, table file, CLI option, FMU parameter) derives from :class:`HacgearError`
and carries a message naming the field, its unit and the allowed range."""
from __future__ import annotations

__all__ = ["HacgearError", "ModelError", "GeometryError", "TableError", "SolverError"]


class HacgearError(Exception):
    """Base class of user-facing hacgear errors (printed without traceback by the CLI)."""


class ModelError(HacgearError, ValueError):
    """A model file (TOML) or a model dataclass has a wrong, missing or unknown field."""


class GeometryError(HacgearError, ValueError):
    """The gear geometry is impossible (pointed tip, undercut beyond limits, interference...)."""


class TableError(HacgearError, ValueError):
    """A tables.h5 file is malformed, belongs to another model, or is queried out of range."""


class SolverError(HacgearError, RuntimeError):
    """A solver was asked for something it cannot do (e.g. non-converged contact)."""
