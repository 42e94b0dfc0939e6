"""FMU variables declared once: :class:`FmuVariable` (name, type, causality, unit, display unit, nominal value,
bounds, and for outputs the :class:`Reading` that says how the value is read from the running simulator), the unit
definitions (SI units and their display units) and the enumeration types; the same spec drives the slave at run
time (:func:`output_getters`, :func:`output_expressions`) and both modelDescription.xml writers (FMI 2.0 and FMI
3.0) at build time."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

from hacgear_core.encodings import CONTACT_STATE_DESCRIPTIONS, ContactState
from hacgear_core.model.schema import RANGES

__all__ = ["UNITS", "DISPLAY_UNITS", "ENUMERATIONS", "TYPES", "TIME", "CALCULATED", "FmuVariable", "Reading", "ident",
           "ranged", "output_getters", "output_expressions", "variables_table", "README_BEGIN", "README_END",
           "readme_with_variables"]

#: SI units used by hacgear FMUs: name -> exponents of the SI base units (FMI ``BaseUnit`` attributes).
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
    "kg.m2": {"kg": 1, "m": 2},
    "N.m/rad": {"kg": 1, "m": 2, "s": -2, "rad": -1},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
    "W": {"kg": 1, "m": 2, "s": -3},
    "J": {"kg": 1, "m": 2, "s": -2},
}

#: Display units per unit: name -> factor (display value = factor * SI value; FMI ``DisplayUnit``).  Names are
#: ASCII unit expressions as Modelica writes them (``u`` = micro): microstrain is ``um/m``.
DISPLAY_UNITS: dict[str, dict[str, float]] = {
    "m": {"um": 1e6, "mm": 1e3},
    "rad": {"deg": 180.0 / math.pi},
    "rad/s": {"rpm": 30.0 / math.pi},
    "N": {"kN": 1e-3},
    "N.m": {"kN.m": 1e-3},
    "N/m": {"N/um": 1e-6},
    "Pa": {"MPa": 1e-6},
    "1": {"um/m": 1e6},
    "W": {"kW": 1e-3},
    "J": {"kJ": 1e-3},
}

#: Enumeration types: name -> (description, ((item name, value, description), ...)).
#: ``ContactState`` is :class:`~hacgear_core.encodings.ContactState` (item names in lower case).
ENUMERATIONS: dict[str, tuple[str, tuple[tuple[str, int, str], ...]]] = {
    "ContactState": ("state of a gear mesh's tooth contact", tuple(
        (c.name.lower(), int(c), CONTACT_STATE_DESCRIPTIONS[c]) for c in ContactState)),
}

#: Variable types and the Python type of their values.
TYPES = {"Real": float, "Integer": int, "Boolean": bool, "Enumeration": int}

_CAUSALITIES = ("parameter", "calculatedParameter", "input", "output", "independent")
#: causalities whose values the FMU computes (read through a :class:`Reading`)
CALCULATED = frozenset({"output", "calculatedParameter"})
_VARIABILITIES = ("fixed", "tunable", "continuous", "discrete")
#: what :attr:`Reading.index` numbers: a mesh or gear of the largest structure, a gauge ("<gear>/<gauge>"), or
#: nothing (a scalar of the simulator)
_PARTS = ("", "mesh", "gear", "gauge")


@dataclass(frozen=True)
class Reading:
    """How an output is read from the running simulator ``s``: the attribute ``s.<attr>`` (``part`` empty) or
    ``s.<attr>[k]``, or ``call(s, k)`` for derived values, with ``k`` the slot of ``part`` ``index`` (a mesh or
    gear of the largest structure, a gauge) in the current structure.  Where the current structure does not have
    it the output reads ``absent``.

    Attributes
    ----------
    attr : str
        Simulator attribute (a scalar, or a per-mesh / per-gear list): the slave's fast path reads it directly.
    call : callable or None
        ``call(s, k) -> value`` when the value is computed (table post-processing, bearing forces); exactly one of
        ``attr`` and ``call`` is given.
    part : str
        ``""``, ``"mesh"``, ``"gear"`` or ``"gauge"``.
    index : int or str
        Mesh or gear number in the largest structure, or the gauge key.
    absent : float or int or bool
        Value where the current structure has no such part.
    fallible : bool
        A table post-processing that may fail for a state (the slave then returns NaN and logs it).
    """

    attr: str = ""
    call: Callable[[Any, int], Any] | None = None
    part: str = ""
    index: int | str = -1
    absent: float | int | bool = 0.0
    fallible: bool = False

    def __post_init__(self) -> None:
        if bool(self.attr) == (self.call is not None):
            raise ValueError("Reading: give exactly one of attr and call")
        if self.part not in _PARTS:
            raise ValueError(f"Reading: part must be one of {_PARTS}, got {self.part!r}")


def ranged(quantity: str) -> dict:
    """``min``, ``max`` and their openness and ``allow_inf`` of an :class:`FmuVariable` from the model's range of
    ``quantity`` (:data:`hacgear_core.model.schema.RANGES`, the one table of ranges)."""
    r = RANGES[quantity]
    return {"min": r.lo, "max": r.hi, "min_open": r.lo_open, "max_open": r.hi_open, "allow_inf": r.allow_inf}


@dataclass(frozen=True)
class FmuVariable:
    """Spec of one FMU variable (declared once; drives the slave and modelDescription.xml).

    Attributes
    ----------
    name : str
        FMI name (structured naming convention: identifiers joined by ``.``).
    type : str
        ``"Real"``, ``"Integer"``, ``"Boolean"`` or ``"Enumeration"`` (then ``declared_type`` names one of
        :data:`ENUMERATIONS`).  Discrete quantities are never Real: switches a master sets are Integer (libcosim,
        for one, cannot set Enumeration variables), discrete outputs such as contact states are Enumerations with
        an Integer twin of the same values (libcosim lists no Enumeration variables, Ecos reads none).
    causality : str
        ``parameter`` | ``calculatedParameter`` (fixed values the FMU derives from the parameters: ratios,
        inertias, the recommended step) | ``input`` | ``output`` | ``independent`` (time, FMI 3.0 only).
    variability : str
        ``fixed`` | ``tunable`` | ``continuous`` (Real only) | ``discrete``.
    unit : str
        Key of :data:`UNITS` (Real) or ``""`` (other types).
    description : str
        One sentence with sign convention.
    start : float or int or bool or None
        Start value of parameters and inputs; outputs have none (``initial="calculated"``: they follow from the
        parameters when initialization ends).
    min, max : float or None
        Allowed range (inclusive) of parameters and inputs, checked when initialization ends (parameters, the
        inputs of the chosen experiment) and in every ``doStep`` (inputs).
    allow_inf : bool
        ``+inf`` is allowed as well (a rigid bearing stiffness): modelDescription.xml then states ``max="INF"``
        and ``max`` bounds the finite values only.
    display_unit : str
        A display unit of ``unit`` (:data:`DISPLAY_UNITS`), or ``""``.
    nominal : float or None
        Typical magnitude (> 0) of a Real, for scaling in the master.
    declared_type : str
        Enumeration type name (``type == "Enumeration"`` only).
    min_open, max_open : bool
        That bound is excluded (modelDescription.xml states the bound; :meth:`check` refuses it).
    read : Reading or None
        Outputs and calculated parameters: how the value is read from the running simulator.
    """

    name: str
    type: str
    causality: str
    variability: str
    unit: str
    description: str
    start: float | int | bool | None = None
    min: float | None = None
    max: float | None = None
    display_unit: str = ""
    nominal: float | None = None
    declared_type: str = ""
    allow_inf: bool = False
    min_open: bool = False
    max_open: bool = False
    read: Reading | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.type not in TYPES:
            raise ValueError(f"FmuVariable {self.name}: type must be one of {tuple(TYPES)}, got {self.type!r}")
        if self.causality not in _CAUSALITIES:
            raise ValueError(f"FmuVariable {self.name}: causality must be one of {_CAUSALITIES}")
        if self.variability not in _VARIABILITIES:
            raise ValueError(f"FmuVariable {self.name}: variability must be one of {_VARIABILITIES}")
        if self.variability == "continuous" and self.type != "Real":
            raise ValueError(f"FmuVariable {self.name}: only Real variables can be continuous")
        if self.type == "Real" and self.unit not in UNITS:
            raise ValueError(f"FmuVariable {self.name}: unit {self.unit!r} not in UNITS")
        if self.type != "Real" and (self.unit or self.display_unit or self.nominal is not None):
            raise ValueError(f"FmuVariable {self.name}: unit, display unit and nominal value are for Real only")
        if self.display_unit and self.display_unit not in DISPLAY_UNITS.get(self.unit, {}):
            raise ValueError(f"FmuVariable {self.name}: display unit {self.display_unit!r} is not one of unit "
                             f"{self.unit!r}: {sorted(DISPLAY_UNITS.get(self.unit, {}))}")
        if self.nominal is not None and not (math.isfinite(self.nominal) and self.nominal > 0):
            raise ValueError(f"FmuVariable {self.name}: nominal must be finite and > 0, got {self.nominal!r}")
        if (self.type == "Enumeration") != bool(self.declared_type):
            raise ValueError(f"FmuVariable {self.name}: Enumeration variables (only) need a declared_type")
        if self.declared_type and self.declared_type not in ENUMERATIONS:
            raise ValueError(f"FmuVariable {self.name}: unknown enumeration {self.declared_type!r}")
        if not self.description:
            raise ValueError(f"FmuVariable {self.name}: description missing")
        if self.causality in ("parameter", "input") and self.start is None:
            raise ValueError(f"FmuVariable {self.name}: parameters and inputs need a start value")
        if self.causality in ("output", "calculatedParameter", "independent") and self.start is not None:
            raise ValueError(f"FmuVariable {self.name}: outputs and calculated parameters are calculated, they have "
                             "no start value")
        if self.causality == "calculatedParameter" and self.variability != "fixed":
            raise ValueError(f"FmuVariable {self.name}: calculated parameters are fixed")
        for b in (self.min, self.max):
            if b is not None and not math.isfinite(b):
                raise ValueError(f"FmuVariable {self.name}: min/max must be finite (XML xs:double)")
        if self.allow_inf and self.type != "Real":
            raise ValueError(f"FmuVariable {self.name}: only Real variables can allow inf")
        if self.read is not None and self.causality not in CALCULATED:
            raise ValueError(f"FmuVariable {self.name}: only outputs and calculated parameters are read from the "
                             "simulator")
        if self.start is not None and self.check(self.start):
            raise ValueError(f"FmuVariable {self.name}: start value {self.start!r} outside its own range")

    @property
    def initial(self) -> str:
        """FMI ``initial``: ``exact`` for parameters and inputs, ``calculated`` for outputs and calculated
        parameters."""
        return {"output": "calculated", "calculatedParameter": "calculated", "independent": ""}.get(self.causality,
                                                                                                   "exact")

    def enum_items(self) -> tuple[tuple[str, int, str], ...]:
        """Items (name, value, description) of an Enumeration variable's type."""
        return ENUMERATIONS[self.declared_type][1] if self.declared_type else ()

    def check(self, value) -> str:
        """Empty string if ``value`` is valid for this variable (finite, within [min, max], an integer for
        Integer/Enumeration, an item of the enumeration), else a message naming the variable, the value, its unit
        and the allowed range."""
        unit = f" [{self.unit}]" if self.unit else ""
        try:
            v = float(value)
        except (TypeError, ValueError, OverflowError):
            return f"{self.causality} '{self.name}'{unit} must be a number, got {value!r}"
        if self.type == "Enumeration":
            items = self.enum_items()
            if v not in {it[1] for it in items}:
                allowed = ", ".join(f"{val} = {nm}" for nm, val, _ in items)
                return f"{self.causality} '{self.name}' = {value!r} is not an item of {self.declared_type} ({allowed})"
            return ""
        lo = -math.inf if self.min is None else self.min
        hi = math.inf if self.max is None else self.max
        if self.allow_inf and v == math.inf:
            return ""
        if (not math.isfinite(v) or not lo <= v <= hi or (self.min_open and v == lo)
                or (self.max_open and v == hi)):
            inf_txt = " or inf" if self.allow_inf else ""
            return (f"{self.causality} '{self.name}'{unit} = {v!r} is outside the allowed range "
                    f"{'(' if self.min_open else '['}{lo:g}, {hi:g}{')' if self.max_open else ']'}{inf_txt}"
                    f"{' (NaN/inf are not allowed)' if not math.isfinite(v) and not self.allow_inf else ''}")
        if self.type == "Integer" and v != int(v):
            return f"{self.causality} '{self.name}' must be an integer, got {value!r}"
        return ""


