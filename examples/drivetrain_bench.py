#!/usr/bin/env python
"""Drivetrain test bench on fmpy's low-level API: motor -> shaft -> gear-pair FMU -> shaft -> load.

The gear pair is the hacgear spur-pair FMU in drivetrain mode (``mode = 1``: shaft torques in, gear angles and
speeds out).  Everything else is plain Python here, integrated by the bench with the FMU's communication step
(semi-implicit Euler; the shaft torques are held over a step):

* motor: inertia ``J_m`` driven by a speed controller (PI on the ramped reference speed, torque-limited) -
  a motor with its drive;
* shaft 1: torsion spring-damper between motor and gear 1 (pinion),
  ``T1 = k1 (phi_m - phi_1) + c1 (w_m - w_1)``  -> FMU input ``torque1_in``;
* shaft 2: spring-damper between gear 2 (wheel) and the load, ``T2 = k2 (phi_L - phi_2) + c2 (w_L - w_2)``
  -> ``torque2_in`` (angles of gear 2 and load positive in the wheel's direction of rotation);
* load: inertia ``J_L`` with a constant braking torque ``T_load``.

The reference speed ramps through the mesh resonance of the 28-tooth pair (mesh frequency near the pair's
torsional natural frequency, ~2.6-2.8 kHz, i.e. pinion ~6000 rpm), so the mesh force grows, the teeth lose
contact and the dynamic transmission error jumps.

    python examples/drivetrain_bench.py [--fmu dist/spur_28t_asym.fmu] [--out docs/figures/fmu_drivetrain.png]

Without ``--fmu`` it uses ``dist/spur_28t_asym.fmu`` when present, else builds one from **synthetic** tables
(hacgear_core.fmu.synthetic_system_folder) into a temporary folder; the plot says which.
"""
from __future__ import annotations

import argparse
import math
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

__all__ = ["BenchConfig", "run_drivetrain_bench", "plot_bench", "default_fmu"]


@dataclass(frozen=True)
class BenchConfig:
    """Drivetrain bench parameters (SI; speeds of the pinion in rpm where named so)."""

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
    load_torque_Nm: float = 300.0
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


def default_fmu(workdir: Path | None = None) -> tuple[Path, bool]:
    """``dist/spur_28t_asym.fmu`` if built, else a freshly built one from synthetic tables in ``workdir``.
    Returns (path, synthetic)."""
    dist = ROOT / "dist" / "spur_28t_asym.fmu"
    if dist.exists():
        return dist, False
    from hacgear_core.fmu import build_fmu, synthetic_system_folder

    workdir = Path(workdir or tempfile.mkdtemp(prefix="hacgear_bench_"))
    folder = synthetic_system_folder(ROOT / "models" / "spur_28t_asym" / "model.toml", workdir / "models")
    return build_fmu(folder, workdir / "dist"), True


