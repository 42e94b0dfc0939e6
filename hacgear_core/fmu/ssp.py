"""Drivetrain benches as SSP files (System Structure and Parameterization 1.0): :func:`write_bench_ssp` packs the
bench of :func:`~hacgear_core.fmu.bench.drivetrain_layout` (gear-stage FMUs, and the motor, shaft and load FMUs
of :mod:`~hacgear_core.fmu.components`) with its connections and parameter values into one ``.ssp``;
:func:`run_ssp_fmpy` runs an SSP with fmpy's FMI API (the fixed-step scheme of
:func:`~hacgear_core.fmu.bench.run_layout`), :func:`run_ssp_libcosim` runs it under libcosim (libcosimpy), an
independent FMI master.
"""
from __future__ import annotations

import shutil
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from hacgear_core.errors import HacgearError
from hacgear_core.fmu.bench import BenchConfig, FmuComponent, Layout, drivetrain_layout, run_layout
from hacgear_core.fmu.build import build_component_fmu

__all__ = ["write_bench_ssp", "read_ssp", "run_ssp_fmpy", "run_ssp_libcosim", "SSD_FILE"]

SSD_FILE = "SystemStructure.ssd"
_NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
       "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
       "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues"}
for _p, _u in _NS.items():
    ET.register_namespace(_p, _u)


def _q(prefix: str, tag: str) -> str:
    return f"{{{_NS[prefix]}}}{tag}"


def write_bench_ssp(stage_fmus, dest: str | Path, config: BenchConfig = BenchConfig()) -> Path:
    """Write the drivetrain bench of ``stage_fmus`` (see :func:`~hacgear_core.fmu.bench.drivetrain_layout`) as
    the SSP ``dest``: the stage FMUs and hacgear's motor, shaft and load FMUs (built here) in ``resources/``,
    ``SystemStructure.ssd`` with components, connectors, connections, parameter values and the default
    experiment (the bench's duration)."""
    lay = drivetrain_layout(stage_fmus, config)
    dest = Path(dest)
    with tempfile.TemporaryDirectory(prefix="hacgear_ssp_") as td:
        td = Path(td)
        sources = {}
        for kind in sorted({k for k, _ in lay.components.values()}):
            sources[kind] = build_component_fmu(kind, td)
        root = ET.Element(_q("ssd", "SystemStructureDescription"), {"version": "1.0", "name": "drivetrain_bench"})
        system = ET.SubElement(root, _q("ssd", "System"), {"name": "drivetrain"})
        elements = ET.SubElement(system, _q("ssd", "Elements"))
        conn_of = {}
        for c in lay.connections:
            conn_of.setdefault(c[0], {})[c[1]] = "output"
            conn_of.setdefault(c[2], {})[c[3]] = "input"
        entries = [(n, f"resources/{sources[k].name}", p) for n, (k, p) in lay.components.items()]
        entries += [(n, f"resources/{Path(path).name}", start) for n, (path, start) in lay.stages.items()]
        for name, source, params in entries:
            comp = ET.SubElement(elements, _q("ssd", "Component"),
                                 {"name": name, "source": source, "type": "application/x-fmu-sharedlibrary"})
            conns = ET.SubElement(comp, _q("ssd", "Connectors"))
            for var, kind in sorted(conn_of.get(name, {}).items()):
                ET.SubElement(ET.SubElement(conns, _q("ssd", "Connector"), {"name": var, "kind": kind}),
                              _q("ssc", "Real"))
            values = ET.SubElement(ET.SubElement(ET.SubElement(comp, _q("ssd", "ParameterBindings")),
                                                 _q("ssd", "ParameterBinding")), _q("ssd", "ParameterValues"))
            pset = ET.SubElement(values, _q("ssv", "ParameterSet"), {"version": "1.0", "name": name})
            plist = ET.SubElement(pset, _q("ssv", "Parameters"))
            for pname, val in params.items():
                par = ET.SubElement(plist, _q("ssv", "Parameter"), {"name": pname})
                if isinstance(val, int) and not isinstance(val, bool):
                    ET.SubElement(par, _q("ssv", "Integer"), {"value": str(val)})
                else:
                    ET.SubElement(par, _q("ssv", "Real"), {"value": repr(float(val))})
        cons = ET.SubElement(system, _q("ssd", "Connections"))
        for a, av, b, bv in lay.connections:
            ET.SubElement(cons, _q("ssd", "Connection"),
                          {"startElement": a, "startConnector": av, "endElement": b, "endConnector": bv})
        ET.SubElement(root, _q("ssd", "DefaultExperiment"),
                      {"startTime": "0.0", "stopTime": repr(config.steps * config.step_s)})
        ET.indent(root)
        dest.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr(SSD_FILE, ET.tostring(root, encoding="UTF-8", xml_declaration=True))
            for kind, path in sources.items():
                z.write(path, f"resources/{path.name}")
            for path, _ in lay.stages.values():
                z.write(path, f"resources/{Path(path).name}")
    return dest


