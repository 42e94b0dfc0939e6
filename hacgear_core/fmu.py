"""FMI 2.0 co-simulation FMUs of gear systems (pythonfmu): the library side of the slaves in ``fmu_src/``.

Everything an FMU does lives here, in the installed package, so that

* the compiled kernels are imported from a stable path (numba's on-disk cache hits: no recompilation
  per run; kernels imported from an FMU's extraction folder would recompile every time);
* two different hacgear FMUs in one importer process share this code, while each FMU's own slave
  module has a unique name (``hacgear_<system>``; pythonfmu shares one interpreter and ``sys.modules``);
* each variable is declared **once**, in a spec table (:class:`FmuVariable`), used both to register the
  variables with pythonfmu at run time and to post-process ``modelDescription.xml`` at build time (units,
  ``min``/``max`` and the ``UnitDefinitions`` that pythonfmu 0.7 cannot write).

Pieces
------
:class:`FmuVariable`, :data:`UNITS`
    the spec of one variable; SI unit definitions.
:class:`SpurPairAdapter`
    maps FMI variables of a spur-pair FMU onto :class:`~hacgear_core.dynamics.spur.SpurPairSimulator`.
    Other system kinds add an adapter class and register it in :data:`ADAPTERS`; the generic slave
    :class:`HacgearSlave` and the build script need no change.
:class:`HacgearSlave`
    the pythonfmu ``Fmi2Slave`` all hacgear FMUs derive from; a kind's slave in ``fmu_src/<kind>.py`` only
    names its ``KIND``.
:func:`fmu_info`, :func:`check_requirements`
    the FMU's ``resources/hacgear_fmu.json`` (system, kind, required Python packages) and the version check
    made at instantiation.
:func:`postprocess_model_description`, :func:`build_fmu`
    the build (used by ``build_fmu.py``).

Error policy inside an importer.  pythonfmu 0.7.0 maps a Python exception in the slave to ``fmi2Fatal`` and
then releases its references to the slave twice (heap corruption, a later crash of the importer), and a
false return of ``do_step`` to ``fmi2Discard``; it has no other error path.  So no slave method raises:

* wrong package versions or unreadable resources at instantiation: the instance is created with the variables
  of its modelDescription.xml, the reason is logged (``logStatusError``) and every ``doStep`` is refused;
* parameters out of range when initialization ends: logged there, every ``doStep`` refused (``fmi2Discard``)
  with the same message;
* NaN/inf/out-of-range inputs, impossible step sizes, a diverging integration: logged, ``fmi2DoStep``
  returns ``fmi2Discard``, the state is left unchanged (the importer may correct the input and go on).
"""
from __future__ import annotations

import json
import math
import os
import shutil
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Callable, Sequence
from xml.etree import ElementTree as ET

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from hacgear_core.errors import HacgearError, ModelError

__all__ = [
    "FMU_INFO_FILE",
    "UNITS",
    "FmuVariable",
    "SpurPairAdapter",
    "ADAPTERS",
    "HacgearSlave",
    "fmu_info",
    "check_requirements",
    "requirements",
    "variables_for",
    "postprocess_model_description",
    "build_fmu",
    "synthetic_system_folder",
    "make_adapter",
    "MODE_SPEED",
    "MODE_TORQUE",
]

FMU_INFO_FILE = "hacgear_fmu.json"
MODEL_FILE = "model.toml"
TABLES_FILE = "tables.h5"
MODE_SPEED = 0
MODE_TORQUE = 1

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


# --------------------------------------------------------------------------------------------
# Spur pair
# --------------------------------------------------------------------------------------------
def _ident(text: str) -> str:
    """A structured-name identifier from free text (letters, digits, underscore)."""
    out = "".join(c if (c.isascii() and (c.isalnum() or c == "_")) else "_" for c in text)
    return out if out and not out[0].isdigit() else "g_" + out


