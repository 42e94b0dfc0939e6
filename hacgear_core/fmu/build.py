"""Build of hacgear FMUs: ``<system>.fmu`` (FMI 2.0) and ``<system>_fmi3.fmu`` (FMI 3.0) co-simulation FMUs from a
model folder (model.toml, tables.h5).

An FMU holds:

* ``modelDescription.xml``, written from the variable spec of :class:`~hacgear_core.fmu.adapter.Adapter`
  (units with display units, nominal values, ranges, enumeration types, structured names, ModelStructure with
  Outputs and InitialUnknowns, a DefaultExperiment at the mesh resonance);
* ``binaries/<platform>/<system>.so``, compiled from ``fmu_src/fmi2.c`` or ``fmu_src/fmi3.c`` with the system's C
  compiler against Python's stable ABI and the FMI headers shipped with fmpy, linking no libpython: in a master
  that is not a Python program it loads a libpython itself: of ``HACGEAR_FMU_PYTHON`` where set, else of the
  interpreter recorded here (:func:`python_runtime`) where it exists and has the requirements, else of a ``python3``
  (then ``python``) on ``PATH`` that has them (``fmu_src/bridge.h``);
* ``resources/``: the model file and its tables, ``hacgear_fmu.json`` (system, GUID, variables, minimum versions
  of the importer's packages, ports), the loader ``hacgear_fmu_boot.py`` (:mod:`.bootstrap`) and the hacgear code
  itself as a package whose name is unique to its contents (``hacgear_fmu_<version>_<digest>``), so that the
  importer's Python needs only numpy, scipy, h5py and numba;
* ``resources/numba_cache/``: the compiled code of that package's numba functions the FMU runs with its start
  values (the integration kernel's specialisation, the table functions), made by running the FMU once in a
  separate Python process at build time (:mod:`.numba_cache`): an importer with the same numba, Python and CPU
  loads it instead of compiling.
"""
from __future__ import annotations

import compileall
import dataclasses
import datetime as _dt
import hashlib
import importlib.resources
import json
import logging
import math
import os
import py_compile
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from hacgear_core import __version__
from hacgear_core.dynamics.kernels import COMPILE_CPU_S, COMPILE_LOGGER
from hacgear_core.dynamics.synthetic import spur_fdf_table
from hacgear_core.errors import HacgearError
from hacgear_core.fmu import bootstrap
from hacgear_core.fmu.adapter import MODEL_FILE, TABLES_FILE, make_adapter
from hacgear_core.fmu.documentation import DOCUMENTATION_FILE, documentation_html
from hacgear_core.fmu.components import ComponentAdapter
from hacgear_core.fmu.numba_cache import MANIFEST_FILE, SHIPPED_DIR, machine
from hacgear_core.fmu.pythonfmu_backend import BACKENDS, build_pythonfmu
from hacgear_core.fmu.slave import FMU_INFO_FILE, value_references
from hacgear_core.fmu.spec import DISPLAY_UNITS, ENUMERATIONS, TIME, UNITS
from hacgear_core.model import model_sha256
from hacgear_core.kinds import KINDS, kind_of, load_model
from hacgear_core.tables import SystemTables, write_tables

__all__ = ["build_fmu", "build_component_fmu", "model_description", "bundle_package", "compile_binary", "synthetic_system_folder",
           "python_runtime", "LIBPYTHON_QUERY", "ship_compiled_code",
           "REQUIREMENTS", "PYTHON_REQUIREMENT", "fmu_file_name"]

#: Lowest versions of the importer's packages the FMUs are tested with (docs/fmu.md, "What the importer needs"):
#: numpy 1.26.4, scipy 1.11.4, h5py 3.9.0, numba 0.59.1 run them; numba 0.57.1 and 0.58.1 had not compiled the
#: integration kernel after 15-20 minutes and 6 GB of memory.
REQUIREMENTS = {"numpy": "1.26", "scipy": "1.11", "h5py": "3.9", "numba": "0.59"}
PYTHON_REQUIREMENT = "3.11"

