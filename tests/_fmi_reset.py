"""Test helper: an FMU's Reset against a fresh instance (issue #50 item 1), through fmpy's low-level API, any
FMI version and backend."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave


def _instance(md, folder, name):
    kw = dict(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
              instanceName=name)
    if md.fmiVersion.startswith("3"):
        fmu = FMU3Slave(**kw)
        fmu.instantiate()
    else:
        fmu = FMU2Slave(**kw)
        fmu.instantiate()
    return fmu


def _run(fmu, v3, vrs, h, n, settings):
    """Initialize (``settings``: {value reference: value} of Reals set before initialization), take ``n`` steps of
    ``h`` [s]; the outputs ``vrs`` after each step (n, len(vrs))."""
    if v3:
        if settings:
            fmu.setFloat64(list(settings), list(settings.values()))
        fmu.enterInitializationMode(startTime=0.0)
    else:
        if settings:
            fmu.setReal(list(settings), list(settings.values()))
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    get = fmu.getFloat64 if v3 else fmu.getReal
    rows, t = [], 0.0
    for _ in range(n):
        fmu.doStep(t, h)
        t += h
        rows.append(list(get(vrs)))
    return np.array(rows)


def assert_reset_equals_fresh(path: str | Path, names=None, h: float = 5e-5, n: int = 60, settings=None) -> np.ndarray:
    """Run the FMU at ``path`` in a fresh instance and in a second instance twice, with ``reset`` between the two
    runs and the same parameters; the outputs ``names`` (default: every Real output) of every step must be equal bit for bit (one process, one
    machine).  ``settings``: {name: value} set before each initialization (Reals).  Returns the fresh run."""
    md = read_model_description(str(path))
    v3 = md.fmiVersion.startswith("3")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    if names is None:
        names = [v.name for v in md.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")]
    vrs = [vr[n_] for n_ in names]
    folder = extract(str(path))
    sets = {vr[k]: float(x) for k, x in (settings or {}).items()}
    fresh = _instance(md, folder, "fresh")
    ref = _run(fresh, v3, vrs, h, n, sets)
    fresh.terminate()
    fresh.freeInstance()
    inst = _instance(md, folder, "reused")
    first = _run(inst, v3, vrs, h, n, sets)
    inst.terminate()
    inst.reset()
    again = _run(inst, v3, vrs, h, n, sets)
    inst.terminate()
    inst.freeInstance()
    shutil.rmtree(folder, ignore_errors=True)
    assert np.array_equal(first, ref, equal_nan=True), f"{Path(path).name}: a second instance differs from the first"
    assert not np.array_equal(ref[0], ref[-1]), f"{Path(path).name}: the outputs do not move (a test that cannot fail)"
    bad = [names[j] for j in range(len(names)) if not np.array_equal(again[:, j], ref[:, j], equal_nan=True)]
    assert not bad, (f"{Path(path).name}: after reset the run differs from a fresh instance's in {bad[:5]} "
                     f"({len(bad)} outputs)")
    return ref
