#!/usr/bin/env python
"""Drivetrain bench: motor -> shaft -> gear-system FMU (drivetrain mode) -> shaft -> load, ramped through the
mesh resonance (:mod:`hacgear_core.fmu.bench`).

    python examples/drivetrain_bench.py [--system spur_28t_asym] [--fmu FILE.fmu] [--out docs/figures/fmu_drivetrain.png]

Without ``--fmu`` the FMU of ``--system`` is built from its committed tables into a temporary folder.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from hacgear_core.dynamics.kernels import COMPILE_CPU_S
from hacgear_core.fmu import build_fmu
from hacgear_core.fmu.bench import BenchConfig, plot_bench, run_drivetrain_bench
from hacgear_core.model import resolve_model_path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Motor - shaft - gear FMU - shaft - load bench through resonance",
                                      formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--system", default="spur_28t_asym", help="system to build when --fmu is not given")
    ap.add_argument("--fmu", help="hacgear FMU; None: built from --system")
    ap.add_argument("--out", default="drivetrain.png", help="figure (PNG)")
    ap.add_argument("--ramp", type=float, default=BenchConfig.ramp_s, help="ramp duration [s]")
    ap.add_argument("--rpm", default=f"{BenchConfig.speed_start_rpm:g}:{BenchConfig.speed_end_rpm:g}",
                    help="START:END input-gear speeds of the ramp [rpm]")
    args = ap.parse_args(argv)
    cfg = {"ramp_s": args.ramp}
    if args.rpm:
        a, b = (float(v) for v in args.rpm.split(":"))
        cfg.update(speed_start_rpm=a, speed_end_rpm=b)
    with tempfile.TemporaryDirectory(prefix="hacgear_bench_") as td:
        fmu = Path(args.fmu) if args.fmu else build_fmu(resolve_model_path(args.system).parent, td)
        print(f"bench: running {fmu.name} (its first run on this machine compiles the FMU's own copy of the "
              f"integration kernel: about {COMPILE_CPU_S} s on one core)", flush=True)
        t0 = time.perf_counter()
        res = run_drivetrain_bench(fmu, BenchConfig(**cfg))
        wall = time.perf_counter() - t0
        print(f"bench: {fmu.name}: {len(res['time_s']) - 1} communication steps of {BenchConfig.step_s:g} s in "
              f"{wall:.2f} s wall")
        for mn, fs in res["static_mesh_force_N"].items():
            f = res[f"{mn}.force"]
            k = int(np.argmax(f))
            print(f"bench: {mn}: peak mesh force {f[k]:.0f} N = {f[k] / fs:.2f} x static at mesh frequency "
                  f"{res['mesh_frequency_Hz'][k]:.0f} Hz; contact lost in "
                  f"{np.count_nonzero(res[f'{mn}.contact'] < 0.5)} of {len(f)} samples")
        print(f"bench: figure {plot_bench(res, args.out, f'{fmu.stem} FMU in a drivetrain (fmpy low-level API)')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
