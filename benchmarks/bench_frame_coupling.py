#!/usr/bin/env python
"""What a frame coupling costs: the NREL 5 MW gearbox at rated speed in the library's simulator, without and with a
bending stiffness on its intermediate shaft (sun1 in carrier 1's frame to carrier2 in its own: the kernel then forms
M^-1 K(D) every step, docs/dynamics.md "Frame couplings").

Each variant is warmed up (compilation and assembly not timed), then ``--seconds`` of simulated time are run
``--repeats`` times alternately; printed: the best wall time of each, their ratio (judged: the bent shaft's cost,
expected a few per cent), and the CPU's vector units.  numba and BLAS are held to one thread.

    python benchmarks/bench_frame_coupling.py [--seconds 0.5] [--repeats 3] [--bending 2e9]
"""
from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

from hacgear_core.cpu import vector_units  # noqa: E402
from hacgear_core.dynamics import Simulator, static_equilibrium  # noqa: E402
from hacgear_core.kinds import build_system, parse_model  # noqa: E402
from hacgear_core.model import resolve_model_path  # noqa: E402
from hacgear_core.tables import load_system_tables  # noqa: E402

MODEL = "nrel_5mw_gearbox"
RATED_MESH_HZ = 12.1 / 60 * 56   # stage 1's mesh frequency at 12.1 rpm of the carrier


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=0.5, help="simulated time per run [s] (default: 0.5)")
    ap.add_argument("--repeats", type=int, default=3, help="runs per variant (default: 3)")
    ap.add_argument("--bending", type=float, default=2e9, help="the shaft's bending stiffness [N/m] (default: 2e9)")
    a = ap.parse_args(argv)
    print(f"CPU the kernels are compiled for: {vector_units().describe()}")
    text = resolve_model_path(MODEL).read_text()
    bent = text.replace("torsional_stiffness_Nm_per_rad = 1.25555e9",
                        f"torsional_stiffness_Nm_per_rad = 1.25555e9\nbending_stiffness_N_per_m = {a.bending!r}")
    tables = load_system_tables(MODEL)
    sims = {}
    for label, t in (("plain", text), ("bent shaft", bent)):
        sy = build_system(parse_model(t, file=f"{label}.toml"), tables)
        sim = Simulator(sy)
        sim.set_speed_input(mesh_frequency_Hz=RATED_MESH_HZ)
        sim.s[:sy.n] = static_equilibrium(sy).q
        sim.run(0.01, 1e-3)
        sims[label] = sim
    best = {k: float("inf") for k in sims}
    for _ in range(a.repeats):
        for label, sim in sims.items():
            t0 = time.perf_counter()
            sim.run(a.seconds, 1e-3)
            best[label] = min(best[label], time.perf_counter() - t0)
    for label, w in best.items():
        print(f"{label:>11}: {a.seconds:g} s simulated in {w:.3f} s wall (best of {a.repeats})")
    print(f"ratio bent / plain: {best['bent shaft'] / best['plain']:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
