"""Drivetrain benches as SSP files (System Structure and Parameterization 1.0).

:func:`write_bench_ssp` writes the bench of :func:`~hacgear_core.fmu.bench.drivetrain_layout` (gear-stage FMUs,
and the motor, shaft and load FMUs of :mod:`~hacgear_core.fmu.components`) as one ``.ssp``: ``SystemStructure.ssd``
with the components, connectors, connections, inline parameter values and the default experiment (stop time, and
the communication step as the Open Simulation Platform's annotation, which libcosim reads), with the FMUs in
``resources/`` or, ``fmus=False``, without them (the form shipped as ``examples/*.ssp``: FMUs hold native binaries
built for one machine).  :func:`complete_ssp` adds the FMUs that an SSP names but does not carry (built here, or
taken from a folder); ``python -m hacgear_core.fmu.ssp SRC DEST`` does that from the command line.

Three masters run an SSP: :func:`run_ssp_fmpy` (fmpy's FMI API in the fixed-step scheme of
:func:`~hacgear_core.fmu.bench.run_layout`), :func:`run_ssp_libcosim` (libcosim through libcosimpy, an independent
FMI master) and fmpy's own ``fmpy.ssp.simulation.simulate_ssp``, which does not apply the SSP's parameter values:
:func:`fmpy_parameter_set` gives them to it.
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from hacgear_core.errors import HacgearError
from hacgear_core.fmu.bench import BenchConfig, FmuComponent, Layout, drivetrain_layout, run_layout

__all__ = ["write_bench_ssp", "bench_ssd", "layout_ssd", "write_layout_ssp", "drivetrain_step", "complete_ssp", "read_ssp", "ssp_step",
           "fmpy_parameter_set", "run_ssp_fmpy", "run_ssp_libcosim", "SSD_FILE", "OSP_ANNOTATION"]

SSD_FILE = "SystemStructure.ssd"
#: the annotation type under which libcosim reads its algorithm (``osp:FixedStepAlgorithm baseStepSize`` [s])
OSP_ANNOTATION = "com.opensimulationplatform"
_NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
       "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
       "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
       "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations"}
for _p, _u in _NS.items():
    ET.register_namespace(_p, _u)
#: prefix of the hacgear component FMUs' file names (``hacgear_motor.fmu``: :func:`build_component_fmu`)
_COMPONENT_PREFIX = "hacgear_"


def _q(prefix: str, tag: str) -> str:
    return f"{{{_NS[prefix]}}}{tag}"


def _fmu_name(kind: str) -> str:
    """File name of hacgear's component FMU of ``kind`` (motor, shaft, load; FMI 2.0)."""
    return f"{_COMPONENT_PREFIX}{kind}.fmu"


def bench_ssd(stage_fmus, config: BenchConfig = BenchConfig(), name: str = "drivetrain_bench") -> bytes:
    """``SystemStructure.ssd`` (UTF-8 XML) of the drivetrain bench of ``stage_fmus`` (paths of FMI 2.0 gear-stage
    FMUs, first driven by the motor; see :func:`~hacgear_core.fmu.bench.drivetrain_layout`) under ``config``:
    the components with their sources in ``resources/`` (the stage FMUs by their file names, hacgear's
    ``hacgear_motor.fmu``, ``hacgear_shaft.fmu``, ``hacgear_load.fmu``), Real connectors, the connections, one
    inline parameter set per component (Real and Integer values), and the default experiment: start 0, stop
    ``config.steps * config.step_s`` [s] and the communication step ``config.step_s`` [s] as the Open Simulation
    Platform's ``osp:FixedStepAlgorithm`` annotation (read by libcosim; SSP 1.0 itself has no step size)."""
    lay = drivetrain_layout(stage_fmus, config)
    chain = " -> ".join(["motor"] + [f"{n} ({Path(p).stem})" for n, (p, _) in lay.stages.items()] + ["load"])
    description = (f"hacgear drivetrain bench: {chain}, coupled by torsion shafts; every stage FMU in drivetrain "
                   f"mode (mode = 1); communication step {config.step_s:g} s (the osp:FixedStepAlgorithm annotation "
                   "of the DefaultExperiment, which libcosim reads; other masters: step no coarser, or the "
                   "coupling of the shafts and the gears' small inertias is not resolved). "
                   "The FMUs are under resources/; where this file carries none, `python -m hacgear_core.fmu.ssp "
                   "THIS.ssp COMPLETE.ssp` builds them and writes the SSP with them")
    return layout_ssd(lay, config.steps * config.step_s, config.step_s, name, description,
                      "hacgear (hacgear_core.fmu.ssp.bench_ssd)")


