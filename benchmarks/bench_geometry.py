"""Speed of hacgear_core.geometry: building gears, profiles and point queries.

Target: building one gear geometry (profiles, mass properties) in <= 5 ms; ``flank(side, 800)`` in
<= 2 ms; vectorised ``involute_point``/``relief_m`` at >= 1e6 points/s.  Prints each figure and its
ratio to the target (< 1 is better than the target).
"""
from __future__ import annotations

import time

import numpy as np

from hacgear_core.geometry import gear_geometry, mesh_geometry
from hacgear_core.kinds import load_model

SYSTEMS = ("spur_28t_asym", "spur_50t_icr137", "spur_50t_icr18", "idler_28_33_39", "planetary_65_55_175",
           "helical_28_33")


def best(fn, repeat=5):
    t = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        t.append(time.perf_counter() - t0)
    return min(t)


def main() -> None:
    gears = [(s, g) for s in SYSTEMS for g in load_model(s).gears]
    worst = 0.0
    for s, g in gears:
        dt = best(lambda: gear_geometry(g))
        worst = max(worst, dt)
        print(f"gear_geometry {s}:{g.name:<8} {dt * 1e3:7.2f} ms")
    print(f"worst gear build {worst * 1e3:.2f} ms, target 5 ms, ratio {worst / 5e-3:.2f}")
    gg = gear_geometry(load_model("spur_28t_asym").gear("pinion"))

    def fresh_flank():
        gg._cache.clear()
        gg.flank("drive", 800)

    dt = best(fresh_flank)
    print(f"flank(drive, 800) uncached {dt * 1e3:.3f} ms, target 2 ms, ratio {dt / 2e-3:.2f}")
    u = np.linspace(0.3, 0.6, 100_000)
    dt = best(lambda: (gg.involute_point("drive", u), gg.relief_m("drive", u)))
    rate = u.size / dt
    print(f"involute_point + relief_m: {rate:.3g} points/s, target 1e6, ratio {1e6 / rate:.2f}")
    m = load_model("planetary_65_55_175")
    dt = best(lambda: mesh_geometry(m, "ring_planet"))
    print(f"mesh_geometry planetary ring_planet (builds 2 gears) {dt * 1e3:.2f} ms")


if __name__ == "__main__":
    main()
