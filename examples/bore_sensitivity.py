#!/usr/bin/env python
"""Sensitivity of the 28-tooth pair's published numbers to the one blank dimension the dissertation leaves out.

The dissertation (Table 3.3, Section 3.6) gives the teeth of the 28-tooth asymmetric pair but not its blank.
hacgear models the blank as a solid disk whose bore is tied to a rigid hub (the lumped coordinates); the
model file chooses a 40 mm bore.  This study rebuilds the pair for several bore diameters and for a few webbed
blanks (``[gears.web]``: rim, thin web, hub; everything else as in ``models/spur_28t_asym/model.toml``) and, for
each, measures with the normal tool chain:

* mean mesh stiffness at 300 N·m (``hacgear stiffness``: cycle mean of the local slope) — dissertation 150e6 N/m;
* gear mass and polar inertia (``hacgear info``);
* natural frequency with rigid supports (``hacgear modes --bearing-stiffness inf``, linearised on the FE
  tables) — dissertation 2775 Hz HAC / 2800 Hz FE/CM;
* highest natural frequency with k_y1 = k_y2 = 200e6 N/m (``--bearing-stiffness 200e6``) — dissertation
  4150 Hz HAC / 4250 Hz FE/CM.

It also solves the two-mode frequency equations of the lumped model
(``hacgear_core.dynamics.identical_pair_mass_properties``) for the mass properties that the dissertation's own
numbers imply (mesh stiffness 150e6 N/m, 2775 Hz, 4150 Hz), to compare with those of a
solid blank.  Writes ``<out>/bore_sensitivity.json`` and ``<out>/figures/bore_sensitivity.png``.

    python examples/bore_sensitivity.py [--bores 30,35,40,46,48,50,60] [--webs 5/60/100,5/60/110,8/60/110] [--out docs]
    (~70 s on 2 cores, cold)
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import re
import sys
import tempfile
from pathlib import Path

from hacgear_core.cli._help import plain_text

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "models" / "spur_28t_asym" / "model.toml"
TORQUE_NM = 300.0
K_Y = 200e6
PUBLISHED = {"mesh_stiffness_N_per_m": 150e6, "f_rigid_Hz": 2775.0, "f_rigid_fecm_Hz": 2800.0,
             "f_200_Hz": 4150.0, "f_200_fecm_Hz": 4250.0}


def _cli_json(argv: list[str]) -> dict:
    from hacgear_core.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(argv)
    if rc != 0:
        raise SystemExit(f"hacgear {' '.join(argv)} failed with exit code {rc}")
    return json.loads(buf.getvalue())


def _measure(text: str, folder: Path, name: str) -> dict:
    """info, stiffness, FE tables and both modal analyses of one model variant (text of a model file)."""
    folder.mkdir()
    text = text.replace('name = "spur_28t_asym"', f'name = "{name}"', 1)
    path = folder / "model.toml"
    path.write_text(text, encoding="utf-8")
    info = _cli_json(["info", str(path), "--json"])["gears"]["pinion"]
    stiff = _cli_json(["stiffness", str(path), "--torque", str(TORQUE_NM), "--positions", "32", "--json"])
    _cli_json(["statics", str(path), "--positions", "32", "--loads", "16", "--deflections", "32",
               "--no-progress", "--json"])
    rigid = _cli_json(["modes", str(path), "--torque", str(TORQUE_NM), "--bearing-stiffness", "inf",
                       "--no-impulse", "--json"])
    soft = _cli_json(["modes", str(path), "--torque", str(TORQUE_NM), "--bearing-stiffness", str(K_Y),
                      "--no-impulse", "--json"])
    r_b = info["base_radius_m"]["drive"]
    return {"base_radius_m": r_b, "mass_kg": info["mass_kg"], "inertia_kgm2": info["inertia_kgm2"],
            "mass_ratio_m_rb2_over_J": info["mass_kg"] * r_b ** 2 / info["inertia_kgm2"],
            "mean_mesh_stiffness_N_per_m": stiff["meshes"]["m12"]["mean_mesh_stiffness_N_per_m"],
            "f_rigid_Hz": max(rigid["natural_frequencies_Hz"]), "f_200_Hz": max(soft["natural_frequencies_Hz"])}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=plain_text(__doc__.split("\n\n")[0]),
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--bores", default="30,35,40,46,48,50,60", help="solid blanks: bore diameters [mm], comma separated")
    ap.add_argument("--webs", default="5/60/100,5/60/110,8/60/110",
                    help="webbed blanks on the model's 40 mm bore: thickness/inner/outer diameter [mm] triples, "
                         "comma separated ('' for none)")
    ap.add_argument("--out", default=str(ROOT / "docs"), help="folder for bore_sensitivity.json and figures/")
    args = ap.parse_args(argv)
    from hacgear_core.dynamics import identical_pair_mass_properties

    bores = [float(b) for b in args.bores.split(",")]
    webs = [tuple(float(v) for v in w.split("/")) for w in args.webs.split(",") if w.strip()]
    if any(len(w) != 3 for w in webs):
        raise SystemExit("--webs: each entry is thickness/inner/outer diameter in mm, e.g. 8/60/110")
    text = MODEL.read_text(encoding="utf-8")
    if len(re.findall(r"^bore_diameter_mm = .*$", text, flags=re.M)) != 2 or text.count('material = "steel"\n') != 2:
        raise SystemExit(f"{MODEL}: expected two 'bore_diameter_mm' and two 'material' lines (pinion and wheel)")
    rows, web_rows = [], []
    with tempfile.TemporaryDirectory(prefix="hacgear_bore_") as tmp:
        for d in bores:
            variant = re.sub(r"^bore_diameter_mm = .*$", f"bore_diameter_mm = {d!r}", text, flags=re.M)
            row = {"bore_diameter_mm": d, **_measure(variant, Path(tmp) / f"bore_{d:g}mm", f"spur_28t_asym_bore{d:g}")}
            rows.append(row)
            print(f"bore {d:5.1f} mm: m = {row['mass_kg']:.3f} kg, J = {row['inertia_kgm2'] * 1e3:.3f}e-3 kg m², "
                  f"m r_b²/J = {row['mass_ratio_m_rb2_over_J']:.3f}, k = {row['mean_mesh_stiffness_N_per_m'] / 1e6:.1f}e6 "
                  f"N/m, f(rigid) = {row['f_rigid_Hz']:.0f} Hz, f(k_y = 200e6) = {row['f_200_Hz']:.0f} Hz", flush=True)
        for t, di, do in webs:
            block = (f'  [gears.web]\n  thickness_mm = {t!r}\n  inner_diameter_mm = {di!r}\n'
                     f'  outer_diameter_mm = {do!r}\n')
            variant = text.replace('material = "steel"\n', 'material = "steel"\n' + block)
            row = {"bore_diameter_mm": 40.0, "web_thickness_mm": t, "web_inner_diameter_mm": di,
                   "web_outer_diameter_mm": do,
                   **_measure(variant, Path(tmp) / f"web_{t:g}_{di:g}_{do:g}", f"spur_28t_asym_web{t:g}_{di:g}_{do:g}")}
            web_rows.append(row)
            print(f"web {t:g} mm, {di:g}/{do:g} mm: m = {row['mass_kg']:.3f} kg, J = {row['inertia_kgm2'] * 1e3:.3f}e-3 "
                  f"kg m², m r_b²/J = {row['mass_ratio_m_rb2_over_J']:.3f}, k = "
                  f"{row['mean_mesh_stiffness_N_per_m'] / 1e6:.1f}e6 N/m, f(rigid) = {row['f_rigid_Hz']:.0f} Hz, "
                  f"f(k_y = 200e6) = {row['f_200_Hz']:.0f} Hz", flush=True)
    r_b = rows[0]["base_radius_m"]
    # check of the inversion: each row's own frequencies and stiffness must give back its mass and inertia
    for row in rows + web_rows:
        back = identical_pair_mass_properties(row["mean_mesh_stiffness_N_per_m"], row["f_rigid_Hz"], row["f_200_Hz"], K_Y, r_b)
        row["inversion_error_mass"] = back["mass_kg"] / row["mass_kg"] - 1.0
        row["inversion_error_inertia"] = back["inertia_kgm2"] / row["inertia_kgm2"] - 1.0
    err = max(max(abs(r["inversion_error_mass"]), abs(r["inversion_error_inertia"])) for r in rows + web_rows)
    print(f"inversion check on the computed rows: largest relative error in m, J = {err:.1e}")
    implied = identical_pair_mass_properties(PUBLISHED["mesh_stiffness_N_per_m"], PUBLISHED["f_rigid_Hz"],
                                      PUBLISHED["f_200_Hz"], K_Y, r_b)
    print(f"dissertation's numbers imply m = {implied['mass_kg']:.3f} kg, J = {implied['inertia_kgm2'] * 1e3:.3f}e-3 "
          f"kg m², m r_b²/J = {implied['mass_ratio']:.3f}")
    band = {"mean_mesh_stiffness_N_per_m": (0.9 * 150e6, 1.1 * 150e6), "f_rigid_Hz": (0.95 * 2800, 1.05 * 2800),
            "f_200_Hz": (0.95 * 4150, 1.05 * 4150)}
    for row in rows + web_rows:
        row["within_issue_bands"] = {k: bool(lo <= row[k] <= hi) for k, (lo, hi) in band.items()}
    out = Path(args.out)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    result = {"model": "spur_28t_asym", "torque_Nm": TORQUE_NM, "support_stiffness_N_per_m": K_Y,
              "published": PUBLISHED, "issue_bands": band, "rows": rows, "web_rows": web_rows,
              "implied_by_dissertation": implied,
              "command": f"python examples/bore_sensitivity.py --bores {args.bores} --webs {args.webs}"}
    (out / "bore_sensitivity.json").write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = [r["bore_diameter_mm"] for r in rows]
    fig, axs = plt.subplots(1, 3, figsize=(12, 3.6), constrained_layout=True)
    for ax, key, scale, label in ((axs[0], "mean_mesh_stiffness_N_per_m", 1e-6, "mean mesh stiffness [1e6 N/m]"),
                                  (axs[1], "f_rigid_Hz", 1.0, "natural frequency, rigid supports [Hz]"),
                                  (axs[2], "f_200_Hz", 1.0, "highest frequency, k_y = 200e6 N/m [Hz]")):
        lo, hi = band[key]
        ax.axhspan(lo * scale, hi * scale, color="tab:green", alpha=0.2, label="issue band (dissertation)")
        ax.plot(x, [r[key] * scale for r in rows], "o-k", label="hacgear, solid blank, rigid hub")
        for w, mk in zip(web_rows, "sD^v<>"):
            ax.plot(w["bore_diameter_mm"], w[key] * scale, mk, ms=7, mfc="none",
                    label=f"web {w['web_thickness_mm']:g} mm, {w['web_inner_diameter_mm']:g}/"
                          f"{w['web_outer_diameter_mm']:g} mm (40 mm bore)")
        ax.set_xlabel("bore diameter [mm]")
        ax.set_ylabel(label)
        ax.axvline(40.0, color="tab:blue", ls=":", label="model file (40 mm)")
        ax.grid(alpha=0.3)
    axs[0].legend(fontsize=7)
    fig.suptitle("28-tooth pair, 300 N·m: the unspecified blank (bore, web) against the three published numbers")
    fig.savefig(out / "figures" / "bore_sensitivity.png", dpi=110)
    print(f"wrote {out / 'bore_sensitivity.json'} and {out / 'figures' / 'bore_sensitivity.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
