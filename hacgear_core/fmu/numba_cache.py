"""Compiled code shipped in an FMU: numba's cache files of the bundled code's functions, collected when the FMU is
built and installed where numba looks for them when it is instantiated.

At build time (:func:`hacgear_core.fmu.build.build_fmu`) a separate Python process instantiates the new FMU's
Python side from its resources, initializes it with its start values and takes one communication step; numba
compiles (or loads from the builder's cache) every function that run needs: the integration kernel's one
specialisation and the table functions of the system assembly.  :func:`collect` then copies numba's cache files
of exactly those functions (its index ``<function>-<line>.py<XY>.nbi`` and data files ``... .nbc``) into
``resources/numba_cache/`` with a manifest, :data:`MANIFEST_FILE`.

At instantiation (:class:`~hacgear_core.fmu.slave.FmuInstance`), :func:`install` copies them into each function's
numba cache folder (next to the bundled code in the per-user FMU cache, or below ``$NUMBA_CACHE_DIR``) when that
folder holds no index of the function yet, before anything runs: numba then loads them instead of compiling.
numba's own index check decides whether they fit: its key holds the numba version, a hash of the source file,
the Python version and the target machine (triple, CPU name and features), so a mismatch (another numba, another
CPU, an edited or damaged file) makes numba compile as without them.  :func:`install` compares the manifest with
:func:`machine` first and installs nothing where they differ, so that the FMU can say why it compiles.
"""
from __future__ import annotations

import glob
import importlib
import json
import os
import shutil
import sys
import uuid
from pathlib import Path

__all__ = ["SHIPPED_DIR", "MANIFEST_FILE", "machine", "describe", "mismatch", "used_functions", "collect",
           "install"]

#: folder of the shipped cache files in an FMU's resources
SHIPPED_DIR = "numba_cache"
#: the manifest in :data:`SHIPPED_DIR`: ``{"machine": machine(), "functions": [{"module", "function", "files"}]}``
MANIFEST_FILE = "manifest.json"
_FORMAT = "hacgear-numba-cache 1"


def machine() -> dict[str, str]:
    """What numba's cache index keys on besides the source: numba version, Python tag (``py311``) and target
    (numba's codegen magic tuple: target triple, host CPU name, CPU features) of this process."""
    import numba
    from numba.core.registry import cpu_target

    triple, cpu, features = cpu_target.target_context.codegen().magic_tuple()
    return {"numba": numba.__version__,
            "python": f"py{sys.version_info[0]}{sys.version_info[1]}{getattr(sys, 'abiflags', '')}",
            "triple": str(triple), "cpu": str(cpu), "features": str(features)}


def describe(m: dict) -> str:
    """A :func:`machine` in words: ``numba 0.68.1, py311, CPU znver3 (x86_64-unknown-linux-gnu)``."""
    return f"numba {m.get('numba')}, {m.get('python')}, CPU {m.get('cpu')} ({m.get('triple')})"


def mismatch(shipped: dict, here: dict | None = None) -> str:
    """'' when the shipped :func:`machine` ``shipped`` equals this process's (``here``, default :func:`machine`),
    else what differs, in words."""
    here = machine() if here is None else here
    diffs = [f"{k} {shipped.get(k)!s:.60} here {here[k]!s:.60}" for k in ("numba", "python", "triple", "cpu")
             if shipped.get(k) != here[k]]
    if not diffs and shipped.get("features") != here["features"]:
        diffs.append("CPU features differ")
    return "; ".join(diffs)


def _dispatchers(package: str):
    """(module name relative to ``package``, attribute name, dispatcher) of every numba function with an on-disk
    cache defined in the imported modules of ``package``."""
    from numba.core.caching import FunctionCache
    from numba.core.dispatcher import Dispatcher

    for modname, mod in sorted(sys.modules.items()):
        if mod is None or not modname.startswith(package + "."):
            continue
        for attr, obj in sorted(vars(mod).items()):
            if (isinstance(obj, Dispatcher) and getattr(obj.py_func, "__module__", None) == modname
                    and isinstance(getattr(obj, "_cache", None), FunctionCache)):
                yield modname[len(package) + 1:], attr, obj


