"""Speed of the HAC dynamics core (one compiled kernel for every gear system).

Prints, measured in one run (CPU time, best of repeats, the compared loops alternating in one process: the machine
may be shared, and a loop timed first would pay the warm-up):
  1. the core kernel per mesh cycle [us] at 128 RK4 steps per cycle on the committed FE tables of the 28-tooth
     spur pair, 4-DOF (k_y = 200 N/um) and 2-DOF, both flanks (the committed tables' drive and coast sides) and
     drive flank only (the coast tables dropped), and the ratio two-sided / one-sided (target <= 1.05);
  1b. the batched kernel (:mod:`hacgear_core.dynamics.batch`) advancing K = 8 speeds (500-4000 Hz) of the 4-DOF pair
     (both flanks) in one call against the single-state kernel running the same 8 one after the other: CPU time per
     mesh cycle and lane, the throughput ratio (target >= 2) and whether the lanes equal the single-state runs bit
     for bit;
  2. a hand-scalarised one-sided 4-DOF spur RK4 kernel with the same bilinear lookup (every matrix entry a
     scalar, the practical limit on this machine) and the ratio core / hand-scalarised (aim <= 1.5);
  3. the idler chain (3 DOF, 2 meshes, both flanks) per mesh cycle at 128 RK4 steps (target <= 20 us; the dissertation's HAC
     took 7 ms);
  4. the 4-DOF spur model integrated with ``scipy.integrate.solve_ivp`` (RK45) and a
     ``scipy.interpolate.RegularGridInterpolator`` FDF lookup: cost per mesh cycle, agreement, speed ratio
     (target >= 100x);
  5. the wall time of a 200-speed up+down sweep on 2 worker processes (target <= 10 s), and the same sweep in
     this process with its two branches as two lanes of the batched kernel against the serial single-state sweep
     (CPU time, alternating; ratio, same rows bit for bit), and sweeps at 4 torques (8 branches) in this process as
     ``run_sweeps`` runs them by default (one 8-lane batched task) against the serial sweeps;
  6. the helical pair (12 DOF, one mesh, generalized FDF: W and M by trilinear lookup over position, deflection and
     twist) per mesh cycle at 128 RK4 steps on the committed tables of helical_28_33 (target <= 100 us; the
     dissertation's HAC: 10 ms).

Before the gear-train core (commit ed828f8, the spur-only kernel), ``python benchmarks/bench_dynamics.py`` measured
8.8-11.5 us (4-DOF) and 7.0-7.6 us (2-DOF) per mesh cycle on this machine (docs/dynamics.md "Speed").

Run: ``python benchmarks/bench_dynamics.py [--quick]``.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time

import numpy as np
from numba import njit

from hacgear_core.dynamics.batch import Lanes
from hacgear_core.dynamics.equilibrium import static_state
from hacgear_core.dynamics.steady import steady_state
from hacgear_core.dynamics.sweep import SweepSpec, run_sweep, run_sweeps
from hacgear_core.kinds import build_system, load_model
from hacgear_core.tables import load_system_tables
from hacgear_core.tables.interp import bilinear
from hacgear_core.workers import process_pool
from hacgear_core.cpu import vector_units

FM = 1500.0  # mesh frequency of the timing runs [Hz]
SPC = 128  # RK4 steps per mesh cycle


def kernel_us_per_cycle(system, cycles: int, repeats: int) -> float:
    return alternating([kernel_run(system, cycles)], repeats)[0] / cycles * 1e6


def kernel_run(system, cycles: int):
    """A call of the single-state kernel over ``cycles`` mesh cycles at ``FM`` from the static state (compiled or
    loaded here, outside any timing)."""
    s = static_state(system)
    fext = system.fext_speed()
    h = 1.0 / (FM * SPC)
    kin = np.array([0.0, 0.0, FM / system.zref_2pi])
    system.integrate(s, kin, SPC, h, fext)
    return lambda: system.integrate(s, kin, cycles * SPC, h, fext)


def alternating(runs, repeats: int) -> list[float]:
    """Best CPU time [s] of each callable in ``runs`` over ``repeats`` rounds; each round runs every callable once,
    starting with a different one each round (so no callable always runs first: warm-up and clock changes fall on
    each alike)."""
    best = [math.inf] * len(runs)
    for r in range(repeats):
        for k in range(len(runs)):
            i = (r + k) % len(runs)
            t = time.process_time()
            runs[i]()
            best[i] = min(best[i], time.process_time() - t)
    return best


def batched_vs_single(system, lanes: int, cycles: int, repeats: int) -> tuple[float, float, bool]:
    """CPU time per mesh cycle and lane [us] of ``lanes`` speeds (500-4000 Hz) advanced ``cycles`` cycles by the
    batched kernel in one call and by the single-state kernel one after the other (alternating, best of
    ``repeats``), and whether the lanes' states equal the single-state runs' bit for bit."""
    fms = np.linspace(500.0, 4000.0, lanes)
    fext = system.fext_speed()
    s0 = static_state(system)
    b = Lanes(system, lanes)

    def load():
        for j, fm in enumerate(fms):
            b.load(j, s0, [0.0, 0.0, system.reference_speed(fm)], 1.0 / (fm * SPC), fext, 0)

    singles = [(s0.copy(), np.array([0.0, 0.0, system.reference_speed(fm)]), 1.0 / (fm * SPC)) for fm in fms]

    def run_single():
        for s, kin, h in singles:
            system.integrate(s, kin, cycles * SPC, h, fext)

    load()
    b.run(SPC)  # compile / load cache
    system.integrate(s0.copy(), singles[0][1].copy(), SPC, singles[0][2], fext)
    tb, ts = alternating([lambda: b.run(cycles * SPC), run_single], repeats)
    load()
    b.run(cycles * SPC)
    same = True
    for j, (fm, (_, _, h)) in enumerate(zip(fms, singles)):
        s, kin = s0.copy(), np.array([0.0, 0.0, system.reference_speed(fm)])
        system.integrate(s, kin, cycles * SPC, h, fext)
        same = same and np.array_equal(s, b.state(j)) and np.array_equal(kin, b.kin(j))
    per = cycles * lanes
    return tb / per * 1e6, ts / per * 1e6, same


def batched_sweep(system, n_speeds: int, repeats: int, torque_factors=(1.0,),
                  batched: bool | None = True) -> tuple[float, float, bool]:
    """CPU time [s] of up+down sweeps of ``n_speeds`` speeds (500-4000 Hz) at ``torque_factors`` x the system's torque
    in this process: with ``run_sweeps(batched=batched)`` (their branches as lanes of the batched kernel) and
    serially with the single-state kernel (alternating, best of ``repeats``); whether the two give the same rows bit
    for bit."""
    fms = tuple(np.linspace(500.0, 4000.0, n_speeds))
    specs = [SweepSpec(system, fms, "both", torque_Nm=f * system.torque_Nm) for f in torque_factors]
    out = {}

    def go(b):
        out[b] = run_sweeps(specs, progress=False, batched=b)

    go(batched)  # compile / load the batched loop
    tb, ts = alternating([lambda: go(batched), lambda: go(False)], repeats)
    same = all(np.array_equal(x.branches[b].state, y.branches[b].state)
               and all(np.array_equal(x.branches[b].metrics[k], y.branches[b].metrics[k], equal_nan=True)
                       for k in x.branches[b].metrics)
               for x, y in zip(out[batched], out[False]) for b in ("up", "down"))
    return tb, ts, same


@njit(cache=True, inline="always", fastmath={"contract"})
def _deriv(a, b, cc, d, e, f, g, hh, tt, z1_2pi, m1, j1, m2, j2, ky1, ky2, rb1, rb2, c, f1, f2, tab, x0, inv_dx):
    x = a + rb1 * b - cc + rb2 * d
    fm = bilinear(tab, x0, inv_dx, tt + z1_2pi * b, x)
    if fm < 0.0:
        fm = 0.0
    return (e, f, g, hh,
            (-ky1 * a - (c[0, 0] * e + c[0, 1] * f + c[0, 2] * g + c[0, 3] * hh) - fm) / m1,
            (f1 - (c[1, 0] * e + c[1, 1] * f + c[1, 2] * g + c[1, 3] * hh) - fm * rb1) / j1,
            (-ky2 * cc - (c[2, 0] * e + c[2, 1] * f + c[2, 2] * g + c[2, 3] * hh) + fm) / m2,
            (f2 - (c[3, 0] * e + c[3, 1] * f + c[3, 2] * g + c[3, 3] * hh) - fm * rb2) / j2)


@njit(cache=True, fastmath={"contract"})
def _hand_4dof(s, n_steps, h, tau0, dtau, z1_2pi, m1, j1, m2, j2, ky1, ky2, rb1, rb2, c, f1, f2, tab, x0, inv_dx):
    """RK4 of the 4-DOF spur pair [y1, th1, y2, th2] written out scalar by scalar (diagonal M and K, full 4x4 C),
    allocation-free: every stage a tuple of scalars."""
    y = (s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7])
    tau = tau0
    hh = 0.5 * h
    for _ in range(n_steps):
        k1 = _deriv(y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7], tau,
                    z1_2pi, m1, j1, m2, j2, ky1, ky2, rb1, rb2, c, f1, f2, tab, x0, inv_dx)
        k2 = _deriv(y[0] + hh * k1[0], y[1] + hh * k1[1], y[2] + hh * k1[2], y[3] + hh * k1[3],
                    y[4] + hh * k1[4], y[5] + hh * k1[5], y[6] + hh * k1[6], y[7] + hh * k1[7], tau + 0.5 * dtau,
                    z1_2pi, m1, j1, m2, j2, ky1, ky2, rb1, rb2, c, f1, f2, tab, x0, inv_dx)
        k3 = _deriv(y[0] + hh * k2[0], y[1] + hh * k2[1], y[2] + hh * k2[2], y[3] + hh * k2[3],
                    y[4] + hh * k2[4], y[5] + hh * k2[5], y[6] + hh * k2[6], y[7] + hh * k2[7], tau + 0.5 * dtau,
                    z1_2pi, m1, j1, m2, j2, ky1, ky2, rb1, rb2, c, f1, f2, tab, x0, inv_dx)
        k4 = _deriv(y[0] + h * k3[0], y[1] + h * k3[1], y[2] + h * k3[2], y[3] + h * k3[3],
                    y[4] + h * k3[4], y[5] + h * k3[5], y[6] + h * k3[6], y[7] + h * k3[7], tau + dtau,
                    z1_2pi, m1, j1, m2, j2, ky1, ky2, rb1, rb2, c, f1, f2, tab, x0, inv_dx)
        q = h / 6.0
        y = (y[0] + q * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]), y[1] + q * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
             y[2] + q * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]), y[3] + q * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]),
             y[4] + q * (k1[4] + 2.0 * k2[4] + 2.0 * k3[4] + k4[4]), y[5] + q * (k1[5] + 2.0 * k2[5] + 2.0 * k3[5] + k4[5]),
             y[6] + q * (k1[6] + 2.0 * k2[6] + 2.0 * k3[6] + k4[6]), y[7] + q * (k1[7] + 2.0 * k2[7] + 2.0 * k3[7] + k4[7]))
        tau += dtau
        if tau >= 1.0:
            tau -= 1.0
    for i in range(8):
        s[i] = y[i]
    return tau


def hand_us_per_cycle(system, cycles: int, repeats: int) -> tuple[float, float]:
    """The hand-scalarised kernel on the same 4-DOF system: cost per cycle [us] and its mesh deflection after
    ``cycles`` cycles relative to the core's (same RK4, so ~1e-12)."""
    assert system.dof_names[0].endswith(".u_loa") and system.n == 4
    m1, j1, m2, j2 = np.diag(system.M)
    ky1, _, ky2, _ = np.diag(system.K)
    rb1, rb2 = system.V[0, 1], system.V[0, 3]
    fext = system.fext_speed()
    ta = system.table_arrays[0]
    h = 1.0 / (FM * SPC)
    omega = FM / system.zref_2pi
    args = (h, 0.0, system.zref_2pi * omega * h, system.zref_2pi, m1, j1, m2, j2, ky1, ky2, rb1, rb2,
            np.ascontiguousarray(system.C), fext[1], fext[3], ta.ftab, ta.x0, ta.inv_dx)
    s = static_state(system)
    _hand_4dof(s, SPC, *args)
    best = math.inf
    for _ in range(repeats):
        t = time.perf_counter()
        _hand_4dof(s, cycles * SPC, *args)
        best = min(best, time.perf_counter() - t)
    # agreement with the core over the same cycles from the same start
    a, b = static_state(system), static_state(system)
    _hand_4dof(a, 20 * SPC, *args)
    system.integrate(b, np.array([0.0, 0.0, omega]), 20 * SPC, h, fext)
    rel = abs(float(system.V[0] @ (a[:4] - b[:4]))) / abs(float(system.V[0] @ b[:4]))
    return best / cycles * 1e6, rel