def _native() -> Path:
    """Folder of the C sources of the FMU binaries (``fmu_src/`` of the checkout, installed as
    ``hacgear_core.fmu.slaves``)."""
    return Path(str(importlib.resources.files("hacgear_core.fmu.slaves")))
_PLATFORM = {2: "linux64", 3: "x86_64-linux"}
LOG_CATEGORIES = {"logStatusWarning": "warnings", "logStatusDiscard": "discarded steps (divergence, step too long)",
                  "logStatusError": "errors: invalid parameters, inputs, arguments or call sequence",
                  "logStatusFatal": "fatal errors", "logAll": "debug messages (with debug logging on)"}


def fmu_file_name(system: str, fmi_version: int = 2) -> str:
    """``<system>.fmu`` (FMI 2.0) or ``<system>_fmi3.fmu`` (FMI 3.0)."""
    return f"{system}.fmu" if fmi_version == 2 else f"{system}_fmi{fmi_version}.fmu"


def _fmt(x: float) -> str:
    """An xs:double: ``repr`` of finite values, ``INF`` / ``-INF`` for infinities (a rigid bearing)."""
    x = float(x)
    return repr(x) if math.isfinite(x) else ("INF" if x > 0 else "-INF")


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# ---------------------------------------------------------------------------------------------- the bundle
def bundle_package(dest: str | Path) -> tuple[str, str]:
    """Copy this hacgear_core (its ``*.py`` files) into ``dest/<package>/`` under a name unique to its contents,
    with every ``hacgear_core`` in the sources renamed, and compile the copy to bytecode of this Python (checked
    against the sources' hashes, not their times, which extracting the FMU changes: an importer with this Python
    version imports it without compiling); returns (package, digest of the copy)."""
    src = Path(__file__).resolve().parents[1]
    name = f"hacgear_fmu_{re.sub(r'[^0-9A-Za-z]', '_', __version__)}_{bootstrap.tree_digest(src)[:12]}"
    out = Path(dest) / name
    pattern = re.compile(r"\bhacgear_core\b")
    for p in sorted(src.rglob("*.py")):
        rel = p.relative_to(src)
        if "__pycache__" in rel.parts:
            continue
        target = out / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(pattern.sub(name, p.read_text(encoding="utf-8")), encoding="utf-8")
    if not compileall.compile_dir(out, quiet=2, invalidation_mode=py_compile.PycInvalidationMode.CHECKED_HASH):
        raise HacgearError(f"the bundled copy of hacgear_core in {out} does not compile")
    return name, bootstrap.tree_digest(out)


# ---------------------------------------------------------------------------------------------- the binary
def _fmi_headers() -> Path:
    try:
        import fmpy
    except ImportError:  # pragma: no cover - fmpy is a dependency
        raise HacgearError("building an FMU needs fmpy (its FMI headers): pip install fmpy") from None
    d = Path(fmpy.__file__).parent / "c-code"
    if not (d / "fmi2Functions.h").exists() or not (d / "fmi3Functions.h").exists():
        raise HacgearError(f"FMI headers not found in {d}")
    return d


#: Python code (run as ``python -I -c``) printing the path of that interpreter's shared libpython, or an empty
#: line where it has none (a static build without the library).  The FMU build records the building interpreter's
#: with it; the FMU binary asks each candidate interpreter with the same code (:data:`PROBE`).
LIBPYTHON_QUERY = ("import os, sysconfig as s; d = s.get_config_var('LIBDIR') or ''; "
                   "print(next((p for p in (os.path.join(d, s.get_config_var(k) or '') "
                   "for k in ('INSTSONAME', 'LDLIBRARY')) if '.so' in os.path.basename(p) and os.path.isfile(p)), ''))")

