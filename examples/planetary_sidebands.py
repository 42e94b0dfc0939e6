"""Sideband patterns of planetary_65_55_175 at a transducer fixed on the housing (docs/validation.md "Planetary
sideband patterns"; the checks are tests/test_planetary_errors.py).

The steady state at mesh frequency 1000 Hz (400 settling cycles, 64 samples per mesh cycle) over one carrier
revolution (175 mesh cycles; lcm(65, 175) for the sun runout), the three ring-planet mesh forces weighted by a Hann
window of each planet's angular distance to the transducer (half width one planet spacing,
:func:`hacgear_core.spectra.transducer.fixed_transducer_signal`), for identical planets, a 20 um tangential pin
error on planet 1, a 20 um ring runout and a 20 um sun runout.  Prints the amplitudes at m f_m + k f_c (m = 1, 2;
k = -4..4) with the planet-sum factor |P(m, k)| of identical planets, and writes the figure.  About 10 s (plus the
kernels' first compilation).

    python examples/planetary_sidebands.py [--figure docs/figures/planetary_sidebands.png]
"""
from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from hacgear_core.geometry.planetary import planetary_geometry
from hacgear_core.kinds import build_system, load_model
from hacgear_core.model import GearErrors, resolve_model_path
from hacgear_core.spectra.records import steady_record
from hacgear_core.spectra.transducer import fixed_transducer_signal, planet_sum_factor
from hacgear_core.tables import load_system_tables

CASES = {"identical planets": ({}, None), "pin error 20 um (planet 1, tangential)": ({}, {1: (0.0, 20e-6)}),
         "ring runout 20 um": ({"ring": GearErrors(runout_m=20e-6)}, None),
         "sun runout 20 um": ({"sun": GearErrors(runout_m=20e-6)}, None)}


def transducer_spectrum(model, tabs, errors, pins, spc: int = 64, fm: float = 1000.0):
    """(amplitudes [N] of the transducer signal's FFT, mesh cycles of the record) for one case."""
    geo = planetary_geometry(model)
    gears = tuple(replace(g, errors=errors.get(g.name)) for g in model.gears)
    sy = build_system(replace(model, gears=gears), tabs, **({"pin_errors_m": pins} if pins else {}))
    r = sy.carrier_ratio / (2 * math.pi * sy.mesh_cycles_per_rad)       # carrier revolutions per mesh cycle
    zr = round(1 / r)
    cyc = math.lcm(zr, sy.period_cycles)
    rec = steady_record(sy, fm, "force", cyc, samples_per_cycle=spc, settle_cycles=400)
    f = np.column_stack([rec.channels[f"ring_planet_{i}"] for i in range(1, geo.planet_count + 1)])
    c = 400 + np.arange(1, f.shape[0] + 1) / spc
    s = fixed_transducer_signal(f, 2 * math.pi * r * c, np.array(geo.positions_rad))
    return np.abs(np.fft.rfft(s)) * 2 / s.size, cyc, zr


def main(figure: str | None) -> None:
    p = resolve_model_path("planetary_65_55_175")
    model, tabs = load_model(p), load_system_tables(p)
    geo = planetary_geometry(model)
    psi = np.array(geo.positions_rad)
    ph = np.array([geo.meshes[f"ring_planet_{i}"].phase for i in range(1, geo.planet_count + 1)])
    ks = np.arange(-4, 5)
    out = {}
    print("m  k   |P|  " + "  ".join(f"{n[:22]:>22s}" for n in CASES))
    for name, (errors, pins) in CASES.items():
        out[name] = transducer_spectrum(model, tabs, errors, pins)
    for m in (1, 2):
        for k in ks:
            row = []
            for name in CASES:
                a, cyc, zr = out[name]
                row.append(f"{a[int(round(cyc * (m + k / zr)))]:22.4g}")
            print(f"{m}  {k:+d}  {abs(planet_sum_factor(ph, psi, m, int(k))):4.2f}  " + "  ".join(row))
    if not figure:
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(len(CASES), 2, figsize=(10, 2.0 * len(CASES)), sharey="row")
    for row, name in zip(axes, CASES):
        a, cyc, zr = out[name]
        orders = np.arange(a.size) * zr / cyc                        # carrier orders
        for ax, m in zip(row, (1, 2)):
            sel = (orders > m * zr - 6.5) & (orders < m * zr + 6.5)
            ax.vlines(orders[sel] - m * zr, 0, a[sel], color="tab:blue", lw=1.5)
            on = [k for k in range(-6, 7) if abs(planet_sum_factor(ph, psi, m, k)) > 0.5]
            ax.plot(on, [0.0] * len(on), "^", color="tab:green", ms=6, clip_on=False)
            ax.set_yscale("symlog", linthresh=0.05)
            ax.set_xlim(-6.5, 6.5)
            ax.set_title(f"{name}: around {m} x f_m", fontsize=9, loc="left")
        row[0].set_ylabel("N")
    for ax in axes[-1]:
        ax.set_xlabel("k: carrier orders from m f_m (sun runout: also +-f_m/65 lines)", fontsize=8)
    fig.suptitle("planetary_65_55_175, transducer fixed on the ring (3 sequentially phased planets); "
                 "green: |P(m, k)| = 1", fontsize=10)
    fig.tight_layout()
    fig.savefig(figure, dpi=110)
    print(f"wrote {figure}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--figure", default=None, help="write the figure to this path (PNG) (default: none, the table only)")
    main(ap.parse_args().figure)
