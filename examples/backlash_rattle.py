#!/usr/bin/env python
"""Both flanks in action: a torque reversal through the backlash, and gear rattle of an unloaded pair.

    python examples/backlash_rattle.py [--system spur_28t_asym] [--out docs/figures/backlash_rattle.png] [--json]

Two drivetrain-mode runs of the library's simulator (shaft torques in; the same equations the FMU integrates,
``tests/test_fmu.py`` checks that the FMU reproduces them):

1. **Torque reversal** (engine braking): the pinion carries +T and the wheel its load; the torques ramp to the
   opposite sign within ``--ramp`` seconds.  The mesh force leaves the drive flanks, the teeth cross the backlash
   and land on the coast flanks (the 28-tooth pair: from its 25° side to its 20° side).
2. **Gear rattle**: zero mean torque; the pinion is driven by a fluctuating torque ``T_a sin(2 pi f t)`` (firing
   pulses of an idling engine) and the wheel turns freely, so the teeth hammer across the backlash between drive
   and coast flanks.

Prints per run the contact states, impacts and peak forces; writes a figure of mesh deflection (against the
backlash), drive and coast forces and contact state.
"""
from __future__ import annotations

import argparse
import json
import math

import numpy as np

from hacgear_core.cli._help import plain_text
from hacgear_core.kinds import build_system
from hacgear_core.dynamics.simulator import Simulator
from hacgear_core.encodings import ContactState
from hacgear_core.kinds import load_model
from hacgear_core.tables import load_system_tables


def run(system, torques, duration_s: float, speed_rad_s: float, record_dt_s: float = 2e-6) -> dict:
    """Drivetrain-mode run: ``torques(t) -> {port: T [N m]}`` applied at every record step; returns the traces."""
    sim = Simulator(system)
    sim.reset(speed_rad_s=speed_rad_s)
    n = int(round(duration_s / record_dt_s))
    out = {k: np.empty((n, system.m)) for k in ("x", "xc", "f", "fc")}
    out["t"] = np.empty(n)
    out["state"] = np.empty((n, system.m), dtype=int)
    out["speed"] = np.empty((n, len(sim.gear_names)))
    for i in range(n):
        t = i * record_dt_s
        sim.set_torque_inputs(torques(t))
        r = sim.advance(record_dt_s)
        if not r.success:
            raise SystemExit(r.message)
        out["t"][i] = t + record_dt_s
        out["x"][i], out["xc"][i] = sim.mesh_deflection_m, sim.coast_approach_m
        out["f"][i], out["fc"][i] = sim.mesh_force_N, sim.coast_force_N
        out["state"][i] = sim.contact_state
        out["speed"][i] = sim.speed_rad_s
    out["out_of_range_steps"] = list(sim.out_of_range_steps)
    return out


