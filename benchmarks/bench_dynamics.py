"""Speed of the HAC spur-pair dynamics (compiled kernel) against a straightforward SciPy implementation.

Prints
  1. kernel cost per mesh cycle [us] (128 RK4 steps per cycle), 4-DOF (k_y = 200 N/um) and 2-DOF,
     best of several repeats (the machine may be shared);
  2. the same model integrated with ``scipy.integrate.solve_ivp`` (RK45) and a
     ``scipy.interpolate.RegularGridInterpolator`` FDF lookup: cost per mesh cycle, agreement of the
     two solutions, and the speed ratio;
  3. wall time of a 200-speed up+down sweep (steady state detected at every speed) with the two
     branches on 2 worker processes.

Targets (issue 5): <= 10 us per mesh cycle; >= 100x the straightforward implementation;
200-speed up+down sweep <= 10 s on 2 cores.  Tables: the committed FE tables of spur_28t_asym (default)
or, with ``--table synthetic``, the synthetic table (hacgear_core.dynamics.synthetic); 300 N m.

Run: ``python benchmarks/bench_dynamics.py [--quick]``.
"""
from __future__ import annotations

import argparse
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from hacgear_core.dynamics.spur import SpurPairSystem
from hacgear_core.dynamics.steady import steady_state
from hacgear_core.dynamics.sweep import SweepSpec, run_sweep
from hacgear_core.dynamics.synthetic import spur_fdf_table, synthetic_28t_parameters

FM = 1500.0  # mesh frequency of the timing runs [Hz]
SPC = 128  # RK4 steps per mesh cycle


def kernel_us_per_cycle(system: SpurPairSystem, cycles: int, repeats: int) -> float:
    s = system.static_state(0.0)
    fext = system.fext_speed()
    h = 1.0 / (FM * SPC)
    kin = np.array([0.0, 0.0, FM / system.z1_2pi])
    system.integrate(s, kin, SPC, h, fext)  # compile / load cache
    best = math.inf
    for _ in range(repeats):
        t = time.perf_counter()
        system.integrate(s, kin, cycles * SPC, h, fext)
        best = min(best, time.perf_counter() - t)
    return best / cycles * 1e6


def scipy_reference(system: SpurPairSystem, cycles: int):
    """The same 4-DOF model, written the straightforward way: solve_ivp + RegularGridInterpolator."""
    from scipy.integrate import solve_ivp
    from scipy.interpolate import RegularGridInterpolator

    tab = system.table
    pos = np.append(np.asarray(tab.position), 1.0)  # periodic: repeat the first row at position 1
    f = np.asarray(tab.force_N)
    f = np.vstack([f, f[:1]])
    rgi = RegularGridInterpolator((pos, np.asarray(tab.deflection_m)), f, bounds_error=False, fill_value=None)
    n = system.n
    minv, kd, cm, v = system.minv, system.kd, system.cm, system.v
    fext = system.fext_speed()
    omega = FM / system.z1_2pi

    def rhs(t, y):
        q, qd = y[:n], y[n:]
        x = v @ q
        tau = (system.z1_2pi * (omega * t + q[system.ith1])) % 1.0
        force = max(float(rgi((tau, x))), 0.0)
        acc = minv * (fext - kd * q - cm @ qd - force * v)
        return np.concatenate([qd, acc])

    y0 = system.static_state(0.0)
    t_end = cycles / FM
    t = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, t_end), y0, method="RK45", rtol=1e-8, atol=1e-12, max_step=1.0 / (FM * 32))
    dt = time.perf_counter() - t
    # the compiled kernel over the same interval
    s = y0.copy()
    kin = np.array([0.0, 0.0, omega])
    system.integrate(s, kin, cycles * SPC, 1.0 / (FM * SPC), fext)
    x_ref = float(v @ sol.y[:n, -1])
    x_hac = float(v @ s[:n])
    return dt / cycles * 1e6, sol.nfev, x_ref, x_hac


