"""The result file of ``hacgear stiffness --out FILE.json``: written whole after every mesh, resumed by a re-run
with the same inputs.

The file holds the report of :func:`~hacgear_core.statics.studies.mesh_stiffness_report` (what ``--json``
prints) and three more keys:

``inputs``
    what the results depend on (:func:`stiffness_inputs`): ``format`` (:data:`FORMAT`), the model's name, the
    SHA-256 of the model's values (:func:`model_values_all`, after ``--no-relief``/``--no-crowning``) and
    the command's options (torque, side, positions, face slices, face coupling, twist, mesh selection, relief and
    crowning switches; options left to the model's default are ``null``, the model values fix them);
``inputs_sha256``
    SHA-256 of the canonical JSON of ``inputs`` (sorted keys, no spaces), the resume key;
``meshes_pending``
    the meshes of the run not solved yet, in model order (``[]`` when the file is complete).

:func:`write_results` replaces the file in one rename after each mesh (:func:`~hacgear_core.outpaths.written_whole`),
so a run killed at any moment (``kill -9`` included) leaves the file as it was after its last finished mesh, or no
file.  :func:`read_done` gives the meshes a file of the same inputs already holds; a file of other inputs (the
model changed, another torque ...) is refused, naming what differs, and kept: it is never reused or replaced
silently.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from hacgear_core.errors import HacgearError
from hacgear_core.jsonio import dumps
from hacgear_core.outpaths import written_whole

__all__ = ["FORMAT", "model_values_all", "stiffness_inputs", "inputs_sha256", "read_done", "write_results"]

#: identifies the layout and the rules of ``inputs`` (stored in ``inputs.format``)
FORMAT = "hacgear-stiffness-results/1"

#: fields of the model left out of :func:`model_values_all`: where it came from (file path and hash), its words
#: (title, source) and the damping, which no static solve reads
_LEFT_OUT = frozenset({"path", "sha256", "title", "source", "damping"})


def _canon(v: Any, top: bool = False) -> Any:
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return {f.name: _canon(getattr(v, f.name)) for f in dataclasses.fields(v)
                if not (top and f.name in _LEFT_OUT)}
    if isinstance(v, Mapping):
        return {str(k): _canon(v[k]) for k in sorted(v, key=str)}
    if isinstance(v, (tuple, list)):
        return [_canon(x) for x in v]
    if isinstance(v, np.ndarray):
        return [_canon(x) for x in v.tolist()]
    if isinstance(v, bool) or v is None or isinstance(v, str):
        return v
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return repr(float(v)) if math.isfinite(v) else str(float(v))
    return repr(v)


def model_values_all(model: Any) -> str:
    """Canonical JSON of every field of ``model`` (gears, meshes, materials, operating point, planetary set, the
    kind's own section ...) except its file path and hash, title, source and damping; floats by ``repr`` (exact),
    mappings by sorted key.  Wider than the
    tables' :func:`~hacgear_core.model.provenance.model_values` on purpose: the stiffness report also depends on
    the operating point and the planet count (the mesh forces), which the tables leave out."""
    return json.dumps(_canon(model, top=True), sort_keys=True, separators=(",", ":"))


def stiffness_inputs(model: Any, *, torque_Nm: float, side: str, positions: int, face_slices: int | None,
                     face_coupling: str | None, twist_rad: float, mesh: str | None, tip_relief: bool,
                     lead_crowning: bool) -> dict:
    """The ``inputs`` of a result file (module docstring): ``model`` as solved (after any variant), ``torque_Nm``
    [N m] > 0 on its torque gear, ``side`` drive|coast, ``positions`` per mesh cycle, ``face_slices`` /
    ``face_coupling`` (None: the model's default), ``twist_rad`` [rad], ``mesh`` (None: every mesh),
    ``tip_relief`` / ``lead_crowning`` (False: removed, ``--no-relief`` / ``--no-crowning``)."""
    return {
        "format": FORMAT, "model": model.name,
        "model_values_sha256": hashlib.sha256(model_values_all(model).encode()).hexdigest(),
        "torque_Nm": float(torque_Nm), "side": str(side), "positions": int(positions),
        "face_slices": None if face_slices is None else int(face_slices), "face_coupling": face_coupling,
        "twist_rad": float(twist_rad), "mesh": mesh, "tip_relief": bool(tip_relief),
        "lead_crowning": bool(lead_crowning),
    }


def inputs_sha256(inputs: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of ``inputs`` (sorted keys, no spaces): the resume key."""
    return hashlib.sha256(json.dumps(dict(inputs), sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def read_done(path: str | Path, inputs: Mapping[str, Any], option: str = "--out") -> dict[str, dict]:
    """The meshes that the result file ``path`` already holds for ``inputs`` ({mesh name: its report entry}, in
    the file's order; ``{}`` when there is no file).  Raises :class:`HacgearError` naming ``option`` for a file that
    is not a stiffness result file, or one of other inputs (naming each input that differs); the file is kept."""
    path = Path(path)
    if not path.exists():
        return {}
    keep = f"it is kept: write to another {option}, or replace it with --fresh"
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise HacgearError(f"{option} {str(path)!r} exists and is not a stiffness result file ({exc}); {keep}") \
            from None
    if not (isinstance(d, dict) and isinstance(d.get("inputs"), dict) and isinstance(d.get("meshes"), dict)
            and d["inputs"].get("format") == FORMAT):
        raise HacgearError(f"{option} {str(path)!r} exists and is not a stiffness result file of this version "
                           f"(no inputs.format = {FORMAT!r}); {keep}")
    old = d["inputs"]
    if d.get("inputs_sha256") != inputs_sha256(inputs) or inputs_sha256(old) != d.get("inputs_sha256"):
        diff = [f"{k}: {old.get(k)!r} in the file, {inputs.get(k)!r} now" for k in sorted(set(old) | set(inputs))
                if old.get(k) != inputs.get(k)]
        raise HacgearError(f"{option} {str(path)!r} holds stiffness results of other inputs (differs: "
                           + ("; ".join(diff) if diff else "inputs_sha256 does not match its inputs")
                           + f"); {keep}")
    return dict(d["meshes"])


def write_results(path: str | Path, report: Mapping[str, Any], inputs: Mapping[str, Any],
                  pending: Sequence[str]) -> Path:
    """Replace the result file ``path`` by ``report`` with its ``inputs``, ``inputs_sha256`` and ``meshes_pending``
    (written whole: a temporary file beside it, flushed to disk, then one rename).  Returns the path."""
    path = Path(path)
    data = {**report, "inputs": dict(inputs), "inputs_sha256": inputs_sha256(inputs),
            "meshes_pending": list(pending)}
    with written_whole(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(dumps(data, indent=1) + "\n")
            f.flush()
            os.fsync(f.fileno())
    return path
