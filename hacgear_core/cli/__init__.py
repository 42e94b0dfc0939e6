"""Command-line interface: ``hacgear <subcommand> ...``.

Each subcommand lives in its own module of this package and exposes

``register(subparsers) -> None``
    adds its ``argparse`` sub-parser and sets ``func`` (``args -> int``) as a default;

so stages of the pipeline own their commands.  Units: every quantity on the command
line is given in the unit its option name states (``--torque`` in N·m, ``--fm`` in Hz);
``--json`` prints SI values with the unit in the key name.
"""
from __future__ import annotations

import argparse
import importlib
import logging
import pkgutil
import sys

from hacgear_core import __version__
from hacgear_core.dynamics.kernels import COMPILE_LOGGER
from hacgear_core.errors import HacgearError

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hacgear",
        description=(
            "Hybrid analytical-computational gear dynamics. Model files are TOML "
            "(models/<system>/model.toml); keys carry their unit when not SI "
            "(module_mm, tip_relief_um, youngs_modulus_GPa). Torques are N·m, "
            "frequencies Hz, deflections m unless an option says otherwise."
        ),
    )
    parser.add_argument("--version", action="version", version=f"hacgear {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="<command>")
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``hacgear`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    # the library's compile notices ("compiling the integration kernel ...") go to stderr, never into --json stdout
    # (once: a command run inside another, as demo's stages, keeps the outer command's handler)
    logger = logging.getLogger(COMPILE_LOGGER)
    level = logger.level
    notices = None
    if not any(getattr(h, "hacgear_cli", False) for h in logger.handlers):
        notices = logging.StreamHandler(sys.stderr)
        notices.hacgear_cli = True
        notices.setFormatter(logging.Formatter(f"hacgear {args.command}: %(message)s"))
        logger.addHandler(notices)
        logger.setLevel(logging.INFO)
    try:
        return int(args.func(args) or 0)
    except HacgearError as exc:  # clear, user-facing errors: no traceback
        print(f"hacgear {args.command}: error: {exc}", file=sys.stderr)
        return 2
    finally:
        if notices is not None:
            logger.removeHandler(notices)
            logger.setLevel(level)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