class SpurPairAdapter:
    """Spur-pair FMU: FMI variables <-> :class:`~hacgear_core.dynamics.spur.SpurPairSimulator`.

    Gear 1 is the mesh's ``gear_a`` (driver), gear 2 its ``gear_b``.  Angles, speeds and shaft torques
    are positive in each gear's own direction of rotation (gear 2 turns opposite to gear 1); a braking
    load torque on gear 2 is negative.

    Two experiments, chosen by the parameter ``mode`` (fixed after initialization):

    * ``mode = 0`` (constant speed): input ``speed1_in`` (gear-1 speed), torque set-point = parameter
      ``torque``; the gear deviations are integrated around the imposed rotation (dissertation Eq. 3.1);
    * ``mode = 1`` (drivetrain coupling): inputs ``torque1_in``, ``torque2_in`` (shaft torques); outputs
      ``angle1``, ``angle2``, ``speed1``, ``speed2`` are the absolute gear motions to feed back into the
      shafts.  Starts from rest relative to ``speed1_start``.
    """

    kind = "spur_pair"

    def __init__(self, model, table) -> None:
        from hacgear_core.dynamics.spur import SpurPairSimulator, from_model

        self.model = model
        self.table = table
        self.base_params = from_model(model, table=table)
        self._Simulator = SpurPairSimulator
        p = self.base_params
        self.gauges = tuple(sorted(getattr(table, "strain", {}) or {}))
        self.sim = SpurPairSimulator(p, table)
        self._built_key = self._key(p, None)
        self.variables = self._spec()
        self.by_name = {v.name: v for v in self.variables}
        #: outputs computed by table post-processing (may fail: guarded by the slave)
        self.fallible = {v.name for v in self.variables if v.name == "peak_pressure" or v.name.startswith("root_strain.")}
        self._last_inputs: tuple | None = None
        self.mode = MODE_SPEED
        self.input_checks: tuple = ()
        self.step_floor_s = 0.0

    # ------------------------------------------------------------------ the spec (declared once)
    def _spec(self) -> tuple[FmuVariable, ...]:
        p = self.base_params
        m = self.model
        mesh = m.mesh()
        g1, g2 = mesh.gear_a, mesh.gear_b
        rb1, rb2 = p.base_radius_m
        k1, k2 = (0.0 if math.isinf(k) else k for k in p.bearing_stiffness_N_per_m)
        t1 = p.torque_Nm
        t2 = -t1 * rb2 / rb1
        V = FmuVariable
        spec = [
            V("mode", "Integer", "parameter", "fixed", "",
              "experiment: 0 = constant speed (input speed1_in, torque set-point = parameter torque); "
              "1 = drivetrain coupling (inputs torque1_in, torque2_in; outputs angles and speeds)",
              MODE_SPEED, 0, 1),
            V("torque", "Real", "parameter", "fixed", "N.m",
              f"nominal torque on gear 1 ({g1}): torque set-point of the constant-speed experiment; in both modes "
              "it sets the linearisation used for the modal damping", t1, 1e-3, 1e6),
            V("modal_damping_ratio", "Real", "parameter", "fixed", "1",
              "modal damping ratio of every elastic mode of the linearised system", p.modal_damping_ratio, 0.0, 0.99),
            V("bearing_stiffness1", "Real", "parameter", "fixed", "N/m",
              f"support stiffness of gear 1 ({g1}) along the line of action; 0 = rigid (no translation)", k1, 0.0, 1e15),
            V("bearing_stiffness2", "Real", "parameter", "fixed", "N/m",
              f"support stiffness of gear 2 ({g2}) along the line of action; 0 = rigid (no translation)", k2, 0.0, 1e15),
            V("internal_step", "Real", "parameter", "fixed", "s",
              "largest internal RK4 step; 0 = automatic (mesh period / 128 at the current speed and 1/32 of the "
              "period of the highest natural frequency); doStep sub-steps any communication step with equal steps "
              "no larger than this", 0.0, 0.0, 1e-3),
            V("speed1_start", "Real", "parameter", "fixed", "rad/s",
              f"mode 1: initial speed of gear 1 ({g1}); mode 0 starts at speed1_in", 0.0, -2e4, 2e4),
            V("speed1_in", "Real", "input", "continuous", "rad/s",
              f"mode 0: imposed speed of gear 1 ({g1}), positive in its direction of rotation (ignored in mode 1)",
              0.0, -2e4, 2e4),
            V("torque1_in", "Real", "input", "continuous", "N.m",
              f"mode 1: shaft torque on gear 1 ({g1}), positive in its direction of rotation (driving)",
              t1, -1e6, 1e6),
            V("torque2_in", "Real", "input", "continuous", "N.m",
              f"mode 1: shaft torque on gear 2 ({g2}), positive in its direction of rotation (a load is negative)",
              t2, -1e6, 1e6),
            V("mesh_force", "Real", "output", "continuous", "N",
              "dynamic mesh force along the line of action (0 = contact loss)"),
            V("mesh_deflection", "Real", "output", "continuous", "m",
              "mesh deflection x = r_b1 th1 + r_b2 th2 + y1 - y2 (dissertation Eq. 3.4)"),
            V("dte", "Real", "output", "continuous", "m",
              "dynamic transmission error r_b1 th1 + r_b2 th2 (rotations relative to the reference rotation)"),
            V("mesh_position", "Real", "output", "continuous", "1",
              "mesh position in mesh cycles (integer = pitch-point contact of a reference tooth pair), unwrapped"),
            V("contact", "Real", "output", "continuous", "1",
              "contact state: 1 = teeth in contact (mesh force > 0), 0 = contact loss"),
            V("angle1", "Real", "output", "continuous", "rad",
              f"rotation angle of gear 1 ({g1}) in its direction of rotation"),
            V("angle2", "Real", "output", "continuous", "rad",
              f"rotation angle of gear 2 ({g2}) in its direction of rotation"),
            V("speed1", "Real", "output", "continuous", "rad/s",
              f"speed of gear 1 ({g1}) in its direction of rotation"),
            V("speed2", "Real", "output", "continuous", "rad/s",
              f"speed of gear 2 ({g2}) in its direction of rotation"),
            V("bearing_force1", "Real", "output", "continuous", "N",
              f"bearing force on gear 1 ({g1}) along the line of action"),
            V("bearing_force2", "Real", "output", "continuous", "N",
              f"bearing force on gear 2 ({g2}) along the line of action"),
            V("peak_pressure", "Real", "output", "continuous", "Pa",
              "maximum contact pressure over all teeth in mesh (table lookup)"),
        ]
        for g in self.gauges:
            gear, _, gauge = g.partition("/")
            spec.append(V(f"root_strain.{_ident(gear)}.{_ident(gauge or gear)}", "Real", "output", "continuous", "1",
                          f"root strain at gauge '{g}' of one tooth (in mesh every {self._teeth_of(gear)} mesh cycles; "
                          "0 while out of mesh; table lookup)"))
        names = [v.name for v in spec]
        if len(set(names)) != len(names):
            raise ModelError(f"FMU variable names are not unique: {names}")
        return tuple(spec)

    def _teeth_of(self, gear: str) -> int:
        names = tuple(getattr(self.table, "gear_names", ()))
        return int(self.table.teeth[names.index(gear)]) if gear in names else int(self.table.teeth[0])

    # ------------------------------------------------------------------ outputs
    def getters(self) -> dict[str, Callable[[], float]]:
        """Output name -> zero-argument getter returning a Python float for the current step: the simulator's
        own output attributes (kept current by its ``advance``) and the table post-processing."""
        a = self
        out = {
            "mesh_force": lambda: a.sim.mesh_force_N,
            "mesh_deflection": lambda: a.sim.mesh_deflection_m,
            "dte": lambda: a.sim.dynamic_transmission_error_m,
            "mesh_position": lambda: a.sim.mesh_position,
            "contact": lambda: 1.0 if a.sim.in_contact else 0.0,
            "angle1": lambda: a.sim.angle1_rad,
            "angle2": lambda: a.sim.angle2_rad,
            "speed1": lambda: a.sim.speed1_rad_s,
            "speed2": lambda: a.sim.speed2_rad_s,
            "bearing_force1": lambda: a.sim.bearing_force_N[0],
            "bearing_force2": lambda: a.sim.bearing_force_N[1],
            "peak_pressure": a.peak_pressure,
        }
        for g in self.gauges:
            gear, _, gauge = g.partition("/")
            out[f"root_strain.{_ident(gear)}.{_ident(gauge or gear)}"] = (lambda key: lambda: a.root_strain(key))(g)
        return out

    def peak_pressure(self) -> float:
        """Maximum contact pressure over all teeth now [Pa] (table lookup along the dynamic state)."""
        from hacgear_core.post import dynamic_contact_pressure

        sim = self.sim
        return float(dynamic_contact_pressure(self.table, [sim.mesh_position], [sim.mesh_deflection_m])[0])

    def root_strain(self, gauge: str) -> float:
        """Root strain [-] at ``gauge`` on one physical tooth (library:
        :meth:`~hacgear_core.dynamics.spur.SpurPairSimulator.strain`)."""
        return float(self.sim.strain(gauge))

    # ------------------------------------------------------------------ configuration
    @staticmethod
    def _key(p, h):
        return (p.torque_Nm, p.modal_damping_ratio, p.bearing_stiffness_N_per_m, h)

    def configure(self, values: dict) -> None:
        """(Re)build the simulator for the parameter ``values`` and put it at its initial state.

        Raises
        ------
        ModelError
            Parameters that the model cannot take (message names field, unit, range).
        """
        k1, k2 = values["bearing_stiffness1"], values["bearing_stiffness2"]
        p = self.base_params.replace(
            torque_Nm=float(values["torque"]),
            modal_damping_ratio=float(values["modal_damping_ratio"]),
            bearing_stiffness_N_per_m=(math.inf if k1 == 0 else float(k1), math.inf if k2 == 0 else float(k2)),
        )
        h = float(values["internal_step"]) or None
        key = self._key(p, h)
        if key != self._built_key:
            self.sim = self._Simulator(p, self.table, internal_step_s=h)
            self._built_key = key
        self.mode = int(values["mode"])
        if self.mode == MODE_SPEED:
            self.sim.reset(speed_rad_s=float(values["speed1_in"]))
        else:
            self.sim.reset(speed_rad_s=float(values["speed1_start"]))
            self.sim.set_torque_inputs(float(values["torque1_in"]), float(values["torque2_in"]))
        self._last_inputs = None
        self.apply_inputs(values)
        names = ("speed1_in",) if self.mode == MODE_SPEED else ("torque1_in", "torque2_in")
        self.input_checks = tuple((n, self.by_name[n].min, self.by_name[n].max) for n in names)
        # a lower bound of the internal step at any allowed speed (the exact one is asked only for long steps)
        sy = self.sim.system
        v = self.by_name["speed1_in"]
        fm_max = 4.0 * max(abs(v.min), abs(v.max)) * sy.z1_2pi  # mesh frequency bound, margin for vibration [Hz]
        floor = min(1.0 / (32.0 * sy.max_frequency_Hz), 1.0 / (128.0 * fm_max))
        self.step_floor_s = min(floor, h) if h else floor

    def input_names(self) -> tuple[str, ...]:
        """Inputs read in the current mode (only these are checked and applied)."""
        return tuple(n for n, _, _ in self.input_checks)

    def apply_inputs(self, values: dict) -> None:
        """Hand the current inputs to the simulator (only when they changed)."""
        if self.mode == MODE_SPEED:
            cur = (values["speed1_in"],)
            if cur != self._last_inputs:
                self.sim.set_speed_input(speed_rad_s=cur[0])
        else:
            cur = (values["torque1_in"], values["torque2_in"])
            if cur != self._last_inputs:
                self.sim.set_torque_inputs(cur[0], cur[1])
        self._last_inputs = cur

    def advance(self, dt: float) -> str:
        """Advance the simulator by ``dt`` [s] > 0 (checked by the caller) with the library's own step,
        :meth:`SpurPairSimulator.advance <hacgear_core.dynamics.spur.SpurPairSimulator.advance>`; ``""`` on
        success, else the reason (the state is then left unchanged)."""
        r = self.sim.advance(dt)
        return "" if r.success else r.message

    def internal_step(self) -> float:
        """Internal step the simulator would use now [s]."""
        return float(self.sim.current_internal_step_s)


