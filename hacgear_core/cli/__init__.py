"""Command-line interface: ``hacgear <subcommand> ...``.

Each subcommand lives in its own module of this package (listed with its one-line help in ``_commands.py``) and
exposes

``register(subparsers) -> None``
    adds its ``argparse`` sub-parser and sets ``func`` (``args -> int``) as a default;

so stages of the pipeline own their commands.  Only the module of the command being run is imported (the others
appear in ``hacgear --help`` by their one-line help), so ``hacgear --help`` does not load the library.  Units: every quantity on the command
line is given in the unit its option name states (``--torque`` in N·m, ``--fm`` in Hz);
``--json`` prints SI values with the unit in the key name.
"""
from __future__ import annotations

import argparse
import importlib
import logging
import os
import re
import sys

from hacgear_core import __version__
from hacgear_core.cli._commands import COMMANDS
from hacgear_core.errors import HacgearError

__all__ = ["main", "build_parser"]


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``hacgear`` parser.  ``command`` None: every subcommand fully registered; a name: only that one (the
    others are listed with their one-line help), so that parsing imports one command's module."""
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
    for name, (module, one_line) in COMMANDS.items():
        if command is None or name == command:
            importlib.import_module(f"{__name__}.{module}").register(sub)
        else:
            sub.add_parser(name, help=one_line, add_help=False)
    return parser


def _command_in(argv: list[str]) -> str:
    """The subcommand named in ``argv`` ('' for none: ``--help``, ``--version``, an unknown word)."""
    for tok in argv:
        if not tok.startswith("-"):
            return tok if tok in COMMANDS else ""
    return ""


#: a value that begins with '-' but is a number or a range (-200, -1e3, -.5, -1000:4000:31, -inf, -200,235.7)
_NEGATIVE_VALUE = re.compile(r"^-(\d|\.\d|inf\b)", re.IGNORECASE)


def _attach_negative_values(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """``--opt -1000:4000:31`` -> ``--opt=-1000:4000:31`` for every option that takes one value, so that a negative
    number or range reaches the option (and then its range check) instead of argparse's "expected one argument"."""
    takes_value = set()
    for p in [parser] + [sp for a in parser._actions if isinstance(a, argparse._SubParsersAction)
                         for sp in a.choices.values()]:
        takes_value.update(s for a in p._actions if a.option_strings and a.nargs is None
                           and not isinstance(a, argparse._HelpAction) for s in a.option_strings)
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        if tok in takes_value and i + 1 < len(argv) and _NEGATIVE_VALUE.match(argv[i + 1]):
            out.append(f"{tok}={argv[i + 1]}")
            i += 2
            continue
        out.append(tok)
        i += 1
    return out


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``hacgear`` console script; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(_command_in(argv) or "")
    args = parser.parse_args(_attach_negative_values(parser, argv))
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        status = _run(args)
        sys.stdout.flush()   # inside the guard: a reader that went away is met here, not at exit
        return status
    except BrokenPipeError:
        # the reader went away (`hacgear info X | head`): stop quietly, as cat or ls do, and keep Python's
        # flush at exit from writing to the closed pipe
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 141   # the shell's status of a command ended by SIGPIPE


def _run(args: argparse.Namespace) -> int:
    """Run the parsed command with the library's compile notices on stderr; a HacgearError is a clear message."""
    from hacgear_core.dynamics.kernels import COMPILE_LOGGER  # the library, loaded only to run a command

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
