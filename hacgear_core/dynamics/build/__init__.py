"""Builders: model (or lumped parameters) → :class:`~hacgear_core.dynamics.system.LumpedSystem`.

:mod:`.train` builds fixed-axis trains (spur pairs, idler chains).  :func:`build_system` dispatches on the
model's kind.
"""
from __future__ import annotations

from typing import Any

from hacgear_core.dynamics.build.train import (
    SpurPairParameters,
    TrainGear,
    TrainMesh,
    assemble_train,
    spur_pair_system,
    train_from_model,
)
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError

__all__ = [
    "build_system",
    "SpurPairParameters",
    "spur_pair_system",
    "TrainGear",
    "TrainMesh",
    "assemble_train",
    "train_from_model",
]

#: model kind -> builder(model, tables, **options) -> LumpedSystem
BUILDERS = {"spur_pair": train_from_model, "idler_chain": train_from_model}


def build_system(model: Any, tables: Any, **options) -> LumpedSystem:
    """The lumped system of ``model`` on its mesh ``tables`` (a :class:`~hacgear_core.tables.SystemTables` or
    {mesh name: MeshTable}).  ``options``: ``force_law``, ``torque_Nm``, ``bearing_stiffness_N_per_m``,
    ``modal_damping_ratio``, ``shafts`` (see :func:`.train.train_from_model`)."""
    builder = BUILDERS.get(model.kind)
    if builder is None:
        raise ModelError(f"no dynamics builder for system kind {model.kind!r} yet; available: {sorted(BUILDERS)}")
    return builder(model, tables, **options)