#: Python code the FMU binary runs in each candidate interpreter (``python -c PROBE <resource location>``; the
#: candidates: ``HACGEAR_FMU_PYTHON``, the interpreter recorded at build, ``python3`` then ``python`` on ``PATH``),
#: with the flags and environment of the interpreter it would start (user site-packages and ``PYTHONPATH`` count).
#: It prints ``HG-VER <version>``, ``HG-EXE <sys.executable>``, ``HG-LIB <shared libpython or empty>`` and the
#: lines of the FMU's own loader's :func:`.bootstrap.probe` (unmet requirements, the pip command that installs
#: them), so that the requirement check is the loader's, whatever hacgear version built the FMU.
PROBE = ("import sys\n"
         "if sys.path and sys.path[0] == '':\n"
         "    del sys.path[0]\n"
         "print('HG-VER ' + sys.version.split()[0])\n"
         "print('HG-EXE ' + (sys.executable or ''))\n"
         "import contextlib, io, os\n"
         "out = io.StringIO()\n"
         "with contextlib.redirect_stdout(out):\n"
         f"    exec({LIBPYTHON_QUERY!r}, {{}})\n"
         "print('HG-LIB ' + out.getvalue().strip())\n"
         "loc = sys.argv[1]\n"
         "if loc.startswith('file:'):\n"
         "    import urllib.parse, urllib.request\n"
         "    loc = urllib.request.url2pathname(urllib.parse.urlparse(loc).path)\n"
         f"boot = os.path.join(loc, {bootstrap.BOOT_FILE!r})\n"
         "ns = {'__name__': 'hacgear_fmu_probe', '__file__': boot}\n"
         "with open(boot, encoding='utf-8') as f:\n"
         "    exec(compile(f.read(), boot, 'exec'), ns)\n"
         "for line in ns['probe'](loc):\n"
         "    print(line)\n")


def python_runtime(executable: str | None = None) -> dict[str, str]:
    """The interpreter a native FMU binary starts in a master that is not a Python program: ``executable`` (default
    this one, ``sys.executable``, a venv's python kept as it is so that its site-packages are found) and its shared
    ``libpython`` (``""`` where it has none).

    Raises
    ------
    HacgearError
        ``executable`` cannot be run.
    """
    exe = str(executable or sys.executable)
    try:
        r = subprocess.run([exe, "-I", "-c", LIBPYTHON_QUERY], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise HacgearError(f"cannot run the Python interpreter {exe} to find its libpython: {exc}") from None
    if r.returncode != 0:
        raise HacgearError(f"the Python interpreter {exe} failed to name its libpython: {r.stderr.strip()[-500:]}")
    return {"executable": exe, "libpython": r.stdout.strip()}


def _c_string(text: str) -> str:
    """A C string literal of ``text`` (UTF-8 bytes, octal escapes for anything but printable ASCII)."""
    out = []
    for b in text.encode("utf-8"):
        c = chr(b)
        out.append(c if 32 <= b < 127 and c not in '"\\?' else f"\\{b:03o}")
    return '"' + "".join(out) + '"'


def compile_binary(fmi_version: int, out: str | Path, runtime: dict[str, str] | None = None) -> Path:
    """Compile the FMU binary of ``fmi_version`` (2 or 3) into ``out`` (a shared library).

    The binary links no libpython; ``runtime`` (default :func:`python_runtime` of this interpreter) is the
    interpreter it records: in a master that is not a Python program it starts that one unless
    ``HACGEAR_FMU_PYTHON`` names another, or it is missing or lacks the requirements (then a ``python3`` or
    ``python`` on ``PATH`` that has them; ``fmu_src/bridge.h``).

    Raises
    ------
    HacgearError
        No C compiler, no Python headers, or a failed compilation (with the compiler's message).
    """
    runtime = runtime or python_runtime()
    native = _native()
    src = native / f"fmi{fmi_version}.c"
    if not src.exists():
        raise HacgearError(f"no FMU binary source for FMI version {fmi_version!r} ({src})")
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        raise HacgearError("building an FMU needs a C compiler (gcc or cc on PATH, or CC=...): "
                           "e.g. apt-get install gcc")
    py_inc = Path(sysconfig.get_paths()["include"])
    if not (py_inc / "Python.h").exists():
        raise HacgearError(f"building an FMU needs Python's C headers (no Python.h in {py_inc}): e.g. apt-get "
                           f"install python{sys.version_info[0]}-dev")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="hacgear_cc_") as cfg:
        (Path(cfg) / "hg_config.h").write_text(
            "/* written by hacgear_core.fmu.build: how this FMU binary finds the interpreter it starts (bridge.h) */\n"
            f"#define HG_PYTHON_EXECUTABLE {_c_string(runtime['executable'])}\n"
            f"#define HG_PROBE {_c_string(PROBE)}\n"
            f"#define HG_PYTHON_MINIMUM {_c_string(PYTHON_REQUIREMENT)}\n"
            f"#define HG_REQUIREMENTS {_c_string(', '.join(f'{k}>={v}' for k, v in REQUIREMENTS.items()))}\n"
            f"#define HG_INSTALL {_c_string(bootstrap.install_command(REQUIREMENTS, 'python3'))}\n",
            encoding="ascii")
        cmd = [cc, "-shared", "-fPIC", "-O2", "-std=c99", "-Wall", "-fvisibility=hidden", f"-I{native}",
               f"-I{_fmi_headers()}", f"-I{py_inc}", f"-I{cfg}", "-o", str(out), str(src), "-pthread", "-ldl"]
        try:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise HacgearError(f"the C compiler failed to run: {exc}") from None
    if r.returncode != 0 or not out.exists():
        raise HacgearError(f"compiling the FMU binary failed ({' '.join(cmd)}):\n{r.stderr.strip()[-3000:]}")
    return out


