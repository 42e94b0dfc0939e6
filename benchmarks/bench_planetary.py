"""Speed of the planetary set (the one compiled kernel on the carrier-frame system of 3N+5 DOFs, 2N meshes).

Prints, measured in one run (best of repeats; the kernel is judged by its CPU time per mesh cycle, its own cost
whatever else runs on a shared machine; wall time is printed beside it and equals it on a quiet machine):
  1. the kernel per mesh cycle [us] at 128 RK4 steps per cycle on the committed FE tables of planetary_65_55_175
     with 3 planets (14 DOFs, 6 meshes) and 5 planets (20 DOFs, 10 meshes), judged by its ratio to the spur pair's
     4-DOF kernel (spur_28t_asym, k_y = 200 N/um, both flanks) timed in the same run: targets 21x and 36x (the
     absolute targets of 150 and 250 us were set on a machine whose spur 4-DOF kernel took 7.0 us; an absolute
     time judges the machine, the ratio the kernel), and the speed-up over the dissertation's HAC (0.5 s per mesh
     cycle, Section 4.4.3);
  2. the linearised modes of the 5-planet set (gyroscopic quadratic eigenproblem at the carrier speed of 1600 Hz
     mesh frequency, classified; target <= 50 ms), also with the system build from its tables;
  3. one steady state at 1600 Hz for 3 and 5 planets (cycles and wall time).

Run: ``python benchmarks/bench_planetary.py [--quick]``.
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from hacgear_core.cpu import vector_units
from hacgear_core.kinds import build_system
from hacgear_core.dynamics.equilibrium import static_state
from hacgear_core.dynamics.modes import gyroscopic_modes
from hacgear_core.dynamics.steady import steady_state
from hacgear_core.kinds import load_model
from hacgear_core.tables import load_system_tables

FM = 1600.0  # mesh frequency of the timing runs [Hz]
SPC = 128  # RK4 steps per mesh cycle
#: planetary kernel per mesh cycle over the spur 4-DOF kernel's, measured in one run (150 and 250 us over 7.0 us)
TARGET_RATIO = {3: 21.0, 5: 36.0}
TARGET_MODES_MS = 50.0
DISSERTATION_S_PER_CYCLE = 0.5


def kernel_us_per_cycle(system, cycles: int, repeats: int) -> tuple[float, float]:
    """(wall, CPU) microseconds per mesh cycle, best of ``repeats``."""
    s = static_state(system)
    fext = system.fext_speed()
    h = 1.0 / (FM * SPC)
    kin = np.array([0.0, 0.0, system.reference_speed(FM)])
    system.integrate(s, kin, SPC * 4, h, fext)  # compile / load cache, settle
    wall = cpu = math.inf
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        system.integrate(s, kin, cycles * SPC, h, fext)
        wall = min(wall, time.perf_counter() - t)
        cpu = min(cpu, time.process_time() - c)
    return wall / cycles * 1e6, cpu / cycles * 1e6


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer cycles and repeats")
    args = ap.parse_args(argv)
    cycles, repeats = (200, 3) if args.quick else (1000, 7)
    model = load_model("planetary_65_55_175")
    tables = load_system_tables("planetary_65_55_175")
    print(f"CPU the kernels are compiled for: {vector_units().describe()}")
    print(f"planetary_65_55_175, FE tables, {SPC} RK4 steps per mesh cycle at {FM:g} Hz, best of {repeats}:")
    spur = build_system(load_model("spur_28t_asym"), load_system_tables("spur_28t_asym"),
                        bearing_stiffness_N_per_m=2e8)
    ok = True
    for n in (3, 5):
        sy = build_system(model, tables, planet_count=n)
        wall, cpu = kernel_us_per_cycle(sy, cycles, repeats)
        _, ref = kernel_us_per_cycle(spur, cycles, repeats)   # the reference, right after, in the same process
        ratio = cpu / ref
        ok &= ratio <= TARGET_RATIO[n]
        print(f"  {n} planets ({sy.n} DOFs, {sy.m} meshes): {cpu:7.1f} us CPU per mesh cycle ({wall:.1f} us wall); "
              f"spur 4-DOF kernel {ref:.2f} us -> ratio {ratio:.1f} (target <= {TARGET_RATIO[n]:g}: "
              f"{'met' if ratio <= TARGET_RATIO[n] else 'MISSED'}); dissertation's HAC 0.5 s per cycle -> "
              f"{DISSERTATION_S_PER_CYCLE / (cpu * 1e-6):,.0f}x faster")
    sy5 = build_system(model, tables, planet_count=5)
    wc = sy5.carrier_ratio * sy5.reference_speed(FM)
    gyroscopic_modes(sy5, wc)
    best = best_b = math.inf
    for _ in range(repeats * 3):
        t = time.perf_counter()
        gm = gyroscopic_modes(sy5, wc)
        best = min(best, time.perf_counter() - t)
        t = time.perf_counter()
        gyroscopic_modes(build_system(model, tables, planet_count=5), wc)
        best_b = min(best_b, time.perf_counter() - t)
    ok &= best * 1e3 <= TARGET_MODES_MS
    print(f"  linearised modes, 5 planets at W_c = {wc:.2f} rad/s ({len(gm.natural_frequencies_Hz)} modes, "
          f"{gm.types.count('translational')} translational, {gm.types.count('rotational')} rotational, "
          f"{gm.types.count('planet')} planet): {best * 1e3:.2f} ms (target {TARGET_MODES_MS:g} ms -> ratio "
          f"{best * 1e3 / TARGET_MODES_MS:.3f}); with the system build from the tables {best_b * 1e3:.1f} ms")
    for n in (3, 5):
        sy = build_system(model, tables, planet_count=n)
        t = time.perf_counter()
        r = steady_state(sy, FM)
        print(f"  steady state at {FM:g} Hz, {n} planets: {r.status} after {r.cycles_run} cycles, "
              f"{time.perf_counter() - t:.3f} s")
    print("all targets met" if ok else "TARGET MISSED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