#: The independent variable of FMI 3.0 FMUs (value reference 0).
TIME = FmuVariable("time", "Real", "independent", "continuous", "s", "simulation time")


def _slot_of(adapter, r: Reading) -> int:
    return adapter.slot(r.part, r.index) if r.part else 0


def output_getters(variables, adapter) -> dict[str, Callable[[], Any]]:
    """Output name -> zero-argument getter of its current value, generated from each output's :class:`Reading`:
    ``adapter.sim`` is the running simulator (replaced when the adapter reconfigures), ``adapter.slot(part,
    index)`` the slot of a mesh, gear or gauge in its current structure (-1: absent)."""
    out: dict[str, Callable[[], Any]] = {}
    for v in variables:
        if v.causality not in CALCULATED:
            continue
        r = v.read
        if r is None:
            raise ValueError(f"output {v.name} has no Reading: it cannot be read from the simulator")
        if not r.part:
            out[v.name] = ((lambda a: lambda: getattr(adapter.sim, a))(r.attr) if r.attr
                           else (lambda c: lambda: c(adapter.sim, 0))(r.call))
        elif r.attr:
            def get(r=r):
                k = adapter.slot(r.part, r.index)
                return getattr(adapter.sim, r.attr)[k] if k >= 0 else r.absent
            out[v.name] = get
        else:
            def get(r=r):
                k = adapter.slot(r.part, r.index)
                return r.call(adapter.sim, k) if k >= 0 else r.absent
            out[v.name] = get
    return out