#: System kind -> adapter class.  A new kind adds its adapter here and a thin ``fmu_src/<kind>.py``.
ADAPTERS: dict[str, type] = {"spur_pair": SpurPairAdapter}


# --------------------------------------------------------------------------------------------
# Resources, requirements
# --------------------------------------------------------------------------------------------
def requirements() -> dict[str, str]:
    """Python packages (distribution name -> specifier) an importer needs to run a hacgear FMU built
    by this installation: the same hacgear version, and numpy/scipy/numba/h5py at least as new as
    the versions installed at build time (major.minor)."""
    from hacgear_core import __version__

    req = {"hacgear": f"=={__version__}"}
    for pkg in ("numpy", "scipy", "numba", "h5py"):
        try:
            v = metadata.version(pkg)
            req[pkg] = ">=" + ".".join(v.split(".")[:2])
        except metadata.PackageNotFoundError:  # pragma: no cover - all are dependencies
            continue
    return req


def _vtuple(v: str) -> tuple[int, ...]:
    out = []
    for part in v.split("."):
        num = ""
        for c in part:
            if c.isdigit():
                num += c
            else:
                break
        if not num:
            break
        out.append(int(num))
    return tuple(out)


def check_requirements(reqs: dict[str, str]) -> list[str]:
    """Check installed distributions against ``reqs`` (``name -> '==X'`` or ``'>=X'``).

    Returns
    -------
    list of str
        One message per unmet requirement (empty: all met).
    """
    problems = []
    for name, spec in reqs.items():
        try:
            have = metadata.version(name)
        except metadata.PackageNotFoundError:
            problems.append(f"Python package '{name}{spec}' is not installed")
            continue
        if spec.startswith("=="):
            ok = _vtuple(have) == _vtuple(spec[2:])
        elif spec.startswith(">="):
            ok = _vtuple(have) >= _vtuple(spec[2:])
        else:
            ok = True
        if not ok:
            problems.append(f"Python package '{name}' is {have}, this FMU needs {name}{spec}")
    return problems


