"""Model files → validated SI dataclasses: :mod:`.schema` (the dataclasses and their ranges), :mod:`.toml`
(the TOML reader with unit-suffixed keys, file/key/unit/range errors), :mod:`.toml_writer` (TOML text of a parsed
document: variant model files).  ``read_model`` validates every generic section; the rules of the model's kind are
added by :func:`hacgear_core.kinds.load_model`."""
from __future__ import annotations

from hacgear_core.model.schema import (
    FLANKS,
    RELIEF_SHAPES,
    WEB_MIN_RIM_M,
    Damping,
    Flank,
    Gauge,
    Gear,
    GearErrors,
    PlanetErrors,
    Material,
    Mesh,
    Model,
    Operating,
    Planetary,
    StaticsGrid,
    Support,
    Web,
)
from hacgear_core.model.toml import (
    read_model,
    model_sha256,
    parse_model,
    resolve_model_path,
    shipped_systems,
    shipped_systems_dir,
)

__all__ = [
    "FLANKS",
    "RELIEF_SHAPES",
    "WEB_MIN_RIM_M",
    "Material",
    "Flank",
    "Gauge",
    "Support",
    "Web",
    "Gear",
    "GearErrors",
    "PlanetErrors",
    "Mesh",
    "Damping",
    "Operating",
    "StaticsGrid",
    "Planetary",
    "Model",
    "read_model",
    "parse_model",
    "model_sha256",
    "resolve_model_path",
    "shipped_systems",
    "shipped_systems_dir",
]
