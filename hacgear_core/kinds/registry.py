"""The registry of gear kinds: ``[system] kind`` -> its :class:`~hacgear_core.kinds.base.Kind`."""
from __future__ import annotations

from typing import Any

from hacgear_core.errors import ModelError
from hacgear_core.kinds.base import Kind
from hacgear_core.kinds.fixed_axis import FixedAxis
from hacgear_core.kinds.gear_train import GearTrain
from hacgear_core.kinds.gearbox import GearboxKind
from hacgear_core.kinds.helical_pair import HelicalPair
from hacgear_core.kinds.planetary import PlanetaryKind

__all__ = ["KINDS", "kind_of"]

#: every kind, by name (a new kind adds its object here)
KINDS: dict[str, Kind] = {k.name: k for k in (
    FixedAxis("spur_pair", 1),
    FixedAxis("idler_chain", None),
    PlanetaryKind(),
    HelicalPair(),
    GearTrain(),
    GearboxKind(),
)}


def kind_of(model: Any) -> Kind:
    """The Kind of ``model`` (a Model, a LumpedSystem or a kind name)."""
    name = model if isinstance(model, str) else model.kind
    kind = KINDS.get(name)
    if kind is None:
        raise ModelError(f"key 'system.kind': unknown value {name!r}; allowed: {' | '.join(KINDS)}")
    return kind