def fmu_info(resources: str | Path) -> dict:
    """Read ``resources/hacgear_fmu.json`` (system, kind, title, requirements, file hashes)."""
    path = Path(resources) / FMU_INFO_FILE
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise HacgearError(f"FMU resource {path} missing or unreadable: {exc}") from None


def _load(resources: Path):
    """Model and mesh table from an FMU's (or a build's) resources folder."""
    from hacgear_core.model import load_model
    from hacgear_core.tables import read_tables

    model = load_model(resources / MODEL_FILE)
    tables = read_tables(resources / TABLES_FILE, resources / MODEL_FILE)  # refuses tables of another model
    mesh = model.mesh().name
    if mesh not in tables.meshes:
        raise HacgearError(f"tables have no mesh '{mesh}' (have {sorted(tables.meshes)})")
    return model, tables.meshes[mesh]


def make_adapter(resources: str | Path):
    """The adapter of the system in ``resources``: an FMU's resources folder (model.toml, tables.h5,
    hacgear_fmu.json) or a model folder (model.toml, tables.h5)."""
    resources = Path(resources)
    model, table = _load(resources)
    kind = model.kind
    if (resources / FMU_INFO_FILE).exists():
        kind = fmu_info(resources).get("kind")
        if model.kind != kind:
            raise HacgearError(f"model kind {model.kind!r} differs from the FMU's kind {kind!r}")
    if kind not in ADAPTERS:
        raise HacgearError(f"no FMU adapter for system kind {kind!r} yet (have {sorted(ADAPTERS)})")
    return ADAPTERS[kind](model, table)


def variables_for(resources: str | Path) -> tuple[FmuVariable, ...]:
    """The variable spec of the system in ``resources`` (what the slave registers)."""
    return make_adapter(resources).variables