# ---------------------------------------------------------------------------------------------- modelDescription
def _guid(info: dict) -> str:
    h = hashlib.sha256(json.dumps({k: info[k] for k in ("fmi_version", "model_sha256", "tables_sha256", "bundle",
                                                         "variables", "hacgear_version")},
                                  sort_keys=True).encode()).hexdigest()
    return "{" + f"{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:32]}" + "}"


def model_description(adapter, info: dict, fmi_version: int = 2) -> bytes:
    """modelDescription.xml (UTF-8) of an adapter's variables (a gear system's
    :class:`~hacgear_core.fmu.adapter.Adapter` or a :class:`~hacgear_core.fmu.components.ComponentAdapter`) for
    FMI 2.0 or 3.0 co-simulation.

    Value references are :func:`~hacgear_core.fmu.slave.value_references` of the spec (what the slave uses).
    """
    if fmi_version not in (2, 3):
        raise HacgearError(f"FMI version must be 2 or 3, got {fmi_version!r}")
    v3 = fmi_version == 3
    variables = adapter.variables
    vrs = value_references(variables)
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0" if v3 else "2.0", "modelName": info["system"],
        ("instantiationToken" if v3 else "guid"): info["guid"], "description": info["description"],
        "author": "hacgear", "version": __version__, "generationTool": f"hacgear {__version__}",
        "generationDateAndTime": now, "variableNamingConvention": "structured"})
    if not v3:
        root.set("numberOfEventIndicators", "0")
    cs = {"modelIdentifier": info["system"], "needsExecutionTool": "false",
          "canBeInstantiatedOnlyOncePerProcess": "false", "canHandleVariableCommunicationStepSize": "true"}
    if v3:
        cs.update(canGetAndSetFMUState="true", canSerializeFMUState="true", providesDirectionalDerivatives="false",
                  providesAdjointDerivatives="false", providesPerElementDependencies="false",
                  maxOutputDerivativeOrder="0", providesIntermediateUpdate="false", mightReturnEarlyFromDoStep="false",
                  canReturnEarlyAfterIntermediateUpdate="false", hasEventMode="false",
                  providesEvaluateDiscreteStates="false")
    else:
        cs.update(canInterpolateInputs="false", maxOutputDerivativeOrder="0", canRunAsynchronuously="false",
                  canNotUseMemoryManagementFunctions="true", canGetAndSetFMUstate="true",
                  canSerializeFMUstate="true", providesDirectionalDerivative="false")
    ET.SubElement(root, "CoSimulation", cs)
    used_units = sorted({v.unit for v in variables if v.type == "Real"})
    units = ET.SubElement(root, "UnitDefinitions")
    for u in used_units:
        ue = ET.SubElement(units, "Unit", {"name": u})
        ET.SubElement(ue, "BaseUnit", {k: str(e) for k, e in UNITS[u].items()})
        for dname, factor in DISPLAY_UNITS.get(u, {}).items():
            ET.SubElement(ue, "DisplayUnit", {"name": dname, "factor": _fmt(factor)})
    enums = sorted({v.declared_type for v in variables if v.declared_type})
    if enums:
        types = ET.SubElement(root, "TypeDefinitions")
        for e in enums:
            desc, items = ENUMERATIONS[e]
            if v3:
                et = ET.SubElement(types, "EnumerationType", {"name": e, "description": desc})
            else:
                et = ET.SubElement(ET.SubElement(types, "SimpleType", {"name": e, "description": desc}),
                                   "Enumeration")
            for nm, val, d in items:
                ET.SubElement(et, "Item", {"name": nm, "value": str(val), "description": d})
    cats = ET.SubElement(root, "LogCategories")
    for nm, d in LOG_CATEGORIES.items():
        ET.SubElement(cats, "Category", {"name": nm, "description": d})
    ET.SubElement(root, "DefaultExperiment", {k: _fmt(x) for k, x in info["default_experiment"].items()})
    mv = ET.SubElement(root, "ModelVariables")
    if v3:  # FMI 3.0: exactly one independent variable
        vrs = {TIME.name: 0, **vrs}
        variables = (TIME,) + tuple(variables)
    for v in variables:
        a = {"name": v.name, "valueReference": str(vrs[v.name]), "description": v.description,
             "causality": v.causality, "variability": v.variability}
        if v.initial and v.causality != "input":  # FMI: no 'initial' on inputs and the independent variable
            a["initial"] = v.initial
        t = {}
        if v.declared_type:
            t["declaredType"] = v.declared_type
        if v.type == "Real":
            t["unit"] = v.unit
            if v.display_unit:
                t["displayUnit"] = v.display_unit
            if v.nominal is not None:
                t["nominal"] = _fmt(v.nominal)
        if v.type in ("Real", "Integer"):
            conv = _fmt if v.type == "Real" else (lambda x: str(int(x)))
            if v.min is not None:
                t["min"] = conv(v.min)
            if v.max is not None:
                t["max"] = conv(math.inf if v.allow_inf else v.max)
        if v.start is not None:
            t["start"] = (("true" if v.start else "false") if v.type == "Boolean"
                          else _fmt(v.start) if v.type == "Real" else str(int(v.start)))
        if v3:
            tag = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "Enumeration": "Enumeration"}[v.type]
            ET.SubElement(mv, tag, {**a, **t})
        else:
            sv = ET.SubElement(mv, "ScalarVariable", a)
            ET.SubElement(sv, v.type, t)
    ms = ET.SubElement(root, "ModelStructure")
    outputs = [v for v in variables if v.causality == "output"]
    # FMI 2.0 section 2.2.8, FMI 3.0 section 2.4.8: the initial unknowns are the calculated outputs and the
    # calculated parameters
    initial = [v for v in variables if v.causality in ("output", "calculatedParameter")]
    index = {v.name: i + 1 for i, v in enumerate(variables)}  # FMI 2.0: ScalarVariable index
    # outputs at a communication point follow from the state: no direct feedthrough from the inputs
    if v3:
        for v in outputs:
            ET.SubElement(ms, "Output", {"valueReference": str(vrs[v.name]), "dependencies": ""})
        for v in initial:
            ET.SubElement(ms, "InitialUnknown", {"valueReference": str(vrs[v.name])})
    else:
        outs = ET.SubElement(ms, "Outputs")
        for v in outputs:
            ET.SubElement(outs, "Unknown", {"index": str(index[v.name]), "dependencies": ""})
        iu = ET.SubElement(ms, "InitialUnknowns")
        for v in initial:
            ET.SubElement(iu, "Unknown", {"index": str(index[v.name])})
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


