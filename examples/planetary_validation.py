#!/usr/bin/env python
"""Planetary set 65/55/175 at 200 N*m on the sun (dissertation Section 4.5.2, Figs. 4.9-4.15): every number of
docs/validation.md "Planetary set" from one run.

Writes ``docs/validation_planetary.json`` and ``docs/figures/validation_planetary_sweeps.png`` (sun-mesh RMS over
mesh frequency, up and down sweeps, 3 and 5 planets, with and without tip relief) and prints a summary:

* up/down sweeps 400-4400 Hz (25 Hz steps, every orbit Floquet-checked: each speed ends on an attractor) of
  planetary_65_55_175 (15 um tip relief) and planetary_65_55_175_unmodified, 3 and 5 planets: largest up/down
  difference, width of the double-valued regions, contact loss, speeds where the planets respond differently;
* 3 planets in 5 Hz steps over the whole range (narrow double-valued bands a 25 Hz grid would step over;
  quasi-periodic speeds measured over 1000 cycles, speeds where the branches differ integrated on for 30000 cycles;
  ``--fine-only`` recomputes just these);
* 5 planets: the in-phase (identical-planet) periodic solution continued over the range and its Floquet
  multipliers: where it is stable, where a planet mode makes it unstable;
* the support-stiffness and damping sensitivity of the sweeps (``--sensitivity``: Table 4.2 gives neither);
* steady state at 1600 Hz for 3, 4, 5 planets: central members' translational vs rotational motion, the planets'
  sun-mesh deflections against planet 1's shifted by the mesh delays, the sun mid-space root strain;
* static load sharing and a 20 um tangential pin error;
* modes at zero carrier speed and at the carrier speed of 1600 Hz;
* the one-planet chain solve against the per-mesh solves (what the per-mesh tables leave out).

Run: ``python examples/planetary_validation.py [--quick] [--sensitivity]`` (``--sensitivity`` adds about 18 minutes on
2 cores, the 5 Hz sweeps alone take 13 (``--fine-only``); ``--quick``: 50 Hz steps).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from hacgear_core.cli._help import plain_text
from hacgear_core.kinds import build_system
from hacgear_core.dynamics.equilibrium import load_sharing
from hacgear_core.dynamics.floquet import floquet
from hacgear_core.dynamics.modes import gyroscopic_modes
from hacgear_core.dynamics.simulator import strain_of_tooth
from hacgear_core.dynamics.steady import SteadyStateOptions, steady_state
from hacgear_core.dynamics.sweep import SweepSpec, run_sweep
from hacgear_core.kinds import load_model
from hacgear_core.statics.chain import PlanetChain
from hacgear_core.tables import load_system_tables

ROOT = Path(__file__).resolve().parent.parent
MODELS = ("planetary_65_55_175", "planetary_65_55_175_unmodified")
# every detected orbit Floquet-checked (unstable ones are left); a speed without a periodic attractor (quasi-periodic)
# is measured over 200 cycles, not a 4-cycle snapshot
STABLE = SteadyStateOptions(stability=True, cap_record_cycles=200)


def _regions(fm, up, dn, rel=0.02):
    """Frequency intervals [Hz] where the up and down sweeps differ by more than ``rel``."""
    bad = np.abs(up - dn) > rel * np.maximum(np.maximum(up, dn), 1e-15)
    out, start = [], None
    for f, b in zip(fm, bad):
        if b and start is None:
            start = f
        if not b and start is not None:
            out.append((start, prev))
            start = None
        prev = f
    if start is not None:
        out.append((start, prev))
    return out


def sweeps(step_hz: float) -> dict:
    fms = np.arange(400.0, 4400.0 + 1e-9, step_hz)
    res = {}
    for name in MODELS:
        m = load_model(name)
        t = load_system_tables(name)
        for n in (3, 5):
            sy = build_system(m, t, planet_count=n)
            t0 = time.perf_counter()
            r = run_sweep(SweepSpec(sy, tuple(fms), "both", options=STABLE), progress=False)
            up, dn = r.branches["up"].metrics, r.branches["down"].metrics
            mu = np.concatenate([r.branches["up"].max_multiplier, r.branches["down"].max_multiplier])
            caps = int(np.sum(~r.branches["up"].converged) + np.sum(~r.branches["down"].converged))
            sun = [k for k, c in enumerate(sy.meshes) if c.group == "sun_planet"]
            rms_up = up["rms_deflection_m"][:, sun]
            rms_dn = dn["rms_deflection_m"][::-1][:, sun]
            u, d = rms_up[:, 0], rms_dn[:, 0]
            rel = np.abs(u - d) / np.maximum(np.maximum(u, d), 1e-15)
            regions = _regions(fms, u, d)
            both = np.concatenate([rms_up, rms_dn])
            spread_f = np.ptp(both, axis=1) / np.max(both, axis=1)
            spread = float(np.max(spread_f))
            differ = np.unique(np.concatenate([fms, fms])[spread_f > 0.01])
            res[f"{name}/{n}"] = {
                "mesh_frequency_Hz": fms.tolist(), "rms_up_m": u.tolist(), "rms_down_m": d.tolist(),
                "max_up_down_rel": float(rel.max()), "at_Hz": float(fms[np.argmax(rel)]),
                "speeds_within_2pct": int(np.sum(rel <= 0.02)), "speeds": int(fms.size),
                "double_valued_Hz": [list(map(float, x)) for x in regions],
                "double_valued_width_Hz": float(sum(b - a + step_hz for a, b in regions)),
                "contact_loss_max": float(max(np.max(up["contact_loss_fraction"]), np.max(dn["contact_loss_fraction"]))),
                "peak_rms_m": float(max(u.max(), d.max())), "peak_at_Hz": float(fms[np.argmax(np.maximum(u, d))]),
                "planet_spread_rel": spread, "planets_differ_Hz": differ.tolist(),
                "max_multiplier": float(np.nanmax(mu)), "cycle_caps": caps,
                "wall_s": time.perf_counter() - t0}
            print(f"sweep {name} {n} planets: max up/down {rel.max():.3f} at {fms[np.argmax(rel)]:.0f} Hz, "
                  f"double-valued {regions}, contact loss {res[f'{name}/{n}']['contact_loss_max']:.2f}, "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)
    return res


# the 5 Hz sweeps resolve the quasi-periodic windows next to a mode: there the RMS is measured over 1000 cycles
# (a 200-cycle window of a slowly modulated response moves its RMS by a few per cent from window to window)
FINE = dataclasses.replace(STABLE, cap_record_cycles=1000)
LONG_RUN_CYCLES = 30000


def fine_3_planets(step_hz: float = 5.0) -> dict:
    """3 planets, up/down sweeps in ``step_hz`` steps over 400-4400 Hz, both models (narrow double-valued bands that
    a 25 Hz grid steps over).  At each speed where the branches differ by more than 2 %, the up branch's motion is
    integrated on for ``LONG_RUN_CYCLES`` cycles from where the up sweep entered that speed: still no periodic orbit
    there means two attractors coexist (not a transient the cycle cap cut short)."""
    fms = np.arange(400.0, 4400.0 + 1e-9, step_hz)
    out = {}
    for name in MODELS:
        sy = build_system(load_model(name), load_system_tables(name), planet_count=3)
        r = run_sweep(SweepSpec(sy, tuple(fms), "both", options=FINE), progress=False)
        up, dn = r.branches["up"], r.branches["down"]
        u = up.metrics["rms_deflection_m"][:, 0]
        d = dn.metrics["rms_deflection_m"][::-1, 0]
        rel = np.abs(u - d) / np.maximum(u, d)
        apart = []
        for i in np.flatnonzero(rel > 0.02):
            start = up.state[i - 1] if i > 0 else None
            lr = steady_state(sy, float(fms[i]), start, dataclasses.replace(FINE, max_cycles=LONG_RUN_CYCLES))
            apart.append({"Hz": float(fms[i]), "rel": float(rel[i]), "up_rms_m": float(u[i]), "down_rms_m": float(d[i]),
                          "up_periodic": bool(up.converged[i]), "down_periodic": bool(dn.converged[::-1][i]),
                          "down_multiplier": float(dn.max_multiplier[::-1][i]),
                          "up_long_run_periodic": bool(lr.converged), "up_long_run_cycles": int(lr.cycles_run),
                          "up_long_run_rms_m": float(lr.metrics["rms_deflection_m"][0])})
        capped = (~up.converged) | (~dn.converged[::-1])
        out[name] = {"step_Hz": step_hz, "speeds": int(fms.size), "speeds_within_2pct": int(np.sum(rel <= 0.02)),
                     "max_up_down_rel": float(rel.max()), "at_Hz": float(fms[np.argmax(rel)]),
                     "double_valued_Hz": [list(map(float, x)) for x in _regions(fms, u, d)],
                     "quasi_periodic_Hz": [float(f) for f in fms[capped]],
                     "apart": apart,
                     "peak_rms_m": float(max(u.max(), d.max())), "peak_at_Hz": float(fms[np.argmax(np.maximum(u, d))]),
                     "contact_loss_max": float(max(np.max(up.metrics["contact_loss_fraction"]),
                                                   np.max(dn.metrics["contact_loss_fraction"]))),
                     "max_multiplier": float(np.nanmax(np.concatenate([r.branches[b].max_multiplier
                                                                       for b in ("up", "down")])))}
        print(f"3 planets, {name}, {step_hz:g} Hz steps: {out[name]}", flush=True)
    return out


def _symmetrize(sy, s: np.ndarray, n: int) -> np.ndarray:
    """The in-phase state nearest ``s``: every planet's coordinates (in its own frame) their mean, the central
    members' translations 0."""
    s = s.copy()
    d = {name: i for i, name in enumerate(sy.dof_names)}
    for off in (0, sy.n):
        for c in ("zeta", "eta", "theta"):
            idx = [off + d[f"planet_{i}.{c}"] for i in range(1, n + 1)]
            s[idx] = s[idx].mean()
        for c in ("carrier.x", "carrier.y", "sun.x", "sun.y"):
            s[off + d[c]] = 0.0
    return s


