"""Drivetrain bench on fmpy's low-level API: motor -> shaft -> gear-system FMU -> shaft -> load.

The gear system is a hacgear FMU in drivetrain mode (``mode = drivetrain`` (1): shaft torques in on its two port gears, gear
angles and speeds out).  Everything else is plain Python, integrated by the bench with the FMU's communication
step (semi-implicit Euler; the shaft torques are held over a step):

* motor: inertia ``J_m`` driven by a speed controller (PI on the ramped reference speed, torque-limited);
* shaft 1: torsion spring-damper between motor and the input gear, ``T_in = k1 (phi_m - phi_in) + c1 (w_m - w_in)``
  -> FMU input ``<input>.torque_in``;
* shaft 2: spring-damper between the output gear and the load, ``T_out = k2 (phi_L - phi_out) + c2 (w_L - w_out)``
  -> ``<output>.torque_in`` (angles of the output gear and load positive in the output gear's sense);
* load: inertia ``J_L`` with a constant braking torque ``T_load``.

The FMU's ``resources/hacgear_fmu.json`` gives the ports, their kinematic speed ratios and nominal torques.
"""
from __future__ import annotations

import json
import math
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from hacgear_core.fmu.slave import FMU_INFO_FILE

__all__ = ["BenchConfig", "run_drivetrain_bench", "plot_bench"]