def layout_ssd(lay: Layout, stop_time_s: float, step_s: float, name: str, description: str,
               generation_tool: str = "hacgear (hacgear_core.fmu.ssp.layout_ssd)") -> bytes:
    """``SystemStructure.ssd`` (UTF-8 XML) of the co-simulation ``lay`` (a :class:`~hacgear_core.fmu.bench.Layout`:
    its components as hacgear's component FMUs ``resources/hacgear_<kind>.fmu``, its stages as their FMU files
    under ``resources/``), default experiment 0 to ``stop_time_s`` [s] at the communication step ``step_s`` [s]
    (the ``osp:FixedStepAlgorithm`` annotation); what :func:`bench_ssd` writes for a drivetrain bench."""
    root = ET.Element(_q("ssd", "SystemStructureDescription"), {
        "version": "1.0", "name": name, "generationTool": generation_tool, "description": description})
    system = ET.SubElement(root, _q("ssd", "System"), {"name": "drivetrain"})
    elements = ET.SubElement(system, _q("ssd", "Elements"))
    conn_of = {}
    for c in lay.connections:
        conn_of.setdefault(c[0], {})[c[1]] = "output"
        conn_of.setdefault(c[2], {})[c[3]] = "input"
    entries = [(n, f"resources/{_fmu_name(k)}", p) for n, (k, p) in lay.components.items()]
    entries += [(n, f"resources/{Path(path).name}", start) for n, (path, start) in lay.stages.items()]
    for cname, source, params in entries:
        comp = ET.SubElement(elements, _q("ssd", "Component"),
                             {"name": cname, "source": source, "type": "application/x-fmu-sharedlibrary"})
        conns = ET.SubElement(comp, _q("ssd", "Connectors"))
        for var, kind in sorted(conn_of.get(cname, {}).items()):
            ET.SubElement(ET.SubElement(conns, _q("ssd", "Connector"), {"name": var, "kind": kind}),
                          _q("ssc", "Real"))
        values = ET.SubElement(ET.SubElement(ET.SubElement(comp, _q("ssd", "ParameterBindings")),
                                             _q("ssd", "ParameterBinding")), _q("ssd", "ParameterValues"))
        pset = ET.SubElement(values, _q("ssv", "ParameterSet"), {"version": "1.0", "name": cname})
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
    exp = ET.SubElement(root, _q("ssd", "DefaultExperiment"),
                        {"startTime": "0.0", "stopTime": f"{stop_time_s:.12g}"})
    note = ET.SubElement(ET.SubElement(exp, _q("ssd", "Annotations")), _q("ssc", "Annotation"),
                         {"type": OSP_ANNOTATION})
    ET.SubElement(ET.SubElement(note, _q("osp", "Algorithm")), _q("osp", "FixedStepAlgorithm"),
                  {"baseStepSize": f"{step_s:.12g}"})
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def drivetrain_step(stage_fmus, config: BenchConfig = BenchConfig()) -> float | None:
    """The smallest ``drivetrain_step`` [s] (the recommended largest communication step in drivetrain mode, a
    calculated parameter) of the stage FMUs of the bench under ``config``: each FMU instantiated with fmpy at the
    bench's start values and initialized.  None where no stage FMU has that variable (built before it existed)."""
    lay = drivetrain_layout(stage_fmus, config)
    steps = []
    for name, (path, start) in lay.stages.items():
        comp = FmuComponent(path, f"{name}_step", start)
        try:
            comp.start()
            if "drivetrain_step" in comp.vars:
                steps.append(float(comp.get("drivetrain_step")))
        finally:
            comp.close()
    return min(steps) if steps else None


def write_bench_ssp(stage_fmus, dest: str | Path, config: BenchConfig = BenchConfig(), *, fmus: bool = True,
                    name: str = "drivetrain_bench") -> Path:
    """Write the drivetrain bench of ``stage_fmus`` as the SSP ``dest``: :func:`bench_ssd`'s
    ``SystemStructure.ssd`` and, with ``fmus``, the stage FMUs and hacgear's motor, shaft and load FMUs (built
    here) in ``resources/``; ``fmus=False``: the structure alone (what ``examples/*.ssp`` are; :func:`complete_ssp`
    adds the FMUs)."""
    stages = [Path(p) for p in ([stage_fmus] if isinstance(stage_fmus, (str, Path)) else stage_fmus)]
    return write_ssd(bench_ssd(stage_fmus, config, name), dest, stages if fmus else None)


