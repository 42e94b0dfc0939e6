"""Strict JSON of results: the one place that turns numpy values and non-finite floats into JSON."""
from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

__all__ = ["json_safe", "dumps"]


def json_safe(obj: Any) -> Any:
    """Strict-JSON form of ``obj``: NaN becomes None, +-inf the strings "inf"/"-inf"; numpy scalars and arrays
    become Python numbers and lists; tuples become lists; dict keys strings."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        if math.isnan(v):
            return None
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return v
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def dumps(obj: Any, indent: int | None = 2) -> str:
    """``json.dumps`` of :func:`json_safe` (``allow_nan=False``: the output is strict JSON)."""
    return json.dumps(json_safe(obj), indent=indent, allow_nan=False)
