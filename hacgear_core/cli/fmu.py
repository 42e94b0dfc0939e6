"""``hacgear fmu [MODEL ...]``: build FMI 2.0 and FMI 3.0 co-simulation FMUs of gear systems.

    hacgear fmu spur_28t_asym                      # -> dist/spur_28t_asym.fmu (FMI 2.0) and dist/spur_28t_asym_fmi3.fmu
    hacgear fmu                                    # every shipped system that has tables, both FMI versions
    hacgear fmu models/my_pair --fmi 2 --out build --check
    hacgear fmu --models /tmp/models               # every system folder of another models folder
    hacgear fmu spur_28t_asym --backend pythonfmu  # pythonfmu's prebuilt linux64 + win64 binaries

MODEL is a model file, its folder or a system name (`hacgear list`).  Each FMU is self-contained: the model file,
its tables and the hacgear code travel inside it; the importer's Python needs only numpy, scipy, h5py and numba (an
FMU says what is missing when it cannot run).  Two backends write the FMU's binary: native compiles our own (strict
FMI statuses; needs a C compiler and Python's headers), pythonfmu takes pythonfmu's / pythonfmu3's prebuilt
linux64 + win64 binaries (no compiler).  Without --backend the native one is used where a C compiler is found,
pythonfmu where none is; the command says which and why.  --check runs `fmpy validate` and `fmutool -check`
(package fmu-manipulation-toolbox: `pip install "hacgear[check]"`) on each FMU.  Each build runs the new FMU once in
a separate Python process and ships the compiled numba code of that run (--no-compiled-code: not).  Exit status: 0
when every requested FMU was built (and passed the checks), 1 otherwise.
"""
from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
from pathlib import Path
from typing import Any

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._help import plain_text
from hacgear_core.errors import HacgearError, ModelError
from hacgear_core.fmu import build_fmu
from hacgear_core.fmu.adapter import make_adapter
from hacgear_core.fmu.documentation import readme_block
from hacgear_core.fmu.pythonfmu_backend import choose_backend
from hacgear_core.fmu.spec import readme_with_variables
from hacgear_core.model import resolve_model_path, shipped_systems_dir

__all__ = ["register", "run", "validate_fmu", "FMUTOOL_MISSING"]

#: what --check says when the second validator is not installed
FMUTOOL_MISSING = ("fmutool -check cannot run: the package fmu-manipulation-toolbox is not installed "
                   "(pip install \"hacgear[check]\", or pip install fmu-manipulation-toolbox)")


