#!/usr/bin/env python
"""FMU per-step cost: 1 s of simulated time at a 1e-4 s communication step (10 000 steps), in one process.

Printed figures (CPU microseconds of this process per communication step, the best of ``--repeat`` runs taken
in turns, so that other load on the machine affects all alike):

* ``library advance``: :class:`~hacgear_core.dynamics.simulator.Simulator` stepped with ``advance(dt)``, the
  same outputs read each step: the reference of the judged ratio;
* ``FMU slave``: the FMU's own Python side (:class:`~hacgear_core.fmu.slave.FmuInstance` of the FMU's bundled
  code, ``do_step`` + ``get_real`` of the same outputs) called directly: the FMU's own cost per step;
* ``fmpy low-level``: ``doStep`` + ``getReal`` through fmpy's FMU2Slave, i.e. the FMU's binary and fmpy's
  ctypes layer on top of the slave (reported, not judged: no slave can remove it);
* ``fmpy simulate_fmu``: fmpy's high-level call with its recording (reported);
* real-time factors (simulated time / CPU time) of the library, the slave and fmpy low-level at this step;
* fresh processes: instantiate -> end of the first ``doStep`` in two successive fresh processes (the second
  loads the compiled kernels and the assembled system from the per-user cache; goal <= 1 s);
* the same for the pythonfmu backend's FMU (``build_fmu(..., backend="pythonfmu")``): its slave class
  (``HacgearSlave``, the Fmi2Slave subclass pythonfmu's binary calls) called directly, and fmpy low-level through
  pythonfmu's binary (reported).

Judged: native FMU slave / library advance (goal <= 1.25); the pythonfmu slave's ratio is reported.

``--first-step``: only the fresh-process figures, for one system of each kind (or ``--systems``), each from
``fmi2Instantiate`` to the end of the first ``doStep`` in a fresh process: wall and CPU time and the process's peak
resident memory, of three runs per system:

* cold, shipped code: the FMU as built (with the compiled numba code of its run, ``resources/numba_cache/``) in a
  fresh process with empty caches (a new FMU cache folder, so the bundled code and numba's cache of it are new):
  what an importer with the builder's numba, Python and CPU sees the first time;
* cold, compiling: the same FMU built without that code (``build_fmu(..., compiled_code=False)``), empty caches:
  what an importer with another numba or CPU sees the first time (numba compiles, once per machine);
* warm: the first FMU again in a fresh process with the caches the cold run left.

Targets: cold <= 15 s and <= 1 GB (judged on the shipped-code run), warm <= 1 s, on wall time (the verdict on
CPU time is printed beside it: other load on the machine stretches wall time); each figure is printed with its
ratio to the target.

    python benchmarks/bench_fmu.py [--system spur_28t_asym] [--fmu FILE] [--pythonfmu-fmu FILE] [--speed-rpm 3000]
        [--repeat 5]
    python benchmarks/bench_fmu.py --first-step [--systems spur_28t_asym,idler_28_33_39,...]
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from hacgear_core.cpu import vector_units

ROOT = Path(__file__).resolve().parent.parent
GOAL = 1.25

#: one system of each kind (spur pair, idler chain, planetary set, helical pair)
KIND_SYSTEMS = ("spur_28t_asym", "idler_28_33_39", "planetary_65_55_175", "helical_28_33")
COLD_TARGET_S, COLD_TARGET_MB, WARM_TARGET_S = 15.0, 1024.0, 1.0

_FRESH = r"""
import json, resource, shutil, time
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

p = {fmu!r}
md = read_model_description(p); d = extract(p)
vr = {{v.name: v.valueReference for v in md.modelVariables}}
t0, c0 = time.perf_counter(), time.process_time()
f = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier, instanceName='x')
f.instantiate(); f.setupExperiment(startTime=0.0); f.enterInitializationMode()
f.setReal([vr[{speed_in!r}]], [{speed!r}]); f.exitInitializationMode(); f.doStep(0.0, 1e-4)
print(json.dumps([time.perf_counter() - t0, time.process_time() - c0,
                  resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0]))
