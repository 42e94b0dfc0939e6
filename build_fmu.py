#!/usr/bin/env python
"""Build FMI 2.0 and FMI 3.0 co-simulation FMUs of the gear systems: ``dist/<system>.fmu`` (FMI 2.0) and
``dist/<system>_fmi3.fmu`` (FMI 3.0).  The checkout's wrapper of ``hacgear fmu`` (same options; ``hacgear fmu
--help``), which works from an installed wheel too.

    python build_fmu.py                      # every shipped system that has tables.h5, both FMI versions
    python build_fmu.py --system spur_28t_asym --fmi 2 --out dist
    python build_fmu.py --models /tmp/models --check   # other models folder; validate after building
    python build_fmu.py --backend pythonfmu            # pythonfmu's prebuilt linux64 + win64 binaries
"""
from __future__ import annotations

import sys
from pathlib import Path

# The checkout's own folder comes first on sys.path when this script runs; its hacgear_core/ is the source tree,
# which lacks what an install maps into the package (models/ as hacgear_core.systems, fmu_src/ as
# hacgear_core.fmu.slaves).  Import the installed hacgear (editable or wheel) instead.
if sys.path and Path(sys.path[0] or ".").resolve() == Path(__file__).resolve().parent:
    del sys.path[0]
try:
    from hacgear_core.cli import main as hacgear_main
    from hacgear_core.cli.fmu import validate_fmu
except ModuleNotFoundError as exc:  # pragma: no cover - only without an install
    sys.exit(f"build_fmu.py: hacgear is not installed in this Python ({sys.executable}): {exc}. "
             "Install it first: python -m pip install -e .")

__all__ = ["main", "validate_fmu"]


def main(argv: list[str] | None = None) -> int:
    """``hacgear fmu`` with these arguments; returns its exit status."""
    return hacgear_main(["fmu", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
