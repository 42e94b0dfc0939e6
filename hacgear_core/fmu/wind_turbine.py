"""Wind-turbine drivetrain bench: rotor -> main (low-speed) shaft -> gearbox FMU -> high-speed shaft -> generator.

The gearbox is a hacgear FMU in drivetrain mode (``mode = 1``) with a rotor-side port and a generator-side port
(the NREL 5 MW gearbox: ``carrier1`` and ``pinion3``; any two-port FMU works, the ports come from its
hacgear_fmu.json as in :func:`~hacgear_core.fmu.bench.stage_info`).  Rotor and generator are the
:class:`~hacgear_core.fmu.components.Rotor` and :class:`~hacgear_core.fmu.components.Generator` components, the
shafts :class:`~hacgear_core.fmu.components.Shaft`: the same code runs as Python objects
(:func:`run_wind_turbine`, the fixed-step scheme of :func:`~hacgear_core.fmu.bench.run_layout`) and as component
FMUs in the SSP (:func:`write_wind_turbine_ssp`, run by :func:`~hacgear_core.fmu.ssp.run_ssp_fmpy` or
:func:`~hacgear_core.fmu.ssp.run_ssp_libcosim`).

Data (NREL 5 MW reference turbine and gearbox, Nejad et al. 2016, doi 10.1002/we.1884): rotor inertia
57 231 535 kg m^2, generator inertia 534.116 kg m^2, rated 5 MW at 12.1 rpm of the rotor; main shaft d 700 mm,
L 2000 mm and high-speed shaft d 333 mm, L 1000 mm, steel, torsional stiffness k = G pi d^4 / (32 L) with
G = E / (2 (1 + nu)) = 206 GPa / 2.6.

Stated choices (none published for this bench):

* generator: a linear speed-torque law through the rated point, ``T = T_rated (1 + (w - w_rated) / (s w_rated))``
  with the slip ``s`` = 1 % (an induction generator's rated slip; slope T_rated / (s w_rated)).  The NREL
  controller's region-3 law (constant power, T = P / w) has a negative slope: at a prescribed aerodynamic torque
  it has no stable speed without the pitch controller, which this bench does not model;
* shaft damping: ``c = 2 zeta sqrt(k J_red)`` with ``zeta`` = 0.02 (the gear models' modal damping ratio) and
  ``J_red`` the reduced inertia of the shaft's two ends (rotor or generator, and the gearbox's rigid train referred
  to its port, ``<port>.train_inertia``);
* the aerodynamic torque is prescribed (no aerodynamics): rated ``P / w_rated`` = 3.94599e6 N m;
* the generator's rated speed is the rotor's times the gearbox FMU's ratio: 1165.885 rpm for 4625/48 (NREL's
  1173.7 rpm belongs to its 97:1 gearbox), its rated torque the rotor's over that ratio (40 952.98 N m).

Scenarios (:data:`SCENARIOS`), each from the static state at rated speed and torque (shafts wound up by their static torque):

* ``rated``: constant rated torque: every torque stays at its static value (the steady state is the start);
* ``gust``: the aerodynamic torque steps to ``gust_factor`` x rated at ``event_time_s``;
* ``stop``: at ``event_time_s`` the generator torque is reversed, from braking at rated to ``reversal_factor`` x
  rated (-1: the converter motors at rated torque, an emergency stop's torque reversal): the generator side then
  drives, the gearbox's meshes cross the backlash onto their coast flanks.
"""
from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hacgear_core.encodings import Experiment
from hacgear_core.fmu.adapter import _nice_floor
from hacgear_core.fmu.bench import FmuComponent, Layout, PythonComponent, run_layout, stage_info

__all__ = ["WindTurbineConfig", "SCENARIOS", "shaft_stiffness", "coupling", "wind_turbine_layout",
           "bench_step", "generator_side", "run_wind_turbine", "write_wind_turbine_ssp", "plot_wind_turbine", "summary"]

#: the scenarios of the bench
SCENARIOS = ("rated", "gust", "stop")


def shaft_stiffness(diameter_m: float, length_m: float, shear_modulus_Pa: float) -> float:
    """Torsional stiffness [N m/rad] of a solid round shaft: ``G pi d^4 / (32 L)``."""
    if not (diameter_m > 0 and length_m > 0 and shear_modulus_Pa > 0):
        raise ValueError(f"shaft diameter [m], length [m] and shear modulus [Pa] must be > 0, got {diameter_m!r}, "
                         f"{length_m!r}, {shear_modulus_Pa!r}")
    return shear_modulus_Pa * math.pi * diameter_m ** 4 / (32.0 * length_m)


