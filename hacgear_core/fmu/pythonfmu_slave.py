"""The slave class of the pythonfmu backend: a thin ``Fmi2Slave`` (pythonfmu) or ``Fmi3Slave`` (pythonfmu3)
subclass over the one FMU instance every hacgear FMU runs (:class:`hacgear_core.fmu.slave.FmuInstance`).

:mod:`hacgear_core.fmu.pythonfmu_backend` copies this file into each FMU as ``resources/<module>.py`` under a
module name unique to the FMU (``hacgear_pyfmu<version>_<digest>``); for FMI 3.0 it rewrites the lines marked
``# FMI base`` to pythonfmu3's ``Fmi3Slave``.  The file needs only the standard library and pythonfmu (which the
builder bundles into the FMU); at instantiation it runs the FMU's loader (``resources/hacgear_fmu_boot.py``),
which checks the importer's packages and imports the bundled hacgear code.

Statuses.  pythonfmu's wrappers turn a Python exception into Fatal (pythonfmu 0.7.0 also releases the slave twice
then), and let Python choose a status only in ``do_step``: pythonfmu (FMI 2.0) ``True`` -> OK, ``False`` ->
Discard (and ``fmi2Terminated`` true); pythonfmu3 returns the ``status`` of a :class:`Fmi3StepResult`.  So no
method here raises (except a failed instantiation, where the wrapper returns NULL): every other call answers OK,
the instance's Error is logged and the instance enters its error state, and the next ``do_step`` reports it
(FMI 2.0: Discard, FMI 3.0: Error).  Getters refused by the instance return NaN / 0 / false.  docs/fmu.md,
"The pythonfmu backend", has the table.

Start time.  pythonfmu3 0.3.4 passes no start time to Python (its ``fmi3EnterInitializationMode`` drops it), so
under FMI 3.0 the first ``do_step`` after initialization takes its communication point as the start time.

Masters that are not Python programs.  pythonfmu's binaries link no libpython (the master preloads it) and start
Python without telling it its home: it looks for its standard library from a program name (pythonfmu 0.7.0: the
first ``python3`` on PATH; pythonfmu3 0.3.4: ``./PythonFMU`` in the master's working folder), each folder above
it, then the prefix compiled into libpython.  Where that finds another installation's library (Debian's
``/usr/lib/python3.11`` under a preloaded pyenv or conda libpython), the imports below fail (``_struct``,
``_ctypes``); the slave then says which installation the preloaded libpython belongs to and what to set
(:data:`MASTER_ENV_SCRIPT`).  docs/fmu.md, "pythonfmu FMUs in masters that are not Python programs", has the
measured environment.
"""
import os
import sys

#: Python code printing, for the interpreter that runs it, the environment a master that is not a Python program
#: needs for a pythonfmu FMU (``env $(python3 -c "$MASTER_ENV_SCRIPT") ./master ...``): LD_PRELOAD (its libpython),
#: PYTHONHOME (its installation: standard library and extension modules) and PYTHONPATH (its site-packages, which
#: a virtual environment keeps outside PYTHONHOME).  Paths with spaces need quoting by hand.  No '%' in it: the
#: FMI 2.0 wrapper hands a failed import's message to the master's printf-like logger as the format.
MASTER_ENV_SCRIPT = ('import os,site,sys,sysconfig as c;v=c.get_config_var;p,e=sys.base_prefix,sys.base_exec_prefix;'
                     'print("LD_PRELOAD="+os.path.join(v("LIBDIR"),v("INSTSONAME")),"PYTHONHOME="+(p if p==e else '
                     'p+":"+e),"PYTHONPATH="+os.pathsep.join(site.getsitepackages()))')


def _loaded_libpython():
    """Path of the libpython of this Python's version mapped into this process ('' where none is: a Python program
    linked statically, or not Linux)."""
    name = f"libpython{sys.version_info[0]}.{sys.version_info[1]}"
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            for line in maps:
                fields = line.split(None, 5)
                if len(fields) == 6 and os.path.basename(fields[5].strip()).startswith(name):
                    return fields[5].strip()
    except OSError:
        pass
    return ""


