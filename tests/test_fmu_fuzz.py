"""Fuzzing the FMUs through fmpy's low-level API (hypothesis): random sequences of FMI calls (in and out of
order) with random values (NaN, inf, huge, negative, out of range; bad step sizes and communication points;
foreign FMU-state pointers and random state bytes) against a reference model of the FMI state machine and of
the FMU's documented statuses (hacgear_core.fmu.slave).  Every call's status must be the model's; the importer
(this process) must never crash; outputs returned with status OK in step mode must be finite.

The default suite runs >= 500 call sequences (FMI 2.0 and 3.0) with a fixed seed on each backend (native and
pythonfmu; the pythonfmu FMUs answer through the statuses their wrappers allow, :meth:`Driver.wrapper_status`);
``pytest -m slow`` runs thousands more with random seeds.  Each test prints how many sequences and calls it ran.
"""
from __future__ import annotations

import ctypes
import math
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
hyp = pytest.importorskip("hypothesis")
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402
from fmpy.fmi3 import FMU3Slave  # noqa: E402
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from hacgear_core.fmu import build_fmu, make_adapter  # noqa: E402
from hacgear_core.fmu.slave import DISCARD, ERROR, OK  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = "spur_28t_asym"

# ---------------------------------------------------------------------------------------------- values
NASTY = [math.nan, math.inf, -math.inf, 1e300, -1e300, 5e-324, -0.0, 1e7, -1e7]
#: per settable variable: values drawn by the fuzzer (valid ones first, then nasty ones)
VALUES = {
    "torque": [None, 500.0, 0.0, -1.0, 1e-4] + NASTY,
    "modal_damping_ratio": [None, 0.99, 1.5, -0.1] + NASTY,
    "internal_step": [None, 1e-6, 1e-2, -1e-6] + NASTY,
    "pinion.bearing_stiffness": [None, -5.0, 2e15] + NASTY,
    "wheel.bearing_stiffness": [None, -5.0] + NASTY,
    "pinion.speed_start": [None, 300.0, -300.0, 3e4] + NASTY,
    "pinion.speed_in": [None, 300.0, -700.0, 2e4, 0.0, 3e4] + NASTY,
    "pinion.torque_in": [None, 400.0, -1e8, 2e8] + NASTY,
    "wheel.torque_in": [None, -400.0, 1e8, -2e8] + NASTY,
}
MODES = [0, 1, 2, -1, 7, 2**31 - 1]
#: outputs compared after every successful initialization (the reference model's initial states)
INITIAL_OUTPUTS = ("m12.force", "m12.deflection", "m12.dte", "pinion.speed", "wheel.angle")
STEPS = [1e-5, 1e-4, 1e-3, 0.0, -1e-4, math.nan, math.inf, 1e300]
OFFSETS = [0.0, 0.0, 0.0, 1e-3, -1e-3, math.nan]


# ---------------------------------------------------------------------------------------------- the reference model
@dataclass
class Model:
    """What the FMU must answer (FMI 2.0.4/3.0 state machine and hacgear_core.fmu.slave's rules)."""

    spec: dict
    start: dict
    state: str = "instantiated"
    time: float = 0.0
    values: dict = field(default_factory=dict)
    #: pythonfmu FMI 3.0: the next doStep's communication point becomes the start time (pythonfmu3 passes none)
    start_pending: bool = False
    #: outputs right after a successful initialization, by the parameters and inputs it had (kept across resets
    #: and sequences: an initialization with the same values must give the same initial state, bit for bit)
    initial: dict = field(default_factory=dict)

    def key(self) -> tuple:
        return tuple(sorted((k, float(v)) for k, v in self.values.items()))

    def reset(self):
        self.state, self.time, self.values = "instantiated", 0.0, dict(self.start)
        self.start_pending = False

    def snapshot(self):
        return (self.state, self.time, dict(self.values))

    def restore(self, snap):
        self.state, self.time, self.values = snap[0], snap[1], dict(snap[2])
        self.start_pending = False

    def fail(self):
        self.state = "error"
        return ERROR

    def params_ok(self) -> bool:
        if any(v.check(self.values[n]) for n, v in self.spec.items() if v.causality == "parameter"):
            return False
        if any(self.values[n] == 0 for n in ("pinion.bearing_stiffness", "wheel.bearing_stiffness")):
            return False  # 0 = no bearing (inf = rigid): the builder refuses it for a spur pair
        inputs = ["pinion.speed_in"] if self.values["mode"] == 0 else ["pinion.torque_in", "wheel.torque_in"]
        return not any(self.spec[n].check(self.values[n]) for n in inputs)

    def inputs_ok(self) -> bool:
        inputs = ["pinion.speed_in"] if self.values["mode"] == 0 else ["pinion.torque_in", "wheel.torque_in"]
        return not any(self.spec[n].check(self.values[n]) for n in inputs)