def register(subparsers: Any) -> None:
    p = subparsers.add_parser("fmu", help=command_help("fmu"), description=plain_text(__doc__),
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", nargs="*", help="model file, folder or system name (default: every system of --models "
                                            "that has tables.h5)")
    p.add_argument("--system", action="append", default=[],
                   help="system folder name in --models (repeatable, the same as giving it as MODEL; default: none)")
    p.add_argument("--models", default=None,
                   help="models folder whose systems are built (default: the shipped systems, `hacgear list`)")
    p.add_argument("--out", default="dist", help="output folder (default: dist/ in the current folder)")
    p.add_argument("--fmi", choices=("2", "3", "all"), default="all",
                   help="FMI version of the FMUs: 2, 3 or all (default: all)")
    p.add_argument("--check", action="store_true", help="run fmpy validate and fmutool -check on each FMU")
    p.add_argument("--backend", choices=("native", "pythonfmu"), default=None,
                   help="native: own binaries compiled with the C compiler (strict FMI statuses); pythonfmu: "
                        "pythonfmu's/pythonfmu3's prebuilt linux64 + win64 binaries, no compiler (default: native "
                        "where a C compiler is found, else pythonfmu)")
    p.add_argument("--no-compiled-code", action="store_true",
                   help="do not ship the compiled numba code of the FMU's run (resources/numba_cache/, made by "
                        "running each FMU once at build time); the importer then compiles it at its first "
                        "instantiation, once per machine")
    p.add_argument("--readme", action="store_true",
                   help="instead of building: write each system's FMU variable table (from the FMU's spec) into "
                        "its readme.md")
    p.set_defaults(func=run)


def validate_fmu(path: str | Path) -> list[str]:
    """Problems reported by ``fmpy validate`` (API) and ``fmutool -check`` (CLI) for one FMU; a validator that
    is not installed is a problem naming the package to install."""
    from fmpy.validation import validate_fmu as _fmpy_validate

    problems = [f"fmpy validate: {p}" for p in _fmpy_validate(str(path))]
    if importlib.util.find_spec("fmu_manipulation_toolbox") is None:
        return problems + [FMUTOOL_MISSING]
    r = subprocess.run([sys.executable, "-m", "fmu_manipulation_toolbox.cli.fmutool", "-input", str(path),
                        "-check"], capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        problems.append(f"fmutool -check (exit {r.returncode}): {(r.stdout + r.stderr).strip()[-2000:]}")
    return problems


def _folders(args: argparse.Namespace) -> tuple[list[Path], bool]:
    """System folders to build and whether they were named (a named folder without tables is an error)."""
    models = Path(args.models) if args.models else shipped_systems_dir()
    if args.models and not models.is_dir():
        raise ModelError(f"--models {args.models!r} is not a folder")
    named = [models / s for s in args.system] + [resolve_model_path(m).parent for m in args.model]
    missing = [d for d in named if not (d / "model.toml").is_file()]
    if missing:
        raise ModelError(f"no model.toml in {', '.join(map(str, missing))}")
    if named:
        return named, True
    return sorted(d for d in models.iterdir() if (d / "model.toml").is_file()), False


def run(args: argparse.Namespace) -> int:
    dirs, named = _folders(args)
    versions = (2, 3) if args.fmi == "all" else (int(args.fmi),)
    status = built = 0
    if not args.readme:
        backend, why = choose_backend(args.backend)
        print(f"hacgear fmu: backend {backend}: {why}", flush=True)
    for d in dirs:
        if not (d / "tables.h5").exists():
            msg = f"{d.name}: skipped, no tables.h5 (run `hacgear statics {d}`)"
            if named:
                print(f"hacgear fmu: error: {msg}", file=sys.stderr)
                status = 1
            else:
                print(f"hacgear fmu: {msg}")
            continue
        if args.readme:
            try:
                table = readme_block(make_adapter(d))
            except HacgearError as exc:
                print(f"hacgear fmu: {d.name}: no FMU, readme unchanged ({exc})")
                continue
            readme = d / "readme.md"
            text = readme.read_text(encoding="utf-8") if readme.exists() else f"# {d.name}\n"
            readme.write_text(readme_with_variables(text, table), encoding="utf-8")
            print(f"hacgear fmu: {d.name}: FMU variable table written to {readme}")
            continue
        for version in versions:
            print(f"hacgear fmu: building {d.name} (FMI {version}.0) ...", flush=True)
            try:
                fmu = build_fmu(d, args.out, fmi_version=version, backend=backend,
                                compiled_code=not args.no_compiled_code)
            except HacgearError as exc:
                print(f"hacgear fmu: error: {d}: {exc}", file=sys.stderr)
                status = 1
                break
            built += 1
            print(f"hacgear fmu: {d.name} -> {fmu} (FMI {version}.0)", flush=True)
            if args.check:
                problems = validate_fmu(fmu)
                for p in problems:
                    print(f"hacgear fmu: {fmu.name}: {p}", file=sys.stderr)
                if problems:
                    status = 1
                else:
                    print(f"hacgear fmu: {fmu.name}: fmpy validate and fmutool -check passed")
    if built == 0 and status == 0 and not args.readme:
        print("hacgear fmu: nothing built (no model folder with tables.h5)")
    return status