def in_phase_stability(step_hz: float) -> dict:
    """5 planets: the in-phase periodic solution (identical planets) continued upward over 400-4400 Hz, refined by
    shooting at every speed, and its largest Floquet multiplier with the linearised mode it grows along."""
    fms = np.arange(400.0, 4400.0 + 1e-9, step_hz)
    out = {}
    for name in MODELS:
        sy = build_system(load_model(name), load_system_tables(name), planet_count=5)
        g0 = gyroscopic_modes(sy, 0.0)
        kinds = dict(zip(np.round(g0.natural_frequencies_Hz, 3), g0.types))
        s, rows = None, []
        for fm in fms:
            r = steady_state(sy, fm, None if s is None else _symmetrize(sy, s, 5),
                             SteadyStateOptions(max_cycles=600))
            f = floquet(sy, fm, _symmetrize(sy, r.state, 5), 1)
            s = f.state
            fd, share = f.dominant_modes(0, 1)[0]
            kind = min(kinds.items(), key=lambda kv: abs(kv[0] - fd))[1]
            rows.append((float(fm), f.max_multiplier, float(np.angle(f.multipliers[0]) / np.pi), kind, fd, f.success))
        unstable = [r for r in rows if r[1] > 1.0]
        regions, start = [], None
        for fm, row in zip(fms, rows):  # intervals of consecutive unstable speeds
            if row[1] > 1.0 and start is None:
                start = fm
            if row[1] <= 1.0 and start is not None:
                regions.append((start, prev))
                start = None
            prev = fm
        if start is not None:
            regions.append((start, prev))
        out[name] = {"mesh_frequency_Hz": fms.tolist(), "max_multiplier": [r[1] for r in rows],
                     "unstable_Hz": [list(map(float, x)) for x in regions],
                     "unstable_rows": [{"fm_Hz": r[0], "max_multiplier": r[1], "angle_over_pi": r[2], "mode_type": r[3],
                                        "mode_Hz": r[4]} for r in unstable],
                     "all_refined": bool(all(r[5] for r in rows)),
                     "max_multiplier_max": float(max(r[1] for r in rows))}
        print(f"5 planets in phase, {name}: unstable over {out[name]['unstable_Hz']}, largest |mu| "
              f"{out[name]['max_multiplier_max']:.4f}; growing modes "
              f"{sorted({(r[3], round(r[4], 1)) for r in unstable})}", flush=True)
    return out


