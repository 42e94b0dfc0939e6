"""One planet between sun and ring solved as a chain: both meshes at once, coupled through the planet's body.

The tables of a planetary set are per mesh kind (:mod:`hacgear_core.statics.grid`): each mesh is solved with both
hubs held, so the planet's elastic deformation under its sun-mesh loads does not reach its ring-mesh contact and
vice versa.  In the chain (the dissertation's Fig. 4.5(a)) the planet carries both at once: its drive flanks meet
the sun, its coast flanks the ring, and the finite-element body of the planet couples the two contact zones.  This
module solves that chain statically so that the difference can be measured:

* both meshes are set up by their own contact solvers (:class:`~hacgear_core.statics.contact.MeshContactSolver`),
  at positions that keep the planet one body: the sun mesh at ``p``, the ring mesh at ``p + gamma_rs`` (the phase
  of :func:`hacgear_core.geometry.planetary.planetary_geometry`), each shifted by the planet's tooth passage so
  that both solvers number the planet's teeth alike;
* the cross compliance of the planet (inward normal displacement at its coast-flank points of every tooth per unit
  normal line load at its drive-flank points of tooth 0, hub held) comes from the same finite-element model as its
  flank compliances (:func:`hacgear_core.statics.fe.build_gear_fe`);
* load control of both meshes (the planet's torque balance fixes ``F_r = F_s r_bps / r_bpr``); each mesh is solved
  with the other mesh's loads entering its separations (block Gauss-Seidel, exact at convergence).

The reported difference ``x_chain - x_alone`` is what the per-mesh tables leave out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from hacgear_core.errors import SolverError
from hacgear_core.geometry import gear_geometry
from hacgear_core.geometry.planetary import planetary_geometry
from hacgear_core.model import Model
from hacgear_core.kinds import load_model
from hacgear_core.statics import fe as fe_mod
from hacgear_core.statics.contact import make_mesh_solver

__all__ = ["ChainPoint", "PlanetChain"]


@dataclass(frozen=True)
class ChainPoint:
    """One chain solve: sun-mesh ``position`` [cycles], mesh forces [N], mesh deflections alone and in the chain
    [m], and the block iterations used."""

    position: float
    force_sun_N: float
    force_ring_N: float
    deflection_sun_alone_m: float
    deflection_ring_alone_m: float
    deflection_sun_chain_m: float
    deflection_ring_chain_m: float
    iterations: int

    @property
    def relative_change_sun(self) -> float:
        return (self.deflection_sun_chain_m - self.deflection_sun_alone_m) / self.deflection_sun_alone_m

    @property
    def relative_change_ring(self) -> float:
        return (self.deflection_ring_chain_m - self.deflection_ring_alone_m) / self.deflection_ring_alone_m


class PlanetChain:
    """Static chain solver of one planet of a planetary model (module docstring).

    Parameters
    ----------
    model : Model or path / system name
    """

    def __init__(self, model: Any) -> None:
        if not isinstance(model, Model):
            model = load_model(model)
        geo = planetary_geometry(model, 1)
        mem = geo.members
        self.model = model
        self.members = mem
        self.sun = make_mesh_solver(model, mem.sun_mesh)
        self.ring = make_mesh_solver(model, mem.ring_mesh)
        self.ring_sun_phase = geo.ring_sun_phase
        sm, rm = geo.sun_mesh(1), geo.ring_mesh(1)
        p1 = geo.planets[0]
        self._shift_sun = sm.tooth_passage[p1]
        self._shift_ring = rm.tooth_passage[p1]
        self._ip_sun = self.sun.gear_names.index(mem.planet)
        self._ip_ring = self.ring.gear_names.index(mem.planet)
        fs, fr = self.sun.compliance[self._ip_sun], self.ring.compliance[self._ip_ring]
        self._fs, self._fr = fs, fr
        self.z = int(fs.z)
        rb_s = self.sun.base_radius_m[self._ip_sun]
        rb_r = self.ring.base_radius_m[self._ip_ring]
        self.force_ratio = rb_s / rb_r
        # cross compliance of the planet: loads on drive-flank samples of tooth 0 -> inward normal displacement at
        # the reading depth below the coast-flank samples of every tooth [k, i (drive load), j (coast response)]
        planet = model.gear(mem.planet)
        gg = gear_geometry(planet)
        mat = fe_mod.ElasticMaterial(planet.material.youngs_modulus_Pa, planet.material.poisson_ratio, "stress")
        fe = fe_mod.build_gear_fe(gg, mat)
        read = fr.xy_m - fr.depth_m[:, None] * fr.normal
        disp, _, _ = fe.influence(fs.xy_m, -fs.normal, read, -fr.normal, np.zeros((0, 2)), np.zeros((0, 2)))
        self.cross_m2_N = np.ascontiguousarray(disp.transpose(0, 2, 1))   # [k, i, j]

    def _cross(self, k: int, s_drive, s_coast) -> np.ndarray:
        """Coast-flank displacement [m per N/m] on tooth ``k`` (relative to the loaded drive tooth) at ``s_coast``
        per unit line load at ``s_drive`` (bilinear in both profile coordinates; reciprocal)."""
        C = self.cross_m2_N[int(k) % self.z]
        i0, fi = self._fs._frac(s_drive)
        j0, fj = self._fr._frac(s_coast)
        return ((1 - fi) * (1 - fj) * C[i0, j0] + fi * (1 - fj) * C[i0 + 1, j0]
                + (1 - fi) * fj * C[i0, j0 + 1] + fi * fj * C[i0 + 1, j0 + 1])

    def _operators(self, ps: float, pr: float):
        """(A_sr, A_rs): gap change at each candidate of one mesh per unit force [N] at the candidates of the
        other (line loads over each mesh's slice width)."""
        su, ri = self.sun.setup(ps), self.ring.setup(pr)
        t_s = (su.tooth_b if self._ip_sun == 1 else su.tooth_a)[su.pair_index]
        s_s = (su.s_b if self._ip_sun == 1 else su.s_a)[su.pair_index]
        t_r = (ri.tooth_a if self._ip_ring == 0 else ri.tooth_b)[ri.pair_index]
        s_r = (ri.s_a if self._ip_ring == 0 else ri.s_b)[ri.pair_index]
        A = np.zeros((t_s.size, t_r.size))   # displacement at sun candidate i per unit line load at ring candidate j
        for a in range(t_s.size):
            for b in range(t_r.size):
                # reciprocity: displacement at drive point (t_s, s_s) due to load at coast point (t_r, s_r) equals
                # the coast displacement at (t_r, s_r) due to a drive load at (t_s, s_s)
                A[a, b] = self._cross(t_r[b] - t_s[a], s_s[a], s_r[b])
        return A / ri.slice_width_m, A.T / su.slice_width_m, (su, ri)

    def solve(self, position: float, force_sun_N: float, *, tol: float = 1e-9, max_iter: int = 50) -> ChainPoint:
        """Chain solve at sun-mesh position ``position`` [cycles] with ``force_sun_N`` [N] on the sun mesh (the ring
        mesh carries ``force_sun_N * r_bps / r_bpr``)."""
        ps = float(position) - self._shift_sun
        pr = float(position) + self.ring_sun_phase - self._shift_ring
        fs = float(force_sun_N)
        fr = fs * self.force_ratio
        alone_s = self.sun.state_load(ps, fs)
        alone_r = self.ring.state_load(pr, fr)
        A_sr, A_rs, _ = self._operators(ps, pr)
        st_s, st_r = alone_s, alone_r
        it = 0
        for it in range(1, max_iter + 1):
            xs, xr = st_s.mesh_deflection_m, st_r.mesh_deflection_m
            st_s = self.sun.state_load(ps, fs, warm=st_s.force_N, gap_offset_m=A_sr @ st_r.force_N)
            st_r = self.ring.state_load(pr, fr, warm=st_r.force_N, gap_offset_m=A_rs @ st_s.force_N)
            if not (st_s.success and st_r.success):
                raise SolverError(f"chain solve failed at position {position}: {st_s.message}; {st_r.message}")
            if abs(st_s.mesh_deflection_m - xs) < tol * abs(xs) and abs(st_r.mesh_deflection_m - xr) < tol * abs(xr):
                break
        return ChainPoint(float(position), fs, fr, alone_s.mesh_deflection_m, alone_r.mesh_deflection_m,
                          st_s.mesh_deflection_m, st_r.mesh_deflection_m, it)

    def study(self, force_sun_N: float, positions: Sequence[float] | None = None) -> list[ChainPoint]:
        """Chain solves over a mesh cycle (default 16 positions)."""
        pos = np.arange(16) / 16 if positions is None else np.asarray(positions, float)
        return [self.solve(float(p), force_sun_N) for p in pos]

    def teeth_in_contact(self, position: float) -> tuple[set, set]:
        """Planet teeth loaded by the sun and by the ring at the nominal split of ``force`` (diagnostics: the two
        sets lie about half a planet turn apart)."""
        ps = float(position) - self._shift_sun
        pr = float(position) + self.ring_sun_phase - self._shift_ring
        su, ri = self.sun.setup(ps), self.ring.setup(pr)
        t_s = su.tooth_b if self._ip_sun == 1 else su.tooth_a
        t_r = ri.tooth_a if self._ip_ring == 0 else ri.tooth_b
        fin_s = np.isfinite(su.g0.reshape(len(su.pairs), -1).min(axis=1))
        fin_r = np.isfinite(ri.g0.reshape(len(ri.pairs), -1).min(axis=1))
        return set(int(t) for t in t_s[fin_s]), set(int(t) for t in t_r[fin_r])

    @staticmethod
    def summary(points: Sequence[ChainPoint]) -> dict:
        """Mean and largest relative deflection changes over ``points`` and the mean mesh stiffness change."""
        rs = np.array([p.relative_change_sun for p in points])
        rr = np.array([p.relative_change_ring for p in points])
        return {"positions": len(points), "force_sun_N": points[0].force_sun_N if points else math.nan,
                "sun_mean_rel": float(rs.mean()), "sun_max_abs_rel": float(np.max(np.abs(rs))),
                "ring_mean_rel": float(rr.mean()), "ring_max_abs_rel": float(np.max(np.abs(rr))),
                "sun_mean_change_m": float(np.mean([p.deflection_sun_chain_m - p.deflection_sun_alone_m
                                                    for p in points])),
                "ring_mean_change_m": float(np.mean([p.deflection_ring_chain_m - p.deflection_ring_alone_m
                                                     for p in points]))}
