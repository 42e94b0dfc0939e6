"""Run pytest as on another CPU: numba compiles for a generic x86-64 target (no AVX, no FMA) and NumPy's
run-time dispatch is limited to its baseline, so every float that depends on the CPU's vector units changes in its
last bits.  A test that compares such floats bit for bit against a record made on another machine fails here.

``python tests/foreign_cpu.py [pytest arguments]`` (``.ci/run`` runs it after the default suite).  OpenBLAS's core
type is left as the machine sets it (some machines need it set to compute correctly at all)."""
from __future__ import annotations

import os
import subprocess
import sys


def foreign_environment(base: dict[str, str] | None = None) -> dict[str, str]:
    """``base`` (default: this process's environment) with numba's target CPU generic and every NumPy
    dispatch target above the baseline disabled (asked of NumPy itself, so the names fit its version)."""
    env = dict(os.environ if base is None else base)
    probe = ("import numpy._core._multiarray_umath as m; "
             "print(' '.join(k for k in m.__cpu_dispatch__ if m.__cpu_features__.get(k)))")
    try:
        dispatched = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                                    check=True, env={k: v for k, v in env.items()
                                                     if k != "NPY_DISABLE_CPU_FEATURES"}).stdout.split()
    except subprocess.CalledProcessError:   # NumPy < 2 keeps the module at numpy.core
        dispatched = subprocess.run([sys.executable, "-c", probe.replace("numpy._core", "numpy.core")],
                                    capture_output=True, text=True, check=True).stdout.split()
    env["NUMBA_CPU_NAME"] = "generic"
    if dispatched:
        env["NPY_DISABLE_CPU_FEATURES"] = " ".join(dispatched)
    return env


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    env = foreign_environment()
    print(f"foreign_cpu: NUMBA_CPU_NAME=generic NPY_DISABLE_CPU_FEATURES="
          f"{env.get('NPY_DISABLE_CPU_FEATURES', '')!r}", flush=True)
    return subprocess.call([sys.executable, "-m", "pytest", *args], env=env)


if __name__ == "__main__":
    raise SystemExit(main())
