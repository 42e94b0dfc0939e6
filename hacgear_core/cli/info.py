"""``hacgear info MODEL [--json]``: derived geometry of every gear and mesh.

Per mesh: centre distance, backlash (circular on the operating pitch circle and normal along the unloaded
flanks' line of action), base radii, operating pressure angles, contact ratios (loaded and
unloaded flank, face and total), base pitch, roll angles of SAP/LPSTC/HPSTC/EAP per gear (loaded
flank, degrees of tan(pressure angle)); per gear: profile shift, tool addendum, form and tip
radii, tip thickness, mass and inertias; per mesh also its phase in the train (mesh cycles, from the gear placement)
and its nominal load (the torque flow at the operating torque).  Warnings are printed after the tables (stderr for text,
a ``warnings`` list in JSON).  Every default the model file left to the reader (key, value, meaning) follows the
tables (``defaults_applied`` in JSON).
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys
from typing import Any

from hacgear_core.cli._commands import command_help
from hacgear_core.errors import GeometryError, ModelError
from hacgear_core.geometry import SIDES, model_geometry
from hacgear_core.geometry.gear import normal_thickness_at_radius_m
from hacgear_core.jsonio import json_safe
from hacgear_core.kinds import kind_of, load_model
from hacgear_core.model import iso21771 as _iso
from hacgear_core.statics import nominal_mesh_forces

__all__ = ["register", "run", "info_dict"]


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "info", help=command_help("info"),
        description="Derived gear geometry of a model (models/<system>/model.toml, its folder or a system name). "
                    "Text: tables with units. --json: SI values, unit in the key name.")
    p.add_argument("model", help="model file, folder or system name")
    p.add_argument("--json", action="store_true", help="print JSON (SI units, unit in the key name)")
    p.add_argument("--lenient", action="store_true",
                   help="report interference / contact ratio < 1 as warnings instead of errors")
    p.set_defaults(func=run)


def _iso_gear(gear: Any, g: Any) -> dict:
    """ISO 21771 terms of one gear (SI), normal and transverse, from its geometry ``g``
    (:class:`~hacgear_core.geometry.GearGeometry`) and, for a gear of the ISO form, the data it was given in
    (``gear.iso``).  ``profile_shift``: x in the normal section with ISO 21771's sign (an internal gear's x is positive
    towards its tooth tips); for the ISO form the given x, for the transverse form x from the tooth thickness;
    ``generating_profile_shift``: x from the modelled tooth thickness (the given x plus the mean thickness allowance
    / (2 m_n tan alpha_n))."""
    beta = abs(g.helix_angle_rad)
    cos_b = math.cos(beta)
    iso = getattr(gear, "iso", None)
    m_n = g.module_m * cos_b
    sign = -1.0 if g.internal else 1.0   # the geometry's internal x is the tool's displacement away from the axis
    x_gen = sign * g.profile_shift["drive"] / cos_b
    s_t = g.pitch_radius_m * float(g._form.thickness_angle(g.pitch_radius_m))
    out = {
        "form": "iso21771" if iso is not None else "transverse",
        "normal_module_m": m_n, "transverse_module_m": g.module_m,
        "normal_pressure_angle_deg": {s: math.degrees(math.atan(math.tan(g.pressure_angle_rad[s]) * cos_b))
                                      for s in SIDES},
        "transverse_pressure_angle_deg": {s: math.degrees(g.pressure_angle_rad[s]) for s in SIDES},
        "helix_angle_deg": math.degrees(beta),
        "hand": "" if beta == 0 else ("right" if g.helix_angle_rad > 0 else "left"),
        "reference_diameter_m": 2.0 * g.pitch_radius_m, "tip_diameter_m": 2.0 * g.tip_radius_m,
        "root_diameter_m": 2.0 * g.root_radius_m,
        "base_diameter_m": {s: 2.0 * g.base_radius_m[s] for s in SIDES},
        "profile_shift": x_gen if iso is None else iso.profile_shift,
        "generating_profile_shift": x_gen,
        "tip_alteration": None if iso is None else iso.tip_alteration,
        "tip_alteration_m": None if iso is None else iso.tip_alteration * iso.normal_module_m,
        "normal_tooth_thickness_m": s_t * cos_b, "transverse_tooth_thickness_m": s_t,
        "nominal_normal_tooth_thickness_m": None if iso is None else iso.nominal_normal_tooth_thickness_m,
        "thickness_allowance_upper_m": None if iso is None else iso.thickness_allowance_upper_m,
        "thickness_allowance_lower_m": None if iso is None else iso.thickness_allowance_lower_m,
        "tip_normal_thickness_m": normal_thickness_at_radius_m(g._form, g.helix_angle_rad, g.tip_radius_m),
        "basic_rack": None if iso is None else iso.basic_rack,
        "rack_addendum_coefficient": None if iso is None else iso.addendum_coefficient,
        "rack_dedendum_coefficient": None if iso is None else iso.dedendum_coefficient,
        "rack_root_radius_coefficient": None if iso is None else iso.root_radius_coefficient,
    }
    return out


def _iso_mesh(model: Any, mg: Any, iso_gears: dict) -> dict:
    """ISO 21771 terms of one mesh (SI): operating centre distance a_w and transverse pressure angle alpha_wt (from
    the geometry: cos(alpha_wt) = (r_b1 +- r_b2) / a_w), the sum of the profile shifts (ISO sign) and the centre distance
    it gives without backlash (inv(alpha_wt) = inv(alpha_t) + 2 tan(alpha_n) (x1 + x2) / (z1 + z2); symmetric teeth
    only), the contact ratios eps_alpha, eps_beta, eps_gamma and the circumferential backlash (modelled teeth, and its
    range over the thickness allowances)."""
    a, b = iso_gears[mg.gear_a], iso_gears[mg.gear_b]
    ga, gb = model.gear(mg.gear_a), model.gear(mg.gear_b)
    sum_x = a["profile_shift"] + b["profile_shift"]
    a_x = None
    alpha_n = {a["normal_pressure_angle_deg"][s] for s in SIDES} | {b["normal_pressure_angle_deg"][s] for s in SIDES}
    if len(alpha_n) == 1 and abs(a["normal_module_m"] - b["normal_module_m"]) <= 1e-12 * a["normal_module_m"]:
        a_x = _iso.working_center_distance(
            a["normal_module_m"], math.radians(alpha_n.pop()), math.radians(a["helix_angle_deg"]),
            _iso.mesh_tooth_count(ga.teeth, ga.internal), _iso.mesh_tooth_count(gb.teeth, gb.internal),
            a["profile_shift"], b["profile_shift"])
    lo, hi = mg.backlash_circular_range_m
    return {
        "center_distance_m": mg.center_distance_m,
        "operating_transverse_pressure_angle_deg": math.degrees(mg.operating_pressure_angle_rad),
        "sum_profile_shift": sum_x, "center_distance_from_profile_shifts_m": a_x,
        "transverse_contact_ratio": mg.contact_ratio, "overlap_ratio": mg.face_contact_ratio,
        "total_contact_ratio": mg.total_contact_ratio,
        "backlash_circular_m": mg.backlash_circular_m, "backlash_circular_min_m": lo, "backlash_circular_max_m": hi,
    }


def info_dict(model: Any, *, strict: bool = True) -> dict:
    """Everything ``hacgear info --json`` prints, as a dict (SI; NaN -> None)."""
    gears, meshes = model_geometry(model, strict=strict)
    try:
        train = kind_of(model).placement(model, gears, meshes)
    except (GeometryError, ModelError):
        train = None
    out: dict = {"model": model.name, "kind": model.kind, "gears": {}, "meshes": {}, "warnings": []}
    for g in gears.values():
        out["gears"][g.name] = {
            "teeth": g.z, "module_m": g.module_m, "internal": g.internal,
            "reference_radius_m": g.pitch_radius_m, "tip_radius_m": g.tip_radius_m, "root_radius_m": g.root_radius_m,
            "pressure_angle_deg": {s: math.degrees(g.pressure_angle_rad[s]) for s in SIDES},
            "base_radius_m": dict(g.base_radius_m), "profile_shift": g.profile_shift["drive"],
            "tool_addendum_m": g.hob_addendum_m, "tool_addendum_coefficient": g.hob_addendum_m / g.module_m,
            "tip_addendum_coefficient": g.tip_addendum_m / g.module_m,
            "form_radius_m": dict(g.form_radius_m),
            "tip_roll_angle_deg": {s: math.degrees(g.tip_roll_rad[s]) for s in SIDES},
            "undercut": dict(g.undercut), "tip_thickness_m": g.tip_thickness_m,
            "fillet_root_curvature_radius_m": dict(g.fillet_root_curvature_radius_m),
            "helix_angle_deg": math.degrees(g.helix_angle_rad), "lead_m": g.lead_m,
            "face_width_m": g.face_width_m, "bore_radius_m": g.bore_radius_m,
            "web": None if g.web is None else {"thickness_m": g.web.thickness_m, "inner_radius_m": g.web.inner_radius_m,
                                               "outer_radius_m": g.web.outer_radius_m},
            "mass_kg": g.mass_kg, "inertia_kgm2": g.inertia_kgm2, "diametral_inertia_kgm2": g.diametral_inertia_kgm2,
            "blank_mass_kg": g.blank_mass_kg, "blank_inertia_kgm2": g.blank_inertia_kgm2,
            "mass_source": "model" if model.gear(g.name).mass_kg is not None else "blank",
            "inertia_source": "model" if model.gear(g.name).inertia_kgm2 is not None else "blank",
            "shaper_teeth": g.shaper_teeth,
            "iso": _iso_gear(model.gear(g.name), g),
        }
    try:
        forces = nominal_mesh_forces(model, {m.name: (m.base_radius_m[m.gear_a], m.base_radius_m[m.gear_b])
                                             for m in meshes.values()})
    except ModelError:
        forces = {}
    for mg in meshes.values():
        out["meshes"][mg.name] = {
            "gear_a": mg.gear_a, "gear_b": mg.gear_b, "flank_a": mg.flank_a, "flank_b": mg.flank_b,
            "internal": mg.internal, "center_distance_m": mg.center_distance_m,
            "center_distance_source": mg.center_distance_source,
            "zero_backlash_center_distance_m": mg.zero_backlash_center_distance_m, "backlash_m": mg.backlash_m,
            "backlash_circular_m": mg.backlash_circular_m, "backlash_normal_m": mg.backlash_normal_m,
            "coast_position_offset": mg.coast_position_offset,
            "gear_ratio": mg.gear_ratio, "base_radius_m": dict(mg.base_radius_m),
            "base_radius_coast_m": dict(mg.base_radius_coast_m),
            "operating_pitch_radius_m": dict(mg.operating_pitch_radius_m),
            "operating_pressure_angle_deg": math.degrees(mg.operating_pressure_angle_rad),
            "operating_pressure_angle_coast_deg": math.degrees(mg.operating_pressure_angle_coast_rad),
            "base_pitch_m": mg.base_pitch_m, "contact_ratio": mg.contact_ratio,
            "contact_ratio_coast": mg.contact_ratio_coast, "face_contact_ratio": mg.face_contact_ratio,
            "total_contact_ratio": mg.total_contact_ratio, "path_of_contact_m": mg.line_of_action_length_m,
            "roll_angle_deg": {k: {g: mg.roll_angle_deg[g][k] for g in mg.roll_angle_deg}
                               for k in ("SAP", "LPSTC", "HPSTC", "EAP")},
            "roll_angle_coast_deg": {k: {g: mg.roll_angle_coast_deg[g].get(k, math.nan)
                                         for g in mg.roll_angle_coast_deg}
                                     for k in ("SAP", "LPSTC", "HPSTC", "EAP")},
            "tip_clearance_m": dict(mg.tip_clearance_m),
            "line_of_centres_deg": math.degrees(model.mesh(mg.name).line_of_centres_rad),
            "phase": None if train is None else train.meshes[mg.name].phase,
            "nominal_force_N": forces.get(mg.name),
            "nominal_torque_Nm": None if mg.name not in forces else forces[mg.name] * mg.base_radius_m[mg.gear_a],
            "iso": _iso_mesh(model, mg, {n: out["gears"][n]["iso"] for n in (mg.gear_a, mg.gear_b)}),
        }
    warns: list[str] = []
    for g in gears.values():
        warns += [w for w in g.warnings if w not in warns]
    for mg in meshes.values():
        warns += [w for w in mg.warnings if w not in warns]
    out["warnings"] = warns
    out["defaults_applied"] = [{"key": k, "value": v, "meaning": m} for k, v, m in model.defaults_applied]
    return json_safe(out)


def _f(v: Any, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def _text(d: dict) -> str:
    lines = [f"model {d['model']} ({d['kind']})", "", "Gears"]
    hdr = (f"  {'gear':<10}{'z':>5}{'m [mm]':>8}{'int':>5}{'d_a [mm]':>10}{'d_f [mm]':>10}{'x [-]':>9}"
           f"{'h_a0/m':>8}{'s_a [mm]':>9}{'d_b drive/coast [mm]':>22}{'d_Ff drive/coast [mm]':>23}"
           f"{'mass [kg]':>11}{'J [kg m^2]':>13}")
    lines.append(hdr)
    for n, g in d["gears"].items():
        lines.append(
            f"  {n:<10}{g['teeth']:>5}{g['module_m'] * 1e3:>8.3f}{('yes' if g['internal'] else 'no'):>5}"
            f"{2e3 * g['tip_radius_m']:>10.3f}{2e3 * g['root_radius_m']:>10.3f}{g['profile_shift']:>9.4f}"
            f"{g['tool_addendum_coefficient']:>8.3f}{g['tip_thickness_m'] * 1e3:>9.3f}"
            f"{2e3 * g['base_radius_m']['drive']:>11.3f}/{2e3 * g['base_radius_m']['coast']:<10.3f}"
            f"{2e3 * g['form_radius_m']['drive']:>12.3f}/{2e3 * g['form_radius_m']['coast']:<10.3f}"
            f"{g['mass_kg']:>11.4f}{g['inertia_kgm2']:>13.4e}"
            + ("" if g["mass_source"] == "blank" and g["inertia_source"] == "blank" else "  (model override)"))
    lines += ["", "Gears in ISO 21771 terms (x: normal, ISO sign; s_n: normal tooth thickness modelled; s_an: at the tip)"]
    lines.append(f"  {'gear':<10}{'form':>11}{'m_n [mm]':>10}{'a_n [deg]':>11}{'beta [deg]':>16}{'x [-]':>9}"
                 f"{'k m_n [mm]':>11}{'d [mm]':>11}{'d_a [mm]':>11}{'d_f [mm]':>11}{'d_b [mm]':>11}{'s_n [mm]':>10}"
                 f"{'s_an [mm]':>10}")
    for n, g in d["gears"].items():
        i = g["iso"]
        an = i["normal_pressure_angle_deg"]
        an_txt = f"{an['drive']:.4f}" if an["drive"] == an["coast"] else f"{an['drive']:.2f}/{an['coast']:.2f}"
        beta = f"{i['helix_angle_deg']:.4f} {i['hand']:<5}"
        lines.append(
            f"  {n:<10}{i['form']:>11}{i['normal_module_m'] * 1e3:>10.4f}{an_txt:>11}{beta:>16}"
            f"{i['profile_shift']:>9.4f}{_f(None if i['tip_alteration_m'] is None else i['tip_alteration_m'] * 1e3, '.4f'):>11}"
            f"{i['reference_diameter_m'] * 1e3:>11.4f}{i['tip_diameter_m'] * 1e3:>11.4f}{i['root_diameter_m'] * 1e3:>11.4f}"
            f"{i['base_diameter_m']['drive'] * 1e3:>11.4f}{i['normal_tooth_thickness_m'] * 1e3:>10.4f}"
            f"{i['tip_normal_thickness_m'] * 1e3:>10.4f}")
    lines += ["", "Meshes"]
    for n, m in d["meshes"].items():
        ga, gb = m["gear_a"], m["gear_b"]
        lines.append(f"  {n}: {ga} ({m['flank_a']}) -> {gb} ({m['flank_b']}){'  internal' if m['internal'] else ''}")
        lines.append(f"    centre distance        {m['center_distance_m'] * 1e3:10.4f} mm ({m['center_distance_source']}; "
                     f"zero backlash {m['zero_backlash_center_distance_m'] * 1e3:.4f} mm)")
        lines.append(f"    backlash               {m['backlash_circular_m'] * 1e6:10.1f} µm circular (operating pitch "
                     f"circle), {_f(None if m['backlash_normal_m'] is None else m['backlash_normal_m'] * 1e6, '.1f')}"
                     f" µm normal (unloaded flanks' line of action)")
        lines.append(f"    base radius            {ga}: {m['base_radius_m'][ga] * 1e3:.4f} mm, "
                     f"{gb}: {m['base_radius_m'][gb] * 1e3:.4f} mm (loaded flanks)")
        lines.append(f"    operating press. angle {m['operating_pressure_angle_deg']:10.4f} deg loaded, "
                     f"{_f(m['operating_pressure_angle_coast_deg'], '.4f')} deg unloaded")
        lines.append(f"    base pitch             {m['base_pitch_m'] * 1e3:10.4f} mm")
        lines.append(f"    contact ratio          {m['contact_ratio']:10.4f} loaded, "
                     f"{_f(m['contact_ratio_coast'], '.4f')} unloaded flank, face {m['face_contact_ratio']:.4f}, "
                     f"total {m['total_contact_ratio']:.4f}")
        lines.append(f"    roll angles [deg]      {'SAP':>8}{'LPSTC':>9}{'HPSTC':>9}{'EAP':>9}   (loaded flank)")
        for g in (ga, gb):
            r = m["roll_angle_deg"]
            lines.append(f"      {g:<20} " + "".join(f"{_f(r[k][g], '9.3f'):>9}" for k in ("SAP", "LPSTC", "HPSTC", "EAP")))
        i = m["iso"]
        rng = ""
        if i["backlash_circular_min_m"] is not None and i["backlash_circular_min_m"] != i["backlash_circular_max_m"]:
            rng = (f" ({i['backlash_circular_min_m'] * 1e6:.1f} .. {i['backlash_circular_max_m'] * 1e6:.1f} µm over the "
                   "thickness allowances)")
        a_x = i["center_distance_from_profile_shifts_m"]
        lines.append(f"    ISO 21771              a_w {i['center_distance_m'] * 1e3:.4f} mm, alpha_wt "
                     f"{i['operating_transverse_pressure_angle_deg']:.6f} deg, sum x {i['sum_profile_shift']:.4f}"
                     + ("" if a_x is None else f" (a_w from sum x: {a_x * 1e3:.4f} mm)"))
        lines.append(f"                           eps_alpha {i['transverse_contact_ratio']:.4f}, eps_beta "
                     f"{i['overlap_ratio']:.4f}, eps_gamma {i['total_contact_ratio']:.4f}, backlash j_t "
                     f"{i['backlash_circular_m'] * 1e6:.1f} µm{rng}")
        lines.append("    tip clearance          " + ", ".join(f"{g}: {v * 1e3:.4f} mm" for g, v in m["tip_clearance_m"].items()))
        if m["phase"] is not None:
            lines.append(f"    mesh phase             {m['phase']:10.4f} mesh cycles (line of centres "
                         f"{m['line_of_centres_deg']:.1f} deg; first mesh at 0)")
        if m["nominal_force_N"] is not None:
            lines.append(f"    nominal load           {m['nominal_force_N']:10.1f} N ({m['nominal_torque_Nm']:.1f} N·m on "
                         f"{ga}) at the operating torque")
    if d.get("defaults_applied"):
        lines += ["", "Defaults applied (keys absent from the model file; list in README 'Model files')"]
        groups: dict = {}
        for r in d["defaults_applied"]:
            m = re.match(r"(gears\[\d+\]) \((.*?)\)\.(.*)", r["key"])
            key, who = (m.group(3), m.group(2)) if m else (r["key"], "")
            groups.setdefault((key, r["value"], r["meaning"]), []).append(who)
        for (key, value, meaning), who in groups.items():
            whom = f"  [{', '.join(w for w in who if w)}]" if any(who) else ""
            lines.append(f"  {key} = {value}" + (f"  ({meaning})" if meaning else "") + whom)
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    model = load_model(args.model)
    d = info_dict(model, strict=not args.lenient)
    if args.json:
        print(json.dumps(d, indent=2, allow_nan=False))
    else:
        print(_text(d))
        for w in d["warnings"]:
            print(f"warning: {w}", file=sys.stderr)
    return 0
