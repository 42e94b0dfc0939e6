"""Geometry of one tooth mesh: centre distance, backlash, line of action, contact ratios, roll angles (SI)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from hacgear_core.errors import GeometryError

from hacgear_core.geometry.gear import GearGeometry, gear_geometry
from hacgear_core.geometry.tooth import zero_backlash_center_distance
from hacgear_core.model import iso21771 as _iso

__all__ = ["MeshGeometry", "mesh_backlash", "mesh_geometry", "model_geometry", "zero_backlash_center_distance"]

@dataclass(frozen=True, eq=False)
class MeshGeometry:
    """Derived geometry of one tooth mesh (SI).  Per-gear dicts are keyed by gear name.

    The line of action (loaded flank) is parametrised by ``xi`` [m], the distance from gear a's base
    tangent point; ``contact_start_m``/``contact_end_m`` bound the active path of contact.

    Backlash (:func:`mesh_backlash`): ``backlash_circular_m`` ``j_t = p_w - s_wa - s_wb`` on the operating
    pitch circle (``s_w`` the tooth thickness there, each flank's own involute), ``backlash_normal_m``
    ``j_n = j_t cos(alpha_w,unloaded)`` along the line of action of the unloaded ("coast") flanks: the rigid
    approach of those flanks from the loaded-flank kinematic position (loaded flanks touching) to their
    contact.  ``coast_position_offset`` [mesh cycles]: the unloaded flanks' own mesh position is
    ``coast_position_offset - tau`` at loaded-flank mesh position ``tau`` (``docs/tables.md``, coast side).
    ``backlash_m`` is ``backlash_circular_m``.  ``backlash_circular_range_m``: ``j_t`` at the thickest and the
    thinnest teeth the ISO-form gears' thickness allowances admit (upper, lower allowance; the modelled teeth sit
    at the mean; transverse-form gears: both equal ``backlash_circular_m``).
    """

    name: str
    gear_a: str
    gear_b: str
    internal: bool
    flank_a: str
    flank_b: str
    center_distance_m: float
    center_distance_source: str
    zero_backlash_center_distance_m: float
    backlash_circular_m: float
    backlash_normal_m: float
    coast_position_offset: float
    gear_ratio: float
    operating_pitch_radius_m: Mapping[str, float]
    base_radius_m: Mapping[str, float]
    base_radius_coast_m: Mapping[str, float]
    operating_pressure_angle_rad: float
    operating_pressure_angle_coast_rad: float
    base_pitch_m: float
    base_pitch_coast_m: float
    contact_ratio: float
    contact_ratio_coast: float
    face_width_overlap_m: float
    face_contact_ratio: float
    total_contact_ratio: float
    roll_angle_deg: Mapping[str, Mapping[str, float]]
    roll_angle_coast_deg: Mapping[str, Mapping[str, float]]
    line_of_action_length_m: float
    tangent_length_m: float
    contact_start_m: float
    contact_end_m: float
    tip_clearance_m: Mapping[str, float]
    warnings: tuple[str, ...]
    _aff: Mapping[str, tuple] = field(default_factory=dict, repr=False, compare=False)
    backlash_circular_range_m: tuple[float, float] = (math.nan, math.nan)

    @property
    def backlash_m(self) -> float:
        """Circumferential backlash on the operating pitch circle [m] (= ``backlash_circular_m``)."""
        return self.backlash_circular_m

    def roll_angle_rad_at(self, gear: str, xi_m: Any) -> Any:
        """Roll angle [rad] of gear ``gear`` (loaded flank) at line-of-action position ``xi_m`` [m]
        (distance from gear a's base tangent point)."""
        c, d, rb = self._aff[gear]
        return (c + d * np.asarray(xi_m, dtype=float)) / rb


def _other(side: str) -> str:
    return "coast" if side == "drive" else "drive"


def _tip_fix(mate: GearGeometry, mate_iso: Any, aff: Mapping[str, tuple], g: GearGeometry, g_iso: Any,
             l_target: float, fillet: bool) -> str:
    """``; fix: ...`` naming the tip alteration of the ISO-form gear ``mate`` whose tip circle would meet the flank of
    ``g`` at roll length ``l_target`` [m] (its involute form point), or ``""`` for a gear of the transverse form.
    ``g_iso``: ``g``'s ISO data or ``None``.  ``fillet``: the contact reaches into ``g``'s root fillet, so the fix
    also names ``g``'s rack (or hob tip radius): a smaller root radius or a deeper dedendum lowers its form point.
    A larger profile shift of ``g`` is not named: it raises the form point about as far as the contact start."""
    if mate_iso is None:
        return ""
    c, d, _ = aff[g.name]
    cm, dm, rbm = aff[mate.name]
    l_m = cm + dm * (l_target - c) / d          # the mate's roll length where g's flank starts
    d_a = 2.0 * math.sqrt(rbm * rbm + l_m * l_m)
    k = _iso.tip_alteration(mate_iso.teeth, mate_iso.normal_module_m, mate_iso.helix_angle_rad,
                            mate_iso.addendum_coefficient, mate_iso.profile_shift, d_a, mate_iso.internal)
    rel = ">=" if mate.internal else "<="
    return (f"; fix: tip_alteration_mm of '{mate.name}' <= {k * mate_iso.normal_module_m * 1e3:.6f} (tip_diameter_mm "
            f"{rel} {d_a * 1e3:.6f}; now {mate_iso.tip_alteration * mate_iso.normal_module_m * 1e3:.6f} mm, "
            f"{2e3 * mate.tip_radius_m:.6f} mm)"
            + ("" if not fillet else
               f", or a smaller rack_root_radius_coefficient / larger rack_dedendum_coefficient of '{g.name}'"
               if g_iso is not None else f", or a smaller hob_tip_radius_mm of '{g.name}'"))


def _line_of_action(ga: GearGeometry, gb: GearGeometry, sa: str, sb: str, a: float, name: str,
                    strict: bool, warnings: list[str], isos: Mapping[str, Any] | None = None) -> dict:
    """Contact geometry along the line of action of flanks sa (gear a) / sb (gear b); ``isos``: the ISO data
    (``Gear.iso``) by gear name, so that an interference of ISO-form gears names the tip alteration that removes it."""
    isos = isos or {}
    internal = ga.internal or gb.internal
    rba, rbb = ga.base_radius_m[sa], gb.base_radius_m[sb]
    if not internal:
        cos_w = (rba + rbb) / a
    else:
        cos_w = abs(rbb - rba) / a
    if cos_w >= 1:
        raise GeometryError(f"mesh '{name}': centre distance {a * 1e3:.4f} mm too small for base radii "
                            f"{rba * 1e3:.4f}/{rbb * 1e3:.4f} mm ({sa}/{sb} flanks)")
    aw = math.acos(cos_w)
    tw = math.tan(aw)
    # affine maps xi -> roll length of each gear; xi = distance from gear a's base tangent point
    if not internal:
        L = a * math.sin(aw)
        aff = {ga.name: (0.0, 1.0, rba), gb.name: (L, -1.0, rbb)}
    elif gb.internal:
        L = (rbb - rba) * tw
        aff = {ga.name: (0.0, 1.0, rba), gb.name: (L, 1.0, rbb)}
    else:  # gear a internal, b external pinion: xi measured from the ring's tangent point
        L = (rba - rbb) * tw
        aff = {ga.name: (0.0, 1.0, rba), gb.name: (-L, 1.0, rbb)}
    lo, hi = -math.inf, math.inf
    for g, s in ((ga, sa), (gb, sb)):
        c, d, rb = aff[g.name]
        l_tip = rb * g.involute_end_roll_rad[s]
        # external: roll length <= l_tip ; internal: roll length >= l_tip
        bound = (l_tip - c) / d
        if (not g.internal) == (d > 0):
            hi = min(hi, bound)
        else:
            lo = max(lo, bound)
    if not lo < hi:
        raise GeometryError(f"mesh '{name}' ({sa}/{sb} flanks): the tip circles do not overlap on the line of action "
                            "(no contact)")
    pb = 2 * math.pi * rba / ga.z
    eps = (hi - lo) / pb
    # interference: each gear's active roll range inside [form, tip] and outside the base circle
    for g, s in ((ga, sa), (gb, sb)):
        c, d, rb = aff[g.name]
        l1, l2 = sorted((c + d * lo, c + d * hi))
        l_form = rb * g.form_roll_rad[s]
        mate = gb.name if g is ga else ga.name
        mg_ = gb if g is ga else ga
        if l1 < -1e-9:
            msg = (f"mesh '{name}': involute interference, the tip of '{mate}' reaches inside the base circle of "
                   f"'{g.name}' ({s} flank, {-l1 * 1e3:.4f} mm beyond the tangent point of the line of action)"
                   + _tip_fix(mg_, isos.get(mate), aff, g, isos.get(g.name), max(l_form, 0.0), False))
            if strict:
                raise GeometryError(msg)
            warnings.append(msg)
        if not g.internal and l1 < l_form - 1e-6:
            r_sap = rb * math.sqrt(1 + (max(l1, 0) / rb) ** 2)
            msg = (f"mesh '{name}': tip-fillet interference, the tip of '{mate}' reaches below the true involute form "
                   f"diameter of '{g.name}' ({s} flank): contact diameter {2e3 * r_sap:.4f} mm < form diameter "
                   f"{2e3 * g.form_radius_m[s]:.4f} mm"
                   + _tip_fix(mg_, isos.get(mate), aff, g, isos.get(g.name), l_form, True))
            if strict:
                raise GeometryError(msg)
            warnings.append(msg)
        if g.internal and l2 > l_form + 1e-6:
            msg = (f"mesh '{name}': the tip of '{mate}' reaches beyond the involute form diameter of the internal gear "
                   f"'{g.name}' ({s} flank) into its root fillet"
                   + _tip_fix(mg_, isos.get(mate), aff, g, isos.get(g.name), l_form, True))
            if strict:
                raise GeometryError(msg)
            warnings.append(msg)
    roll = {}
    for g, s in ((ga, sa), (gb, sb)):
        c, d, rb = aff[g.name]
        l1, l2 = sorted((c + d * lo, c + d * hi))  # roll length range on this gear
        if not g.internal:  # root at small roll
            sap, eap, lp, hp = l1, l2, l2 - pb, l1 + pb
        else:  # internal: root at large roll
            sap, eap, lp, hp = l2, l1, l1 + pb, l2 - pb
        if eps < 1:
            lp = hp = math.nan
        roll[g.name] = {k: math.degrees(v / rb) for k, v in (("SAP", sap), ("LPSTC", lp), ("HPSTC", hp), ("EAP", eap))}
    return dict(aw=aw, L=L, lo=lo, hi=hi, pb=pb, eps=eps, roll=roll, aff=aff)


def mesh_backlash(ga: GearGeometry, gb: GearGeometry, r_wa: float, r_wb: float,
                  cos_alpha_w_unloaded: float) -> tuple[float, float, float]:
    """Backlash of a mesh from the tooth thicknesses on the operating pitch circles.

    ``s_w = r_w Theta(r_w)`` is each gear's tooth thickness at its operating pitch radius ``r_w``, with
    ``Theta`` the angular thickness from both flanks' own involutes (asymmetric teeth: each flank's
    polar half-angle, :meth:`~hacgear_core.geometry.tooth._ToothForm.thickness_angle`); ``p_w = 2 pi r_wa / z_a``.

    Returns
    -------
    (j_t, j_n, c0)
        circumferential backlash ``j_t = p_w - s_wa - s_wb`` [m], normal backlash ``j_n = j_t cos(alpha_w)``
        along the line of action of the unloaded flanks [m] (the rigid approach that closes them from the
        loaded flanks' kinematic position), and the unloaded flanks' mesh-position offset
        ``c0 = (s_wa - s_wb - p_w) / (2 p_w)`` [mesh cycles]: at loaded-flank mesh position ``tau`` (integer =
        a loaded pair at the pitch point) the unloaded pair numbered 0 of the opposite-side contact solver is
        at its own position ``c0 - tau`` (``docs/tables.md``, coast side).
    """
    p_w = 2 * math.pi * r_wa / ga.z
    s_a = r_wa * float(ga._form.thickness_angle(r_wa))
    s_b = r_wb * float(gb._form.thickness_angle(r_wb))
    j_t = p_w - s_a - s_b
    return j_t, j_t * cos_alpha_w_unloaded, (s_a - s_b - p_w) / (2 * p_w)


def _iso_pair(model: Any, mesh: Any) -> tuple[Any, Any] | None:
    """The ISO data (:class:`~hacgear_core.model.schema.IsoGear`) of both gears of ``mesh``, or None when either
    gear was given in the transverse form."""
    ia = getattr(model.gear(mesh.gear_a), "iso", None)
    ib = getattr(model.gear(mesh.gear_b), "iso", None)
    return None if ia is None or ib is None else (ia, ib)


def _iso_center_distance(ia: Any, ib: Any) -> float:
    """ISO 21771 a_w [m] of two ISO-form gears from their profile shifts (inv(alpha_wt) = inv(alpha_t) + 2 tan(alpha_n)
    (x1 + x2) / (z1 + z2), signed tooth counts): the centre distance at which the nominal teeth mesh without
    backlash."""
    return _iso.working_center_distance(ia.normal_module_m, ia.normal_pressure_angle_rad, ia.helix_angle_rad,
                                        ia.mesh_teeth, ib.mesh_teeth, ia.profile_shift, ib.profile_shift)


def _thickness_to_backlash(ga: GearGeometry, r_wa: float, model: Any, mesh: Any) -> float:
    """d j_t / d (s_n,a + s_n,b) [-]: the change of the circumferential backlash on the operating pitch circle per unit
    increase of the two gears' normal tooth thicknesses on their reference cylinders (``-(r_w / r) / cos(beta)``,
    the same ratio ``r_w / r`` for both gears of a mesh)."""
    cos_beta = math.cos(model.gear(mesh.gear_a).helix_angle_rad)
    return -(r_wa / ga.pitch_radius_m) / cos_beta


def _backlash_fix(model: Any, mesh: Any, ga: GearGeometry, r_wa: float, j_t: float, a0: float | None) -> str:
    """What would make a mesh with negative backlash ``j_t`` [m] mesh: thinner teeth (ISO form: the sum of the
    upper thickness allowances; transverse form: the tooth thicknesses) or a larger centre distance (``a0`` [m], the
    zero-backlash one, where known)."""
    ds_n = -j_t / _thickness_to_backlash(ga, r_wa, model, mesh)   # < 0: the change of the normal thickness sum
    planetary = getattr(model, "planetary", None) is not None and mesh.center_distance_m is None
    cd = f"{'carrier_radius_mm' if planetary else 'center_distance_mm'} >= " + (
        f"{a0 * 1e3:.6f} mm (zero backlash)" if a0 is not None else "a larger value")
    pair = _iso_pair(model, mesh)
    if pair is not None:
        ia, ib = pair
        cur = ia.thickness_allowance_upper_m + ib.thickness_allowance_upper_m
        return (f"fix: thickness_allowance_upper_mm of '{mesh.gear_a}' + '{mesh.gear_b}' <= {(cur + ds_n) * 1e3:.6f} mm "
                f"(now {cur * 1e3:.6f} mm; e.g. thickness_allowance_upper_mm = "
                f"{(ia.thickness_allowance_upper_m + ds_n) * 1e3:.6f} on '{mesh.gear_a}' and its lower allowance at "
                f"most that), or {cd}")
    cos_beta = math.cos(model.gear(mesh.gear_a).helix_angle_rad)
    return (f"fix: tooth_thickness_mm of '{mesh.gear_a}' + '{mesh.gear_b}' thinner by {-ds_n / cos_beta * 1e3:.6f} mm "
            f"(transverse, reference circle), or {cd}")


def _standard_pitch_radii(ga: GearGeometry, gb: GearGeometry, a: float) -> tuple[float, float]:
    if ga.internal or gb.internal:
        k = a / abs(gb.z - ga.z)
    else:
        k = a / (ga.z + gb.z)
    return k * ga.z, k * gb.z


def _in_file(model: Any, exc: GeometryError) -> GeometryError:
    """``exc`` with the model file's path in front (a geometry error of a model names its file)."""
    path = getattr(model, "path", None)
    if path is None or str(exc).startswith(str(path)):
        return exc
    return GeometryError(f"{path}: {exc}")


def mesh_geometry(model: Any, mesh_name: str | None = None, *, gears: Mapping[str, GearGeometry] | None = None,
                  strict: bool = True) -> MeshGeometry:
    """Derived geometry of mesh ``mesh_name`` (None: the first) of ``model``; :func:`_mesh_geometry`, its
    :class:`GeometryError` naming the model file."""
    try:
        return _mesh_geometry(model, mesh_name, gears=gears, strict=strict)
    except GeometryError as exc:
        raise _in_file(model, exc) from None


def _mesh_geometry(model: Any, mesh_name: str | None = None, *, gears: Mapping[str, GearGeometry] | None = None,
                   strict: bool = True) -> MeshGeometry:
    """Derived geometry of mesh ``mesh_name`` (None: the first) of ``model``.

    Centre distance: the mesh's ``center_distance_m``; else, for planetary sets, the carrier radius
    (``planetary.carrier_radius_m``); else the zero-backlash centre distance (both flanks touching)
    from the tooth thicknesses; for a planetary set without either, the standard centre distance
    clamped into [zero-backlash external mesh, zero-backlash internal mesh].

    ``strict``: interference and a loaded-flank contact ratio below 1 (total, for helical gears)
    raise :class:`GeometryError`; with ``strict=False`` they become warnings.
    """
    mesh = model.mesh(mesh_name)
    if gears is None:
        gears = {}
    ga = gears.get(mesh.gear_a) or gear_geometry(model.gear(mesh.gear_a))
    gb = gears.get(mesh.gear_b) or gear_geometry(model.gear(mesh.gear_b))
    warnings: list[str] = []
    internal = ga.internal or gb.internal
    a0 = zero_backlash_center_distance(ga._form, gb._form)
    src = "model"
    if mesh.center_distance_m is not None:
        a = float(mesh.center_distance_m)
        planetary = getattr(model, "planetary", None)
        if planetary is not None and planetary.carrier_radius_m is not None and \
                abs(planetary.carrier_radius_m - a) > 1e-9:
            warnings.append(f"mesh '{mesh.name}': center_distance {a * 1e3:.4f} mm differs from the carrier radius "
                            f"{planetary.carrier_radius_m * 1e3:.4f} mm")
    elif getattr(model, "planetary", None) is not None and model.planetary.carrier_radius_m is not None:
        a = float(model.planetary.carrier_radius_m)
        src = "carrier radius"
    elif getattr(model, "planetary", None) is not None:
        ext, inn = [], []
        for m2 in model.meshes:
            g1, g2 = gear_geometry(model.gear(m2.gear_a)), gear_geometry(model.gear(m2.gear_b))
            (inn if (g1.internal or g2.internal) else ext).append(zero_backlash_center_distance(g1._form, g2._form))
        lo_a, hi_a = max(ext) if ext else 0.0, min(inn) if inn else math.inf
        if lo_a > hi_a:
            raise GeometryError(f"planetary: no common centre distance: sun-planet needs >= {lo_a * 1e3:.4f} mm, "
                                f"ring-planet <= {hi_a * 1e3:.4f} mm; give carrier_radius_mm")
        a_std = 0.5 * ga.module_m * (abs(gb.z - ga.z) if internal else ga.z + gb.z)
        a = min(max(a_std, lo_a), hi_a)
        src = "planetary: standard clamped to zero-backlash limits"
    elif _iso_pair(model, mesh) is not None:
        a = _iso_center_distance(*_iso_pair(model, mesh))
        src = "ISO 21771 a_w from the profile shifts"
    else:
        a = a0
        src = "zero backlash"
    r_wa, r_wb = _standard_pitch_radii(ga, gb, a)
    sa, sb = mesh.flank_a, mesh.flank_b
    # backlash on the operating pitch circle (circumferential), of the modelled teeth and, for ISO-form gears, of the
    # thickest and thinnest teeth their thickness allowances admit (j_t is linear in the reference thicknesses)
    backlash, _, _ = mesh_backlash(ga, gb, r_wa, r_wb, 1.0)
    j_range = (backlash, backlash)
    pair = _iso_pair(model, mesh)
    up = 0.0
    if pair is not None:
        dj = _thickness_to_backlash(ga, r_wa, model, mesh)
        up = sum(i.thickness_allowance_upper_m - i.thickness_allowance_mean_m for i in pair)
        lo = sum(i.thickness_allowance_lower_m - i.thickness_allowance_mean_m for i in pair)
        j_range = (backlash + dj * up, backlash + dj * lo)
    if j_range[0] < -1e-7:
        at = "" if up == 0.0 else f" at the upper thickness allowances (modelled mean: {backlash * 1e6:.2f} um)"
        raise GeometryError(f"mesh '{mesh.name}': negative backlash {j_range[0] * 1e6:.2f} um{at} at centre distance "
                            f"{a * 1e3:.4f} mm (zero-backlash centre distance {a0 * 1e3:.4f} mm): the teeth of "
                            f"'{ga.name}' and '{gb.name}' overlap; "
                            + _backlash_fix(model, mesh, ga, r_wa, j_range[0], a0 if up == 0.0 else None))
    isos = {g.name: getattr(model.gear(g.name), "iso", None) for g in (ga, gb)}
    loaded = _line_of_action(ga, gb, sa, sb, a, mesh.name, strict, warnings, isos)
    try:
        coast = _line_of_action(ga, gb, _other(sa), _other(sb), a, mesh.name, False, warnings, isos)
        if abs(ga.base_radius_m[_other(sa)] / ga.z - gb.base_radius_m[_other(sb)] / gb.z) > 1e-9 * ga.pitch_radius_m:
            warnings.append(f"mesh '{mesh.name}': the unloaded flanks have different base pitches (pressure angles "
                            "differ); coast contact ratio is approximate")
    except GeometryError as exc:
        warnings.append(f"mesh '{mesh.name}' unloaded flanks: {exc}")
        coast = dict(aw=math.nan, eps=math.nan, pb=math.nan, roll={ga.name: {}, gb.name: {}})
    _, backlash_n, c0 = mesh_backlash(ga, gb, r_wa, r_wb, math.cos(coast["aw"]))
    # helical overlap
    beta = ga.helix_angle_rad
    za0, za1 = ga.axial_position_m - ga.face_width_m / 2, ga.axial_position_m + ga.face_width_m / 2
    zb0, zb1 = gb.axial_position_m - gb.face_width_m / 2, gb.axial_position_m + gb.face_width_m / 2
    overlap = max(0.0, min(za1, zb1) - max(za0, zb0))
    if overlap <= 0:
        raise GeometryError(f"mesh '{mesh.name}': the face widths do not overlap axially")
    eps_b = overlap * abs(math.tan(beta)) / (math.pi * ga.module_m)
    eps = loaded["eps"]
    total = eps + eps_b
    if total < 1:
        msg = (f"mesh '{mesh.name}': contact ratio {total:.3f} < 1 on the loaded flanks: the load cannot pass "
               "continuously from tooth to tooth")
        if strict:
            raise GeometryError(msg)
        warnings.append(msg)
    elif eps < 1:
        warnings.append(f"mesh '{mesh.name}': transverse contact ratio {eps:.3f} < 1 (face overlap {eps_b:.3f} makes "
                        "the total >= 1)")
    if math.isfinite(coast["eps"]) and coast["eps"] + eps_b < 1:
        warnings.append(f"mesh '{mesh.name}': contact ratio of the unloaded flanks {coast['eps']:.3f} < 1")
    # tip clearances
    clear = {}
    if not internal:
        clear[ga.name] = a - ga.tip_radius_m - gb.root_radius_m
        clear[gb.name] = a - gb.tip_radius_m - ga.root_radius_m
    else:
        ring, pin = (ga, gb) if ga.internal else (gb, ga)
        clear[pin.name] = ring.root_radius_m - (a + pin.tip_radius_m)
        clear[ring.name] = (ring.tip_radius_m - a) - pin.root_radius_m
    for g, c in clear.items():
        if c < 0:
            raise GeometryError(f"mesh '{mesh.name}': the tip of '{g}' hits the root of its mate (clearance "
                                f"{c * 1e3:.4f} mm)")
        if c < 0.1 * ga.module_m:
            warnings.append(f"mesh '{mesh.name}': small tip clearance of '{g}': {c * 1e3:.4f} mm < 0.1 m")
    for g in (ga, gb):
        warnings.extend(w for w in g.warnings if w not in warnings)
    mg = MeshGeometry(
        name=mesh.name, gear_a=ga.name, gear_b=gb.name, internal=internal, flank_a=sa, flank_b=sb,
        center_distance_m=a, center_distance_source=src, zero_backlash_center_distance_m=a0,
        backlash_circular_m=backlash, backlash_normal_m=backlash_n, coast_position_offset=c0,
        gear_ratio=gb.z / ga.z, operating_pitch_radius_m={ga.name: r_wa, gb.name: r_wb},
        base_radius_m={ga.name: ga.base_radius_m[sa], gb.name: gb.base_radius_m[sb]},
        base_radius_coast_m={ga.name: ga.base_radius_m[_other(sa)], gb.name: gb.base_radius_m[_other(sb)]},
        operating_pressure_angle_rad=loaded["aw"], operating_pressure_angle_coast_rad=coast["aw"],
        base_pitch_m=loaded["pb"], base_pitch_coast_m=coast["pb"], contact_ratio=eps,
        contact_ratio_coast=coast["eps"], face_width_overlap_m=overlap, face_contact_ratio=eps_b,
        total_contact_ratio=total, roll_angle_deg=loaded["roll"], roll_angle_coast_deg=coast["roll"],
        line_of_action_length_m=loaded["hi"] - loaded["lo"], tangent_length_m=loaded["L"],
        contact_start_m=loaded["lo"], contact_end_m=loaded["hi"], tip_clearance_m=clear, warnings=tuple(warnings),
        _aff=loaded["aff"], backlash_circular_range_m=j_range)
    return mg


def model_geometry(model: Any, *, strict: bool = True) -> tuple[dict[str, GearGeometry], dict[str, MeshGeometry]]:
    """Geometry of every gear and every mesh of a model: ``(gears, meshes)`` dicts keyed by name."""
    try:
        gears = {g.name: gear_geometry(g) for g in model.gears}
    except GeometryError as exc:
        raise _in_file(model, exc) from None
    meshes = {m.name: mesh_geometry(model, m.name, gears=gears, strict=strict) for m in model.meshes}
    return gears, meshes
