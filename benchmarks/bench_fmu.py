#!/usr/bin/env python
"""FMU overhead: 1 s of simulated time through fmpy at a 1e-4 s communication step against the library run
directly with the same internal step, in one process.

Printed figures (wall seconds, best of ``--repeat``):

* ``library advance``: :class:`~hacgear_core.dynamics.simulator.Simulator` stepped with ``advance(1e-4)``
  10 000 times (the same communication grid, outputs read each step): the reference of the judged ratio;
* ``library run``: one ``run(1.0, record_dt_s=1e-4)`` call (the kernel's own loop, no per-step Python);
* ``fmpy simulate_fmu``: the FMU under ``fmpy.simulate_fmu`` (step 1e-4, outputs recorded every step);
* ``fmpy low-level``: ``doStep`` + ``getReal`` of the same outputs on fmpy's FMU2Slave;
* ``slave without importer`` (not judged): the FMU's Python slave class called directly (``do_step`` +
  ``get_real``), i.e. the FMU's own per-step work; ``fmpy low-level`` minus this is what pythonfmu's C wrapper
  and fmpy add per step;
* instantiate-to-first-doStep time of the FMU in this (warm) process.

Judged ratio: fmpy simulate_fmu / library advance (goal <= 1.5).

    python benchmarks/bench_fmu.py [--fmu dist/spur_28t_asym.fmu] [--speed-rpm 3000] [--repeat 3]
"""
from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUTPUTS = ["m12.force", "m12.deflection", "m12.dte", "m12.position", "pinion.speed"]
SPEED_IN = "pinion.speed_in"