def sensitivity(step_hz: float = 25.0) -> dict:
    """Up/down sweeps (3 and 5 planets, both models) for the support stiffnesses and damping ratios Table 4.2 leaves
    open: sun, carrier and planet-bearing translational stiffness together; the ring stays fixed."""
    fms = np.arange(400.0, 4400.0 + 1e-9, step_hz)
    out = {}
    for name in MODELS:
        base = load_model(name)
        tabs = load_system_tables(name)
        for kb, zeta in ((1e8, 0.02), (2e8, 0.02), (3e8, 0.02), (1e9, 0.02), (1e8, 0.03), (1e8, 0.04)):
            gears = tuple(g if g.name == "ring" else dataclasses.replace(g, support=dataclasses.replace(
                g.support, translational_stiffness_N_per_m=kb)) for g in base.gears)
            pl = dataclasses.replace(base.planetary, carrier_support=dataclasses.replace(
                base.planetary.carrier_support, translational_stiffness_N_per_m=kb))
            m = dataclasses.replace(base, gears=gears, planetary=pl)
            for n in (3, 5):
                sy = build_system(m, tabs, planet_count=n, modal_damping_ratio=zeta)
                r = run_sweep(SweepSpec(sy, tuple(fms), "both", options=STABLE), progress=False)
                u = r.branches["up"].metrics["rms_deflection_m"][:, 0]
                d = r.branches["down"].metrics["rms_deflection_m"][::-1, 0]
                rel = np.abs(u - d) / np.maximum(u, d)
                reg = _regions(fms, u, d)
                key = f"{name}|{kb:g}|{zeta:g}|{n}"
                out[key] = {"max_up_down_rel": float(rel.max()), "speeds_within_2pct": int(np.sum(rel <= 0.02)),
                            "double_valued_width_Hz": float(sum(b - a + step_hz for a, b in reg)),
                            "contact_loss_max": float(max(np.max(r.branches[b].metrics["contact_loss_fraction"])
                                                          for b in ("up", "down"))),
                            "peak_rms_m": float(max(u.max(), d.max()))}
                print(f"sensitivity {key}: {out[key]}", flush=True)
    return out


