"""Study files (TOML) → a validated :class:`StudySpec`, and the model file of each variant (key paths, TOML text).

A study file names a base model, the variables with their values (every combination is one variant), the statics
grid of each variant's tables, and what to compute per variant::

    [study]
    name = "spur_28t_asym_relief"
    base_model = "spur_28t_asym"        # shipped system name, or a model file / folder (relative to this file)
    mesh = "m12"                        # optional (default: the first mesh of each variant's model)

    [[variables]]
    key = "gears[*].drive.tip_relief_um"    # a model key path (below)
    values = [0.0, 15.0, 30.0, 45.0, 60.0]

    [statics]                           # the grid of every variant's tables (default: the model's [statics])
    positions = 64; loads = 8; deflections = 32; max_torque_factor = 3.0; solver = "fe"   # fe | analytic

    [static]                            # static results over torque (from each variant's tables)
    torques_Nm = [100.0, 200.0, 300.0, 400.0, 500.0]

    [dynamic]                           # optional: up/down speed sweeps
    torque_Nm = 300.0                   # optional (default: the variant's [operating] torque_Nm), or
    # torques_Nm = [150.0, 300.0, 450.0]  one sweep per torque (they run as lanes of the batched kernel)
    mesh_frequency_Hz = [500.0, 4000.0, 36]    # start, stop, count
    direction = "both"                  # up | down | both
    max_cycles = 3000                   # steady-state cycle cap per speed

    [load_spectrum]                     # optional: for the best variant per criterion
    torques_Nm = [150.0, 300.0, 450.0]
    weights = [0.3, 0.5, 0.2]           # time shares, summing to 1

Key paths
---------
A variable's ``key`` is the path of a numeric key in the model file, dots between tables.  An array of tables
(``gears``, ``meshes``, ``gears[...].gauges``) takes a selector in brackets: ``[*]`` every element,
``[pinion]`` the element whose ``name`` is ``pinion``, ``[0]`` the first element.  Examples:
``gears[*].drive.tip_relief_um`` (the drive-flank tip relief of every gear), ``gears[pinion].lead_crowning_um``,
``meshes[m12].center_distance_mm``, ``operating.torque_Nm``.  The last key may be absent in the base model (it then
takes its default there); the tables above it must exist, except a gear's ``errors`` table (manufacturing errors,
all of its keys optional: :data:`OPTIONAL_TABLES`), created where absent, so ``gears[pinion].errors.runout_um``,
``gears[pinion].errors.runout_phase_deg``, ``gears[*].errors.iso1328_grade`` and ``gears[*].errors.seed`` (integers
for the last two) are variables of any model.  The errors leave the tables as they are (the variants share them:
their model values hash is the same); they enter the dynamics (the ``[dynamic]`` sweeps).  The key ``model`` is
special: its values are base models (system names or paths), so one study can compare systems.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hacgear_core.errors import ModelError
from hacgear_core.model.schema import RANGES

__all__ = ["Variable", "StudySpec", "load_study", "parse_study", "apply_key", "MODEL_KEY", "OPTIONAL_TABLES"]

#: the variable key whose values are base models
MODEL_KEY = "model"

#: (array of tables, table) pairs a variable key may name although the base model lacks the table: tables whose
#: keys are all optional, created empty in each selected element (``gears[pinion].errors.runout_um`` on a model
#: whose pinion has no ``[gears.errors]``)
OPTIONAL_TABLES = frozenset({("gears", "errors")})

_SEGMENT = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[([^\]]+)\])?$")
_SOLVERS = ("fe", "analytic")
_DIRECTIONS = ("up", "down", "both")


@dataclass(frozen=True)
class Variable:
    """One study variable: a model key path and its values (numbers, or base models for ``key = "model"``)."""

    key: str
    values: tuple

    def __post_init__(self) -> None:
        if not self.values:
            raise ModelError(f"variable {self.key!r}: values must be a non-empty list")
        if self.key == MODEL_KEY:
            if not all(isinstance(v, str) and v for v in self.values):
                raise ModelError(f"variable {self.key!r}: values must be system names or model paths (strings)")
        else:
            _segments(self.key)
            for v in self.values:
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                    raise ModelError(f"variable {self.key!r}: value {v!r} is not a finite number")
        if len(set(self.values)) != len(self.values):
            raise ModelError(f"variable {self.key!r}: values repeat ({list(self.values)})")

    @property
    def unit(self) -> str:
        """The unit its key name carries (``tip_relief_um`` → ``um``), ``-`` without suffix."""
        last = self.key.rsplit(".", 1)[-1]
        for suffix in ("um", "mm", "deg", "Nm", "GPa", "N_per_m", "Nm_per_rad", "kg", "kgm2", "mrad"):
            if last.endswith("_" + suffix):
                return suffix
        return "-"

    @property
    def numeric(self) -> bool:
        return self.key != MODEL_KEY


@dataclass(frozen=True)
class StudySpec:
    """A validated study (module docstring); paths absolute.  ``variants`` lists every combination of the
    variables' values (the last variable varies fastest)."""

    name: str
    base_model: str
    variables: tuple
    static_torques_Nm: tuple
    mesh: str | None = None
    statics: dict = field(default_factory=dict)
    solver: str = "fe"
    dynamic: dict | None = None
    spectrum_torques_Nm: tuple = ()
    spectrum_weights: tuple = ()
    source: str = ""

    def __post_init__(self) -> None:
        if not self.variables:
            raise ModelError("study: at least one [[variables]] table (key, values) is required")
        keys = [v.key for v in self.variables]
        if len(set(keys)) != len(keys):
            raise ModelError(f"study: a variable key is given twice ({keys})")
        if self.solver not in _SOLVERS:
            raise ModelError(f"[statics] solver = {self.solver!r}; allowed: {' | '.join(_SOLVERS)}")
        if not self.static_torques_Nm:
            raise ModelError("[static] torques_Nm [N*m]: at least one torque is required")
        t = list(self.static_torques_Nm)
        if any(b <= a for a, b in zip(t, t[1:])):
            raise ModelError(f"[static] torques_Nm [N*m] = {t} must be ascending without repeats")
        if self.spectrum_torques_Nm:
            lo, hi = t[0], t[-1]
            for s in self.spectrum_torques_Nm:
                if not lo <= s <= hi:
                    raise ModelError(f"[load_spectrum] torques_Nm [N*m]: {s:g} lies outside the static torques "
                                     f"{lo:g} … {hi:g} N*m (the spectrum is read from them)")

    @property
    def variants(self) -> list[tuple]:
        """Every combination of the variables' values, one tuple per variant (in ``variables`` order)."""
        return list(itertools.product(*(v.values for v in self.variables)))

    def label(self, values: tuple) -> str:
        """``key=value, ...`` of one variant."""
        return ", ".join(f"{v.key}={x:g}" if v.numeric else f"{v.key}={x}" for v, x in zip(self.variables, values))

    def frequencies_Hz(self) -> list[float]:
        """The sweep's mesh frequencies [Hz] (empty without ``[dynamic]``)."""
        if not self.dynamic:
            return []
        a, b, n = self.dynamic["mesh_frequency_Hz"]
        return [a + (b - a) * i / (n - 1) for i in range(n)] if n > 1 else [a]

    def dynamic_torques_Nm(self, operating_torque_Nm: float) -> list[float]:
        """The torques of the sweeps [N*m]: ``[dynamic] torques_Nm``, else ``torque_Nm``, else the variant's
        operating torque ``operating_torque_Nm`` (empty without ``[dynamic]``)."""
        if not self.dynamic:
            return []
        if self.dynamic.get("torques_Nm"):
            return list(self.dynamic["torques_Nm"])
        t = self.dynamic["torque_Nm"]
        return [float(operating_torque_Nm if t is None else t)]

    @property
    def n_dynamic_torques(self) -> int:
        """How many torques each variant is swept at (0 without ``[dynamic]``)."""
        return len(self.dynamic_torques_Nm(0.0))

    def canonical(self) -> dict:
        """The values the results depend on (what the results file's ``study_sha256`` is taken of)."""
        return {"base_model": self.base_model, "mesh": self.mesh,
                "variables": [{"key": v.key, "values": list(v.values)} for v in self.variables],
                "statics": dict(sorted(self.statics.items())), "solver": self.solver,
                "static_torques_Nm": list(self.static_torques_Nm), "dynamic": self.dynamic,
                "spectrum_torques_Nm": list(self.spectrum_torques_Nm),
                "spectrum_weights": list(self.spectrum_weights)}

    def sha256(self) -> str:
        return hashlib.sha256(json.dumps(self.canonical(), sort_keys=True).encode()).hexdigest()


