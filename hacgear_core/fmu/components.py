"""Drivetrain components of the benches (motor, shaft, load): the plain-Python models the Python bench steps and,
through :class:`ComponentAdapter`, the small FMUs of the SSP benches (the same code in both).

Every component advances one communication step ``h`` with the inputs held over the step (co-simulation
coupling: its outputs at the end of the step feed the others' next step):

* :class:`Motor`: inertia ``J`` driven by a PI speed controller (torque-limited, integrator frozen while the
  torque limit holds) on a reference speed held for ``hold_time``, ramped linearly over ``ramp_time``; it drives
  the shaft whose torque ``shaft_torque`` loads it: ``J dw/dt = T_drive - shaft_torque`` (semi-implicit Euler);
* :class:`Shaft`: torsion spring-damper between side a and side b; its twist integrates the speed difference,
  ``torque = k twist + c (w_a - w_b)`` is the torque on side b, ``torque_a = -torque`` the one on side a;
* :class:`Load`: inertia on side a of a shaft, braked by a constant torque: ``J dw/dt = -shaft_torque - T_brake``;
* :class:`Rotor`: a wind-turbine rotor, an inertia driven by a prescribed aerodynamic torque (a step at
  ``step_time``: a gust) that drives the shaft on its side a: ``J dw/dt = T_aero(t) - shaft_torque``;
* :class:`Generator`: inertia on side a of a shaft, braked by its electrical torque, a linear speed-torque law
  ``T_gen = rated_torque + slope (w - rated_speed)`` until ``reversal_time``, ``reversal_torque`` from then on (an
  emergency stop's torque reversal): ``J dw/dt = -shaft_torque - T_gen``, the law taken at the step's end speed
  (implicit Euler: stable for a stiff law on a small inertia).

Angles and speeds are positive in each body's sense of rotation (the gear's at the shaft it is coupled to).
"""
from __future__ import annotations

import math

from hacgear_core.dynamics.simulator import StepResult
from hacgear_core.errors import ModelError
from hacgear_core.fmu.spec import FmuVariable, Reading, output_expressions, output_getters

__all__ = ["Motor", "Shaft", "Load", "Rotor", "Generator", "COMPONENTS", "ComponentAdapter"]

_OK = StepResult(True, "", 1)


class Motor:
    """Speed-controlled motor (module docstring).  Parameters in SI (inertia [kg m^2], speeds [rad/s], times [s],
    gains [N m s/rad] and [N m/rad], torque [N m], angles [rad])."""

    def __init__(self, inertia, speed_start, speed_end, hold_time, ramp_time, gain_p, gain_i, torque_limit,
                 angle_start=0.0, integrator_start=0.0) -> None:
        self.inertia, self.speed_start, self.speed_end = float(inertia), float(speed_start), float(speed_end)
        self.hold_time, self.ramp_time = float(hold_time), float(ramp_time)
        self.gain_p, self.gain_i, self.torque_limit = float(gain_p), float(gain_i), float(torque_limit)
        self.time = 0.0
        self.angle, self.speed, self.integrator = float(angle_start), self.speed_start, float(integrator_start)
        self.shaft_torque = 0.0
        self.speed_reference = self.speed_start
        self.torque = self._torque(self.speed_start)

    def _reference(self, t: float) -> float:
        s = min(max((t - self.hold_time) / self.ramp_time, 0.0), 1.0)
        return self.speed_start + (self.speed_end - self.speed_start) * s

    def _torque(self, w_ref: float) -> float:
        tm = self.gain_p * (w_ref - self.speed) + self.gain_i * self.integrator
        return min(max(tm, -self.torque_limit), self.torque_limit)

    def advance(self, h: float) -> StepResult:
        w_ref = self._reference(self.time)
        err = w_ref - self.speed
        tm = self.gain_p * err + self.gain_i * self.integrator
        if abs(tm) < self.torque_limit:
            self.integrator += err * h
        tm = min(max(tm, -self.torque_limit), self.torque_limit)
        self.speed += h * (tm - self.shaft_torque) / self.inertia
        self.angle += h * self.speed
        self.time += h
        self.torque, self.speed_reference = tm, w_ref
        return _OK

    def state(self) -> tuple:
        return (self.time, self.angle, self.speed, self.integrator, self.shaft_torque, self.torque,
                self.speed_reference)

    def set_state(self, st) -> None:
        (self.time, self.angle, self.speed, self.integrator, self.shaft_torque, self.torque,
         self.speed_reference) = st


