"""The one FMU adapter of every gear system: FMI variables <-> :class:`~hacgear_core.dynamics.simulator.Simulator`.

The variables come from the system itself (its gears, meshes, ports and gauges), so spur pairs, idler chains
and every later kind share this adapter and the generic slave; only the builder of the lumped system is
kind-specific.  Names are structured (``<gear>.speed``, ``<mesh>.force``, ``<gear>.<gauge>.root_strain``).

Two experiments, chosen by the parameter ``mode`` (fixed after initialization):

* ``mode = 0`` (constant speed): input ``<reference gear>.speed_in``; the torque set-point is the parameter
  ``torque`` on the input gear; the gear deviations are integrated around the imposed rotation, with the model's
  shaft stiffnesses (dissertation Eqs. 3.1, 4.1);
* ``mode = 1`` (drivetrain coupling): inputs ``<port>.torque_in`` (shaft torques on the port gears: the input
  gear and the output gears); outputs ``<gear>.angle`` and ``<gear>.speed`` are the absolute gear motions to feed
  back into the shafts (the shafts belong to the drivetrain model: rotational supports are dropped).  Starts
  from rest relative to ``<reference gear>.speed_start``.

Angles, speeds and shaft torques are positive in each gear's operating sense of rotation; a braking load torque
is negative.
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Callable

from hacgear_core.dynamics.build import build_system, structural_parameters
from hacgear_core.dynamics.simulator import Simulator, system_gauges
from hacgear_core.errors import HacgearError, ModelError
from hacgear_core.fmu.spec import FmuVariable, ident
from hacgear_core.model import load_model
from hacgear_core.tables import read_tables

__all__ = ["MODE_SPEED", "MODE_TORQUE", "MODEL_FILE", "TABLES_FILE", "Adapter", "make_adapter", "variables_for"]

MODEL_FILE = "model.toml"
TABLES_FILE = "tables.h5"
MODE_SPEED = 0
MODE_TORQUE = 1


class Adapter:
    """FMI variables of one gear system and the simulator behind them.

    Parameters
    ----------
    model : Model
    tables : SystemTables
    """

    def __init__(self, model, tables) -> None:
        self.model = model
        self.tables = tables
        self.kind = model.kind
        base = build_system(model, tables)
        self.base_system = base
        self.sim = Simulator(base)
        #: fixed Integer parameters that change the structure (planet count); the outputs cover the largest one
        self.structural = structural_parameters(model)
        big = {p.name: p.max for p in self.structural}
        spec_system = build_system(model, tables, **big) if big else base
        self.spec_system = spec_system
        self.bearing_gears = tuple(g.name for g in model.gears) + (("carrier",) if model.kind == "planetary" else ())
        self._built_key = self._key(base.torque_Nm, base.modal_damping_ratio, self._model_bearings(model), None, True,
                                    tuple((p.name, p.start) for p in self.structural))
        self.ref = base.reference_gear
        # ports: the gears that carry external torque in drivetrain coupling (turning members free)
        self._drive_sim = Simulator(build_system(model, tables, shafts=False, **big))
        self.ports = self._drive_sim.ports
        #: nominal torque on each port [N m] in its sense of rotation (the drivetrain coupling's start values)
        self.port_torques_Nm = dict(self._drive_sim.port_torques_Nm)
        self.gear_names = tuple(spec_system.gears)
        self.mesh_names = spec_system.mesh_names
        groups = [c.group for c in spec_system.meshes]
        self.shared_meshes = tuple(c.name for c in spec_system.meshes if c.group and groups.count(c.group) > 1)
        self.gauges = system_gauges(spec_system)
        self._index()
        self.variables = self._spec()
        self.by_name = {v.name: v for v in self.variables}
        #: outputs computed by table post-processing (guarded by the slave: NaN and a log line on failure)
        self.fallible = {v.name for v in self.variables if v.name.endswith((".peak_pressure", ".root_strain"))}
        self._last_inputs: tuple | None = None
        self.mode = MODE_SPEED
        self.input_checks: tuple = ()
        self.step_floor_s = 0.0

    def _model_bearings(self, model) -> tuple:
        """Translational support stiffness of every gear of the model (and the carrier of a planetary set)."""
        out = [model.gear(g).support.translational_stiffness_N_per_m for g in self.bearing_gears if g != "carrier"]
        if "carrier" in self.bearing_gears:
            out.append(model.planetary.carrier_support.translational_stiffness_N_per_m)
        return tuple(out)

    def _with_bearings(self, bearings: tuple):
        """The model with the translational support stiffnesses ``bearings`` (order of :attr:`bearing_gears`)."""
        model = self.model
        k = dict(zip(self.bearing_gears, bearings))
        gears = tuple(replace(g, support=replace(g.support, translational_stiffness_N_per_m=k[g.name]))
                      for g in model.gears)
        model = replace(model, gears=gears)
        if "carrier" in k:
            pl = model.planetary
            model = replace(model, planetary=replace(pl, carrier_support=replace(
                pl.carrier_support, translational_stiffness_N_per_m=k["carrier"])))
        return model

    @staticmethod
    def _key(torque, zeta, bearings, h, shafts, structure=()):
        return (torque, zeta, bearings, h, shafts, structure)

    def _index(self) -> None:
        """Slots of the spec's meshes and gears in the current simulator (-1: absent in this structure)."""
        sy = self.sim.system
        mi = {c: k for k, c in enumerate(sy.mesh_names)}
        gi = {g: k for k, g in enumerate(self.sim.gear_names)}
        self._mslot = [mi.get(mn, -1) for mn in self.mesh_names]
        self._gslot = [gi.get(g, -1) for g in self.gear_names]
        self._gauge_on = {g: g.partition("/")[0] in sy.gears for g in self.gauges}

    # ------------------------------------------------------------------ the spec (declared once)
    def _spec(self) -> tuple[FmuVariable, ...]:
        sy = self.spec_system
        V = FmuVariable
        ref, inp = self.ref, sy.input_gear
        port_t = self.port_torques_Nm
        spec = [
            V("mode", "Integer", "parameter", "fixed", "",
              f"experiment: 0 = constant speed (input {ref}.speed_in, torque set-point = parameter torque); "
              f"1 = drivetrain coupling (inputs <port>.torque_in on {', '.join(self.ports)}; outputs angles and "
              "speeds)", MODE_SPEED, 0, 1),
        ]
        for p in self.structural:
            spec.append(V(p.name, "Integer", "parameter", "fixed", "", p.description, p.start, p.min, p.max))
        spec += [
            V("torque", "Real", "parameter", "fixed", "N.m",
              f"nominal torque on the input gear {inp}: torque set-point of the constant-speed experiment; in both "
              "modes it sets the linearisation used for the modal damping", sy.torque_Nm, 1e-3, 1e6),
            V("modal_damping_ratio", "Real", "parameter", "fixed", "1",
              "modal damping ratio of every elastic mode of the linearised system", sy.modal_damping_ratio, 0.0, 0.99),
        ]
        planets = {a for c in sy.meshes for gi, a in c.gear_alias.items() if gi != a}
        for g, k in zip(self.bearing_gears, self._model_bearings(self.model)):
            what = "every planet's bearing on its pin" if g in planets else f"{'the ' if g == 'carrier' else 'gear '}{g}"
            spec.append(V(f"{ident(g)}.bearing_stiffness", "Real", "parameter", "fixed", "N/m",
                          f"translational bearing stiffness of {what}; 0 = rigid (no translation)",
                          0.0 if math.isinf(k) else k, 0.0, 1e15))
        spec += [
            V("internal_step", "Real", "parameter", "fixed", "s",
              "largest internal RK4 step; 0 = automatic (mesh period / 128 at the current speed and 1/32 of the "
              "period of the highest natural frequency); doStep sub-steps any communication step with equal steps "
              "no larger than this", 0.0, 0.0, 1e-3),
            V(f"{ident(ref)}.speed_start", "Real", "parameter", "fixed", "rad/s",
              f"mode 1: initial speed of gear {ref} in its sense of rotation; mode 0 starts at {ref}.speed_in",
              0.0, -2e4, 2e4),
            V(f"{ident(ref)}.speed_in", "Real", "input", "continuous", "rad/s",
              f"mode 0: imposed speed of gear {ref}, positive in its sense of rotation (ignored in mode 1)",
              0.0, -2e4, 2e4),
        ]
        for g in self.ports:
            role = "driving (positive)" if g == inp else "a braking load is negative"
            spec.append(V(f"{ident(g)}.torque_in", "Real", "input", "continuous", "N.m",
                          f"mode 1: shaft torque on gear {g}, positive in its sense of rotation ({role})",
                          port_t[g], -1e6, 1e6))
        for k, mn in enumerate(self.mesh_names):
            c = sy.meshes[k]
            m_ = ident(mn)
            spec += [
                V(f"{m_}.force", "Real", "output", "continuous", "N",
                  f"dynamic mesh force of mesh {mn} ({c.gear_a}-{c.gear_b}) along its line of action "
                  "(0 = contact loss)"),
                V(f"{m_}.deflection", "Real", "output", "continuous", "m",
                  f"mesh deflection of mesh {mn}: approach of the loaded flanks along the line of action "
                  "(dissertation Eqs. 3.4, 4.4)"),
                V(f"{m_}.dte", "Real", "output", "continuous", "m",
                  f"dynamic transmission error of mesh {mn}: rotational part of its mesh deflection"),
                V(f"{m_}.position", "Real", "output", "continuous", "1",
                  f"mesh position of mesh {mn} in mesh cycles (integer = pitch-point contact of a tooth pair), "
                  "unwrapped"),
                V(f"{m_}.contact", "Real", "output", "continuous", "1",
                  f"contact state of mesh {mn}: 1 = teeth in contact (mesh force > 0), 0 = contact loss"),
                V(f"{m_}.peak_pressure", "Real", "output", "continuous", "Pa",
                  f"maximum contact pressure over all teeth of mesh {mn} (table lookup)"),
            ]
            if mn in self.shared_meshes:
                spec.append(V(f"{m_}.load_share", "Real", "output", "continuous", "1",
                              f"load-sharing factor of mesh {mn}: its force over the mean force of the meshes of "
                              f"kind {c.group} (1 = equal sharing)"))
        for g in self.gear_names:
            g_ = ident(g)
            spec += [
                V(f"{g_}.angle", "Real", "output", "continuous", "rad", f"rotation angle of gear {g} in its sense of rotation"),
                V(f"{g_}.speed", "Real", "output", "continuous", "rad/s", f"speed of gear {g} in its sense of rotation"),
                V(f"{g_}.bearing_force_x", "Real", "output", "continuous", "N",
                  f"force of gear {g} on its bearing, x component (fixed frame of the model's gear placement)"),
                V(f"{g_}.bearing_force_y", "Real", "output", "continuous", "N",
                  f"force of gear {g} on its bearing, y component (fixed frame)"),
            ]
        for gauge in self.gauges:
            gear, _, gname = gauge.partition("/")
            z = sy.gears[gear].teeth if gear in sy.gears else 0
            spec.append(V(f"{ident(gear)}.{ident(gname or gear)}.root_strain", "Real", "output", "continuous", "1",
                          f"root strain at gauge '{gauge}' of tooth 0 of {gear} (in mesh every {z} mesh cycles, "
                          "all its meshes superposed; table lookup)"))
        names = [v.name for v in spec]
        if len(set(names)) != len(names):
            raise ModelError(f"FMU variable names are not unique: {names}")
        return tuple(spec)

    # ------------------------------------------------------------------ outputs
    def getters(self) -> dict[str, Callable[[], float]]:
        """Output name -> zero-argument getter returning a Python float for the current step (the simulator's own
        outputs, kept current by its ``advance``, and the table post-processing).  Outputs of meshes and gears that
        the current structure does not have (planets beyond ``planet_count``) read 0."""
        a = self
        ms, gs = self._mslot_ref, self._gslot_ref
        out: dict[str, Callable[[], float]] = {}

        def mesh(j, fn):
            def get():
                k = ms()[j]
                return fn(k) if k >= 0 else 0.0
            return get

        def gear(j, fn):
            def get():
                i = gs()[j]
                return fn(i) if i >= 0 else 0.0
            return get

        for j, mn in enumerate(self.mesh_names):
            m_ = ident(mn)
            out[f"{m_}.force"] = mesh(j, lambda k: a.sim.mesh_force_N[k])
            out[f"{m_}.deflection"] = mesh(j, lambda k: a.sim.mesh_deflection_m[k])
            out[f"{m_}.dte"] = mesh(j, lambda k: a.sim.dynamic_transmission_error_m[k])
            out[f"{m_}.position"] = mesh(j, lambda k: a.sim.mesh_position[k])
            out[f"{m_}.contact"] = mesh(j, lambda k: 1.0 if a.sim.mesh_force_N[k] > 0.0 else 0.0)
            out[f"{m_}.peak_pressure"] = mesh(j, lambda k: a.sim.peak_pressure_Pa(k))
            if mn in self.shared_meshes:
                out[f"{m_}.load_share"] = mesh(j, lambda k: a.sim.load_share(k))
        for j, g in enumerate(self.gear_names):
            g_ = ident(g)
            out[f"{g_}.angle"] = gear(j, lambda i: a.sim.angle_rad[i])
            out[f"{g_}.speed"] = gear(j, lambda i: a.sim.speed_rad_s[i])
            out[f"{g_}.bearing_force_x"] = gear(j, lambda i: float(a.sim.bearing_force_N(a.sim.gear_names[i])[0]))
            out[f"{g_}.bearing_force_y"] = gear(j, lambda i: float(a.sim.bearing_force_N(a.sim.gear_names[i])[1]))
        for gauge in self.gauges:
            gear_, _, gname = gauge.partition("/")
            out[f"{ident(gear_)}.{ident(gname or gear_)}.root_strain"] = (
                lambda key: lambda: a.sim.strain(key) if a._gauge_on[key] else 0.0)(gauge)
        return out

    def _mslot_ref(self) -> list:
        return self._mslot

    def _gslot_ref(self) -> list:
        return self._gslot

    # ------------------------------------------------------------------ configuration
    def configure(self, values: dict) -> None:
        """(Re)build the simulator for the parameter ``values`` and put it at its initial state.

        Raises
        ------
        ModelError
            Parameters that the model cannot take (message names field, unit, range).
        """
        mode = int(values["mode"])
        shafts = mode == MODE_SPEED
        bearings = tuple(math.inf if values[f"{ident(g)}.bearing_stiffness"] == 0
                         else float(values[f"{ident(g)}.bearing_stiffness"]) for g in self.bearing_gears)
        h = float(values["internal_step"]) or None
        structure = tuple((p.name, int(values[p.name])) for p in self.structural)
        key = self._key(float(values["torque"]), float(values["modal_damping_ratio"]), bearings, h, shafts, structure)
        if key != self._built_key:
            model = self.model
            if bearings != self._model_bearings(model):
                model = self._with_bearings(bearings)
            system = build_system(model, self.tables, torque_Nm=float(values["torque"]),
                                  modal_damping_ratio=float(values["modal_damping_ratio"]), shafts=shafts,
                                  **dict(structure))
            self.sim = Simulator(system, internal_step_s=h)
            self._built_key = key
            self._index()
        self.mode = mode
        ref = ident(self.ref)
        if self.mode == MODE_SPEED:
            self.sim.reset(speed_rad_s=float(values[f"{ref}.speed_in"]))
        else:
            self.sim.reset(speed_rad_s=float(values[f"{ref}.speed_start"]))
            self.sim.set_torque_inputs({g: float(values[f"{ident(g)}.torque_in"]) for g in self.ports})
        self._last_inputs = None
        self.apply_inputs(values)
        names = ((f"{ref}.speed_in",) if self.mode == MODE_SPEED
                 else tuple(f"{ident(g)}.torque_in" for g in self.ports))
        self.input_checks = tuple((n, self.by_name[n].min, self.by_name[n].max) for n in names)
        self._input_names = names
        # a lower bound of the internal step at any allowed speed (the exact one is asked only for long steps)
        sy = self.sim.system
        v = self.by_name[f"{ref}.speed_in"]
        fm_max = 4.0 * max(abs(v.min), abs(v.max)) * sy.zref_2pi  # mesh frequency bound, margin for vibration [Hz]
        floor = min(1.0 / (32.0 * sy.max_frequency_Hz), 1.0 / (128.0 * fm_max))
        self.step_floor_s = min(floor, h) if h else floor

    def input_names(self) -> tuple[str, ...]:
        """Inputs read in the current mode (only these are checked and applied)."""
        return tuple(n for n, _, _ in self.input_checks)

    def apply_inputs(self, values: dict) -> None:
        """Hand the current inputs to the simulator (only when they changed)."""
        if self.mode == MODE_SPEED:
            cur = (values[f"{ident(self.ref)}.speed_in"],)
            if cur != self._last_inputs:
                self.sim.set_speed_input(speed_rad_s=cur[0])
        else:
            cur = tuple(values[f"{ident(g)}.torque_in"] for g in self.ports)
            if cur != self._last_inputs:
                self.sim.set_torque_inputs(dict(zip(self.ports, cur)))
        self._last_inputs = cur

    def advance(self, dt: float) -> str:
        """Advance the simulator by ``dt`` [s] > 0 (checked by the caller) with the library's own step
        (:meth:`Simulator.advance <hacgear_core.dynamics.simulator.Simulator.advance>`); ``""`` on success, else
        the reason (the state is then left unchanged)."""
        r = self.sim.advance(dt)
        return "" if r.success else r.message

    def internal_step(self) -> float:
        """Internal step the simulator would use now [s]."""
        return float(self.sim.current_internal_step_s)


def load_resources(resources: str | Path):
    """Model and tables from an FMU's (or a build's) resources folder, or a model folder (model.toml, tables.h5);
    the tables must belong to the model file."""
    resources = Path(resources)
    model = load_model(resources / MODEL_FILE)
    tables = read_tables(resources / TABLES_FILE, resources / MODEL_FILE)  # refuses tables of another model
    missing = [m.name for m in model.meshes if m.name not in tables.meshes]
    if missing:
        raise HacgearError(f"tables have no mesh {missing} (have {sorted(tables.meshes)})")
    return model, tables


def make_adapter(resources: str | Path) -> Adapter:
    """The adapter of the system in ``resources`` (see :func:`load_resources`)."""
    model, tables = load_resources(resources)
    return Adapter(model, tables)


def variables_for(resources: str | Path) -> tuple[FmuVariable, ...]:
    """The variable spec of the system in ``resources`` (what the slave registers)."""
    return make_adapter(resources).variables
