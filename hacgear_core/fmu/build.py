"""Build of hacgear FMUs: ``<system>.fmu`` from a model folder (model.toml, tables.h5) with pythonfmu, and the
post-processing of ``modelDescription.xml`` from the variable spec (units, bounds, unit definitions).

The slave module is ``<kind>.py`` of the slave sources (``fmu_src/`` in the checkout, installed as the package data
``hacgear_core.fmu.slaves``) copied under the unique name ``hacgear_<system>``; the model file, the tables and
``hacgear_fmu.json`` (system, kind, required packages, ports) travel as resources.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import shutil
import sys
import tempfile
import zipfile
from importlib import resources as _res
from pathlib import Path
from typing import Sequence
from xml.etree import ElementTree as ET

from pythonfmu import FmuBuilder
from pythonfmu.default_experiment import DefaultExperiment  # noqa: F401  (imported eagerly, see docs/fmu.md)

from hacgear_core import __version__
from hacgear_core.dynamics.synthetic import spur_fdf_table
from hacgear_core.errors import HacgearError
from hacgear_core.fmu.adapter import MODEL_FILE, TABLES_FILE, make_adapter
from hacgear_core.fmu.slave import FMU_INFO_FILE, requirements
from hacgear_core.fmu.spec import UNITS, FmuVariable, ident
from hacgear_core.model import load_model, model_sha256
from hacgear_core.model.provenance import model_values_json, model_values_sha256
from hacgear_core.tables import SystemTables, load_system_tables, write_tables

__all__ = ["postprocess_model_description", "build_fmu", "synthetic_system_folder", "slave_source"]


def _fmt(x: float) -> str:
    return repr(float(x))


def postprocess_model_description(xml_text: str | bytes, variables: Sequence[FmuVariable],
                                  description: str | None = None) -> bytes:
    """Add units, ``min``/``max`` and ``UnitDefinitions`` to a pythonfmu modelDescription.xml.

    Every ScalarVariable must match exactly one spec entry by name with the same causality and
    variability (and vice versa), else :class:`HacgearError`.

    Returns
    -------
    bytes
        The new XML (UTF-8).
    """
    root = ET.fromstring(xml_text)
    spec = {v.name: v for v in variables}
    mv = root.find("ModelVariables")
    seen = set()
    used_units = set()
    for sv in mv.findall("ScalarVariable"):
        name = sv.get("name")
        v = spec.get(name)
        if v is None:
            raise HacgearError(f"modelDescription.xml variable '{name}' is not in the spec")
        seen.add(name)
        if sv.get("causality") != v.causality or sv.get("variability") != v.variability:
            raise HacgearError(f"variable '{name}': XML causality/variability {sv.get('causality')}/"
                               f"{sv.get('variability')} differ from the spec {v.causality}/{v.variability}")
        sv.set("description", v.description)
        typed = sv.find(v.type)
        if typed is None:
            raise HacgearError(f"variable '{name}': XML type differs from the spec type {v.type}")
        if v.type == "Real":
            typed.set("unit", v.unit)
            used_units.add(v.unit)
        if v.min is not None:
            typed.set("min", _fmt(v.min) if v.type == "Real" else str(int(v.min)))
        if v.max is not None:
            typed.set("max", _fmt(v.max) if v.type == "Real" else str(int(v.max)))
        if v.causality != "output" and v.start is not None and v.type == "Real":
            typed.set("start", _fmt(v.start))
    missing = set(spec) - seen
    if missing:
        raise HacgearError(f"spec variables missing in modelDescription.xml: {sorted(missing)}")
    if root.find("UnitDefinitions") is not None:
        root.remove(root.find("UnitDefinitions"))
    units = ET.Element("UnitDefinitions")
    for u in sorted(used_units):
        ue = ET.SubElement(units, "Unit", {"name": u})
        ET.SubElement(ue, "BaseUnit", {k: str(e) for k, e in UNITS[u].items()})
    # schema order: ModelExchange?, CoSimulation?, UnitDefinitions?, TypeDefinitions?, LogCategories?, ...
    children = list(root)
    pos = max(i for i, c in enumerate(children) if c.tag in ("CoSimulation", "ModelExchange")) + 1
    root.insert(pos, units)
    if description:
        root.set("description", description)
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def _rewrite_zip_member(zpath: Path, member: str, data: bytes) -> None:
    tmp = zpath.with_suffix(zpath.suffix + ".tmp")
    with zipfile.ZipFile(zpath) as zin, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            content = data if item.filename == member else zin.read(item.filename)
            zout.writestr(item.filename, content, compress_type=zipfile.ZIP_DEFLATED)
    os.replace(tmp, zpath)


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()



def slave_source(kind: str, slave_dir: str | Path | None = None) -> Path:
    """The slave source ``<kind>.py`` from ``slave_dir`` or the installed slave sources.

    Raises
    ------
    HacgearError
        No slave for ``kind``.
    """
    if slave_dir is not None:
        src = Path(slave_dir) / f"{kind}.py"
    else:
        src = Path(str(_res.files("hacgear_core.fmu.slaves").joinpath(f"{kind}.py")))
    if not src.exists():
        raise HacgearError(f"no FMU slave for system kind '{kind}' ({src})")
    return src


def build_fmu(system_dir: str | Path, out_dir: str | Path, *, slave_dir: str | Path | None = None) -> Path:
    """Build ``<out_dir>/<system>.fmu`` from ``<system_dir>/model.toml`` and ``<system_dir>/tables.h5``.

    The slave module is :func:`slave_source` of the model's kind copied under the unique name
    ``hacgear_<system>``; the model file, the tables and ``hacgear_fmu.json`` (system, kind, required packages,
    ports) travel as resources; modelDescription.xml is post-processed from the same variable spec the slave
    registers.

    Raises
    ------
    HacgearError
        No tables, no slave for the model's kind, tables of another model, or a failed build.
    """
    system_dir = Path(system_dir)
    out_dir = Path(out_dir)
    model = load_model(system_dir / MODEL_FILE)
    tables = system_dir / TABLES_FILE
    if not tables.exists():
        raise HacgearError(f"{system_dir}: no {TABLES_FILE} (run `hacgear statics {model.name}` first)")
    load_system_tables(system_dir / MODEL_FILE, tables)  # errors name the user's files, not the build folder
    slave_src = slave_source(model.kind, slave_dir)
    module = f"hacgear_{ident(model.name)}"
    out_dir.mkdir(parents=True, exist_ok=True)
    dest = out_dir / f"{model.name}.fmu"
    with tempfile.TemporaryDirectory(prefix="hacgear_fmu_") as td:
        td = Path(td)
        script = td / f"{module}.py"
        shutil.copy2(slave_src, script)
        res = td / "res"
        res.mkdir()
        shutil.copy2(system_dir / MODEL_FILE, res / MODEL_FILE)
        shutil.copy2(tables, res / TABLES_FILE)
        info = {
            "format": "hacgear-fmu", "format_version": 1, "system": model.name, "kind": model.kind,
            "description": f"hacgear {model.kind} FMU: {model.title or model.name}",
            "hacgear_version": __version__, "requirements": requirements(),
            "model_sha256": _sha256(res / MODEL_FILE), "tables_sha256": _sha256(res / TABLES_FILE),
            "slave_module": module,
        }
        (res / FMU_INFO_FILE).write_text(json.dumps(info, indent=1), encoding="utf-8")
        try:
            adapter = make_adapter(res)
        except HacgearError as exc:  # name the user's files, not the temporary build folder
            raise type(exc)(str(exc).replace(str(res / MODEL_FILE), str(system_dir / MODEL_FILE))
                            .replace(str(res / TABLES_FILE), str(tables)).replace(str(res), str(system_dir))) from None
        spec = adapter.variables  # the same spec the slave registers
        info["ports"] = {g: {"speed_ratio": adapter.sim.system.gears[g].speed_ratio,
                             "nominal_torque_Nm": adapter.port_torques_Nm[g]} for g in adapter.ports}
        info["reference_gear"] = adapter.ref
        info["input_gear"] = adapter.base_system.input_gear
        info["meshes"] = {m: {"nominal_force_N": float(f)} for m, f in
                          zip(adapter.base_system.mesh_names, adapter.base_system.nominal_forces_N())}
        info["reference_teeth"] = adapter.base_system.gears[adapter.ref].teeth
        info["mesh_cycles_per_rad"] = adapter.base_system.mesh_cycles_per_rad
        (res / FMU_INFO_FILE).write_text(json.dumps(info, indent=1), encoding="utf-8")
        try:
            built = FmuBuilder.build_FMU(script, dest=dest, project_files=[res / MODEL_FILE, res / TABLES_FILE,
                                                                          res / FMU_INFO_FILE])
        except HacgearError:
            raise
        except Exception as exc:
            raise HacgearError(f"{model.name}: pythonfmu build failed: {type(exc).__name__}: {exc}") from exc
        finally:
            sys.modules.pop(module, None)
            while str(td) in sys.path:
                sys.path.remove(str(td))
    built = Path(built)
    with zipfile.ZipFile(built) as z:
        xml = z.read("modelDescription.xml")
    new = postprocess_model_description(xml, spec, description=info["description"])
    _rewrite_zip_member(built, "modelDescription.xml", new)
    return built


def synthetic_system_folder(model: str | Path, dest: str | Path) -> Path:
    """A model folder ``dest/<system>/`` with the model file and a **synthetic** ``tables.h5``.

    For building and testing FMUs before the static solver's tables exist: the table comes from
    :func:`hacgear_core.dynamics.synthetic.spur_fdf_table` with the model's teeth, module, loaded-flank
    pressure angle and tip relief (not from the contact solver; results are labelled synthetic).
    """
    m = load_model(model)
    if m.kind != "spur_pair":
        raise HacgearError(f"synthetic tables exist for spur pairs only, not {m.kind!r}")
    mesh = m.mesh()
    ga, gb = m.gear(mesh.gear_a), m.gear(mesh.gear_b)
    fl = ga.flanks[mesh.flank_a]
    table = spur_fdf_table(
        name=mesh.name, teeth=(ga.teeth, gb.teeth), module_m=ga.module_m,
        pressure_angle_deg=math.degrees(fl.pressure_angle_rad), tip_relief_m=fl.tip_relief_m,
        nominal_torque_Nm=m.operating.torque_Nm, gear_names=(ga.name, gb.name), n_positions=64,
        n_deflections=64)
    if dataclasses.is_dataclass(table) and any(f.name == "solver" for f in dataclasses.fields(table)):
        table = dataclasses.replace(table, solver="SYNTHETIC (hacgear_core.dynamics.synthetic.spur_fdf_table)")
    folder = Path(dest) / m.name
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy2(m.path, folder / MODEL_FILE)
    write_tables(folder / TABLES_FILE, SystemTables(
        meshes={mesh.name: table}, model_sha256=model_sha256(folder / MODEL_FILE), model_file=str(folder / MODEL_FILE),
        attrs={"model_values_sha256": model_values_sha256(m), "model_values": model_values_json(m)}))
    return folder
