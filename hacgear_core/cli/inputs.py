"""Resolve the ``MODEL`` argument of the dynamics commands into a lumped system.

Accepted forms:

``models/<system>/model.toml``, its folder, or a shipped system name
    the model file and its ``tables.h5`` (hash-checked), built by :func:`~hacgear_core.kinds.build_system`;
``path/to/tables.h5``
    a tables file; the model file recorded in it (``model_file`` attribute, looked up next to the tables file);
``synthetic:28t[,key=value...]``
    the synthetic table of :func:`~hacgear_core.dynamics.synthetic.spur_fdf_table` with the dissertation's
    28-tooth gear blanks (outputs are labelled synthetic).  Keys: ``tip_relief_um``, ``contact_ratio``,
    ``stiffness_MN_per_m`` (mean mesh stiffness), ``variation`` (pair-stiffness variation), ``bearing_MN_per_m``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from hacgear_core.kinds import build_system, spur_pair_system, structural_parameters
from hacgear_core.dynamics.synthetic import spur_fdf_table, synthetic_28t_parameters
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError
from hacgear_core.kinds import load_model
from hacgear_core.tables import load_system_tables, read_tables

__all__ = ["DynamicsInputs", "load_inputs"]


@dataclass
class DynamicsInputs:
    """A lumped system with a label for reports; ``synthetic``: built on a synthetic table; ``model``: the model
    (None for synthetic inputs)."""

    system: LumpedSystem
    label: str
    synthetic: bool
    model: object = None


def _synthetic(spec: str, torque_Nm, bearing, damping, force_law, shafts) -> DynamicsInputs:
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
    changes = {}
    if torque_Nm is not None:
        changes["torque_Nm"] = torque_Nm
    if bearing is not None:
        changes["bearing_stiffness_N_per_m"] = (bearing, bearing)
    if damping is not None:
        changes["modal_damping_ratio"] = damping
    if changes:
        params = params.replace(**changes)
    return DynamicsInputs(spur_pair_system(params, table, force_law, shafts=shafts), spec, True)


def load_inputs(model: str, *, torque_Nm: float | None = None, bearing_stiffness_N_per_m: float | None = None,
                damping_ratio: float | None = None, tables: str | None = None, force_law: str = "hac",
                allow_hash_mismatch: bool = False, shafts: bool = True,
                planet_count: int | None = None) -> DynamicsInputs:
    """The lumped system of ``model`` (see module docstring) with optional overrides of the torque on the input
    gear [N m], every translational bearing stiffness [N/m] and the modal damping ratio; ``tables``: a tables
    file to use instead of the model folder's ``tables.h5`` (hash-checked unless ``allow_hash_mismatch``, an
    expert override for a table of an edited model file); ``shafts``: False drops rotational supports
    (drivetrain coupling); ``planet_count``: planetary sets, number of equally spaced planets (the tables are per
    mesh kind).  A lumped model (``[system] lumped = true``) needs no tables."""
    if model.startswith("synthetic:"):
        if planet_count is not None:
            raise ModelError("--planets applies to planetary models only")
        return _synthetic(model, torque_Nm, bearing_stiffness_N_per_m, damping_ratio, force_law, shafts)
    extra = {}
    if planet_count is not None:
        extra["planet_count"] = int(planet_count)
    path = Path(model)
    if path.suffix in (".h5", ".hdf5"):
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
        mdl = load_model(mp)
        tabs = read_tables(path, mp, allow_hash_mismatch=allow_hash_mismatch)
    else:
        mdl = load_model(model)
        if mdl.lumped:
            if tables is not None:
                raise ModelError(f"{mdl.name} is a lumped model (constant mesh stiffnesses): it takes no tables")
            tabs = None
        else:
            tabs = load_system_tables(model, tables, allow_hash_mismatch=allow_hash_mismatch)
    if extra and not set(extra) <= {p.name for p in structural_parameters(mdl)}:
        raise ModelError(f"--planets applies to planetary models only; {mdl.name} is a {mdl.kind}")
    system = build_system(mdl, tabs, force_law=force_law, torque_Nm=torque_Nm,
                          bearing_stiffness_N_per_m=bearing_stiffness_N_per_m, modal_damping_ratio=damping_ratio,
                          shafts=shafts, **extra)
    if tabs is None:
        return DynamicsInputs(system, f"{mdl.name} (lumped: constant mesh stiffnesses)", False, mdl)
    solvers = sorted({str(getattr(t, "solver", "") or "?").split(", mesh ")[0] for t in tabs.meshes.values()})
    synth = any("synthetic" in s for s in solvers)
    return DynamicsInputs(system, f"{mdl.name} (tables: {'; '.join(solvers)})", synth, mdl)