# --------------------------------------------------------------------------------------------
# The slave
# --------------------------------------------------------------------------------------------
_CAUS = {"parameter": Fmi2Causality.parameter, "input": Fmi2Causality.input, "output": Fmi2Causality.output}
_VARI = {"fixed": Fmi2Variability.fixed, "tunable": Fmi2Variability.tunable,
         "continuous": Fmi2Variability.continuous, "discrete": Fmi2Variability.discrete}

#: Hard limit of internal steps in one doStep (~30 s of computing): a longer step is refused.
MAX_SUBSTEPS_PER_STEP = 200_000_000


#: pythonfmu binaries (path -> ctypes handle) whose exit-time state is released by :func:`_release_pythonfmu_states`.
_PYTHONFMU_BINARIES: dict = {}


def _release_pythonfmu_states() -> None:
    for handle in list(_PYTHONFMU_BINARIES.values()):
        try:
            handle.finalizePythonInterpreter()
        except Exception:  # pragma: no cover - nothing sensible to do at exit
            pass


def _guard_pythonfmu_exit(resources: Path) -> None:
    """Work around a use-after-free at process exit in pythonfmu 0.7.0's binary.

    Measured with valgrind (pythonfmu 0.7.0, fmpy 0.3.32, glibc): the binary stays loaded until the importer
    exits (its std::thread holds it); at exit the C++ destructor of its global ``std::shared_ptr<PyState>`` runs
    first, then its ``__attribute__((destructor))`` calls ``finalizePythonInterpreter()``, which resets that
    already destroyed shared_ptr and decrements a counter inside the freed block ("Invalid read ... 8 bytes inside
    a block of size 128 free'd").  That write corrupts the malloc free lists; when the process later frees more
    (e.g. scipy's libgfortran at exit) it aborts with "corrupted double-linked list" (~10 % of runs, more under
    load).  Calling the exported ``finalizePythonInterpreter()`` from a Python ``atexit`` handler, while the
    shared_ptr is still alive, empties it, so both exit-time destructors find nothing to release.  A handle is kept
    on each binary so that the call target stays mapped.  Linux binaries only.
    """
    import atexit
    import ctypes

    for lib in sorted((resources.parent / "binaries").glob("*/*.so")):
        key = str(lib)
        if key in _PYTHONFMU_BINARIES:
            continue
        try:
            handle = ctypes.CDLL(key)
            fn = handle.finalizePythonInterpreter
        except (OSError, AttributeError):  # another platform's binary, or not a pythonfmu binary
            continue
        fn.restype = None
        fn.argtypes = []
        if not _PYTHONFMU_BINARIES:
            atexit.register(_release_pythonfmu_states)
        _PYTHONFMU_BINARIES[key] = handle


