"""Gear kinds as plug-ins: the registry (the only place a kind name is matched), the train description each kind
hands to the one assembly, and the model loader and system builder that dispatch on a model's kind."""
from __future__ import annotations

import difflib
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

from hacgear_core.dynamics.lead import check_lead_inputs
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError
from hacgear_core.kinds.assembly import assemble
from hacgear_core.kinds.base import Kind, StructuralParameter, Train
from hacgear_core.kinds.fixed_axis import SpurPairParameters, TrainGear, TrainMesh, fixed_axis_train, spur_pair_system
from hacgear_core.kinds.helical_pair import helical_from_model
from hacgear_core.kinds.planetary import constant_stiffness_table, planetary_from_model
from hacgear_core.kinds.registry import KINDS, kind_of
from hacgear_core.model import Model, read_model
from hacgear_core.model.toml import TOP_LEVEL_KEYS, SectionReader
from hacgear_core.model import parse_model as read_model_text

__all__ = [
    "KINDS",
    "Kind",
    "Train",
    "kind_of",
    "load_model",
    "parse_model",
    "check_model",
    "build_system",
    "error_gears",
    "StructuralParameter",
    "structural_parameters",
    "assemble",
    "SpurPairParameters",
    "spur_pair_system",
    "TrainGear",
    "TrainMesh",
    "fixed_axis_train",
    "planetary_from_model",
    "constant_stiffness_table",
    "helical_from_model",
]


def check_model(model: Model, file: str | None = None) -> Model:
    """``model`` with its kind's own section parsed (:meth:`Kind.parse_section` of ``model.sections``, stored as
    ``model.section``) after its kind's checks (:meth:`Kind.check`); raises ModelError naming the file (``file``,
    default the model's path) and the key."""
    where = str(file or model.path or "<model>")
    try:
        kind = kind_of(model)
        extra = sorted(set(model.sections) - {kind.section})
        if extra:
            allowed = sorted(set(TOP_LEVEL_KEYS) | ({kind.section} if kind.section else set()))
            near = difflib.get_close_matches(extra[0], allowed, n=1)
            hint = f"did you mean '{near[0]}'? " if near else ""
            raise ModelError(f"unknown key '{extra[0]}' in [top level]; {hint}allowed keys for kind '{kind.name}': "
                             f"{', '.join(allowed)}")
        raw = model.sections.get(kind.section) if kind.section else None
        reader = None if raw is None else SectionReader(raw, kind.section, where)
        model = replace(model, section=kind.parse_section(reader))
        kind.check(model)
    except ModelError as exc:
        if str(exc).startswith(where):
            raise
        raise ModelError(f"{where}: {exc}") from None
    return model


def load_model(model: str | Path) -> Model:
    """Read and validate a model file (path, folder or system name), its kind's rules included."""
    return check_model(read_model(model))


def parse_model(text: str, **options) -> Model:
    """Parse model TOML text (:func:`hacgear_core.model.parse_model` options), its kind's rules included."""
    return check_model(read_model_text(text, **options), options.get("file"))


def build_system(model: Any, tables: Any, **options) -> LumpedSystem:
    """The lumped system of ``model`` on its mesh ``tables`` (a :class:`~hacgear_core.tables.SystemTables` or
    {mesh name: MeshTable}; None for a lumped model): its kind's train, assembled.  ``options``: ``force_law``,
    ``torque_Nm``, ``bearing_stiffness_N_per_m``, ``modal_damping_ratio``, ``shafts`` and the kind's structural
    parameters (planetary sets: ``planet_count``, ``pin_errors_m``).  Gears with manufacturing errors
    (``[gears.errors]``) give their meshes error profiles (:mod:`hacgear_core.dynamics.gear_errors`; spur and
    helical pairs, idler chains, planetary sets, gear trains and the stages of gearboxes, planetary ones included)."""
    system = assemble(kind_of(model).train(model, tables, **options))
    check_lead_inputs(model, system)
    if _has_errors(model):
        system = _with_model_errors(model, system)
    return system


def _has_errors(model: Any) -> bool:
    """Whether a gear of ``model`` (``[gears.errors]``) or a single planet of one of its planetary sets
    (``[[planetary.planet_errors]]``, a gearbox's stages included) has a pitch or runout error."""
    if any(getattr(g, "errors", None) is not None and g.errors.any for g in getattr(model, "gears", ())):
        return True
    sets = [getattr(model, "planetary", None)]
    sets += [st.planetary for st in getattr(getattr(model, "section", None), "planetary", ()) or ()
             if hasattr(st, "planetary")]
    return any(pe.errors.any for p in sets if p is not None for pe in getattr(p, "planet_errors", ()))