def sweep_wall(table, params, n_speeds: int, workers: int) -> tuple[float, dict]:
    fm = tuple(np.linspace(500.0, 4000.0, n_speeds))
    spec = SweepSpec(params, table, fm, "both")
    # warm the workers' compile caches outside the timing
    with ProcessPoolExecutor(workers) as ex:
        list(ex.map(_warm, [(params, table)] * workers))
        t = time.perf_counter()
        res = run_sweep(spec, executor=ex, progress=False)
        wall = time.perf_counter() - t
    cycles = {b: int(np.sum(r.cycles_run)) for b, r in res.branches.items()}
    capped = {b: int(np.sum(~r.converged)) for b, r in res.branches.items()}
    return wall, {"cycles": cycles, "capped": capped, "jumps": [(j.kind, round(j.frequency_Hz)) for j in res.jumps
                                                                if j.confirmed]}


def _warm(args):
    params, table = args
    steady_state(SpurPairSystem(params, table), 1000.0)
    return os.getpid()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer cycles/speeds (smoke run)")
    ap.add_argument("--table", choices=("fe", "synthetic"), default="fe",
                    help="committed FE tables of spur_28t_asym (default) or the synthetic table")
    a = ap.parse_args()
    cycles, repeats = (100, 10) if a.quick else (100, 200)  # many short runs: catch an uncontended core
    ap_table = a.table
    if ap_table == "fe":  # the committed FE tables of the 28-tooth pair (the real case)
        from dataclasses import replace as _replace

        from hacgear_core.dynamics.spur import from_model
        from hacgear_core.model import load_model
        from hacgear_core.tables import load_system_tables

        model = load_model("spur_28t_asym")
        table = load_system_tables(model.path).meshes["m12"]
        p2 = from_model(model, "m12", table)
        p4 = _replace(p2, bearing_stiffness_N_per_m=(200e6, 200e6))
        print("tables: committed FE tables models/spur_28t_asym/tables.h5")
    else:
        table = spur_fdf_table(tip_relief_m=20e-6)
        p4 = synthetic_28t_parameters(table, bearing_stiffness_N_per_m=200e6)
        p2 = synthetic_28t_parameters(table)
        print("tables: SYNTHETIC (hacgear_core.dynamics.synthetic)")
    s4, s2 = SpurPairSystem(p4, table), SpurPairSystem(p2, table)
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs (shared machine: timings are "
          "best of repeats)")
    us4 = kernel_us_per_cycle(s4, cycles, repeats)
    us2 = kernel_us_per_cycle(s2, cycles, repeats)
    print(f"kernel, 4-DOF, {SPC} RK4 steps/cycle: {us4:.2f} us per mesh cycle ({us4 / SPC * 1e3:.1f} ns/step); "
          f"target <= 10 us: {'MET' if us4 <= 10 else 'NOT MET'}")
    print(f"kernel, 2-DOF, {SPC} RK4 steps/cycle: {us2:.2f} us per mesh cycle ({us2 / SPC * 1e3:.1f} ns/step)")
    ref_cycles = 10 if a.quick else 40
    us_ref, nfev, x_ref, x_hac = scipy_reference(s4, ref_cycles)
    print(f"scipy solve_ivp(RK45, rtol 1e-8) + RegularGridInterpolator, 4-DOF: {us_ref:.0f} us per mesh cycle "
          f"({nfev} RHS evaluations for {ref_cycles} cycles); mesh deflection after {ref_cycles} cycles: "
          f"scipy {x_ref * 1e6:.5f} um, kernel {x_hac * 1e6:.5f} um (difference {abs(x_ref - x_hac) * 1e9:.2f} nm)")
    ratio = us_ref / us4
    print(f"speed ratio kernel / straightforward: {ratio:.0f}x; target >= 100x: {'MET' if ratio >= 100 else 'NOT MET'}")
    n_speeds = 40 if a.quick else 200
    wall2, info2 = sweep_wall(table, p2, n_speeds, 2)
    print(f"{n_speeds}-speed up+down sweep (500-4000 Hz, 2-DOF, 300 N m), 2 worker processes: {wall2:.2f} s wall; "
          f"mesh cycles integrated {info2['cycles']}, speeds at the cycle cap {info2['capped']}, confirmed jumps "
          f"{info2['jumps']}; target <= 10 s: {'MET' if wall2 <= 10 else 'NOT MET'}")
    wall4, info4 = sweep_wall(table, p4, n_speeds, 2)
    print(f"{n_speeds}-speed up+down sweep, 4-DOF (k_y = 200 N/um), 2 worker processes: {wall4:.2f} s wall; "
          f"mesh cycles integrated {info4['cycles']}, speeds at the cap {info4['capped']}")
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