@dataclass(frozen=True)
class WindTurbineConfig:
    """Wind-turbine bench parameters (SI; the rated rotor speed in rpm).  ``generator_side_ratio``: the gear ratio
    the generator-side data belong to (the NREL gearbox's 4625/48); a gearbox FMU of another ratio (a stand-in
    stage) gets the generator inertia referred to its output, ``J_g (r_data / r_fmu)^2``, so that the drivetrain's
    rigid-body dynamics referred to the rotor stay the turbine's (the high-speed shaft keeps its stiffness).
    ``step_s``: communication step, None:
    :func:`bench_step` (the FMU's ``drivetrain_step`` or less where a shaft needs it).  ``gust_factor``: the
    aerodynamic torque after the gust over the rated one; ``reversal_factor``: the generator torque after the
    stop over the rated one (negative: motoring); both at ``event_time_s``."""

    rotor_inertia_kg_m2: float = 57_231_535.0
    generator_inertia_kg_m2: float = 534.116
    rated_power_W: float = 5.0e6
    rated_rotor_speed_rpm: float = 12.1
    main_shaft_diameter_m: float = 0.700
    main_shaft_length_m: float = 2.000
    hss_diameter_m: float = 0.333
    hss_length_m: float = 1.000
    shear_modulus_Pa: float = 206e9 / 2.6
    shaft_damping_ratio: float = 0.02
    generator_slip: float = 0.01
    gust_factor: float = 1.2
    reversal_factor: float = -1.0
    event_time_s: float = 0.2
    duration_s: float = 1.0
    step_s: float | None = None
    internal_step_s: float = 0.0
    generator_side_ratio: float = 4625.0 / 48.0

    def __post_init__(self) -> None:
        for name in ("rotor_inertia_kg_m2", "generator_inertia_kg_m2", "rated_power_W", "rated_rotor_speed_rpm",
                     "main_shaft_diameter_m", "main_shaft_length_m", "hss_diameter_m", "hss_length_m",
                     "shear_modulus_Pa", "generator_slip", "duration_s", "generator_side_ratio"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be finite and > 0, got {v!r}")
        if not 0 <= self.shaft_damping_ratio < 1:
            raise ValueError(f"shaft_damping_ratio [-] must be in [0, 1), got {self.shaft_damping_ratio!r}")
        if not (math.isfinite(self.gust_factor) and math.isfinite(self.reversal_factor)
                and abs(self.gust_factor) <= 10 and abs(self.reversal_factor) <= 10):
            raise ValueError(f"gust_factor and reversal_factor [-] must be in [-10, 10], got {self.gust_factor!r}, "
                             f"{self.reversal_factor!r}")
        if not 0 <= self.event_time_s < self.duration_s:
            raise ValueError(f"event_time_s [s] must be in [0, duration_s = {self.duration_s!r}), got "
                             f"{self.event_time_s!r}")
        if self.step_s is not None and not (0 < self.step_s <= 1e-3):
            raise ValueError(f"step_s [s] must be in (0, 1e-3] or None, got {self.step_s!r}")
        if not 0 <= self.internal_step_s <= 1e-3:
            raise ValueError(f"internal_step_s [s] must be in [0, 1e-3], got {self.internal_step_s!r}")

    @property
    def rated_rotor_speed_rad_s(self) -> float:
        """Rated rotor speed [rad/s]."""
        return self.rated_rotor_speed_rpm * 2 * math.pi / 60

    @property
    def rated_rotor_torque_Nm(self) -> float:
        """Rated aerodynamic torque [N m]: rated power over rated rotor speed."""
        return self.rated_power_W / self.rated_rotor_speed_rad_s

    @property
    def main_shaft_stiffness_Nm_per_rad(self) -> float:
        return shaft_stiffness(self.main_shaft_diameter_m, self.main_shaft_length_m, self.shear_modulus_Pa)

    @property
    def hss_stiffness_Nm_per_rad(self) -> float:
        return shaft_stiffness(self.hss_diameter_m, self.hss_length_m, self.shear_modulus_Pa)


def _start_values(info: dict, cfg: WindTurbineConfig) -> dict:
    """The gearbox FMU's start values: drivetrain mode, its input at rated speed, the static torques on both ports."""
    t_in = cfg.rated_rotor_torque_Nm
    ports = info["ports"]
    t_out = t_in * ports[info["output"]]["nominal_torque_Nm"] / ports[info["input"]]["nominal_torque_Nm"]
    r_in = abs(ports[info["input"]]["speed_ratio"])
    return {"mode": int(Experiment.TORQUE), f"{info['reference_gear']}.speed_start": cfg.rated_rotor_speed_rad_s / r_in,
            "torque": t_in, "internal_step": cfg.internal_step_s, f"{info['input']}.torque_in": t_in,
            f"{info['output']}.torque_in": t_out}


def coupling(gearbox_fmu: str | Path, cfg: WindTurbineConfig = WindTurbineConfig()) -> dict:
    """What the bench needs from the gearbox FMU, instantiated with fmpy at the bench's start values: its
    hacgear_fmu.json (:func:`~hacgear_core.fmu.bench.stage_info`: ``input``, ``output``, ``ratio``) and the
    calculated parameters ``<port>.train_inertia``, ``<port>.inertia`` [kg m^2] of both ports and
    ``drivetrain_step`` [s] (keys ``train_inertia_in``, ``train_inertia_out``, ``inertia_in``, ``inertia_out``,
    ``drivetrain_step``)."""
    info = stage_info(gearbox_fmu)
    comp = FmuComponent(gearbox_fmu, "gearbox_coupling", _start_values(info, cfg))
    try:
        comp.start()
        out = {"info": info, "train_inertia_in": float(comp.get(f"{info['input']}.train_inertia")),
               "train_inertia_out": float(comp.get(f"{info['output']}.train_inertia")),
               "inertia_in": float(comp.get(f"{info['input']}.inertia")),
               "inertia_out": float(comp.get(f"{info['output']}.inertia")),
               "drivetrain_step": float(comp.get("drivetrain_step")) if "drivetrain_step" in comp.vars else None}
    finally:
        comp.close()
    return out


def generator_side(cp: dict, cfg: WindTurbineConfig) -> tuple[float, float]:
    """(generator inertia [kg m^2], high-speed shaft stiffness [N m/rad]) at the gearbox FMU's output: the
    generator inertia referred by ``(cfg.generator_side_ratio / ratio)^2`` (1 for the NREL gearbox; see
    :class:`WindTurbineConfig`)."""
    f = (cfg.generator_side_ratio / cp["info"]["ratio"]) ** 2
    return cfg.generator_inertia_kg_m2 * f, cfg.hss_stiffness_Nm_per_rad


def _reduced(a: float, b: float) -> float:
    return a * b / (a + b)


def bench_step(cp: dict, cfg: WindTurbineConfig = WindTurbineConfig()) -> float:
    """The bench's communication step [s]: the FMU's ``drivetrain_step`` and, no larger, 1/10 of 1/omega of each
    shaft on the reduced inertia of its ends, the port gear's own inertia (in the backlash the port gear is alone on
    its shaft; omega h <= 0.1, as the drivetrain bench), rounded down to 1, 2 or 5 x 10^k; ``cfg.step_s`` where
    given."""
    if cfg.step_s is not None:
        return cfg.step_s
    jg, k2 = generator_side(cp, cfg)
    w = max(math.sqrt(cfg.main_shaft_stiffness_Nm_per_rad / _reduced(cfg.rotor_inertia_kg_m2, cp["inertia_in"])),
            math.sqrt(k2 / _reduced(jg, cp["inertia_out"])))
    h = _nice_floor(0.1 / w)
    return min(h, cp["drivetrain_step"]) if cp["drivetrain_step"] is not None else h


def wind_turbine_layout(gearbox_fmu: str | Path, cfg: WindTurbineConfig = WindTurbineConfig(),
                        scenario: str = "rated", cp: dict | None = None) -> Layout:
    """The bench of ``gearbox_fmu`` in ``scenario`` (:data:`SCENARIOS`): components ``rotor``, ``main_shaft``,
    ``hss``, ``generator`` and the stage ``gearbox``, everything at the static state of rated operation (shafts
    wound up by their static torque).  ``cp``: :func:`coupling` of the FMU (None: computed here).
    ``static`` holds ``rotor_torque_Nm``, ``gearbox_output_torque_Nm`` (on the output gear, negative: braking),
    ``hss_torque_Nm`` (carried, = -that), ``ratio``, ``rotor_speed_rad_s``, ``generator_speed_rad_s``,
    ``main_shaft_stiffness_Nm_per_rad``, ``hss_stiffness_Nm_per_rad``, their ``..._damping_Nm_s_per_rad``,
    ``generator_slope_Nm_s_per_rad``, ``step_s``, ``steps``, ``scenario``."""
    if scenario not in SCENARIOS:
        raise ValueError(f"scenario must be one of {SCENARIOS}, got {scenario!r}")
    cp = coupling(gearbox_fmu, cfg) if cp is None else cp
    info = cp["info"]
    start = _start_values(info, cfg)
    t_in, t_out = start[f"{info['input']}.torque_in"], start[f"{info['output']}.torque_in"]
    w_r = cfg.rated_rotor_speed_rad_s
    w_g = w_r * info["ratio"]
    t_gen = -t_out
    slope = t_gen / (cfg.generator_slip * w_g)
    jg, k2 = generator_side(cp, cfg)
    k1 = cfg.main_shaft_stiffness_Nm_per_rad
    z = cfg.shaft_damping_ratio
    c1 = 2 * z * math.sqrt(k1 * _reduced(cfg.rotor_inertia_kg_m2, cp["train_inertia_in"]))
    c2 = 2 * z * math.sqrt(k2 * _reduced(jg, cp["train_inertia_out"]))
    never = 1e9
    gust = scenario == "gust"
    stop = scenario == "stop"
    comps = {
        "rotor": ("rotor", dict(inertia=cfg.rotor_inertia_kg_m2, aero_torque=t_in,
                                step_time=cfg.event_time_s if gust else never,
                                step_torque=t_in * (cfg.gust_factor if gust else 1.0), speed_start=w_r,
                                angle_start=0.0)),
        "main_shaft": ("shaft", dict(stiffness=k1, damping=c1, twist_start=t_in / k1)),
        "hss": ("shaft", dict(stiffness=k2, damping=c2, twist_start=t_out / k2)),
        "generator": ("generator", dict(inertia=jg, rated_torque=t_gen, rated_speed=w_g,
                                        slope=slope, reversal_time=cfg.event_time_s if stop else never,
                                        reversal_torque=t_gen * (cfg.reversal_factor if stop else 1.0),
                                        speed_start=w_g, angle_start=0.0)),
    }
    i, o = info["input"], info["output"]
    con = [("rotor", "speed", "main_shaft", "speed_a"), ("gearbox", f"{i}.speed", "main_shaft", "speed_b"),
           ("main_shaft", "torque", "rotor", "shaft_torque"), ("main_shaft", "torque", "gearbox", f"{i}.torque_in"),
           ("generator", "speed", "hss", "speed_a"), ("gearbox", f"{o}.speed", "hss", "speed_b"),
           ("hss", "torque", "gearbox", f"{o}.torque_in"), ("hss", "torque", "generator", "shaft_torque")]
    record = [("rotor", "speed"), ("rotor", "torque"), ("generator", "speed"), ("generator", "torque"),
              ("main_shaft", "torque"), ("hss", "torque"), ("gearbox", f"{i}.speed"), ("gearbox", f"{o}.speed")]
    record += [("gearbox", f"{m}.{q}") for m in info["meshes"] for q in ("force", "coast_force", "contact_code")]
    h = bench_step(cp, cfg)
    steps = int(round(cfg.duration_s / h))
    static = {"rotor_torque_Nm": t_in, "gearbox_output_torque_Nm": t_out, "hss_torque_Nm": -t_out,
              "ratio": info["ratio"], "rotor_speed_rad_s": w_r, "generator_speed_rad_s": w_g,
              "main_shaft_stiffness_Nm_per_rad": k1, "hss_stiffness_Nm_per_rad": k2,
              "main_shaft_damping_Nm_s_per_rad": c1, "hss_damping_Nm_s_per_rad": c2,
              "generator_slope_Nm_s_per_rad": slope, "step_s": h, "steps": steps, "scenario": scenario,
              "drivetrain_step": cp["drivetrain_step"], "generator_inertia_kg_m2": jg}
    return Layout(comps, {"gearbox": (Path(gearbox_fmu), start)}, con, record, static, {"gearbox": info})


def run_wind_turbine(gearbox_fmu: str | Path, cfg: WindTurbineConfig = WindTurbineConfig(),
                     scenario: str = "rated", cp: dict | None = None) -> dict:
    """Run ``scenario`` of the bench (:func:`wind_turbine_layout`) in Python: rotor, shafts and generator as Python
    objects, the gearbox through fmpy's low-level API, :func:`~hacgear_core.fmu.bench.run_layout`'s scheme.
    Returns the recorded series ``"<component>.<variable>"`` (SI; ``hss.torque`` and ``main_shaft.torque`` are
    the torques on the gearbox's ports: driving > 0, braking < 0), ``time_s`` and ``layout``."""
    lay = wind_turbine_layout(gearbox_fmu, cfg, scenario, cp)
    comps = {}
    try:
        for name, (kind, params) in lay.components.items():
            comps[name] = PythonComponent(kind, params)
        for name, (path, start) in lay.stages.items():
            comps[name] = FmuComponent(path, name, start)
        res = run_layout(lay, comps, lay.static["steps"], lay.static["step_s"])
    finally:
        for c in comps.values():
            with contextlib.suppress(Exception):
                c.close()
    res["layout"] = lay
    return res


def write_wind_turbine_ssp(gearbox_fmu: str | Path, dest: str | Path, cfg: WindTurbineConfig = WindTurbineConfig(),
                           scenario: str = "rated", *, fmus: bool = True, name: str | None = None,
                           cp: dict | None = None) -> Path:
    """Write ``scenario`` of the bench as the SSP ``dest`` (:func:`~hacgear_core.fmu.ssp.write_layout_ssp`): the
    gearbox FMU and hacgear's rotor, shaft and generator FMUs in ``resources/`` (``fmus=False``: the structure
    alone), default experiment 0 to ``cfg.duration_s`` at the bench's step (:func:`bench_step`)."""
    from hacgear_core.fmu.ssp import write_layout_ssp

    lay = wind_turbine_layout(gearbox_fmu, cfg, scenario, cp)
    st = lay.static
    info = lay.infos["gearbox"]
    jg = st["generator_inertia_kg_m2"]
    desc = (f"hacgear wind-turbine drivetrain bench, scenario {scenario!r}: rotor ({cfg.rotor_inertia_kg_m2:g} kg.m2) "
            f"-> main shaft ({st['main_shaft_stiffness_Nm_per_rad']:.6g} N.m/rad) -> gearbox "
            f"{Path(gearbox_fmu).stem} ({info['input']} -> {info['output']}, ratio {info['ratio']:.9g}, mode = 1) "
            f"-> high-speed shaft ({st['hss_stiffness_Nm_per_rad']:.6g} N.m/rad) -> generator "
            f"({jg:.6g} kg.m2, linear speed-torque law, slip {cfg.generator_slip:g}); "
            f"rated {cfg.rated_power_W:g} W at {cfg.rated_rotor_speed_rpm:g} rpm of the rotor; event at "
            f"{cfg.event_time_s:g} s; communication step {st['step_s']:g} s (osp:FixedStepAlgorithm; the gearbox's "
            "drivetrain_step or less). Where this file carries no FMUs, `python -m hacgear_core.fmu.ssp THIS.ssp "
            "COMPLETE.ssp` builds them")
    return write_layout_ssp(lay, dest, st["steps"] * st["step_s"], st["step_s"], name or f"wind_turbine_{scenario}",
                            desc, fmus=fmus)


def summary(res: dict) -> dict:
    """Measured numbers of a run (SI): mean shaft torques over the last 20 % of the run (``main_shaft_mean_Nm``,
    ``hss_mean_Nm``: the HSS torque carried, -``hss.torque``), their extremes over the run (``..._max_Nm``,
    ``..._min_Nm``), per mesh the largest force and coast force and the number of samples on each flank
    (``contact_code`` 1 drive, 2 coast, 0 separated), the first time a mesh touches its coast flank
    (``first_coast_s``, None if none), rotor and generator speeds at the end."""
    lay = res["layout"]
    t = res["time_s"]
    tail = t >= t[-1] - 0.2 * (t[-1] - t[0])
    ms, hss = res["main_shaft.torque"], -res["hss.torque"]
    out = {"main_shaft_mean_Nm": float(np.mean(ms[tail])), "hss_mean_Nm": float(np.mean(hss[tail])),
           "main_shaft_max_Nm": float(np.max(ms)), "main_shaft_min_Nm": float(np.min(ms)),
           "hss_max_Nm": float(np.max(hss)), "hss_min_Nm": float(np.min(hss)),
           "rotor_speed_end_rpm": float(res["rotor.speed"][-1] * 60 / (2 * math.pi)),
           "generator_speed_end_rpm": float(res["generator.speed"][-1] * 60 / (2 * math.pi)), "meshes": {}}
    first = None
    for m in lay.infos["gearbox"]["meshes"]:
        code = res[f"gearbox.{m}.contact_code"]
        coast = np.flatnonzero(code == 2)
        if coast.size and (first is None or t[coast[0]] < first):
            first = float(t[coast[0]])
        out["meshes"][m] = {"force_max_N": float(np.max(res[f"gearbox.{m}.force"])),
                            "coast_force_max_N": float(np.max(res[f"gearbox.{m}.coast_force"])),
                            "drive": int(np.count_nonzero(code == 1)), "coast": int(coast.size),
                            "separated": int(np.count_nonzero(code == 0))}
    out["first_coast_s"] = first
    return out


def plot_wind_turbine(res: dict, path: str | Path, title: str = "") -> Path:
    """Figure of a run: rotor and generator speeds (the generator's referred to the rotor), the torques of the main
    shaft and the high-speed shaft (the HSS's x the gear ratio, on the rotor's scale), every mesh's drive-flank
    and coast-flank force (coast negative), each over its static (rated) value."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lay = res["layout"]
    st = lay.static
    info = lay.infos["gearbox"]
    t = res["time_s"]
    rpm = 60 / (2 * math.pi)
    fig, ax = plt.subplots(3, 1, figsize=(8, 10), constrained_layout=True, sharex=True)
    ax[0].plot(t, res["rotor.speed"] * rpm, lw=1, label="rotor")
    ax[0].plot(t, res["generator.speed"] * rpm / st["ratio"], lw=1, ls="--",
               label=f"generator / {st['ratio']:.4f} (referred to the rotor)")
    ax[0].set_ylabel("speed [rpm]")
    ax[0].legend(fontsize=8, loc="best")
    ax[1].plot(t, -res["hss.torque"] * st["ratio"] / 1e6, lw=0.6, alpha=0.7, color="C1",
               label=f"high-speed shaft (carried) x {st['ratio']:.4f}")
    ax[1].plot(t, res["main_shaft.torque"] / 1e6, lw=1.2, color="C0",
               label="main shaft (on the gearbox's rotor-side port)")
    ax[1].plot(t, res["rotor.torque"] / 1e6, "k:", lw=1, label="aerodynamic torque")
    ax[1].plot(t, res["generator.torque"] * st["ratio"] / 1e6, "k--", lw=0.8,
               label=f"generator torque x {st['ratio']:.4f}")
    ax[1].axhline(0.0, color="grey", lw=0.5)
    ax[1].set_ylabel("torque [MN·m] (rotor scale)")
    ax[1].legend(fontsize=8, loc="best")
    scale = st["rotor_torque_Nm"] / info["ports"][info["input"]]["nominal_torque_Nm"]
    groups: dict[str, list[str]] = {}  # meshes by stage (a gearbox's "s<k>_" prefix), one colour each
    for m in info["meshes"]:
        head = m.split("_", 1)[0]
        groups.setdefault(head if head[:1] == "s" and head[1:].isdigit() else "", []).append(m)
    for k, (stage, meshes) in enumerate(groups.items()):
        for j, m in enumerate(meshes):
            fs = info["meshes"][m]["nominal_force_N"] * scale
            kinds = ", ".join(sorted({q.rstrip("0123456789").rstrip("_") for q in meshes}))
            lab = None if j else (f"stage {stage[1:]}" if stage else "gearbox") + f": {len(meshes)} meshes ({kinds})"
            ax[2].plot(t, res[f"gearbox.{m}.force"] / fs, lw=0.5, color=f"C{k}", alpha=0.8, label=lab)
            ax[2].plot(t, -res[f"gearbox.{m}.coast_force"] / fs, lw=0.5, color=f"C{k}", alpha=0.8, ls="--")
    ax[2].axhline(0.0, color="grey", lw=0.5)
    ax[2].set_xlabel("time [s]")
    ax[2].set_ylabel("mesh force / rated static force [–]\n(drive flank > 0, coast flank < 0, dashed)")
    ax[2].legend(fontsize=6, loc="best")
    fig.suptitle(title or f"wind-turbine drivetrain: {st['scenario']}", fontsize=10)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path

