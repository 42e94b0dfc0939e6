"""The model values that ``tables.h5`` depends on, in canonical form, and their hash (table provenance).

A table is the result of static contact analyses: it depends on the gear geometry (teeth, module, diameters,
tooth thickness, hob tip radius, face width, bore, web, modifications, helix), the elastic constants, the gauges,
the meshes (gears, loaded flanks, centre distance, placement) and the statics grid.  It does **not** depend on
comments, titles, the system name, damping, the operating point (torque, torque gear) or the planet count (they
only scale the load grid, whose range the table stores itself: ``hacgear statics --check`` compares it with the
model's nominal load), supports, densities or lumped mass/inertia overrides.

Rules of the canonical form (:func:`model_values`):

* every field of the model dataclasses is included unless :data:`EXCLUDED` names it, so a field added to the
  schema later is covered by default;
* a field at its dataclass default is left out, so adding a field with a default does not change the hash of
  existing models (and two different values of a field always give different hashes);
* floats are written with ``repr`` (exact round trip), gears and meshes keyed by name, SI units.

The hash (:func:`model_values_sha256`) is the SHA-256 of that JSON text.  :func:`values_diff` names the values
that differ between two canonical forms, for error messages.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from typing import Any, Mapping

from hacgear_core.model.schema import Gear, Material, Mesh, Model, Planetary

__all__ = ["CANONICAL_VERSION", "EXCLUDED", "model_values", "model_values_json", "model_values_sha256",
           "values_diff"]

#: identifies the rules above; stored inside the canonical form
CANONICAL_VERSION = "hacgear-model-values/1"

#: dataclass -> fields left out of the canonical form (the tables do not depend on them)
EXCLUDED: dict[type, frozenset[str]] = {
    # a kind's own section holds dynamics parameters (shafts, supports), not what the tables depend on
    Model: frozenset({"name", "title", "source", "damping", "operating", "path", "sha256", "defaults_applied",
                      "sections", "section"}),
    # manufacturing errors enter the dynamics as a shift of the lookup deflection, not the static contact analyses
    Gear: frozenset({"support", "mass_kg", "inertia_kgm2", "errors"}),
    # a shaft misalignment or axis deviation enters the dynamics as an offset of the tables' twist axis
    # (dynamics/lead.py)
    Mesh: frozenset({"misalignment_in_plane_rad", "axis_deviation_in_axes_plane_rad",
                     "axis_deviation_normal_to_axes_plane_rad", "misalignment_out_of_plane_rad"}),
    Material: frozenset({"name", "density_kg_per_m3"}),
    # the power flow's output member names the driver of each mesh, which the meshes' own gear order already holds
    Planetary: frozenset({"planet_count", "carrier_mass_kg", "carrier_inertia_kgm2", "carrier_support",
                          "output_member", "planet_errors"}),
}


def _default(f: dataclasses.Field) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
        return f.default_factory()  # type: ignore[misc]
    return dataclasses.MISSING


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(a == b) and type(a) is type(b)
    except Exception:  # noqa: BLE001 - arrays and other exotic defaults never equal
        return False


def _canon(v: Any) -> Any:
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        skip = EXCLUDED.get(type(v), frozenset())
        out = {}
        for f in dataclasses.fields(v):
            if f.name in skip:
                continue
            val = getattr(v, f.name)
            if _same(val, _default(f)):
                continue
            out[f.name] = _canon(val)
        return out
    if isinstance(v, Mapping):
        return {str(k): _canon(v[k]) for k in sorted(v)}
    if isinstance(v, (tuple, list)):
        return [_canon(x) for x in v]
    if isinstance(v, bool) or v is None or isinstance(v, str):
        return v
    if isinstance(v, int):
        return int(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else str(v)
    return repr(v)


def model_values(model: Model) -> dict:
    """The canonical form (module docstring) of the values ``model``'s tables depend on."""
    d = _canon(model)
    d["gears"] = {g["name"]: {k: x for k, x in g.items() if k != "name"} for g in d.get("gears", [])}
    d["meshes"] = {m["name"]: {k: x for k, x in m.items() if k != "name"} for m in d.get("meshes", [])}
    d["canonical"] = CANONICAL_VERSION
    return d


def model_values_json(model: Model) -> str:
    """:func:`model_values` as compact JSON with sorted keys (what the hash is taken of)."""
    return json.dumps(model_values(model), sort_keys=True, separators=(",", ":"))


def model_values_sha256(model: Model) -> str:
    """SHA-256 (hex) of :func:`model_values_json`: the key that ties tables to their model."""
    return hashlib.sha256(model_values_json(model).encode()).hexdigest()


def _flat(d: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(d, dict):
        out: dict[str, Any] = {}
        for k, v in d.items():
            out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    if isinstance(d, list):
        out = {}
        for i, v in enumerate(d):
            out.update(_flat(v, f"{prefix}[{i}]"))
        return out if d else {prefix: []}
    return {prefix: d}


def values_diff(old: Mapping | str, new: Mapping | str, limit: int = 6) -> list[str]:
    """Human-readable differences ``"<key>: <old> in the table, <new> now"`` between two canonical forms
    (dicts or their JSON), at most ``limit`` of them (then a count of the rest)."""
    a = _flat(json.loads(old) if isinstance(old, str) else dict(old))
    b = _flat(json.loads(new) if isinstance(new, str) else dict(new))
    lines = []
    for k in sorted(set(a) | set(b)):
        va, vb = a.get(k, "(default)"), b.get(k, "(default)")
        if va != vb:
            lines.append(f"{k}: {va} in the table, {vb} now")
    if len(lines) > limit:
        lines = lines[:limit] + [f"... and {len(lines) - limit} more"]
    return lines
