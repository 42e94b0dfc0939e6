"""Order spectrum, run-up waterfall and Campbell diagram of every shipped system (docs/spectra.md "Gallery").

Each system is taken at its model file's torque and at one operating mesh frequency:

* the NREL 5 MW models at rated speed, 12.1 rpm on the stage-1 carrier (each stage at the speed the gearbox gives
  it);
* every other system below its mesh mode, the mode with the largest share of its strain energy in the meshes:
  f_op = 0.8 f_mode / r_max (r_max the fastest mesh's rate over the reference mesh's), so its fastest mesh's first
  harmonic lies at 80 % of that mode.

Per system: the steady-state order spectrum of the dynamic transmission error (DTE) at f_op, each mesh's harmonics
marked at its own rate (hacgear_core.spectra.records.system_spectra; one common period of the shafts where it is at
most --max-record-cycles and a million samples, else that many cycles with the flat-top window), a run-up from 0.5
to 1.5 f_op (hacgear_core.spectra.waterfall.system_waterfalls, through the mesh mode), and the Campbell diagram from
rest to 1.5 f_op (hacgear_core.spectra.campbell.campbell).  Figures go to --out (default docs/figures/gallery), the
measured numbers to <out>/gallery.json, written after each system.  A planetary set or gearbox shows the first mesh
of each stage and kind of contact (sun and ring meshes of planet 1).

    python examples/spectra_gallery.py [--systems spur_28t_asym,helical_28_33] [--out DIR]
"""
from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from fractions import Fraction
from pathlib import Path

import numpy as np
import scipy.linalg

from hacgear_core.cli.inputs import load_inputs
from hacgear_core.errors import ModelError
from hacgear_core.model.toml import shipped_systems
from hacgear_core.plots.spectra import save_campbell_figure, save_spectrum_figure, save_waterfall_figure
from hacgear_core.spectra.campbell import RPM_PER_RAD_S, campbell
from hacgear_core.spectra.records import system_spectra
from hacgear_core.spectra.spectrum import mesh_harmonic_label, order_basis
from hacgear_core.spectra.waterfall import resonance_of_track, system_waterfalls

#: rated input speed of the NREL 5 MW drivetrain [rpm] on the stage-1 carrier, and each model's input speed over it
RATED_RPM = 12.1
NREL_INPUT_RATIO = {"nrel_5mw_gearbox": Fraction(1), "nrel_5mw_stage1": Fraction(1),
                    "nrel_5mw_stage2": Fraction(75, 19), "nrel_5mw_stage3": Fraction(75, 19) * Fraction(111, 18)}


def mesh_mode_Hz(system) -> tuple[float, float]:
    """(frequency [Hz], mesh share of its strain energy) of the mode with the largest share of its strain energy
    in the meshes (the linearised model at the torque)."""
    klin, k0, m = system.k_lin, np.asarray(system.K, float), np.asarray(system.M, float)
    w2, phi = scipy.linalg.eigh(klin, m)
    best = (0.0, -1.0)
    for i in range(len(w2)):
        if w2[i] <= 1e-6 * w2[-1]:
            continue
        p = phi[:, i]
        share = 1.0 - float(p @ k0 @ p) / float(p @ klin @ p)
        if share > best[1]:
            best = (math.sqrt(w2[i]) / (2 * math.pi), share)
    return best


def _finite(x: float) -> float | None:
    """``x``, or None where it is not a number (a windowed record reports no power fractions)."""
    return float(x) if math.isfinite(x) else None


def operating_point(name: str, system) -> tuple[float, str]:
    """(reference mesh frequency [Hz], why) of ``name``."""
    if name in NREL_INPUT_RATIO:
        rpm = RATED_RPM * float(NREL_INPUT_RATIO[name])
        probe = campbell(system, np.array([0.0, 1.0]), harmonics=1, shaft_orders=0)
        return probe.mesh_hz_per_rad_s * rpm / RPM_PER_RAD_S, f"rated speed ({rpm:.4g} rpm input)"
    f_mode, share = mesh_mode_Hz(system)
    r_max = float(np.max(system.rates))
    return 0.8 * f_mode / r_max, f"0.8 x mesh mode {f_mode:.1f} Hz ({100 * share:.0f} % mesh energy) / rate {r_max:.4g}"


def shown_channels(system, channels: dict) -> list[str]:
    """The channels drawn: every mesh of a pair or train, the first sun and ring mesh of each planetary stage."""
    names = list(channels)
    if len(names) <= 4:
        return names
    seen, keep = set(), []
    for c in system.meshes:
        group = getattr(c, "group", "") or c.name
        if group not in seen and c.name in channels:
            seen.add(group)
            keep.append(c.name)
    return keep[:6]