# ---------------------------------------------------------------------------------------------- the FMU
def build_fmu(system_dir: str | Path, out_dir: str | Path, *, fmi_version: int = 2, backend: str = "native",
              compiled_code: bool = True) -> Path:
    """Build ``<out_dir>/<system>.fmu`` (FMI 2.0) or ``<out_dir>/<system>_fmi3.fmu`` (FMI 3.0) from
    ``<system_dir>/model.toml`` and ``<system_dir>/tables.h5`` (see the module docstring).  ``backend``:
    ``native`` (binary compiled from ``fmu_src/``) or ``pythonfmu`` (pythonfmu's / pythonfmu3's prebuilt binaries,
    :mod:`.pythonfmu_backend`).  ``compiled_code``: ship the compiled numba code of the FMU's run
    (:func:`ship_compiled_code`; False: the importer compiles it at its first instantiation, once per machine).

    Raises
    ------
    HacgearError
        No tables, tables of another model, no C compiler, or a failed build (the message names the user's
        files).
    """
    if fmi_version not in (2, 3):
        raise HacgearError(f"FMI version must be 2 or 3, got {fmi_version!r}")
    if backend not in BACKENDS:
        raise HacgearError(f"FMU backend must be one of {', '.join(BACKENDS)}, got {backend!r}")
    system_dir = Path(system_dir)
    out_dir = Path(out_dir)
    model = load_model(system_dir / MODEL_FILE)
    tables = system_dir / TABLES_FILE
    if not tables.exists():
        raise HacgearError(f"{system_dir}: no {TABLES_FILE} (run `hacgear statics {model.name}` first)")
    adapter = make_adapter(system_dir)  # refuses tables of another model
    sy = adapter.base_system
    info = {
        "system": model.name, "kind": model.kind,
        "description": f"hacgear {model.kind} FMU: {model.title or model.name}",
        "ports": {g: {"speed_ratio": sy.gears[g].speed_ratio, "nominal_torque_Nm": adapter.port_torques_Nm[g]}
                  for g in adapter.ports},
        "reference_gear": adapter.ref, "input_gear": sy.input_gear, "reference_teeth": sy.gears[adapter.ref].teeth,
        "meshes": {m: {"nominal_force_N": float(f)} for m, f in zip(sy.mesh_names, sy.nominal_forces_N())},
        "mesh_cycles_per_rad": sy.mesh_cycles_per_rad,
        "resonance_mesh_frequency_Hz": adapter.nominal["resonance_mesh_frequency_Hz"],
    }
    files = {MODEL_FILE: system_dir / MODEL_FILE, TABLES_FILE: tables}
    out_dir.mkdir(parents=True, exist_ok=True)
    return _package(adapter, info, files, out_dir / fmu_file_name(model.name, fmi_version), fmi_version, backend,
                    compiled_code)