def output_expressions(variables, adapter) -> dict[str, str]:
    """Output name -> Python expression of its value in terms of ``s`` (the simulator) for the outputs read from a
    simulator attribute (the slave's fast path; the others have only :func:`output_getters`), with the slots of
    the adapter's current structure; absent parts read their ``absent`` value."""
    out = {}
    for v in variables:
        r = v.read
        if v.causality not in CALCULATED or r is None or not r.attr:
            continue
        k = _slot_of(adapter, r)
        out[v.name] = f"s.{r.attr}" if not r.part else (f"s.{r.attr}[{k}]" if k >= 0 else repr(r.absent))
    return out


def ident(text: str) -> str:
    """A structured-name identifier from free text (letters, digits, underscore)."""
    out = "".join(c if (c.isascii() and (c.isalnum() or c == "_")) else "_" for c in text)
    return out if out and not out[0].isdigit() else "g_" + out


#: Markers of the generated variable table in a model readme (``python build_fmu.py --readme``).
README_BEGIN = "<!-- FMU variables: generated by `python build_fmu.py --readme`; do not edit -->"
README_END = "<!-- end of FMU variables -->"


def _num(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def variables_table(variables) -> str:
    """Markdown table of FMU ``variables`` (name, causality and type, unit with display unit, range, meaning):
    what the model readmes show, rendered from the one spec."""
    rows = ["| name | causality, type | unit | range | meaning |", "|---|---|---|---|---|"]
    for v in variables:
        if v.causality == "independent":
            continue
        kind = v.causality if v.type == "Real" else f"{v.causality}, {v.type}"
        if v.declared_type:
            kind += f" `{v.declared_type}`"
        unit = v.unit + (f" (display {v.display_unit})" if v.display_unit else "")
        if v.declared_type:
            rng = ", ".join(f"{n} = {k}" for n, k, _ in ENUMERATIONS[v.declared_type][1])
        elif v.min is not None or v.max is not None:
            rng = (f"{'(' if v.min_open else '['}{_num(v.min) if v.min is not None else '-inf'}, "
                   f"{_num(v.max) if v.max is not None else 'inf'}{')' if v.max_open else ']'}")
            rng += " or inf" if v.allow_inf else ""
        else:
            rng = ""
        rows.append(f"| `{v.name}` | {kind} | {unit} | {rng} | {v.description.replace('|', '/')} |")
    return "\n".join(rows) + "\n"


def readme_with_variables(text: str, table: str) -> str:
    """``text`` (a model readme) with the generated variable ``table`` between :data:`README_BEGIN` and
    :data:`README_END`, replacing the block there or, without one, appended under a heading."""
    block = f"{README_BEGIN}\n{table}{README_END}\n"
    if README_BEGIN in text and README_END in text:
        head, rest = text.split(README_BEGIN, 1)
        return head + block + rest.split(README_END, 1)[1].lstrip("\n")
    return text.rstrip("\n") + "\n\n### FMU variables (units, ranges and descriptions from the FMU's spec)\n\n" + block