def write_layout_ssp(lay: Layout, dest: str | Path, stop_time_s: float, step_s: float, name: str, description: str,
                     *, fmus: bool = True) -> Path:
    """Write the co-simulation ``lay`` as the SSP ``dest`` (:func:`layout_ssd`); with ``fmus`` its stage FMUs and
    hacgear's component FMUs (built here) in ``resources/``, ``fmus=False``: the structure alone."""
    ssd = layout_ssd(lay, stop_time_s, step_s, name, description)
    return write_ssd(ssd, dest, [Path(p) for p, _ in lay.stages.values()] if fmus else None)


def write_ssd(ssd: bytes, dest: str | Path, stage_fmus: list | None) -> Path:
    """Write the SSP ``dest`` of ``ssd``: with the FMUs (``stage_fmus`` paths, the components built here), or,
    ``stage_fmus`` None, the structure alone."""
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    if stage_fmus is None:
        with zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr(SSD_FILE, ssd)
        return dest
    stages = [Path(p) for p in stage_fmus]
    with tempfile.TemporaryDirectory(prefix="hacgear_ssp_") as td:
        with zipfile.ZipFile(Path(td) / "structure.ssp", "w") as z:
            z.writestr(SSD_FILE, ssd)
        return complete_ssp(Path(td) / "structure.ssp", dest, fmus={p.name: p for p in stages})


def _sources(ssd: bytes) -> list[str]:
    """The ``source`` of every component of a SystemStructure.ssd, in order."""
    system = ET.fromstring(ssd).find(_q("ssd", "System"))
    return [c.get("source") for c in system.find(_q("ssd", "Elements")).findall(_q("ssd", "Component"))]


def complete_ssp(src: str | Path, dest: str | Path, fmu_dir: str | Path | None = None, *,
                 fmus: dict | None = None) -> Path:
    """Write ``dest``: the SSP ``src`` with every FMU that its SystemStructure.ssd names as
    ``resources/<file>.fmu`` and ``src`` does not carry added.  Each comes from ``fmus`` (file name -> path), else
    from ``fmu_dir`` where that holds the file, else it is built here (FMI 2.0): hacgear's component FMUs
    (``hacgear_motor.fmu``, ``hacgear_shaft.fmu``, ``hacgear_load.fmu``) by
    :func:`~hacgear_core.fmu.build.build_component_fmu`, a gear-stage FMU ``<system>.fmu`` from the shipped system
    of that name (``hacgear list``) by :func:`~hacgear_core.fmu.build.build_fmu` (native backend where a C compiler
    is found, pythonfmu where none is).  ``src`` and ``dest`` may be the same file.

    Raises
    ------
    HacgearError
        A source outside ``resources/``, or not an FMU, that ``src`` does not carry; a stage FMU with no system of
        its name.
    """
    from hacgear_core.fmu.build import build_component_fmu, build_fmu
    from hacgear_core.fmu.pythonfmu_backend import choose_backend
    from hacgear_core.model import resolve_model_path

    src, dest = Path(src), Path(dest)
    fmus = dict(fmus or {})
    with tempfile.TemporaryDirectory(prefix="hacgear_ssp_complete_") as td:
        td = Path(td)
        with zipfile.ZipFile(src) as z:
            carried = {i.filename: z.read(i) for i in z.infolist() if not i.is_dir()}
        if SSD_FILE not in carried:
            raise HacgearError(f"{src}: no {SSD_FILE} (not an SSP)")
        add = {}
        for source in _sources(carried[SSD_FILE]):
            if source in carried or source in add:
                continue
            file = source[len("resources/"):] if source.startswith("resources/") else ""
            if not file.endswith(".fmu") or "/" in file:
                raise HacgearError(f"{src}: component source {source!r} is neither in the SSP nor an FMU under "
                                   "resources/ that can be built")
            if file in fmus:
                add[source] = Path(fmus[file])
            elif fmu_dir is not None and (Path(fmu_dir) / file).is_file():
                add[source] = Path(fmu_dir) / file
            elif file.startswith(_COMPONENT_PREFIX):
                add[source] = build_component_fmu(file[len(_COMPONENT_PREFIX):-len(".fmu")], td)
            else:
                system = file[:-len(".fmu")]
                try:
                    system_dir = resolve_model_path(system).parent
                except Exception as exc:
                    raise HacgearError(f"{src}: no FMU {file!r} given and no system {system!r} to build it from "
                                       f"({exc}); build it (`hacgear fmu MODEL --fmi 2`) and pass its folder")
                add[source] = build_fmu(system_dir, td, backend=choose_backend()[0])
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp = dest.with_name(dest.name + ".part")
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            for arc, data in carried.items():
                z.writestr(arc, data)
            for arc, path in add.items():
                z.write(path, arc)
        tmp.replace(dest)
    return dest


