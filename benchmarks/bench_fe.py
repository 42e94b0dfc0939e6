"""Benchmark of the finite-element far field for the 28-tooth gear (spur_28t_asym):
mesh + assemble + factorise + unit-load solves, DOF, pitch-point compliance, and
(``--convergence``) the change of the near-field-corrected compliance and of the gauge
strains under mesh refinement.

    python benchmarks/bench_fe.py [--refine F] [--convergence] [--method cyclic|full] [--json]

Judged by: ``ratio = (mesh + assemble + factorise + solves) / 10 s`` for the default mesh
(target <= 1 on the 2-core reference machine); the cache is bypassed.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hacgear_core.statics.fe import ElasticMaterial, Gauge, MeshOptions, build_gear_fe, gear_compliance  # noqa: E402
from hacgear_core.statics.nearfield import hertz_line_contact  # noqa: E402
from hacgear_core.cpu import vector_units

TARGET_S = 10.0
TORQUE_NM = 300.0


def _gear():
    from hacgear_core.geometry import gear_geometry
    from hacgear_core.kinds import load_model

    model = load_model(ROOT / "models" / "spur_28t_asym" / "model.toml")
    g = model.gears[0]
    return g, gear_geometry(g)


def _pitch_numbers(fc, gg, gear, w):
    """Compliance at the pitch point of the drive flank: one tooth and the identical pair."""
    r_p = gg.pitch_radius_m
    r = np.hypot(fc.xy_m[:, 0], fc.xy_m[:, 1])
    s_p = float(np.interp(r_p, r[::-1], fc.s_m[::-1]))
    rho = float(np.interp(s_p, fc.s_m, fc.curvature_radius_m))
    hz = hertz_line_contact(w, rho, rho, fc.youngs_modulus_Pa, fc.poisson_ratio, plane=fc.plane)
    c_far = float(fc.far_field(0, s_p, s_p))
    c_near = float(fc.self_approach(w, hz.half_width_m, s_p)) / w
    c_tooth = c_far + c_near                              # one gear, per unit face width [m^2/N]
    c_pair = 2 * c_tooth                                   # identical gears, both near fields
    b = gear.face_width_m
    return dict(s_pitch_m=s_p, curvature_radius_m=rho, hertz_half_width_m=hz.half_width_m,
                compliance_far_m2_N=c_far, compliance_near_m2_N=c_near,
                tooth_stiffness_N_per_m_per_m=1 / c_tooth, tooth_stiffness_N_per_m=b / c_tooth,
                pair_stiffness_N_per_m=b / c_pair,
                neighbour_coupling_ratio=float(fc.far_field(1, s_p, s_p) / c_far),
                neighbour_coupling_ratio_minus=float(fc.far_field(-1, s_p, s_p) / c_far))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refine", type=float, default=1.0, help="divide all mesh sizes by this factor")
    ap.add_argument("--convergence", action="store_true", help="also run refine x2 and x4")
    ap.add_argument("--method", choices=("cyclic", "full"), default="cyclic",
                    help="cyclic-symmetry solver (default) or the whole-gear reference model")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    print(f"CPU the kernels are compiled for: {vector_units().describe()}", flush=True)

    gear, gg = _gear()
    mat = ElasticMaterial(gear.material.youngs_modulus_Pa, gear.material.poisson_ratio, "stress")
    gauges = [Gauge(x.name, x.flank, x.radius_m) for x in gear.gauges]
    w = TORQUE_NM / (gg.base_radius_m["drive"] * gear.face_width_m)
    rows = []
    factors = [args.refine] + ([2 * args.refine, 4 * args.refine] if args.convergence else [])
    for f in factors:
        opts = MeshOptions().refined(f)
        t0 = time.perf_counter()
        fe = build_gear_fe(gg, mat, opts, method=args.method)
        t1 = time.perf_counter()
        fc = gear_compliance(gg, mat, "drive", options=opts, gauges=gauges, fe=fe, cache=False)
        t2 = time.perf_counter()
        i = fc.n_samples // 2
        row = dict(refine=f, n_dofs=fe.n_dofs, n_free=fe.n_free, n_triangles=int(fe.gear_mesh.t.shape[0]),
                   n_samples=fc.n_samples, mesh_s=fe.timings_s["mesh"], assemble_s=fe.timings_s["assemble"],
                   factorize_s=fe.timings_s["factorize"], solves_and_post_s=t2 - t1, total_s=t2 - t0,
                   **_pitch_numbers(fc, gg, gear, w),
                   gauge_strain_per_N_m_mid_sample={n: float(fc.strain_per_N_m[g, 0, i])
                                                    for g, n in enumerate(fc.gauge_names)},
                   gauge_strain_at_300Nm_pitch={n: float(fc.strain(g, 0, _pitch_numbers(fc, gg, gear, w)["s_pitch_m"]) * w)
                                                for g, n in enumerate(fc.gauge_names)})
        rows.append(row)
        if not args.json:
            print(f"[{args.method}] refine x{f:g}: {row['n_triangles']} triangles, {row['n_dofs']} DOF "
                  f"({row['n_free']} free), {row['n_samples']} unit loads")
            print(f"  mesh {row['mesh_s']:.2f} s, assemble {row['assemble_s']:.2f} s, factorise "
                  f"{row['factorize_s']:.2f} s, solves+post {row['solves_and_post_s']:.2f} s, total {row['total_s']:.2f} s")
            print(f"  pitch point s = {row['s_pitch_m'] * 1e3:.3f} mm, rho = {row['curvature_radius_m'] * 1e3:.2f} mm, "
                  f"a = {row['hertz_half_width_m'] * 1e6:.1f} um at {w / 1e3:.0f} N/mm")
            print(f"  one tooth: far {row['compliance_far_m2_N']:.4e} + near {row['compliance_near_m2_N']:.4e} m^2/N"
                  f" -> {row['tooth_stiffness_N_per_m_per_m']:.4e} N/m per m face, {row['tooth_stiffness_N_per_m']:.4e} N/m"
                  f" for {gear.face_width_m * 1e3:g} mm")
            print(f"  identical pair at the pitch point: {row['pair_stiffness_N_per_m']:.4e} N/m; neighbour coupling "
                  f"C[+1]/C[0] = {row['neighbour_coupling_ratio']:.3f}, C[-1]/C[0] = {row['neighbour_coupling_ratio_minus']:.3f}")
            print("  gauge strains at 300 N m, load at pitch point of tooth 0 (on tooth 0): "
                  + ", ".join(f"{k} {v * 1e6:.1f} ue" for k, v in row["gauge_strain_at_300Nm_pitch"].items()))
    base = rows[0]
    ratio = base["total_s"] / TARGET_S
    conv = {}
    if len(rows) > 1:
        c = [1 / r["tooth_stiffness_N_per_m_per_m"] for r in rows]
        conv = dict(compliance_change_x2=c[1] / c[0] - 1, compliance_change_x4=c[2] / c[1] - 1,
                    gauge_change_x2={k: rows[1]["gauge_strain_at_300Nm_pitch"][k] / v - 1
                                     for k, v in rows[0]["gauge_strain_at_300Nm_pitch"].items()},
                    gauge_change_x4={k: rows[2]["gauge_strain_at_300Nm_pitch"][k] / v - 1
                                     for k, v in rows[1]["gauge_strain_at_300Nm_pitch"].items()})
    if args.json:
        print(json.dumps(dict(rows=rows, convergence=conv, ratio=ratio, target_s=TARGET_S), indent=1))
    else:
        if conv:
            print(f"convergence: pitch compliance change x2 {conv['compliance_change_x2'] * 100:+.3f}%, "
                  f"x4 {conv['compliance_change_x4'] * 100:+.3f}%")
            print("  gauge change x2: " + ", ".join(f"{k} {v * 100:+.2f}%" for k, v in conv["gauge_change_x2"].items())
                  + "; x4: " + ", ".join(f"{k} {v * 100:+.2f}%" for k, v in conv["gauge_change_x4"].items()))
        print(f"ratio = total / {TARGET_S:g} s = {ratio:.3f} (<= 1 passes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
