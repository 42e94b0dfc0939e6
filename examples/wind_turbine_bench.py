#!/usr/bin/env python
"""Wind-turbine drivetrain bench: rotor -> main shaft -> gearbox FMU -> high-speed shaft -> generator
(:mod:`hacgear_core.fmu.wind_turbine`), three scenarios: rated operation, a gust (+20 % aerodynamic torque), an
emergency stop's generator torque reversal (the meshes cross the backlash onto their coast flanks).  In Python and,
with ``--ssp``, as SSP files under fmpy and libcosim.

    python examples/wind_turbine_bench.py [--scenario rated gust stop] [--out-dir docs/figures]
    python examples/wind_turbine_bench.py --ssp DIR          # also each scenario as DIR/wind_turbine_<s>.ssp
                                                             # (with its FMUs), run under fmpy and libcosim
    python examples/wind_turbine_bench.py --ssp examples --structure-only   # the shipped SSPs

The gearbox is the FMU of ``--system`` (built from its committed tables into a temporary folder) or ``--fmu``:
``nrel_5mw_gearbox`` (ports ``carrier1`` -> ``pinion3``, ratio 4625/48).  Another two-port FMU works as a stand-in
(``--system nrel_5mw_stage1``: the first stage alone, ``carrier`` -> ``sun``, ratio 75/19); the generator inertia
is then referred to its output by ``(4625/48 / ratio)^2`` so that the drivetrain's rigid-body dynamics stay the
turbine's (``generator_side_ratio`` of :class:`~hacgear_core.fmu.wind_turbine.WindTurbineConfig`), and the output
names it a stand-in.  The communication step is the gearbox FMU's ``drivetrain_step`` or
less where a shaft on its port gear needs it (:func:`~hacgear_core.fmu.wind_turbine.bench_step`).
``examples/wind_turbine_<scenario>.ssp`` hold the structure only; ``python -m hacgear_core.fmu.ssp
examples/wind_turbine_gust.ssp gust.ssp`` builds the FMUs and writes the SSP with them.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from hacgear_core.fmu import build_fmu
from hacgear_core.fmu.ssp import run_ssp_fmpy, run_ssp_libcosim
from hacgear_core.fmu.wind_turbine import (SCENARIOS, WindTurbineConfig, coupling, plot_wind_turbine,
                                           run_wind_turbine, summary, wind_turbine_layout, write_wind_turbine_ssp)
from hacgear_core.model import resolve_model_path

#: the gearbox system (the NREL 5 MW reference gearbox: stage 1 planetary, stage 2 planetary, stage 3 helical)
SYSTEM = "nrel_5mw_gearbox"
#: name of each scenario's SSP file (and its ``SystemStructureDescription`` name)
SSP_NAME = "wind_turbine_{scenario}"
#: the bench: 2.5 s, the event (gust, torque reversal) at 0.2 s: the gust's response (the rotor on the main shaft
#: against the generator's speed-torque law, 0.64 Hz) peaks near 1 s and has settled by the end
CONFIG = WindTurbineConfig(duration_s=2.5, event_time_s=0.2)


def bench_config() -> WindTurbineConfig:
    """The bench of the example (and of its shipped SSPs)."""
    return CONFIG


def label(fmu: Path) -> str:
    """What the gearbox of the runs is: the NREL 5 MW gearbox, or a stand-in (named as such)."""
    stem = Path(fmu).stem
    return stem if stem.startswith("nrel_5mw_gearbox") else f"{stem} (STAND-IN for the NREL 5 MW gearbox)"


def report(res: dict) -> list[str]:
    """Lines of measured numbers of a run: static vs. steady shaft torques, extremes, coast-flank contact."""
    st = res["layout"].static
    s = summary(res)
    lines = [f"main shaft: static {st['rotor_torque_Nm']:.6g} N m, mean over the last 20 % {s['main_shaft_mean_Nm']:.6g} "
             f"N m, range {s['main_shaft_min_Nm']:.6g} .. {s['main_shaft_max_Nm']:.6g} N m",
             f"high-speed shaft (carried): static {st['hss_torque_Nm']:.6g} N m, mean over the last 20 % "
             f"{s['hss_mean_Nm']:.6g} N m, range {s['hss_min_Nm']:.6g} .. {s['hss_max_Nm']:.6g} N m",
             f"rotor {s['rotor_speed_end_rpm']:.4f} rpm, generator {s['generator_speed_end_rpm']:.2f} rpm at the end"]
    t = res["time_s"]
    ms = res["main_shaft.torque"]
    lines.append(f"main shaft: largest {ms.max():.6g} N m ({ms.max() / st['rotor_torque_Nm']:.4f} x static) at "
                 f"{t[np.argmax(ms)]:.4f} s, smallest {ms.min():.6g} N m ({ms.min() / st['rotor_torque_Nm']:.4f} x "
                 f"static) at {t[np.argmin(ms)]:.4f} s")
    fmax = max(v["force_max_N"] for v in s["meshes"].values())
    cmax = max(v["coast_force_max_N"] for v in s["meshes"].values())
    n_coast = sum(v["coast"] for v in s["meshes"].values())
    first = "none" if s["first_coast_s"] is None else f"first at {s['first_coast_s']:.5f} s"
    lines.append(f"meshes: largest drive-flank force {fmax:.6g} N, largest coast-flank force {cmax:.6g} N; coast-flank "
                 f"contact in {n_coast} of {len(t) * len(s['meshes'])} mesh samples ({first})")
    info = res["layout"].infos["gearbox"]
    scale = st["rotor_torque_Nm"] / info["ports"][info["input"]]["nominal_torque_Nm"]
    for m, v in s["meshes"].items():
        fs = info["meshes"][m]["nominal_force_N"] * scale
        lines.append(f"  {m}: drive flank up to {v['force_max_N'] / fs:.3f}, coast flank up to "
                     f"{v['coast_force_max_N'] / fs:.3f} x its rated static force; samples drive / coast / separated "
                     f"{v['drive']} / {v['coast']} / {v['separated']}")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Wind-turbine drivetrain bench: rated, gust, emergency stop",
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--system", default=SYSTEM, help="gearbox system to build when --fmu is not given")
    ap.add_argument("--fmu", help="hacgear gearbox FMU (FMI 2.0, two ports); None: built from --system")
    ap.add_argument("--scenario", nargs="+", default=list(SCENARIOS), choices=SCENARIOS, help="scenarios to run")
    ap.add_argument("--duration", type=float, default=CONFIG.duration_s, help="run time [s]")
    ap.add_argument("--out-dir", default=".", help="folder of the figures wind_turbine_<scenario>.png")
    ap.add_argument("--ssp", metavar="DIR", help="also write each scenario as DIR/wind_turbine_<scenario>.ssp (with its FMUs) and "
                    "run it under fmpy and libcosim; None: no SSP")
    ap.add_argument("--structure-only", action="store_true",
                    help="with --ssp: write the SSPs without their FMUs (the form of examples/wind_turbine_*.ssp) "
                    "and run nothing")
    args = ap.parse_args(argv)
    cfg = CONFIG if args.duration == CONFIG.duration_s else WindTurbineConfig(
        duration_s=args.duration, event_time_s=CONFIG.event_time_s)
    with tempfile.TemporaryDirectory(prefix="hacgear_wind_") as td:
        fmu = Path(args.fmu) if args.fmu else build_fmu(resolve_model_path(args.system).parent, td)
        cp = coupling(fmu, cfg)
        lay = wind_turbine_layout(fmu, cfg, "rated", cp)
        st = lay.static
        print(f"wind turbine: gearbox {label(fmu)}: {cp['info']['input']} -> {cp['info']['output']}, ratio "
              f"{st['ratio']:.9g}; communication step {st['step_s']:g} s (drivetrain_step {cp['drivetrain_step']:g} s)")
        print(f"  main shaft {st['main_shaft_stiffness_Nm_per_rad']:.6g} N m/rad, damping "
              f"{st['main_shaft_damping_Nm_s_per_rad']:.4g} N m s/rad; high-speed shaft "
              f"{st['hss_stiffness_Nm_per_rad']:.6g} N m/rad, damping {st['hss_damping_Nm_s_per_rad']:.4g} N m s/rad; "
              f"generator {st['generator_inertia_kg_m2']:.6g} kg m2 at {st['generator_speed_rad_s'] * 30 / np.pi:.4f} "
              f"rpm, slope {st['generator_slope_Nm_s_per_rad']:.6g} N m s/rad")
        if args.ssp and args.structure_only:
            for sc in args.scenario:
                dest = Path(args.ssp) / f"{SSP_NAME.format(scenario=sc)}.ssp"
                print(f"  SSP {write_wind_turbine_ssp(fmu, dest, cfg, sc, fmus=False, name=dest.stem, cp=cp)} "
                      "(structure only)")
            return 0
        for sc in args.scenario:
            t0 = time.perf_counter()
            res = run_wind_turbine(fmu, cfg, sc, cp)
            n = res["layout"].static["steps"]
            print(f"wind turbine: {sc}: {n} steps in {time.perf_counter() - t0:.1f} s wall")
            for line in report(res):
                print(f"  {line}")
            fig = plot_wind_turbine(res, Path(args.out_dir) / f"wind_turbine_{sc}.png",
                                    f"wind-turbine drivetrain, {sc}: gearbox {label(fmu)}")
            print(f"  figure {fig}")
            if args.ssp:
                dest = Path(args.ssp) / f"{SSP_NAME.format(scenario=sc)}.ssp"
                ssp = write_wind_turbine_ssp(fmu, dest, cfg, sc, name=dest.stem, cp=cp)
                rec = [r for r in res["layout"].record if not r[1].endswith("contact_code")]
                for name, run in (("fmpy", run_ssp_fmpy), ("libcosim", run_ssp_libcosim)):
                    t0 = time.perf_counter()
                    out = run(ssp, n, res["layout"].static["step_s"], rec)
                    dev = max(float(np.nanmax(np.abs(out[f"{c}.{v}"][1:] - res[f"{c}.{v}"][1:]))
                                    / max(np.max(np.abs(res[f"{c}.{v}"])), 1e-300)) for c, v in rec)
                    print(f"  SSP {ssp} under {name}: {time.perf_counter() - t0:.1f} s wall, largest relative "
                          f"difference to the Python bench {dev:.2e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
