#!/usr/bin/env python
"""Cold compile of integration-kernel specialisations: time, memory and where numba spends it.

For each named specialisation of :mod:`hacgear_core.dynamics.kernels` (default: ``_table_2_1_s2``, the spur pairs'
loop), a fresh process with an empty numba cache (a new ``NUMBA_CACHE_DIR``) compiles it for the argument types
of a real ``LumpedSystem.integrate`` call and prints the wall and CPU time of the compile, the process's peak
resident memory, the time numba held its LLVM lock (LLVM optimisation and code generation) and the slowest
passes of numba's pipeline (its own front end: inlining, typing, lowering).  CPU time is the figure to compare on
a shared machine; wall time grows with other load.

    python benchmarks/bench_compile.py [_table_2_1_s2 _twist_12_1 ...]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from hacgear_core.cpu import vector_units

ROOT = Path(__file__).resolve().parent.parent

_CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, {tests!r})
from _warm_kernels import _signature
from hacgear_core.dynamics import kernels
sig = _signature("hacgear_core")
disp = getattr(kernels, {name!r})
t0, c0 = time.perf_counter(), time.process_time()
disp.compile(sig)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
md = disp.get_metadata(disp.signatures[-1])
passes = {{}}
for pipe, times in md.get("pipeline_times", {{}}).items():
    for k, v in times.items():
        passes[k.split("_", 1)[-1]] = passes.get(k.split("_", 1)[-1], 0.0) + v.init + v.run + v.finalize
print(json.dumps({{"wall_s": wall, "cpu_s": cpu, "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "llvm_lock_s": md.get("timers", {{}}).get("llvm_lock", float("nan")),
                  "passes": sorted(passes.items(), key=lambda kv: -kv[1])[:6]}}))
"""


def cold_compile(name: str) -> dict:
    """Figures of one cold compile of specialisation ``name`` in a fresh process."""
    with tempfile.TemporaryDirectory(prefix="hacgear_numba_") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
        p = subprocess.run([sys.executable, "-c", _CHILD.format(tests=str(ROOT / "tests"), name=name)], env=env,
                           capture_output=True, text=True, timeout=3600)
    if p.returncode != 0:
        raise SystemExit(f"{name}: the compile failed ({p.returncode}): {p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", default=["_table_2_1_s2"], help="specialisations (kernels module names)")
    args = ap.parse_args(argv)
    print(f"CPU the kernels are compiled for: {vector_units().describe()}", flush=True)
    for name in args.names:
        f = cold_compile(name)
        print(f"{name}: cold compile {f['wall_s']:.1f} s wall, {f['cpu_s']:.1f} s CPU, peak RSS "
              f"{f['peak_rss_MB']:.0f} MB; LLVM lock held {f['llvm_lock_s']:.1f} s; slowest numba passes: "
              + ", ".join(f"{k} {v:.1f} s" for k, v in f["passes"]), flush=True)
    print(f"load average at the end: {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