def build_component_fmu(kind: str, out_dir: str | Path, *, fmi_version: int = 2) -> Path:
    """Build ``<out_dir>/hacgear_<kind>.fmu`` (FMI 2.0) or ``..._fmi3.fmu``: a drivetrain component of the SSP
    benches (:mod:`~hacgear_core.fmu.components`: ``motor``, ``shaft``, ``load``)."""
    if fmi_version not in (2, 3):
        raise HacgearError(f"FMI version must be 2 or 3, got {fmi_version!r}")
    adapter = ComponentAdapter(kind)
    name = f"hacgear_{kind}"
    info = {"system": name, "kind": kind, "description": f"hacgear drivetrain component: {adapter.description}"}
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    return _package(adapter, info, {}, out_dir / fmu_file_name(name, fmi_version), fmi_version)


#: Python code (run as ``python -c CODE RESOURCES``) that instantiates the FMU in ``RESOURCES`` through its loader,
#: initializes it with its start values, takes one communication step and collects the compiled code of that run
#: (:func:`hacgear_core.fmu.numba_cache.collect`); prints the manifest's function count
_SHIP_RUN = r"""
import importlib, importlib.util, json, sys
from pathlib import Path
res = Path(sys.argv[1])
spec = importlib.util.spec_from_file_location("hacgear_fmu_boot_build", res / "{boot}")
boot = importlib.util.module_from_spec(spec)
spec.loader.exec_module(boot)
info = json.loads((res / boot.INFO_FILE).read_text(encoding="utf-8"))
# assemble the system in this run, so that its functions are compiled and shipped: a pickle of it kept from an
# earlier build (the same GUID, another CPU target) would skip the assembly and leave them out of the FMU
(boot.cache_root() / "systems" / (str(info["guid"]).strip("{}") + ".pickle")).unlink(missing_ok=True)
inst = boot.instantiate("build", str(res), info["guid"], False, info["fmi_version"])
ok = (inst.enter_initialization_mode(0.0) == 0 and inst.exit_initialization_mode() == 0
      and inst.do_step(0.0, 1e-4) == 0)
if not ok:
    raise SystemExit("the FMU failed its first step: " + "; ".join(m[2] for m in inst.messages))
package = info["bundle"]["package"]
manifest = importlib.import_module(package + ".fmu.numba_cache").collect(package, res / "{shipped}")
print(len(manifest["functions"]))
"""


