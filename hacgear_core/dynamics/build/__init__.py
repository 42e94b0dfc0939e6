"""Builders: model (or lumped parameters) → :class:`~hacgear_core.dynamics.system.LumpedSystem`.

:mod:`.train` builds fixed-axis trains (spur pairs, idler chains), :mod:`.planetary` planetary sets (in the
carrier frame), :mod:`.helical` helical pairs (12 DOF).  :func:`build_system` dispatches on the
model's kind.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from hacgear_core.dynamics.build.helical import helical_from_model
from hacgear_core.dynamics.build.planetary import constant_stiffness_table, planetary_from_model
from hacgear_core.dynamics.build.train import (
    SpurPairParameters,
    TrainGear,
    TrainMesh,
    assemble_train,
    spur_pair_system,
    train_from_model,
)
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import GeometryError, ModelError
from hacgear_core.geometry.planetary import planetary_geometry
from hacgear_core.model.schema import RANGES

__all__ = [
    "build_system",
    "StructuralParameter",
    "structural_parameters",
    "SpurPairParameters",
    "spur_pair_system",
    "TrainGear",
    "TrainMesh",
    "assemble_train",
    "train_from_model",
    "planetary_from_model",
    "constant_stiffness_table",
    "helical_from_model",
]

#: model kind -> builder(model, tables, **options) -> LumpedSystem
BUILDERS = {"spur_pair": train_from_model, "idler_chain": train_from_model, "planetary": planetary_from_model,
            "helical_pair": helical_from_model}


@dataclass(frozen=True)
class StructuralParameter:
    """An integer option of a builder that changes the structure of the system (its DOFs and meshes), e.g. the
    planet count of a planetary set: ``name`` (the builder keyword), ``start``, ``min``, ``max`` and a
    ``description`` (FMUs declare their outputs for ``max`` and take the value as a fixed parameter)."""

    name: str
    start: int
    min: int
    max: int
    description: str


def structural_parameters(model: Any) -> tuple[StructuralParameter, ...]:
    """The structural options of ``model``'s builder (none for fixed-axis trains; ``planet_count`` for planetary
    sets: every count of :data:`~hacgear_core.model.schema.RANGES` ``planet_count`` up to the largest whose equally
    spaced planets the set can assemble without overlapping, the range the command line's ``--planets`` has too)."""
    if model.kind == "planetary":
        n = model.planetary.planet_count
        r = RANGES["planet_count"]
        n_max = max([k for k in range(int(r.lo), int(r.hi) + 1) if _planets_fit(model, k)] + [n])
        return (StructuralParameter(
            "planet_count", n, int(r.lo), n_max,
            f"number of equally spaced planets (1 to {n_max}"
            + (": more do not fit this set" if n_max < r.hi else "") + "); outputs of planets beyond it "
            "read 0 (the tables are per mesh kind: one FMU serves every count its tables' load range allows)"),)
    return ()


def _planets_fit(model: Any, count: int) -> bool:
    """Whether ``count`` equally spaced planets can be assembled in ``model``'s set without overlapping."""
    try:
        planetary_geometry(model, count)
    except (ModelError, GeometryError):
        return False
    return True


def build_system(model: Any, tables: Any, **options) -> LumpedSystem:
    """The lumped system of ``model`` on its mesh ``tables`` (a :class:`~hacgear_core.tables.SystemTables` or
    {mesh name: MeshTable}; None for a lumped model).  ``options``: ``force_law``, ``torque_Nm``,
    ``bearing_stiffness_N_per_m``, ``modal_damping_ratio``, ``shafts`` (see :func:`.train.train_from_model`);
    planetary sets also ``planet_count``, ``pin_errors_m`` (:func:`.planetary.planetary_from_model`)."""
    builder = BUILDERS.get(model.kind)
    if builder is None:
        raise ModelError(f"no dynamics builder for system kind {model.kind!r} yet; available: {sorted(BUILDERS)}")
    return builder(model, tables, **options)