class Shaft:
    """Torsion spring-damper (module docstring): stiffness [N m/rad], damping [N m s/rad], initial twist [rad]."""

    def __init__(self, stiffness, damping, twist_start=0.0) -> None:
        self.stiffness, self.damping = float(stiffness), float(damping)
        self.twist = float(twist_start)
        self.speed_a = self.speed_b = 0.0
        self.torque = self.stiffness * self.twist
        self.torque_a = -self.torque

    def advance(self, h: float) -> StepResult:
        dw = self.speed_a - self.speed_b
        self.twist += h * dw
        self.torque = self.stiffness * self.twist + self.damping * dw
        self.torque_a = -self.torque
        return _OK

    def state(self) -> tuple:
        return (self.twist, self.speed_a, self.speed_b, self.torque)

    def set_state(self, st) -> None:
        self.twist, self.speed_a, self.speed_b, self.torque = st
        self.torque_a = -self.torque


class Load:
    """Braked inertia on side a of a shaft (module docstring): inertia [kg m^2], braking torque [N m], initial
    speed [rad/s] and angle [rad]."""

    def __init__(self, inertia, braking_torque, speed_start, angle_start=0.0) -> None:
        self.inertia, self.braking_torque = float(inertia), float(braking_torque)
        self.speed, self.angle = float(speed_start), float(angle_start)
        self.shaft_torque = 0.0

    def advance(self, h: float) -> StepResult:
        self.speed += h * (-self.shaft_torque - self.braking_torque) / self.inertia
        self.angle += h * self.speed
        return _OK

    def state(self) -> tuple:
        return (self.speed, self.angle, self.shaft_torque)

    def set_state(self, st) -> None:
        self.speed, self.angle, self.shaft_torque = st


class Rotor:
    """Wind-turbine rotor (module docstring): inertia [kg m^2], aerodynamic torque [N m] before ``step_time`` [s]
    and ``step_torque`` [N m] from then on, initial speed [rad/s] and angle [rad].  The torque of a step is the one
    at its start time (held over the step, as every input); the step happens at the communication point nearest
    ``step_time`` (a start time within half a step of it counts: time accumulated in floats, or a master's whole
    nanoseconds, do not move it by a step)."""

    def __init__(self, inertia, aero_torque, step_time, step_torque, speed_start, angle_start=0.0) -> None:
        self.inertia, self.aero_torque = float(inertia), float(aero_torque)
        self.step_time, self.step_torque = float(step_time), float(step_torque)
        self.speed, self.angle = float(speed_start), float(angle_start)
        self.time = 0.0
        self.shaft_torque = 0.0
        self.torque = self._torque(0.0)

    def _torque(self, t: float, h: float = 0.0) -> float:
        return self.aero_torque if t < self.step_time - 0.5 * h else self.step_torque

    def advance(self, h: float) -> StepResult:
        self.torque = self._torque(self.time, h)
        self.speed += h * (self.torque - self.shaft_torque) / self.inertia
        self.angle += h * self.speed
        self.time += h
        return _OK

    def state(self) -> tuple:
        return (self.time, self.speed, self.angle, self.shaft_torque, self.torque)

    def set_state(self, st) -> None:
        self.time, self.speed, self.angle, self.shaft_torque, self.torque = st


class Generator:
    """Generator on side a of a shaft (module docstring): inertia [kg m^2], the speed-torque law's rated torque
    [N m] at rated speed [rad/s] and slope [N m s/rad], the torque after ``reversal_time`` [s]
    ``reversal_torque`` [N m] (positive brakes), initial speed [rad/s] and angle [rad].  The electrical torque of a
    step is the law's at the speed at its end (implicit in the speed: stable for a stiff law on a small inertia);
    the reversal from the communication point nearest ``reversal_time`` on (as :class:`Rotor`'s step)."""

    def __init__(self, inertia, rated_torque, rated_speed, slope, reversal_time, reversal_torque, speed_start,
                 angle_start=0.0) -> None:
        self.inertia, self.rated_torque, self.rated_speed = float(inertia), float(rated_torque), float(rated_speed)
        self.slope, self.reversal_time, self.reversal_torque = float(slope), float(reversal_time), float(reversal_torque)
        self.speed, self.angle = float(speed_start), float(angle_start)
        self.time = 0.0
        self.shaft_torque = 0.0
        self.torque = self._torque(0.0, self.speed)
        self.power = self.torque * self.speed

    def _torque(self, t: float, w: float, h: float = 0.0) -> float:
        if t >= self.reversal_time - 0.5 * h:
            return self.reversal_torque
        return self.rated_torque + self.slope * (w - self.rated_speed)

    def advance(self, h: float) -> StepResult:
        if self.time >= self.reversal_time - 0.5 * h:
            self.torque = self.reversal_torque
            self.speed += h * (-self.shaft_torque - self.torque) / self.inertia
        else:  # the law implicit in the step's end speed: stable for any slope h / inertia
            g = h / self.inertia
            self.speed = (self.speed + g * (-self.shaft_torque - self.rated_torque + self.slope * self.rated_speed)) / (
                1.0 + g * self.slope)
            self.torque = self._torque(self.time, self.speed, h)
        self.power = self.torque * self.speed
        self.angle += h * self.speed
        self.time += h
        return _OK

    def state(self) -> tuple:
        return (self.time, self.speed, self.angle, self.shaft_torque, self.torque, self.power)

    def set_state(self, st) -> None:
        self.time, self.speed, self.angle, self.shaft_torque, self.torque, self.power = st