def at_1600() -> dict:
    m = load_model(MODELS[0])
    t = load_system_tables(MODELS[0])
    out = {}
    for n in (3, 4, 5):
        sy = build_system(m, t, planet_count=n)
        r = steady_state(sy, 1600.0, options=SteadyStateOptions(rtol=1e-9, max_cycles=6000), keep_trace=True)
        st, nsp = r.trace["state"], r.steps_per_cycle
        d = {name: i for i, name in enumerate(sy.dof_names)}
        osc = st - st.mean(axis=0)
        rs = sy.gears["sun"].radius_m
        trans = np.sqrt(np.mean(osc[:, d["sun.x"]] ** 2 + osc[:, d["sun.y"]] ** 2))
        rot = np.sqrt(np.mean((rs * osc[:, d["sun.theta"]]) ** 2))
        ctr = np.sqrt(np.mean(osc[:, d["carrier.x"]] ** 2 + osc[:, d["carrier.y"]] ** 2))
        x = r.trace["mesh_deflection_m"]
        sun = [k for k, c in enumerate(sy.meshes) if c.group == "sun_planet"]
        # planet i's sun mesh = planet 1's delayed by gamma_i mesh cycles (one period recorded: a spectral shift
        # delays it by any fraction of the period)
        shift_err = 0.0
        x1 = x[:, sun[0]] - x[:, sun[0]].mean()
        per = r.period_cycles
        harm = np.fft.rfftfreq(x1.size, 1.0 / x1.size) / per          # mesh harmonic of each bin
        for i, k in enumerate(sun[1:], start=1):
            delay = (-(sy.meshes[k].phase - sy.meshes[sun[0]].phase)) % 1.0
            shifted = np.fft.irfft(np.fft.rfft(x1) * np.exp(-2j * np.pi * harm * delay), x1.size)
            shift_err = max(shift_err, float(np.max(np.abs(shifted - (x[:, k] - x[:, k].mean())))
                                             / np.max(np.abs(x1))))
        # sun mid-space root strain over one relative revolution of the sun (65 mesh cycles)
        fm = 1600.0
        from hacgear_core.dynamics.simulator import Simulator

        sim = Simulator(sy)
        sim.set_speed_input(mesh_frequency_Hz=fm)
        sim.s[:] = r.state
        tr = sim.run(65 / fm, 1.0 / (fm * 64))
        eps = strain_of_tooth(sy, "sun/SGmid", tr["mesh_position"], tr["mesh_deflection_m"])
        out[n] = {"sun_translation_rms_m": float(trans), "sun_rotation_rms_m": float(rot),
                  "carrier_translation_rms_m": float(ctr), "translation_over_rotation": float(trans / rot),
                  "sun_mesh_rms_m": [float(np.std(x[:, k])) for k in sun],
                  "planets_equal_shifted_rel": shift_err, "sun_root_strain_max": float(eps.max()),
                  "sun_root_strain_min": float(eps.min())}
        print(f"1600 Hz, {n} planets: sun translation RMS {trans * 1e6:.3f} um, rotation RMS {rot * 1e6:.3f} um "
              f"(ratio {trans / rot:.3g}), carrier {ctr * 1e6:.3f} um; planets = planet 1 delayed within "
              f"{shift_err:.1e}; sun root strain {eps.min() * 1e6:.0f}..{eps.max() * 1e6:.0f} ue", flush=True)
    return out


