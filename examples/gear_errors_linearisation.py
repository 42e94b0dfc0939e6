"""The linearisation of hacgear's pitch-error profile, measured (docs/validation.md "Manufacturing errors").

spur_28t_asym with one pinion tooth displaced by d (single pitch deviations +d, -d): at mesh positions around the
tooth's pass the per-pair static solve sum_o P_o(tau, x - e_o) = F (each tooth pair at its own approach, the table's
tooth loads, scipy brentq) against the kernel's rule F(tau, x - e(c, x)) = F (the table's force at the lookup
deflection, the error profile over position and approach), both less the same without errors, at 0.5, 1 and 1.5 x
the nominal force.  Prints the pulse's peak-to-peak and the RMS and largest difference
as fractions of it.  About 30 s.

    python examples/gear_errors_linearisation.py [d_um ...]
"""
from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
from scipy.optimize import brentq

from hacgear_core.dynamics.gear_errors import cumulative_pitch_deviations_m
from hacgear_core.kinds import build_system, load_model
from hacgear_core.model import GearErrors, resolve_model_path
from hacgear_core.tables import load_system_tables


def main(ds_um) -> None:
    p = resolve_model_path("spur_28t_asym")
    model, tabs = load_model(p), load_system_tables(p)
    z = model.gears[0].teeth
    for d_um in ds_um:
        f = np.zeros(z)
        f[5], f[6] = d_um * 1e-6, -d_um * 1e-6
        g0 = replace(model.gears[0], errors=GearErrors(single_pitch_deviations_m=tuple(f)))
        sy = build_system(replace(model, gears=(g0,) + tuple(model.gears[1:])), tabs)
        c = sy.meshes[0]
        tab, fn, tp = c.table, c.nominal_force_N, c.tooth_passage[c.gear_a]
        # each pair's opening: a late driving tooth (positive cumulative deviation) meets later
        E = (c.base_radius_m[0] / (0.5 * model.gears[0].module_m * z)) * cumulative_pitch_deviations_m(f)
        offs = [int(o) for o in tab.tooth_offsets]
        cs = np.arange(5 * 64) / 64 + 2.0
        rows = []
        for fac in (0.5, 1.0, 1.5):
            pa, pb = [], []
            for cc in cs:
                n, tau = int(np.floor(cc)), cc - np.floor(cc)

                def g(x, ee):
                    return sum(float(tab.tooth_load(tau, x - e, o)) for o, e in zip(offs, ee)) - fn * fac

                eo = [E[(n - tp + o) % z] for o in offs]
                pb.append(brentq(g, -50e-6, 200e-6, xtol=1e-14, args=(eo,))
                          - brentq(g, -50e-6, 200e-6, xtol=1e-14, args=([0.0] * len(offs),)))
                # the kernel's rule: the table's force at x - e(c, x)
                def h(x):
                    return float(sy.mesh_force(0, tau, x - sy.mesh_errors_m(np.array([[cc]]), np.array([[x]]))[0, 0])) - fn * fac

                def h0(x):
                    return float(sy.mesh_force(0, tau, x)) - fn * fac

                pa.append(brentq(h, -50e-6, 200e-6, xtol=1e-14) - brentq(h0, -50e-6, 200e-6, xtol=1e-14))
            pa, pb = np.array(pa), np.array(pb)
            ptp = np.ptp(pb)
            rows.append(f"{fac:g} x F: pulse {ptp * 1e6:.3f} um, rms {np.sqrt(np.mean((pa - pb) ** 2)) / np.sqrt(np.mean((pb - pb.mean()) ** 2)) * 100:.1f} %, "
                        f"peak {np.max(np.abs(pa - pb)) / ptp * 100:.1f} %")
        print(f"d = {d_um:g} um: " + "; ".join(rows), flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("d_um", nargs="*", type=float, default=[5.0],
                    help="displacement of the one pinion tooth [um] (several: one line each; default 5)")
    main(ap.parse_args().d_um)