# ------------------------------------------------------------------------------------------------ key paths
def _segments(key: str) -> list[tuple[str, str | None]]:
    if not isinstance(key, str) or not key:
        raise ModelError(f"variable key {key!r}: a model key path such as 'gears[*].drive.tip_relief_um'")
    out = []
    for part in key.split("."):
        m = _SEGMENT.match(part)
        if m is None:
            raise ModelError(f"variable key {key!r}: segment {part!r} is not 'name' or 'name[selector]' (selector: "
                             "* | <element name> | <index>)")
        out.append((m.group(1), m.group(2)))
    if out[-1][1] is not None:
        raise ModelError(f"variable key {key!r}: the last segment must name a key, not select an array element")
    return out


def _select(items: list, sel: str, where: str, key: str) -> list:
    if sel == "*":
        return items
    if sel.isdigit():
        i = int(sel)
        if i >= len(items):
            raise ModelError(f"variable key {key!r}: {where}[{sel}]: the base model has {len(items)} element(s)")
        return [items[i]]
    hit = [d for d in items if d.get("name") == sel]
    if not hit:
        names = [d.get("name") for d in items]
        raise ModelError(f"variable key {key!r}: no element named {sel!r} in {where} of the base model ({names})")
    return hit


def apply_key(raw: dict, key: str, value: Any) -> int:
    """Set ``key`` (a key path, module docstring) to ``value`` in the parsed TOML ``raw`` (in place); returns how
    many keys were set.  Raises :class:`ModelError` naming the key when a table on the path does not exist."""
    segs = _segments(key)
    nodes = [raw]
    where = ""
    parent = ""
    for name, sel in segs[:-1]:
        nxt = []
        for node in nodes:
            if name not in node and sel is None and (parent, name) in OPTIONAL_TABLES:
                node[name] = {}
            if name not in node:
                raise ModelError(f"variable key {key!r}: the base model has no table {where + name!r}")
            child = node[name]
            if isinstance(child, list):
                if sel is None:
                    raise ModelError(f"variable key {key!r}: {where + name!r} is an array of tables; select "
                                     f"elements with {name}[*] (every one), {name}[<name>] or {name}[<index>]")
                nxt.extend(_select(child, sel, where + name, key))
            elif isinstance(child, dict):
                if sel is not None:
                    raise ModelError(f"variable key {key!r}: {where + name!r} is a table, not an array of tables; "
                                     "drop the selector")
                nxt.append(child)
            else:
                raise ModelError(f"variable key {key!r}: {where + name!r} is a value, not a table")
        nodes = nxt
        where += name + "."
        parent = name
    last = segs[-1][0]
    for node in nodes:
        old = node.get(last)
        if isinstance(old, (dict, list)):
            raise ModelError(f"variable key {key!r}: {where + last!r} is a table, not a numeric key")
        if isinstance(old, str) or isinstance(old, bool):
            raise ModelError(f"variable key {key!r}: {where + last!r} = {old!r} is not numeric")
        node[last] = value
    return len(nodes)


