"""Fingerprints of every shipped system's assembled arrays (M, K, C, G, K_W, coupling vectors, phases, the kernel's
packed arrays and label): ``python tests/_fingerprints.py --write`` records them in
tests/data/assembly_fingerprints.json; tests/test_assembly.py asserts that the assembly reproduces them bit for
bit."""
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


def _digest(arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        if a is None:
            h.update(b"None")
            continue
        a = np.ascontiguousarray(a)
        if a.dtype.kind == "f":
            a = a + 0.0   # -0.0 -> 0.0: a table's vector copied entry by entry into the DOFs keeps its values
        h.update(repr((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:32]


def fingerprint(sy) -> dict[str, str]:
    """Hashes of one assembled system's arrays, by group."""
    a = sy.arrays
    return {
        "matrices": _digest([sy.M, sy.K, sy.C, sy.G, sy.K_W]),
        "couplings": _digest([sy.V, sy.W, sy.V_rot, sy.Vc, sy.T, sy.Tc, sy.phase, sy.backlash_m,
                              sy.nominal_forces_N(), sy.nominal_coast_forces_N(-sy.torque_Nm)]),
        "kernel": _digest([a.mats, a.kidx, a.kval, a.vecs, a.mmat, a.phase, a.u, a.scal, np.array([a.iref]), a.tab,
                           a.tint, a.tflt, a.lin, a.lint, a.nz]),
        "label": sy.kernel_label,
        "dofs": "|".join(sy.dof_names),
        "step": repr(sy.max_frequency_Hz),
    }


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
        bad = [k for k in ref if fp.get(k) != ref[k]]
        print(f"{len(ref) - len(bad)}/{len(ref)} identical; differ: {bad}")