def _fresh_process_first_step(fmu_path: Path, speed: float) -> list[float]:
    """Seconds from fmi2Instantiate to the end of the first doStep in two successive fresh processes."""
    import subprocess

    code = (
        "import time, json\n"
        "from fmpy import extract, read_model_description\n"
        "from fmpy.fmi2 import FMU2Slave\n"
        f"p = {str(fmu_path)!r}\n"
        "md = read_model_description(p); d = extract(p)\n"
        "vr = {v.name: v.valueReference for v in md.modelVariables}\n"
        "t0 = time.perf_counter()\n"
        "f = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,"
        " instanceName='x')\n"
        "f.instantiate(); f.setupExperiment(startTime=0.0); f.enterInitializationMode()\n"
        f"f.setReal([vr[{SPEED_IN!r}]], [{speed!r}]); f.exitInitializationMode(); f.doStep(0.0, 1e-4)\n"
        "print(json.dumps(time.perf_counter() - t0))\n"
        "f.terminate(); f.freeInstance()\n"
        "import shutil; shutil.rmtree(d, ignore_errors=True)\n"
    )
    out = []
    for _ in range(2):
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
        if p.returncode != 0:
            raise SystemExit(f"fresh-process run failed ({p.returncode}): {p.stderr[-2000:]}")
        out.append(float(p.stdout.strip().splitlines()[-1]))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fmu", help="spur-pair FMU (default: dist/spur_28t_asym.fmu, else a synthetic build)")
    ap.add_argument("--speed-rpm", type=float, default=3000.0, help="pinion speed [rpm]")
    ap.add_argument("--internal-step", type=float, default=2e-6, help="internal RK4 step [s]")
    ap.add_argument("--comm-step", type=float, default=1e-4,
                    help="communication step [s] (the judged figure uses 1e-4; larger steps show the per-step "
                         "cost of pythonfmu + fmpy amortised)")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)

    import fmpy
    import numpy as np
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from hacgear_core.dynamics.build import build_system
    from hacgear_core.dynamics.simulator import Simulator
    from hacgear_core.model import load_model
    from hacgear_core.tables import read_tables

    work = Path(tempfile.mkdtemp(prefix="hacgear_bench_fmu_"))
    synthetic = False
    if args.fmu:
        fmu_path = Path(args.fmu)
    elif (ROOT / "dist" / "spur_28t_asym.fmu").exists():
        fmu_path = ROOT / "dist" / "spur_28t_asym.fmu"
    else:
        from hacgear_core.fmu import build_fmu, synthetic_system_folder

        folder = synthetic_system_folder(ROOT / "models" / "spur_28t_asym" / "model.toml", work / "models")
        fmu_path = build_fmu(folder, work / "dist")
        synthetic = True
    speed = args.speed_rpm * 2 * math.pi / 60
    h_int, dt, t_end = args.internal_step, args.comm_step, 1.0
    n = int(round(t_end / dt))

    unz = extract(str(fmu_path))
    model = load_model(Path(unz) / "resources" / "model.toml")
    sim = Simulator(build_system(model, read_tables(Path(unz) / "resources" / "tables.h5")), internal_step_s=h_int)
    ip = sim.gear_index("pinion")

    def lib_advance():
        sim.reset(speed_rad_s=speed)
        sim.set_speed_input(speed_rad_s=speed)
        rec = np.empty((n, len(OUTPUTS)))
        for k in range(n):
            sim.advance(dt)
            rec[k] = (sim.mesh_force_N[0], sim.mesh_deflection_m[0], sim.dynamic_transmission_error_m[0],
                      sim.mesh_position[0], sim.speed_rad_s[ip])
        return rec

    def lib_run():
        sim.reset(speed_rad_s=speed)
        sim.set_speed_input(speed_rad_s=speed)
        return sim.run(t_end, dt)

    def fmu_high():
        return fmpy.simulate_fmu(str(fmu_path), stop_time=t_end, step_size=dt, output_interval=dt,
                                 start_values={SPEED_IN: speed, "internal_step": h_int}, output=OUTPUTS)

    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outs = [vr[o] for o in OUTPUTS]
    first_step = []

    def fmu_low():
        t0 = time.perf_counter()
        f = FMU2Slave(guid=md.guid, unzipDirectory=unz, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="bench")
        f.instantiate()
        f.setupExperiment(startTime=0.0)
        f.enterInitializationMode()
        f.setReal([vr[SPEED_IN], vr["internal_step"]], [speed, h_int])
        f.exitInitializationMode()
        rec = np.empty((n, len(OUTPUTS)))
        t = 0.0
        for k in range(n):
            f.doStep(t, dt)
            if k == 0:
                first_step.append(time.perf_counter() - t0)
            t += dt
            rec[k] = f.getReal(outs)
        f.terminate()
        f.freeInstance()
        return rec

    def slave_direct():
        from hacgear_core.fmu import HacgearSlave

        sl = HacgearSlave(instance_name="direct", resources=str(Path(unz) / "resources"))  # KIND "" accepts any
        sl.setup_experiment(0.0)
        sl.set_real([vr[SPEED_IN], vr["internal_step"]], [speed, h_int])
        sl.exit_initialization_mode()
        rec = np.empty((n, len(OUTPUTS)))
        t = 0.0
        for k in range(n):
            if not sl.do_step(t, dt):
                raise SystemExit(f"direct slave step failed: {[m.msg for m in sl.log_queue]}")
            t += dt
            rec[k] = sl.get_real(outs)
        return rec

    def best(fn):
        times, out = [], None
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            out = fn()
            times.append(time.perf_counter() - t0)
        return min(times), out

    fresh = _fresh_process_first_step(fmu_path, speed)
    fmu_high()  # warm-up (first instantiation in this process imports the slave module)
    t_adv, rec_adv = best(lib_advance)
    t_run, _ = best(lib_run)
    t_high, res = best(fmu_high)
    t_low, rec_low = best(fmu_low)
    t_direct, _ = best(slave_direct)
    same = np.max(np.abs(rec_low[:, 0] - rec_adv[:, 0])) / np.max(np.abs(rec_adv[:, 0]))
    nsub = int(math.ceil(dt / h_int - 1e-9))
    print(f"bench_fmu: {fmu_path.name}{' (synthetic tables)' if synthetic else ''}, pinion {args.speed_rpm:g} rpm, "
          f"1 s simulated, communication step {dt:g} s, internal step {dt / nsub:.3g} s ({nsub} RK4 sub-steps per "
          f"step, {n * nsub} in all), best of {args.repeat}")
    print(f"  library advance({dt:g}) x {n}:        {t_adv:7.3f} s")
    print(f"  library run(1 s, record {dt:g}):      {t_run:7.3f} s")
    print(f"  fmpy simulate_fmu:                  {t_high:7.3f} s")
    print(f"  fmpy low-level doStep+getReal:      {t_low:7.3f} s")
    print(f"  slave without importer (not judged): {t_direct:7.3f} s")
    print(f"  instantiate -> first doStep (warm): {min(first_step):7.3f} s")
    print(f"  fresh process, instantiate -> first doStep: {fresh[0]:.3f} s (1st process), {fresh[1]:.3f} s "
          f"(2nd process, numba cache warm; goal <= 1 s)")
    print(f"  max relative difference FMU vs library (mesh force): {same:.2e}")
    print(f"  per communication step: library {t_adv / n * 1e6:.1f} us, fmpy simulate_fmu {t_high / n * 1e6:.1f} us, "
          f"fmpy low-level {t_low / n * 1e6:.1f} us, slave without importer {t_direct / n * 1e6:.1f} us "
          f"(pythonfmu wrapper + fmpy add {(t_low - t_direct) / n * 1e6:.1f} us low-level, "
          f"{(t_high - t_direct) / n * 1e6:.1f} us in simulate_fmu)")
    print(f"RATIO fmpy simulate_fmu / library advance = {t_high / t_adv:.2f} (goal <= 1.5); "
          f"low-level / library advance = {t_low / t_adv:.2f}; simulate_fmu / library run = {t_high / t_run:.2f}")
    shutil.rmtree(unz, ignore_errors=True)
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