# ------------------------------------------------------------------------------------------------ study file
class _Reader:
    def __init__(self, data: dict, where: str, file: str) -> None:
        self.data, self.where, self.file = dict(data), where, file

    def _err(self, key: str, unit: str, allowed: str, got: Any) -> ModelError:
        u = f" [{unit}]" if unit else ""
        return ModelError(f"{self.file}: [{self.where}] {key}{u} = {got!r}; allowed: {allowed}")

    def get(self, key: str, kind: type | tuple, unit: str, allowed: str, default: Any = ..., check=None) -> Any:
        if key not in self.data:
            if default is ...:
                raise ModelError(f"{self.file}: [{self.where}] {key}{f' [{unit}]' if unit else ''} is missing; "
                                 f"allowed: {allowed}")
            return default
        v = self.data.pop(key)
        if isinstance(v, bool) and kind is not bool or not isinstance(v, kind):
            raise self._err(key, unit, allowed, v)
        if check is not None and not check(v):
            raise self._err(key, unit, allowed, v)
        return v

    def done(self) -> None:
        if self.data:
            raise ModelError(f"{self.file}: [{self.where}] unknown key(s) {sorted(self.data)}")


def _num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _torques(v: list) -> bool:
    return bool(v) and all(_num(t) and RANGES["torque_Nm"].contains(t) for t in v)