class HacgearSlave(Fmi2Slave):
    """Generic pythonfmu slave of a hacgear system; subclasses (``fmu_src/<kind>.py``) set ``KIND``.

    No method lets an exception escape: pythonfmu 0.7.0 turns one into ``fmi2Fatal`` *and* releases its
    references to the slave then and again at ``fmi2FreeInstance`` (a double ``Py_DECREF``: heap corruption,
    a crash of the importer later).  Errors are logged and reported through ``doStep`` (``fmi2Discard``).
    The slave keeps no module-level state: everything lives on the instance.
    """

    KIND = ""
    author = "hacgear"
    license = "MIT"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.values: dict[str, float] = {}
        self._failed = ""
        self.time = 0.0
        self.adapter = None
        try:
            _guard_pythonfmu_exit(Path(self.resources))
        except Exception:  # pragma: no cover - best effort
            pass
        try:
            self._setup(Path(self.resources))
        except Exception as exc:  # keep the instance alive, report the reason, refuse to step
            self._failed = f"this FMU cannot run: {exc}"
            if not self._register_from_model_description():
                raise  # at build time (no modelDescription.xml yet): fail the build loudly
            self.log(self._failed, Fmi2Status.error)
        self._index_reals()

    def _setup(self, res: Path) -> None:
        info = fmu_info(res)
        problems = check_requirements(info.get("requirements", {}))
        if problems:
            raise HacgearError(
                f"FMU '{info.get('system')}' needs other Python packages in the importer's Python "
                f"({sys.executable}): " + "; ".join(problems) + ". Install them (pip install ...).")
        if self.KIND and info.get("kind") != self.KIND:
            raise HacgearError(f"slave of kind {self.KIND!r} got resources of kind {info.get('kind')!r}")
        self.modelName = info["system"]
        self.description = info.get("description") or f"hacgear {info['kind']} {info['system']}"
        self.version = info.get("hacgear_version")
        adapter = make_adapter(res)
        getters = adapter.getters()
        self.adapter = adapter
        for v in adapter.variables:
            if v.causality == "output":
                var_cls = Real if v.type == "Real" else Integer
                self.register_variable(var_cls(
                    v.name, causality=_CAUS[v.causality], variability=_VARI[v.variability],
                    description=v.description, initial=Fmi2Initial.exact,
                    getter=self._safe(v.name, getters[v.name]) if v.name in adapter.fallible else getters[v.name]))
            else:
                self.values[v.name] = float(v.start) if v.type == "Real" else int(v.start)
                self.register_variable(self._param_var(v.name, v.type, v.causality, v.variability, v.description))

    def _register_from_model_description(self) -> bool:
        """Register the FMU's variables from its modelDescription.xml (start values, no model) so that an
        importer can still set and get them; False when there is no modelDescription.xml (build time)."""
        path = Path(self.resources).parent / "modelDescription.xml"
        if not path.exists() or self.vars:
            return False
        for sv in ET.parse(path).getroot().find("ModelVariables").findall("ScalarVariable"):
            typed = sv.find("Real")
            typ = "Real"
            if typed is None:
                typed, typ = sv.find("Integer"), "Integer"
            start = typed.get("start") if typed is not None else None
            name = sv.get("name")
            self.values[name] = (float(start) if typ == "Real" else int(start)) if start is not None else math.nan
            if sv.get("causality") == "output":
                self.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                            description=sv.get("description"), initial=Fmi2Initial.exact,
                                            getter=(lambda n: lambda: self.values[n])(name)))
            else:
                self.register_variable(self._param_var(name, typ, sv.get("causality"), sv.get("variability"),
                                                       sv.get("description")))
        return True

    def _safe(self, name: str, getter: Callable[[], float]) -> Callable[[], float]:
        """Wrap an output getter so that a failure gives NaN and a log message, never an exception."""
        def get():
            try:
                return getter()
            except Exception as exc:
                self.log(f"output '{name}' could not be computed: {type(exc).__name__}: {exc}", Fmi2Status.error)
                return math.nan
        return get

    def _index_reals(self) -> None:
        """Value reference -> getter / setter of the Real variables (the per-step fast path of
        :meth:`get_real` and :meth:`set_real`; outputs have no setter)."""
        self._real_get = {vr: v.getter for vr, v in self.vars.items() if isinstance(v, Real)}
        self._real_set = {vr: v.setter for vr, v in self.vars.items() if isinstance(v, Real) and v.setter is not None}

    def _param_var(self, name: str, typ: str, causality: str, variability: str, description: str):
        values = self.values
        cls, conv = (Real, float) if typ == "Real" else (Integer, int)

        def setter(x):
            try:
                values[name] = conv(x)
            except (TypeError, ValueError, OverflowError):
                values[name] = math.nan

        return cls(name, causality=_CAUS[causality], variability=_VARI[variability], description=description,
                   getter=lambda: values[name], setter=setter)

    # ------------------------------------------------------------------ FMI calls (never raise)
    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        try:
            self.time = float(start_time)
        except (TypeError, ValueError):
            pass

    def exit_initialization_mode(self):
        if self._failed:
            self.log(self._failed, Fmi2Status.error)
            return
        try:
            errors = [msg for v in self.adapter.variables if v.causality != "output"
                      for msg in [v.check(self.values[v.name])] if msg]
            if not errors:
                try:
                    self.adapter.configure(self.values)
                except (HacgearError, ValueError, ArithmeticError) as exc:
                    errors.append(str(exc))
        except Exception as exc:
            errors = [f"{type(exc).__name__}: {exc}"]
        if errors:
            # pythonfmu 0.7 can return no error status here without corrupting itself (see class docstring):
            # log it now, refuse every doStep (fmi2Discard) with the same message.
            self._failed = "invalid parameters or start values: " + "; ".join(errors)
            self.log(self._failed, Fmi2Status.error)

    def get_real(self, vrs):
        """fmi2GetReal: the values (a list of floats, as pythonfmu's C wrapper reads them) of the Real variables
        ``vrs``.  One dictionary lookup and one getter call per variable (pythonfmu's own version checks each
        variable's type first); a value reference that is not a Real variable of this FMU gives NaN and a log
        message instead of an exception (see the class docstring)."""
        try:
            get = self._real_get
            return [get[vr]() for vr in vrs]
        except Exception:
            return self._get_real_checked(vrs)

    def _get_real_checked(self, vrs):
        out = []
        for vr in vrs:
            g = self._real_get.get(vr)
            if g is None:
                self.log(f"getReal: value reference {vr!r} is not a Real variable of this FMU; NaN returned",
                         Fmi2Status.error)
                out.append(math.nan)
                continue
            try:
                out.append(float(g()))
            except Exception as exc:
                self.log(f"getReal: '{self.vars[vr].name}' could not be read: {type(exc).__name__}: {exc}; NaN "
                         "returned", Fmi2Status.error)
                out.append(math.nan)
        return out

    def set_real(self, vrs, values):
        """fmi2SetReal: store the values of Real parameters and inputs (checked when initialization ends and in
        every ``doStep``); a value reference that is not a settable Real variable is logged and ignored."""
        try:
            put = self._real_set
            for vr, x in zip(vrs, values):
                put[vr](x)
        except Exception:
            for vr, x in zip(vrs, values):
                setter = self._real_set.get(vr)
                if setter is None:
                    self.log(f"setReal: value reference {vr!r} is not a settable Real variable of this FMU "
                             "(parameter or input); ignored", Fmi2Status.error)
                else:
                    setter(x)

    def do_step(self, current_time, step_size):
        try:
            return self._do_step(current_time, step_size)
        except Exception as exc:  # never let an exception reach the importer as fmi2Fatal
            self.log(f"doStep at t = {current_time!r} s failed: {type(exc).__name__}: {exc}", Fmi2Status.error)
            return False

    def _do_step(self, current_time, step_size):
        if self._failed:
            self.log(f"doStep refused: {self._failed}", Fmi2Status.error)
            return False
        h = float(step_size)
        if not (0.0 < h < math.inf):  # False for NaN
            self.log(f"communication step size [s] must be finite and > 0, got {step_size!r}", Fmi2Status.error)
            return False
        ad = self.adapter
        values = self.values
        for name, lo, hi in ad.input_checks:
            if not (lo <= values[name] <= hi):  # False for NaN
                self.log(f"doStep at t = {current_time:g} s: {ad.by_name[name].check(values[name])}; step refused, "
                         "state unchanged", Fmi2Status.error)
                return False
        ad.apply_inputs(values)
        if h > MAX_SUBSTEPS_PER_STEP * ad.step_floor_s:  # only then can the step be too long: ask exactly
            hi_ = ad.internal_step()
            if h / hi_ > MAX_SUBSTEPS_PER_STEP:
                self.log(f"communication step {h:g} s needs {h / hi_:.3g} internal steps of {hi_:.3g} s "
                         f"(limit {MAX_SUBSTEPS_PER_STEP:g}); use shorter communication steps", Fmi2Status.error)
                return False
        msg = ad.advance(h)
        if msg:
            self.log(f"doStep at t = {current_time:g} s: {msg}", Fmi2Status.error)
            return False
        self.time = current_time + h
        return True