def master_hint():
    """'' in a Python program; where the FMU binary started this Python (a master that is not a Python program):
    which installation its libpython belongs to, whether the standard library found is that installation's, and the
    environment to set."""
    if sys.argv not in ([], [""]) or hasattr(sys, "ps1"):  # a Python program or an interactive session hosts us
        return ""
    lib = _loaded_libpython()
    ver = f"python{sys.version_info[0]}.{sys.version_info[1]}"
    home = os.path.dirname(os.path.dirname(lib)) if lib else ""
    stdlib = os.path.join(os.path.dirname(lib), ver) if lib else ""
    if not (stdlib and os.path.isfile(os.path.join(stdlib, "os.py"))):
        home, stdlib = "", ""  # not a <prefix>/lib/libpython + <prefix>/lib/pythonX.Y layout: no home to name
    on_path = {os.path.realpath(p) for p in sys.path if p}
    found = f"standard library {os.path.join(sys.base_prefix, 'lib', ver)!r}"
    if stdlib and os.path.realpath(stdlib) not in on_path:
        what = (f"it found the {found} (from {sys.executable!r}), not that of the libpython in this process ({lib}): "
                f"set PYTHONHOME={home}")
    else:
        what = (f"it runs as {sys.executable!r} with the {found} and the libpython {lib or '(none found)'}; "
                f"set PYTHONHOME{'=' + home if home else ''} and PYTHONPATH to the site-packages holding numpy, "
                "scipy, h5py and numba")
    return (f"this Python was started by the FMU binary (pythonfmu's binaries start it without a home, in a master "
            f"that is not a Python program): {what}; start the master with the LD_PRELOAD, PYTHONHOME and "
            f"PYTHONPATH that `python3 -c '{MASTER_ENV_SCRIPT}'` prints for the Python with those packages")


FMI_VERSION = 2  # FMI base
#: why the imports below failed ('' where they did not); under pythonfmu3 the slave's constructor raises it
_IMPORT_ERROR = ""
try:
    import atexit
    import ctypes
    import importlib.util
    import json
    import math
    from collections import namedtuple
    from pathlib import Path

    from pythonfmu import Fmi2Slave  # FMI base
except ImportError as _exc:  # the wrappers log this only with debug logging on: stderr too
    _hint = master_hint()
    _IMPORT_ERROR = f"{_exc}; {_hint}" if _hint else str(_exc)
    print(f"hacgear FMU: {type(_exc).__name__}: {_IMPORT_ERROR}", file=sys.stderr)
    if FMI_VERSION < 3:  # pythonfmu 0.7.0 returns NULL from a failed import of this module
        raise ImportError(_IMPORT_ERROR) from None
    # pythonfmu3 0.3.4 prints and clears a failed import's exception, then reads it: the master dies (SIGSEGV).  An
    # exception from the slave's constructor it turns into a NULL instance: the module imports, the constructor
    # raises.
    Fmi2Slave = object  # FMI base

if not _IMPORT_ERROR:
    # pythonfmu 0.7.0's C wrapper (findClass) executes this file's source in the module's __dict__ at every
    # instantiation and then Py_DECREFs that dict although it only borrowed it.  Each execution of this line adds
    # the reference the wrapper takes away (without it: a freed module dict, a failed second instantiation or an
    # abort).
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(globals()))

INFO_FILE = "hacgear_fmu.json"
BOOT_FILE = "hacgear_fmu_boot.py"
OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
#: what pythonfmu3's wrapper reads from ``do_step``'s result (its ``Fmi3StepResult`` has the same fields)
StepResult = None if _IMPORT_ERROR else namedtuple("StepResult", ["status", "terminateSimulation"])

#: pythonfmu binaries of this process (path -> ctypes handle) released at exit by :func:`_release_binaries`: the
#: one process-wide registry this module keeps (a binary is loaded once per process).
_BINARIES = {}


def _release_binaries():
    for handle in list(_BINARIES.values()):
        try:
            handle.finalizePythonInterpreter()
        except Exception:  # pragma: no cover - nothing sensible to do at exit
            pass


