"""Loader of a hacgear FMU in the importer's Python (standard library only): each FMU carries this file as
``resources/hacgear_fmu_boot.py`` and its binary executes it at every instantiation.

1. It checks the importer's Python and the third-party packages the model needs (numpy, scipy, h5py, numba, with
   the minimum versions in ``hacgear_fmu.json``) and raises :class:`ImportError` naming every missing or too old
   package and the ``pip`` command that installs them (the binary passes the message to the master's logger and to
   stderr and fails the instantiation).  In a master that is not a Python program the native binary asks each
   candidate interpreter the same before it starts one (:func:`probe`, run in the candidate by the binary).
2. It copies the FMU's bundled hacgear code (``resources/<package>/``: hacgear_core under a name unique to its
   contents) once to a stable per-user folder, :func:`cache_root`, and imports it from there: numba caches the
   compiled kernels next to their source, so every later process loads them instead of compiling them.  FMUs of
   different hacgear builds have different package names and run side by side in one process.  The bundle's
   bytecode (compiled by the builder's Python, checked against the sources' hashes) is copied with it: an importer
   with the builder's Python version compiles no source, even where it writes no bytecode itself
   (``PYTHONDONTWRITEBYTECODE``).
3. It returns the FMU instance (``<package>.fmu.slave.FmuInstance``), which keeps the tables and the assembled
   lumped system in ``cache_root()/systems/<GUID>.pickle`` for the next process.
"""
from __future__ import annotations

import hashlib
import importlib
import json
import os
import shlex
import shutil
import sys
import tempfile
import urllib.parse
import urllib.request
from importlib import metadata
from pathlib import Path

__all__ = ["cache_root", "tree_digest", "check_requirements", "install_command", "probe", "stable_copy",
           "resources_folder", "instantiate", "INFO_FILE", "BOOT_FILE"]

INFO_FILE = "hacgear_fmu.json"
BOOT_FILE = "hacgear_fmu_boot.py"
_MARKER = "HACGEAR_BUNDLE_SHA256"


def cache_root() -> Path:
    """Folder of the FMUs' bundled code: ``$HACGEAR_FMU_CACHE``, else ``$HACGEAR_CACHE_DIR/fmu``, else
    ``$XDG_CACHE_HOME/hacgear/fmu``, else ``~/.cache/hacgear/fmu``."""
    if os.environ.get("HACGEAR_FMU_CACHE"):
        return Path(os.environ["HACGEAR_FMU_CACHE"])
    if os.environ.get("HACGEAR_CACHE_DIR"):
        return Path(os.environ["HACGEAR_CACHE_DIR"]) / "fmu"
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "hacgear" / "fmu"


def tree_digest(folder: str | Path) -> str:
    """SHA-256 over the relative paths and contents of the ``*.py`` files below ``folder`` (caches such as
    ``__pycache__`` do not count)."""
    folder = Path(folder)
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*.py")):
        rel = p.relative_to(folder)
        if "__pycache__" in rel.parts:
            continue
        h.update(rel.as_posix().encode() + b"\0")
        h.update(p.read_bytes() + b"\0")
    return h.hexdigest()


def _vtuple(v: str) -> tuple[int, ...]:
    out = []
    for part in v.split("."):
        num = ""
        for c in part:
            if not c.isdigit():
                break
            num += c
        if not num:
            break
        out.append(int(num))
    return tuple(out)


def check_requirements(requirements: dict[str, str], python: str = "") -> list[str]:
    """Unmet requirements, one message each: ``requirements`` maps distribution name -> minimum version;
    ``python``: minimum Python version."""
    problems = []
    if python and sys.version_info[:3] < _vtuple(python):
        problems.append(f"Python {'.'.join(map(str, sys.version_info[:3]))} is older than {python}")
    for name, minimum in requirements.items():
        try:
            have = metadata.version(name)
        except metadata.PackageNotFoundError:
            problems.append(f"{name}>={minimum} is not installed")
            continue
        if _vtuple(have) < _vtuple(minimum):
            problems.append(f"{name} {have} is older than {minimum}")
    return problems


def install_command(requirements: dict[str, str], executable: str | None = None) -> str:
    """The shell command that installs ``requirements`` (distribution name -> minimum version) into the Python
    ``executable`` (default this one): ``'<executable>' -m pip install 'numpy>=1.26' ...``."""
    reqs = " ".join(shlex.quote(f"{k}>={v}") for k, v in requirements.items())
    return f"{shlex.quote(executable or sys.executable)} -m pip install {reqs}"