def _cache_files(dispatcher) -> tuple[Path, str]:
    """(numba's cache folder of ``dispatcher``, its index file name)."""
    cache = dispatcher._cache
    return Path(cache.cache_path), f"{cache._impl.filename_base}.nbi"


def used_functions(package: str) -> list[tuple[str, str, object]]:
    """The numba functions of ``package`` (an imported bundle) that this process has compiled or loaded: (module
    relative to ``package``, attribute, dispatcher)."""
    return [(mod, attr, d) for mod, attr, d in _dispatchers(package) if d.overloads]


def collect(package: str, dest: str | Path) -> dict:
    """Copy numba's cache files of the functions of ``package`` used in this process (:func:`used_functions`)
    into ``dest`` (one folder per module) and write the manifest; returns it.  A function whose cache has no
    index (numba could not write it) is left out."""
    dest = Path(dest)
    functions = []
    for mod, attr, d in used_functions(package):
        folder, index = _cache_files(d)
        if not (folder / index).is_file():
            continue
        base = index[:-len(".nbi")]
        files = [index] + sorted(Path(p).name for p in glob.glob(str(folder / f"{glob.escape(base)}.*.nbc")))
        (dest / mod).mkdir(parents=True, exist_ok=True)
        for name in files:
            shutil.copyfile(folder / name, dest / mod / name)
        functions.append({"module": mod, "function": attr, "files": files})
    manifest = {"format": _FORMAT, "machine": machine(), "functions": functions}
    dest.mkdir(parents=True, exist_ok=True)
    (dest / MANIFEST_FILE).write_text(json.dumps(manifest, indent=1), encoding="utf-8")
    return manifest


def install(package: str, src: str | Path) -> tuple[int, str]:
    """Copy the shipped cache files in ``src`` (a :data:`SHIPPED_DIR` folder) into numba's cache folders of the
    functions of ``package`` (imported here as needed) where those folders hold no index of the function yet.

    Returns
    -------
    (installed, why_not) : (int, str)
        How many functions' files were installed (0: all had their own cache already, or none could be written),
        and why nothing was installed ('' unless no usable manifest or another machine: :func:`mismatch`).
    """
    src = Path(src)
    try:
        manifest = json.loads((src / MANIFEST_FILE).read_text(encoding="utf-8"))
    except FileNotFoundError:
        return 0, "this FMU ships no compiled code"
    except (OSError, ValueError) as exc:
        return 0, f"its manifest {src / MANIFEST_FILE} is unreadable ({exc})"
    if manifest.get("format") != _FORMAT:
        return 0, f"its manifest has format {manifest.get('format')!r}, not {_FORMAT!r}"
    shipped = manifest.get("machine", {})
    diff = mismatch(shipped)
    if diff:
        return 0, f"it was compiled for {describe(shipped)} ({diff})"
    installed = 0
    for entry in manifest.get("functions", []):
        try:
            d = getattr(importlib.import_module(f"{package}.{entry['module']}"), entry["function"])
            folder, index = _cache_files(d)
            if index not in entry["files"] or (folder / index).exists():
                continue
            folder.mkdir(parents=True, exist_ok=True)
            # data files first, the index last (each by rename): a concurrent process sees a whole cache or none
            for name in sorted(entry["files"], key=lambda n: n == index):
                tmp = folder / f".{name}.{uuid.uuid4().hex[:12]}"
                shutil.copyfile(src / entry["module"] / name, tmp)
                os.replace(tmp, folder / name)
            installed += 1
        except (OSError, ImportError, AttributeError, KeyError):
            continue  # numba compiles this one as without a shipped cache
    return installed, ""
