"""The one FMU adapter of every gear system: FMI variables <-> :class:`~hacgear_core.dynamics.simulator.Simulator`.

The variables come from the system itself (its gears, meshes, ports and gauges), so spur pairs, idler chains
and every later kind share this adapter and the generic slave; only the builder of the lumped system is
kind-specific.  Names are structured (``<gear>.speed``, ``<mesh>.force``, ``<gear>.<gauge>.root_strain``).

Two experiments, chosen by the parameter ``mode`` (fixed after initialization;
:class:`~hacgear_core.encodings.Experiment`):

* ``mode = 0`` (constant speed): input ``<reference gear>.speed_in``; the torque set-point is the parameter
  ``torque`` on the input gear; the gear deviations are integrated around the imposed rotation, with the model's
  shaft stiffnesses (dissertation Eqs. 3.1, 4.1);
* ``mode = 1`` (drivetrain coupling): inputs ``<port>.torque_in`` (shaft torques on the port gears: the input
  gear and the output gears); outputs ``<gear>.angle`` and ``<gear>.speed`` are the absolute gear motions to feed
  back into the shafts (the shafts belong to the drivetrain model: rotational supports are dropped).  Starts
  from rest relative to ``<reference gear>.speed_start``.

Angles, speeds and shaft torques are positive in each gear's operating sense of rotation; a braking load torque
is negative.  Either sign of torque and any motion are allowed: every mesh has its drive and coast flanks, with the
backlash between them (``<mesh>.contact``, ``<mesh>.coast_force``, ``<mesh>.backlash_position``).

Structural parameters (the planet count of a planetary set, :func:`~hacgear_core.kinds.
structural_parameters`) are fixed Integer parameters; the outputs are declared for the largest structure and the
meshes and gears the chosen one does not have read 0.
"""
from __future__ import annotations

import hashlib
import math
import os
import pickle
import re
from dataclasses import replace
from pathlib import Path
from typing import Callable

import numpy as np

from hacgear_core.kinds import build_system, error_gears, kind_of, structural_parameters
from hacgear_core.dynamics.lead import MESH_INPUTS
from hacgear_core.dynamics.simulator import Simulator, strain_of_tooth, system_gauges
from hacgear_core.encodings import ContactState, Experiment
from hacgear_core.errors import HacgearError, ModelError
from hacgear_core.fmu.spec import FmuVariable, Reading, ident, output_expressions, output_getters, ranged
from hacgear_core.model.schema import RANGES, GearErrors
from hacgear_core.kinds import load_model
from hacgear_core.tables import read_tables
from hacgear_core.tables.check import STEEL_PRESSURE_LIMIT_PA

__all__ = ["MODEL_FILE", "TABLES_FILE", "Adapter", "make_adapter", "variables_for"]

MODEL_FILE = "model.toml"
#: a mode counts for the recommended communication step when a port's rotation holds at least this share of its
#: modal mass (the shipped systems: 0.009 to 0.5 for the modes that move a port, below 1e-4 for the others)
PORT_MODE_SHARE = 1e-3
TABLES_FILE = "tables.h5"


#: builder field names (in error messages) -> the FMU parameters that set them
_FMU_NAME_OF = {"torque_Nm [N*m]": "parameter 'torque' [N.m]", "torque_Nm": "torque",
                "modal_damping_ratio [-]": "parameter 'modal_damping_ratio' [1]",
                "translational_stiffness_N_per_m [N/m]": "bearing_stiffness [N/m]"}
_FMU_NAMES = re.compile("|".join(re.escape(k) for k in sorted(_FMU_NAME_OF, key=len, reverse=True)))


def _fmu_name(attr: str) -> str:
    """The FMU parameter (after ``<mesh>.``) of a :class:`~hacgear_core.model.schema.Mesh` field ``<name>_rad``."""
    return attr.removesuffix("_rad")


def _nice_floor(x: float) -> float:
    """Largest 1, 2 or 5 x 10^k <= x."""
    e = math.floor(math.log10(x))
    for m in (5.0, 2.0, 1.0):
        if m * 10.0 ** e <= x:
            return float(f"{m * 10.0 ** e:.1g}")
    return float(f"{10.0 ** e:.1g}")  # pragma: no cover


def _nice_ceil(x: float) -> float:
    """Smallest 1, 2 or 5 x 10^k >= x."""
    e = math.floor(math.log10(x))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10.0 ** e >= x:
            return float(f"{m * 10.0 ** e:.1g}")
    return float(f"{10.0 ** (e + 1):.1g}")  # pragma: no cover



def tells_flank_from_edge(coupling) -> bool:
    """Whether the tables of a mesh (drive and, where present, coast side) tell flank from tip-edge contact."""
    tabs = [getattr(coupling, "table", None), getattr(coupling, "coast_table", None)]
    tabs = [t for t in tabs if t is not None]
    return bool(tabs) and all(getattr(t, "flank_pressure_Pa", None) is not None
                              and getattr(t, "edge_pressure_Pa", None) is not None for t in tabs)

