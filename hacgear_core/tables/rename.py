"""Renaming gears in a finished ``tables.h5`` (names only: every value and dataset stays as the statics wrote it).

A gear's name is a label: the static analyses do not depend on it, but a table records it (the canonical model
values and their hash, each mesh's ``gear_names`` and ``gauge_names``, the ``strain/<gear>`` and
``hub_reaction/<gear>`` datasets).  :func:`rename_gears` carries a rename of the model file over to its table
instead of re-running the statics: it first proves that the renamed model differs from the table's stored model
values in the names alone, then renames, records the rename in the root attribute ``renamed_gears`` and seals the
file again (docs/tables.md, "Renaming gears").
"""
from __future__ import annotations

import datetime as _dt
import json
from pathlib import Path
from typing import Any, Mapping

import h5py
import numpy as np

from hacgear_core.model import model_sha256, read_model
from hacgear_core.model.provenance import model_values, model_values_json, model_values_sha256, values_diff
from hacgear_core.errors import TableError
from hacgear_core.tables.format import seal_file

__all__ = ["rename_gears", "RENAMED_ATTR"]

#: root attribute listing the renames a table went through: JSON list of {"date", "renames"}
RENAMED_ATTR = "renamed_gears"


def _renamed_values(values: Any, renames: Mapping[str, str], under_gears: bool = False) -> Any:
    """The canonical model values with every gear name (keys of ``gears``, string values such as a mesh's
    ``gear_a``) replaced by its new name."""
    if isinstance(values, dict):
        return {(renames.get(k, k) if under_gears else k): _renamed_values(v, renames, k == "gears" and not under_gears)
                for k, v in values.items()}
    if isinstance(values, list):
        return [_renamed_values(v, renames) for v in values]
    if isinstance(values, str):
        return renames.get(values, values)
    return values


def _rename_group(g: Any, renames: Mapping[str, str]) -> None:
    """Rename the gears in one mesh group (and its coast subgroup): attributes and per-gear datasets."""
    names = [x.decode() if isinstance(x, bytes) else str(x) for x in g.attrs["gear_names"]]
    g.attrs["gear_names"] = np.array([renames.get(n, n) for n in names], dtype=h5py.string_dtype())
    gauges = [x.decode() if isinstance(x, bytes) else str(x) for x in g.attrs.get("gauge_names", [])]
    new_gauges = []
    for gname in gauges:
        gear, _, gauge = gname.partition("/")
        new_gauges.append(f"{renames.get(gear, gear)}/{gauge}" if gauge else gname)
    g.attrs["gauge_names"] = np.array(new_gauges, dtype=h5py.string_dtype())
    for sub in ("strain", "strain_twist", "hub_reaction"):
        if sub not in g:
            continue
        grp = g[sub]
        for old in [n for n in list(grp) if n in renames]:
            grp.move(old, f"__renaming__{old}")
        for old in [n for n in renames if f"__renaming__{n}" in grp]:
            grp.move(f"__renaming__{old}", renames[old])
    if "coast" in g and isinstance(g["coast"], h5py.Group):
        _rename_group(g["coast"], renames)


def rename_gears(path: str | Path, renames: Mapping[str, str], model: str | Path) -> dict[str, str]:
    """Rename gears in the finished table ``path`` so that it belongs to the model file ``model`` again.

    Parameters
    ----------
    path : str or Path
        The ``tables.h5`` to rewrite in place.
    renames : mapping of str to str
        Old gear name -> new gear name (the names in the table -> those in ``model``).
    model : str or Path
        The renamed model file: apart from the gear names its table-relevant values
        (:mod:`hacgear_core.model.provenance`) must equal those stored in the table.

    Returns
    -------
    dict
        ``model_values_sha256`` before and after.

    Raises
    ------
    TableError
        The table lacks its stored model values, names a gear it does not have, or the renamed values differ
        from ``model``'s in anything but the names (each difference named): then nothing is written.
    """
    path, mp = Path(path), Path(model)
    new_model = read_model(mp)
    with h5py.File(path, "r+") as f:
        stored_text = f.attrs.get("model_values", "")
        stored_text = stored_text.decode() if isinstance(stored_text, bytes) else str(stored_text)
        if not stored_text:
            raise TableError(f"{path}: no stored model values (written before hacgear recorded them): regenerate it "
                             f"with `hacgear statics {mp}` instead of renaming")
        stored = json.loads(stored_text)
        unknown = sorted(set(renames) - set(stored.get("gears", {})))
        if unknown:
            raise TableError(f"{path}: renames name gears the table does not have: {unknown} (it has "
                             f"{sorted(stored.get('gears', {}))})")
        want = json.loads(json.dumps(model_values(new_model)))
        got = _renamed_values(stored, renames)
        if got != want:
            diff = values_diff(got, want)
            raise TableError(f"{path}: after renaming {dict(renames)} the table's model values still differ from "
                             f"{mp} (" + "; ".join(diff) + "): a rename carries names only; regenerate the table "
                             f"with `hacgear statics {mp}`")
        before = str(f.attrs.get("model_values_sha256", ""))
        for m in f["meshes"]:
            _rename_group(f["meshes"][m], renames)
        history = json.loads(str(f.attrs.get(RENAMED_ATTR, "[]")))
        history.append({"date": _dt.datetime.now(_dt.timezone.utc).date().isoformat(), "renames": dict(renames)})
        f.attrs[RENAMED_ATTR] = json.dumps(history)
        f.attrs["model_values"] = model_values_json(new_model)
        f.attrs["model_values_sha256"] = model_values_sha256(new_model)
        f.attrs["model_sha256"] = model_sha256(mp)
        seal_file(f)
        return {"before": before, "after": str(f.attrs["model_values_sha256"])}