def ship_compiled_code(res: str | Path) -> int:
    """Run the FMU whose resources are ``res`` (complete but for the compiled code) once in a separate Python
    process, through its loader as an importer does, and store the compiled numba code of that run in
    ``res/numba_cache/`` (:mod:`.numba_cache`); returns the number of functions stored.  numba loads the builder's
    own cache where it has compiled the same code before, so only the first build of a hacgear version and
    kernel specialisation compiles (~15 s); the result is kept per GUID and builder machine in
    ``<FMU cache>/compiled/`` (:func:`~hacgear_core.fmu.bootstrap.cache_root`), so that rebuilding the same FMU
    copies it.

    Raises
    ------
    HacgearError
        The run failed (its message).
    """
    res = Path(res)
    shipped = res / SHIPPED_DIR
    info = json.loads((res / FMU_INFO_FILE).read_text(encoding="utf-8"))
    key = hashlib.sha256(json.dumps([info["guid"], machine()], sort_keys=True).encode()).hexdigest()[:32]
    memo = bootstrap.cache_root() / "compiled" / key
    if (memo / MANIFEST_FILE).is_file():
        try:
            shutil.copytree(memo, shipped)
            return len(json.loads((shipped / MANIFEST_FILE).read_text(encoding="utf-8"))["functions"])
        except (OSError, ValueError, KeyError):
            shutil.rmtree(shipped, ignore_errors=True)  # run it
    logging.getLogger(COMPILE_LOGGER).info(
        f"running the FMU {info['system']} once to ship its compiled code: numba compiles what this machine's "
        f"cache lacks (the first build of a hacgear version: about {COMPILE_CPU_S} s per kernel specialisation)")
    code = _SHIP_RUN.replace("{boot}", bootstrap.BOOT_FILE).replace("{shipped}", SHIPPED_DIR)
    try:
        r = subprocess.run([sys.executable, "-c", code, str(res)], capture_output=True, text=True, timeout=1800,
                           stdin=subprocess.DEVNULL)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise HacgearError(f"running the FMU at build time to compile its code failed: {exc}") from None
    if r.returncode != 0:
        raise HacgearError("running the FMU at build time to compile its code failed: "
                           f"{(r.stderr or r.stdout).strip()[-3000:]}")
    try:
        memo.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{key}-", dir=memo.parent))
        shutil.copytree(shipped, tmp / "c")
        os.replace(tmp / "c", memo)
        shutil.rmtree(tmp, ignore_errors=True)
    except OSError:  # not kept (unwritable cache, or another build kept it first): the next build runs it again
        pass
    return int(r.stdout.strip().splitlines()[-1])