class Adapter:
    """FMI variables of one gear system and the simulator behind them.

    Parameters
    ----------
    model : Model
    tables : SystemTables
    prepared : dict, optional
        :meth:`prepared` of an adapter of the same model and tables (the lumped system and the nominal values,
        e.g. unpickled from a cache): skips assembling the system.
    """

    def __init__(self, model, tables, prepared: dict | None = None) -> None:
        self.model = model
        self.tables = tables
        self.kind = model.kind
        #: fixed Integer parameters that change the structure (planet count); the outputs cover the largest one
        self.structural = structural_parameters(model) if prepared is None else prepared["structural"]
        big = {p.name: p.max for p in self.structural}
        if prepared is None:
            base = build_system(model, tables)
            spec_system = build_system(model, tables, **big) if big else base
            # ports: the gears that carry external torque in drivetrain coupling (turning members free)
            drive_system = build_system(model, tables, shafts=False, **big)
        else:
            base, spec_system, drive_system = prepared["system"], prepared["spec_system"], prepared["drive_system"]
        self.base_system = base
        self.spec_system = spec_system
        self._drive_system = drive_system
        self.sim = Simulator(base)
        self.bearing_gears = kind_of(model).members(model)
        #: the gears whose runout is a parameter (``<gear>.runout``, ``<gear>.runout_phase``)
        self.runout_gears = error_gears(model)
        #: the meshes whose system mesh runs on a table with a twist axis (helical meshes, spur pairs whose tables
        #: have one; the test of :func:`~hacgear_core.dynamics.lead.check_lead_inputs`), in the model file's order:
        #: their misalignment and axis deviations are parameters (``<mesh>.misalignment_in_plane``, ...)
        twist = {c.name for c in base.meshes if c.t is not None and getattr(getattr(c, "table", None), "twist", None)
                 is not None}
        self.lead_meshes = tuple(m.name for m in model.meshes if m.name in twist)
        #: the gears of :attr:`lead_meshes`, in the model file's order: their lead slope is a parameter
        #: (``<gear>.lead_slope``)
        in_lead = {g for m in model.meshes if m.name in twist for g in (m.gear_a, m.gear_b)}
        self.lead_gears = tuple(g.name for g in model.gears if g.name in in_lead)
        self._built_key = self._key(base.torque_Nm, base.modal_damping_ratio, self._model_bearings(model), None, True,
                                    tuple((p.name, p.start) for p in self.structural), self._model_runouts(model),
                                    self._model_leads(model))
        self.ref = base.reference_gear
        drive_sim = Simulator(drive_system)
        self.ports = drive_sim.ports
        #: nominal torque on each port [N m] in its sense of rotation (the drivetrain coupling's start values)
        self.port_torques_Nm = dict(drive_sim.port_torques_Nm)
        self.ref_ident = ident(self.ref)
        self.port_idents = tuple(ident(g) for g in self.ports)
        self.gear_names = tuple(spec_system.gears)
        self.mesh_names = spec_system.mesh_names
        groups = [c.group for c in spec_system.meshes]
        self.shared_meshes = tuple(c.name for c in spec_system.meshes if c.group and groups.count(c.group) > 1)
        self.gauges = system_gauges(spec_system)
        self._index()
        self.nominal = self._nominals() if prepared is None else prepared["nominal"]
        self.variables = self._spec()
        self.by_name = {v.name: v for v in self.variables}
        #: outputs computed by table post-processing (guarded by the slave: NaN and a log line on failure)
        self.fallible = {v.name for v in self.variables if v.read is not None and v.read.fallible}
        self._last_inputs: tuple | None = None
        self._systems: dict = {self._built_key[:3] + self._built_key[4:]: base}
        #: per mesh: the integration steps beyond its tables so far (the slave warns once per mesh)
        self.out_of_range_reported: set = set()
        self.mode = Experiment.SPEED
        self._start_speed = self.nominal["resonance_speed_rad_s"]
        self.input_checks: tuple = ()
        self.step_floor_s = 0.0

    def prepared(self) -> dict:
        """What a new adapter of the same model and tables can start from (see the ``prepared`` parameter)."""
        return {"system": self.base_system, "spec_system": self.spec_system, "drive_system": self._drive_system,
                "nominal": self.nominal, "structural": self.structural}

    def _model_bearings(self, model) -> tuple:
        """Translational support stiffness [N/m] of every member of :attr:`bearing_gears` (its kind's rule)."""
        kind = kind_of(model)
        return tuple(kind.bearing_stiffness(model, g) for g in self.bearing_gears)

    def _with_bearings(self, bearings: tuple):
        """The model with the translational support stiffnesses ``bearings`` (order of :attr:`bearing_gears`)."""
        return kind_of(self.model).with_bearing_stiffness(self.model, dict(zip(self.bearing_gears, bearings)))

    def _model_runouts(self, model) -> tuple:
        """(runout [m], its phase [rad]) of every gear of :attr:`runout_gears` in ``model`` (0, 0 without errors)."""
        gears = {g.name: g for g in model.gears}
        return tuple((gears[g].errors.runout_m, gears[g].errors.runout_phase_rad) if gears[g].errors is not None
                     else (0.0, 0.0) for g in self.runout_gears)

    def _with_runouts(self, model, runouts: tuple):
        """``model`` with the runouts ``runouts`` (order of :attr:`runout_gears`; each gear's other errors kept)."""
        new = dict(zip(self.runout_gears, runouts))
        return replace(model, gears=tuple(
            g if g.name not in new else replace(g, errors=replace(g.errors or GearErrors(), runout_m=new[g.name][0],
                                                                  runout_phase_rad=new[g.name][1]))
            for g in model.gears))

    def _model_leads(self, model) -> tuple:
        """(lead slopes [m] of :attr:`lead_gears`, (in-plane misalignment, out-of-plane misalignment, axis deviation
        in the plane of the axes, normal to it) [rad] of every mesh of :attr:`lead_meshes`) in ``model``."""
        gears = {g.name: g for g in model.gears}
        meshes = {m.name: m for m in model.meshes}
        return (tuple(gears[g].errors.lead_slope_m if gears[g].errors is not None else 0.0 for g in self.lead_gears),
                tuple(tuple(getattr(meshes[m], attr) for _, attr in MESH_INPUTS) for m in self.lead_meshes))

    def _with_leads(self, model, leads: tuple):
        """``model`` with the lead slopes and mesh inputs ``leads`` (as :meth:`_model_leads` gives them; each gear's
        other errors kept)."""
        slopes, mesh_inputs = leads
        new = dict(zip(self.lead_gears, slopes))
        inputs = dict(zip(self.lead_meshes, mesh_inputs))
        return replace(model, gears=tuple(
            g if g.name not in new else replace(g, errors=replace(g.errors or GearErrors(), lead_slope_m=new[g.name]))
            for g in model.gears), meshes=tuple(
            m if m.name not in inputs else replace(m, **{attr: x for (_, attr), x in zip(MESH_INPUTS,
                                                                                           inputs[m.name])})
            for m in model.meshes))

    def _lead_values(self, values: dict) -> tuple:
        """The lead parameters of ``values`` (FMU names) as :meth:`_model_leads` orders them."""
        return (tuple(float(values[f"{ident(g)}.lead_slope"]) for g in self.lead_gears),
                tuple(tuple(float(values[f"{ident(m)}.{_fmu_name(attr)}"]) for _, attr in MESH_INPUTS)
                      for m in self.lead_meshes))

    def _lead_parameters_set(self, leads: tuple) -> list[str]:
        """``"<name> = <value> <unit>"`` of every lead parameter in ``leads`` that differs from the model file."""
        out = []
        (slopes, inputs), (slopes0, inputs0) = leads, self._model_leads(self.model)
        for g, x, x0 in zip(self.lead_gears, slopes, slopes0):
            if x != x0:
                out.append(f"{ident(g)}.lead_slope = {x:g} m")
        for m, xs, xs0 in zip(self.lead_meshes, inputs, inputs0):
            for (_, attr), x, x0 in zip(MESH_INPUTS, xs, xs0):
                if x != x0:
                    out.append(f"{ident(m)}.{_fmu_name(attr)} = {x:g} rad")
        return out

    @staticmethod
    def _key(torque, zeta, bearings, h, shafts, structure=(), runouts=(), leads=((), ())):
        return (torque, zeta, bearings, h, shafts, structure, runouts, leads)

    def _index(self) -> None:
        """Slots of the spec's meshes and gears in the current simulator (-1: absent in this structure)."""
        sy = self.sim.system
        mi = {c: k for k, c in enumerate(sy.mesh_names)}
        gi = {g: k for k, g in enumerate(self.sim.gear_names)}
        self._mslot = [mi.get(mn, -1) for mn in self.mesh_names]
        self._gslot = [gi.get(g, -1) for g in self.gear_names]
        self._gauge_on = {g: g.partition("/")[0] in sy.gears for g in self.gauges}

    def slot(self, part: str, index) -> int:
        """Slot of mesh or gear ``index`` of the largest structure (``part`` ``"mesh"`` or ``"gear"``) in the
        current simulator, 0 for a gauge ``index`` whose gear it has; -1 where it has none."""
        if part == "mesh":
            return self._mslot[index]
        if part == "gear":
            return self._gslot[index]
        return 0 if self._gauge_on[index] else -1

    # ------------------------------------------------------------------ the spec (declared once)
    def _nominals(self) -> dict:
        """Typical magnitudes of the outputs at the nominal torque (FMI ``nominal``) and the resonance speed of the
        default experiment."""
        sy = self.spec_system
        forces = np.abs(sy.nominal_forces_N())
        defl = np.abs(sy.mean_static_deflections_m())
        out = {"force": [float(f) if f > 0 else None for f in forces],
               "deflection": [float(x) if x > 0 else None for x in defl]}
        # the elastic mode with the largest share of mesh strain energy: its natural frequency as mesh frequency
        w, phi = sy.modal_omega, sy.modal_shapes
        best, fm = -1.0, float(sy.natural_frequencies_Hz()[0])
        for j in np.flatnonzero(~sy.rigid_modes):
            e_mesh = float(np.sum(sy.mesh_stiffness_N_per_m * (sy.V @ phi[:, j]) ** 2))
            e_tot = float(w[j] ** 2 * phi[:, j] @ sy.M @ phi[:, j])
            if e_tot > 0 and e_mesh / e_tot > best:
                best, fm = e_mesh / e_tot, float(w[j] / (2 * math.pi))
        out["pressure"] = self._static_pressures(sy)
        if "twist_moment_Nm" in sy.mesh_law.fields:
            # the static state at the nominal torque: twist moments and the largest tilting moment
            from_eq = Simulator(sy)
            out["twist_moment"] = [abs(float(v)) or None for v in from_eq.twist_moment_Nm]
            out["twist"] = [abs(float(v)) or None for v in from_eq.mesh_twist_rad]
            tilt = [abs(from_eq.support_reaction(f"{g}.theta_{a}")) for g in sy.gears for a in "xy"
                    if f"{g}.theta_{a}" in sy.dof_names]   # the six-DOF (helical) gears
            out["tilting_moment"] = max(tilt, default=0.0) or None
        out["resonance_mesh_frequency_Hz"] = fm
        out["resonance_speed_rad_s"] = sy.reference_speed(fm)
        out["strain"] = {}
        for gauge in self.gauges:
            gear = gauge.partition("/")[0]
            z = sy.gears[gear].teeth if gear in sy.gears else 1
            tau = np.linspace(-0.5 * z, 0.5 * z, 16 * z)[:, None] + np.zeros(sy.m)
            x = np.zeros_like(tau) + defl
            try:
                e = float(np.max(np.abs(strain_of_tooth(sy, gauge, tau, x))))
            except HacgearError:
                e = 0.0
            out["strain"][gauge] = e if e > 0 and math.isfinite(e) else None
        return out

    def default_experiment(self) -> dict:
        """The FMU's DefaultExperiment: constant speed at the mesh resonance (the mesh frequency equals the natural
        frequency of the mode with the largest share of mesh strain energy), long enough for the resonant
        response to build up (>= 10 time constants of its modal damping, >= 40 mesh cycles), with a communication
        step of 1/10 of a mesh period or longer so that the run has at most 1000 steps (fmpy doubles the output
        interval of longer runs): ``startTime``, ``stopTime``, ``stepSize`` [s]."""
        fm = self.nominal["resonance_mesh_frequency_Hz"]
        zeta = max(self.base_system.modal_damping_ratio, 1e-3)
        stop = _nice_ceil(max(10.0 / (zeta * 2 * math.pi * fm), 40.0 / fm))
        step = _nice_floor(max(1.0 / (10.0 * fm), stop / 1000.0))
        return {"startTime": 0.0, "stopTime": stop, "stepSize": step}

    def _spec(self) -> tuple[FmuVariable, ...]:
        sy = self.spec_system
        V = FmuVariable
        ref, inp = self.ref, sy.input_gear
        port_t = self.port_torques_Nm
        nom = self.nominal
        w_res = nom["resonance_speed_rad_s"]
        t_max = RANGES["torque_Nm"].hi
        spec = [
            V("mode", "Integer", "parameter", "fixed", "",
              f"experiment: {int(Experiment.SPEED)} = constant speed (the reference gear {ref} turns at "
              f"{ref}.speed_in, torque set-point = parameter torque); {int(Experiment.TORQUE)} = drivetrain (inputs "
              f"<port>.torque_in on {', '.join(self.ports)}, outputs angles and speeds)", int(Experiment.SPEED),
              int(min(Experiment)), int(max(Experiment))),
        ]
        for p in self.structural:
            spec.append(V(p.name, "Integer", "parameter", "fixed", "", p.description, p.start, p.min, p.max))
        spec += [
            V("torque", "Real", "parameter", "fixed", "N.m",
              f"nominal torque on the input gear {inp}: torque set-point of the constant-speed experiment; in both "
              "modes it sets the linearisation used for the modal damping; negative loads the coast flanks "
              "(not 0)", sy.torque_Nm, nominal=abs(sy.torque_Nm),
              **(dict(min=-t_max, max=t_max) if sy.two_sided else ranged("torque_Nm"))),
            V("modal_damping_ratio", "Real", "parameter", "fixed", "1",
              "modal damping ratio of every elastic mode of the linearised system", sy.modal_damping_ratio,
              **ranged("modal_damping_ratio")),
        ]
        planets = {a for c in sy.meshes for gi, a in c.gear_alias.items() if gi != a}
        for g, k in zip(self.bearing_gears, self._model_bearings(self.model)):
            what = "every planet's bearing on its pin" if g in planets else f"{'the ' if g == 'carrier' else 'gear '}{g}"
            spec.append(V(f"{ident(g)}.bearing_stiffness", "Real", "parameter", "fixed", "N/m",
                          f"translational bearing stiffness of {what}; inf = rigid (no translation DOF), as in model "
                          "files and on the command line; 0 = no bearing (a floating member)",
                          k, display_unit="N/um", **ranged("translational_stiffness_N_per_m")))
        # a gear in a carrier's frame (a planetary set's, or a gearbox's planetary stage's: the body names its
        # stage) turns its runout relative to that carrier; a planet gear's runout is every planet's (the instances
        # aliasing it)
        instances = {a: gi for c in sy.meshes for gi, a in c.gear_alias.items()}
        for g, (e, phase) in zip(self.runout_gears, self._model_runouts(self.model)):
            body = g if g in sy.gears else instances.get(g)
            stage = sy.gears[body].stage if body is not None else ""
            what = f"gear {g}"
            if g in planets:
                what = f"every planet of stage {stage} (gear {g})" if stage else f"every planet (gear {g})"
            sense = ""
            if body is not None and sy.frame_ratio(body) != 0.0:
                sense = f" relative to the carrier of stage {stage}" if stage else " relative to the carrier"
            spec += [
                V(f"{ident(g)}.runout", "Real", "parameter", "fixed", "m",
                  f"runout of {what}: eccentricity of its teeth about its axis (the model file's "
                  "[gears.errors] runout_um; its other errors stay as the model file gives them)", e, 0.0, 1e-3,
                  display_unit="um"),
                V(f"{ident(g)}.runout_phase", "Real", "parameter", "fixed", "rad",
                  f"direction of the runout of {what} from its tooth 0's centre line, in its sense of rotation"
                  f"{sense} (runout_phase_deg)", phase, -2 * math.pi, 2 * math.pi, display_unit="deg"),
            ]
        # lead slopes and shaft misalignment: constant offsets of the twist of the meshes whose tables have a twist
        # axis (hacgear_core.dynamics.lead)
        meshes = {m.name: m for m in self.model.meshes}
        of_gear = {g: [m for m in self.lead_meshes if g in (meshes[m].gear_a, meshes[m].gear_b)]
                   for g in self.lead_gears}
        slopes, mesh_inputs = self._model_leads(self.model)
        for g, f in zip(self.lead_gears, slopes):
            ms = " and ".join(of_gear[g])
            spec.append(V(f"{ident(g)}.lead_slope", "Real", "parameter", "fixed", "m",
                          f"lead slope deviation f_Hbeta of gear {g}: of the flank it loads in mesh {ms}, over its "
                          "own face width, along the transverse line of action; positive: material added at its +z "
                          "face end (the model file's [gears.errors] lead_slope_um; its other errors stay as the "
                          f"model file gives them); acts as an offset of the mesh twist of {ms}", f, -1e-3, 1e-3,
                          display_unit="um"))
        for mn, xs in zip(self.lead_meshes, mesh_inputs):
            m = meshes[mn]
            what = {
                "misalignment_in_plane_rad":
                    f"in-plane shaft misalignment of mesh {mn}: the installed relative tilt of the axes of {m.gear_a} "
                    f"and {m.gear_b} in the plane of action, the rotation (theta_{m.gear_a} - theta_{m.gear_b}) . e1 "
                    "about the normal e1 to the plane of action (the sign of the mesh twist: positive closes the "
                    "flanks at the -z end of the face); acts as an offset of the mesh twist",
                "misalignment_out_of_plane_rad":
                    f"out-of-plane shaft misalignment of mesh {mn}: the installed rotation of {m.gear_b}'s axis "
                    f"relative to {m.gear_a}'s about the transverse line of action e2 = z x e1 (positive: "
                    "right-handed about e2); acts as an offset "
                    "of the coast flanks' mesh twist (second order on the drive flanks, not modelled there)",
                "axis_deviation_in_axes_plane_rad":
                    f"axis parallelism deviation f_Sigma_delta of mesh {mn} (ISO 10064-4: the deviation over the "
                    f"bearing span divided by the span): the rotation of {m.gear_b}'s axis relative to {m.gear_a}'s "
                    f"about the normal to the plane of the axes (positive: the +z end of {m.gear_b}'s axis away "
                    f"from {m.gear_a}); its share about the normal to the plane of action acts as an offset of the "
                    "mesh twist",
                "axis_deviation_normal_to_axes_plane_rad":
                    f"axis parallelism deviation f_Sigma_beta of mesh {mn} (ISO 10064-4: the deviation over the "
                    f"bearing span divided by the span): the rotation of {m.gear_b}'s axis relative to {m.gear_a}'s "
                    f"about the line of centres (positive: right-handed about the direction from {m.gear_a} to "
                    f"{m.gear_b}); its share about the normal to the plane of action acts as an offset of the mesh "
                    "twist",
            }
            for (key, attr), x in zip(MESH_INPUTS, xs):
                spec.append(V(f"{ident(mn)}.{_fmu_name(attr)}", "Real", "parameter", "fixed", "rad",
                              f"{what[attr]} (the model file's [[meshes]] {key}, there in urad)", x, -0.01, 0.01))
        spec += [
            V("internal_step", "Real", "parameter", "fixed", "s",
              "largest internal RK4 step; 0 = automatic (mesh period / 128 at the current speed and 1/32 of the "
              "period of the highest natural frequency); doStep sub-steps any communication step with equal steps "
              "no larger than this", 0.0, 0.0, 1e-3),
            V(f"{ident(ref)}.speed_start", "Real", "parameter", "fixed", "rad/s",
              f"drivetrain mode: initial speed of gear {ref} in its sense of rotation (constant-speed mode starts at "
              f"{ref}.speed_in); default: the mesh resonance", w_res, display_unit="rpm", nominal=w_res,
              **ranged("speed_rad_s")),
            V(f"{ident(ref)}.speed_in", "Real", "input", "continuous", "rad/s",
              f"constant-speed mode: imposed speed of gear {ref}, positive in its sense of rotation (ignored in "
              "drivetrain mode); default: the mesh resonance", w_res, display_unit="rpm", nominal=w_res,
              **ranged("speed_rad_s")),
        ]
        for g in self.ports:
            role = "driving (positive)" if g == inp else "a braking load is negative"
            # the torque range of the input gear, carried through the train: a slower port holds more torque
            t_port = t_max * max(1.0, 1.0 / abs(self.speed_ratio(g)))
            spec.append(V(f"{ident(g)}.torque_in", "Real", "input", "continuous", "N.m",
                          f"drivetrain mode: shaft torque on gear {g}, positive in its sense of rotation ({role}); "
                          f"range: the torque range times the gear's speed ratio to the input where it turns slower",
                          port_t[g], -t_port, t_port, nominal=abs(port_t[g]) or None))
        pressure = nom["pressure"]
        for k, mn in enumerate(self.mesh_names):
            c = sy.meshes[k]
            m_ = ident(mn)
            f_nom, x_nom = nom["force"][k], nom["deflection"][k]

            def at(attr, k=k):   # a per-mesh attribute of the simulator
                return Reading(attr=attr, part="mesh", index=k)

            def by(call, k=k, absent=0.0, fallible=False):   # a per-mesh value computed by the simulator
                return Reading(call=call, part="mesh", index=k, absent=absent, fallible=fallible)

            spec += [
                V(f"{m_}.force", "Real", "output", "continuous", "N",
                  f"dynamic mesh force of mesh {mn} ({c.gear_a}-{c.gear_b}) along its line of action "
                  "(0 = contact loss)", display_unit="kN", nominal=f_nom, read=at("mesh_force_N")),
                V(f"{m_}.deflection", "Real", "output", "continuous", "m",
                  f"mesh deflection of mesh {mn}: approach of the loaded flanks along the line of action "
                  "(dissertation Eqs. 3.4, 4.4)", display_unit="um", nominal=x_nom, read=at("mesh_deflection_m")),
                V(f"{m_}.dte", "Real", "output", "continuous", "m",
                  f"dynamic transmission error of mesh {mn}: rotational part of its mesh deflection",
                  display_unit="um", nominal=x_nom, read=at("dynamic_transmission_error_m")),
                V(f"{m_}.position", "Real", "output", "continuous", "1",
                  f"mesh position of mesh {mn} in mesh cycles (integer = pitch-point contact of a tooth pair), "
                  "unwrapped", nominal=1.0, read=at("mesh_position")),
                V(f"{m_}.contact", "Enumeration", "output", "discrete", "",
                  f"contact state of mesh {mn} at the end of the step: drive flanks, coast flanks (across the "
                  "backlash), or separated (in the backlash)", declared_type="ContactState",
                  read=by(lambda s, j: int(s.contact_state[j]), absent=int(ContactState.SEPARATED))),
                V(f"{m_}.contact_code", "Integer", "output", "discrete", "",
                  f"{m_}.contact as an Integer, for masters that read no Enumeration: 0 = separated (in the "
                  "backlash), 1 = drive flanks, 2 = coast flanks (across the backlash)",
                  read=by(lambda s, j: int(s.contact_state[j]), absent=int(ContactState.SEPARATED))),
                V(f"{m_}.peak_pressure", "Real", "output", "continuous", "Pa",
                  f"maximum contact pressure over all teeth of mesh {mn} on the flanks in contact, drive or coast "
                  "(table lookup)", display_unit="MPa",
                  nominal=pressure[k], read=by(lambda s, j: s.peak_pressure_Pa(j), fallible=True)),
            ]
            if tells_flank_from_edge(c):   # tables that tell flank from tip-edge contact
                spec += [
                    V(f"{m_}.flank_pressure", "Real", "output", "continuous", "Pa",
                      f"maximum flank (Hertzian) contact pressure over all teeth of mesh {mn} on the flanks in "
                      f"contact (table lookup); above {STEEL_PRESSURE_LIMIT_PA / 1e9:g} GPa no gear steel carries it",
                      display_unit="MPa", nominal=pressure[k],
                      read=by(lambda s, j: s.peak_pressure_Pa(j, "flank"), fallible=True)),
                    V(f"{m_}.edge_pressure", "Real", "output", "continuous", "Pa",
                      f"maximum tip-edge contact pressure over all teeth of mesh {mn} (a tip corner on the mating "
                      "flank, off the line of action; 0 without such contact): its value is set by the edge radius "
                      "(0.1 mm taken for a sharp corner), not a flank stress", display_unit="MPa",
                      nominal=pressure[k], read=by(lambda s, j: s.peak_pressure_Pa(j, "edge"), fallible=True)),
                ]
            spec += [
                V(f"{m_}.out_of_range", "Boolean", "output", "discrete", "",
                  f"true once the state of mesh {mn} has left its tables' deflection range (forces, pressures and "
                  "strains there are extrapolated; logged once as a warning)",
                  read=by(lambda s, j: s.out_of_range_steps[j] > 0, absent=False)),
            ]
            if c.v_c is not None:
                spec += [
                    V(f"{m_}.coast_force", "Real", "output", "continuous", "N",
                      f"dynamic force on the coast flanks of mesh {mn} along the coast line of action (after the "
                      "torque reverses or the teeth cross the backlash; 0 otherwise)", display_unit="kN",
                      nominal=f_nom, read=at("coast_force_N")),
                    V(f"{m_}.backlash_position", "Real", "output", "continuous", "1",
                      f"where the teeth of mesh {mn} are in the backlash: 0 at the drive flanks' kinematic contact, "
                      f"1 where ideal coast flanks touch (coast approach over the normal backlash "
                      f"{c.backlash_m * 1e6:.4g} µm)", nominal=1.0, read=at("backlash_position")),
                ]
            if c.t is not None:   # helical mesh (docs/helical.md): twist and twist moment
                spec += [
                    V(f"{m_}.twist_moment", "Real", "output", "continuous", "N.m",
                      f"twist moment M of mesh {mn}: generalized force on the mesh twist (f_d = W r_mesh + M r_twist; "
                      "table lookup over position, deflection and twist)", nominal=nom.get("twist_moment", [None])[k],
                      read=at("twist_moment_Nm")),
                    V(f"{m_}.twist", "Real", "output", "continuous", "rad",
                      f"mesh twist of mesh {mn}: relative rotation of the gears about the normal to the plane of "
                      "action (gamma = r_twist . q)", nominal=nom.get("twist", [None])[k],
                      read=at("mesh_twist_rad")),
                ]
            if mn in self.shared_meshes:
                spec.append(V(f"{m_}.load_share", "Real", "output", "continuous", "1",
                              f"load-sharing factor of mesh {mn}: its force over the mean force of the meshes of "
                              f"kind {c.group} (1 = equal sharing; 0 while every mesh of that kind is separated)",
                              nominal=1.0,
                              read=by(lambda s, j: s.load_share(j))))
        f_max = max((f for f in nom["force"] if f), default=None)
        for i, g in enumerate(self.gear_names):
            g_ = ident(g)
            w_nom = abs(sy.gears[g].speed_ratio) * w_res or None

            def on(attr=None, call=None, i=i):   # a per-gear attribute or value of the simulator
                return Reading(attr=attr or "", call=call, part="gear", index=i)

            def reaction(dof):   # support reaction of the gear's DOF ``dof`` (x, y, z, theta_x, ...)
                return on(call=lambda s, j: s.support_reaction(f"{s.gear_names[j]}.{dof}"))

            spec += [
                V(f"{g_}.angle", "Real", "output", "continuous", "rad",
                  f"rotation angle of gear {g} in its sense of rotation", display_unit="deg", read=on("angle_rad")),
                V(f"{g_}.speed", "Real", "output", "continuous", "rad/s", f"speed of gear {g} in its sense of rotation",
                  display_unit="rpm", nominal=w_nom, read=on("speed_rad_s")),
                V(f"{g_}.bearing_force_x", "Real", "output", "continuous", "N",
                  f"force of gear {g} on its bearing, x component (fixed frame of the model's gear placement)",
                  display_unit="kN", nominal=f_max,
                  read=on(call=lambda s, j: float(s.bearing_force_N(s.gear_names[j])[0]))),
                V(f"{g_}.bearing_force_y", "Real", "output", "continuous", "N",
                  f"force of gear {g} on its bearing, y component (fixed frame)", display_unit="kN", nominal=f_max,
                  read=on(call=lambda s, j: float(s.bearing_force_N(s.gear_names[j])[1]))),
            ]
            if f"{g}.theta_x" in sy.dof_names:   # six-DOF gears: axial force and tilting moments on the bearing
                spec += [
                    V(f"{g_}.bearing_force_z", "Real", "output", "continuous", "N",
                      f"axial force of gear {g} on its bearing (z along the axes; axial support spring)",
                      display_unit="kN", nominal=f_max, read=reaction("z")),
                    V(f"{g_}.bearing_moment_x", "Real", "output", "continuous", "N.m",
                      f"tilting moment of gear {g} on its bearing about x (line of centres; tilting support spring)",
                      nominal=nom.get("tilting_moment"), read=reaction("theta_x")),
                    V(f"{g_}.bearing_moment_y", "Real", "output", "continuous", "N.m",
                      f"tilting moment of gear {g} on its bearing about y (tilting support spring)",
                      nominal=nom.get("tilting_moment"), read=reaction("theta_y")),
                ]
        for gauge in self.gauges:
            gear, _, gname = gauge.partition("/")
            z = sy.gears[gear].teeth if gear in sy.gears else 0
            spec.append(V(f"{ident(gear)}.{ident(gname or gear)}.root_strain", "Real", "output", "continuous", "1",
                          f"root strain at gauge '{gauge}' of tooth 0 of {gear} (in mesh every {z} mesh cycles, "
                          "all its meshes superposed; table lookup)", display_unit="um/m", nominal=nom["strain"][gauge],
                          read=Reading(call=lambda s, _, key=gauge: s.strain(key), part="gauge", index=gauge,
                                       fallible=True)))
        # the outputs the model's kind adds (:meth:`~hacgear_core.kinds.base.Kind.extra_outputs`)
        for extra in kind_of(self.kind).extra_outputs(self.model, sy):
            spec.append(V(extra.name, "Real", "output", "continuous", extra.unit, extra.description,
                          read=Reading(call=lambda s, _, read=extra.read: float(read(s)))))
        spec += self._coupling_spec()
        names = [v.name for v in spec]
        if len(set(names)) != len(names):
            raise ModelError(f"FMU variable names are not unique: {names}")
        return tuple(spec)

    def _coupling_spec(self) -> list[FmuVariable]:
        """What a drivetrain coupling needs: per port its speed ratio, own and train inertia (calculated
        parameters), the recommended communication step, and the energy flows (port powers, dissipated power,
        kinetic and elastic energy) that close the balance ``sum of port powers - dissipated power = d(kinetic +
        elastic energy)/dt``."""
        sy = self.spec_system
        V = FmuVariable
        inp = sy.input_gear
        w_res = self.nominal["resonance_speed_rad_s"]
        p_nom = abs(self.port_torques_Nm[inp] * w_res) or None
        out = []
        free = self._drive_system   # the ports' nominal inertias: of the free train (a port held at constant speed
        for g in self.ports:        # has no rotation in the constant-speed system)
            g_ = ident(g)
            rot = free.gears[g].rotation
            out += [
                V(f"{g_}.speed_ratio", "Real", "calculatedParameter", "fixed", "1",
                  f"speed of gear {g} over the speed of the input gear {inp}, each in its own sense of rotation "
                  "(rigid train)", read=Reading(call=lambda s, _, g=g: self.speed_ratio(g))),
                V(f"{g_}.inertia", "Real", "calculatedParameter", "fixed", "kg.m2",
                  f"moment of inertia of gear {g} about its axis (its own body, as the lumped model holds it)",
                  nominal=float(free.M[rot, rot]), read=Reading(call=lambda s, _, g=g: self.inertia(self.free_system(), g))),
                V(f"{g_}.train_inertia", "Real", "calculatedParameter", "fixed", "kg.m2",
                  f"moment of inertia of the whole rigid train referred to gear {g}: sum of J_i (w_i/w_{g_})^2 "
                  f"(what a shaft on {g} accelerates)", nominal=self.train_inertia(free, g),
                  read=Reading(call=lambda s, _, g=g: self.train_inertia(self.free_system(), g))),
            ]
        if len(self.ports) == 2:
            o = next(g for g in self.ports if g != inp)
            out.append(V("gear_ratio", "Real", "calculatedParameter", "fixed", "1",
                         f"gear ratio i = w_{ident(inp)} / w_{ident(o)} (input over output speed, rigid train)",
                         read=Reading(call=lambda s, _, o=o: 1.0 / self.speed_ratio(o))))
        out.append(V("drivetrain_step", "Real", "calculatedParameter", "fixed", "s",
                     "recommended largest communication step in drivetrain mode: 1/20 of the period of the highest "
                     "natural frequency of the free train in which a port moves and 1/10 of the mesh period at "
                     f"{self.ref_ident}.speed_start, rounded down to 1, 2 or 5 x 10^k (a coarser step samples the "
                     "port motion too seldom: spurious force peaks, states beyond the tables)",
                     read=Reading(call=lambda s, _: self.drivetrain_step())))
        for g in self.ports:
            g_ = ident(g)
            out.append(V(f"{g_}.power", "Real", "output", "continuous", "W",
                         f"power into the FMU at gear {g}: the torque on it during the last step ({g_}.torque_in in "
                         "drivetrain mode; at constant speed the torque set-point's load on it, 0 where its shaft "
                         "holds it) times its speed at the step's end (negative: power leaves, e.g. into a load)", display_unit="kW",
                         nominal=p_nom, read=Reading(call=lambda s, _, g=g: s.port_power_W(g))))
        out += [
            V("dissipated_power", "Real", "output", "continuous", "W",
              "power dissipated by the modal damping at the step's end (>= 0)", display_unit="kW", nominal=p_nom,
              read=Reading(call=lambda s, _: s.dissipated_power_W())),
            V("kinetic_energy", "Real", "output", "continuous", "J",
              "kinetic energy of the gears (absolute motion) at the step's end", display_unit="kJ",
              read=Reading(call=lambda s, _: s.kinetic_energy_J())),
            V("elastic_energy", "Real", "output", "continuous", "J",
              "potential energy at the step's end: mesh strain energy, bearing and shaft springs (and the "
              "centrifugal potential of a rotating carrier frame); in drivetrain mode sum of <port>.power - "
              "dissipated_power = d(kinetic_energy + elastic_energy)/dt",
              read=Reading(call=lambda s, _: s.elastic_energy_J())),
        ]
        return out

    def speed_ratio(self, gear: str) -> float:
        """Speed of ``gear`` over the input gear's, each in its own sense of rotation (rigid train)."""
        gs = self.spec_system.gears
        g, i = gs[gear], gs[self.spec_system.input_gear]
        return (g.sense * g.speed_ratio) / (i.sense * i.speed_ratio)

    def free_system(self):
        """The free train (no shafts: the system that runs in drivetrain mode) of the parameters configured now."""
        k = self._built_key
        return self.sim.system if not k[4] else self._system(k[:4] + (False,) + k[5:])

    @staticmethod
    def inertia(system, gear: str) -> float:
        """Moment of inertia [kg m^2] of ``gear`` about its axis in ``system``."""
        r = system.gears[gear].rotation
        return float(system.M[r, r])

    @staticmethod
    def train_inertia(system, gear: str) -> float:
        """Moment of inertia [kg m^2] of the rigid train of ``system`` referred to ``gear``: ``u^T M u / u_g^2``
        with ``u`` the reference motion."""
        u = system.reference_motion
        ug = u[system.gears[gear].rotation]
        return float(u @ system.M @ u / (ug * ug))

    def drivetrain_step(self) -> float:
        """The recommended largest communication step [s] in drivetrain mode (see ``drivetrain_step``) of the
        parameters configured now."""
        sy = self.free_system()
        f = 0.0
        phi = sy.modal_shapes
        rots = [sy.gears[g].rotation for g in self.ports if g in sy.gears]
        for j in np.flatnonzero(~sy.rigid_modes):
            share = max(sy.M[r, r] * phi[r, j] ** 2 for r in rots)   # modal mass share of a port's rotation
            if share >= PORT_MODE_SHARE:
                f = max(f, float(sy.modal_omega[j]) / (2 * math.pi))
        bounds = [1.0 / (20.0 * f)] if f > 0 else []
        w0 = abs(float(self._start_speed))
        if w0 > 0:
            bounds.append(1.0 / (10.0 * w0 * sy.zref_2pi))
        return _nice_floor(min(bounds)) if bounds else 1e-4

    @staticmethod
    def _static_pressures(sy) -> list:
        sim = Simulator(sy)
        out = []
        for k in range(sy.m):
            try:
                p = float(sim.peak_pressure_Pa(k))
            except HacgearError:
                p = 0.0
            out.append(p if p > 0 and math.isfinite(p) else None)
        return out

    # ------------------------------------------------------------------ outputs
    def output_expressions(self) -> dict[str, str]:
        """Output name -> Python expression of its value in terms of ``s`` (the simulator) for the outputs read
        from a simulator attribute (:func:`~hacgear_core.fmu.spec.output_expressions` of the declarations)."""
        return output_expressions(self.variables, self)

    def getters(self) -> dict[str, Callable[[], float | int | bool]]:
        """Output name -> zero-argument getter of its current value (:func:`~hacgear_core.fmu.spec.output_getters`
        of the declarations); outputs of meshes, gears and gauges the current structure does not have (planets
        beyond ``planet_count``) read their ``absent`` value."""
        return output_getters(self.variables, self)

    def out_of_range_meshes(self) -> list[str]:
        """Meshes whose state has left their tables' deflection range and that were not reported yet (the slave
        logs one warning per mesh and reports each once)."""
        new = [mn for j, mn in enumerate(self.mesh_names)
               if self._mslot[j] >= 0 and self.sim.out_of_range_steps[self._mslot[j]] > 0
               and mn not in self.out_of_range_reported]
        self.out_of_range_reported.update(new)
        return new

    # ------------------------------------------------------------------ configuration
    def configure(self, values: dict) -> None:
        """(Re)build the simulator for the parameter ``values`` and put it at its initial state.

        Raises
        ------
        ModelError
            Parameters that the model cannot take (message names field, unit, range).
        """
        mode = Experiment(int(values["mode"]))
        shafts = mode == Experiment.SPEED
        bearings = tuple(float(values[f"{ident(g)}.bearing_stiffness"]) for g in self.bearing_gears)
        h = float(values["internal_step"]) or None
        structure = tuple((p.name, int(values[p.name])) for p in self.structural)
        runouts = tuple((float(values[f"{ident(g)}.runout"]), float(values[f"{ident(g)}.runout_phase"]))
                        for g in self.runout_gears)
        key = self._key(float(values["torque"]), float(values["modal_damping_ratio"]), bearings, h, shafts, structure,
                        runouts, self._lead_values(values))
        if key != self._built_key:
            system = self._system(key)
            self.sim = Simulator(system, internal_step_s=h)
            self._built_key = key
            self._index()
        self.out_of_range_reported = set()
        self.mode = mode
        ref = ident(self.ref)
        self._start_speed = float(values[f"{ref}.speed_start"])
        if self.mode == Experiment.SPEED:
            self.sim.reset(speed_rad_s=float(values[f"{ref}.speed_in"]))
        else:
            self.sim.reset(speed_rad_s=float(values[f"{ref}.speed_start"]))
            self.sim.set_torque_inputs({g: float(values[f"{ident(g)}.torque_in"]) for g in self.ports})
        self._last_inputs = None
        self.apply_inputs(values)
        names = ((f"{ref}.speed_in",) if self.mode == Experiment.SPEED
                 else tuple(f"{ident(g)}.torque_in" for g in self.ports))
        self.input_checks = tuple((n, self.by_name[n].min, self.by_name[n].max) for n in names)
        self._input_names = names
        # a lower bound of the internal step at any allowed speed (the exact one is asked only for long steps)
        sy = self.sim.system
        v = self.by_name[f"{ref}.speed_in"]
        fm_max = 4.0 * max(abs(v.min), abs(v.max)) * sy.zref_2pi  # mesh frequency bound, margin for vibration [Hz]
        floor = min(1.0 / (32.0 * sy.max_frequency_Hz), 1.0 / (128.0 * fm_max))
        self.step_floor_s = min(floor, h) if h else floor

    def _system(self, key: tuple):
        """The lumped system of the configuration ``key`` (:meth:`_key`), assembled or from the last few kept (masters
        that reset and re-initialize do not assemble them again)."""
        torque, zeta, bearings, _, shafts, structure, runouts, leads = key
        skey = key[:3] + key[4:]  # the lumped system does not depend on the internal step
        system = self._systems.pop(skey, None)
        if system is None:
            model = self.model
            if bearings != self._model_bearings(model):
                model = self._with_bearings(bearings)
            if runouts != self._model_runouts(model):
                model = self._with_runouts(model, runouts)
            if leads != self._model_leads(model):
                model = self._with_leads(model, leads)
            try:
                system = build_system(model, self.tables, torque_Nm=torque, modal_damping_ratio=zeta, shafts=shafts,
                                      **dict(structure))
            except ModelError as exc:  # the builder's field names -> this FMU's parameter names
                msg = _FMU_NAMES.sub(lambda mt: _FMU_NAME_OF[mt.group(0)], str(exc))
                changed = self._lead_parameters_set(leads)
                if changed and "mesh twist" in msg:  # an offset of the mesh twist the tables cannot take
                    msg = f"parameters {', '.join(changed)} (offsets of the mesh twist): {msg}"
                raise ModelError(msg) from None
        self._systems[skey] = system
        while len(self._systems) > 8:
            self._systems.pop(next(iter(self._systems)))
        return system

    def active_inputs(self, values: dict) -> tuple[str, ...]:
        """The inputs the experiment chosen in ``values`` reads (checked when initialization ends)."""
        if int(values["mode"]) == Experiment.SPEED:
            return (f"{self.ref_ident}.speed_in",)
        return tuple(f"{p}.torque_in" for p in self.port_idents)

    def input_names(self) -> tuple[str, ...]:
        """Inputs read in the current mode (only these are checked and applied)."""
        return tuple(n for n, _, _ in self.input_checks)

    def apply_inputs(self, values: dict) -> None:
        """Hand the current inputs to the simulator (only when they changed)."""
        if self.mode == Experiment.SPEED:
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

    # ------------------------------------------------------------------ state snapshots (FMI get/set FMU state)
    def get_state(self) -> dict:
        """Snapshot of everything a later :meth:`advance` and the outputs depend on (the simulator's own
        :meth:`~hacgear_core.dynamics.simulator.Simulator.get_state`, the experiment and the last inputs)."""
        return {"sim": self.sim.get_state(), "mode": self.mode, "last_inputs": self._last_inputs}

    def set_state(self, snap: dict) -> None:
        """Restore a :meth:`get_state` snapshot taken with the same parameters (the caller configures first)."""
        self.sim.set_state(snap["sim"])
        self.mode = Experiment(snap["mode"])
        li = snap["last_inputs"]
        self._last_inputs = None if li is None else tuple(li)


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