# ---------------------------------------------------------------------------------------------- drivers
def _status(call, *args):
    try:
        out = call(*args)
        return OK, out
    except FMICallException as exc:
        return exc.status, None


class Driver:
    """One FMU instance under fmpy's low-level API (FMI 2.0 or 3.0), calls returning (status, value)."""

    def __init__(self, path: Path):
        self.md = read_model_description(str(path))
        self.v3 = self.md.fmiVersion.startswith("3")
        self.dir = extract(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.backend = "pythonfmu" if (Path(self.dir) / "resources" / "slavemodule.txt").exists() else "native"
        self.messages = 0
        kw = dict(guid=self.md.guid, unzipDirectory=self.dir, modelIdentifier=self.md.coSimulation.modelIdentifier,
                  instanceName="fuzz")
        if self.v3:
            def log3(env, st_, cat, msg):
                self.messages += 1

            self.fmu = FMU3Slave(**kw)
            self.fmu.instantiate(loggingOn=False, logMessage=log3)
        else:
            from fmpy.fmi2 import (calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                                   fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free)

            def log2(c, inst, st_, cat, msg):
                self.messages += 1

            cb = fmi2CallbackFunctions()
            cb.logger = fmi2CallbackLoggerTYPE(log2)
            cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            self._cb = cb
            self.fmu = FMU2Slave(**kw)
            self.fmu.instantiate(loggingOn=False, callbacks=cb)
        f = self.fmu
        self.set_real = f.setFloat64 if self.v3 else f.setReal
        self.get_real = f.getFloat64 if self.v3 else f.getReal
        self.set_int = f.setInt32 if self.v3 else f.setInteger
        self.get_enum = f.getInt64 if self.v3 else f.getInteger
        self.get_state = f.getFMUState if self.v3 else f.getFMUstate
        self.set_state = f.setFMUState if self.v3 else f.setFMUstate
        self.free_state = f.freeFMUState if self.v3 else f.freeFMUstate
        self.serialize = f.serializeFMUState if self.v3 else f.serializeFMUstate
        self.deserialize = f.deserializeFMUState if self.v3 else f.deSerializeFMUstate

    def wrapper_status(self, what: str, want: int) -> int:
        """The status the FMU answers where the reference model says ``want`` (docs/fmu.md): the native binary
        returns it as it is; pythonfmu's wrappers let Python choose a status only in doStep, so every other call
        answers OK (the Error logged, the instance in its error state) and doStep answers Error as Discard (FMI
        2.0) or Error (FMI 3.0)."""
        if self.backend == "native" or want == OK:
            return want
        if what.startswith("doStep"):
            return want if (want == DISCARD or self.v3) else DISCARD
        return OK

    def enter(self, t0):
        if self.v3:
            return _status(self.fmu.enterInitializationMode, None, t0, None)[0]
        s = _status(self.fmu.setupExperiment, None, t0, None)[0]
        if s != OK:
            return s
        return _status(self.fmu.enterInitializationMode)[0]

    def close(self):
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


# ---------------------------------------------------------------------------------------------- operations
#: a value index: mostly the start value, often a valid other one, else anything
_pick = st.one_of(st.just(0), st.just(0), st.just(1), st.integers(0, 100))
ops = st.one_of(
    st.tuples(st.just("set"), st.sampled_from(sorted(VALUES)), _pick),
    st.tuples(st.just("set_mode"), st.sampled_from(MODES)),
    st.tuples(st.just("set_output"), st.sampled_from(["m12.force", "pinion.speed"])),
    st.tuples(st.just("set_wrong_type")),
    st.tuples(st.just("enter"), st.sampled_from([0.0, 0.0, 1.5, math.nan, math.inf])),
    st.tuples(st.just("exit")),
    st.tuples(st.just("step"), st.sampled_from(STEPS), st.sampled_from(OFFSETS), st.integers(1, 3)),
    st.tuples(st.just("get"), st.lists(st.sampled_from(["m12.force", "m12.dte", "pinion.speed", "torque",
                                                        "pinion.speed_in", "m12.peak_pressure",
                                                        "wheel.SG25.root_strain", "unknown", "mode"]),
                                       max_size=4)),
    st.tuples(st.just("get_contact")),
    st.tuples(st.just("terminate")),
    st.tuples(st.just("reset")),
    st.tuples(st.just("save")),
    st.tuples(st.just("restore")),
    st.tuples(st.just("restore_bytes")),
    st.tuples(st.just("foreign_state"), st.integers(1, 2**40)),
    st.tuples(st.just("random_bytes"), st.binary(max_size=64)),
)
_valid_set = st.tuples(st.just("set"), st.sampled_from(sorted(VALUES)), st.sampled_from([0, 0, 0, 1]))
#: most sequences initialize first (with mostly valid parameters), then go anywhere
sequences = st.one_of(
    st.lists(ops, min_size=1, max_size=30),
    st.tuples(st.lists(_valid_set, max_size=3), st.sampled_from([0, 1]), st.lists(_valid_set, max_size=2),
              st.lists(ops, min_size=1, max_size=25)).map(
        lambda p: p[0] + [("set_mode", p[1]), ("enter", 0.0)] + p[2] + [("exit",)] + p[3]),
    st.tuples(st.lists(_valid_set, max_size=2), st.lists(ops, min_size=1, max_size=25)).map(
        lambda p: p[0] + [("enter", 0.0), ("exit",), ("step", 1e-4, 0.0, 2)] + p[1]),
    st.tuples(st.booleans(), st.lists(ops, max_size=10)).map(
        lambda p: [("enter", 0.0), ("exit",), ("step", 1e-4, 0.0, 1)] + [("step", 1e300, 0.0, 1)] * p[0]
        + [("terminate",)] + p[1]),
)


@dataclass
class Counter:
    sequences: int = 0
    calls: int = 0
    statuses: dict = field(default_factory=dict)  # (operation, status) -> count


def run_sequence(drv: Driver, model: Model, seq, counter: Counter) -> None:
    """Play ``seq`` on the FMU and the model; assert equal statuses."""
    vr = drv.vr
    saved = []  # (fmu state pointer, serialized bytes, model snapshot)

    def expect(got, want, what):
        want = drv.wrapper_status(what, want)
        assert got == want, f"{what}: status {got}, expected {want} (model state {model.state!r})"
        key = (what.split()[0], got)
        counter.statuses[key] = counter.statuses.get(key, 0) + 1

    st_, _ = _status(drv.fmu.reset)
    expect(st_, OK, "reset")
    model.reset()
    for op in seq:
        counter.calls += 1
        kind = op[0]
        if kind == "set":
            name, pick = op[1], op[2]
            vals = VALUES[name]
            v = vals[pick % len(vals)]
            v = model.spec[name].start if v is None else v
            got = _status(drv.set_real, [vr[name]], [v])[0]
            spec = model.spec[name]
            if model.state not in ("instantiated", "initialization", "step"):
                want = model.fail()
            elif model.state == "step" and spec.causality != "input":
                want = model.fail()
            else:
                model.values[name] = float(v)
                want = OK
            expect(got, want, f"set {name} = {v!r}")
        elif kind == "set_mode":
            got = _status(drv.set_int, [vr["mode"]], [op[1]])[0]
            if model.state not in ("instantiated", "initialization"):
                want = model.fail()
            else:
                model.values["mode"] = op[1]
                want = OK
            expect(got, want, f"set mode = {op[1]}")
        elif kind == "set_output":
            got = _status(drv.set_real, [vr[op[1]]], [1.0])[0]
            expect(got, model.fail(), f"set output {op[1]}")
        elif kind == "set_wrong_type":
            got = _status(drv.set_real, [vr["mode"]], [1.0])[0]  # an Integer through the Real setter
            expect(got, model.fail(), "setReal of an Integer")
        elif kind == "enter":
            t0 = op[1]
            got = drv.enter(t0)
            if drv.backend == "pythonfmu" and drv.v3 and model.state == "instantiated":
                model.state, model.time, want = "initialization", 0.0, OK  # pythonfmu3 passes no start time
            elif model.state != "instantiated" or not math.isfinite(t0):
                want = model.fail()
            else:
                model.state, model.time, want = "initialization", t0, OK
            expect(got, want, f"enter initialization at {t0!r}")
        elif kind == "exit":
            got = _status(drv.fmu.exitInitializationMode)[0]
            if model.state != "initialization" or not model.params_ok():
                want = model.fail()
            else:
                model.state, want = "step", OK
                model.start_pending = drv.backend == "pythonfmu" and drv.v3
            expect(got, want, "exit initialization")
            if want == OK:  # the initial state depends on the parameters and inputs only (not on earlier runs)
                got, vals = _status(drv.get_real, [vr[n] for n in INITIAL_OUTPUTS])
                expect(got, OK, "getReal after initialization")
                prev = model.initial.setdefault(model.key(), vals)
                assert np.array_equal(vals, prev, equal_nan=True), (
                    f"initialized with values it had before, the FMU starts from {vals}, not from {prev} "
                    "(a reset did not reset?)")
                counter.statuses[("initial state", "repeated")] = counter.statuses.get(
                    ("initial state", "repeated"), 0) + (prev is not vals)
        elif kind == "step":
            h, off, repeat = op[1], op[2], op[3]
            for _ in range(repeat):
                t, o = model.time + off, off
                if model.start_pending:  # pythonfmu FMI 3.0: the first doStep's communication point is the start
                    model.start_pending = False
                    if math.isfinite(t):
                        model.time, o = t, 0.0
                if drv.v3:
                    got = _status(drv.fmu.doStep, t, h)[0]
                else:
                    got = _status(drv.fmu.doStep, t, h)[0]
                if model.state != "step" or not (0 < h < math.inf) or not (o == 0.0) or not model.inputs_ok():
                    expect(got, model.fail(), f"doStep(t + {o!r}, {h!r})")
                elif h == 1e300:
                    expect(got, DISCARD, "doStep of 1e300 s")  # needs too many internal steps
                    model.state = "step failed"
                else:
                    assert got in (OK, DISCARD), f"doStep({t!r}, {h!r}): status {got}"
                    counter.statuses[("doStep", got)] = counter.statuses.get(("doStep", got), 0) + 1
                    if got == OK:
                        model.time = t + h
                    else:
                        model.state = "step failed"
                counter.calls += 1
        elif kind == "get":
            names = op[1]
            if "unknown" in names:
                refs = [vr[n] if n != "unknown" else 987654 for n in names]
            else:
                refs = [vr[n] for n in names]
            got, vals = _status(drv.get_real, refs)
            if not names:
                want = OK
            elif model.state not in ("initialization", "step", "step failed", "terminated", "error"):
                want = model.fail()
            elif "unknown" in names or "mode" in names:
                want = model.fail()
            elif model.state == "initialization" and not model.params_ok() and any(
                    model.spec[n].causality == "output" for n in names):
                want = model.fail()
            else:
                want = OK
            expect(got, want, f"getReal {names}")
            if got == OK and model.state == "step":
                for n, x in zip(names, vals):
                    if model.spec[n].causality == "output":
                        assert math.isfinite(x), f"output {n} = {x!r} with status OK"
                    else:
                        assert x == model.values[n] or (math.isnan(x) and math.isnan(model.values[n]))
        elif kind == "get_contact":
            got, vals = _status(drv.get_enum, [vr["m12.contact"]])
            if model.state not in ("initialization", "step", "step failed", "terminated", "error"):
                want = model.fail()
            elif model.state == "initialization" and not model.params_ok():
                want = model.fail()
            else:
                want = OK
            expect(got, want, "get contact")
            if got == OK:
                assert vals[0] in (0, 1, 2)
        elif kind == "terminate":
            got = _status(drv.fmu.terminate)[0]
            if model.state in ("step", "step failed"):
                model.state, want = "terminated", OK
            else:
                want = model.fail()
            expect(got, want, "terminate")
        elif kind == "reset":
            expect(_status(drv.fmu.reset)[0], OK, "reset")
            model.reset()
        elif kind == "save":
            got, ptr = _status(drv.get_state)
            expect(got, OK, "get FMU state")
            got, blob = _status(drv.serialize, ptr)
            expect(got, OK, "serialize FMU state")
            saved.append((ptr, blob, model.snapshot()))
        elif kind in ("restore", "restore_bytes") and saved:
            ptr, blob, snap = saved[-1]
            if kind == "restore_bytes":
                got, ptr2 = _status(drv.deserialize, blob)
                expect(got, OK, "deserialize FMU state")
                got = _status(drv.set_state, ptr2)[0]
                expect(_status(drv.free_state, ptr2)[0], OK, "free FMU state")
            else:
                got = _status(drv.set_state, ptr)[0]
            # a state taken with invalid parameters after initialization cannot happen; before it, any state
            expect(got, OK, "set FMU state")
            model.restore(snap)
        elif kind == "foreign_state" and drv.backend == "pythonfmu":
            continue  # pythonfmu's wrappers use the pointer as a Python object: not playable
        elif kind == "random_bytes" and drv.backend == "pythonfmu":
            got, _ = _status(drv.deserialize, op[1])  # pythonfmu: refused when the state is set, not here
            expect(got, OK, "deserialize random bytes (pythonfmu)")
        elif kind == "foreign_state":
            got = _status(drv.set_state, ctypes.c_void_p(op[1]))[0]
            expect(got, model.fail(), "set a foreign FMU state pointer")
        elif kind == "random_bytes":
            got, _ = _status(drv.deserialize, op[1])
            expect(got, model.fail(), "deserialize random bytes")
    for ptr, _, _ in saved:
        _status(drv.free_state, ptr)
    counter.sequences += 1


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("fuzz")
    return {v: build_fmu(ROOT / "models" / SYSTEM, out, fmi_version=v) for v in (2, 3)}


@pytest.fixture(scope="module")
def pyfmus(tmp_path_factory):
    pytest.importorskip("pythonfmu")
    pytest.importorskip("pythonfmu3")
    out = tmp_path_factory.mktemp("fuzz_pythonfmu")
    return {v: build_fmu(ROOT / "models" / SYSTEM, out, fmi_version=v, backend="pythonfmu") for v in (2, 3)}


@pytest.fixture(scope="module")
def spec():
    ad = make_adapter(ROOT / "models" / SYSTEM)
    return {v.name: v for v in ad.variables}


def _fuzz(path, spec, n, derandomize, capsys, label):
    drv = Driver(path)
    model = Model(spec=spec, start={n_: v.start for n_, v in spec.items() if v.causality in ("parameter", "input")})
    counter = Counter()

    @settings(max_examples=n, deadline=None, derandomize=derandomize, database=None,
              suppress_health_check=list(HealthCheck))
    @given(sequences)
    def check(seq):
        run_sequence(drv, model, seq, counter)

    try:
        check()
    finally:
        drv.close()
    names = {OK: "OK", DISCARD: "Discard", ERROR: "Error"}
    summary = ", ".join(f"{op} {names.get(s_, s_)} x{k}" for (op, s_), k in sorted(counter.statuses.items()))
    with capsys.disabled():
        print(f"\n{label}: {counter.sequences} FMU call sequences, {counter.calls} FMI calls, every status as "
              f"expected, no importer crash ({summary})", file=sys.stderr)
    return counter


@pytest.mark.parametrize("version, n", [(2, 400), (3, 150)])
def test_fuzzed_call_sequences(fmus, spec, capsys, version, n):
    """>= 500 sequences in the default suite (FMI 2.0: 400, FMI 3.0: 150), fixed seed."""
    c = _fuzz(fmus[version], spec, n, True, capsys, f"FMI {version}.0 fuzz (default suite)")
    assert c.sequences >= n and c.calls > 3 * n
    # the sequences reach every part of the state machine: successful and refused initializations and steps
    for key in (("exit", OK), ("exit", ERROR), ("doStep", OK), ("doStep(t", ERROR), ("set", OK), ("set", ERROR),
                ("getReal", OK), ("getReal", ERROR), ("doStep", DISCARD), ("terminate", OK), ("terminate", ERROR),
                ("set", OK), ("deserialize", OK), ("deserialize", ERROR), ("initial state", "repeated")):
        assert c.statuses.get(key, 0) > 0, (key, c.statuses)


@pytest.mark.parametrize("version, n", [(2, 400), (3, 150)])
def test_fuzzed_call_sequences_pythonfmu(pyfmus, spec, capsys, version, n):
    """The pythonfmu backend: >= 500 sequences (FMI 2.0: 400, FMI 3.0: 150), fixed seed; every status the one
    its wrapper allows for the model's answer (:meth:`Driver.wrapper_status`), no importer crash."""
    c = _fuzz(pyfmus[version], spec, n, True, capsys, f"FMI {version}.0 pythonfmu fuzz (default suite)")
    assert c.sequences >= n and c.calls > 3 * n
    refused = DISCARD if version == 2 else ERROR
    for key in (("exit", OK), ("doStep", OK), ("doStep(t", refused), ("set", OK), ("getReal", OK),
                ("doStep", DISCARD), ("terminate", OK), ("deserialize", OK), ("set", OK), ("getReal", OK),
                ("initial state", "repeated")):
        assert c.statuses.get(key, 0) > 0, (key, c.statuses)
    statuses = [(op, s_) for op, s_ in c.statuses if op != "initial state"]
    assert not any(s_ not in (OK, DISCARD, ERROR) for _, s_ in statuses)
    assert not any(s_ != OK for (op, s_) in statuses if not op.startswith("doStep"))


@pytest.mark.slow
@pytest.mark.parametrize("version, n", [(2, 4000), (3, 2000)])
def test_fuzzed_call_sequences_long(fmus, spec, capsys, version, n):
    """Thousands more sequences with random seeds (``pytest -m slow``)."""
    c = _fuzz(fmus[version], spec, n, False, capsys, f"FMI {version}.0 fuzz (slow)")
    assert c.sequences >= n


def test_fuzz_model_catches_a_wrong_status(fmus, spec):
    """The reference model is strict: a model that expects another status than the FMU's fails the sequence."""
    drv = Driver(fmus[2])
    start = {n_: v.start for n_, v in spec.items() if v.causality in ("parameter", "input")}
    try:
        model = Model(spec=spec, start=start)
        run_sequence(drv, model, [("enter", 0.0), ("exit",), ("step", 1e-4, 0.0, 2)], Counter())
        assert model.state == "step" and model.time == pytest.approx(2e-4)
        wrong = Model(spec=spec, start={**start, "torque": math.nan})  # expects initialization to fail
        with pytest.raises(AssertionError, match="exit initialization"):
            run_sequence(drv, wrong, [("enter", 0.0), ("exit",)], Counter())
    finally:
        drv.close()


def test_nan_step_outputs_never_reach_the_master(fmus):
    """Huge but allowed torques in drivetrain mode: every step is OK with finite outputs, or Discard with the
    state unchanged."""
    drv = Driver(fmus[2])
    vr = drv.vr
    try:
        assert drv.enter(0.0) == OK
        drv.set_int([vr["mode"]], [1])
        drv.set_real([vr["pinion.torque_in"], vr["wheel.torque_in"]], [1e6, 1e6])
        drv.fmu.exitInitializationMode()
        outs = [vr[n] for n in ("m12.force", "pinion.speed", "m12.dte", "pinion.angle")]
        t = 0.0
        seen = set()
        for _ in range(30):
            before = drv.get_real(outs)
            st_, _ = _status(drv.fmu.doStep, t, 1e-3)
            seen.add(st_)
            after = drv.get_real(outs)
            if st_ == OK:
                assert np.all(np.isfinite(after))
                t += 1e-3
            else:
                assert st_ == DISCARD and after == before
                break
        assert seen <= {OK, DISCARD}
    finally:
        drv.close()