def _resolve_base(text: str, folder: Path) -> str:
    p = folder / text
    if p.exists():
        return str(p.resolve())
    return text  # a system name (resolved, and refused if unknown, per variant)


def parse_study(text: str, *, file: str = "<study>", folder: Path | None = None) -> StudySpec:
    """Parse study TOML text (module docstring) into a :class:`StudySpec`; relative model paths are read from
    ``folder`` (the study file's folder)."""
    folder = Path.cwd() if folder is None else folder
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"{file}: not valid TOML: {exc}") from None
    top = _Reader(raw, "", file)
    st = _Reader(top.get("study", dict, "", "a [study] table with name and base_model"), "study", file)
    name = st.get("name", str, "", "a non-empty string", check=bool)
    base = st.get("base_model", str, "", "a shipped system name or a model file/folder path", check=bool)
    mesh = st.get("mesh", str, "", "a mesh name of the model", default=None)
    source = st.get("source", str, "", "free text", default="")
    st.done()
    variables = []
    for i, vt in enumerate(top.get("variables", list, "", "[[variables]] tables with key and values")):
        if not isinstance(vt, dict):
            raise ModelError(f"{file}: variables must be [[variables]] tables")
        vr = _Reader(vt, f"variables {i + 1}", file)
        key = vr.get("key", str, "", "a model key path (e.g. 'gears[*].drive.tip_relief_um') or 'model'")
        vals = vr.get("values", list, "", "a non-empty list", check=bool)
        vr.done()
        if key == MODEL_KEY:
            vals = [_resolve_base(v, folder) if isinstance(v, str) else v for v in vals]
        variables.append(Variable(key, tuple(vals)))
    sr = _Reader(top.get("statics", dict, "", "a table", default={}), "statics", file)
    statics = {}
    for k, lo, hi in (("positions", 2, 4096), ("loads", 2, 1024), ("deflections", 4, 4096)):
        v = sr.get(k, int, "-", f"integer {lo} … {hi}", default=None, check=lambda x, lo=lo, hi=hi: lo <= x <= hi)
        if v is not None:
            statics[k] = v
    f = sr.get("max_torque_factor", (int, float), "-", ">= 3 (tables span 0 … >= 3 x the operating torque)",
               default=None, check=lambda x: _num(x) and x >= 3.0)
    if f is not None:
        statics["max_torque_factor"] = float(f)
    solver = sr.get("solver", str, "", " | ".join(_SOLVERS), default="fe", check=lambda s: s in _SOLVERS)
    sr.done()
    sa = _Reader(top.get("static", dict, "", "a [static] table with torques_Nm"), "static", file)
    torques = sa.get("torques_Nm", list, "N*m", f"a non-empty list of torques, each {RANGES['torque_Nm'].text}",
                     check=_torques)
    sa.done()
    dynamic = None
    if "dynamic" in top.data:
        dr = _Reader(top.get("dynamic", dict, "", "a table"), "dynamic", file)
        r = RANGES["mesh_frequency_Hz"]
        fm = dr.get("mesh_frequency_Hz", list, "Hz", f"[start, stop, count]: start <= stop, each {r.text}; "
                    "count >= 1 (1: start = stop); the sweep's order is [dynamic] direction",
                    check=lambda v: len(v) == 3 and _num(v[0]) and _num(v[1]) and r.contains(v[0])
                    and r.contains(v[1]) and isinstance(v[2], int) and not isinstance(v[2], bool) and v[2] >= 1
                    and v[0] <= v[1] and (v[2] > 1 or v[0] == v[1]))
        dt = dr.get("torque_Nm", (int, float), "N*m", RANGES["torque_Nm"].text, default=None,
                    check=lambda t: _num(t) and RANGES["torque_Nm"].contains(t))
        dts = dr.get("torques_Nm", list, "N*m", f"a non-empty list of distinct torques, each "
                     f"{RANGES['torque_Nm'].text}", default=None, check=lambda v: _torques(v) and len(set(v)) == len(v))
        if dt is not None and dts is not None:
            raise ModelError(f"{file}: [dynamic] torque_Nm and torques_Nm [N*m] exclude each other: give one torque "
                             "or a list of them")
        direction = dr.get("direction", str, "", " | ".join(_DIRECTIONS), default="both",
                           check=lambda s: s in _DIRECTIONS)
        cap = dr.get("max_cycles", int, "-", "integer 16 … 100000", default=3000, check=lambda c: 16 <= c <= 100000)
        dr.done()
        dynamic = {"mesh_frequency_Hz": [float(fm[0]), float(fm[1]), int(fm[2])],
                   "torque_Nm": None if dt is None else float(dt), "direction": direction, "max_cycles": int(cap)}
        if dts is not None:  # only then a key of its own: the results of studies with one torque keep their hash
            dynamic["torques_Nm"] = [float(t) for t in dts]
    sp_t: tuple = ()
    sp_w: tuple = ()
    if "load_spectrum" in top.data:
        lr = _Reader(top.get("load_spectrum", dict, "", "a table"), "load_spectrum", file)
        sp_t = tuple(float(t) for t in lr.get("torques_Nm", list, "N*m", "a non-empty list of torques",
                                              check=_torques))
        sp_w = tuple(float(w) for w in lr.get("weights", list, "-", "one time share >= 0 per torque, the shares "
                                              "summing to 1 (within 1e-6)",
                                              check=lambda w: len(w) == len(sp_t) and all(_num(x) and x >= 0
                                                                                          for x in w)
                                              and abs(math.fsum(w) - 1.0) <= 1e-6))
        lr.done()
    top.done()
    return StudySpec(name=name, base_model=_resolve_base(base, folder), variables=tuple(variables),
                     static_torques_Nm=tuple(float(t) for t in torques), mesh=mesh, statics=statics, solver=solver,
                     dynamic=dynamic, spectrum_torques_Nm=sp_t, spectrum_weights=sp_w, source=source)


def load_study(path: str | Path) -> StudySpec:
    """Read and validate a study file (relative model paths from its folder)."""
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"study file not found: {str(p)!r}")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"{p}: cannot read the study file ({exc})") from None
    return parse_study(text, file=str(p), folder=p.resolve().parent)

