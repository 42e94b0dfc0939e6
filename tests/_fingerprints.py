"""Fingerprints of every shipped system's assembled arrays (M, K, C, G, K_W, coupling vectors, phases, the kernel's
packed arrays and label): ``python tests/_fingerprints.py --write`` records them in
tests/data/assembly_fingerprints.json; tests/test_assembly.py asserts that the assembly reproduces them: floats
within RTOL of their size (or of 1e-12 of their array's largest entry, for entries that cancel to nearly zero),
since machines differ in the last bits; what is exact by construction (shapes, integers, labels, which entries are
not finite) exactly."""
from __future__ import annotations

import hashlib
import json
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from hacgear_core.dynamics.synthetic import linear_fdf_table
from hacgear_core.tables import load_system_tables

from hacgear_core.kinds import SpurPairParameters, build_system, load_model, spur_pair_system

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "assembly_fingerprints.json"
FORCE_LAWS = ("hac", "ste", "average_slope", "local_slope")
FIXED_AXIS = ("spur_50t_icr18", "spur_50t_icr137", "spur_28t_asym", "idler_28_33_39")
PLANETARY = ("planetary_65_55_175", "planetary_65_55_175_unmodified")


#: tolerance of an entry relative to its own size: the assembly's eigen-solutions, BLAS products and compiled
#: reductions differ in their last bits between CPUs (and BLAS builds), so floats are never compared bit for bit
RTOL = 1e-8
#: entries smaller than this fraction of their array's largest magnitude are compared absolutely, at RTOL x FLOOR
#: x that magnitude (1e-12 of it): such entries are sums that cancel (a damping matrix's coupling terms), whose
#: last-bit noise is a fraction of the array's scale, not of their own size
FLOOR = 1e-4
#: tolerance of the array's largest magnitude itself
SCALE_RTOL = 1e-10
#: weights of the random projections, drawn once with a fixed seed (a change of any entry moves them)
_N_PROJ = 3


def _weights(n: int) -> np.ndarray:
    return np.random.default_rng(20261207).uniform(-1.0, 1.0, size=(_N_PROJ, n))