# --------------------------------------------------------------------------------------------
# Build: modelDescription post-processing and the FMU
# --------------------------------------------------------------------------------------------
def _fmt(x: float) -> str:
    return repr(float(x))


def postprocess_model_description(xml_text: str | bytes, variables: Sequence[FmuVariable],
                                  description: str | None = None) -> bytes:
    """Add units, ``min``/``max`` and ``UnitDefinitions`` to a pythonfmu modelDescription.xml.

    Every ScalarVariable must match exactly one spec entry by name with the same causality and
    variability (and vice versa), else :class:`HacgearError`.

    Returns
    -------
    bytes
        The new XML (UTF-8).
    """
    root = ET.fromstring(xml_text)
    spec = {v.name: v for v in variables}
    mv = root.find("ModelVariables")
    seen = set()
    used_units = set()
    for sv in mv.findall("ScalarVariable"):
        name = sv.get("name")
        v = spec.get(name)
        if v is None:
            raise HacgearError(f"modelDescription.xml variable '{name}' is not in the spec")
        seen.add(name)
        if sv.get("causality") != v.causality or sv.get("variability") != v.variability:
            raise HacgearError(f"variable '{name}': XML causality/variability {sv.get('causality')}/"
                               f"{sv.get('variability')} differ from the spec {v.causality}/{v.variability}")
        sv.set("description", v.description)
        typed = sv.find(v.type)
        if typed is None:
            raise HacgearError(f"variable '{name}': XML type differs from the spec type {v.type}")
        if v.type == "Real":
            typed.set("unit", v.unit)
            used_units.add(v.unit)
        if v.min is not None:
            typed.set("min", _fmt(v.min) if v.type == "Real" else str(int(v.min)))
        if v.max is not None:
            typed.set("max", _fmt(v.max) if v.type == "Real" else str(int(v.max)))
        if v.causality != "output" and v.start is not None and v.type == "Real":
            typed.set("start", _fmt(v.start))
    missing = set(spec) - seen
    if missing:
        raise HacgearError(f"spec variables missing in modelDescription.xml: {sorted(missing)}")
    if root.find("UnitDefinitions") is not None:
        root.remove(root.find("UnitDefinitions"))
    units = ET.Element("UnitDefinitions")
    for u in sorted(used_units):
        ue = ET.SubElement(units, "Unit", {"name": u})
        ET.SubElement(ue, "BaseUnit", {k: str(e) for k, e in UNITS[u].items()})
    # schema order: ModelExchange?, CoSimulation?, UnitDefinitions?, TypeDefinitions?, LogCategories?, ...
    children = list(root)
    pos = max(i for i, c in enumerate(children) if c.tag in ("CoSimulation", "ModelExchange")) + 1
    root.insert(pos, units)
    if description:
        root.set("description", description)
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def _rewrite_zip_member(zpath: Path, member: str, data: bytes) -> None:
    tmp = zpath.with_suffix(zpath.suffix + ".tmp")
    with zipfile.ZipFile(zpath) as zin, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            content = data if item.filename == member else zin.read(item.filename)
            zout.writestr(item.filename, content, compress_type=zipfile.ZIP_DEFLATED)
    os.replace(tmp, zpath)


