#!/usr/bin/env python
"""Build FMI 2.0 and FMI 3.0 co-simulation FMUs of the gear systems: ``dist/<system>.fmu`` (FMI 2.0) and
``dist/<system>_fmi3.fmu`` (FMI 3.0).

    python build_fmu.py                      # every models/<system>/ that has tables.h5, both FMI versions
    python build_fmu.py --system spur_28t_asym --fmi 2 --out dist
    python build_fmu.py --models /tmp/models --check   # other models folder; validate after building
    python build_fmu.py --backend pythonfmu            # pythonfmu's prebuilt linux64 + win64 binaries

Each FMU is self-contained: the model file, its tables and the hacgear code travel inside it; the importer's
Python needs only numpy, scipy, h5py and numba (an FMU says what is missing when it cannot run).  Two backends
write the FMU's binary: ``native`` compiles our own (strict FMI statuses; needs a C compiler and Python's
headers), ``pythonfmu`` takes pythonfmu's / pythonfmu3's prebuilt linux64 + win64 binaries (no compiler).  Without
``--backend`` the native one is used where a C compiler is found, pythonfmu where none is; the script says which
and why.  ``--check`` runs ``fmpy validate``
and ``fmutool -check`` on each FMU.  Each build runs the new FMU once in a separate Python process and ships the
compiled numba code of that run (``--no-compiled-code``: not).  Exit status: 0 when every requested FMU was built (and passed the checks),
1 otherwise.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

from hacgear_core.cli._help import plain_text

HERE = Path(__file__).resolve().parent


def validate_fmu(path: str | Path) -> list[str]:
    """Problems reported by ``fmpy validate`` (API) and ``fmutool -check`` (CLI) for one FMU."""
    from fmpy.validation import validate_fmu as _fmpy_validate

    problems = [f"fmpy validate: {p}" for p in _fmpy_validate(str(path))]
    try:
        r = subprocess.run([sys.executable, "-m", "fmu_manipulation_toolbox.cli.fmutool", "-input", str(path),
                            "-check"], capture_output=True, text=True, timeout=300)
        if r.returncode != 0:
            problems.append(f"fmutool -check (exit {r.returncode}): {(r.stdout + r.stderr).strip()[-2000:]}")
    except FileNotFoundError as exc:  # pragma: no cover
        problems.append(f"fmutool not available: {exc}")
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=plain_text(__doc__.split("\n\n")[0]),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--system", action="append", help="system folder name in --models (repeatable; default: all)")
    ap.add_argument("--out", default=str(HERE / "dist"), help="output folder (default: dist/)")
    ap.add_argument("--models", default=str(HERE / "models"), help="models folder (default: models/)")
    ap.add_argument("--fmi", choices=("2", "3", "all"), default="all",
                    help="FMI version of the FMUs: 2, 3 or all (default: all)")
    ap.add_argument("--check", action="store_true", help="run fmpy validate and fmutool -check on each FMU")
    ap.add_argument("--backend", choices=("native", "pythonfmu"), default=None,
                    help="native: own binaries compiled with the C compiler (strict FMI statuses); pythonfmu: "
                         "pythonfmu's/pythonfmu3's prebuilt linux64 + win64 binaries, no compiler (default: native "
                         "where a C compiler is found, else pythonfmu)")
    ap.add_argument("--no-compiled-code", action="store_true",
                    help="do not ship the compiled numba code of the FMU's run (resources/numba_cache/, made by "
                         "running each FMU once at build time); the importer then compiles it at its first "
                         "instantiation, once per machine")
    ap.add_argument("--readme", action="store_true",
                    help="instead of building: write each system's FMU variable table (from the FMU's spec) into "
                         "its models/<system>/readme.md")
    args = ap.parse_args(argv)

    from hacgear_core.errors import HacgearError
    from hacgear_core.fmu import build_fmu
    from hacgear_core.fmu.adapter import variables_for
    from hacgear_core.fmu.pythonfmu_backend import choose_backend
    from hacgear_core.fmu.spec import readme_with_variables, variables_table

    versions = (2, 3) if args.fmi == "all" else (int(args.fmi),)
    models = Path(args.models)
    if args.system:
        dirs = [models / s for s in args.system]
        missing = [d for d in dirs if not (d / "model.toml").exists()]
        if missing:
            print(f"build_fmu: error: no model.toml in {', '.join(map(str, missing))}", file=sys.stderr)
            return 1
    else:
        dirs = sorted(d for d in models.iterdir() if (d / "model.toml").exists())
    status = 0
    built = 0
    backend, why = choose_backend(args.backend)
    if not args.readme:
        print(f"build_fmu: backend {backend}: {why}")
    for d in dirs:
        if not (d / "tables.h5").exists():
            msg = f"{d.name}: skipped, no tables.h5 (run `hacgear statics {d.name}`)"
            if args.system:
                print(f"build_fmu: error: {msg}", file=sys.stderr)
                status = 1
            else:
                print(f"build_fmu: {msg}")
            continue
        if args.readme:
            try:
                table = variables_table(variables_for(d))
            except HacgearError as exc:
                print(f"build_fmu: {d.name}: no FMU, readme unchanged ({exc})")
                continue
            readme = d / "readme.md"
            text = readme.read_text(encoding="utf-8") if readme.exists() else f"# {d.name}\n"
            readme.write_text(readme_with_variables(text, table), encoding="utf-8")
            print(f"build_fmu: {d.name}: FMU variable table written to {readme}")
            continue
        for version in versions:
            try:
                fmu = build_fmu(d, args.out, fmi_version=version, backend=backend,
                                compiled_code=not args.no_compiled_code)
            except HacgearError as exc:
                print(f"build_fmu: error: {d}: {exc}", file=sys.stderr)
                status = 1
                break
            built += 1
            print(f"build_fmu: {d.name} -> {fmu} (FMI {version}.0)")
            if args.check:
                problems = validate_fmu(fmu)
                for p in problems:
                    print(f"build_fmu: {fmu.name}: {p}", file=sys.stderr)
                if problems:
                    status = 1
                else:
                    print(f"build_fmu: {fmu.name}: fmpy validate and fmutool -check passed")
    if built == 0 and status == 0 and not args.readme:
        print("build_fmu: nothing built (no model folder with tables.h5)")
    return status


if __name__ == "__main__":
    sys.exit(main())