def _v(name, causality, unit, description, start=None, lo=None, hi=None, display=""):
    """A Real variable; an output is read from the component's attribute of its own name."""
    variability = {"parameter": "fixed", "input": "continuous", "output": "continuous"}[causality]
    return FmuVariable(name, "Real", causality, variability, unit, description, start, lo, hi, display_unit=display,
                       read=Reading(attr=name) if causality == "output" else None)


#: component kind -> (class, variables, inputs -> attribute, one-line description); outputs are read from the
#: attribute of their name
COMPONENTS = {
    "motor": (Motor, (
        _v("inertia", "parameter", "kg.m2", "rotor inertia", 0.05, 1e-9, 1e6),
        _v("speed_start", "parameter", "rad/s", "reference speed before the ramp (and initial speed)", 418.879,
           -1e5, 1e5, "rpm"),
        _v("speed_end", "parameter", "rad/s", "reference speed after the ramp", 785.398, -1e5, 1e5, "rpm"),
        _v("hold_time", "parameter", "s", "time at speed_start before the ramp", 0.05, 0.0, 1e6),
        _v("ramp_time", "parameter", "s", "duration of the linear ramp", 1.5, 1e-9, 1e6),
        _v("gain_p", "parameter", "N.m.s/rad", "proportional gain of the speed controller", 10.0, 0.0, 1e9),
        _v("gain_i", "parameter", "N.m/rad", "integral gain of the speed controller", 1000.0, 0.0, 1e12),
        _v("torque_limit", "parameter", "N.m", "largest drive torque", 2000.0, 0.0, 1e7),
        _v("angle_start", "parameter", "rad", "initial rotor angle", 0.0, -1e9, 1e9),
        _v("integrator_start", "parameter", "rad", "initial value of the controller's integrator", 0.0, -1e9, 1e9),
        _v("shaft_torque", "input", "N.m", "torque of the driven shaft (loads the motor)", 0.0, -1e7, 1e7),
        _v("angle", "output", "rad", "rotor angle"),
        _v("speed", "output", "rad/s", "rotor speed", display="rpm"),
        _v("torque", "output", "N.m", "drive torque of the last step"),
        _v("speed_reference", "output", "rad/s", "reference speed of the last step", display="rpm"),
    ), {"shaft_torque": "shaft_torque"},
        "speed-controlled motor (PI on a ramped reference speed)"),
    "shaft": (Shaft, (
        _v("stiffness", "parameter", "N.m/rad", "torsional stiffness", 2.0e4, 0.0, 1e12),
        _v("damping", "parameter", "N.m.s/rad", "torsional damping", 10.0, 0.0, 1e9),
        _v("twist_start", "parameter", "rad", "initial twist (side a minus side b)", 0.0, -1e3, 1e3),
        _v("speed_a", "input", "rad/s", "speed of side a", 0.0, -1e6, 1e6, "rpm"),
        _v("speed_b", "input", "rad/s", "speed of side b", 0.0, -1e6, 1e6, "rpm"),
        _v("torque", "output", "N.m", "torque of the shaft on side b"),
        _v("torque_a", "output", "N.m", "torque of the shaft on side a (= -torque)"),
        _v("twist", "output", "rad", "twist, side a minus side b"),
    ), {"speed_a": "speed_a", "speed_b": "speed_b"},
        "torsion spring-damper shaft"),
    "load": (Load, (
        _v("inertia", "parameter", "kg.m2", "load inertia", 0.2, 1e-9, 1e6),
        _v("braking_torque", "parameter", "N.m", "constant braking torque (positive brakes)", 0.0, -1e7, 1e7),
        _v("speed_start", "parameter", "rad/s", "initial speed", 0.0, -1e6, 1e6, "rpm"),
        _v("angle_start", "parameter", "rad", "initial angle", 0.0, -1e9, 1e9),
        _v("shaft_torque", "input", "N.m", "torque of the shaft on whose side a the load sits", 0.0, -1e7, 1e7),
        _v("angle", "output", "rad", "load angle"),
        _v("speed", "output", "rad/s", "load speed", display="rpm"),
    ), {"shaft_torque": "shaft_torque"}, "braked load inertia"),
    "rotor": (Rotor, (
        _v("inertia", "parameter", "kg.m2", "rotor inertia", 57231535.0, 1e-9, 1e10),
        _v("aero_torque", "parameter", "N.m", "aerodynamic torque before step_time", 3.94599e6, -1e9, 1e9),
        _v("step_time", "parameter", "s", "time of the torque step (a gust)", 1e9, 0.0, 1e9),
        _v("step_torque", "parameter", "N.m", "aerodynamic torque from step_time on", 3.94599e6, -1e9, 1e9),
        _v("speed_start", "parameter", "rad/s", "initial speed", 1.26711, -1e4, 1e4, "rpm"),
        _v("angle_start", "parameter", "rad", "initial angle", 0.0, -1e9, 1e9),
        _v("shaft_torque", "input", "N.m", "torque of the driven shaft (loads the rotor)", 0.0, -1e9, 1e9),
        _v("angle", "output", "rad", "rotor angle"),
        _v("speed", "output", "rad/s", "rotor speed", display="rpm"),
        _v("torque", "output", "N.m", "aerodynamic torque of the last step"),
    ), {"shaft_torque": "shaft_torque"}, "wind-turbine rotor (inertia, prescribed aerodynamic torque with a step)"),
    "generator": (Generator, (
        _v("inertia", "parameter", "kg.m2", "generator rotor inertia", 534.116, 1e-9, 1e10),
        _v("rated_torque", "parameter", "N.m", "electrical torque at rated_speed (positive brakes)", 40952.98, -1e9,
           1e9),
        _v("rated_speed", "parameter", "rad/s", "rated speed", 122.909, -1e5, 1e5, "rpm"),
        _v("slope", "parameter", "N.m.s/rad", "slope of the speed-torque law", 33318.6, 0.0, 1e12),
        _v("reversal_time", "parameter", "s", "time from which the torque is reversal_torque", 1e9, 0.0, 1e9),
        _v("reversal_torque", "parameter", "N.m", "electrical torque from reversal_time on (negative: motoring)",
           -40952.98, -1e9, 1e9),
        _v("speed_start", "parameter", "rad/s", "initial speed", 122.909, -1e5, 1e5, "rpm"),
        _v("angle_start", "parameter", "rad", "initial angle", 0.0, -1e9, 1e9),
        _v("shaft_torque", "input", "N.m", "torque of the shaft on whose side a the generator sits", 0.0, -1e9, 1e9),
        _v("angle", "output", "rad", "generator angle"),
        _v("speed", "output", "rad/s", "generator speed", display="rpm"),
        _v("torque", "output", "N.m", "electrical torque of the last step (positive brakes)"),
        _v("power", "output", "W", "electrical power of the last step (torque x speed at its end)"),
    ), {"shaft_torque": "shaft_torque"}, "generator (inertia, linear speed-torque law, torque reversal)"),
}


