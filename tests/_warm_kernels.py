"""Background compilation of integration-kernel specialisations for the test session (tests/conftest.py).

Run as ``python _warm_kernels.py MARKER_DIR SPEC...``, each SPEC ``lib:<kernel>`` (hacgear_core's kernels) or
``fmu:<kernel>`` (the kernels of the code bundled into every FMU, hacgear_core under its content-unique package
name, copied to the FMUs' per-user cache exactly as an FMU instantiation copies it).  For each SPEC in order it
claims ``MARKER_DIR/claim-<SPEC>`` (atomic create: the test process claims a kernel the same way when a test
needs one nobody has started) and, if it got the claim, compiles that specialisation into numba's on-disk cache,
then writes ``done-<SPEC>``.  The tests then load the compiled code from the cache instead of compiling it
themselves: the work runs on the second core while the test process runs other tests.  Nothing numeric depends on
this: the argument types are those of a real ``LumpedSystem.integrate`` call (one signature serves every kernel),
so the cache entries are the ones the tests would have written; if this process fails or is slow the tests compile
what they need as before.
"""
from __future__ import annotations

import importlib
import os
import sys
import tempfile
import time
from pathlib import Path


def claim(marker_dir: Path, spec: str) -> bool:
    try:
        os.close(os.open(marker_dir / f"claim-{spec}", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        return True
    except FileExistsError:
        return False


def _signature(pkg: str):
    """numba types of the arguments ``LumpedSystem.integrate`` passes to its kernel (a 2-DOF spur pair)."""
    import numba
    import numpy as np

    synthetic = importlib.import_module(f"{pkg}.dynamics.synthetic")
    build = importlib.import_module(f"{pkg}.kinds")
    tab = synthetic.spur_fdf_table()
    sy = build.spur_pair_system(synthetic.synthetic_28t_parameters(tab), tab)
    got = []
    sy.kernel = lambda *args: got.append(args) or 0
    sy._kernel_ready = sy.kernel  # integrate calls the spy without preparing it
    sy.integrate(np.zeros(2 * sy.n), np.array([0.0, 0.0, 100.0]), 1, 1e-6, np.zeros(sy.n))
    return tuple(numba.typeof(a) for a in got[0])


def _bundle_package() -> str:
    """Copy the FMU bundle of this hacgear_core to the FMUs' cache (as an FMU instantiation does) and put it on
    sys.path; returns its package name."""
    from hacgear_core.fmu import bootstrap
    from hacgear_core.fmu.build import bundle_package

    with tempfile.TemporaryDirectory(prefix="hacgear_warm_") as td:
        package, digest = bundle_package(td)
        root, notes = bootstrap.stable_copy(Path(td) / package, package, digest)
        if notes:
            raise OSError("; ".join(notes))
    if str(root) not in sys.path:
        sys.path.append(str(root))
    return package


def main(argv: list[str]) -> int:
    marker_dir = Path(argv[0])
    sigs: dict[str, tuple] = {}
    mods: dict[str, object] = {}
    for spec in argv[1:]:
        where, name = spec.split(":", 1)
        if not claim(marker_dir, spec):
            continue
        t0 = time.perf_counter()
        try:
            if where not in mods:
                pkg = "hacgear_core" if where == "lib" else _bundle_package()
                mods[where] = importlib.import_module(f"{pkg}.dynamics.kernels")
                sigs[where] = _signature(pkg)
            getattr(mods[where], name).compile(sigs[where])
            print(f"{spec}: {time.perf_counter() - t0:.1f} s", flush=True)
        except Exception as exc:  # the tests compile it themselves
            print(f"{spec}: failed ({type(exc).__name__}: {exc})", flush=True)
        finally:
            (marker_dir / f"done-{spec}").touch()
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