def _with_model_errors(model: Any, system: LumpedSystem) -> LumpedSystem:
    """``system`` with the error profiles of ``model``'s gears (:func:`~hacgear_core.dynamics.gear_errors.
    with_gear_errors`; planetary sets and a gearbox's planetary stages: their gear and mesh instances in the carrier
    frame, :func:`~hacgear_core.kinds.planetary.planetary_error_inputs`); kinds other than fixed-axis trains (spur
    and helical pairs, idler chains, gear trains), planetary sets and gearboxes are refused."""
    from hacgear_core.dynamics.gear_errors import with_gear_errors
    from hacgear_core.geometry import mesh_geometry

    if model.kind == "planetary":
        from hacgear_core.kinds.planetary import planetary_error_inputs
        inp = planetary_error_inputs(model, len(system.meshes) // 2)
        return with_gear_errors(system, inp["gears"], inp["pressure_angles_rad"],
                                internal_gears=inp["internal_gears"], runout_passage=inp["runout_passage"],
                                coast_pressure_angles_rad=inp["coast_pressure_angles_rad"])
    bad = [g.name for g in model.gears if g.errors is not None and g.errors.any]
    fixed_axis = set(_fixed_axis_error_gears(model))
    if not fixed_axis and model.kind != "gearbox":
        raise ModelError(f"{model.path or model.name}: [gears.errors] of {bad}: manufacturing errors are supported "
                         f"on kinds spur_pair, helical_pair, idler_chain, planetary, gear_train and gearbox, not yet "
                         f"on '{model.kind}'")
    gears = {g.name: (g.errors, 0.5 * g.module_m * g.teeth, g.module_m * math.cos(g.helix_angle_rad))
             for g in model.gears if g.name in fixed_axis}
    # the fixed-axis meshes of the gears with errors (the others keep no profile)
    erring = [m for m in model.meshes if {m.gear_a, m.gear_b} & set(bad) and m.gear_a in fixed_axis]
    mgeo = {m.name: mesh_geometry(model, m.name) for m in erring}
    alpha = {name: g.operating_pressure_angle_rad for name, g in mgeo.items()}
    alpha_c = {name: g.operating_pressure_angle_coast_rad for name, g in mgeo.items()}
    # a helical mesh's deflection is along the flank normal: cos(beta_b) of a transverse displacement
    # (tan beta_b = tan beta cos alpha_t)
    gd = {g.name: g for g in model.gears}
    factor = {m.name: math.cos(math.atan(abs(math.tan(gd[m.gear_a].helix_angle_rad))
                                         * math.cos(gd[m.gear_a].flanks["drive"].pressure_angle_rad)))
              for m in erring}
    internal, passage = (), None
    if model.kind == "gearbox":
        from hacgear_core.kinds.gearbox import planetary_stage_error_inputs
        inp = planetary_stage_error_inputs(model)
        gears.update(inp["gears"])
        alpha.update(inp["pressure_angles_rad"])
        alpha_c.update(inp["coast_pressure_angles_rad"])
        internal, passage = inp["internal_gears"], inp["runout_passage"]
    return with_gear_errors(system, gears, alpha, normal_factor=factor, internal_gears=internal,
                            coast_pressure_angles_rad=alpha_c,
                            runout_passage=passage)


def error_gears(model: Any) -> tuple[str, ...]:
    """The gears of ``model`` (names of its ``[[gears]]``, in their order) that may carry manufacturing errors
    (``[gears.errors]``, :func:`build_system`); an FMU takes the runout of each as parameters (``<gear>.runout``,
    ``.runout_phase``).

    Every gear of a spur or helical pair, idler chain or gear train; the sun, planet and ring of a planetary set
    (the planet's errors apply to every planet alike, :func:`~hacgear_core.kinds.planetary.planetary_error_inputs`);
    the gears of every stage of a gearbox: its fixed-axis stages' and its planetary stages' (the sun, planet and
    ring of each, in its carrier's frame as a planetary set's,
    :func:`~hacgear_core.kinds.gearbox.planetary_stage_error_inputs`).  Empty for the other kinds and for lumped
    models (no tooth geometry).
    """
    if getattr(model, "lumped", False):
        return ()
    if model.kind == "gearbox":
        from hacgear_core.kinds.gearbox import gearbox_stages

        staged = {g for s in gearbox_stages(model) for g in s.gears}
        return tuple(g.name for g in model.gears if g.name in staged)
    if model.kind in ("spur_pair", "idler_chain", "helical_pair", "gear_train", "planetary"):
        return tuple(g.name for g in model.gears)
    return ()


def _fixed_axis_error_gears(model: Any) -> tuple[str, ...]:
    """The gears of :func:`error_gears` on fixed axes (their errors as a fixed-axis train's): all of them but a
    gearbox's planetary stages' gears (and none of a planetary set)."""
    if model.kind == "gearbox":
        from hacgear_core.kinds.gearbox import gearbox_stages

        planetary = {g for s in gearbox_stages(model) if s.planetary is not None for g in s.gears}
        return tuple(g for g in error_gears(model) if g not in planetary)
    return error_gears(model)


def structural_parameters(model: Any) -> tuple[StructuralParameter, ...]:
    """The structural options of ``model``'s kind (:meth:`Kind.structural_parameters`)."""
    return kind_of(model).structural_parameters(model)