class ComponentAdapter:
    """The FMU adapter of a component (the protocol of :class:`~hacgear_core.fmu.adapter.Adapter` that
    :class:`~hacgear_core.fmu.slave.FmuInstance` uses)."""

    step_floor_s = math.inf  # no internal steps: any communication step is one step

    def __init__(self, kind: str) -> None:
        if kind not in COMPONENTS:
            raise ModelError(f"unknown drivetrain component {kind!r}; known: {sorted(COMPONENTS)}")
        self.kind = kind
        self.cls, self.variables, self._inputs, self.description = COMPONENTS[kind]
        self.by_name = {v.name: v for v in self.variables}
        self.fallible: set = set()
        self.inputs = tuple(v.name for v in self.variables if v.causality == "input")
        self.input_checks = tuple((n, self.by_name[n].min, self.by_name[n].max) for n in self.inputs)
        self.sim = self._make({v.name: v.start for v in self.variables if v.start is not None})

    def _make(self, values: dict):
        params = {v.name: float(values[v.name]) for v in self.variables if v.causality == "parameter"}
        return self.cls(**params)

    def default_experiment(self) -> dict:
        return {"startTime": 0.0, "stopTime": 1.0, "stepSize": 1e-4}

    def output_expressions(self) -> dict[str, str]:
        return output_expressions(self.variables, self)

    def getters(self) -> dict:
        return output_getters(self.variables, self)

    def active_inputs(self, values: dict) -> tuple[str, ...]:
        return self.inputs

    def configure(self, values: dict) -> None:
        self.sim = self._make(values)
        self.apply_inputs(values)

    def apply_inputs(self, values: dict) -> None:
        for name, attr in self._inputs.items():
            setattr(self.sim, attr, float(values[name]))

    def internal_step(self) -> float:
        return math.inf

    def get_state(self) -> dict:
        return {"state": self.sim.state()}

    def set_state(self, snap: dict) -> None:
        self.sim.set_state(tuple(snap["state"]))
