"""Resolve the ``MODEL`` argument of the dynamics commands into (parameters, mesh table).

Accepted forms:

``models/<system>/model.toml`` or its folder
    the model file and its ``tables.h5`` (hash-checked), parameters via
    :func:`~hacgear_core.dynamics.spur.from_model`;
``path/to/tables.h5``
    a tables file; parameters from the model file recorded in it (``model_file`` attribute, looked
    up next to the tables file); or give the model and ``tables=`` (CLI ``--tables``);
``synthetic:28t[,key=value...]``
    the synthetic table of :func:`~hacgear_core.dynamics.synthetic.spur_fdf_table` with the
    dissertation's 28-tooth gear blanks (outputs are labelled synthetic).  Keys:
    ``tip_relief_um``, ``contact_ratio``, ``stiffness_MN_per_m`` (mean mesh stiffness),
    ``variation`` (pair-stiffness variation), ``bearing_MN_per_m``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from hacgear_core.errors import ModelError

__all__ = ["DynamicsInputs", "load_inputs"]


@dataclass
class DynamicsInputs:
    params: object
    table: object
    label: str
    synthetic: bool


def _synthetic(spec: str) -> DynamicsInputs:
    from hacgear_core.dynamics.synthetic import spur_fdf_table, synthetic_28t_parameters

    body = spec.split(":", 1)[1]
    parts = [p for p in body.split(",") if p]
    if not parts or parts[0] != "28t":
        raise ModelError(f"synthetic model must be 'synthetic:28t[,key=value...]', got {spec!r}")
    kw = {"tip_relief_um": 0.0, "contact_ratio": 1.45, "stiffness_MN_per_m": 150.0, "variation": 0.15,
          "bearing_MN_per_m": math.inf}
    for p in parts[1:]:
        if "=" not in p:
            raise ModelError(f"synthetic option must be key=value, got {p!r}")
        k, v = p.split("=", 1)
        if k not in kw:
            raise ModelError(f"unknown synthetic option {k!r}; allowed: {sorted(kw)}")
        try:
            kw[k] = float(v)
        except ValueError:
            raise ModelError(f"synthetic option {k} must be a number, got {v!r}") from None
    table = spur_fdf_table(tip_relief_m=kw["tip_relief_um"] * 1e-6, contact_ratio=kw["contact_ratio"],
                           mean_stiffness_N_per_m=kw["stiffness_MN_per_m"] * 1e6,
                           stiffness_variation=kw["variation"])
    params = synthetic_28t_parameters(table, bearing_stiffness_N_per_m=kw["bearing_MN_per_m"] * 1e6)
    return DynamicsInputs(params, table, spec, True)


def load_inputs(model: str, *, mesh: str | None = None, torque_Nm: float | None = None,
                bearing_stiffness_N_per_m: float | None = None,
                damping_ratio: float | None = None, tables: str | None = None,
                allow_hash_mismatch: bool = False) -> DynamicsInputs:
    """Parameters and mesh table for ``model`` (see module docstring), with optional overrides of
    the torque on gear 1 [N m], both bearing stiffnesses [N/m] and the modal damping ratio;
    ``tables``: a tables file to use instead of the model folder's ``tables.h5`` (hash-checked unless
    ``allow_hash_mismatch``, an expert override for a table of an edited model file)."""
    if model.startswith("synthetic:"):
        inp = _synthetic(model)
    else:
        from hacgear_core.dynamics.spur import from_model

        path = Path(model)
        if path.suffix in (".h5", ".hdf5"):
            from hacgear_core.tables import read_tables

            tabs = read_tables(path)
            mf = str(getattr(tabs, "model_file", "") or "")
            if not mf:
                raise ModelError(f"{path} does not record its model file; pass the model.toml instead")
            mp = Path(mf)
            if not mp.is_absolute():
                mp = path.parent / mp
            if not mp.exists():
                cand = path.parent / "model.toml"
                mp = cand if cand.exists() else mp
            from hacgear_core.model import load_model

            mdl = load_model(mp)
            from hacgear_core.tables import read_tables as _rt

            tabs = _rt(path, mp, allow_hash_mismatch=allow_hash_mismatch)
        else:
            from hacgear_core.model import load_model
            from hacgear_core.tables import load_system_tables

            mdl = load_model(model)
            tabs = load_system_tables(model, tables, allow_hash_mismatch=allow_hash_mismatch)
        tm = tabs.mesh(mesh)
        params = from_model(mdl, tm.name, table=tm)
        solver = str(getattr(tm, "solver", "") or "?")
        synth = "synthetic" in solver
        inp = DynamicsInputs(params, tm, f"{mdl.name}/{tm.name} (table solver: {solver})", synth)
    changes = {}
    if torque_Nm is not None:
        changes["torque_Nm"] = torque_Nm
    if bearing_stiffness_N_per_m is not None:
        changes["bearing_stiffness_N_per_m"] = (bearing_stiffness_N_per_m, bearing_stiffness_N_per_m)
    if damping_ratio is not None:
        changes["modal_damping_ratio"] = damping_ratio
    if changes:
        inp.params = inp.params.replace(**changes)
    return inp