def scipy_reference(system, cycles: int):
    """The same 4-DOF model, written the straightforward way: solve_ivp + RegularGridInterpolator."""
    from scipy.integrate import solve_ivp
    from scipy.interpolate import RegularGridInterpolator

    tab = system.meshes[0].table
    pos = np.append(np.asarray(tab.position), 1.0)  # periodic: repeat the first row at position 1
    f = np.asarray(tab.force_N)
    f = np.vstack([f, f[:1]])
    rgi = RegularGridInterpolator((pos, np.asarray(tab.deflection_m)), f, bounds_error=False, fill_value=None)
    n = system.n
    minv, kd, cm, v = np.diag(system.minv), np.diag(system.K), system.C, system.V[0]
    fext = system.fext_speed()
    omega = FM / system.zref_2pi
    iref = system.iref

    def rhs(t, y):
        q, qd = y[:n], y[n:]
        x = v @ q
        tau = (system.zref_2pi * (omega * t + q[iref])) % 1.0
        force = max(float(rgi((tau, x))), 0.0)
        acc = minv * (fext - kd * q - cm @ qd - force * v)
        return np.concatenate([qd, acc])

    y0 = static_state(system)
    t_end = cycles / FM
    t = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, t_end), y0, method="RK45", rtol=1e-8, atol=1e-12, max_step=1.0 / (FM * 32))
    dt = time.perf_counter() - t
    s = y0.copy()
    kin = np.array([0.0, 0.0, omega])
    system.integrate(s, kin, cycles * SPC, 1.0 / (FM * SPC), fext)
    return dt / cycles * 1e6, sol.nfev, float(v @ sol.y[:n, -1]), float(v @ s[:n])


