"""The Python side of every hacgear FMU (FMI 2.0 and FMI 3.0 co-simulation): :class:`FmuInstance`, the FMI state
machine and statuses over the generic :class:`~hacgear_core.fmu.adapter.Adapter`.

The FMU's binary (``fmu_src/``, compiled when the FMU is built) forwards each FMI call to one
method of :class:`FmuInstance` and returns the status that method returns; messages queued in
:attr:`FmuInstance.messages` go to the master's logger after every call (warnings and errors always, the rest
only with debug logging on).  Python exceptions never reach the binary: every method catches them and answers
``Error`` with a message.

FMI behaviour (FMI 2.0.4 section 4.2, FMI 3.0 section 4.2; the same rules for both versions):

* a call that the current state does not allow (``doStep`` before initialization, ``setReal`` after
  ``terminate``...) returns Error and names the call and the state;
* ``setX`` of an output, of an unknown value reference, of a variable of another type, or of a fixed parameter
  after initialization returns Error, nothing is stored;
* parameters (and the inputs of the chosen experiment, which set its initial state) are checked when
  initialization ends: a value that is not finite or outside [min, max] makes ``ExitInitializationMode`` return
  Error with a message naming the variable, its value, unit and allowed range;
* in ``doStep``: a step size that is not finite and > 0, a ``currentCommunicationPoint`` that is not the end of
  the previous step, or an input that is not finite or outside [min, max] is an Error (the state is left
  unchanged); an integration that diverges, or a step that would need more than :data:`MAX_SUBSTEPS_PER_STEP`
  internal steps, is Discard (state unchanged, last successful time = the step's start);
* after Error only getters, ``get/setFMUstate``, ``reset`` and ``freeInstance`` are allowed (the master may roll
  back to a stored FMU state); after Discard the same plus ``terminate``;
* FMU states (``get/setFMUstate``, serialization) hold everything a later step depends on, so a restored state
  repeats a step bit for bit.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from hacgear_core.dynamics.kernels import COMPILE_CPU_S
from hacgear_core.encodings import Experiment
from hacgear_core.errors import HacgearError
from hacgear_core.fmu.adapter import make_adapter
from hacgear_core.fmu.components import COMPONENTS, ComponentAdapter
from hacgear_core.fmu.numba_cache import SHIPPED_DIR, install as install_shipped_code
from hacgear_core.fmu.spec import CALCULATED, TIME, TYPES, FmuVariable

__all__ = ["FMU_INFO_FILE", "FmuInstance", "fmu_info", "value_references", "MAX_SUBSTEPS_PER_STEP",
           "OK", "WARNING", "DISCARD", "ERROR", "FATAL"]

FMU_INFO_FILE = "hacgear_fmu.json"

#: FMI status codes (equal in FMI 2.0 and 3.0)
OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4

#: Hard limit of internal steps in one doStep (~30 s of computing): a longer step is discarded.
MAX_SUBSTEPS_PER_STEP = 200_000_000

# instance states
INSTANTIATED, INITIALIZATION, STEP, STEP_FAILED, TERMINATED, FAILED = (
    "instantiated", "initialization mode", "step mode", "step failed (after Discard)", "terminated",
    "error (after Error)")
_GET_STATES = frozenset({INITIALIZATION, STEP, STEP_FAILED, TERMINATED, FAILED})
_SET_STATES = frozenset({INSTANTIATED, INITIALIZATION, STEP})
_STATE_STATES = frozenset({INSTANTIATED, INITIALIZATION, STEP, STEP_FAILED, TERMINATED, FAILED})
_CATEGORY = {OK: "logAll", WARNING: "logStatusWarning", DISCARD: "logStatusDiscard", ERROR: "logStatusError",
             FATAL: "logStatusFatal"}
_STATE_MAGIC = b"hacgear-fmu-state 1\n"


def fmu_info(resources: str | Path) -> dict:
    """Read ``resources/hacgear_fmu.json`` (system, kind, guid, variables, requirements, bundle, ports)."""
    path = Path(resources) / FMU_INFO_FILE
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise HacgearError(f"FMU resource {path} missing or unreadable: {exc}") from None


def value_references(variables) -> dict[str, int]:
    """Variable name -> value reference (1, 2, ... in spec order; unique over all types, as FMI 3.0 needs)."""
    return {v.name: i + 1 for i, v in enumerate(variables)}


def _fmi_kinds(fmi_version: int) -> dict[str, frozenset]:
    """FMI access function family -> variable types it reads and writes."""
    if fmi_version >= 3:
        return {"real": frozenset({"Real"}), "integer": frozenset({"Integer"}),
                "int64": frozenset({"Enumeration"}), "boolean": frozenset({"Boolean"}), "string": frozenset()}
    return {"real": frozenset({"Real"}), "integer": frozenset({"Integer", "Enumeration"}),
            "boolean": frozenset({"Boolean"}), "string": frozenset()}


class FmuInstance:
    """One instance of a hacgear FMU.

    Parameters
    ----------
    resources : str or Path
        The FMU's resources folder (model.toml, tables.h5, hacgear_fmu.json).
    instance_name : str
    token : str
        The GUID (FMI 2.0) or instantiation token (FMI 3.0) the master read from modelDescription.xml; must be this
        FMU's.
    logging_on : bool
        Debug logging (messages with status OK); warnings and errors are always queued.
    fmi_version : int
        2 or 3 (names of the calls in messages, the type families of the access functions).
    notes : sequence of str
        Warnings of the loader to pass on to the master's logger.
    cache_dir : str or Path, optional
        Where the assembled lumped system is kept between processes (by GUID); None: assemble every time.
    """

    def __init__(self, resources, instance_name: str, token: str, logging_on: bool = False, fmi_version: int = 2,
                 notes=(), cache_dir=None) -> None:
        self.messages: list[tuple[int, str, str]] = []
        self.instance_name = str(instance_name)
        self.fmi_version = int(fmi_version)
        self.logging_on = bool(logging_on)
        self.resources = Path(resources)
        self.info = fmu_info(self.resources)
        if token != self.info.get("guid"):
            raise HacgearError(f"instantiation token {token!r} is not this FMU's ({self.info.get('guid')!r}): the "
                               "modelDescription.xml read by the master belongs to another FMU or build")
        cache_file = None if cache_dir is None else Path(cache_dir) / f"{str(token).strip('{}')}.pickle"
        #: (functions whose shipped compiled code was installed, why none was): before anything is compiled
        self.shipped_code = (0, "")
        if self.info.get("kind") in COMPONENTS:
            self.adapter = ComponentAdapter(self.info["kind"])
            self._tables_adapter = False
        else:
            package = __name__.split(".")[0]
            if package == self.info.get("bundle", {}).get("package"):  # the FMU's own bundled code
                self.shipped_code = install_shipped_code(package, self.resources / SHIPPED_DIR)
            self.adapter = make_adapter(self.resources, cache_file)
            self._tables_adapter = True
        variables = self.adapter.variables
        names = [v.name for v in variables]
        if names != self.info.get("variables"):
            raise HacgearError("the FMU's variables differ from the model and tables in its resources (resources "
                               "edited after the build?)")
        self.vrs = value_references(variables)
        self.var: dict[int, FmuVariable] = {self.vrs[v.name]: v for v in variables}
        if self.fmi_version >= 3:
            self.var[0] = TIME
        self.kinds = _fmi_kinds(self.fmi_version)
        self.start_values = {v.name: TYPES[v.type](v.start) for v in variables if v.causality in ("parameter", "input")}
        self.values = dict(self.start_values)
        getters = self.adapter.getters()
        values = self.values
        self._get = {}
        for vr, v in self.var.items():
            if v is TIME:
                self._get[vr] = lambda: self.time
            elif v.causality in CALCULATED:
                g = getters[v.name]
                self._get[vr] = self._guarded(v.name, g) if v.name in self.adapter.fallible else g
            else:
                self._get[vr] = (lambda n: lambda: values[n])(v.name)
        self._real_get = {vr: g for vr, g in self._get.items() if self.var[vr].type == "Real"}
        self._real_set_step = frozenset(vr for vr, v in self.var.items()
                                        if v.type == "Real" and v.causality == "input")
        #: inputs one of the experiments ignores (all inputs: each experiment reads some of them)
        self._ignorable = tuple(v.name for v in variables if v.causality == "input")
        self.state = INSTANTIATED
        self.time = 0.0
        self.stop_time: float | None = None
        self._configured_key = None
        #: inputs the chosen experiment ignores that were reported (once each) as set
        self._ignored_reported: set = set()
        self._watched: tuple = ()
        self._issued: dict[int, object] = {}  # FMU states handed to the binary, by address
        self._inputs_changed = True
        self._long_step_s = 0.0
        self._advance = None
        self._readers: dict = {}
        for note in notes:
            self.log(WARNING, str(note))
        if self._tables_adapter:
            self.log(OK, f"ExitInitializationMode makes {self.adapter.sim.system.kernel_label} ready: numba loads it "
                         "from its cache (or the compiled code shipped in this FMU), or compiles it the first time on this machine (once per machine, about "
                         f"{COMPILE_CPU_S} s on one core)")

    # ------------------------------------------------------------------ helpers
    def log(self, status: int, message: str) -> None:
        """Queue a message for the master's logger (statuses OK only when debug logging is on)."""
        if status == OK and not self.logging_on:
            return
        if self.fmi_version < 3:  # the FMI 2.0 logger is printf-like
            message = message.replace("%", "%%")
        self.messages.append((int(status), _CATEGORY.get(status, "logAll"), message))

    def _fn(self, name: str) -> str:
        return f"fmi{self.fmi_version}{name}"

    def _error(self, message: str) -> int:
        """Log an error and enter the error state (FMI: the simulation cannot go on unless a stored state is
        restored or the instance is reset)."""
        self.log(ERROR, message)
        self.state = FAILED
        return ERROR

    def _illegal(self, call: str) -> int:
        return self._error(f"{self._fn(call)}: not allowed in state '{self.state}' (illegal call sequence)")

    def _guarded(self, name: str, getter):
        """A getter whose failure gives NaN and an error message (table post-processing of an output)."""
        def get():
            try:
                return getter()
            except Exception as exc:
                self._error(f"output '{name}' could not be computed: {type(exc).__name__}: {exc}")
                return math.nan
        return get

    def _configure(self, parameters_only: bool = False) -> str:
        """Check the parameters and the chosen experiment's inputs, then build the simulator and put it at its
        initial state (only when they changed since the last call); '' or the reasons.  With ``parameters_only``
        (restoring an FMU state, which then sets the simulator's state): only the parameters are checked and
        only a change of parameters rebuilds."""
        values = self.values
        ad = self.adapter
        errors = [msg for v in self.var.values() if v.causality == "parameter" for msg in [v.check(values[v.name])]
                  if msg]
        if errors:
            return "; ".join(errors)
        if parameters_only:
            if self._configured_key is not None and self._keys(values)[0] == self._configured_key[0]:
                self._bind()
                return ""
            # invalid inputs do not matter here (the restored state replaces the initial one): use start values
            values = {n: (x if not ad.by_name[n].check(x) else ad.by_name[n].start) for n, x in values.items()}
        else:
            errors = [msg for n in ad.active_inputs(values) for msg in [ad.by_name[n].check(values[n])] if msg]
            if errors:
                return "; ".join(errors)
        key = self._keys(values)
        if key != self._configured_key:
            try:
                ad.configure(values)
            except (HacgearError, ValueError, ArithmeticError) as exc:
                self._configured_key = None
                return str(exc)
            self._configured_key = key
        self._bind()
        return ""

    def _bind(self) -> None:
        """The per-step path of the simulator configured now (see :meth:`do_step`)."""
        ad = self.adapter
        self._advance = ad.sim.advance
        self._long_step_s = MAX_SUBSTEPS_PER_STEP * ad.step_floor_s
        self._inputs_changed = True

    def _keys(self, values: dict) -> tuple:
        """(parameter values, input values): what the simulator was configured with."""
        par = tuple(sorted((n, x) for n, x in values.items() if self.adapter.by_name[n].causality == "parameter"))
        inp = tuple(sorted((n, x) for n, x in values.items() if self.adapter.by_name[n].causality == "input"))
        return par, inp

    # ------------------------------------------------------------------ life cycle
    def setup_experiment(self, start_time: float, stop_time: float | None = None, tolerance=None) -> int:
        """fmi2SetupExperiment (FMI 3.0 passes the same to :meth:`enter_initialization_mode`)."""
        try:
            if self.state != INSTANTIATED:
                return self._illegal("SetupExperiment")
            return self._setup(start_time, stop_time)
        except Exception as exc:  # pragma: no cover - defensive
            return self._error(f"{self._fn('SetupExperiment')}: {type(exc).__name__}: {exc}")

    def _setup(self, start_time, stop_time) -> int:
        t0 = float(start_time)
        if not math.isfinite(t0):
            return self._error(f"start time [s] must be finite, got {t0!r}")
        if stop_time is not None and not (float(stop_time) >= t0):
            return self._error(f"stop time [s] must be >= start time {t0!r}, got {stop_time!r}")
        self.time = t0
        self.stop_time = None if stop_time is None else float(stop_time)
        return OK

    def enter_initialization_mode(self, start_time: float | None = None, stop_time: float | None = None,
                                  tolerance=None) -> int:
        """fmi2EnterInitializationMode; FMI 3.0 passes start and stop time here."""
        try:
            if self.state != INSTANTIATED:
                return self._illegal("EnterInitializationMode")
            if start_time is not None:
                st = self._setup(start_time, stop_time)
                if st != OK:
                    return st
            self.state = INITIALIZATION
            return OK
        except Exception as exc:  # pragma: no cover - defensive
            return self._error(f"{self._fn('EnterInitializationMode')}: {type(exc).__name__}: {exc}")

    def exit_initialization_mode(self) -> int:
        """Check the parameters (Error naming variable, value, unit and range) and build the simulator."""
        try:
            if self.state != INITIALIZATION:
                return self._illegal("ExitInitializationMode")
            msg = self._configure()
            if msg:
                return self._error(f"{self._fn('ExitInitializationMode')}: invalid parameters or start values: {msg}")
            if self._tables_adapter:  # compile (or load) the kernel here, not in the first doStep
                installed, why_not = self.shipped_code
                why = (f" (the compiled code shipped in this FMU was not used: {why_not})" if why_not else
                       " (numba did not accept the compiled code shipped in this FMU)" if installed else "")
                compiled, seconds = self.adapter.sim.system.prepare_kernel(notice=lambda m: self.log(OK, m + why))
                label = self.adapter.sim.system.kernel_label
                if compiled:
                    self.log(OK, f"compiled {label} in {seconds:.1f} s")
                elif installed:
                    self.log(OK, f"loaded {label} from the compiled code shipped in this FMU (nothing compiled)")
                    self.shipped_code = (0, "")
            self.state = STEP
            self._watch_ignored_inputs()
            return WARNING if self._report_ignored_inputs("ExitInitializationMode") else OK
        except Exception as exc:
            return self._error(f"{self._fn('ExitInitializationMode')}: {type(exc).__name__}: {exc}")

    def terminate(self) -> int:
        if self.state not in (STEP, STEP_FAILED):
            return self._illegal("Terminate")
        self.state = TERMINATED
        return OK

    def reset(self) -> int:
        """Back to the state after instantiation, with the start values: the next initialization builds the
        simulator at its initial state even where the parameters are the ones it ran with."""
        self.values.clear()
        self.values.update(self.start_values)
        self._configured_key = None
        self._ignored_reported = set()
        self._watched = ()
        self.state = INSTANTIATED
        self.time = 0.0
        self.stop_time = None
        return OK

    # ------------------------------------------------------------------ stepping
    def do_step(self, current_time: float, step_size: float) -> int:
        """fmiDoStep: OK, Error (bad arguments or inputs; state unchanged) or Discard (divergence, step too long;
        state unchanged)."""
        try:
            if self.state != STEP:
                return self._illegal("DoStep")
            h = step_size
            warned = False
            if not (0.0 < h < math.inf):  # False for NaN
                return self._error(f"{self._fn('DoStep')}: communication step size [s] must be finite and > 0, got "
                                   f"{h!r}")
            t = self.time
            if current_time != t and not abs(current_time - t) <= 1e-9 * max(1.0, abs(t)):
                return self._error(f"{self._fn('DoStep')}: currentCommunicationPoint = {current_time!r} s is not the "
                                   f"end of the previous step ({t!r} s)")
            if self._inputs_changed:  # check and apply the inputs only when the master set them
                ad = self.adapter
                values = self.values
                for name, lo, hi in ad.input_checks:
                    if not (lo <= values[name] <= hi):  # False for NaN
                        return self._error(f"{self._fn('DoStep')} at t = {t:g} s: "
                                           f"{ad.by_name[name].check(values[name])}; step refused, state unchanged")
                ad.apply_inputs(values)
                self._inputs_changed = False
                if self._watched and self._report_ignored_inputs("DoStep"):
                    warned = True
            if h > self._long_step_s:  # only then can the step need too many internal steps: ask exactly
                hi_ = self.adapter.internal_step()
                if h / hi_ > MAX_SUBSTEPS_PER_STEP:
                    self.log(DISCARD, f"{self._fn('DoStep')}: communication step {h:g} s needs {h / hi_:.3g} internal "
                                      f"steps of {hi_:.3g} s (limit {MAX_SUBSTEPS_PER_STEP:g}); use shorter steps")
                    self.state = STEP_FAILED
                    return DISCARD
            r = self._advance(h)
            if not r.success:
                self.log(DISCARD, f"{self._fn('DoStep')} at t = {t:g} s: {r.message}")
                self.state = STEP_FAILED
                return DISCARD
            self.time = current_time + h
            for mn in (self.adapter.out_of_range_meshes() if self._tables_adapter else ()):
                self.log(WARNING, f"{self._fn('DoStep')} at t = {self.time:g} s: mesh {mn} has left its tables' "
                                  "deflection range (torque or vibration beyond the statics grid): forces, pressures "
                                  f"and strains there are extrapolated (output {mn}.out_of_range = true); extend the "
                                  "tables: raise [statics] max_torque_factor and run `hacgear statics MODEL` (which "
                                  "also builds a missing coast side: without it a state past the backlash counts)")
            return WARNING if warned else OK
        except Exception as exc:
            return self._error(f"{self._fn('DoStep')} at t = {current_time!r} s failed: {type(exc).__name__}: {exc}")

    def _watch_ignored_inputs(self) -> None:
        """The inputs the configured experiment ignores and that were not reported yet (watched in every step)."""
        active = set(self.adapter.input_names()) if self._tables_adapter else set(self._ignorable)
        self._watched = tuple(n for n in self._ignorable if n not in active and n not in self._ignored_reported)

    def _report_ignored_inputs(self, call: str) -> bool:
        """Warn (once per input) of an input set to other than its start value that the chosen experiment ignores
        (a shaft torque at constant speed, the imposed speed in drivetrain mode); True when a warning was logged."""
        new = [n for n in self._watched if self.values[n] != self.start_values[n]]
        if not new:
            return False
        ad = self.adapter
        for n in new:
            self._ignored_reported.add(n)
            if int(self.values["mode"]) == Experiment.SPEED:
                why = (f"parameter mode = {int(Experiment.SPEED)} (constant speed: gear {ad.ref} turns at "
                       f"{ad.ref_ident}.speed_in and the torque set-point is parameter torque); for a drivetrain "
                       f"coupling set mode = {int(Experiment.TORQUE)} before initialization ends")
            else:
                why = (f"parameter mode = {int(Experiment.TORQUE)} (drivetrain coupling: the speeds are outputs, "
                       f"the start speed is parameter {ad.ref_ident}.speed_start)")
            unit = self.var[self.vrs[n]].unit
            self.log(WARNING, f"{self._fn(call)} at t = {self.time:g} s: input '{n}' = {self.values[n]!r} {unit} is "
                              f"ignored: {why} (reported once)")
        self._watch_ignored_inputs()
        return True

    def last_successful_time(self) -> float:
        """End of the last completed step [s] (FMI 2.0 ``fmi2LastSuccessfulTime``, FMI 3.0 ``doStep``)."""
        return self.time

    # ------------------------------------------------------------------ values
    def _outputs_ready(self, call: str) -> str:
        """In initialization mode the outputs follow from the parameters set so far."""
        if self.state != INITIALIZATION:
            return ""
        msg = self._configure()
        return f"{self._fn(call)}: outputs cannot be computed from the current parameters: {msg}" if msg else ""

    def get_real(self, vrs) -> list | None:
        """fmiGetReal/GetFloat64: the values of the Real variables ``vrs`` (a list of floats), or None (Error,
        logged).  In step mode a master's repeated request (the same value references every step) is answered by
        one function compiled for it (:meth:`_reader`)."""
        if self.state == STEP or self.state == TERMINATED:
            try:
                return self._readers[vrs]()
            except KeyError:
                try:
                    reader = self._reader(vrs)
                except Exception:
                    reader = None
                if reader is not None:
                    return reader()
            except Exception:
                pass
        return self.get_values("real", vrs)

    def _reader(self, vrs):
        """A function returning the values of the Real variables ``vrs`` (a tuple) as a list: the simulator's
        attributes read directly (:meth:`Adapter.output_expressions`), parameters and inputs from the stored
        values, other outputs through their getters.  None when a reference is not a Real variable."""
        if not isinstance(vrs, tuple) or len(self._readers) >= 64:
            return None
        exprs = self.adapter.output_expressions()
        items = []
        for vr in vrs:
            v = self.var.get(vr)
            if v is None or v.type != "Real":
                return None
            if v is TIME:
                items.append("inst.time")
            elif v.causality in CALCULATED:
                items.append(exprs.get(v.name) or f"get[{vr!r}]()")
            else:
                items.append(f"values[{v.name!r}]")
        src = f"def read():\n    s = ad.sim\n    return [{', '.join(items)}]\n"
        ns = {"ad": self.adapter, "get": self._get, "values": self.values, "inst": self}
        exec(compile(src, "<hacgear getReal>", "exec"), ns)
        self._readers[vrs] = ns["read"]
        return ns["read"]

    def get_values(self, kind: str, vrs) -> list | None:
        """Values of ``vrs`` through the access family ``kind`` (``real``, ``integer``, ``int64``, ``boolean``,
        ``string``), or None (Error, logged)."""
        call = {"real": "GetReal" if self.fmi_version < 3 else "GetFloat64"}.get(kind, f"Get{kind.capitalize()}")
        if len(vrs) == 0:  # no values asked: nothing to refuse, in any state (as the native binary answers)
            return []
        try:
            if self.state not in _GET_STATES:
                self._illegal(call)
                return None
            types = self.kinds.get(kind, frozenset())
            for vr in vrs:
                v = self.var.get(vr)
                if v is None or v.type not in types:
                    what = "no variable" if v is None else f"'{v.name}' ({v.type})"
                    self._error(f"{self._fn(call)}: value reference {vr!r} is {what}, not a variable of this call's "
                                "type")
                    return None
            if any(self.var[vr].causality in CALCULATED for vr in vrs):
                msg = self._outputs_ready(call)
                if msg:
                    self._error(msg)
                    return None
            conv = {"real": float, "integer": int, "int64": int, "boolean": bool}.get(kind, str)
            before = self.state
            out = [conv(self._get[vr]()) for vr in vrs]
            if self.state == FAILED and before != FAILED:  # an output could not be computed (logged)
                return None
            return out
        except Exception as exc:
            self._error(f"{self._fn(call)}: {type(exc).__name__}: {exc}")
            return None

    def set_real(self, vrs, values) -> int:
        """fmiSetReal/SetFloat64 (fast path for inputs in step mode)."""
        if self.state == STEP:
            ok = self._real_set_step
            vals = self.values
            var = self.var
            try:
                if all(vr in ok for vr in vrs):
                    for vr, x in zip(vrs, values):
                        vals[var[vr].name] = float(x)
                    self._inputs_changed = True
                    return OK
            except Exception:
                pass
        return self.set_values("real", vrs, values)

    def set_values(self, kind: str, vrs, values) -> int:
        """Store the values of parameters and inputs (checked when initialization ends and in every step)."""
        call = {"real": "SetReal" if self.fmi_version < 3 else "SetFloat64"}.get(kind, f"Set{kind.capitalize()}")
        if len(vrs) == 0 and len(values) == 0:  # nothing to set: OK in any state (as the native binary answers)
            return OK
        try:
            if self.state not in _SET_STATES:
                return self._illegal(call)
            vrs, values = list(vrs), list(values)
            if len(vrs) != len(values):
                return self._error(f"{self._fn(call)}: {len(vrs)} value references but {len(values)} values")
            types = self.kinds.get(kind, frozenset())
            conv = {"real": float, "integer": int, "int64": int, "boolean": bool}.get(kind, str)
            new = []
            for vr, x in zip(vrs, values):
                v = self.var.get(vr)
                if v is None or v.type not in types:
                    what = "no variable" if v is None else f"'{v.name}' ({v.type})"
                    return self._error(f"{self._fn(call)}: value reference {vr!r} is {what}, not a variable of this "
                                       "call's type")
                if v.causality in ("output", "calculatedParameter", "independent"):
                    return self._error(f"{self._fn(call)}: '{v.name}' is {v.causality} (calculated by the FMU); it "
                                       "cannot be set")
                if self.state == STEP and v.causality != "input":
                    return self._error(f"{self._fn(call)}: '{v.name}' is a fixed parameter; it can only be set before "
                                       "initialization ends")
                new.append((v.name, conv(x)))
            self.values.update(new)
            self._inputs_changed = True
            return OK
        except Exception as exc:
            return self._error(f"{self._fn(call)}: {type(exc).__name__}: {exc}")

    # ------------------------------------------------------------------ FMU states
    def get_state(self):
        """fmiGetFMUstate: a snapshot (an opaque Python object for the binary), or None (Error)."""
        try:
            if self.state not in _STATE_STATES:
                self._illegal("GetFMUstate")
                return None
            snap = {"guid": self.info["guid"], "state": self.state, "time": self.time, "stop_time": self.stop_time,
                    "values": dict(self.values), "adapter": None}
            if self._configured_key is not None and self.state != INSTANTIATED:
                snap["adapter"] = self.adapter.get_state()
            return snap
        except Exception as exc:
            self._error(f"{self._fn('GetFMUstate')}: {type(exc).__name__}: {exc}")
            return None

    def set_state(self, snap) -> int:
        """fmiSetFMUstate: restore a snapshot of :meth:`get_state` of this FMU."""
        try:
            if not isinstance(snap, dict) or snap.get("guid") != self.info["guid"]:
                return self._error(f"{self._fn('SetFMUstate')}: not a state of this FMU")
            self.values.clear()
            self.values.update(snap["values"])
            # the simulator's state where it has one (a state taken while the parameters were invalid, in
            # initialization or after an Error there, restores the values only)
            if snap["adapter"] is not None and not self._configure(parameters_only=True):
                self.adapter.set_state(snap["adapter"])
            self._inputs_changed = True
            self.state, self.time, self.stop_time = snap["state"], snap["time"], snap["stop_time"]
            self._watched = ()
            if self.state in (STEP, STEP_FAILED, TERMINATED) and self._configured_key is not None:
                self._watch_ignored_inputs()
            return OK
        except Exception as exc:
            return self._error(f"{self._fn('SetFMUstate')}: {type(exc).__name__}: {exc}")

    def _issue_state(self, snap, address: int) -> None:
        """The binary hands ``snap`` to the master as the pointer ``address``."""
        self._issued[address] = snap

    def _known_state(self, address: int) -> bool:
        """Whether ``address`` is an FMU state this instance handed out and that was not freed."""
        return address in self._issued

    def _forget_state(self, address: int) -> None:
        self._issued.pop(address, None)

    def serialize_state(self, snap) -> bytes | None:
        """Bytes of a snapshot (JSON; floats written with repr, so they read back bit for bit)."""
        try:
            return _STATE_MAGIC + json.dumps(_to_json(snap), allow_nan=True).encode()
        except Exception as exc:
            self._error(f"{self._fn('SerializeFMUstate')}: {type(exc).__name__}: {exc}")
            return None

    def deserialize_state(self, data: bytes):
        """A snapshot from :meth:`serialize_state` bytes, or None (Error)."""
        try:
            data = bytes(data)
            if not data.startswith(_STATE_MAGIC):
                self._error(f"{self._fn('DeSerializeFMUstate')}: not a serialized hacgear FMU state")
                return None
            snap = _from_json(json.loads(data[len(_STATE_MAGIC):].decode()))
            if not isinstance(snap, dict) or snap.get("guid") != self.info["guid"]:
                self._error(f"{self._fn('DeSerializeFMUstate')}: a state of another FMU")
                return None
            return snap
        except Exception as exc:
            self._error(f"{self._fn('DeSerializeFMUstate')}: {type(exc).__name__}: {exc}")
            return None


def _to_json(x):
    """JSON-able form of a snapshot: numpy arrays and tuples tagged, floats kept exact."""
    import numpy as np

    if isinstance(x, dict):
        return {"__dict__": [[_to_json(k), _to_json(v)] for k, v in x.items()]}
    if isinstance(x, np.ndarray):
        return {"__array__": x.tolist(), "dtype": str(x.dtype), "shape": list(x.shape)}
    if isinstance(x, tuple):
        return {"__tuple__": [_to_json(v) for v in x]}
    if isinstance(x, list):
        return [_to_json(v) for v in x]
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    return x


def _from_json(x):
    import numpy as np

    if isinstance(x, dict):
        if "__dict__" in x:
            return {_from_json(k): _from_json(v) for k, v in x["__dict__"]}
        if "__array__" in x:
            return np.array(x["__array__"], dtype=x["dtype"]).reshape(x["shape"])
        if "__tuple__" in x:
            return tuple(_from_json(v) for v in x["__tuple__"])
        raise ValueError("unknown tagged object in a serialized state")
    if isinstance(x, list):
        return [_from_json(v) for v in x]
    return x