def _sha256(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


SLAVE_DIR = Path(__file__).resolve().parent.parent / "fmu_src"


def build_fmu(system_dir: str | Path, out_dir: str | Path, *, slave_dir: str | Path | None = None) -> Path:
    """Build ``<out_dir>/<system>.fmu`` from ``<system_dir>/model.toml`` and ``<system_dir>/tables.h5``.

    The slave module is ``fmu_src/<kind>.py`` copied under the unique name ``hacgear_<system>``; the
    model file, the tables and ``hacgear_fmu.json`` (system, kind, required packages) travel as
    resources; modelDescription.xml is post-processed from the same variable spec the slave registers.

    Raises
    ------
    HacgearError
        No tables, no slave for the model's kind, tables of another model, or a failed build.
    """
    from pythonfmu import FmuBuilder
    from pythonfmu.default_experiment import DefaultExperiment  # noqa: F401  (eager import)

    from hacgear_core import __version__
    from hacgear_core.model import load_model

    system_dir = Path(system_dir)
    out_dir = Path(out_dir)
    model = load_model(system_dir / MODEL_FILE)
    tables = system_dir / TABLES_FILE
    if not tables.exists():
        raise HacgearError(f"{system_dir}: no {TABLES_FILE} (run `hacgear statics {model.name}` first)")
    slave_dir = Path(slave_dir) if slave_dir else SLAVE_DIR
    slave_src = slave_dir / f"{model.kind}.py"
    if model.kind not in ADAPTERS or not slave_src.exists():
        raise HacgearError(f"{model.name}: no FMU slave for kind '{model.kind}' yet ({slave_src})")
    module = f"hacgear_{_ident(model.name)}"
    out_dir.mkdir(parents=True, exist_ok=True)
    dest = out_dir / f"{model.name}.fmu"
    with tempfile.TemporaryDirectory(prefix="hacgear_fmu_") as td:
        td = Path(td)
        script = td / f"{module}.py"
        shutil.copy2(slave_src, script)
        res = td / "res"
        res.mkdir()
        shutil.copy2(system_dir / MODEL_FILE, res / MODEL_FILE)
        shutil.copy2(tables, res / TABLES_FILE)
        info = {
            "format": "hacgear-fmu", "format_version": 1, "system": model.name, "kind": model.kind,
            "description": f"hacgear {model.kind} FMU: {model.title or model.name}",
            "hacgear_version": __version__, "requirements": requirements(),
            "model_sha256": _sha256(res / MODEL_FILE), "tables_sha256": _sha256(res / TABLES_FILE),
            "slave_module": module,
        }
        (res / FMU_INFO_FILE).write_text(json.dumps(info, indent=1), encoding="utf-8")
        spec = variables_for(res)  # the same spec the slave registers
        try:
            built = FmuBuilder.build_FMU(script, dest=dest, project_files=[res / MODEL_FILE, res / TABLES_FILE,
                                                                          res / FMU_INFO_FILE])
        except HacgearError:
            raise
        except Exception as exc:
            raise HacgearError(f"{model.name}: pythonfmu build failed: {type(exc).__name__}: {exc}") from exc
        finally:
            sys.modules.pop(module, None)
            while str(td) in sys.path:
                sys.path.remove(str(td))
    built = Path(built)
    with zipfile.ZipFile(built) as z:
        xml = z.read("modelDescription.xml")
    new = postprocess_model_description(xml, spec, description=info["description"])
    _rewrite_zip_member(built, "modelDescription.xml", new)
    return built


def synthetic_system_folder(model: str | Path, dest: str | Path) -> Path:
    """A model folder ``dest/<system>/`` with the model file and a **synthetic** ``tables.h5``.

    For building and testing FMUs before the static solver's tables exist: the table comes from
    :func:`hacgear_core.dynamics.synthetic.spur_fdf_table` with the model's teeth, module, loaded-flank
    pressure angle and tip relief (not from the contact solver; results are labelled synthetic).
    """
    from hacgear_core.dynamics.synthetic import spur_fdf_table
    from hacgear_core.model import load_model, model_sha256
    from hacgear_core.tables import SystemTables, write_tables

    m = load_model(model)
    if m.kind != "spur_pair":
        raise HacgearError(f"synthetic tables exist for spur pairs only, not {m.kind!r}")
    mesh = m.mesh()
    ga, gb = m.gear(mesh.gear_a), m.gear(mesh.gear_b)
    fl = ga.flanks[mesh.flank_a]
    table = spur_fdf_table(
        name=mesh.name, teeth=(ga.teeth, gb.teeth), module_m=ga.module_m,
        pressure_angle_deg=math.degrees(fl.pressure_angle_rad), tip_relief_m=fl.tip_relief_m,
        nominal_torque_Nm=m.operating.torque_Nm, gear_names=(ga.name, gb.name), n_positions=64,
        n_deflections=64)
    import dataclasses

    if dataclasses.is_dataclass(table) and any(f.name == "solver" for f in dataclasses.fields(table)):
        table = dataclasses.replace(table, solver="SYNTHETIC (hacgear_core.dynamics.synthetic.spur_fdf_table)")
    folder = Path(dest) / m.name
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy2(m.path, folder / MODEL_FILE)
    write_tables(folder / TABLES_FILE, SystemTables(meshes={mesh.name: table},
                                                    model_sha256=model_sha256(folder / MODEL_FILE),
                                                    model_file=str(folder / MODEL_FILE)))
    return folder