def statics_and_modes() -> dict:
    m = load_model(MODELS[0])
    t = load_system_tables(MODELS[0])
    out = {"load_sharing": {}, "modes": {}}
    for n in (3, 4, 5):
        sy = build_system(m, t, planet_count=n)
        ls = load_sharing(sy, 64)
        sun = list(ls.groups["sun_planet"])
        out["load_sharing"][n] = {"cycle_mean_factor_max_dev": float(np.max(np.abs(ls.factor[sun] - 1))),
                                  "peak_factor": float(np.max(ls.peak_factor[sun]))}
        g0 = gyroscopic_modes(sy, 0.0)
        wc = sy.carrier_ratio * sy.reference_speed(1600.0)
        g1 = gyroscopic_modes(sy, wc)
        out["modes"][n] = {"zero_speed": list(zip(g0.natural_frequencies_Hz.round(1).tolist(), g0.types,
                                                   g0.multiplicity.tolist())),
                           "carrier_speed_rad_s": wc,
                           "at_1600Hz": list(zip(g1.natural_frequencies_Hz.round(1).tolist(), g1.types))}
    sy = build_system(m, t, planet_count=3, pin_errors_m={1: (0.0, 20e-6)})
    ls = load_sharing(sy, 64)
    out["pin_error_20um_tangential"] = ls.factor[list(ls.groups["sun_planet"])].tolist()
    print("load sharing:", out["load_sharing"], "pin error 20 um:", out["pin_error_20um_tangential"], flush=True)
    return out


def chain() -> dict:
    c = PlanetChain(MODELS[0])
    out = {}
    for f in (442.0, 1326.06, 3978.0):
        s = c.summary(c.study(f))
        out[f] = s
        print(f"chain at {f:g} N: sun mesh deflection {s['sun_mean_rel'] * 100:+.2f} % (max {s['sun_max_abs_rel'] * 100:.2f}"
              f" %), ring {s['ring_mean_rel'] * 100:+.2f} % (max {s['ring_max_abs_rel'] * 100:.2f} %)", flush=True)
    return out


def figure(sw: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(11, 7), constrained_layout=True, sharex=True)
    for j, name in enumerate(MODELS):
        for i, n in enumerate((3, 5)):
            d = sw[f"{name}/{n}"]
            a = ax[i, j]
            f = np.array(d["mesh_frequency_Hz"])
            a.plot(f, np.array(d["rms_up_m"]) * 1e6, "k.", ms=4, label="up sweep")
            a.plot(f, np.array(d["rms_down_m"]) * 1e6, "o", mfc="none", color="tab:blue", ms=5, label="down sweep")
            a.set_title(f"{n} planets, {'15 um tip relief' if j == 0 else 'no modification'}", fontsize=9)
            a.set_ylabel("sun-mesh RMS deflection [um]")
            a.legend(fontsize=8)
    for a in ax[1]:
        a.set_xlabel("mesh frequency [Hz]")
    fig.suptitle("planetary_65_55_175, 200 N*m on the sun (dissertation Figs. 4.10, 4.12): HAC, our FE tables",
                 fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=plain_text(__doc__.split("\n\n")[0]),
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="50 Hz steps")
    ap.add_argument("--fine-only", action="store_true",
                    help="recompute only the 3-planet sweeps in 5 Hz steps (key 'fine_3_planets' of the JSON)")
    ap.add_argument("--sensitivity", action="store_true",
                    help="also the support-stiffness / damping sensitivity of the sweeps (key 'sensitivity', ~4 min)")
    args = ap.parse_args(argv)
    out = ROOT / "docs" / "validation_planetary.json"
    if args.fine_only:
        res = json.loads(out.read_text())
        res["fine_3_planets"] = fine_3_planets()
        out.write_text(json.dumps(res, indent=1, default=float))
        print("updated 'fine_3_planets' in docs/validation_planetary.json")
        return 0
    t0 = time.perf_counter()
    res = {"statics_and_modes": statics_and_modes(), "chain": chain(), "at_1600Hz": at_1600(),
           "sweeps": sweeps(50.0 if args.quick else 25.0),
           "fine_3_planets": fine_3_planets(25.0 if args.quick else 5.0),
           "in_phase_5_planets": in_phase_stability(50.0 if args.quick else 25.0)}
    if args.sensitivity:
        res["sensitivity"] = sensitivity()
    elif out.exists() and "sensitivity" in json.loads(out.read_text()):
        res["sensitivity"] = json.loads(out.read_text())["sensitivity"]  # kept from the last --sensitivity run
    res["wall_s"] = time.perf_counter() - t0
    out.write_text(json.dumps(res, indent=1, default=float))
    figure(res["sweeps"], ROOT / "docs" / "figures" / "validation_planetary_sweeps.png")
    print(f"wrote docs/validation_planetary.json and docs/figures/validation_planetary_sweeps.png "
          f"({res['wall_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