def _guard_exit(resources):
    """Work around a use-after-free at process exit in pythonfmu's binaries (measured with valgrind on 0.7.0):
    at exit the C++ destructor of the binary's global ``shared_ptr<PyState>`` runs first, then its
    ``__attribute__((destructor))`` resets that destroyed pointer (heap corruption; importers aborted in 10-50 %
    of runs).  Calling the exported ``finalizePythonInterpreter()`` from a Python ``atexit`` handler, while the
    pointer is alive, empties it first.  A handle is kept on each binary so that it stays mapped."""
    for lib in sorted((Path(resources).parent / "binaries").glob("*/*.so")):
        key = str(lib)
        if key in _BINARIES:
            continue
        try:
            handle = ctypes.CDLL(key)
            fn = handle.finalizePythonInterpreter
        except (OSError, AttributeError):  # another platform's binary
            continue
        fn.restype = None
        fn.argtypes = []
        if not _BINARIES:
            atexit.register(_release_binaries)
        _BINARIES[key] = handle


def _instance(resources, instance_name, fmi_version):
    """The FMU instance, created by the FMU's loader (raises with a message naming what is missing)."""
    res = Path(resources)
    info = json.loads((res / INFO_FILE).read_text(encoding="utf-8"))
    spec = importlib.util.spec_from_file_location(f"{__name__}_boot", res / BOOT_FILE)
    boot = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(boot)
    inst = boot.instantiate(instance_name, str(res), info["guid"], True, fmi_version)
    return info, inst


class _State:
    """An FMU state handed to the wrapper: a snapshot of the instance, or serialized bytes (from
    ``_fmu_state_from_bytes``, read back by the instance in ``_set_fmu_state``)."""

    __slots__ = ("snap", "data", "inst")

    def __init__(self, snap=None, data=None, inst=None):
        self.snap, self.data, self.inst = snap, data, inst


