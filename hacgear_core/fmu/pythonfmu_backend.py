"""The pythonfmu backend of :func:`hacgear_core.fmu.build.build_fmu`: FMI 2.0 FMUs written by pythonfmu's builder
(``pythonfmu.builder.FmuBuilder``), FMI 3.0 FMUs by pythonfmu3's, with their prebuilt binaries (``linux64`` +
``win64``; FMI 3.0: ``x86_64-linux`` + ``x86_64-windows``): no C compiler is needed.

The FMU's resources are those of the native backend (model, tables, ``hacgear_fmu.json``, the loader and the
bundled hacgear code); the slave is :mod:`hacgear_core.fmu.pythonfmu_slave` under a module name unique to the FMU;
the modelDescription.xml that pythonfmu writes is replaced by the spec's (:func:`~hacgear_core.fmu.build.
model_description`: units, display units, ranges, enumerations, InitialUnknowns, DefaultExperiment, FMU state),
whose value references the slave serves.
"""
from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

from hacgear_core.errors import HacgearError

__all__ = ["BACKENDS", "PLATFORMS", "build_pythonfmu", "slave_source", "slave_module_name", "pythonfmu_available",
           "choose_backend", "master_env_script", "master_environment"]

#: the FMU backends of :func:`~hacgear_core.fmu.build.build_fmu`
BACKENDS = ("native", "pythonfmu")
#: the slave file every pythonfmu FMU carries (not imported here: it imports pythonfmu)
SLAVE_FILE = Path(__file__).with_name("pythonfmu_slave.py")
#: FMI version -> the binary folders a pythonfmu FMU carries
PLATFORMS = {2: ("linux64", "win64"), 3: ("x86_64-linux", "x86_64-windows")}
_BUILDER = {2: "pythonfmu", 3: "pythonfmu3"}


def slave_module_name(info: dict, fmi_version: int) -> str:
    """The slave's module name in the FMU: unique to its GUID (two FMUs in one importer never share it)."""
    return f"hacgear_pyfmu{fmi_version}_{info['guid'].strip('{}').replace('-', '')[:16]}"


def slave_source(fmi_version: int) -> str:
    """Text of the slave file for ``fmi_version``: :mod:`.pythonfmu_slave`, its ``# FMI base`` lines rewritten to
    pythonfmu3's ``Fmi3Slave`` for FMI 3.0."""
    if fmi_version not in (2, 3):
        raise HacgearError(f"FMI version must be 2 or 3, got {fmi_version!r}")
    text = SLAVE_FILE.read_text(encoding="utf-8")
    if fmi_version == 2:
        return text
    out = []
    for line in text.splitlines(keepends=True):
        if line.rstrip().endswith("# FMI base"):
            line = (line.replace("from pythonfmu ", "from pythonfmu3 ").replace("Fmi2Slave", "Fmi3Slave")
                    .replace("FMI_VERSION = 2", "FMI_VERSION = 3"))
        out.append(line)
    return "".join(out)


def master_env_script() -> str:
    """The slave's ``MASTER_ENV_SCRIPT`` (read from its source: importing the slave imports pythonfmu): Python code
    printing ``LD_PRELOAD=... PYTHONHOME=... PYTHONPATH=...`` for the interpreter that runs it."""
    for node in ast.parse(SLAVE_FILE.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "MASTER_ENV_SCRIPT" for t in node.targets):
            return ast.literal_eval(node.value)
    raise HacgearError(f"{SLAVE_FILE.name} defines no MASTER_ENV_SCRIPT")  # pragma: no cover


def master_environment(python: str | os.PathLike | None = None) -> dict[str, str]:
    """The environment a master that is not a Python program needs to run a pythonfmu FMU in the Python
    ``python`` (default: this interpreter), as :func:`master_env_script` prints it: ``LD_PRELOAD`` (its libpython
    file), ``PYTHONHOME`` (its installation prefix, ``prefix:exec_prefix`` where they differ) and ``PYTHONPATH``
    (its site-packages, ``os.pathsep``-separated; a virtual environment's are outside PYTHONHOME).

    Raises
    ------
    HacgearError
        ``python`` does not run, or has no shared libpython (a static build: pythonfmu's binaries cannot use it).
    """
    exe = str(python) if python is not None else sys.executable
    try:
        p = subprocess.run([exe, "-c", master_env_script()], capture_output=True, text=True, timeout=60)
    except OSError as exc:
        raise HacgearError(f"cannot run the Python {exe!r}: {exc}") from None
    text = p.stdout.strip()
    if p.returncode != 0 or not text.startswith("LD_PRELOAD=") or " PYTHONHOME=" not in text:
        raise HacgearError(f"the Python {exe!r} did not print its environment: {(p.stderr or text)[-1000:]}")
    head, path = text.split(" PYTHONPATH=", 1)
    lib, home = head[len("LD_PRELOAD="):].split(" PYTHONHOME=", 1)
    if not os.path.isfile(lib):
        raise HacgearError(f"the Python {exe!r} has no shared libpython ({lib} is not a file): pythonfmu FMUs need "
                           "one in the master's process; use a Python built with --enable-shared")
    return {"LD_PRELOAD": lib, "PYTHONHOME": home, "PYTHONPATH": path}


