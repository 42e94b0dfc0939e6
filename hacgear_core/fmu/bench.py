"""Drivetrain benches: motor -> shaft -> gear stage(s) -> shaft -> load, ramped through the mesh resonances.

The gear stages are hacgear FMUs in drivetrain mode (``mode = 1``: shaft torques in on their port gears,
gear angles and speeds out); motor, shafts and load are the components of :mod:`~hacgear_core.fmu.components`.
A stage's output gear drives the next stage's input gear through a shaft; the last stage's output drives the
load.  :func:`drivetrain_layout` gives the components, their parameters and the connections of any number of
stages (a spur or idler stage, a planetary stage: whatever FMU has one input and one output port), so swapping a
stage is changing one path in the list.

Every component advances one communication step with the inputs held over the step, and the outputs at the end
of the step are passed on for the next step (the fixed-step co-simulation scheme of FMI masters such as
libcosim).  :func:`run_drivetrain_bench` runs that scheme in Python (the components as Python objects, the stages
through fmpy's low-level API); :mod:`hacgear_core.fmu.ssp` writes the same bench as an SSP file of FMUs and runs
it under fmpy or libcosim with the same results.
"""
from __future__ import annotations

import contextlib

import json
import math
import shutil
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from hacgear_core.encodings import ContactState, Experiment
from hacgear_core.fmu.components import COMPONENTS
from hacgear_core.fmu.slave import FMU_INFO_FILE

__all__ = ["BenchConfig", "Layout", "drivetrain_layout", "run_drivetrain_bench", "run_layout", "plot_bench", "plot_stages",
           "stage_info", "PythonComponent", "FmuComponent"]


