"""Test helpers for property-based fuzzing: the TOML writer for generated model files and the counts of fuzz
cases that ran (printed at the end of the test session by ``conftest.py``)."""
from __future__ import annotations

from collections import Counter

from hacgear_core.model.toml_writer import dumps  # noqa: F401 - the library's TOML writer, for the fuzz tests

#: name of a fuzz campaign -> Counter of outcomes ("cases", "accepted", "ModelError", ...)
FUZZ_COUNTS: dict[str, Counter] = {}


def count(campaign: str, outcome: str) -> None:
    c = FUZZ_COUNTS.setdefault(campaign, Counter())
    c["cases"] += 1
    c[outcome] += 1