def pythonfmu_available(fmi_version: int) -> str:
    """'' when the builder of ``fmi_version`` (pythonfmu, pythonfmu3) imports, else why not."""
    try:
        __import__(f"{_BUILDER[fmi_version]}.builder")
    except ImportError as exc:
        return f"{_BUILDER[fmi_version]} is not installed ({exc}): pip install pythonfmu pythonfmu3"
    return ""


def choose_backend(requested: str | None = None) -> tuple[str, str]:
    """(backend, why): ``requested`` ('native' or 'pythonfmu') as given, else native where a C compiler is found
    (``$CC``, ``cc`` or ``gcc`` on PATH) and pythonfmu where none is."""
    if requested is not None:
        if requested not in BACKENDS:
            raise HacgearError(f"--backend must be one of {', '.join(BACKENDS)}, got {requested!r}")
        return requested, "chosen with --backend"
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if cc:
        return "native", f"C compiler found ({cc}): own FMI binaries, compiled per build"
    return "pythonfmu", ("no C compiler found (CC unset, no cc or gcc on PATH): pythonfmu's prebuilt linux64 + "
                         "win64 binaries")


def build_pythonfmu(res: Path, info: dict, xml: bytes, dest: Path, fmi_version: int,
                    extra: dict[str, bytes] | None = None) -> Path:
    """Write the FMU ``dest`` with pythonfmu's (FMI 2.0) or pythonfmu3's (FMI 3.0) builder from the resources
    folder ``res`` (complete: model, tables, ``hacgear_fmu.json``, loader, bundle; in a temporary folder whose
    parent takes the builder's output), the modelDescription ``xml`` and ``extra`` members (archive name ->
    bytes: the documentation).

    Raises
    ------
    HacgearError
        The builder is not installed or failed (its message).
    """
    why = pythonfmu_available(fmi_version)
    if why:
        raise HacgearError(f"the pythonfmu backend needs {why}")
    builder = __import__(f"{_BUILDER[fmi_version]}.builder", fromlist=["FmuBuilder"]).FmuBuilder
    module = slave_module_name(info, fmi_version)
    script = res / f"{module}.py"
    script.write_text(slave_source(fmi_version), encoding="utf-8")
    project = sorted(p for p in res.iterdir() if p != script and p.name != "__pycache__")
    out = res.parent / "pythonfmu_out"
    out.mkdir()
    tmp = out / f"{info['system']}.fmu"
    path_before = list(sys.path)
    try:
        builder.build_FMU(script, dest=out, project_files=project)
    except Exception as exc:
        raise HacgearError(f"{_BUILDER[fmi_version]}'s builder failed for {info['system']}: "
                           f"{type(exc).__name__}: {exc}") from None
    finally:
        sys.path[:] = path_before  # the builder inserts the script's folder
        sys.modules.pop(module, None)
    if not tmp.is_file():
        raise HacgearError(f"{_BUILDER[fmi_version]}'s builder wrote no {tmp.name}")
    _replace_model_description(tmp, xml, extra or {})
    with zipfile.ZipFile(tmp) as z:
        names = set(z.namelist())
    missing = [p for p in PLATFORMS[fmi_version]
               if not any(n.startswith(f"binaries/{p}/{info['system']}.") for n in names)]
    if missing:
        raise HacgearError(f"{_BUILDER[fmi_version]} wrote no binaries for {', '.join(missing)}")
    partial = dest.with_name(dest.name + ".tmp")
    shutil.copyfile(tmp, partial)
    os.replace(partial, dest)
    return dest


def _replace_model_description(zpath: Path, xml: bytes, extra: dict[str, bytes]) -> None:
    """Our modelDescription ``xml`` and the ``extra`` members in place of the builder's (no bytecode caches)."""
    tmp = zpath.with_name(zpath.name + ".md")
    with zipfile.ZipFile(zpath) as zin, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            if (item.filename.endswith("/__pycache__/") or "/__pycache__/" in item.filename
                    or item.filename in extra):
                continue
            data = xml if item.filename == "modelDescription.xml" else zin.read(item.filename)
            zout.writestr(item.filename, data, compress_type=zipfile.ZIP_DEFLATED)
        for name, data in extra.items():
            zout.writestr(name, data, compress_type=zipfile.ZIP_DEFLATED)
    os.replace(tmp, zpath)