def gallery_entry(name: str, out: Path, *, max_record_cycles: int, runup_cycles: int) -> dict:
    """Figures and numbers of one shipped system."""
    t0 = time.perf_counter()
    system = load_inputs(name).system
    f_op, why = operating_point(name, system)
    r_max = float(np.max(system.rates))
    spc = int(2 ** math.ceil(math.log2(max(64.0, 16.0 * r_max))))   # >= 16 samples per fastest mesh cycle
    period = order_basis(system).common_period_cycles()
    cap = min(max_record_cycles, 2 ** 20 // spc)    # at most about a million samples per record
    whole = period is not None and period.denominator == 1 and period <= cap
    cycles = int(period) if whole else cap
    rec, spectra = system_spectra(system, f_op, "dte", record_cycles=cycles, samples_per_cycle=spc,
                                  harmonics=3, sideband_orders=2)
    show = shown_channels(system, spectra)
    title = f"{name}: DTE at f_m = {f_op:.4g} Hz ({why})"
    save_spectrum_figure({k: spectra[k] for k in show}, out / f"{name}_spectrum.png", unit="µm", scale=1e6,
                         title=title)
    seg = int(period) if whole and period <= 128 else 64
    wcycles = max(runup_cycles, 8 * seg)
    _, falls = system_waterfalls(system, 0.5 * f_op, 1.5 * f_op, wcycles, "dte", segment_cycles=seg,
                                 samples_per_cycle=spc, harmonics=3)
    save_waterfall_figure({k: falls[k] for k in show}, out / f"{name}_waterfall.png", unit="µm", scale=1e6,
                          max_order=3.5 * r_max,
                          title=f"{name}: DTE run-up {0.5 * f_op:.4g} -> {1.5 * f_op:.4g} Hz in {wcycles} mesh cycles")
    probe = campbell(system, np.array([0.0, 1.0]), harmonics=1, shaft_orders=0)
    top_rad_s = 1.5 * f_op / probe.mesh_hz_per_rad_s
    speeds = np.linspace(0.0, top_rad_s, 41 if getattr(system, "carrier_ratio", 0.0) else 2)
    cres = campbell(system, speeds, harmonics=3, shaft_orders=1)
    save_campbell_figure(cres, out / f"{name}_campbell.png",
                         title=f"{name}: Campbell diagram, torque {system.torque_Nm:g} N·m")
    entry = {"mesh_frequency_Hz": f_op, "operating_point": why, "samples_per_cycle": spc,
             "record_cycles": cycles, "coherent": bool(whole), "periodicity_error": rec.periodicity_error,
             "runup_cycles": wcycles, "segment_cycles": seg, "meshes": {}}
    for k in show:
        sp = spectra[k]
        label = mesh_harmonic_label(system, k)      # the channel's own mesh's first harmonic
        h1 = sp.line(label)
        peak_fm, peak_amp = resonance_of_track(falls[k], label)
        entry["meshes"][k] = {"harmonic1_label": label,
            "dte_mean_m": float(sp.amplitude[0]), "dte_harmonic1_m": h1.amplitude,
            "harmonic_power_fraction": _finite(sp.mesh_harmonic_power_fraction),
            "runup_peak_harmonic1_m": peak_amp, "runup_peak_mesh_frequency_Hz": peak_fm}
    low = [c for c in cres.crossings if c.line.startswith("1") or c.line == "f_m"]
    entry["crossings"] = len(cres.crossings)
    entry["first_crossing"] = None if not cres.crossings else {
        "line": cres.crossings[0].line, "input_speed_rpm": cres.crossings[0].input_speed_rpm,
        "frequency_Hz": cres.crossings[0].frequency_Hz}
    entry["mesh_harmonic1_crossings"] = len(low)
    entry["wall_s"] = time.perf_counter() - t0
    return entry


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    p.add_argument("--systems", default=None, help="comma-separated shipped systems (default: all of them)")
    p.add_argument("--out", default="docs/figures/gallery", help="folder of the figures and gallery.json (default: %(default)s)")
    p.add_argument("--max-record-cycles", type=int, default=2048,
                   help="longest steady record [mesh cycles]; a longer common period is windowed (flat-top) "
                        "(default: %(default)s)")
    p.add_argument("--runup-cycles", type=int, default=1200, help="mesh cycles of the run-up, at least 8 segments (default: %(default)s)")
    args = p.parse_args(argv)
    names = shipped_systems() if args.systems is None else tuple(args.systems.split(","))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "gallery.json"
    data = json.loads(path.read_text()) if path.exists() else {}
    data["machine"] = {"cpu": platform.processor() or platform.machine(), "python": platform.python_version()}
    for name in names:
        try:
            entry = gallery_entry(name, out, max_record_cycles=args.max_record_cycles,
                                  runup_cycles=args.runup_cycles)
        except ModelError as exc:
            print(f"{name}: {exc}", file=sys.stderr)
            return 2
        data.setdefault("systems", {})[name] = entry
        path.write_text(json.dumps(data, indent=1, sort_keys=True))   # written after each system
        m = next(iter(entry["meshes"].values()))
        print(f"{name}: f_m {entry['mesh_frequency_Hz']:.4g} Hz, DTE h1 {1e6 * m['dte_harmonic1_m']:.4g} um, "
              f"harmonic power {m['harmonic_power_fraction']}, run-up peak {1e6 * m['runup_peak_harmonic1_m']:.4g}"
              f" um at {m['runup_peak_mesh_frequency_Hz']:.4g} Hz, {entry['crossings']} crossings, "
              f"{entry['wall_s']:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