@dataclass(frozen=True)
class BenchConfig:
    """Drivetrain bench parameters (SI; speeds of the input gear in rpm where named so).  ``load_torque_Nm``:
    braking torque on the output shaft; None: the FMU's nominal output torque."""

    speed_start_rpm: float = 4000.0
    speed_end_rpm: float = 7500.0
    ramp_s: float = 1.5
    hold_s: float = 0.05
    step_s: float = 1e-4
    motor_inertia_kg_m2: float = 0.05
    load_inertia_kg_m2: float = 0.2
    shaft1_stiffness_Nm_per_rad: float = 2.0e4
    shaft2_stiffness_Nm_per_rad: float = 2.0e4
    shaft_damping_ratio: float = 0.05
    load_torque_Nm: float | None = None
    controller_bandwidth_Hz: float = 10.0
    motor_torque_limit_Nm: float = 2000.0
    internal_step_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("ramp_s", "step_s", "motor_inertia_kg_m2", "load_inertia_kg_m2", "shaft1_stiffness_Nm_per_rad",
                     "shaft2_stiffness_Nm_per_rad", "controller_bandwidth_Hz", "motor_torque_limit_Nm"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be finite and > 0, got {v!r}")
        if not (0 < self.speed_start_rpm < 2e5 and 0 < self.speed_end_rpm < 2e5):
            raise ValueError("speed_start_rpm and speed_end_rpm [rpm] must be in (0, 2e5)")


def run_drivetrain_bench(fmu_path: str | Path, config: BenchConfig = BenchConfig()) -> dict[str, np.ndarray]:
    """Run the bench; returns time series (SI): ``time_s``, ``speed_ref_rad_s``, ``motor_speed_rad_s``,
    ``input_speed_rad_s``, ``output_speed_rad_s``, ``load_speed_rad_s``, ``shaft1_torque_Nm``, ``shaft2_torque_Nm``,
    per mesh ``<mesh>.force`` / ``<mesh>.dte`` / ``<mesh>.contact`` (ContactState: 0 = separated),
    ``mesh_frequency_Hz``; and ``info`` (the FMU's
    hacgear_fmu.json) with the port names."""
    cfg = config
    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = extract(str(fmu_path))
    info = json.loads((Path(unzip) / "resources" / FMU_INFO_FILE).read_text(encoding="utf-8"))
    ports = info["ports"]
    inp = info["input_gear"]
    outs = [g for g in ports if g != inp]
    if len(outs) != 1:
        raise ValueError(f"the bench drives one input and one output port; this FMU has ports {sorted(ports)}")
    out_g = outs[0]
    r_in = abs(ports[inp]["speed_ratio"])  # input speed / reference gear speed
    ratio = abs(ports[out_g]["speed_ratio"]) / r_in  # output speed / input speed (each in its sense)
    t_in_static = ports[inp]["nominal_torque_Nm"]
    t_out_static = ports[out_g]["nominal_torque_Nm"]  # negative: a braking load
    t_load = -t_out_static if cfg.load_torque_Nm is None else float(cfg.load_torque_Nm)
    t1_static = t_in_static * t_load / -t_out_static
    meshes = list(info["meshes"])
    ref = info["reference_gear"]
    z_ref = info["reference_teeth"]
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="gearsystem")
    w_start = cfg.speed_start_rpm * 2 * math.pi / 60
    w_end = cfg.speed_end_rpm * 2 * math.pi / 60
    h = cfg.step_s
    n = int(round((cfg.ramp_s + 2 * cfg.hold_s) / h))
    jm, jl = cfg.motor_inertia_kg_m2, cfg.load_inertia_kg_m2
    k1, k2 = cfg.shaft1_stiffness_Nm_per_rad, cfg.shaft2_stiffness_Nm_per_rad
    c1 = 2 * cfg.shaft_damping_ratio * math.sqrt(k1 * jm)
    c2 = 2 * cfg.shaft_damping_ratio * math.sqrt(k2 * jl)
    wb = 2 * math.pi * cfg.controller_bandwidth_Hz
    j_tot = jm + jl * ratio ** 2
    kp, ki = 2 * wb * j_tot, wb ** 2 * j_tot
    # initial state: everything at speed, shafts pre-twisted to carry the static torques
    phi_m, w_m = t1_static / k1, w_start
    phi_l, w_l = -t_load / k2, w_start * ratio
    integ = t1_static / ki
    keys = ("time_s", "speed_ref_rad_s", "motor_speed_rad_s", "input_speed_rad_s", "output_speed_rad_s",
            "load_speed_rad_s", "shaft1_torque_Nm", "shaft2_torque_Nm")
    res = {k: np.empty(n + 1) for k in keys}
    for mn in meshes:
        for q in ("force", "dte", "contact"):
            res[f"{mn}.{q}"] = np.empty(n + 1)
    read = [vr[f"{inp}.angle"], vr[f"{inp}.speed"], vr[f"{out_g}.angle"], vr[f"{out_g}.speed"]]
    read += [vr[f"{mn}.{q}"] for mn in meshes for q in ("force", "dte")]
    read_contact = [vr[f"{mn}.contact"] for mn in meshes]  # Enumeration ContactState: 0 = separated
    fmu.instantiate()
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setInteger([vr["mode"]], [1])
        fmu.setReal([vr[f"{ref}.speed_start"], vr["torque"], vr["internal_step"], vr[f"{inp}.torque_in"],
                     vr[f"{out_g}.torque_in"]], [w_start / r_in, t1_static, cfg.internal_step_s, t1_static, -t_load])
        fmu.exitInitializationMode()
        t = 0.0
        for k in range(n + 1):
            vals = fmu.getReal(read)
            contact = fmu.getInteger(read_contact)
            a1, w1, a2, w2 = vals[:4]
            t_sh1 = k1 * (phi_m - a1) + c1 * (w_m - w1)
            t_sh2 = k2 * (phi_l - a2) + c2 * (w_l - w2)
            s = min(max((t - cfg.hold_s) / cfg.ramp_s, 0.0), 1.0)
            w_ref = w_start + (w_end - w_start) * s
            for key, val in zip(keys, (t, w_ref, w_m, w1, w2, w_l, t_sh1, t_sh2)):
                res[key][k] = val
            j = 4
            for i, mn in enumerate(meshes):
                res[f"{mn}.force"][k], res[f"{mn}.dte"][k] = vals[j], vals[j + 1]
                res[f"{mn}.contact"][k] = contact[i]
                j += 2
            if k == n:
                break
            err = w_ref - w_m
            t_m = kp * err + ki * integ
            if abs(t_m) < cfg.motor_torque_limit_Nm:
                integ += err * h
            t_m = min(max(t_m, -cfg.motor_torque_limit_Nm), cfg.motor_torque_limit_Nm)
            w_m += h * (t_m - t_sh1) / jm
            phi_m += h * w_m
            w_l += h * (-t_sh2 - t_load) / jl
            phi_l += h * w_l
            fmu.setReal([vr[f"{inp}.torque_in"], vr[f"{out_g}.torque_in"]], [t_sh1, t_sh2])
            fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            t += h
        fmu.terminate()
    finally:
        fmu.freeInstance()
        shutil.rmtree(unzip, ignore_errors=True)
    res["mesh_frequency_Hz"] = res["input_speed_rad_s"] / r_in * z_ref / (2 * math.pi)
    res["info"] = info
    res["input_gear"], res["output_gear"], res["speed_ratio"] = inp, out_g, ratio
    res["static_mesh_force_N"] = {mn: info["meshes"][mn]["nominal_force_N"] * t_load / -t_out_static for mn in meshes}
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
        _, cmin, _ = _envelope(t, -res[f"{mn}.contact"], w)
        ax[2].fill_between(fmid, dmin * 1e6, dmax * 1e6, alpha=0.4, label=f"{mn}: DTE range per 5 ms")
        loss = cmin > -0.5
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