def _ssd_bytes(ssp: str | Path) -> bytes:
    """SystemStructure.ssd of an SSP file or of an extracted SSP's folder."""
    ssp = Path(ssp)
    if ssp.is_dir():
        return (ssp / SSD_FILE).read_bytes()
    with zipfile.ZipFile(ssp) as z:
        return z.read(SSD_FILE)


def read_ssp(ssp: str | Path) -> tuple[dict, list]:
    """Components (name -> (FMU path, {parameter: value})) and connections (start element, start connector, end
    element, end connector) of the SystemStructure.ssd of an SSP file or of an extracted SSP's folder (inline
    parameter sets; Real and Integer values).  FMU paths are relative to the folder (for an SSP file: to where it
    is extracted)."""
    ssp = Path(ssp)
    where = ssp if ssp.is_dir() else Path(".")
    root = ET.fromstring(_ssd_bytes(ssp))
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
                raise HacgearError(f"{ssp}: parameter {par.get('name')!r} of {comp.get('name')!r} is neither Real "
                                   "nor Integer")
        comps[comp.get("name")] = (where / comp.get("source"), params)
    cons = [(c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
            for c in system.find(_q("ssd", "Connections")).findall(_q("ssd", "Connection"))]
    return comps, cons


def ssp_step(ssp: str | Path) -> tuple[float | None, float | None]:
    """(communication step [s], stop time [s]) of an SSP's default experiment: the step of its
    ``osp:FixedStepAlgorithm`` annotation, the ``stopTime``; None where it has none."""
    exp = ET.fromstring(_ssd_bytes(ssp)).find(_q("ssd", "DefaultExperiment"))
    if exp is None:
        return None, None
    step = None
    for note in exp.iter(_q("ssc", "Annotation")):
        algo = note.find(f"{_q('osp', 'Algorithm')}/{_q('osp', 'FixedStepAlgorithm')}")
        if note.get("type") == OSP_ANNOTATION and algo is not None:
            step = float(algo.get("baseStepSize"))
    stop = exp.get("stopTime")
    return step, None if stop is None else float(stop)


def fmpy_parameter_set(ssp: str | Path):
    """The SSP's parameter values as the ``parameter_set`` of ``fmpy.ssp.simulation.simulate_ssp``, which
    applies only that argument (named ``<component>.<variable>``) and none of the SSP's own parameter bindings::

        from fmpy.ssp.simulation import simulate_ssp
        step, stop = ssp_step("bench.ssp")          # simulate_ssp reads no step and no stop time either
        res = simulate_ssp("bench.ssp", stop_time=stop, step_size=step,
                           parameter_set=fmpy_parameter_set("bench.ssp"))
    """
    from fmpy.ssp.ssd import Parameter, ParameterSet

    comps, _ = read_ssp(ssp)
    return ParameterSet(name="parameter_bindings", version="1.0",
                        parameters=[Parameter(name=f"{c}.{n}", value=v) for c, (_, params) in comps.items()
                                    for n, v in params.items()])


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


def _check_record(comps: dict, record) -> None:
    """Refuse ``record`` entries that libcosim cannot read (unknown component or variable; an Enumeration, which
    libcosim does not list), from the FMUs' modelDescription.xml: before the execution exists."""
    from fmpy import read_model_description

    types = {}
    for comp, var in record:
        if comp not in comps:
            raise HacgearError(f"the SSP has no component {comp!r} (it has {', '.join(sorted(comps))})")
        if comp not in types:
            types[comp] = {v.name: v.type for v in read_model_description(str(comps[comp][0])).modelVariables}
        typ = types[comp].get(var)
        if typ not in ("Real", "Integer"):
            raise HacgearError(f"libcosim cannot record {comp}.{var}: " + (
                "no such variable" if typ is None else f"its type is {typ} (libcosim reads Real and Integer "
                "variables here and lists no Enumerations: record the Integer twin, e.g. <mesh>.contact_code)"))


def run_ssp_libcosim(ssp: str | Path, steps: int, step_s: float | None, record) -> dict[str, np.ndarray]:
    """Run ``ssp`` under libcosim (libcosimpy's fixed-step SSP execution) for ``steps`` steps of ``step_s`` [s]
    (whole nanoseconds; None: the step of the SSP's ``osp:FixedStepAlgorithm`` annotation, which libcosim reads
    itself); ``record``: (component, variable) pairs of Real or Integer variables (libcosim lists no Enumeration
    variables), read after every step.  Returns ``"<component>.<variable>"`` -> (steps + 1,) and ``time_s``; the
    first row (t = 0) is NaN: libcosim's last-value observer has no sample before the first step.  The execution
    is released before the function returns (also on an error)."""
    try:
        from libcosimpy.CosimEnums import CosimVariableType
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
        from libcosimpy.CosimObserver import CosimObserver
    except ImportError as exc:  # pragma: no cover - a test dependency
        raise HacgearError(f"running an SSP under libcosim needs libcosimpy (pip install libcosimpy): {exc}") from None
    ns = None
    if step_s is not None:
        ns = int(round(step_s * 1e9))
        if ns <= 0 or abs(ns - step_s * 1e9) > 1e-6 * ns:
            raise HacgearError(f"libcosim steps in whole nanoseconds; step_s = {step_s!r} s is not one")
    elif ssp_step(ssp)[0] is None:
        raise HacgearError(f"{ssp}: no osp:FixedStepAlgorithm annotation in its DefaultExperiment: give step_s")
    log_output_level(CosimLogLevel.WARNING)
    work = Path(tempfile.mkdtemp(prefix="hacgear_ssp_cosim_"))
    ex = obs = None
    try:
        with zipfile.ZipFile(ssp) as z:
            z.extractall(work)
        _check_record(read_ssp(work)[0], record)
        ex = CosimExecution.from_ssp_file(str(work), step_size=ns)
        obs = CosimObserver.create_last_value()
        ex.add_observer(obs)
        index = {s.name.decode(): s.index for s in ex.slave_infos()}
        refs = {}
        for comp, var in record:
            i = index[comp]
            v = {v.name.decode(): v for v in ex.slave_variables(i)}[var]
            refs[(comp, var)] = (i, v.reference, v.type)
        out = {f"{c}.{v}": np.empty(steps + 1) for c, v in record}
        time = np.empty(steps + 1)
        for arr in out.values():
            arr[0] = np.nan
        time[0] = 0.0
        for k in range(1, steps + 1):
            ex.step(1)
            for (c, v), (i, r, typ) in refs.items():
                if typ == CosimVariableType.REAL.value:
                    out[f"{c}.{v}"][k] = obs.last_real_values(i, [r])[0]
                else:
                    out[f"{c}.{v}"][k] = obs.last_integer_values(i, [r])[0]
            time[k] = ex.status().current_time * 1e-9
        out["time_s"] = time
        return out
    finally:
        del obs, ex  # the execution (and its FMU instances) goes before its extracted files
        shutil.rmtree(work, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    """``python -m hacgear_core.fmu.ssp SRC DEST [--fmus DIR]``: :func:`complete_ssp` from the command line."""
    ap = argparse.ArgumentParser(
        prog="python -m hacgear_core.fmu.ssp",
        description="Write DEST: the SSP SRC with the FMUs its SystemStructure.ssd names under resources/ and SRC "
                    "does not carry (examples/*.ssp carry none), taken from --fmus or built here (FMI 2.0: "
                    "hacgear_motor/shaft/load.fmu, and <system>.fmu from the shipped system of that name).")
    ap.add_argument("src", help="SSP file (e.g. examples/drivetrain_bench.ssp)")
    ap.add_argument("dest", help="SSP file to write (may be SRC)")
    ap.add_argument("--fmus", help="folder with FMUs to use where it has one of the name the SSP gives (default: "
                    "build every missing FMU)")
    args = ap.parse_args(argv)
    try:
        dest = complete_ssp(args.src, args.dest, args.fmus)
    except HacgearError as exc:
        print(f"hacgear ssp: {exc}", file=sys.stderr)
        return 1
    step, stop = ssp_step(dest)
    with zipfile.ZipFile(dest) as z:
        fmus = sorted(n[len("resources/"):] for n in z.namelist() if n.startswith("resources/"))
    print(f"hacgear ssp: {dest}: {', '.join(fmus)}; default experiment 0 to {stop:g} s, communication step "
          f"{step:g} s (libcosim: CosimExecution.from_ssp_file('{dest}') takes it from the SSP)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
