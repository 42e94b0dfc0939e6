"""Command-line values checked against the model's own ranges (:data:`hacgear_core.model.schema.RANGES`, the one
range of each quantity that model files and FMUs share), and options that exclude each other."""
from __future__ import annotations

import argparse
from typing import Any

from hacgear_core.errors import ModelError
from hacgear_core.model.schema import RANGES

__all__ = ["check_option", "given", "refuse_together"]


def check_option(option: str, value: Any, quantity: str, *, signed: bool = False) -> Any:
    """``value`` of command-line ``option`` when it lies in ``RANGES[quantity]`` (``signed``: its magnitude does,
    either sign allowed), else :class:`ModelError` naming the option, its unit, the value and the allowed range.
    None (option not given) passes."""
    if value is None:
        return None
    r = RANGES[quantity]
    if r.contains(abs(value) if signed and isinstance(value, (int, float)) and not isinstance(value, bool) else value):
        return value
    unit = f" [{r.unit}]" if r.unit and r.unit != "-" else " [-]"
    allowed = f"magnitude {r.text}, either sign" if signed else r.text
    raise ModelError(f"{option}{unit} = {value!r} is out of range; allowed: {allowed}")


def given(args: argparse.Namespace, dest: str, default: Any = None) -> bool:
    """Whether the option stored in ``dest`` was given (differs from its ``default``)."""
    return getattr(args, dest, default) not in (default, False)


def refuse_together(args: argparse.Namespace, first: str, others: dict[str, str], why: str) -> None:
    """:class:`ModelError` when option ``first`` (its dest, option string derived) is given together with any of
    ``others`` ({dest: option string}); ``why`` says what the user should do instead."""
    if not given(args, first.lstrip("-").replace("-", "_")):
        return
    clash = [opt for dest, opt in others.items() if given(args, dest)]
    if clash:
        raise ModelError(f"{first} and {', '.join(clash)} exclude each other: {why}")
