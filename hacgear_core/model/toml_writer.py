"""TOML text of a parsed TOML document (the inverse of ``tomllib.loads`` for what model and study files hold)."""
from __future__ import annotations

import datetime as _dt
import json
import math
import re
from typing import Any

__all__ = ["toml_value", "dumps"]

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else _string(k)


def _string(s: str) -> str:
    # JSON escapes every control character but DEL, which TOML forbids raw as well
    return json.dumps(s, ensure_ascii=False).replace("\x7f", "\\u007f")


def toml_value(v: Any) -> str:
    """One TOML value (inline): booleans, integers, floats (``inf``, ``nan``), strings, dates and times, arrays
    and inline tables of these."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        r = repr(v)
        return r if any(c in r for c in ".en") else r + ".0"
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, (_dt.datetime, _dt.date, _dt.time)):
        return v.isoformat()
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"no TOML form for {type(v).__name__}")


def _is_aot(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def dumps(d: dict, header: str = "") -> str:
    """TOML text of a nested dict as ``tomllib`` returns it (tables, arrays of tables, values), so that
    ``tomllib.loads(dumps(d)) == d``; ``header``: lines put first as comments."""
    lines: list[str] = [f"# {h}" for h in header.splitlines()]

    def table(t: dict, prefix: list[str]) -> None:
        for k, v in t.items():
            if not isinstance(v, dict) and not _is_aot(v):
                lines.append(f"{_key(k)} = {toml_value(v)}")
        for k, v in t.items():
            path = ".".join(_key(p) for p in prefix + [k])
            if isinstance(v, dict):
                lines.append(f"[{path}]")
                table(v, prefix + [k])
            elif _is_aot(v):
                for item in v:
                    lines.append(f"[[{path}]]")
                    table(item, prefix + [k])

    table(d, [])
    return "\n".join(lines) + "\n"