def _package(adapter, info: dict, files: dict, dest: Path, fmi_version: int, backend: str = "native",
             compiled_code: bool = False) -> Path:
    """Write the FMU ``dest``: binary, modelDescription.xml, resources (``files``: name -> path), the loader and
    the bundled code; ``info`` completed into hacgear_fmu.json; with ``compiled_code`` the compiled code of the
    FMU's run (:func:`ship_compiled_code`).  The pythonfmu backend hands the resources and the modelDescription to
    pythonfmu's builder."""
    with tempfile.TemporaryDirectory(prefix="hacgear_fmu_") as td:
        td = Path(td)
        res = td / "resources"
        res.mkdir()
        for name, path in files.items():
            shutil.copy2(path, res / name)
        shutil.copy2(Path(bootstrap.__file__), res / bootstrap.BOOT_FILE)
        package, digest = bundle_package(res)
        info = {"format": "hacgear-fmu", "format_version": 2, **info, "hacgear_version": __version__,
                "fmi_version": fmi_version, "python": PYTHON_REQUIREMENT, "requirements": dict(REQUIREMENTS),
                "bundle": {"package": package, "sha256": digest},
                "model_sha256": _sha256(res / MODEL_FILE) if (res / MODEL_FILE).exists() else "",
                "tables_sha256": _sha256(res / TABLES_FILE) if (res / TABLES_FILE).exists() else "",
                "variables": [v.name for v in adapter.variables],
                "default_experiment": adapter.default_experiment(),
                "python_runtime": python_runtime()}
        info["guid"] = _guid(info)
        (res / FMU_INFO_FILE).write_text(json.dumps(info, indent=1), encoding="utf-8")
        if compiled_code:
            ship_compiled_code(res)
        docs = {DOCUMENTATION_FILE: documentation_html(adapter, info, fmi_version, backend).encode("utf-8")}
        if backend == "pythonfmu":
            return build_pythonfmu(res, info, model_description(adapter, info, fmi_version), dest, fmi_version,
                                   extra=docs)
        binary = compile_binary(fmi_version, td / "binaries" / _PLATFORM[fmi_version] / f"{info['system']}.so",
                                info["python_runtime"])
        xml = model_description(adapter, info, fmi_version)
        tmp = dest.with_name(dest.name + ".tmp")
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("modelDescription.xml", xml)
            z.write(binary, binary.relative_to(td).as_posix())
            for member, data in docs.items():
                z.writestr(member, data)
            for p in sorted(res.rglob("*")):  # of the caches, the bundle's bytecode only (bundle_package)
                if p.is_file() and ("__pycache__" not in p.parts
                                    or (p.is_relative_to(res / package) and p.suffix == ".pyc")):
                    z.write(p, p.relative_to(td).as_posix())
        os.replace(tmp, dest)
    return dest


def _rewrite_zip_member(zpath: Path, member: str, data: bytes) -> None:
    """Replace one member of a zip file (tests and tools that alter a built FMU)."""
    tmp = zpath.with_suffix(zpath.suffix + ".tmp")
    with zipfile.ZipFile(zpath) as zin, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            content = data if item.filename == member else zin.read(item.filename)
            zout.writestr(item.filename, content, compress_type=zipfile.ZIP_DEFLATED)
    os.replace(tmp, zpath)


def synthetic_system_folder(model: str | Path, dest: str | Path) -> Path:
    """A model folder ``dest/<system>/`` with the model file and a **synthetic** ``tables.h5``.

    For building and testing FMUs before the static solver's tables exist: the table comes from
    :func:`hacgear_core.dynamics.synthetic.spur_fdf_table` with the model's teeth, module, loaded-flank
    pressure angle and tip relief (not from the contact solver; results are labelled synthetic).
    """
    m = load_model(model)
    if not kind_of(m).synthetic_tables:
        raise HacgearError(f"synthetic tables exist for kinds {[k for k, v in KINDS.items() if v.synthetic_tables]} "
                           f"only, not {m.kind!r}")
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
    write_tables(folder / TABLES_FILE, SystemTables(meshes={mesh.name: table},
                                                    model_sha256=model_sha256(folder / MODEL_FILE),
                                                    model_file=str(folder / MODEL_FILE)))
    return folder
