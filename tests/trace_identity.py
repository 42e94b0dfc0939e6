"""Bit-identity of the dynamics across two checkouts: steady-state traces of shipped systems, saved by one checkout
and compared with another's on the same machine (a kernel change that must leave today's results unchanged).

    PYTHONPATH=<old checkout> python tests/trace_identity.py save /tmp/old.npz
    PYTHONPATH=<new checkout> python tests/trace_identity.py save /tmp/new.npz
    python tests/trace_identity.py compare /tmp/old.npz /tmp/new.npz      # exit 0: every array identical

Same machine only: floats are compared bit for bit.
"""
from __future__ import annotations

import sys

import numpy as np

CASES = (("spur_28t_asym", 1500.0), ("planetary_65_55_175", 900.0), ("helical_28_33", 2000.0),
         ("idler_28_33_39", 1200.0), ("gear_train_2stage", 1400.0), ("reducer_19_71_23_83", 1500.0))


def save(path: str) -> None:
    from hacgear_core.dynamics.steady import steady_state
    from hacgear_core.kinds import build_system, load_model
    from hacgear_core.model import resolve_model_path
    from hacgear_core.tables import load_system_tables

    out = {}
    for name, fm in CASES:
        p = resolve_model_path(name)
        sy = build_system(load_model(p), load_system_tables(p))
        r = steady_state(sy, fm, keep_trace=True)
        out.update({f"{name}/{k}": np.asarray(v) for k, v in r.trace.items()})
        out[f"{name}/state"] = r.state
        print(f"{name}: {r.status}, {r.cycles_run} cycles at {fm:g} Hz", flush=True)
    np.savez(path, **out)


def compare(a_path: str, b_path: str) -> int:
    a, b = np.load(a_path), np.load(b_path)
    if set(a.files) != set(b.files):
        print("different arrays:", sorted(set(a.files) ^ set(b.files)))
        return 1
    bad = [k for k in a.files if not np.array_equal(a[k], b[k], equal_nan=True)]
    print(f"{len(a.files)} arrays, {len(bad)} differ{': ' + ', '.join(bad) if bad else ''}")
    return 1 if bad else 0


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "save":
        save(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    else:
        sys.exit(__doc__)
