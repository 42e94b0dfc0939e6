"""Session hooks: print how many property-based fuzz cases ran and how they ended (tests/_fuzz.py)."""
from __future__ import annotations

from _fuzz import FUZZ_COUNTS


def pytest_terminal_summary(terminalreporter) -> None:
    if not FUZZ_COUNTS:
        return
    terminalreporter.write_sep("-", "fuzz cases")
    for name, c in sorted(FUZZ_COUNTS.items()):
        rest = ", ".join(f"{k} {v}" for k, v in sorted(c.items()) if k != "cases")
        terminalreporter.write_line(f"{name}: {c['cases']} cases ({rest})")