def _warm(system):
    steady_state(system, 1000.0)
    return os.getpid()


def sweep_wall(system, n_speeds: int, workers: int) -> tuple[float, dict]:
    fm = tuple(np.linspace(500.0, 4000.0, n_speeds))
    spec = SweepSpec(system, fm, "both")
    with process_pool(workers) as ex:
        list(ex.map(_warm, [system] * workers))  # compile caches outside the timing
        t = time.perf_counter()
        res = run_sweep(spec, executor=ex, progress=False)
        wall = time.perf_counter() - t
    cycles = {b: int(np.sum(r.cycles_run)) for b, r in res.branches.items()}
    capped = {b: int(np.sum(~r.converged)) for b, r in res.branches.items()}
    return wall, {"cycles": cycles, "capped": capped,
                  "jumps": [(j.mesh, j.kind, round(j.frequency_Hz)) for j in res.jumps if j.confirmed]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer cycles/speeds (smoke run)")
    a = ap.parse_args()
    print(f"CPU the kernels are compiled for: {vector_units().describe()}", flush=True)
    cycles, repeats = (100, 10) if a.quick else (100, 200)  # many short runs: catch an uncontended core
    model = load_model("spur_28t_asym")
    tables = load_system_tables(model.path)
    s2 = build_system(model, tables)
    s4 = build_system(model, tables, bearing_stiffness_N_per_m=200e6)
    drive_only = {name: dataclasses.replace(t, coast=None) for name, t in tables.meshes.items()}
    s2_one = build_system(model, drive_only)
    s4_one = build_system(model, drive_only, bearing_stiffness_N_per_m=200e6)
    assert s4.two_sided and not s4_one.two_sided
    idler = load_model("idler_28_33_39")
    si = build_system(idler, load_system_tables(idler.path))
    print("tables: committed FE tables of spur_28t_asym and idler_28_33_39")
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs (shared machine: timings are "
          "best of repeats)")
    us4, us4_one = (t / cycles * 1e6 for t in alternating([kernel_run(s4, cycles), kernel_run(s4_one, cycles)],
                                                           repeats))
    us2, us2_one = (t / cycles * 1e6 for t in alternating([kernel_run(s2, cycles), kernel_run(s2_one, cycles)],
                                                           repeats))
    for label, two, one in (("4-DOF", us4, us4_one), ("2-DOF", us2, us2_one)):
        print(f"core kernel, spur {label}, {SPC} RK4 steps/cycle (CPU time, alternating): both flanks {two:.2f} us per "
              f"mesh cycle ({two / SPC * 1e3:.1f} ns/step), drive flank only {one:.2f} us; ratio two-sided / "
              f"one-sided {two / one:.3f} (target <= 1.05: {'MET' if two / one <= 1.05 else 'NOT MET'})")
    lanes = 8
    ub, us, same = batched_vs_single(s4, lanes, 20, max(repeats // 4, 5))
    print(f"batched kernel, spur 4-DOF both flanks, K = {lanes} speeds 500-4000 Hz in one call: {ub:.2f} us per mesh "
          f"cycle and lane, single-state kernel on the same speeds {us:.2f} us; throughput ratio {us / ub:.2f} "
          f"(target >= 2: {'MET' if us / ub >= 2 else 'NOT MET'}); lanes equal the single-state runs bit for bit: "
          f"{same}")
    ush, rel = hand_us_per_cycle(s4_one, cycles, repeats)
    print(f"hand-scalarised one-sided 4-DOF RK4, same lookup: {ush:.2f} us per mesh cycle (mesh deflection after 20 "
          f"cycles differs from the core by {rel:.1e} relative); ratio core (one-sided) / hand-scalarised "
          f"{us4_one / ush:.2f} (aim <= 1.5: {'MET' if us4_one / ush <= 1.5 else 'NOT MET'})")
    usi = kernel_us_per_cycle(si, cycles, repeats)
    print(f"core kernel, idler chain 3 DOF x 2 meshes, {SPC} RK4 steps/cycle: {usi:.2f} us per mesh cycle; target "
          f"<= 20 us: {'MET' if usi <= 20 else 'NOT MET'} (dissertation's HAC: 7000 us, ratio {7000 / usi:.0f}x)")
    ref_cycles = 10 if a.quick else 40
    us_ref, nfev, x_ref, x_hac = scipy_reference(s4, ref_cycles)
    print(f"scipy solve_ivp(RK45, rtol 1e-8) + RegularGridInterpolator, 4-DOF: {us_ref:.0f} us per mesh cycle "
          f"({nfev} RHS evaluations for {ref_cycles} cycles); mesh deflection after {ref_cycles} cycles: "
          f"scipy {x_ref * 1e6:.5f} um, kernel {x_hac * 1e6:.5f} um (difference {abs(x_ref - x_hac) * 1e9:.2f} nm)")
    ratio = us_ref / us4
    print(f"speed ratio kernel / straightforward: {ratio:.0f}x; target >= 100x: {'MET' if ratio >= 100 else 'NOT MET'}")
    n_speeds = 40 if a.quick else 200
    wall2, info2 = sweep_wall(s2, n_speeds, 2)
    print(f"{n_speeds}-speed up+down sweep (500-4000 Hz, 2-DOF, 300 N m), 2 worker processes: {wall2:.2f} s wall; "
          f"mesh cycles integrated {info2['cycles']}, speeds at the cycle cap {info2['capped']}, confirmed jumps "
          f"{info2['jumps']}; target <= 10 s: {'MET' if wall2 <= 10 else 'NOT MET'}")
    tb, ts, same = batched_sweep(s2, n_speeds, 3)
    print(f"{n_speeds}-speed up+down sweep (500-4000 Hz, 2-DOF), this process (CPU time, alternating): up and down "
          f"as 2 lanes of the batched kernel {tb:.2f} s, serial single-state {ts:.2f} s; ratio serial / batched "
          f"{ts / tb:.2f}; same rows bit for bit: {same}")
    nt = 4
    tb, ts, same = batched_sweep(s2, n_speeds // 4, 2, (1.0, 0.75, 0.5, 0.25), None)
    print(f"{n_speeds // 4}-speed up+down sweeps at {nt} torques (300, 225, 150, 75 N m; 2-DOF), this process (CPU "
          f"time, alternating): run_sweeps' default (their {2 * nt} branches as one {2 * nt}-lane batched task) "
          f"{tb:.2f} s, serial single-state {ts:.2f} s; ratio serial / batched {ts / tb:.2f}; same rows bit for bit: "
          f"{same}")
    wall4, info4 = sweep_wall(s4, n_speeds, 2)
    print(f"{n_speeds}-speed up+down sweep, 4-DOF (k_y = 200 N/um), 2 worker processes: {wall4:.2f} s wall; "
          f"mesh cycles integrated {info4['cycles']}, speeds at the cap {info4['capped']}")
    hel = load_model("helical_28_33")
    sh = build_system(hel, load_system_tables(hel.path))
    ush12 = kernel_us_per_cycle(sh, cycles, repeats)
    print(f"core kernel, helical pair 12 DOF x 1 mesh (trilinear W, M), {SPC} RK4 steps/cycle: {ush12:.2f} us per "
          f"mesh cycle ({ush12 / SPC * 1e3:.0f} ns/step); target <= 100 us: {'MET' if ush12 <= 100 else 'NOT MET'} "
          f"(dissertation's HAC: 10000 us, ratio {10000 / ush12:.0f}x)")
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
