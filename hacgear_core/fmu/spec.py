"""FMU variables declared once: :class:`FmuVariable` (name, type, causality, unit, description, bounds) and the SI
unit definitions; the same spec registers the variables with pythonfmu at run time and post-processes
``modelDescription.xml`` at build time (units, ``min``/``max``, ``UnitDefinitions``)."""
from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["UNITS", "FmuVariable", "ident"]

#: SI units used by hacgear FMUs: name -> exponents of the SI base units (FMI 2.0 ``BaseUnit`` attributes).
UNITS: dict[str, dict[str, int]] = {
    "1": {},
    "s": {"s": 1},
    "m": {"m": 1},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "N/m": {"kg": 1, "s": -2},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "Hz": {"s": -1},
}

_CAUSALITIES = ("parameter", "input", "output")
_VARIABILITIES = ("fixed", "tunable", "continuous", "discrete")


@dataclass(frozen=True)
class FmuVariable:
    """Spec of one FMU variable (declared once; drives registration and modelDescription.xml).

    Attributes
    ----------
    name : str
        FMI name (structured naming convention: identifiers joined by ``.``).
    type : str
        ``"Real"`` or ``"Integer"`` (FMI 2.0 allows a unit only on Real; Integers are enumerated
        switches documented in ``description``).
    causality : str
        ``parameter`` | ``input`` | ``output``.
    variability : str
        ``fixed`` | ``tunable`` | ``continuous`` | ``discrete``.
    unit : str
        Key of :data:`UNITS` (Real) or ``""`` (Integer).
    description : str
        One sentence with sign convention.
    start : float or int or None
        Start value of parameters and inputs (outputs get theirs from the slave at build time:
        the initial equilibrium).
    min, max : float or None
        Allowed range (inclusive), checked at the end of initialization (parameters) and in every
        ``doStep`` (inputs); written into modelDescription.xml.
    """

    name: str
    type: str
    causality: str
    variability: str
    unit: str
    description: str
    start: float | int | None = None
    min: float | None = None
    max: float | None = None

    def __post_init__(self) -> None:
        if self.type not in ("Real", "Integer"):
            raise ValueError(f"FmuVariable {self.name}: type must be Real | Integer, got {self.type!r}")
        if self.causality not in _CAUSALITIES:
            raise ValueError(f"FmuVariable {self.name}: causality must be one of {_CAUSALITIES}")
        if self.variability not in _VARIABILITIES:
            raise ValueError(f"FmuVariable {self.name}: variability must be one of {_VARIABILITIES}")
        if self.type == "Real" and self.unit not in UNITS:
            raise ValueError(f"FmuVariable {self.name}: unit {self.unit!r} not in UNITS")
        if not self.description:
            raise ValueError(f"FmuVariable {self.name}: description missing")
        if self.causality != "output" and self.start is None:
            raise ValueError(f"FmuVariable {self.name}: parameters and inputs need a start value")
        for b in (self.min, self.max):
            if b is not None and not math.isfinite(b):
                raise ValueError(f"FmuVariable {self.name}: min/max must be finite (XML xs:double)")

    def check(self, value) -> str:
        """Empty string if ``value`` is finite and within [min, max], else a message naming the
        variable, its unit and the allowed range."""
        unit = f" [{self.unit}]" if self.unit else ""
        try:
            v = float(value)
        except (TypeError, ValueError):
            return f"{self.causality} '{self.name}'{unit} must be a number, got {value!r}"
        lo = -math.inf if self.min is None else self.min
        hi = math.inf if self.max is None else self.max
        if not math.isfinite(v) or not lo <= v <= hi:
            return (f"{self.causality} '{self.name}'{unit} = {v!r} is outside the allowed range "
                    f"[{lo:g}, {hi:g}]{' (NaN/inf are not allowed)' if not math.isfinite(v) else ''}")
        if self.type == "Integer" and v != int(v):
            return f"{self.causality} '{self.name}' must be an integer, got {v!r}"
        return ""




def ident(text: str) -> str:
    """A structured-name identifier from free text (letters, digits, underscore)."""
    out = "".join(c if (c.isascii() and (c.isalnum() or c == "_")) else "_" for c in text)
    return out if out and not out[0].isdigit() else "g_" + out
