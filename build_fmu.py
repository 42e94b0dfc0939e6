#!/usr/bin/env python
"""Build FMI 2.0 co-simulation FMUs of the gear systems: ``dist/<system>.fmu``.

    python build_fmu.py                      # every models/<system>/ that has tables.h5
    python build_fmu.py --system spur_28t_asym --out dist
    python build_fmu.py --models /tmp/models --check   # other models folder; validate after building

One FMU per system whose kind has a slave in ``fmu_src/`` (spur_pair, idler_chain, planetary).  The model file and its
tables travel as FMU resources; the FMU runs its model in the importer's Python and checks at
instantiation that the packages it names (hacgear, numpy, scipy, numba, h5py) are installed in
compatible versions.  ``--check`` runs ``fmpy validate`` and ``fmutool -check`` on each FMU.
Exit status: 0 when every requested FMU was built (and passed the checks), 1 otherwise.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

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
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--system", action="append", help="system folder name in --models (repeatable; default: all)")
    ap.add_argument("--out", default=str(HERE / "dist"), help="output folder (default: dist/)")
    ap.add_argument("--models", default=str(HERE / "models"), help="models folder (default: models/)")
    ap.add_argument("--check", action="store_true", help="run fmpy validate and fmutool -check on each FMU")
    args = ap.parse_args(argv)

    from hacgear_core.errors import HacgearError
    from hacgear_core.fmu import build_fmu

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
    for d in dirs:
        if not (d / "tables.h5").exists():
            msg = f"{d.name}: skipped, no tables.h5 (run `hacgear statics {d.name}`)"
            if args.system:
                print(f"build_fmu: error: {msg}", file=sys.stderr)
                status = 1
            else:
                print(f"build_fmu: {msg}")
            continue
        try:
            fmu = build_fmu(d, args.out, slave_dir=HERE / "fmu_src")
        except HacgearError as exc:
            print(f"build_fmu: error: {exc}", file=sys.stderr)
            status = 1
            continue
        built += 1
        print(f"build_fmu: {d.name} -> {fmu}")
        if args.check:
            problems = validate_fmu(fmu)
            for p in problems:
                print(f"build_fmu: {fmu.name}: {p}", file=sys.stderr)
            if problems:
                status = 1
            else:
                print(f"build_fmu: {fmu.name}: fmpy validate and fmutool -check passed")
    if built == 0 and status == 0:
        print("build_fmu: nothing built (no model folder with tables.h5)")
    return status


if __name__ == "__main__":
    sys.exit(main())