f.terminate(); f.freeInstance(); shutil.rmtree(d, ignore_errors=True)
"""


def fresh_process_first_step(fmu_path: Path, speed_in: str, speed: float, runs: int = 2,
                             cache_dir: str | None = None) -> list[list[float]]:
    """[wall s, CPU s, peak resident memory MB] from fmi2Instantiate to the end of the first doStep in ``runs``
    successive fresh processes; with ``cache_dir`` they use it as the FMUs' cache folder (``HACGEAR_FMU_CACHE``:
    an empty folder makes the first run cold)."""
    env = dict(os.environ)
    if cache_dir is not None:
        env["HACGEAR_FMU_CACHE"] = str(cache_dir)
        env.pop("NUMBA_CACHE_DIR", None)  # numba caches next to the bundled code, in that folder
    out = []
    for _ in range(runs):
        p = subprocess.run([sys.executable, "-c", _FRESH.format(fmu=str(fmu_path), speed_in=speed_in, speed=speed)],
                           capture_output=True, text=True, timeout=1800, env=env)
        if p.returncode != 0:
            raise SystemExit(f"fresh-process run failed ({p.returncode}): {p.stderr[-2000:]}")
        out.append(json.loads(p.stdout.strip().splitlines()[-1]))
    return out


def first_step_per_kind(systems, speed_rpm: float, as_json: bool) -> int:
    """Cold (shipped code; compiling) and warm fresh-process first-doStep figures of one FMU per system in
    ``systems``."""
    from hacgear_core.fmu import build_fmu
    from hacgear_core.model import resolve_model_path

    speed = speed_rpm * 2 * math.pi / 60
    figs = []
    ok = True
    if not as_json:
        print(f"fresh process, fmi2Instantiate -> end of the first doStep (wall s, CPU s, peak RSS MB; ratio to the "
              f"target: cold <= {COLD_TARGET_S:g} s and <= {COLD_TARGET_MB:g} MB, warm <= {WARM_TARGET_S:g} s)",
              flush=True)
    for system in systems:
        work = Path(tempfile.mkdtemp(prefix="hacgear_bench_fmu_"))
        try:
            folder = resolve_model_path(system).parent
            fmu_path = build_fmu(folder, work / "dist")
            bare_path = build_fmu(folder, work / "bare", compiled_code=False)
            info = _fmu_info(fmu_path)
            speed_in = f"{info['reference_gear']}.speed_in"
            (cold, warm) = fresh_process_first_step(fmu_path, speed_in, speed, cache_dir=str(work / "cache"))
            (compiling,) = fresh_process_first_step(bare_path, speed_in, speed, runs=1,
                                                    cache_dir=str(work / "cache_bare"))
        finally:
            shutil.rmtree(work, ignore_errors=True)
        met = cold[0] <= COLD_TARGET_S and cold[2] <= COLD_TARGET_MB and warm[0] <= WARM_TARGET_S
        met_cpu = cold[1] <= COLD_TARGET_S and cold[2] <= COLD_TARGET_MB and warm[1] <= WARM_TARGET_S
        ok &= met
        fig = {"system": system, "met": met, "met_on_cpu_time": met_cpu}
        for key, run, target in (("cold_shipped", cold, COLD_TARGET_S), ("cold_compiling", compiling, COLD_TARGET_S),
                                 ("warm", warm, WARM_TARGET_S)):
            fig[key] = {"wall_s": run[0], "cpu_s": run[1], "peak_rss_MB": run[2], "ratio_time": run[0] / target,
                        "ratio_rss": run[2] / COLD_TARGET_MB}
        figs.append(fig)
        if not as_json:
            print(f"{system}: {'met' if met else 'MISSED'} (on CPU time instead of wall time: "
                  f"{'met' if met_cpu else 'MISSED'})")
            for key, words in (("cold_shipped", "cold, shipped code"), ("cold_compiling", "cold, compiling  "),
                               ("warm", "warm              ")):
                f = fig[key]
                print(f"  {words} {f['wall_s']:6.2f} s (CPU {f['cpu_s']:6.2f} s) = {f['ratio_time']:5.2f} x target, "
                      f"peak RSS {f['peak_rss_MB']:5.0f} MB = {f['ratio_rss']:4.2f} x 1 GB", flush=True)
    if as_json:
        print(json.dumps({"load_average": os.getloadavg()[0], "cpus": os.cpu_count(), "first_step": figs}, indent=1))
    else:
        print(f"load average at the end: {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs (wall times grow with "
              "other load; CPU times much less)")
    return 0 if ok else 1


def _fmu_info(fmu_path: Path) -> dict:
    import zipfile

    with zipfile.ZipFile(fmu_path) as z:
        return json.loads(z.read("resources/hacgear_fmu.json"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--system", default="spur_28t_asym", help="system to build when --fmu is not given")
    ap.add_argument("--fmu", help="hacgear FMI 2.0 FMU (default: built from --system's committed tables)")
    ap.add_argument("--pythonfmu-fmu", help="hacgear FMI 2.0 FMU of the pythonfmu backend (default: built from "
                                            "--system's committed tables)")
    ap.add_argument("--speed-rpm", type=float, default=3000.0, help="speed of the reference gear [rpm]")
    ap.add_argument("--internal-step", type=float, default=2e-6, help="internal RK4 step [s] (0 = automatic)")
    ap.add_argument("--comm-step", type=float, default=1e-4, help="communication step [s]")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")
    ap.add_argument("--first-step", action="store_true",
                    help="only the cold (shipped code; compiling) and warm fresh-process first-doStep time and peak "
                         "memory, per system")
    ap.add_argument("--systems", default=",".join(KIND_SYSTEMS),
                    help="comma-separated systems of --first-step (default: one of each kind)")
    args = ap.parse_args(argv)
    print(f"CPU the kernels are compiled for: {vector_units().describe()}", flush=True)
    if args.first_step:
        return first_step_per_kind([s for s in args.systems.split(",") if s], args.speed_rpm, args.json)

    import fmpy
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from hacgear_core.kinds import build_system
    from hacgear_core.dynamics.simulator import Simulator
    from hacgear_core.fmu import bootstrap, build_fmu
    from hacgear_core.model import resolve_model_path
    from hacgear_core.kinds import load_model
    from hacgear_core.tables import read_tables

    work = Path(tempfile.mkdtemp(prefix="hacgear_bench_fmu_"))
    try:
        fmu_path = Path(args.fmu) if args.fmu else build_fmu(resolve_model_path(args.system).parent, work)
        unz = Path(extract(str(fmu_path)))
        res = unz / "resources"
        info = json.loads((res / "hacgear_fmu.json").read_text())
        ref, mesh = info["reference_gear"], next(iter(info["meshes"]))
        outputs = [f"{mesh}.force", f"{mesh}.deflection", f"{mesh}.dte", f"{mesh}.position", f"{ref}.speed"]
        speed = args.speed_rpm * 2 * math.pi / 60
        h_int = args.internal_step or None
        dt, t_end = args.comm_step, 1.0
        n = int(round(t_end / dt))

        model = load_model(res / "model.toml")
        sim = Simulator(build_system(model, read_tables(res / "tables.h5", res / "model.toml")), internal_step_s=h_int)

        def library():
            sim.reset(speed_rad_s=speed)
            sim.set_speed_input(speed_rad_s=speed)
            adv = sim.advance
            for _ in range(n):
                adv(dt)
                (sim.mesh_force_N[0], sim.mesh_deflection_m[0], sim.dynamic_transmission_error_m[0],
                 sim.mesh_position[0], sim.speed_rad_s[0])

        # the FMU's own Python side, from its bundled code (as the binary loads it)
        inst = bootstrap.instantiate("bench", str(res), info["guid"], False, 2)
        vrs = tuple(inst.vrs[o] for o in outputs)  # the binary passes a tuple

        def slave():
            inst.reset()
            inst.enter_initialization_mode(0.0)
            inst.set_real([inst.vrs[f"{ref}.speed_in"], inst.vrs["internal_step"]], [speed, args.internal_step])
            assert inst.exit_initialization_mode() == 0, inst.messages
            step, get = inst.do_step, inst.get_real
            t = 0.0
            for _ in range(n):
                step(t, dt)
                t += dt
                get(vrs)

        py_path = (Path(args.pythonfmu_fmu) if args.pythonfmu_fmu else
                   build_fmu(resolve_model_path(args.system).parent, work / "pythonfmu", backend="pythonfmu"))
        py_unz = Path(extract(str(py_path)))
        py_res = py_unz / "resources"
        module = (py_res / "slavemodule.txt").read_text().strip()
        spec = importlib.util.spec_from_file_location(module, py_res / f"{module}.py")
        py_module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(py_module)

        def py_slave():
            ps = py_module.HacgearSlave(instance_name="bench", resources=str(py_res))
            ps.setup_experiment(0.0)
            ps.enter_initialization_mode()
            ps.set_real([ps._inst.vrs[f"{ref}.speed_in"], ps._inst.vrs["internal_step"]], [speed, args.internal_step])
            ps.exit_initialization_mode()
            step, get = ps.do_step, ps.get_real
            py_vrs = list(vrs)  # pythonfmu's binary passes a list
            t = 0.0
            t0 = time.process_time()
            for _ in range(n):
                step(t, dt)
                t += dt
                get(py_vrs)
            return time.process_time() - t0

        def low_level_of(path, unzipped):
            md = read_model_description(str(path))
            vr = {v.name: v.valueReference for v in md.modelVariables}
            low_vrs = [vr[o] for o in outputs]

            def low_level():
                return _low_level(md, vr, low_vrs, unzipped)
            return low_level

        def _low_level(md, vr, low_vrs, unzipped):
            f = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped), modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName="bench")
            f.instantiate()
            f.setupExperiment(startTime=0.0)
            f.enterInitializationMode()
            f.setReal([vr[f"{ref}.speed_in"], vr["internal_step"]], [speed, args.internal_step])
            f.exitInitializationMode()
            step, get = f.doStep, f.getReal
            t = 0.0
            t0 = time.process_time()
            for _ in range(n):
                step(t, dt)
                t += dt
                get(low_vrs)
            wall = time.process_time() - t0
            f.terminate()
            f.freeInstance()
            return wall

        def high_level():
            fmpy.simulate_fmu(str(fmu_path), stop_time=t_end, output_interval=dt, output=outputs,
                              start_values={f"{ref}.speed_in": speed, "internal_step": args.internal_step})

        def timed(fn):
            t0 = time.process_time()
            r = fn()
            return r if isinstance(r, float) else time.process_time() - t0

        low_level = low_level_of(fmu_path, unz)
        py_low_level = low_level_of(py_path, py_unz)
        library()  # warm-up (compilation, caches)
        slave()
        py_slave()
        runs = {"library": [], "slave": [], "low": [], "high": [], "py_slave": [], "py_low": []}
        for _ in range(args.repeat):  # in turns
            for key, fn in (("library", library), ("slave", slave), ("low", low_level), ("high", high_level),
                            ("py_slave", py_slave), ("py_low", py_low_level)):
                runs[key].append(timed(fn))
        t_lib, t_slave, t_low, t_high, t_py, t_py_low = (min(runs[k]) for k in ("library", "slave", "low", "high",
                                                                                 "py_slave", "py_low"))
        first = fresh_process_first_step(fmu_path, f"{ref}.speed_in", speed, cache_dir=str(work / "cache"))
        us = 1e6 / n
        fig = {"system": info["system"], "communication_step_s": dt, "internal_step_s": args.internal_step,
               "speed_rpm": args.speed_rpm, "steps": n,
               "library_advance_us": t_lib * us, "fmu_slave_us": t_slave * us, "fmpy_low_level_us": t_low * us,
               "fmpy_simulate_fmu_us": t_high * us,
               "ratio_slave_over_library": t_slave / t_lib, "goal": GOAL,
               "binary_and_fmpy_floor_us": (t_low - t_slave) * us,
               "real_time_factor": {"library": t_end / t_lib, "fmu_slave": t_end / t_slave,
                                    "fmpy_low_level": t_end / t_low},
               "fresh_process_first_step_s": first,
               "pythonfmu": {"fmu_slave_us": t_py * us, "fmpy_low_level_us": t_py_low * us,
                             "ratio_slave_over_library": t_py / t_lib,
                             "binary_and_fmpy_floor_us": (t_py_low - t_py) * us,
                             "real_time_factor": {"fmu_slave": t_end / t_py, "fmpy_low_level": t_end / t_py_low}}}
        if args.json:
            print(json.dumps(fig, indent=1))
        else:
            print(f"bench_fmu: {info['system']}, {n} communication steps of {dt:g} s at {args.speed_rpm:g} rpm, "
                  f"internal step {args.internal_step:g} s (best of {args.repeat})")
            print(f"  library advance          {fig['library_advance_us']:7.2f} us/step   real-time factor "
                  f"{fig['real_time_factor']['library']:.1f}")
            print(f"  FMU slave (own cost)     {fig['fmu_slave_us']:7.2f} us/step   real-time factor "
                  f"{fig['real_time_factor']['fmu_slave']:.1f}")
            print(f"  fmpy low-level           {fig['fmpy_low_level_us']:7.2f} us/step   real-time factor "
                  f"{fig['real_time_factor']['fmpy_low_level']:.1f}")
            print(f"  fmpy simulate_fmu        {fig['fmpy_simulate_fmu_us']:7.2f} us/step")
            print(f"  binary + fmpy floor      {fig['binary_and_fmpy_floor_us']:7.2f} us/step (reported, not judged)")
            print(f"  fresh process, instantiate -> first doStep: cold {first[0][0]:.2f} s (CPU {first[0][1]:.2f} s, "
                  f"peak {first[0][2]:.0f} MB), then warm {first[1][0]:.2f} s (CPU {first[1][1]:.2f} s); goal <= 1 s "
                  "for the warm one")
            pf = fig["pythonfmu"]
            print(f"  pythonfmu backend: slave {pf['fmu_slave_us']:7.2f} us/step, fmpy low-level "
                  f"{pf['fmpy_low_level_us']:7.2f} us/step (real-time factor "
                  f"{pf['real_time_factor']['fmpy_low_level']:.1f}), wrapper + fmpy floor "
                  f"{pf['binary_and_fmpy_floor_us']:.2f} us/step")
            print(f"  reported: pythonfmu slave / library advance = {pf['ratio_slave_over_library']:.3f}")
            verdict = "met" if fig["ratio_slave_over_library"] <= GOAL else "MISSED"
            print(f"  judged: native FMU slave / library advance = {fig['ratio_slave_over_library']:.3f} "
                  f"(goal <= {GOAL}): {verdict}")
        shutil.rmtree(unz, ignore_errors=True)
        shutil.rmtree(py_unz, ignore_errors=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