@dataclass(frozen=True)
class BenchConfig:
    """Drivetrain bench parameters (SI; speeds of the first stage's input gear in rpm where named so).
    ``load_torque_Nm``: braking torque on the output shaft; None: the last stage's nominal output torque.
    ``shaft1``: motor - first stage; ``shaft2``: last stage - load; ``coupling_shaft``: between stages.
    ``step_s``: communication step; 2e-5 s resolves the shafts on the gears' small inertias (omega h ~ 0.1; at 1e-4 s
    the explicit coupling distorts the response: peak 5.2 instead of 2.65 x the static mesh force of spur_28t_asym)."""

    speed_start_rpm: float = 4000.0
    speed_end_rpm: float = 7500.0
    ramp_s: float = 1.5
    hold_s: float = 0.05
    step_s: float = 2e-5
    motor_inertia_kg_m2: float = 0.05
    load_inertia_kg_m2: float = 0.2
    shaft1_stiffness_Nm_per_rad: float = 2.0e4
    shaft2_stiffness_Nm_per_rad: float = 2.0e4
    coupling_shaft_stiffness_Nm_per_rad: float = 5.0e4
    shaft_damping_ratio: float = 0.05
    load_torque_Nm: float | None = None
    controller_bandwidth_Hz: float = 10.0
    motor_torque_limit_Nm: float = 2000.0
    internal_step_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("ramp_s", "step_s", "motor_inertia_kg_m2", "load_inertia_kg_m2", "shaft1_stiffness_Nm_per_rad",
                     "shaft2_stiffness_Nm_per_rad", "coupling_shaft_stiffness_Nm_per_rad", "controller_bandwidth_Hz",
                     "motor_torque_limit_Nm"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be finite and > 0, got {v!r}")
        if not (0 < self.speed_start_rpm < 2e5 and 0 < self.speed_end_rpm < 2e5):
            raise ValueError("speed_start_rpm and speed_end_rpm [rpm] must be in (0, 2e5)")
        if not (0 <= self.shaft_damping_ratio < 1 and 0 <= self.hold_s and 0 <= self.internal_step_s <= 1e-3):
            raise ValueError("shaft_damping_ratio [-] must be in [0, 1), hold_s [s] >= 0, internal_step_s [s] in "
                             "[0, 1e-3]")

    @property
    def steps(self) -> int:
        """Communication steps of a run (hold, ramp, hold)."""
        return int(round((self.ramp_s + 2 * self.hold_s) / self.step_s))


def stage_info(fmu_path: str | Path) -> dict:
    """The hacgear_fmu.json of a gear-stage FMU, with ``input`` / ``output`` port names and ``ratio`` (output speed
    over input speed, each in its own sense) added."""
    with zipfile.ZipFile(fmu_path) as z:
        info = json.loads(z.read(f"resources/{FMU_INFO_FILE}"))
    ports = info.get("ports", {})
    inp = info.get("input_gear")
    outs = [g for g in ports if g != inp]
    if inp not in ports or len(outs) != 1:
        raise ValueError(f"{Path(fmu_path).name}: a bench stage needs one input and one output port; this FMU has "
                         f"ports {sorted(ports)}")
    info["input"], info["output"] = inp, outs[0]
    info["ratio"] = abs(ports[outs[0]]["speed_ratio"]) / abs(ports[inp]["speed_ratio"])
    return info


@dataclass
class Layout:
    """A drivetrain: ``components`` name -> (kind, parameters) for motor/shafts/load, ``stages`` name -> (FMU path,
    start values), ``connections`` (source component, variable, destination component, variable), ``record``
    (component, variable) pairs to record, ``static`` torques and speeds of the initial state, ``infos`` of the
    stages."""

    components: dict
    stages: dict
    connections: list
    record: list
    static: dict
    infos: dict


def drivetrain_layout(stage_fmus, cfg: BenchConfig = BenchConfig()) -> Layout:
    """The bench of ``stage_fmus`` (one or more gear-stage FMU paths, first driven by the motor, last driving the
    load): everything at the start speed, shafts preloaded (their static twist) to carry the static torques of the load torque."""
    paths = [Path(p) for p in ([stage_fmus] if isinstance(stage_fmus, (str, Path)) else stage_fmus)]
    if not paths:
        raise ValueError("the bench needs at least one gear stage")
    infos = [stage_info(p) for p in paths]
    names = [f"stage{k + 1}" for k in range(len(paths))]
    # static torques: the load torque through the chain (each stage at its nominal torque ratio)
    last = infos[-1]
    t_out_nom = last["ports"][last["output"]]["nominal_torque_Nm"]  # negative: a braking load
    t_load = -t_out_nom if cfg.load_torque_Nm is None else float(cfg.load_torque_Nm)
    t_in, t_out = [0.0] * len(infos), [0.0] * len(infos)
    carried = t_load  # torque the stage's output shaft brakes with
    for k in range(len(infos) - 1, -1, -1):
        ports = infos[k]["ports"]
        ti, to = ports[infos[k]["input"]]["nominal_torque_Nm"], ports[infos[k]["output"]]["nominal_torque_Nm"]
        t_out[k] = -carried
        t_in[k] = carried * ti / -to
        carried = t_in[k]
    ratio = float(np.prod([i["ratio"] for i in infos]))
    w0 = cfg.speed_start_rpm * 2 * math.pi / 60
    w_in = [w0 * float(np.prod([i["ratio"] for i in infos[:k]])) for k in range(len(infos))]
    jm, jl = cfg.motor_inertia_kg_m2, cfg.load_inertia_kg_m2
    wb = 2 * math.pi * cfg.controller_bandwidth_Hz
    j_tot = jm + jl * ratio ** 2
    kp, ki = 2 * wb * j_tot, wb ** 2 * j_tot
    zeta = cfg.shaft_damping_ratio
    comps = {"motor": ("motor", dict(inertia=jm, speed_start=w0, speed_end=cfg.speed_end_rpm * 2 * math.pi / 60,
                                     hold_time=cfg.hold_s, ramp_time=cfg.ramp_s, gain_p=kp, gain_i=ki,
                                     torque_limit=cfg.motor_torque_limit_Nm, angle_start=0.0,
                                     integrator_start=t_in[0] / ki))}
    k1 = cfg.shaft1_stiffness_Nm_per_rad
    comps["shaft0"] = ("shaft", dict(stiffness=k1, damping=2 * zeta * math.sqrt(k1 * jm), twist_start=t_in[0] / k1))
    for k in range(len(infos) - 1):
        kc = cfg.coupling_shaft_stiffness_Nm_per_rad
        comps[f"shaft{k + 1}"] = ("shaft", dict(stiffness=kc, damping=2 * zeta * math.sqrt(kc * jm),
                                                twist_start=-t_out[k] / kc))
    k2 = cfg.shaft2_stiffness_Nm_per_rad
    n = len(infos)
    comps[f"shaft{n}"] = ("shaft", dict(stiffness=k2, damping=2 * zeta * math.sqrt(k2 * jl), twist_start=t_out[-1] / k2))
    comps["load"] = ("load", dict(inertia=jl, braking_torque=t_load, speed_start=w0 * ratio, angle_start=0.0))
    stages = {}
    for k, (name, info, path) in enumerate(zip(names, infos, paths)):
        r_in = abs(info["ports"][info["input"]]["speed_ratio"])
        stages[name] = (path, {"mode": int(Experiment.TORQUE), f"{info['reference_gear']}.speed_start": w_in[k] / r_in, "torque": t_in[k],
                               "internal_step": cfg.internal_step_s, f"{info['input']}.torque_in": t_in[k],
                               f"{info['output']}.torque_in": t_out[k]})
    con = [("motor", "speed", "shaft0", "speed_a"), (names[0], f"{infos[0]['input']}.speed", "shaft0", "speed_b"),
           ("shaft0", "torque", "motor", "shaft_torque"), ("shaft0", "torque", names[0], f"{infos[0]['input']}.torque_in")]
    for k in range(n - 1):
        a, b = names[k], names[k + 1]
        con += [(a, f"{infos[k]['output']}.speed", f"shaft{k + 1}", "speed_a"),
                (b, f"{infos[k + 1]['input']}.speed", f"shaft{k + 1}", "speed_b"),
                (f"shaft{k + 1}", "torque_a", a, f"{infos[k]['output']}.torque_in"),
                (f"shaft{k + 1}", "torque", b, f"{infos[k + 1]['input']}.torque_in")]
    con += [("load", "speed", f"shaft{n}", "speed_a"), (names[-1], f"{infos[-1]['output']}.speed", f"shaft{n}", "speed_b"),
            (f"shaft{n}", "torque", names[-1], f"{infos[-1]['output']}.torque_in"),
            (f"shaft{n}", "torque", "load", "shaft_torque")]
    record = [("motor", "speed"), ("motor", "speed_reference"), ("load", "speed")]
    record += [(f"shaft{k}", "torque") for k in range(n + 1)]
    for name, info in zip(names, infos):
        record += [(name, f"{info['input']}.speed"), (name, f"{info['output']}.speed")]
        record += [(name, f"{m}.{q}") for m in info["meshes"] for q in ("force", "dte", "contact")]
    static = {"load_torque_Nm": t_load, "input_torque_Nm": t_in, "output_torque_Nm": t_out, "ratio": ratio,
              "input_speed_rad_s": w_in}
    return Layout(comps, stages, con, record, static, dict(zip(names, infos)))


class PythonComponent:
    """A component of :mod:`~hacgear_core.fmu.components` as a Python object (get, set, step)."""

    def __init__(self, kind: str, params: dict) -> None:
        cls, variables, self._inputs, _ = COMPONENTS[kind]
        defaults = {v.name: v.start for v in variables if v.causality == "parameter"}
        self.obj = cls(**{**defaults, **params})
        self._outputs = {v.name: v.read.attr for v in variables if v.causality == "output"}

    def get(self, name):
        return getattr(self.obj, self._outputs[name])

    def set(self, name, value) -> None:
        setattr(self.obj, self._inputs[name], float(value))

    def step(self, t: float, h: float) -> None:
        r = self.obj.advance(h)
        if not r.success:  # pragma: no cover - the components cannot fail
            raise RuntimeError(r.message)

    def close(self) -> None:
        pass


class FmuComponent:
    """An FMI 2.0 FMU under fmpy's low-level API (get, set, step) with start values, in initialization mode
    until :meth:`start`."""

    def __init__(self, path: str | Path, name: str, start_values: dict) -> None:
        self.md = read_model_description(str(path))
        self.dir = extract(str(path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for k, v in start_values.items():
            self.set(k, v)

    def start(self) -> None:
        self.fmu.exitInitializationMode()

    def get(self, name):
        v = self.vars[name]
        if v.type == "Real":
            return self.fmu.getReal([v.valueReference])[0]
        return self.fmu.getInteger([v.valueReference])[0]

    def set(self, name, value) -> None:
        v = self.vars[name]
        if v.type == "Real":
            self.fmu.setReal([v.valueReference], [float(value)])
        else:
            self.fmu.setInteger([v.valueReference], [int(value)])

    def step(self, t: float, h: float) -> None:
        self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)

    def close(self) -> None:
        try:
            self.fmu.terminate()
        finally:
            self.fmu.freeInstance()
            shutil.rmtree(self.dir, ignore_errors=True)


def run_layout(layout: Layout, components: dict, steps: int, h: float) -> dict[str, np.ndarray]:
    """The fixed-step co-simulation of ``components`` (name -> object with get/set/step; FMUs in initialization
    mode with a ``start`` method): outputs passed to inputs at the start (initialization) and after every step,
    every component stepping with the inputs of the previous communication point.  Returns the recorded series
    ``"<component>.<variable>"`` (steps + 1,) and ``time_s``."""
    con = layout.connections
    for c in con:  # initialization: the initial outputs to the inputs
        components[c[2]].set(c[3], components[c[0]].get(c[1]))
    for comp in components.values():
        if hasattr(comp, "start"):
            comp.start()
    rec = {f"{c}.{v}": np.empty(steps + 1) for c, v in layout.record}
    getters = [(rec[f"{c}.{v}"], components[c], v) for c, v in layout.record]
    time = np.empty(steps + 1)
    t = 0.0
    order = list(components.values())
    for k in range(steps + 1):
        time[k] = t
        for arr, comp, v in getters:
            arr[k] = comp.get(v)
        if k == steps:
            break
        for comp in order:
            comp.step(t, h)
        values = [components[c[0]].get(c[1]) for c in con]
        for c, val in zip(con, values):
            components[c[2]].set(c[3], val)
        t += h
    rec["time_s"] = time
    return rec


def run_drivetrain_bench(stage_fmus, config: BenchConfig = BenchConfig()) -> dict:
    """Run the bench of ``stage_fmus`` (one path or a list, see :func:`drivetrain_layout`) in Python: motor, shafts
    and load as Python objects, the gear stages through fmpy's low-level API.

    Returns
    -------
    dict
        The recorded series (SI): ``time_s``, ``motor.speed``, ``motor.speed_reference``, ``load.speed``,
        ``shaft<k>.torque``, per stage ``stage<k>.<gear>.speed`` of its ports and ``stage<k>.<mesh>.force`` /
        ``.dte`` / ``.contact`` (ContactState, 0 = separated); ``layout`` (:class:`Layout`); and, for the first
        stage, the names of the former single-stage bench (``input_speed_rad_s``, ``output_speed_rad_s``,
        ``shaft1_torque_Nm``, ``shaft2_torque_Nm``, ``<mesh>.force``..., ``mesh_frequency_Hz``,
        ``static_mesh_force_N``, ``speed_ratio``, ``input_gear``, ``output_gear``, ``info``).
    """
    cfg = config
    lay = drivetrain_layout(stage_fmus, cfg)
    comps = {}
    try:
        for name, (kind, params) in lay.components.items():
            comps[name] = PythonComponent(kind, params)
        for name, (path, start) in lay.stages.items():
            comps[name] = FmuComponent(path, name, start)
        res = run_layout(lay, comps, cfg.steps, cfg.step_s)
    except BaseException:
        # the failure is what the user needs to read: an FMU left in its error state refuses fmi2Terminate as well,
        # and that second error must not be raised on top of the first
        for c in comps.values():
            with contextlib.suppress(Exception):
                c.close()
        raise
    for c in comps.values():
        c.close()
    return _named(res, lay)


def _named(res: dict, lay: Layout) -> dict:
    """Add the single-stage names (first stage's input, last stage's output) to a bench result."""
    names = list(lay.stages)
    first, last = lay.infos[names[0]], lay.infos[names[-1]]
    res["layout"] = lay
    res["info"] = first
    res["motor_speed_rad_s"] = res["motor.speed"]
    res["speed_ref_rad_s"] = res["motor.speed_reference"]
    res["load_speed_rad_s"] = res["load.speed"]
    res["input_speed_rad_s"] = res[f"{names[0]}.{first['input']}.speed"]
    res["output_speed_rad_s"] = res[f"{names[-1]}.{last['output']}.speed"]
    res["shaft1_torque_Nm"] = res["shaft0.torque"]
    res["shaft2_torque_Nm"] = res[f"shaft{len(names)}.torque"]
    for m in first["meshes"]:
        for q in ("force", "dte", "contact"):
            res[f"{m}.{q}"] = res[f"{names[0]}.{m}.{q}"]
    r_in = abs(first["ports"][first["input"]]["speed_ratio"])
    res["mesh_frequency_Hz"] = res["input_speed_rad_s"] / r_in * first.get(
        "mesh_cycles_per_rad", first["reference_teeth"] / (2 * math.pi))
    res["input_gear"], res["output_gear"] = first["input"], last["output"]
    res["speed_ratio"] = lay.static["ratio"]
    t_in0 = lay.static["input_torque_Nm"][0]
    nom_in = first["ports"][first["input"]]["nominal_torque_Nm"]
    res["static_mesh_force_N"] = {m: first["meshes"][m]["nominal_force_N"] * t_in0 / nom_in for m in first["meshes"]}
    return res


def _envelope(t, y, width):
    """Max and min of ``y`` over consecutive windows of ``width`` samples -> (t_mid, max, min)."""
    m = len(y) // width
    yy = y[: m * width].reshape(m, width)
    return t[: m * width].reshape(m, width).mean(axis=1), yy.max(axis=1), yy.min(axis=1)


def plot_bench(res: dict, path: str | Path, title: str = "") -> Path:
    """Figure of a bench run: speeds, mesh force envelopes over the mesh frequency, DTE and contact loss."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = res["time_s"]
    meshes = list(res["info"]["meshes"])
    fig, ax = plt.subplots(3, 1, figsize=(8, 9), constrained_layout=True)
    rpm = 60 / (2 * math.pi)
    ax[0].plot(t, res["speed_ref_rad_s"] * rpm, "k--", lw=1, label="reference (motor drive)")
    ax[0].plot(t, res["motor_speed_rad_s"] * rpm, lw=1, label="motor")
    ax[0].plot(t, res["input_speed_rad_s"] * rpm, lw=0.6, label=f"{res['input_gear']} (FMU output)")
    ax[0].plot(t, res["load_speed_rad_s"] * rpm / res["speed_ratio"], lw=1, ls="-.",
               label=f"load, referred to {res['input_gear']}")
    ax[0].set_xlabel("time [s]")
    ax[0].set_ylabel("speed [rpm]")
    ax[0].legend(fontsize=8, loc="upper left")
    w = 50
    fm = res["mesh_frequency_Hz"]
    fmid, _, _ = _envelope(fm, fm, w)
    for mn in meshes:
        _, fmax, fmin = _envelope(t, res[f"{mn}.force"], w)
        fs = res["static_mesh_force_N"][mn]
        ax[1].fill_between(fmid, fmin / fs, fmax / fs, alpha=0.4, label=f"{mn}: mesh force range per 5 ms")
    ax[1].axhline(1.0, color="k", lw=0.8, ls=":")
    ax[1].set_xlabel("mesh frequency [Hz]")
    ax[1].set_ylabel("mesh force / static mesh force [–]")
    ax[1].legend(fontsize=8, loc="upper left")
    for mn in meshes:
        _, dmax, dmin = _envelope(t, res[f"{mn}.dte"], w)
        _, apart, _ = _envelope(t, (res[f"{mn}.contact"] == int(ContactState.SEPARATED)).astype(float), w)
        ax[2].fill_between(fmid, dmin * 1e6, dmax * 1e6, alpha=0.4, label=f"{mn}: DTE range per 5 ms")
        loss = apart > 0.5
        if np.any(loss):
            ax[2].plot(fmid[loss], np.full(loss.sum(), np.nanmin(dmin) * 1e6), "|", ms=8,
                       label=f"{mn}: contact loss in window")
    ax[2].set_xlabel("mesh frequency [Hz]")
    ax[2].set_ylabel("dynamic transmission error [µm]")
    ax[2].legend(fontsize=8, loc="upper left")
    fig.suptitle(title or "gear-system FMU in a drivetrain (fmpy low-level API)", fontsize=10)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def stage_mesh_frequency_Hz(res: dict, name: str) -> np.ndarray:
    """Mesh frequency [Hz] of stage ``name`` of a multi-stage bench run over time: its input speed over the input
    port's speed ratio (the reference gear's speed) x the reference gear's teeth / 2 pi."""
    info = res["layout"].infos[name]
    r_in = abs(info["ports"][info["input"]]["speed_ratio"])
    return np.abs(res[f"{name}.{info['input']}.speed"]) / r_in * info["reference_teeth"] / (2 * math.pi)


def shaft_labels(res: dict) -> list[str]:
    """What each shaft of a multi-stage bench connects: ``shaft0`` motor -> first stage, ``shaft1`` ... the
    couplings between stages, the last one the last stage -> load."""
    names = list(res["layout"].infos)
    infos = list(res["layout"].infos.values())
    out = [f"shaft0: motor -> {names[0]} {infos[0]['input']}"]
    out += [f"shaft{k + 1}: {names[k]} {infos[k]['output']} -> {names[k + 1]} {infos[k + 1]['input']}"
            for k in range(len(names) - 1)]
    out.append(f"shaft{len(names)}: {names[-1]} {infos[-1]['output']} -> load")
    return out


def plot_stages(res: dict, path: str | Path, title: str = "") -> Path:
    """Figure of a multi-stage bench run: speeds of the motor, every stage's input and output and the load; mesh
    force envelopes of every mesh of every stage over its static force, over the stage's own mesh frequency (where
    its resonances are read, marked); shaft torques, each shaft named by what it connects."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lay = res["layout"]
    t = res["time_s"]
    rpm = 60 / (2 * math.pi)
    w = max(1, int(round(0.005 / (t[1] - t[0])))) if len(t) > 1 else 1
    fig, ax = plt.subplots(3, 1, figsize=(8, 10), constrained_layout=True)
    ax[0].plot(t, res["motor.speed_reference"] * rpm, "k--", lw=1, label="reference (motor drive)")
    ax[0].plot(t, res["motor.speed"] * rpm, lw=1, label="motor")
    for name, info in lay.infos.items():
        for port, ls in ((info["input"], "-"), (info["output"], ":")):
            ax[0].plot(t, res[f"{name}.{port}.speed"] * rpm, lw=0.8, ls=ls, label=f"{name} ({info['system']}) {port}")
    ax[0].plot(t, res["load.speed"] * rpm, lw=1, ls="-.", label="load")
    ax[0].set_xlabel("time [s]")
    ax[0].set_ylabel("speed [rpm]")
    ax[0].legend(fontsize=7, loc="upper left", ncol=2)
    for k, (name, info) in enumerate(lay.infos.items()):
        nom_in = info["ports"][info["input"]]["nominal_torque_Nm"]
        scale = lay.static["input_torque_Nm"][k] / nom_in
        fm = stage_mesh_frequency_Hz(res, name)
        for m in info["meshes"]:
            fs = info["meshes"][m]["nominal_force_N"] * scale
            tm, fmax, fmin = _envelope(t, res[f"{name}.{m}.force"], w)
            window = f"range per {w * (t[1] - t[0]) * 1e3:.0f} ms"
            line = ax[1].fill_between(np.interp(tm, t, fm), fmin / fs, fmax / fs, alpha=0.45,
                                      label=f"{name} ({info['system']}) {m}: {window}")
        ax[1].axvline(info["resonance_mesh_frequency_Hz"], color=line.get_facecolor()[0], lw=0.8, ls="--",
                      label=f"{name}: linearised mesh resonance {info['resonance_mesh_frequency_Hz']:.0f} Hz")
    ax[1].axhline(1.0, color="k", lw=0.8, ls=":")
    ax[1].set_xlabel("mesh frequency of the stage [Hz] (its reference gear's speed x teeth / 2 pi)")
    ax[1].set_ylabel("mesh force / static mesh force [–]")
    ax[1].legend(fontsize=7, loc="upper left")
    for k, label in enumerate(shaft_labels(res)):
        ax[2].plot(t, res[f"shaft{k}.torque"], lw=0.8, label=label)
    ax[2].set_xlabel("time [s]")
    ax[2].set_ylabel("shaft torque on the stage gear [N·m]")
    ax[2].set_title("torque each shaft applies to the stage gear at its downstream end (side b), in that gear's "
                    "sense of rotation:\ndriving > 0; the last shaft brakes the last stage (the load) < 0", fontsize=8)
    ax[2].legend(fontsize=7, loc="upper left")
    fig.suptitle(title or "gear stages in a drivetrain (co-simulation, fmpy low-level API)", fontsize=10)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