def _read_info(res: Path) -> dict:
    try:
        return json.loads((res / INFO_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ImportError(f"hacgear FMU: resource {res / INFO_FILE} missing or unreadable: {exc}") from None


def probe(location: str) -> list[str]:
    """What this Python lacks to run the FMU at ``location`` (resources folder or its ``file:`` URI), as the lines the
    native FMU binary reads when it probes a candidate interpreter (``HG_PROBE``, written by the FMU build): one
    ``HG-NEED <unmet requirement>`` per :func:`check_requirements` message and, where installing packages fixes
    them (the Python version suffices), ``HG-FIX <command>`` (:func:`install_command`).  No lines: it has all."""
    info = _read_info(resources_folder(location))
    python = info.get("python", "")
    lines = [f"HG-NEED {p}" for p in check_requirements(info["requirements"], python)]
    if lines and not (python and sys.version_info[:3] < _vtuple(python)):
        lines.append(f"HG-FIX {install_command(info['requirements'])}")
    return lines


def stable_copy(src: Path, package: str, digest: str) -> tuple[Path, list[str]]:
    """Copy the bundled package ``src`` (folder named ``package``, contents hashing to ``digest``) to
    ``cache_root()/package`` unless an intact copy is there; returns (folder to put on ``sys.path``, notes).
    Where the cache cannot be written the package is imported from ``src``'s parent (the FMU's extraction
    folder: the kernels are then compiled in every process) and a note says why."""
    root = cache_root()
    dest = root / package
    try:
        if (dest / _MARKER).is_file() and (dest / _MARKER).read_text().strip() == digest \
                and tree_digest(dest) == digest:
            return root, []
        root.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{package}-", dir=root))
        try:
            shutil.copytree(src, tmp / package)
            (tmp / package / _MARKER).write_text(digest + "\n")
            if tree_digest(tmp / package) != digest:
                raise OSError(f"the FMU's bundled code {src} does not match its digest (corrupted FMU?)")
            if dest.exists():  # a damaged or edited copy: replace it
                shutil.rmtree(dest, ignore_errors=True)
            try:
                os.replace(tmp / package, dest)
            except OSError:
                if not ((dest / _MARKER).is_file() and tree_digest(dest) == digest):  # another process won the race
                    raise
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        return root, []
    except OSError as exc:
        return src.parent, [f"hacgear FMU: the bundled code could not be cached in {dest} ({exc}); it runs from "
                            "the FMU's extraction folder and its kernels are compiled in every process (set "
                            "HACGEAR_FMU_CACHE to a writable folder)"]


def resources_folder(location: str) -> Path:
    """The resources folder from an FMI 2.0 ``fmuResourceLocation`` URI (``file:///...``) or an FMI 3.0
    ``resourcePath``."""
    if location.startswith("file:"):
        parsed = urllib.parse.urlparse(location)
        return Path(urllib.request.url2pathname(parsed.path))
    return Path(location)


def instantiate(instance_name: str, location: str, token: str, logging_on: bool, fmi_version: int,
                chosen_by_binary: bool = False):
    """The FMU instance for the binary's ``fmiInstantiate``; raises with a message for the master's logger.

    ``chosen_by_binary``: this interpreter was started by the native FMU binary in a master that is not a Python
    program (found by its discovery: ``HACGEAR_FMU_PYTHON``, the interpreter recorded at build, ``python3`` on
    ``PATH``), not the master's own; the message for unmet requirements then points to ``HACGEAR_FMU_PYTHON``.
    """
    res = resources_folder(location)
    info = _read_info(res)
    problems = check_requirements(info["requirements"], info.get("python", ""))
    if problems:
        version = ".".join(map(str, sys.version_info[:3]))
        install = install_command(info["requirements"])
        if chosen_by_binary:
            raise ImportError(
                f"hacgear FMU '{info.get('system')}' runs its model in the Python the FMU binary started "
                f"({sys.executable}, {version}), which lacks what it needs: " + "; ".join(problems)
                + f". Install with: {install}; or point the FMU to a Python that has them: "
                "export HACGEAR_FMU_PYTHON=/path/to/python")
        raise ImportError(
            f"hacgear FMU '{info.get('system')}' runs its model in the Python already running in the master's "
            f"process ({sys.executable}, {version}), which lacks what it needs: " + "; ".join(problems)
            + f". Install with: {install} (HACGEAR_FMU_PYTHON does not apply here: the FMU uses the interpreter "
            "running in the process, so run the master with a Python that has the packages)")
    bundle = info["bundle"]
    package = bundle["package"]
    notes: list[str] = []
    cache = cache_root() / "systems"
    if package not in sys.modules:
        folder, notes = stable_copy(res / package, package, bundle["sha256"])
        if notes:
            cache = None
        if str(folder) not in sys.path:
            sys.path.append(str(folder))
    slave = importlib.import_module(f"{package}.fmu.slave")
    return slave.FmuInstance(res, instance_name, token, logging_on=logging_on, fmi_version=fmi_version,
                             notes=notes, cache_dir=cache)
