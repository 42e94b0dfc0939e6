#!/usr/bin/env python
"""The NREL 5 MW gearbox FMU at rated speed: real-time factor on one core and CPU time per high-speed mesh cycle.

The native FMI 2.0 FMU of ``models/nrel_5mw_gearbox`` (built here, or ``--fmu``) is run through fmpy's low-level
FMU2Slave in this process, numba and BLAS held to one thread, after a warm-up step (compilation and the system's
assembly are not timed):

* constant speed (``mode`` 0): the rotor-side port ``carrier1`` at the rated 12.1 rpm, the rated torque 3.946e6 N m;
* drivetrain coupling (``mode`` 1): the ports driven by their rated torques (``carrier1.torque_in`` the rotor torque,
  ``pinion3.torque_in`` the generator's braking torque T 48/4625), started at the rated speed;

each for ``--seconds`` of simulated time at the communication step ``--step``.  Printed: CPU time of this process,
the real-time factor (simulated time / CPU time; judged: >= 1, faster than real time on one core), the CPU time
per high-speed mesh cycle (the helical stage's mesh at 466.35 Hz at rated speed), and the CPU's vector units.

``--statics``: also time ``hacgear statics nrel_5mw_gearbox --workers 2`` into a scratch file (about 12 minutes on
2 cores) with its peak resident memory (goal: <= 1 h).

    python benchmarks/bench_gearbox_fmu.py [--fmu FILE] [--seconds 5] [--step 1e-3] [--statics]
"""
from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from hacgear_core.cpu import vector_units  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = ROOT / "models" / "nrel_5mw_gearbox"
RATED_RPM = 12.1
RATED_TORQUE_NM = 3.94599e6
HS_MESH_PER_INPUT_REV = 4625 / 2          # stage 3 mesh cycles per carrier-1 revolution (exact)
GOAL = 1.0


def _run(fmu: Path, mode: int, seconds: float, step: float) -> dict:
    """CPU and wall time of ``seconds`` simulated at communication step ``step`` in ``mode``."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    d = extract(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="b")
    w = RATED_RPM * 2 * math.pi / 60
    try:
        f.instantiate()
        f.setupExperiment(startTime=0.0)
        f.enterInitializationMode()
        f.setInteger([vr["mode"]], [mode])
        f.setReal([vr["carrier1.speed_start"], vr["carrier1.speed_in"], vr["torque"]], [w, w, RATED_TORQUE_NM])
        if mode == 1:
            f.setReal([vr["carrier1.torque_in"], vr["pinion3.torque_in"]],
                      [RATED_TORQUE_NM, -RATED_TORQUE_NM * 48 / 4625])
        f.exitInitializationMode()
        outs = [vr[n] for n in ("s3_wheel_pinion.force", "ims_shaft.torque", "carrier1.speed")]
        t = 0.0
        f.doStep(t, step)          # warm-up: the kernel's first call
        t += step
        n = int(round(seconds / step))
        c0, w0 = time.process_time(), time.perf_counter()
        for _ in range(n):
            f.doStep(t, step)
            f.getReal(outs)
            t += step
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        speed = f.getReal([vr["carrier1.speed"]])[0]
    finally:
        f.terminate()
        f.freeInstance()
        shutil.rmtree(d, ignore_errors=True)
    sim = n * step
    return {"simulated_s": sim, "cpu_s": cpu, "wall_s": wall, "rtf": sim / cpu, "end_speed_rad_s": speed,
            "us_per_hs_mesh_cycle": 1e6 * cpu / (HS_MESH_PER_INPUT_REV * RATED_RPM / 60 * sim)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fmu", type=Path, default=None, help="the gearbox FMU (default: build it here)")
    ap.add_argument("--seconds", type=float, default=5.0, help="simulated time per mode [s] (default 5)")
    ap.add_argument("--step", type=float, default=1e-3, help="communication step [s] (default 1e-3)")
    ap.add_argument("--statics", action="store_true", help="also time the gearbox's statics (about 12 min)")
    args = ap.parse_args(argv)
    print(f"CPU: {vector_units()}; python {sys.version.split()[0]}; one thread (NUMBA_NUM_THREADS="
          f"{os.environ['NUMBA_NUM_THREADS']})")
    tmp = Path(tempfile.mkdtemp(prefix="bench_gearbox_"))
    try:
        fmu = args.fmu
        if fmu is None:
            from hacgear_core.fmu import build_fmu
            t0 = time.perf_counter()
            fmu = build_fmu(SYSTEM, tmp, fmi_version=2, backend="native")
            print(f"built {fmu.name} in {time.perf_counter() - t0:.1f} s")
        verdicts = []
        for mode, label in ((0, "constant speed (mode 0)"), (1, "drivetrain coupling (mode 1), rated port torques")):
            r = _run(fmu, mode, args.seconds, args.step)
            ok = r["rtf"] >= GOAL
            verdicts.append(ok)
            print(f"{label}: {r['simulated_s']:g} s simulated in {r['cpu_s']:.2f} s CPU ({r['wall_s']:.2f} s wall) -> "
                  f"real-time factor {r['rtf']:.2f} (goal >= {GOAL:g}: {'met' if ok else 'MISSED'}); "
                  f"{r['us_per_hs_mesh_cycle']:.1f} us CPU per high-speed mesh cycle (466.35 Hz at rated); "
                  f"input speed at the end {r['end_speed_rad_s']:.4f} rad/s")
        if args.statics:
            out = tmp / "tables.h5"
            cmd = [sys.executable, "-m", "hacgear_core.cli", "statics", str(SYSTEM), "--workers", "2", "--out", str(out)]
            t0 = time.perf_counter()
            before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
            subprocess.run(cmd, check=True, env={**os.environ, "HACGEAR_CACHE_DIR": str(tmp / "cache")})
            wall = time.perf_counter() - t0
            rss = max(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, before) / 1024 ** 2
            print(f"statics: {wall / 60:.1f} min wall on 2 workers (goal <= 60 min: {'met' if wall <= 3600 else 'MISSED'}),"
                  f" peak RSS of a child process {rss:.2f} GB")
        return 0 if all(verdicts) else 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    raise SystemExit(main())