def run_drivetrain_bench(fmu_path: str | Path, config: BenchConfig = BenchConfig()) -> dict[str, np.ndarray]:
    """Run the bench; returns time series (SI): ``time_s``, ``speed_ref_rad_s``, ``motor_speed_rad_s``,
    ``pinion_speed_rad_s``, ``wheel_speed_rad_s``, ``load_speed_rad_s``, ``shaft1_torque_Nm``,
    ``shaft2_torque_Nm``, ``mesh_force_N``, ``dte_m``, ``contact``, ``mesh_frequency_Hz`` and the FMU's
    ``teeth`` (z1) and ``base_radius_m`` (r_b1, r_b2) as arrays of length 1 / 2."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    cfg = config
    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = extract(str(fmu_path))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="gearpair")
    from hacgear_core.model import load_model

    model = load_model(Path(unzip) / "resources" / "model.toml")
    from hacgear_core.tables import read_tables

    table = read_tables(Path(unzip) / "resources" / "tables.h5").meshes[model.mesh().name]
    z1 = table.teeth[0]
    rb1, rb2 = table.base_radius_m
    ratio = rb1 / rb2  # wheel speed / pinion speed
    w_start = cfg.speed_start_rpm * 2 * math.pi / 60
    w_end = cfg.speed_end_rpm * 2 * math.pi / 60
    t_load = cfg.load_torque_Nm
    t1_static = t_load * rb1 / rb2  # pinion torque that balances the load
    h = cfg.step_s
    n = int(round((cfg.ramp_s + 2 * cfg.hold_s) / h))

    # shaft damping from a damping ratio of each shaft on the smaller adjacent inertia
    jm, jl = cfg.motor_inertia_kg_m2, cfg.load_inertia_kg_m2
    k1, k2 = cfg.shaft1_stiffness_Nm_per_rad, cfg.shaft2_stiffness_Nm_per_rad
    c1 = 2 * cfg.shaft_damping_ratio * math.sqrt(k1 * jm)
    c2 = 2 * cfg.shaft_damping_ratio * math.sqrt(k2 * jl)
    # PI speed controller on the whole train's inertia referred to the motor
    wb = 2 * math.pi * cfg.controller_bandwidth_Hz
    j_tot = jm + jl * ratio**2 + 2 * 0.0044
    kp, ki = 2 * wb * j_tot, wb**2 * j_tot

    # initial state: everything at w_start, shafts pre-twisted to carry the static torques
    phi_m, w_m = t1_static / k1, w_start
    phi_l, w_l = -t_load / k2, w_start * ratio
    integ = t1_static / ki  # controller integral so that the initial motor torque balances the load

    out = {k: np.empty(n + 1) for k in ("time_s", "speed_ref_rad_s", "motor_speed_rad_s", "pinion_speed_rad_s",
                                        "wheel_speed_rad_s", "load_speed_rad_s", "shaft1_torque_Nm",
                                        "shaft2_torque_Nm", "mesh_force_N", "dte_m", "contact")}
    outs = [vr[k] for k in ("angle1", "speed1", "angle2", "speed2", "mesh_force", "dte", "contact")]
    fmu.instantiate()
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setInteger([vr["mode"]], [1])
        fmu.setReal([vr["speed1_start"], vr["torque"], vr["internal_step"], vr["torque1_in"], vr["torque2_in"]],
                    [w_start, t1_static, cfg.internal_step_s, t1_static, -t_load])
        fmu.exitInitializationMode()
        t = 0.0
        for k in range(n + 1):
            a1, w1, a2, w2, f, dte, contact = fmu.getReal(outs)
            t_sh1 = k1 * (phi_m - a1) + c1 * (w_m - w1)
            t_sh2 = k2 * (phi_l - a2) + c2 * (w_l - w2)
            s = min(max((t - cfg.hold_s) / cfg.ramp_s, 0.0), 1.0)
            w_ref = w_start + (w_end - w_start) * s
            for key, val in (("time_s", t), ("speed_ref_rad_s", w_ref), ("motor_speed_rad_s", w_m),
                             ("pinion_speed_rad_s", w1), ("wheel_speed_rad_s", w2), ("load_speed_rad_s", w_l),
                             ("shaft1_torque_Nm", t_sh1), ("shaft2_torque_Nm", t_sh2), ("mesh_force_N", f),
                             ("dte_m", dte), ("contact", contact)):
                out[key][k] = val
            if k == n:
                break
            # motor drive (PI with anti-windup by clamping) and the plain-Python parts: semi-implicit Euler
            err = w_ref - w_m
            t_m = kp * err + ki * integ
            if abs(t_m) < cfg.motor_torque_limit_Nm:
                integ += err * h
            t_m = min(max(t_m, -cfg.motor_torque_limit_Nm), cfg.motor_torque_limit_Nm)
            w_m += h * (t_m - t_sh1) / jm
            phi_m += h * w_m
            w_l += h * (-t_sh2 - t_load) / jl
            phi_l += h * w_l
            # the gear pair over the same step with the shaft torques held
            fmu.setReal([vr["torque1_in"], vr["torque2_in"]], [t_sh1, t_sh2])
            fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            t += h
        fmu.terminate()
    finally:
        fmu.freeInstance()
        shutil.rmtree(unzip, ignore_errors=True)
    out["mesh_frequency_Hz"] = out["pinion_speed_rad_s"] * z1 / (2 * math.pi)
    out["teeth"] = np.array([z1])
    out["base_radius_m"] = np.array([rb1, rb2])
    out["static_mesh_force_N"] = np.array([t1_static / rb1])
    out["synthetic"] = np.array(["SYNTHETIC" in str(getattr(table, "solver", ""))])
    return out


def _envelope(t, y, width):
    """Max and min of ``y`` over consecutive windows of ``width`` samples -> (t_mid, max, min)."""
    m = len(y) // width
    yy = y[: m * width].reshape(m, width)
    return t[: m * width].reshape(m, width).mean(axis=1), yy.max(axis=1), yy.min(axis=1)


def plot_bench(res: dict, path: str | Path, title: str = "") -> Path:
    """Figure of a bench run: speeds, mesh force envelope over the mesh frequency, DTE, contact loss."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = res["time_s"]
    fig, ax = plt.subplots(3, 1, figsize=(8, 9), constrained_layout=True)
    rpm = 60 / (2 * math.pi)
    ax[0].plot(t, res["speed_ref_rad_s"] * rpm, "k--", lw=1, label="reference (motor drive)")
    ax[0].plot(t, res["motor_speed_rad_s"] * rpm, lw=1, label="motor")
    ax[0].plot(t, res["pinion_speed_rad_s"] * rpm, lw=0.6, label="pinion (FMU output speed1)")
    ax[0].plot(t, res["load_speed_rad_s"] * rpm / (res["base_radius_m"][0] / res["base_radius_m"][1]), lw=1,
               label="load, referred to the pinion")
    ax[0].set_xlabel("time [s]")
    ax[0].set_ylabel("speed [rpm]")
    ax[0].legend(fontsize=8)
    w = 50
    fm = res["mesh_frequency_Hz"]
    _, fmax, fmin = _envelope(t, res["mesh_force_N"], w)
    fmid, _, _ = _envelope(fm, fm, w)
    fs = res["static_mesh_force_N"][0]
    ax[1].fill_between(fmid, fmin / fs, fmax / fs, alpha=0.5, label="mesh force range per 5 ms")
    ax[1].axhline(1.0, color="k", lw=0.8, ls=":")
    ax[1].set_xlabel("mesh frequency [Hz] (from the pinion speed)")
    ax[1].set_ylabel("mesh force / static mesh force [-]")
    ax[1].legend(fontsize=8)
    _, dmax, dmin = _envelope(t, res["dte_m"], w)
    _, cmin, _ = _envelope(t, -res["contact"], w)
    ax[2].fill_between(fmid, dmin * 1e6, dmax * 1e6, alpha=0.5, label="DTE range per 5 ms")
    loss = cmin > -0.5  # some sample without contact in the window
    ax[2].plot(fmid[loss], np.full(loss.sum(), np.nanmin(dmin) * 1e6), "r|", label="contact loss in window")
    ax[2].set_xlabel("mesh frequency [Hz]")
    ax[2].set_ylabel("dynamic transmission error [um]")
    ax[2].legend(fontsize=8)
    fig.suptitle(title or "gear-pair FMU in a drivetrain (fmpy low-level API)", fontsize=10)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Motor - shaft - gear FMU - shaft - load bench through resonance")
    ap.add_argument("--fmu", help="spur-pair FMU (default: dist/spur_28t_asym.fmu or a synthetic build)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "figures" / "fmu_drivetrain.png"))
    ap.add_argument("--ramp", type=float, default=BenchConfig.ramp_s, help="ramp duration [s]")
    args = ap.parse_args(argv)
    import time

    synthetic = False
    if args.fmu:
        fmu = Path(args.fmu)
    else:
        fmu, synthetic = default_fmu()
    t0 = time.perf_counter()
    res = run_drivetrain_bench(fmu, BenchConfig(ramp_s=args.ramp))
    synthetic = synthetic or bool(res["synthetic"][0])
    wall = time.perf_counter() - t0
    fm, f = res["mesh_frequency_Hz"], res["mesh_force_N"]
    k = int(np.argmax(f))
    print(f"bench: {fmu.name}{' (synthetic tables)' if synthetic else ''}: {len(f) - 1} communication steps of "
          f"{BenchConfig.step_s:g} s in {wall:.2f} s wall")
    print(f"bench: peak mesh force {f[k]:.0f} N = {f[k] / res['static_mesh_force_N'][0]:.2f} x static at mesh "
          f"frequency {fm[k]:.0f} Hz; contact lost in {np.count_nonzero(res['contact'] < 0.5)} of {len(f)} samples")
    title = f"{fmu.stem} FMU in a drivetrain (fmpy low-level API){' - SYNTHETIC tables' if synthetic else ''}"
    print(f"bench: figure {plot_bench(res, args.out, title)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
