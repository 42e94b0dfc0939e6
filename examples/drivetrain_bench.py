#!/usr/bin/env python
"""Drivetrain bench: motor -> shaft -> gear-system FMU (drivetrain mode) -> shaft -> load, ramped through the
mesh resonance (:mod:`hacgear_core.fmu.bench`), in Python and, with ``--ssp``, as an SSP file under libcosim.

    python examples/drivetrain_bench.py [--system spur_28t_asym] [--fmu FILE.fmu] [--out docs/figures/fmu_drivetrain.png]
    python examples/drivetrain_bench.py --ssp bench.ssp  # also as an SSP (with its FMUs), run under libcosim
    python examples/drivetrain_bench.py --ssp examples/drivetrain_bench.ssp --structure-only  # the shipped SSP

Without ``--fmu`` the FMU of ``--system`` is built from its committed tables into a temporary folder.  The
communication step is the bench's 2e-5 s or the FMU's ``drivetrain_step`` (its recommended largest step in
drivetrain mode), whichever is smaller.  ``examples/drivetrain_bench.ssp`` is this bench's SSP without the FMUs
(written by the last command above); ``python -m hacgear_core.fmu.ssp examples/drivetrain_bench.ssp bench.ssp``
builds them and writes the SSP with them.
"""
from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from hacgear_core.dynamics.kernels import COMPILE_CPU_S
from hacgear_core.fmu import build_fmu
from hacgear_core.fmu.bench import BenchConfig, plot_bench, run_drivetrain_bench
from hacgear_core.fmu.ssp import drivetrain_step, run_ssp_libcosim, write_bench_ssp
from hacgear_core.model import resolve_model_path

#: name of the bench in its SSP (``SystemStructureDescription`` name)
SSP_NAME = "drivetrain_bench"


def bench_config(fmu, ramp_s: float = BenchConfig.ramp_s, rpm: tuple[float, float] | None = None) -> BenchConfig:
    """The bench of ``fmu``: a ``ramp_s`` [s] ramp between the input-gear speeds ``rpm`` [rpm] (None: the
    bench's), communication step the smaller of the bench's and the FMU's ``drivetrain_step``."""
    cfg = BenchConfig(ramp_s=ramp_s) if rpm is None else BenchConfig(ramp_s=ramp_s, speed_start_rpm=rpm[0],
                                                                     speed_end_rpm=rpm[1])
    step = drivetrain_step(fmu, cfg)
    return dataclasses.replace(cfg, step_s=step) if step is not None and step < cfg.step_s else cfg


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Motor - shaft - gear FMU - shaft - load bench through resonance",
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--system", default="spur_28t_asym", help="system to build when --fmu is not given")
    ap.add_argument("--fmu", help="hacgear FMU (FMI 2.0); None: built from --system")
    ap.add_argument("--out", default="drivetrain.png", help="figure (PNG)")
    ap.add_argument("--ramp", type=float, default=BenchConfig.ramp_s, help="ramp duration [s]")
    ap.add_argument("--rpm", default=f"{BenchConfig.speed_start_rpm:g}:{BenchConfig.speed_end_rpm:g}",
                    help="START:END input-gear speeds of the ramp [rpm]")
    ap.add_argument("--ssp", help="also write the bench as this SSP file (with its FMUs) and run it under libcosim; "
                    "None: no SSP")
    ap.add_argument("--structure-only", action="store_true",
                    help="with --ssp: write the SSP without its FMUs (the form of examples/drivetrain_bench.ssp) and "
                    "run nothing")
    args = ap.parse_args(argv)
    rpm = tuple(float(v) for v in args.rpm.split(":"))
    with tempfile.TemporaryDirectory(prefix="hacgear_bench_") as td:
        fmu = Path(args.fmu) if args.fmu else build_fmu(resolve_model_path(args.system).parent, td)
        print(f"bench: {fmu.name} (its first run on this machine compiles the FMU's own copy of the integration "
              f"kernel: about {COMPILE_CPU_S} s on one core)", flush=True)
        cfg = bench_config(fmu, args.ramp, rpm)
        print(f"bench: communication step {cfg.step_s:g} s (the bench's {BenchConfig.step_s:g} s or the FMU's "
              "drivetrain_step, whichever is smaller)")
        if args.ssp and args.structure_only:
            print(f"bench: SSP {write_bench_ssp(fmu, args.ssp, cfg, fmus=False, name=SSP_NAME)} (structure only)")
            return 0
        t0 = time.perf_counter()
        res = run_drivetrain_bench(fmu, cfg)
        wall = time.perf_counter() - t0
        print(f"bench: {fmu.name}: {len(res['time_s']) - 1} communication steps of {cfg.step_s:g} s in "
              f"{wall:.2f} s wall")
        for mn, fs in res["static_mesh_force_N"].items():
            f = res[f"{mn}.force"]
            k = int(np.argmax(f))
            print(f"bench: {mn}: peak mesh force {f[k]:.0f} N = {f[k] / fs:.2f} x static at mesh frequency "
                  f"{res['mesh_frequency_Hz'][k]:.0f} Hz; contact lost in "
                  f"{np.count_nonzero(res[f'{mn}.contact'] < 0.5)} of {len(f)} samples")
        print(f"bench: figure {plot_bench(res, args.out, f'{fmu.stem} FMU in a drivetrain (fmpy low-level API)')}")
        if args.ssp:
            ssp = write_bench_ssp(fmu, args.ssp, cfg, name=SSP_NAME)
            reals = [r for r in res["layout"].record if not r[1].endswith(".contact")]
            t0 = time.perf_counter()
            out = run_ssp_libcosim(ssp, cfg.steps, None, reals)  # None: the step the SSP carries
            dev = max(float(np.nanmax(np.abs(out[f"{c}.{v}"] - res[f"{c}.{v}"])) / np.max(np.abs(res[f"{c}.{v}"])))
                      for c, v in reals)
            print(f"bench: SSP {ssp} under libcosim: {time.perf_counter() - t0:.1f} s wall, largest relative "
                  f"difference to the Python bench {dev:.2e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
