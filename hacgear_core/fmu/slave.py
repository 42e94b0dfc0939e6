"""The pythonfmu slave every hacgear FMU runs (:class:`HacgearSlave`), its requirement checks and the workarounds
of pythonfmu 0.7.0 defects (docs/fmu.md).

Error policy inside an importer.  pythonfmu 0.7.0 maps a Python exception in the slave to ``fmi2Fatal`` and then
releases its references to the slave twice (heap corruption, a later crash of the importer), and a false return
of ``do_step`` to ``fmi2Discard``; it has no other error path.  So no slave method raises:

* wrong package versions or unreadable resources at instantiation: the instance is created with the variables of
  its modelDescription.xml, the reason is logged (``logStatusError``) and every ``doStep`` is refused;
* parameters out of range when initialization ends: logged there, every ``doStep`` refused (``fmi2Discard``) with
  the same message;
* NaN/inf/out-of-range inputs, impossible step sizes, a diverging integration: logged, ``fmi2DoStep`` returns
  ``fmi2Discard``, the state is left unchanged (the importer may correct the input and go on).
"""
from __future__ import annotations

import atexit
import ctypes
import json
import math
import sys
from importlib import metadata
from pathlib import Path
from typing import Callable
from xml.etree import ElementTree as ET

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from hacgear_core import __version__
from hacgear_core.errors import HacgearError
from hacgear_core.fmu.adapter import make_adapter

__all__ = ["FMU_INFO_FILE", "HacgearSlave", "fmu_info", "check_requirements", "requirements",
           "MAX_SUBSTEPS_PER_STEP"]

FMU_INFO_FILE = "hacgear_fmu.json"


def requirements() -> dict[str, str]:
    """Python packages (distribution name -> specifier) an importer needs to run a hacgear FMU built
    by this installation: the same hacgear version, and numpy/scipy/numba/h5py at least as new as
    the versions installed at build time (major.minor)."""
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