def read_ssp(folder: str | Path) -> tuple[dict, list]:
    """Components (name -> (FMU path, {parameter: value})) and connections of an extracted SSP's
    SystemStructure.ssd (inline parameter sets; Real and Integer values)."""
    folder = Path(folder)
    root = ET.parse(folder / SSD_FILE).getroot()
    system = root.find(_q("ssd", "System"))
    comps = {}
    for comp in system.find(_q("ssd", "Elements")).findall(_q("ssd", "Component")):
        params = {}
        for par in comp.iter(_q("ssv", "Parameter")):
            real, integer = par.find(_q("ssv", "Real")), par.find(_q("ssv", "Integer"))
            if real is not None:
                params[par.get("name")] = float(real.get("value"))
            elif integer is not None:
                params[par.get("name")] = int(integer.get("value"))
            else:
                raise HacgearError(f"{folder / SSD_FILE}: parameter {par.get('name')!r} of {comp.get('name')!r} is "
                                   "neither Real nor Integer")
        comps[comp.get("name")] = (folder / comp.get("source"), params)
    cons = [(c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
            for c in system.find(_q("ssd", "Connections")).findall(_q("ssd", "Connection"))]
    return comps, cons


def run_ssp_fmpy(ssp: str | Path, steps: int, step_s: float, record) -> dict[str, np.ndarray]:
    """Run ``ssp`` for ``steps`` communication steps of ``step_s`` [s] with fmpy's FMI 2.0 API, every component an
    FMU, in the fixed-step scheme of :func:`~hacgear_core.fmu.bench.run_layout`; ``record``: (component, variable)
    pairs.  Returns ``"<component>.<variable>"`` -> (steps + 1,) and ``time_s``."""
    work = Path(tempfile.mkdtemp(prefix="hacgear_ssp_run_"))
    comps = {}
    try:
        with zipfile.ZipFile(ssp) as z:
            z.extractall(work)
        spec, cons = read_ssp(work)
        for name, (path, params) in spec.items():
            comps[name] = FmuComponent(path, name, params)
        lay = Layout(components={}, stages={}, connections=cons, record=list(record), static={}, infos={})
        return run_layout(lay, comps, steps, step_s)
    finally:
        for c in comps.values():
            c.close()
        shutil.rmtree(work, ignore_errors=True)


def run_ssp_libcosim(ssp: str | Path, steps: int, step_s: float, record) -> dict[str, np.ndarray]:
    """Run ``ssp`` under libcosim (libcosimpy's fixed-step SSP execution, step ``step_s`` [s] in whole
    nanoseconds) for ``steps`` steps; ``record``: (component, variable) pairs of Real or Integer variables (libcosim
    lists no Enumeration variables), read after every step.  Returns ``"<component>.<variable>"`` -> (steps + 1,)
    and ``time_s``; the first row (t = 0) is NaN: libcosim's last-value observer has no sample before the first
    step."""
    try:
        from libcosimpy.CosimEnums import CosimVariableType
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
        from libcosimpy.CosimObserver import CosimObserver
    except ImportError as exc:  # pragma: no cover - a test dependency
        raise HacgearError(f"running an SSP under libcosim needs libcosimpy (pip install libcosimpy): {exc}") from None
    ns = int(round(step_s * 1e9))
    if ns <= 0 or abs(ns - step_s * 1e9) > 1e-6 * ns:
        raise HacgearError(f"libcosim steps in whole nanoseconds; step_s = {step_s!r} s is not one")
    log_output_level(CosimLogLevel.WARNING)
    work = Path(tempfile.mkdtemp(prefix="hacgear_ssp_cosim_"))
    try:
        with zipfile.ZipFile(ssp) as z:
            z.extractall(work)
        ex = CosimExecution.from_ssp_file(str(work), step_size=ns)
        obs = CosimObserver.create_last_value()
        ex.add_observer(obs)
        index = {s.name.decode(): s.index for s in ex.slave_infos()}
        refs = {}
        for comp, var in record:
            i = index[comp]
            vs = {v.name.decode(): v for v in ex.slave_variables(i)}
            if var not in vs:
                raise HacgearError(f"libcosim does not expose variable {var!r} of {comp!r} (it lists Real, Integer, "
                                   "Boolean and String variables, no Enumerations)")
            refs[(comp, var)] = (i, vs[var].reference, vs[var].type)
        out = {f"{c}.{v}": np.empty(steps + 1) for c, v in record}
        time = np.empty(steps + 1)

        def sample(k, ex=ex):
            for (c, v), (i, r, typ) in refs.items():
                if typ == CosimVariableType.REAL.value:
                    out[f"{c}.{v}"][k] = obs.last_real_values(i, [r])[0]
                else:
                    out[f"{c}.{v}"][k] = obs.last_integer_values(i, [r])[0]
            time[k] = ex.status().current_time * 1e-9

        for arr in out.values():
            arr[0] = np.nan
        time[0] = 0.0
        for k in range(1, steps + 1):
            ex.step(1)
            sample(k)
        out["time_s"] = time
        return out
    finally:
        shutil.rmtree(work, ignore_errors=True)