def _resources_sha256(resources: str | Path) -> str:
    """SHA-256 (hex) over the bytes of the model file and the tables file in ``resources``: what a cached adapter
    (:func:`make_adapter`) was prepared from."""
    h = hashlib.sha256()
    for name in (MODEL_FILE, TABLES_FILE):
        with open(Path(resources) / name, "rb") as f:
            h.update(hashlib.file_digest(f, "sha256").digest())
    return h.hexdigest()


def make_adapter(resources: str | Path, cache_file: str | Path | None = None) -> Adapter:
    """The adapter of the system in ``resources`` (see :func:`load_resources`).

    ``cache_file``: where the tables, the assembled lumped system and the nominal values are kept between
    processes (pickle; read when present, written when not; unreadable or unwritable files are ignored): the key
    must identify the model, the tables and the code (an FMU's GUID does).  The cached tables are used only
    while the model and tables files hold the bytes they were read from (:func:`_resources_sha256`); otherwise
    the files are read (and checked) again.
    """
    resources = Path(resources)
    digest = None
    if cache_file is not None:
        path = Path(cache_file)
        try:
            digest = _resources_sha256(resources)
            with open(path, "rb") as f:  # streamed: no copy of the whole file in memory
                prepared = pickle.load(f)
            if prepared["resources_sha256"] == digest:
                return Adapter(load_model(resources / MODEL_FILE), replace(prepared["tables"], path=resources /
                                                                           TABLES_FILE), prepared=prepared)
        except Exception:  # no cache yet, or one that does not fit: read and assemble
            pass
    model, tables = load_resources(resources)
    adapter = Adapter(model, tables)
    if cache_file is not None and digest is not None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.name}.{os.getpid()}")
            with open(tmp, "wb") as f:
                pickle.dump(adapter.prepared() | {"tables": tables, "resources_sha256": digest}, f,
                            protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, path)
        except OSError:
            pass
    return adapter


def variables_for(resources: str | Path) -> tuple[FmuVariable, ...]:
    """The variable spec of the system in ``resources`` (what the slave registers)."""
    return make_adapter(resources).variables