class HacgearSlave(Fmi2Slave):  # FMI base
    """A hacgear FMU under pythonfmu: every call forwarded to :class:`FmuInstance`, its messages to the wrapper's
    log queue, its statuses mapped onto those the wrapper allows (module docstring)."""

    author = "hacgear"

    def __init__(self, **kwargs):
        if _IMPORT_ERROR:  # pythonfmu3: the module's imports failed (said on stderr); the wrapper returns NULL
            raise ImportError(_IMPORT_ERROR)
        super().__init__(**kwargs)
        try:
            _guard_exit(self.resources)
            info, self._inst = _instance(self.resources, self.instance_name, FMI_VERSION)
        except Exception as exc:  # the wrapper returns NULL: say why on stderr too (its log needs debug logging)
            hint = master_hint()
            print(f"hacgear FMU: instantiation failed: {type(exc).__name__}: {exc}" + (f"; {hint}" if hint else ""),
                  file=sys.stderr)
            raise
        self.modelName = info["system"]
        self.description = info.get("description")
        self.version = info.get("hacgear_version")
        self._start_at_first_step = False
        # The instantiation's messages stay in self._inst.messages until the next call flushes them: pythonfmu
        # 0.7.0's fmi2Instantiate leaves the wrapper's log queue as it is, and its fmi2FreeInstance destroys the
        # FMU's logger before the slave, whose destructor hands what is still queued to the freed logger (SIGSEGV
        # when a master frees an instance it never called: libcosim releasing an execution that never stepped,
        # fmpy's instantiate() + freeInstance()).

    # ------------------------------------------------------------------ messages and statuses
    def _flush(self):
        """Pass the instance's queued messages to the wrapper's log queue (FMI 3.0: warnings and errors always,
        debug messages only with debug logging on; pythonfmu 0.7.0 forwards any only with debug logging on).
        The FMI 2.0 text keeps its doubled '%' (the master's logger is printf-like)."""
        msgs = self._inst.messages
        while msgs:
            status, category, text = msgs.pop(0)
            if FMI_VERSION >= 3:
                self.log(text, status, category, status == OK)
            else:
                self.log(text, status, category)

    def _call(self, method, *args, fill=None):
        """``method(*args)`` of the instance, its messages flushed; an unexpected exception is logged as an Error
        of the instance (never raised into the wrapper) and gives ``fill``."""
        try:
            return method(*args)
        except Exception as exc:  # pragma: no cover - the instance catches its own errors
            self._inst._error(f"{type(exc).__name__}: {exc}")
            return fill
        finally:
            try:
                self._flush()
            except Exception:  # pragma: no cover
                pass

    # ------------------------------------------------------------------ life cycle
    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._call(self._inst.setup_experiment, start_time, stop_time, tolerance)

    def enter_initialization_mode(self):
        self._call(self._inst.enter_initialization_mode)

    def exit_initialization_mode(self):
        status = self._call(self._inst.exit_initialization_mode, fill=ERROR)
        # pythonfmu3 0.3.4's fmi3EnterInitializationMode drops startTime (the instance would stay at t = 0 and
        # refuse the first doStep at any other time): the first doStep's communication point is the start time.
        self._start_at_first_step = FMI_VERSION >= 3 and status == OK

    def terminate(self):
        self._call(self._inst.terminate)

    def do_step(self, current_time, step_size):
        if self._start_at_first_step:
            self._start_at_first_step = False
            if math.isfinite(current_time):
                self._inst.time = float(current_time)
        status = self._call(self._inst.do_step, current_time, step_size, fill=ERROR)
        if FMI_VERSION >= 3:
            return StepResult(status, False)
        return status == OK  # Error and Discard: Discard (fmi2Terminated true), the reason logged

    # ------------------------------------------------------------------ values (lists of the requested length)
    def _get(self, vtype, vrs, fill):
        if vtype == "real":
            out = self._call(self._inst.get_real, tuple(vrs))
        else:
            out = self._call(self._inst.get_values, vtype, list(vrs))
        return [fill] * len(vrs) if out is None else list(out)

    def _set(self, vtype, vrs, values):
        if vtype == "real":
            self._call(self._inst.set_real, list(vrs), list(values))
        else:
            self._call(self._inst.set_values, vtype, list(vrs), list(values))

    def get_real(self, vrs):
        return self._get("real", vrs, math.nan)

    get_float64 = get_real

    def get_integer(self, vrs):
        return self._get("integer", vrs, 0)

    get_int32 = get_integer

    def get_int64(self, vrs):
        return self._get("int64", vrs, 0)

    def get_uint64(self, vrs):
        return self._get("uint64", vrs, 0)

    def get_boolean(self, vrs):
        return self._get("boolean", vrs, False)

    def get_string(self, vrs):
        return self._get("string", vrs, "")

    def set_real(self, vrs, values):
        self._set("real", vrs, values)

    set_float64 = set_real

    def set_integer(self, vrs, values):
        self._set("integer", vrs, values)

    set_int32 = set_integer

    def set_int64(self, vrs, values):
        self._set("int64", vrs, values)

    def set_uint64(self, vrs, values):
        self._set("uint64", vrs, values)

    def set_boolean(self, vrs, values):
        self._set("boolean", vrs, values)

    def set_string(self, vrs, values):
        self._set("string", vrs, values)

    # ------------------------------------------------------------------ FMU states
    def _get_fmu_state(self):
        return _State(snap=self._call(self._inst.get_state), inst=self._inst)

    def _set_fmu_state(self, state):
        self._start_at_first_step = False  # the state carries its time
        self._call(self._restore, state)

    def _restore(self, state):
        inst = self._inst
        if isinstance(state, _State) and state.data is not None:
            snap = inst.deserialize_state(state.data)
            if snap is None:  # logged, error state
                return
        else:
            snap = state.snap if isinstance(state, _State) else None
        inst.set_state(snap)

    @staticmethod
    def _fmu_state_to_bytes(state):
        """Bytes of an FMU state (b"" for anything else: an error the instance logged)."""
        try:
            if state.data is not None:
                return bytes(state.data)
            data = state.inst.serialize_state(state.snap)
            return b"" if data is None else bytes(data)
        except Exception:
            return b""

    @staticmethod
    def _fmu_state_from_bytes(data):
        return _State(data=bytes(data))
