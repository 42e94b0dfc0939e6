"""Geometry of one gear: its flanks, blank (solid or webbed), tip and form circles, mass and inertia (SI).

Frames (see :mod:`hacgear_core.geometry.tooth`): gear frame origin at the gear centre, tooth ``k`` centred at
polar angle ``2 pi k / z``; the "drive" flank of tooth 0 at positive polar angles, "coast" at negative ones.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import numpy as np

from hacgear_core.errors import GeometryError, ModelError

from hacgear_core.geometry.tooth import (
    _brentq, REGION_FILLET, REGION_INVOLUTE, REGION_ROOT_LAND, REGION_TIP_LAND, REGION_TIP_ROUNDING, SHAPER_TEETH, SIDES,
    _FILLET_DENSE, Boundary, FlankProfile, _build_flank, _check_side, _Flank, _involute_local, _jay, _max_tool_tip_radius,
    _rot, _ToothForm, fillet_root_curvature_radius_rack, fillet_root_curvature_radius_shaper,
)

__all__ = ["WebGeometry", "GearGeometry", "gear_geometry"]

@dataclass(frozen=True)
class WebGeometry:
    """Web of a webbed blank (SI), as the finite-element model sees it.

    ``inner_radius_m``: hub outer radius (web starts); ``outer_radius_m``: rim inner radius (web ends);
    ``thickness_m``: axial web thickness; ``relative_thickness``: ``thickness_m / face_width_m`` in (0, 1],
    the factor on the plane stiffness of the web region (the plane model works per unit face width).
    """

    thickness_m: float
    inner_radius_m: float
    outer_radius_m: float
    relative_thickness: float

    def __post_init__(self) -> None:
        if not 0.0 < self.inner_radius_m < self.outer_radius_m:
            raise GeometryError(f"web radii must satisfy 0 < inner_radius_m < outer_radius_m, got "
                                f"{self.inner_radius_m!r}, {self.outer_radius_m!r} m")
        if not 0.0 < self.relative_thickness <= 1.0:
            raise GeometryError(f"web relative_thickness must lie in (0, 1], got {self.relative_thickness!r}")
        if not self.thickness_m > 0.0:
            raise GeometryError(f"web thickness_m must be > 0 m, got {self.thickness_m!r}")


@dataclass(frozen=True, eq=False)
class GearGeometry:
    """Geometry of one gear, built by :func:`gear_geometry`.  See the module docstring for frames."""

    name: str
    z: int
    module_m: float
    pitch_radius_m: float
    tip_radius_m: float
    root_radius_m: float
    internal: bool
    face_width_m: float
    helix_angle_rad: float
    axial_position_m: float
    lead_crowning_m: float
    tip_edge_radius_m: float
    hob_tip_radius_m: float
    pressure_angle_rad: Mapping[str, float]
    base_radius_m: Mapping[str, float]
    profile_shift: Mapping[str, float]
    hob_addendum_m: float
    tip_addendum_m: float
    form_radius_m: Mapping[str, float]
    form_roll_rad: Mapping[str, float]
    tip_roll_rad: Mapping[str, float]
    involute_end_roll_rad: Mapping[str, float]
    undercut: Mapping[str, bool]
    fillet_root_curvature_radius_m: Mapping[str, float]
    tip_thickness_m: float
    bore_radius_m: float
    mass_kg: float
    inertia_kgm2: float
    diametral_inertia_kgm2: float
    blank_mass_kg: float
    blank_inertia_kgm2: float
    teeth_area_m2: float
    shaper_teeth: int | None
    warnings: tuple[str, ...]
    density_kg_per_m3: float
    sector_offset_rad: float
    web: WebGeometry | None
    _form: _ToothForm = field(repr=False, compare=False)
    _flanks: Mapping[str, _Flank] = field(repr=False, compare=False)
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    # -- derived scalars ---------------------------------------------------------------------
    @property
    def reference_radius_m(self) -> float:
        return self.pitch_radius_m

    @property
    def lead_m(self) -> float:
        """Lead of the helix [m] (inf for spur gears)."""
        t = math.tan(self.helix_angle_rad)
        return math.inf if t == 0 else 2 * math.pi * self.pitch_radius_m / abs(t)

    @property
    def base_helix_angle_rad(self) -> Mapping[str, float]:
        return {s: math.atan(math.tan(self.helix_angle_rad) * math.cos(self.pressure_angle_rad[s])) for s in SIDES}

    def section_rotation_rad(self, z_axial_m: Any) -> Any:
        """Rotation [rad] of the transverse section at axial coordinate ``z_axial_m`` (from the mid-face
        plane of this gear): ``z tan(beta) / r``."""
        return np.asarray(z_axial_m, dtype=float) * math.tan(self.helix_angle_rad) / self.pitch_radius_m

    def thickness_at_radius_m(self, R: Any) -> Any:
        """Circular (arc) tooth thickness of the involute tooth at radius R [m] (unmodified)."""
        R = np.asarray(R, dtype=float)
        return R * self._form.thickness_angle(R)

    # -- involute ----------------------------------------------------------------------------
    def _local_involute(self, fl: _Flank, u: np.ndarray):
        return _involute_local(self.internal, fl.rb, fl.theta0, u)

    @staticmethod
    def _to_gear(side: str, X: Any, Y: Any) -> np.ndarray:
        X = np.asarray(X, dtype=float)
        Y = np.asarray(Y, dtype=float)
        return np.stack([Y, X if side == "drive" else -X], axis=-1)

    def involute_point(self, side: str, roll_angle_rad: Any):
        """Exact unmodified involute point of tooth 0 at roll angle(s) ``u`` [rad].

        Returns ``xy`` (2,) or (n, 2) [m], outward unit ``normal`` of the same shape, and the signed
        curvature radius ``r_b u`` [m] (> 0 convex: external; < 0: internal)."""
        _check_side(side)
        fl = self._flanks[side]
        X, Y, nX, nY, rc = self._local_involute(fl, roll_angle_rad)
        return self._to_gear(side, X, Y), self._to_gear(side, nX, nY), rc

    def roll_angle_at_radius(self, side: str, R: Any) -> Any:
        """Roll angle ``tan(arccos(r_b/R))`` [rad]; NaN inside the base circle."""
        _check_side(side)
        R = np.asarray(R, dtype=float)
        rb = self.base_radius_m[side]
        with np.errstate(invalid="ignore"):
            return np.where(R >= rb, np.sqrt(np.maximum(R * R / (rb * rb) - 1.0, 0.0)), np.nan)

    def radius_at_roll(self, side: str, roll_angle_rad: Any) -> Any:
        u = np.asarray(roll_angle_rad, dtype=float)
        return self.base_radius_m[side] * np.sqrt(1 + u * u)

    # -- modifications -------------------------------------------------------------------------
    def relief_m(self, side: str, roll_angle_rad: Any) -> Any:
        """Tip relief depth [m] along the flank normal at roll angle(s) [rad].

        Zero from the root up to the start roll angle, then ``C t`` (linear) or ``C t**2``
        (parabolic), ``t`` = (u - u_start)/(u_tip - u_start) the fraction of the roll angle from the
        start to the tip circle, so the relief at the tip circle is the model value ``C``.  Internal
        gears: the tip is at the smaller roll angle, ``t = (u_start - u)/(u_start - u_tip)``.
        Beyond the tip it is extrapolated."""
        _check_side(side)
        fl = self._flanks[side]
        u = np.asarray(roll_angle_rad, dtype=float)
        if fl.relief <= 0 or fl.relief_shape == "none":
            return np.zeros_like(u)
        den = fl.u_tip - fl.relief_start
        if den == 0 or (den < 0) != self.internal:
            return np.zeros_like(u)
        t = np.clip((u - fl.relief_start) / den, 0.0, None)
        p = 1.0 if fl.relief_shape == "linear" else 2.0
        return fl.relief * t ** p

    def crowning_m(self, z_axial_m: Any) -> Any:
        """Lead crowning depth [m] at axial coordinate z [m] from the mid-face plane of this gear:
        ``C (2 z / b)**2`` (0 at the face centre, the model value at the face edges ``z = +-b/2``)."""
        z = np.asarray(z_axial_m, dtype=float)
        return self.lead_crowning_m * (2.0 * z / self.face_width_m) ** 2

    # -- profiles ------------------------------------------------------------------------------
    def _fillet_local(self, fl: _Flank, phi: np.ndarray):
        """Fillet points, outward normals and signed curvature radius, local frame."""
        tool = fl.tool
        c, d1, d2 = tool.centre(phi)
        cmi = c - tool.I[:, None]
        dist = np.hypot(cmi[0], cmi[1])
        n = tool.sign * cmi / dist  # from tool into material (fixed frame)
        p = c + tool.rho * n
        pg = _rot(phi, p)
        ng = -_rot(phi, n)  # outward from gear material
        # centre path in the gear frame: derivatives
        cg1 = _rot(phi, _jay(c) + d1)
        cg2 = _rot(phi, -c + 2 * _jay(d1) + d2)
        speed = np.hypot(cg1[0], cg1[1])
        kappa = (cg1[0] * cg2[1] - cg1[1] * cg2[0]) / speed ** 3
        tang = cg1 / speed
        nl = _jay(tang)
        n_in = -ng  # into material, gear frame
        dsign = np.sign(nl[0] * n_in[0] + nl[1] * n_in[1])
        with np.errstate(divide="ignore"):
            r_c = 1.0 / kappa
        r_f = r_c - tool.rho * dsign
        curv = r_f * dsign  # > 0 convex (centre of curvature inside the material)
        return pg, ng, curv

    def _tip_edge_local(self, fl: _Flank, t: np.ndarray):
        cen, a0, a1 = fl.edge
        ang = a0 + (a1 - a0) * t
        re = self.tip_edge_radius_m
        X = cen[0] + re * np.sin(ang)
        Y = cen[1] + re * np.cos(ang)
        nX, nY = np.sin(ang), np.cos(ang)
        return X, Y, nX, nY

    def root_cut_local_rad(self, side: str) -> float:
        """Polar angle [rad], in the flank's local frame (tooth axis = 0, flank on the + side), where
        the flank's root space is cut: ``pi/z`` when both fillet bottoms lie inside the mid-space angle,
        else the middle of the (off-centre) root land, ``pi/z +/- sector_offset_rad``."""
        _check_side(side)
        d = self.sector_offset_rad if side == "drive" else -self.sector_offset_rad
        return math.pi / self.z + d

    def flank(self, side: str, n: int = 200) -> FlankProfile:
        """Flank of tooth 0 (``side`` = drive | coast) with ``n`` points from root to tip."""
        _check_side(side)
        if not isinstance(n, (int, np.integer)) or n < 16:
            raise ModelError(f"flank: n = {n!r} points; allowed: integer >= 16")
        key = ("flank", side, int(n))
        if key in self._cache:
            return self._cache[key]
        fl = self._flanks[side]
        r_f = self.root_radius_m
        th_mid = self.root_cut_local_rad(side)
        # region lengths
        land_len = r_f * (th_mid - fl.bottom_theta)
        phid = np.linspace(fl.phi_start, fl.phi_end, _FILLET_DENSE)
        pf, _, _ = self._fillet_local(fl, phid)
        seg = np.hypot(np.diff(pf[0]), np.diff(pf[1]))
        cum_f = np.r_[0.0, np.cumsum(seg)]
        fil_len = cum_f[-1]
        s_form = 0.5 * fl.rb * fl.u_form ** 2
        s_end = 0.5 * fl.rb * fl.u_end ** 2
        inv_len = abs(s_end - s_form)
        edge_len = 0.0
        if fl.edge is not None:
            edge_len = self.tip_edge_radius_m * abs(fl.edge[2] - fl.edge[1])
        lens = np.array([land_len, fil_len, inv_len, edge_len])
        mins = np.array([2 if land_len > 0 else 0, 6, 8, 4 if edge_len > 0 else 0])
        total = lens.sum()
        counts = np.maximum(mins, np.round(n * lens / total).astype(int))
        counts[lens <= 0] = 0
        counts[2] += n - counts.sum()
        if counts[2] < 8:
            raise ModelError(f"flank: n = {n} too small for this profile; use n >= {n - counts[2] + 8}")
        parts_X, parts_Y, parts_nX, parts_nY, parts_reg, parts_u, parts_rc = [], [], [], [], [], [], []
        # root land: from theta_mid to the fillet bottom (exclusive of the bottom point)
        if counts[0] > 0:
            th = np.linspace(th_mid, fl.bottom_theta, counts[0] + 1)[:-1]
            parts_X.append(r_f * np.sin(th))
            parts_Y.append(r_f * np.cos(th))
            sgn = -1.0 if self.internal else 1.0
            parts_nX.append(sgn * np.sin(th))
            parts_nY.append(sgn * np.cos(th))
            parts_reg.append(np.full(counts[0], REGION_ROOT_LAND))
            parts_u.append(np.full(counts[0], np.nan))
            parts_rc.append(np.full(counts[0], sgn * r_f))
        # fillet (includes the bottom point, excludes the junction)
        nf = counts[1]
        tgt = np.linspace(0.0, fil_len, nf + 1)[:-1]
        phis = np.interp(tgt, cum_f, phid)
        pg, ng, curv = self._fillet_local(fl, phis)
        parts_X.append(pg[0]); parts_Y.append(pg[1]); parts_nX.append(ng[0]); parts_nY.append(ng[1])
        parts_reg.append(np.full(nf, REGION_FILLET)); parts_u.append(np.full(nf, np.nan)); parts_rc.append(curv)
        # involute: uniform in arc length; includes the junction; includes the end if no tip rounding
        ni = counts[2]
        if fl.edge is None:
            sv = np.linspace(s_form, s_end, ni)
        else:
            sv = np.linspace(s_form, s_end, ni + 1)[:-1]
        u = np.sqrt(2.0 * sv / fl.rb)
        X, Y, nX, nY, rc = self._local_involute(fl, u)
        parts_X.append(X); parts_Y.append(Y); parts_nX.append(nX); parts_nY.append(nY)
        parts_reg.append(np.full(ni, REGION_INVOLUTE)); parts_u.append(u); parts_rc.append(rc)
        if fl.edge is not None:
            ne = counts[3]
            t = np.linspace(0.0, 1.0, ne)
            X, Y, nX, nY = self._tip_edge_local(fl, t)
            parts_X.append(X); parts_Y.append(Y); parts_nX.append(nX); parts_nY.append(nY)
            parts_reg.append(np.full(ne, REGION_TIP_ROUNDING)); parts_u.append(np.full(ne, np.nan))
            parts_rc.append(np.full(ne, self.tip_edge_radius_m))
        X = np.concatenate(parts_X); Y = np.concatenate(parts_Y)
        nX = np.concatenate(parts_nX); nY = np.concatenate(parts_nY)
        reg = np.concatenate(parts_reg); u_all = np.concatenate(parts_u); rc_all = np.concatenate(parts_rc)
        # tip relief along the normal (involute; blended into the tip-edge rounding)
        mod = np.zeros_like(X)
        inv_mask = reg == REGION_INVOLUTE
        mod[inv_mask] = self.relief_m(side, u_all[inv_mask])
        if fl.edge is not None:
            em = reg == REGION_TIP_ROUNDING
            ne = int(em.sum())
            mod[em] = float(self.relief_m(side, fl.u_end)) * np.linspace(1.0, 0.0, ne)
        X = X - mod * nX
        Y = Y - mod * nY
        xy = self._to_gear(side, X, Y)
        nrm = self._to_gear(side, nX, nY)
        seg = np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))
        s = np.r_[np.cumsum(seg[::-1])[::-1], 0.0]
        prof = FlankProfile(side=side, xy=xy, normal=nrm, s=s, radius=np.hypot(xy[:, 0], xy[:, 1]), region=reg,
                            roll_angle_rad=u_all, curvature_radius_m=rc_all, modification_m=mod)
        for a in (prof.xy, prof.normal, prof.s, prof.radius, prof.region, prof.roll_angle_rad,
                  prof.curvature_radius_m, prof.modification_m):
            a.setflags(write=False)
        self._cache[key] = prof
        return prof

    def tooth_boundary(self, n_per_flank: int = 100) -> Boundary:
        """Boundary of tooth 0 over one pitch: from the mid-root space on the coast side (polar angle
        -pi/z) along the coast flank, the tip land and the drive flank to the mid-root space on the
        drive side (+pi/z): increasing polar angle (counter-clockwise), for external and internal
        gears alike."""
        key = ("tooth", int(n_per_flank))
        if key in self._cache:
            return self._cache[key]
        c = self.flank("coast", n_per_flank)
        d = self.flank("drive", n_per_flank)
        # tip land between the two tip corners (polar interpolation)
        p0, p1 = c.xy[-1], d.xy[-1]
        a0, a1 = math.atan2(p0[1], p0[0]), math.atan2(p1[1], p1[0])
        r0, r1 = math.hypot(*p0), math.hypot(*p1)
        n_land = max(2, int(round(n_per_flank * abs(a1 - a0) * self.tip_radius_m / max(c.s[0], 1e-12))))
        t = np.linspace(0.0, 1.0, n_land + 2)[1:-1]
        ang = a0 + (a1 - a0) * t
        rr = r0 + (r1 - r0) * t
        land = np.stack([rr * np.cos(ang), rr * np.sin(ang)], axis=1)
        xy = np.concatenate([c.xy, land, d.xy[::-1]])
        side = np.concatenate([np.zeros(len(c.xy), int), np.full(n_land, -1), np.ones(len(d.xy), int)])
        region = np.concatenate([c.region, np.full(n_land, REGION_TIP_LAND), d.region[::-1]])
        side[region == REGION_ROOT_LAND] = -1
        b = Boundary(xy=xy, tooth=np.zeros(len(xy), int), side=side, region=region)
        self._cache[key] = b
        return b

    def gear_boundary(self, n_per_flank: int = 100) -> Boundary:
        """Closed boundary of all teeth (last point not repeated), increasing polar angle
        (counter-clockwise) for external and internal gears; tooth k rotated by 2 pi k / z."""
        key = ("gear", int(n_per_flank))
        if key in self._cache:
            return self._cache[key]
        tb = self.tooth_boundary(n_per_flank)
        xy0 = tb.xy[:-1]
        ang = 2 * np.pi * np.arange(self.z) / self.z
        c, s = np.cos(ang)[:, None], np.sin(ang)[:, None]
        x = c * xy0[None, :, 0] - s * xy0[None, :, 1]
        y = s * xy0[None, :, 0] + c * xy0[None, :, 1]
        xy = np.stack([x.ravel(), y.ravel()], axis=1)
        m = len(xy0)
        b = Boundary(xy=xy, tooth=np.repeat(np.arange(self.z), m), side=np.tile(tb.side[:-1], self.z),
                     region=np.tile(tb.region[:-1], self.z))
        self._cache[key] = b
        return b



def _polygon_area_j(xy: np.ndarray) -> tuple[float, float]:
    """Signed area and polar second moment about the origin of a closed polygon."""
    x, y = xy[:, 0], xy[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cr = x * y1 - x1 * y
    area = 0.5 * cr.sum()
    j = (cr * (x * x + x * x1 + x1 * x1 + y * y + y * y1 + y1 * y1)).sum() / 12.0
    return float(area), float(j)



def normal_thickness_at_radius_m(form: _ToothForm, helix_angle_rad: float, R: float) -> float:
    """Normal circular tooth thickness [m] at radius ``R`` [m]: the transverse arc thickness ``R Theta(R)`` times
    ``cos(beta_R)``, ``tan(beta_R) = tan(beta) R / r`` (the helix angle at that radius)."""
    beta_r = math.atan(abs(math.tan(helix_angle_rad)) * R / form.r)
    return R * float(form.thickness_angle(R)) * math.cos(beta_r)


def _check_iso_tip_thickness(gear: Any, iso: Any, form: _ToothForm, r_a: float) -> None:
    """Refuse an ISO-form gear whose normal tooth thickness at the tip circle is below
    :data:`~hacgear_core.model.iso21771.MIN_TIP_THICKNESS_FACTOR` x m_n, naming the tip diameter that reaches it."""
    from hacgear_core.model.iso21771 import MIN_TIP_THICKNESS_FACTOR, tip_alteration

    m_n = iso.normal_module_m
    s_min = MIN_TIP_THICKNESS_FACTOR * m_n
    beta = gear.helix_angle_rad
    s_an = normal_thickness_at_radius_m(form, beta, r_a)
    if s_an >= s_min:
        return
    lo, hi = sorted((form.r, r_a))
    f = lambda R: normal_thickness_at_radius_m(form, beta, R) - s_min  # noqa: E731
    fix = ""
    if f(form.r) > 0 > f(r_a):
        r_ok = float(_brentq(f, lo, hi, xtol=1e-12))
        k_ok = tip_alteration(iso.teeth, m_n, iso.helix_angle_rad, iso.addendum_coefficient, iso.profile_shift,
                              2 * r_ok, iso.internal)
        rel = ">=" if iso.internal else "<="   # the tip circle moves towards the reference circle
        fix = (f"; fix: tip_alteration_mm <= {k_ok * m_n * 1e3:.6f} (tip_diameter_mm {rel} {2e3 * r_ok:.6f}; now "
               f"{iso.tip_alteration * m_n * 1e3:.6f} mm, tip diameter {2e3 * r_a:.6f} mm), or a smaller "
               "profile_shift")
    raise GeometryError(
        f"gear '{gear.name}': tooth too thin at the tip circle: normal tip thickness s_an = {s_an * 1e3:.6f} mm < "
        f"{MIN_TIP_THICKNESS_FACTOR:g} m_n = {s_min * 1e3:.6f} mm (the usual design minimum; profile_shift "
        f"{iso.profile_shift:g}, tip alteration k = {iso.tip_alteration:.6g}){fix}")


def gear_geometry(gear: Any, *, shaper_teeth: int | None = None) -> GearGeometry:
    """Build the geometry of one :class:`hacgear_core.model.Gear` (a few ms).

    Raises :class:`GeometryError` for impossible teeth (pointed tips, fillets meeting, no involute);
    collects engineering warnings (thin tip, undercut, odd tool addendum, relief outside the flank)
    in ``warnings``.
    """
    if not hasattr(gear, "module_m"):
        raise GeometryError(f"gear '{getattr(gear, 'name', '?')}' is a member of a lumped model (mass, inertia, base "
                            "radius): it has no tooth geometry (info, statics and plots need a model with teeth)")
    z = int(gear.teeth)
    m = float(gear.module_m)
    r = 0.5 * m * z
    r_a = 0.5 * gear.tip_diameter_m
    r_f = 0.5 * gear.root_diameter_m
    internal = bool(gear.internal)
    alpha = {s: float(gear.flanks[s].pressure_angle_rad) for s in SIDES}
    rb = {s: r * math.cos(alpha[s]) for s in SIDES}
    s_ref = float(gear.tooth_thickness_m)
    tsum = math.tan(alpha["drive"]) + math.tan(alpha["coast"])
    if not internal:
        x = (s_ref / m - math.pi / 2) / tsum
        h_a0 = r + x * m - r_f
        h_a = r_a - r - x * m
    else:
        x = (math.pi / 2 - s_ref / m) / tsum
        h_a0 = r_f - r - x * m
        h_a = r + x * m - r_a
    warnings: list[str] = []
    form = _ToothForm(z=z, r=r, internal=internal, alpha=alpha, rb=rb, psi=s_ref / (2 * r))
    z0 = None
    if internal:
        z0 = int(shaper_teeth) if shaper_teeth is not None else max(8, min(SHAPER_TEETH, z // 3))
        if z - z0 < 8:
            raise GeometryError(f"gear '{gear.name}': shaper with {z0} teeth too large for {z} internal teeth")
    if gear.hob_tip_radius_m <= 0:
        raise GeometryError(f"gear '{gear.name}': hob_tip_radius_mm must be > 0 (a sharp tool tip leaves no fillet)")
    flanks = {s: _build_flank(gear, form, s, r_f, r_a, m, z0, warnings) for s in SIDES}
    # root land: the generated root space runs from the drive fillet bottom (polar angle th_d) to the
    # next tooth's coast fillet bottom (2 pi/z - th_c); the rack/shaper tip land maps onto it, so a
    # negative land means the two tip circles of the tool tooth overlap (tool tip too narrow).
    th_d, th_c = flanks["drive"].bottom_theta, flanks["coast"].bottom_theta
    land = 2 * math.pi / z - th_d - th_c
    iso = getattr(gear, "iso", None)
    if land < -1e-9 / z and internal and iso is not None:
        # ISO form, internal gear: rho_fP* m_n is the basic rack's root radius; the pinion-type shaper that cuts the
        # ring has a narrower tooth tip than the rack (the tip land shrinks with the shaper's tooth count), so where
        # the rack's radius does not fit, the shaper's tip is the full radius it can hold (zero root land) — the
        # tool a rack A ring is cut with — said in the warnings, not refused.  Scale-free: the same at any module.
        rho_max = _max_tool_tip_radius(gear, form, r_f, r_a, m, z0)
        if np.isfinite(rho_max) and rho_max > 0:
            rho_full = rho_max * (1.0 - 1e-9)
            warnings.append(
                f"gear '{gear.name}': the basic rack's root radius rho_fP = {iso.root_radius_coefficient:g} m_n = "
                f"{gear.hob_tip_radius_m * 1e3:.4f} mm does not fit the tip of the {z0}-tooth shaper that cuts this "
                f"internal gear; the shaper's tip is its full radius {rho_full * 1e3:.4f} mm = "
                f"{rho_full / iso.normal_module_m:.6f} m_n (zero root land)")
            gear = replace(gear, hob_tip_radius_m=rho_full)
            flanks = {s: _build_flank(gear, form, s, r_f, r_a, m, z0, warnings) for s in SIDES}
            th_d, th_c = flanks["drive"].bottom_theta, flanks["coast"].bottom_theta
            land = 2 * math.pi / z - th_d - th_c
    if land < -1e-9 / z:
        rho_max = _max_tool_tip_radius(gear, form, r_f, r_a, m, z0)
        if iso is not None:
            raise GeometryError(
                f"gear '{gear.name}': the basic rack's root radius rho_fP = rho_fP* m_n = "
                f"{iso.root_radius_coefficient:g} x {iso.normal_module_m * 1e3:g} = {gear.hob_tip_radius_m * 1e3:g} mm "
                f"is too large for the {'shaper' if internal else 'hob'} that cuts this gear: the two tip circles of "
                f"the tool tooth overlap (root land {math.degrees(land):.4f} deg < 0); allowed: "
                f"rack_root_radius_coefficient <= {rho_max / iso.normal_module_m:.6f} (rho_fP <= {rho_max * 1e3:.4f} "
                f"mm) for this gear{'' if iso.basic_rack == 'custom' else f', in place of basic_rack = {iso.basic_rack!r}'}"
                "; or a deeper root (rack_dedendum_coefficient)")
        raise GeometryError(
            f"gear '{gear.name}': hob_tip_radius_mm = {gear.hob_tip_radius_m * 1e3:g} mm too large: the two tip "
            f"circles of the tool tooth overlap (root land {math.degrees(land):.4f} deg < 0); allowed: "
            f"0 < hob_tip_radius_mm <= {rho_max * 1e3:.4f} mm for this gear (or a larger root_diameter_mm)")
    land = max(land, 0.0)
    if th_d <= math.pi / z and th_c <= math.pi / z:
        sector_offset = 0.0  # cut at the mid-space angle (symmetric cut, as before)
    else:
        sector_offset = 0.5 * (th_d - th_c)  # cut in the middle of the off-centre root land
    # tooth thickness at the tip
    s_tip = r_a * float(form.thickness_angle(r_a))
    if getattr(gear, "iso", None) is not None:   # the ISO form's limit, in its keys (a pointed tip included)
        _check_iso_tip_thickness(gear, gear.iso, form, r_a)
    if s_tip <= 0:
        raise GeometryError(f"gear '{gear.name}': pointed tooth, thickness at the tip circle {s_tip * 1e3:.4f} mm "
                            f"<= 0 (tip_diameter_mm {gear.tip_diameter_m * 1e3:g} too large for tooth_thickness_mm "
                            f"{s_ref * 1e3:g})")
    # material removed from the tip corners at the face ends, normal to each flank: tip relief plus lead crowning
    removed = sum(gear.flanks[s].tip_relief_m for s in SIDES) + 2.0 * float(getattr(gear, "lead_crowning_m", 0.0))
    if removed >= s_tip:
        raise GeometryError(
            f"gear '{gear.name}': tip relief drive {gear.flanks['drive'].tip_relief_m * 1e6:g} um + coast "
            f"{gear.flanks['coast'].tip_relief_m * 1e6:g} um + 2 x lead crowning "
            f"{getattr(gear, 'lead_crowning_m', 0.0) * 1e6:g} um = {removed * 1e6:.1f} um remove more than the "
            f"tooth thickness at the tip circle, {s_tip * 1e6:.1f} um: no tooth is left at the tip corners of the "
            f"face ends; allowed: a sum below {s_tip * 1e6:.1f} um")
    if s_tip < 0.2 * m:
        warnings.append(f"gear '{gear.name}': thin tip, tooth thickness at the tip circle {s_tip * 1e3:.3f} mm < "
                        f"0.2 m = {0.2 * m * 1e3:.3f} mm")
    for s in SIDES:
        fl = flanks[s]
        if fl.undercut:
            warnings.append(f"gear '{gear.name}' {s} flank: undercut by the hob tip; true involute form diameter "
                            f"{2e3 * rb[s] * math.sqrt(1 + fl.u_form ** 2):.3f} mm")
        if fl.relief > 0:
            lo, hi = sorted((fl.u_form, fl.u_end))
            if not lo <= fl.relief_start <= hi:
                warnings.append(
                    f"gear '{gear.name}' {s} flank: tip relief start roll angle "
                    f"{math.degrees(fl.relief_start):.2f} deg outside the involute "
                    f"[{math.degrees(lo):.2f}, {math.degrees(hi):.2f}] deg")
    if not 0.9 <= h_a0 / m <= 1.7:
        warnings.append(f"gear '{gear.name}': tool addendum h_a0 = {h_a0 / m:.3f} m from root diameter and profile "
                        "shift is unusual (typical 1.167..1.4 m)")
    if not 0.6 <= h_a / m <= 1.3:
        warnings.append(f"gear '{gear.name}': tip addendum (from the shifted datum) {h_a / m:.3f} m is unusual "
                        "(standard 1.0 m)")
    fillet_rc = {}
    for s in SIDES:
        if not internal:
            fillet_rc[s] = fillet_root_curvature_radius_rack(r, r_f, gear.hob_tip_radius_m)
        else:
            t = flanks[s].tool
            fillet_rc[s] = fillet_root_curvature_radius_shaper(t.r_w, z, z0, r_f, gear.hob_tip_radius_m)
    # blank
    rho_mat = float(gear.material.density_kg_per_m3)
    b = float(gear.face_width_m)
    r_bore = 0.5 * float(gear.bore_diameter_m)
    if internal and r_bore <= 0:
        r_bore = r_f + 3.0 * m
        warnings.append(f"gear '{gear.name}': internal gear without bore_diameter_mm (outer rim); using rim radius "
                        f"r_f + 3 m = {r_bore * 1e3:.3f} mm")
    mweb = getattr(gear, "web", None)
    web = None
    if mweb is not None:
        if internal:
            raise GeometryError(f"gear '{gear.name}': a web is not supported for internal gears")
        r_wi, r_wo = 0.5 * float(mweb.inner_diameter_m), 0.5 * float(mweb.outer_diameter_m)
        if not r_bore < r_wi < r_wo < r_f:
            raise GeometryError(f"gear '{gear.name}': web radii must satisfy bore {r_bore * 1e3:g} < inner "
                                f"{r_wi * 1e3:g} < outer {r_wo * 1e3:g} < root {r_f * 1e3:g} mm")
        web = WebGeometry(float(mweb.thickness_m), r_wi, r_wo, min(1.0, float(mweb.thickness_m) / b))
    gg = GearGeometry(
        name=gear.name, z=z, module_m=m, pitch_radius_m=r, tip_radius_m=r_a, root_radius_m=r_f, internal=internal,
        face_width_m=b, helix_angle_rad=float(gear.helix_angle_rad), axial_position_m=float(gear.axial_position_m),
        lead_crowning_m=float(gear.lead_crowning_m), tip_edge_radius_m=float(gear.tip_edge_radius_m),
        hob_tip_radius_m=float(gear.hob_tip_radius_m), pressure_angle_rad=alpha, base_radius_m=rb,
        profile_shift={s: x for s in SIDES}, hob_addendum_m=h_a0, tip_addendum_m=h_a,
        form_radius_m={s: rb[s] * math.sqrt(1 + flanks[s].u_form ** 2) for s in SIDES},
        form_roll_rad={s: flanks[s].u_form for s in SIDES}, tip_roll_rad={s: flanks[s].u_tip for s in SIDES},
        involute_end_roll_rad={s: flanks[s].u_end for s in SIDES}, undercut={s: flanks[s].undercut for s in SIDES},
        fillet_root_curvature_radius_m=fillet_rc, tip_thickness_m=s_tip, bore_radius_m=r_bore, mass_kg=0.0,
        inertia_kgm2=0.0, diametral_inertia_kgm2=0.0, blank_mass_kg=0.0, blank_inertia_kgm2=0.0, teeth_area_m2=0.0,
        shaper_teeth=z0, warnings=(), density_kg_per_m3=rho_mat, sector_offset_rad=sector_offset, web=web, _form=form,
        _flanks=flanks)
    # mass properties from the polygon of the whole boundary
    # one tooth sector (origin + one pitch of boundary), times z
    sector = np.vstack([[0.0, 0.0], gg.tooth_boundary(240).xy])
    area, j = _polygon_area_j(sector)
    area, j = z * area, z * j
    if not internal:
        teeth_area = area - math.pi * r_f ** 2
        a_tot = area - math.pi * r_bore ** 2
        j_tot = j - 0.5 * math.pi * r_bore ** 4
    else:
        teeth_area = math.pi * r_f ** 2 - area
        a_tot = math.pi * r_bore ** 2 - area
        j_tot = 0.5 * math.pi * r_bore ** 4 - j
    mass = rho_mat * b * a_tot
    inertia = rho_mat * b * j_tot
    web_mass = 0.0
    if web is not None:  # the web annulus has thickness t instead of b: remove (b - t) of it
        ri, ro, t_w = web.inner_radius_m, web.outer_radius_m, web.thickness_m
        mass -= rho_mat * (b - t_w) * math.pi * (ro ** 2 - ri ** 2)
        inertia -= rho_mat * (b - t_w) * 0.5 * math.pi * (ro ** 4 - ri ** 4)
        web_mass = rho_mat * t_w * math.pi * (ro ** 2 - ri ** 2)
    blank_mass, blank_inertia = mass, inertia
    if gear.mass_kg is not None:
        mass = float(gear.mass_kg)
    if gear.inertia_kgm2 is not None:
        inertia = float(gear.inertia_kgm2)
    if web is None or gear.mass_kg is not None:
        diam = 0.5 * inertia + mass * b * b / 12.0
    else:  # thin slices about a diameter: rim and hub of width b, web of width t
        diam = 0.5 * inertia + (mass - web_mass) * b * b / 12.0 + web_mass * web.thickness_m ** 2 / 12.0
    object.__setattr__(gg, "mass_kg", mass)
    object.__setattr__(gg, "inertia_kgm2", inertia)
    object.__setattr__(gg, "diametral_inertia_kgm2", diam)
    object.__setattr__(gg, "blank_mass_kg", blank_mass)
    object.__setattr__(gg, "blank_inertia_kgm2", blank_inertia)
    object.__setattr__(gg, "teeth_area_m2", teeth_area)
    object.__setattr__(gg, "warnings", tuple(warnings))
    return gg