def summary(res: dict, system) -> dict:
    fc, f = res["fc"][:, 0], res["f"][:, 0]
    on_c = fc > 0
    return {"coast_contact_fraction": float(np.mean(on_c)), "drive_contact_fraction": float(np.mean(f > 0)),
            "separated_fraction": float(np.mean((f <= 0) & ~on_c)),
            "back_side_impacts": int(np.sum(on_c[1:] & ~on_c[:-1])),
            "drive_side_impacts": int(np.sum((f[1:] > 0) & (f[:-1] <= 0))),
            "peak_drive_force_N": float(f.max()), "peak_coast_force_N": float(fc.max()),
            "min_mesh_deflection_m": float(res["x"][:, 0].min()),
            "max_coast_approach_m": float(res["xc"][:, 0].max()),
            "backlash_normal_m": float(system.backlash_m[0]),
            "out_of_range_steps": res["out_of_range_steps"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=plain_text(__doc__.splitlines()[0]),
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--system", default="spur_28t_asym", help="a spur pair with two-sided tables")
    ap.add_argument("--torque", type=float, default=300.0, help="torque before the reversal [N m] (on the pinion)")
    ap.add_argument("--ramp", type=float, default=5e-3, help="duration of the torque reversal [s]")
    ap.add_argument("--rattle-torque", type=float, default=40.0, help="amplitude of the fluctuating torque [N m]")
    ap.add_argument("--rattle-hz", type=float, default=40.0, help="frequency of the fluctuating torque [Hz]")
    ap.add_argument("--rpm", type=float, default=1000.0, help="pinion speed [rpm]")
    ap.add_argument("--out", default="backlash_rattle.png", help="figure (PNG)")
    ap.add_argument("--json", action="store_true", help="print the summaries as JSON")
    args = ap.parse_args(argv)
    model = load_model(args.system)
    system = build_system(model, load_system_tables(model.path), shafts=False)
    if not system.two_sided:
        raise SystemExit(f"{args.system}: the tables have no coast side; run `hacgear statics {args.system}`")
    sim0 = Simulator(system)
    p_in, p_out = sim0.ports
    ratio = sim0.port_torques_Nm[p_out] / sim0.port_torques_Nm[p_in]   # load torque per input torque
    w0 = args.rpm * 2 * math.pi / 60
    t0, tr = 0.01, args.ramp

    def reversal(t):
        s = 1.0 if t < t0 else (-1.0 if t > t0 + tr else 1.0 - 2.0 * (t - t0) / tr)
        return {p_in: s * args.torque, p_out: s * args.torque * ratio}

    def rattle(t):
        return {p_in: args.rattle_torque * math.sin(2 * math.pi * args.rattle_hz * t), p_out: 0.0}

    a = run(system, reversal, t0 + tr + 0.02, w0)
    b = run(system, rattle, 4.0 / args.rattle_hz, w0)
    out = {"system": args.system, "backlash_normal_m": float(system.backlash_m[0]),
           "torque_reversal": {"torque_Nm": args.torque, "ramp_s": tr, **summary(a, system)},
           "rattle": {"torque_amplitude_Nm": args.rattle_torque, "frequency_Hz": args.rattle_hz, **summary(b, system)}}
    if args.json:
        print(json.dumps(out, indent=1))
    else:
        for k in ("torque_reversal", "rattle"):
            s = out[k]
            print(f"{k}: drive contact {s['drive_contact_fraction']:.3f}, coast contact {s['coast_contact_fraction']:.3f}, "
                  f"separated {s['separated_fraction']:.3f} of the time; {s['drive_side_impacts']} drive-side and "
                  f"{s['back_side_impacts']} back-side impacts; peak forces {s['peak_drive_force_N']:.0f} N (drive), "
                  f"{s['peak_coast_force_N']:.0f} N (coast); coast approach up to "
                  f"{s['max_coast_approach_m'] * 1e6:.1f} µm against a {s['backlash_normal_m'] * 1e6:.1f} µm backlash")
    _plot(a, b, system, args.out, out)
    print(f"figure: {args.out}")
    return 0


def _plot(a, b, system, path, out) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(3, 2, figsize=(12, 8), sharex="col")
    j = float(system.backlash_m[0])
    for col, (res, title) in enumerate(((a, f"torque reversal {out['torque_reversal']['torque_Nm']:g} → "
                                            f"{-out['torque_reversal']['torque_Nm']:g} N·m"),
                                       (b, f"rattle: ±{out['rattle']['torque_amplitude_Nm']:g} N·m at "
                                           f"{out['rattle']['frequency_Hz']:g} Hz, no load"))):
        t = res["t"] * 1e3
        ax[0, col].plot(t, res["xc"][:, 0] * 1e6, color="C1", label="coast approach $x_c$")
        ax[0, col].plot(t, -res["x"][:, 0] * 1e6, color="C0", label="$-x$ (drive deflection, negated)")
        ax[0, col].axhline(j * 1e6, color="k", ls="--", lw=1, label=f"normal backlash {j * 1e6:.0f} µm")
        ax[0, col].set_ylabel("µm")
        if col == 0:  # the same curves on the right: one legend, where the left panel is empty
            ax[0, col].legend(loc="lower right", fontsize=8)
        ax[0, col].set_title(title)
        ax[1, col].plot(t, res["f"][:, 0] / 1e3, color="C0", label="drive flanks")
        ax[1, col].plot(t, res["fc"][:, 0] / 1e3, color="C1", label="coast flanks")
        ax[1, col].set_ylabel("mesh force [kN]")
        if col == 0:
            ax[1, col].legend(loc="upper left", fontsize=8)
        ax[2, col].step(t, res["state"][:, 0], where="post", color="k")
        ax[2, col].set_yticks([int(c) for c in ContactState], [c.name.lower() for c in ContactState])
        ax[2, col].set_ylabel("contact")
        ax[2, col].set_xlabel("time [ms]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    raise SystemExit(main())
