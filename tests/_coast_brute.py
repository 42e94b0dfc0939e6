"""Brute-force flank closure of a mesh from placed flank polylines (shared by the geometry and coast tests).

The gears are placed by :func:`hacgear_core.geometry.train.place_mesh` (tooth 0 of both gears with its loaded flank
at the pitch point = drive mesh position 0), turned to drive mesh position ``tau`` and then closed with both gears
sharing the approach equally in mesh cycles, until the first pair of flank polylines touches: on the coast side
gear_a turns back by ``e`` and gear_b forward by ``e`` (coast approach ``x_c = 2 e p_bc``), on the drive side the
other way (drive deflection ``x_d = 2 e p_b``).  Nothing here uses the closed forms or the contact solver.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from hacgear_core.geometry import gear_geometry, mesh_geometry
from hacgear_core.geometry.train import place_mesh

OTHER = {"drive": "coast", "coast": "drive"}


def _signed_gaps(P: np.ndarray, Q: np.ndarray, NQ: np.ndarray) -> np.ndarray:
    """Signed distance of points P from polyline Q along Q's outward normals (inf where the foot falls off Q):
    the nearest vertex of Q selects its two adjacent segments, the orthogonal foot on the nearer one counts."""
    from scipy.spatial import cKDTree

    _, v = cKDTree(Q).query(P)
    m = len(Q) - 1
    best = np.full(len(P), np.inf)
    out = np.full(len(P), np.inf)
    for j in (np.clip(v - 1, 0, m - 1), np.clip(v, 0, m - 1)):
        A, D = Q[j], Q[j + 1] - Q[j]
        rel = P - A
        t = np.einsum("ij,ij->i", rel, D) / np.einsum("ij,ij->i", D, D)
        tc = np.clip(t, 0.0, 1.0)
        diff = rel - tc[:, None] * D
        d2 = np.einsum("ij,ij->i", diff, diff)
        n = NQ[j] * (1 - tc)[:, None] + NQ[j + 1] * tc[:, None]
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        g = np.einsum("ij,ij->i", diff, n)
        off = ((j == 0) & (t < 0)) | ((j == m - 1) & (t > 1))
        better = d2 < best
        best = np.where(better, d2, best)
        out = np.where(better, np.where(off, np.inf, g), out)
    return out


class CoastClosure:
    """Placed gears of mesh ``mesh_name`` of ``model``; :meth:`close` finds the first coast-flank touch."""

    def __init__(self, model, mesh_name: str, n: int = 500, side: str = "coast"):
        self.model = model
        mesh = model.mesh(mesh_name)
        self.ga, self.gb = gear_geometry(model.gear(mesh.gear_a)), gear_geometry(model.gear(mesh.gear_b))
        self.mg = mesh_geometry(model, mesh_name, gears={self.ga.name: self.ga, self.gb.name: self.gb}, strict=False)
        self.sa = 1.0 if mesh.flank_a == "drive" else -1.0
        self.sb = self.sa * (1.0 if self.mg.internal else -1.0)
        self.Oa = np.zeros(2)
        self.Ob = np.array([self.mg.center_distance_m, 0.0]) * (-1.0 if self.gb.internal else 1.0)
        pl = place_mesh(self.ga, self.gb, self.mg, self.sa, self.Oa, self.Ob)
        self.P = pl["pitch_point_m"]
        self.angle = (pl["angle_a"], pl["angle_b"])
        self.side = side
        self.close_sign = 1.0 if side == "coast" else -1.0
        self.flank = []
        for gg, f in ((self.ga, mesh.flank_a), (self.gb, mesh.flank_b)):
            prof = gg.flank(OTHER[f] if side == "coast" else f, n)
            keep = prof.region >= 2       # involute and tip: the curves that can touch
            self.flank.append((np.asarray(prof.xy)[keep], np.asarray(prof.normal)[keep]))
        rb = self.mg.base_radius_coast_m if side == "coast" else self.mg.base_radius_m
        self.rb_coast = (rb[self.ga.name], rb[self.gb.name])
        self.pb_coast = 2 * math.pi * self.rb_coast[0] / self.ga.z

    def _teeth(self, g: int, phi: float, teeth):
        xy, nrm = self.flank[g]
        O = (self.Oa, self.Ob)[g]
        z = (self.ga.z, self.gb.z)[g]
        out = {}
        for t in teeth:
            a = phi + 2 * math.pi * t / z
            c, s = math.cos(a), math.sin(a)
            R = np.array([[c, -s], [s, c]])
            out[t] = (xy @ R.T + O, nrm @ R.T)
        return out

    def angles(self, tau: float, e: float) -> tuple[float, float]:
        """Gear rotations [rad] at drive mesh position ``tau`` closed by ``e`` mesh cycles on this side."""
        e = self.close_sign * e
        return (self.angle[0] + self.sa * 2 * math.pi * (tau - e) / self.ga.z,
                self.angle[1] + self.sb * 2 * math.pi * (tau + e) / self.gb.z)

    def pair_gaps(self, tau: float, e: float, window: int = 3, near_m: float = 1e-3) -> dict:
        """Smallest signed gap [m] (within ``near_m``) between the coast flanks of each pair of teeth near the pitch
        point → {(tooth of gear_a, tooth of gear_b): (gap, point)} (gears' own tooth numbering)."""
        pa, pb = self.angles(tau, e)
        near = lambda phi, z, O: int(round((math.atan2(*(self.P - O)[::-1]) - phi) * z / (2 * math.pi)))  # noqa
        A = self._teeth(0, pa, range(near(pa, self.ga.z, self.Oa) - window, near(pa, self.ga.z, self.Oa) + window + 1))
        B = self._teeth(1, pb, range(near(pb, self.gb.z, self.Ob) - window, near(pb, self.gb.z, self.Ob) + window + 1))
        out = {}
        for i, (xa, na) in A.items():
            for j, (xb, nb) in B.items():
                if np.linalg.norm(xa.mean(0) - xb.mean(0)) > 2 * self.mg.base_pitch_m:
                    continue
                g1 = _signed_gaps(xb, xa, na)
                g2 = _signed_gaps(xa, xb, nb)
                g1[np.abs(g1) > near_m] = np.inf          # a flank facing away lies a tooth thickness off
                g2[np.abs(g2) > near_m] = np.inf
                k1, k2 = int(np.argmin(g1)), int(np.argmin(g2))
                g, pt = (g1[k1], xb[k1]) if g1[k1] <= g2[k2] else (g2[k2], xa[k2])
                if math.isfinite(g):
                    out[(i % self.ga.z, j % self.gb.z)] = (float(g), pt)
        return out

    def gap(self, tau: float, e: float) -> float:
        """Smallest coast-flank gap [m] at drive position ``tau`` closed by ``e`` mesh cycles."""
        return min((g for g, _ in self.pair_gaps(tau, e).values()), default=math.inf)

    def close(self, tau: float, tol_m: float = 1e-10, tie_m: float = 0.1e-6):
        """First touch at drive position ``tau`` → (approach [m] from the drive kinematic position along this side's
        line of action, touching pairs): every pair within ``tie_m`` of touching then, as {(tooth of gear_a, tooth
        of gear_b): (point (2,), roll angle on gear_b's flank [deg])} (gears' own tooth numbering; several pairs
        touch at once on unmodified involutes).  On the drive side the search starts 0.02 mesh cycles open."""
        lo = 0.0 if self.side == "coast" else -0.02  # coast: the drive flanks touch, the coast flanks are apart
        assert self.gap(tau, lo) > 0
        hi = lo
        while self.gap(tau, hi) > 0:               # steps of 1/200 mesh cycle (~0.1 mm of approach)
            lo, hi = hi, hi + 0.005
            assert hi < 0.5
        while (hi - lo) * self.pb_coast > tol_m:
            mid = 0.5 * (lo + hi)
            if self.gap(tau, mid) > 0:
                lo = mid
            else:
                hi = mid
        gaps = self.pair_gaps(tau, hi)
        gmin = min(g for g, _ in gaps.values())
        touching = {}
        for pair, (g, pt) in gaps.items():
            if g <= gmin + tie_m:
                r = float(np.linalg.norm(pt - self.Ob))
                touching[pair] = (pt, math.degrees(math.sqrt(max(r * r / self.rb_coast[1] ** 2 - 1.0, 0.0))))
        return 2 * hi * self.pb_coast, touching


def thickness_variant(model, gear_name: str, tooth_thickness_m: float):
    """Copy of ``model`` with one gear's reference tooth thickness changed (a mesh with unequal tooth thicknesses)."""
    gears = tuple(replace(g, tooth_thickness_m=tooth_thickness_m) if g.name == gear_name else g for g in model.gears)
    return replace(model, gears=gears)
