"""A small synthetic external spur gear with the GearGeometry interface used by
:mod:`hacgear_core.statics.fe` (involute flank, radial line below the base circle, circular
fillet tangent to the root circle, sharp tip corner).  Test fixture only: it lets the
finite-element tests run independently of :mod:`hacgear_core.geometry`."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hacgear_core.geometry import FlankProfile  # the geometry contract's profile record


def _inv(a):
    return np.tan(a) - a


@dataclass
class _Boundary:
    xy: np.ndarray
    tooth: np.ndarray
    side: np.ndarray
    region: np.ndarray


class SyntheticGear:
    def __init__(self, z=20, module_m=4e-3, pressure_angle_rad=np.deg2rad(20.0), tip_radius_m=None,
                 root_radius_m=None, fillet_radius_m=1.0e-3, bore_radius_m=15e-3, face_width_m=10e-3):
        self.z = z
        self.module_m = module_m
        self.internal = False
        self.face_width_m = face_width_m
        self.bore_radius_m = bore_radius_m
        self.pitch_radius_m = rp = z * module_m / 2
        self.tip_radius_m = tip_radius_m or rp + module_m
        self.root_radius_m = root_radius_m or rp - 1.25 * module_m
        a = pressure_angle_rad
        self.rb = rp * np.cos(a)
        self.base_radius_m = {"drive": self.rb, "coast": self.rb}
        self.pressure_angle_rad = {"drive": a, "coast": a}
        self.psi = np.pi / (2 * z) + _inv(a)          # polar half-angle of the flank at the base circle
        self.rho = fillet_radius_m
        rf = self.root_radius_m
        cx = np.sqrt((rf + self.rho) ** 2 - self.rho ** 2)
        if cx > self.rb:
            raise ValueError("fillet does not fit below the base circle")
        self._cx = cx

    def _drive_dense(self, n):
        """Dense drive-flank polyline root -> tip: xy, region, roll, curvature."""
        rb, psi, rho, cx = self.rb, self.psi, self.rho, self._cx
        R = np.array([[np.cos(psi), -np.sin(psi)], [np.sin(psi), np.cos(psi)]])
        c = np.array([cx, rho])
        phi_end = np.arctan2(-c[1], -c[0])
        phi = np.linspace(phi_end, -np.pi / 2, n)      # root tangency -> line tangency
        fil = (c + rho * np.stack([np.cos(phi), np.sin(phi)], 1)) @ R.T
        lin_r = np.linspace(cx, rb, n)[1:]
        lin = np.stack([lin_r, 0 * lin_r], 1) @ R.T
        r = np.linspace(rb, self.tip_radius_m, 4 * n)[1:]
        ar = np.arccos(rb / r)
        th = psi - _inv(ar)
        inv_xy = np.stack([r * np.cos(th), r * np.sin(th)], 1)
        xy = np.concatenate([fil, lin, inv_xy])
        region = np.concatenate([np.ones(len(fil) + len(lin), int), 2 * np.ones(len(inv_xy), int)])
        roll = np.concatenate([np.full(len(fil) + len(lin), np.nan), np.tan(ar)])
        curv = np.concatenate([np.full(len(fil), -rho), np.full(len(lin), 1e3), r * np.sin(ar)])
        return xy, region, roll, curv

    def flank(self, side, n=200):
        xy, region, roll, curv = self._drive_dense(max(n, 50))
        seg = np.linalg.norm(np.diff(xy, axis=0), axis=1)
        arc = np.r_[0, np.cumsum(seg)]
        a = np.linspace(0, arc[-1], n)
        xs = np.stack([np.interp(a, arc, xy[:, 0]), np.interp(a, arc, xy[:, 1])], 1)
        idx = np.clip(np.searchsorted(arc, a), 0, len(arc) - 1)
        reg = region[idx]
        rl = np.interp(a, arc, np.nan_to_num(roll, nan=0.0))
        rl[reg != 2] = np.nan
        cv = np.interp(a, arc, curv)
        tang = np.gradient(xs, axis=0)
        tang /= np.linalg.norm(tang, axis=1, keepdims=True)
        normal = np.stack([-tang[:, 1], tang[:, 0]], 1)
        if side == "coast":
            xs = xs * [1, -1]
            normal = normal * [1, -1]
        s = arc[-1] - a
        return FlankProfile(side, xs, normal, s, np.hypot(xs[:, 0], xs[:, 1]), reg, rl, cv, np.zeros(n))

    def tooth_boundary(self, n_per_flank=100):
        d = self.flank("drive", n_per_flank)
        c = self.flank("coast", n_per_flank)
        rf, z = self.root_radius_m, self.z
        a_root = np.arctan2(d.xy[0, 1], d.xy[0, 0])
        nl = max(4, n_per_flank // 10)
        land_d = rf * np.stack([np.cos(np.linspace(a_root, np.pi / z, nl)),
                                np.sin(np.linspace(a_root, np.pi / z, nl))], 1)
        land_c = land_d[::-1] * [1, -1]
        a_tip = np.arctan2(d.xy[-1, 1], d.xy[-1, 0])
        ra = np.hypot(*d.xy[-1])
        tip = ra * np.stack([np.cos(np.linspace(-a_tip, a_tip, nl)), np.sin(np.linspace(-a_tip, a_tip, nl))], 1)
        parts = [(land_c, -1, 0), (c.xy[1:], 0, None), (tip[1:-1], -1, 3), (d.xy[::-1], 1, None),
                 (land_d[1:], -1, 0)]
        xy, side, region = [], [], []
        for pts, sd, rg in parts:
            xy.append(pts)
            side.append(np.full(len(pts), sd))
        region = np.concatenate([np.zeros(len(land_c), int), c.region[1:], np.full(nl - 2, 3),
                                 d.region[::-1], np.zeros(nl - 1, int)])
        xy = np.concatenate(xy)
        return _Boundary(xy, np.zeros(len(xy), int), np.concatenate(side), region)