def _exact(parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(repr((p.dtype.str, p.shape)).encode() if isinstance(p, np.ndarray) else repr(p).encode())
        if isinstance(p, np.ndarray):
            h.update(np.ascontiguousarray(p).tobytes())
    return h.hexdigest()[:24]


def _summary(arrays) -> list:
    """A record of each array: exact where the data are exact by construction (shapes, integers, which entries
    are not finite), and for the float values their largest magnitude ``s`` and random projections of
    ``asinh(a / (FLOOR s))``, which is log|a| for entries above FLOOR s (a relative change moves it by its size) and
    a / (FLOOR s) below (an absolute change relative to ``s``)."""
    out = []
    for a in arrays:
        if a is None:
            out.append(None)
            continue
        a = np.asarray(a)
        if a.dtype.kind != "f":
            out.append({"exact": _exact([a])})
            continue
        flat = a.ravel().astype(float)
        fin = np.isfinite(flat)
        pattern = np.where(fin, 0, np.where(np.isnan(flat), 3, np.sign(flat))).astype(np.int8)
        scale = float(np.max(np.abs(flat[fin]))) if fin.any() else 0.0
        f = np.arcsinh(np.where(fin, flat, 0.0) / (FLOOR * scale if scale > 0 else 1.0))
        w = _weights(flat.size)
        out.append({"exact": _exact([a.shape, pattern]), "scale": scale, "n": int(fin.sum()),
                    "proj": [math.fsum(w[j] * f) for j in range(_N_PROJ)]})
    return out


def _close(x, y) -> bool:
    """Two summaries of one array agree: exact parts equal, the scale within SCALE_RTOL and each projection within
    RTOL sqrt(n) (n entries, weights uniform in [-1, 1]: last-bit differences add up like sqrt(n); a change of
    RTOL sqrt(n) in one entry, relative or below the floor absolute, is caught)."""
    if x is None or y is None or set(x) != set(y):
        return x == y
    if x["exact"] != y["exact"] or x.get("n") != y.get("n"):
        return False
    if "scale" not in x:
        return True
    return (math.isclose(x["scale"], y["scale"], rel_tol=SCALE_RTOL, abs_tol=0.0)
            and all(abs(p - q) <= RTOL * math.sqrt(max(x["n"], 1)) for p, q in zip(x["proj"], y["proj"])))


def fingerprint(sy) -> dict:
    """Summaries of one assembled system's arrays, by group (floats within :data:`RTOL`: :func:`differences`)."""
    a = sy.arrays
    # the kernel's phase array carries each mesh's rate p/q in rows 1-2: recorded systems are all at rate 1 (their
    # phases alone, as recorded); any other rate changes the shape and so shows as a difference
    phase = a.phase[0] if sy.unit_rates else a.phase
    return {
        "matrices": _summary([sy.M, sy.K, sy.C, sy.G, sy.K_W]),
        "couplings": _summary([sy.V, sy.W, sy.V_rot, sy.Vc, sy.T, sy.Tc, sy.phase, sy.backlash_m,
                               sy.nominal_forces_N(), sy.nominal_coast_forces_N(-sy.torque_Nm)]),
        "kernel": _summary([a.mats, a.kidx, a.kval, a.vecs, a.mmat, phase, a.u, a.scal, np.array([a.iref]), a.tab,
                            a.tint, a.tflt, a.lin, a.lint, a.nz]),
        "label": sy.kernel_label,
        "dofs": "|".join(sy.dof_names),
        "step": sy.max_frequency_Hz,
    }


def differences(got: dict, ref: dict) -> list[str]:
    """What of ``got`` differs from the recorded ``ref``: group names (with the array's index) beyond tolerance."""
    bad = [k for k in ("label", "dofs") if got[k] != ref[k]]
    if not math.isclose(got["step"], ref["step"], rel_tol=RTOL, abs_tol=0.0):
        bad.append(f"step {got['step']!r} vs {ref['step']!r}")
    for group in ("matrices", "couplings", "kernel"):
        if len(got[group]) != len(ref[group]):
            bad.append(group)
            continue
        bad += [f"{group}[{i}]" for i, (x, y) in enumerate(zip(got[group], ref[group])) if not _close(x, y)]
    return bad


def cases():
    """(case name, builder of its system) for every shipped system and its variants."""
    out = []
    for name in FIXED_AXIS:
        mp = ROOT / "models" / name
        for law in FORCE_LAWS:
            for kt in (None, 2e8):
                out.append((f"{name}/{law}/k={kt}", lambda mp=mp, law=law, kt=kt: build_system(
                    load_model(mp), load_system_tables(mp), force_law=law, bearing_stiffness_N_per_m=kt)))
        out.append((f"{name}/free", lambda mp=mp: build_system(load_model(mp), load_system_tables(mp), shafts=False)))
    mp = ROOT / "models" / "spur_28t_asym"
    out.append(("spur_28t_asym/coast", lambda mp=mp: build_system(load_model(mp), load_system_tables(mp),
                                                                  torque_Nm=-100.0)))
    for name in PLANETARY:
        mp = ROOT / "models" / name
        for law in FORCE_LAWS:
            for n in (3, 4, 5):
                out.append((f"{name}/{law}/N={n}", lambda mp=mp, law=law, n=n: build_system(
                    load_model(mp), load_system_tables(mp), force_law=law, planet_count=n)))
        out.append((f"{name}/k=1e8", lambda mp=mp: build_system(load_model(mp), load_system_tables(mp),
                                                                bearing_stiffness_N_per_m=1e8)))
        out.append((f"{name}/free", lambda mp=mp: build_system(load_model(mp), load_system_tables(mp), shafts=False)))
        out.append((f"{name}/pins", lambda mp=mp: build_system(load_model(mp), load_system_tables(mp),
                                                               pin_errors_m={1: (1e-5, -2e-5)})))
    ex = ROOT / "examples" / "planetary_lumped.toml"
    for n in (3, 4, 5):
        out.append((f"planetary_lumped/N={n}", lambda n=n: build_system(load_model(ex), None, planet_count=n)))
    mp = ROOT / "models" / "helical_28_33"
    for kt in (None, math.inf):
        out.append((f"helical_28_33/k={kt}", lambda kt=kt, mp=mp: build_system(
            load_model(mp), load_system_tables(mp), bearing_stiffness_N_per_m=kt)))
    out.append(("helical_28_33/free", lambda mp=mp: build_system(load_model(mp), load_system_tables(mp), shafts=False)))
    out.append(("helical_28_33/coast", lambda mp=mp: build_system(load_model(mp), load_system_tables(mp),
                                                                  torque_Nm=-200.0)))

    def drive_only(mp=mp):
        tabs = load_system_tables(mp)
        return build_system(load_model(mp), {k: replace(t, coast=None) for k, t in tabs.meshes.items()})
    out.append(("helical_28_33/drive_only", drive_only))

    def spur_params(law, kt):
        k, rb = 150e6, 0.0634
        xs = 100.0 / rb / k
        tab = linear_fdf_table(k, offset_amplitude_m=0.2 * xs, x_max_m=6 * xs)
        p = SpurPairParameters(mass_kg=(1.6, 2.1), inertia_kg_m2=(0.0044, 0.0061), base_radius_m=(rb, rb),
                               teeth=(28, 28), bearing_stiffness_N_per_m=(kt, kt), modal_damping_ratio=0.03,
                               torque_Nm=100.0)
        return spur_pair_system(p, tab, law)
    for law in FORCE_LAWS:
        for kt in (math.inf, 3e8):
            out.append((f"spur_pair_parameters/{law}/k={kt}", lambda law=law, kt=kt: spur_params(law, kt)))
    return out


def compute() -> dict[str, dict[str, str]]:
    return {name: fingerprint(build()) for name, build in cases()}


if __name__ == "__main__":
    fp = compute()
    if "--write" in sys.argv:
        DATA.write_text(json.dumps(fp, indent=1, sort_keys=True) + "\n")
        print(f"wrote {len(fp)} fingerprints to {DATA}")
    else:
        ref = json.loads(DATA.read_text())
        bad = {k: differences(fp[k], ref[k]) for k in ref if k not in fp or differences(fp[k], ref[k])}
        print(f"{len(ref) - len(bad)}/{len(ref)} within tolerance; differ: {bad}")
