"""Three-dimensional finite-element influence of one gear tooth across its face (helical or spur), cached.

The 2D far field (:mod:`hacgear_core.statics.fe`) treats the face as rigid: a load anywhere on the face
deflects the whole face alike.  A real tooth is a plate: a load at one point deflects it over a width.
This module measures that from elasticity, once per gear and loaded flank:

* **Mesh.**  A sector of ``teeth`` teeth (default 3: the loaded tooth in the middle) and the rim down to
  ``rim_depth_modules`` modules below the root circle, meshed in the transverse plane with gmsh (size fields
  on flanks and fillets) and extruded across the gear's full face width with the helix (gmsh ``twist``: the
  section at axial coordinate ``zeta`` is turned by ``zeta tan(beta) / r``), in layers; prisms split into
  tetrahedra.  The bottom (rim cut) is held and the side cuts (mid root land of the outer teeth) are free;
  P2 tetrahedra (scikit-fem), one sparse Cholesky factorisation in a nested-dissection order
  (:mod:`hacgear_core.statics.cholesky`).  One tooth is not enough: its side cuts fall in the root land next to
  the fillets, where a free cut forces the hoop stress to zero, so the root-circle strain
  reads about a tenth of the whole gear's and the tooth is about 30 % too compliant at the tip (measured on
  helical_28_33, docs/helical.md); with neighbouring teeth the cuts are a tooth pitch away.
* **Influence coefficients.**  Unit loads along the inward 3D flank normal at a grid of ``n_s`` profile
  positions (the active flank) × ``n_z`` axial positions (gear face edge to edge) of the middle tooth;
  responses: the normal displacement at the same grid, read at the near-field depth ``depth`` below the
  surface as in 2D, and the surface strain along the profile tangent at each gauge radius at every axial
  grid position, on the loaded tooth and on the tooth one pitch before it.  Arrays ``disp[i_s, i_z, j_s, j_z]``
  [m/N] (load i, response j), ``strain[g, j_z, i_s, i_z]`` and ``strain_prev[g, j_z, i_s, i_z]`` [1/N].
* **Use.**  The contact solver keeps the 2D whole-gear far field (blank, neighbouring teeth) as the part
  uniform over the face, and adds :meth:`FaceInfluence.correction`, the 3D kernel minus its average over
  both axial positions (load and response): the face-wise distribution that the 2D model lacks, with a zero
  face average, so the 2D model's uniform-load compliance is kept exactly.

Cache: ``<cache_dir()>/fe3d/face_<key>.npz``, the key hashing every input and :data:`FE3D_CODE_VERSION`.
"""
from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Sequence

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from hacgear_core.errors import GeometryError, ModelError, SolverError
from hacgear_core.statics.cholesky import SparseCholesky, nested_dissection
from hacgear_core.statics.fe import (ElasticMaterial, Gauge, _boundary_pieces, _chord_inward, _gauge_location,
                                     _single_thread_blas, cache_dir, gmsh_model, length_scale, read_npz, write_npz)

__all__ = ["FE3D_CODE_VERSION", "Mesh3DOptions", "gear_mesh3d_options", "ToothSectorFE", "FaceInfluence",
           "face_influence", "material_of", "helical_flank_points", "influence_check"]

#: bump when anything changes the numbers produced (part of every cache key)
FE3D_CODE_VERSION = "fe3d-2"


@dataclass(frozen=True)
class Mesh3DOptions:
    """Discretisation of the 3D tooth sector and of its influence grid (lengths in m).

    ``flank_size_m`` element size on flanks and fillets; ``body_size_m`` far from them; ``layer_size_m`` target
    element length across the face (extrusion layers); ``teeth`` teeth in the sector (1, 3 or 5; the loaded
    tooth in the middle); ``rim_depth_modules``
    rim below the root circle [modules]; ``n_s`` profile positions and ``z_spacing_m`` axial spacing of the load
    grid; ``depth_m`` near-field reading depth (as the 2D far field; reduced to ``depth_fraction`` of the tooth
    chord near the tip)."""

    flank_size_m: float = 1.0e-3
    body_size_m: float = 3.0e-3
    fine_layer_m: float = 1.2e-3
    growth_length_m: float = 6.0e-3
    layer_size_m: float = 1.6e-3
    teeth: int = 3
    rim_depth_modules: float = 1.5
    n_s: int = 7
    z_spacing_m: float = 0.5e-3
    depth_m: float = 1.0e-3
    depth_fraction: float = 0.3
    n_per_flank: int = 60

    def __post_init__(self):
        for name in ("flank_size_m", "body_size_m", "fine_layer_m", "growth_length_m", "layer_size_m",
                     "z_spacing_m", "depth_m"):
            v = getattr(self, name)
            # the range covers the defaults scaled from m_n = 0.1 mm to 100 mm (scaled(0.02 .. 20)) and face layers
            # of a face width up to 2 m (gear_mesh3d_options)
            if not (isinstance(v, (int, float, np.floating)) and np.isfinite(v) and 1e-6 <= v <= 1.0):
                raise ModelError(f"Mesh3DOptions.{name} must be in [1e-6, 1] m, got {v!r}")
        if not (isinstance(self.teeth, (int, np.integer)) and self.teeth in (1, 3, 5)):
            raise ModelError(f"Mesh3DOptions.teeth must be 1, 3 or 5, got {self.teeth!r}")
        if not (0.5 <= self.rim_depth_modules <= 5.0):
            raise ModelError(f"Mesh3DOptions.rim_depth_modules must be in [0.5, 5], got {self.rim_depth_modules!r}")
        if not (isinstance(self.n_s, (int, np.integer)) and 3 <= self.n_s <= 40):
            raise ModelError(f"Mesh3DOptions.n_s must be an integer in [3, 40], got {self.n_s!r}")
        if not (0.05 <= self.depth_fraction <= 0.5):
            raise ModelError(f"Mesh3DOptions.depth_fraction must be in [0.05, 0.5], got {self.depth_fraction!r}")

    def refined(self, factor: float) -> "Mesh3DOptions":
        """Copy with element sizes and layer length divided by ``factor`` (> 0); the influence grid is kept."""
        if not factor > 0:
            raise ModelError(f"refinement factor must be > 0, got {factor!r}")
        return replace(self, flank_size_m=self.flank_size_m / factor, body_size_m=self.body_size_m / factor,
                       layer_size_m=self.layer_size_m / factor)

    def scaled(self, factor: float) -> "Mesh3DOptions":
        """Copy with every length (element sizes, fine layer, growth length, face layer length, axial spacing of the
        influence grid, reading depth) times ``factor`` (> 0) [-]: a gear of normal module ``m_n`` and face width
        ``b`` with ``scaled(m_n / 5 mm)`` has the elements, face layers and influence grid of the default model of a
        module-5 mm gear of face width ``b 5 mm / m_n``."""
        if not (isinstance(factor, (int, float, np.floating)) and np.isfinite(factor) and factor > 0):
            raise ModelError(f"length scale factor [-] must be a finite number > 0, got {factor!r}")
        return replace(self, flank_size_m=self.flank_size_m * factor, body_size_m=self.body_size_m * factor,
                       fine_layer_m=self.fine_layer_m * factor, growth_length_m=self.growth_length_m * factor,
                       layer_size_m=self.layer_size_m * factor, z_spacing_m=self.z_spacing_m * factor,
                       depth_m=self.depth_m * factor)


def gear_mesh3d_options(gear: Any, mode: str = "auto", face_slices: int = 21) -> Mesh3DOptions:
    """The :class:`Mesh3DOptions` statics uses for model gear ``gear`` under ``[statics] fe_lengths = mode``
    (:func:`hacgear_core.statics.fe.length_scale`): the defaults (absolute lengths); or, module-scaled, the defaults
    times m_n / 5 mm with the face discretisation following the face width ``b`` and the contact pattern's
    ``face_slices`` ``n``: face layers no shorter than ``b / n`` and axial influence-grid spacing no shorter than
    ``b / (2 n)`` (at most one layer and two grid intervals per face slice, the ratio of the shipped helical pair:
    11 slices on 7 / 10 layers and 20 / 32 grid intervals; a wide face, 360 mm at m_n 14 mm, would otherwise get 81
    layers and 259 grid planes)."""
    f = length_scale(gear, mode)
    if f is None:
        return Mesh3DOptions()
    o = Mesh3DOptions().scaled(f)
    if not (isinstance(face_slices, (int, np.integer)) and face_slices >= 1):
        raise ModelError(f"face_slices must be an integer >= 1, got {face_slices!r}")
    b = float(gear.face_width_m)
    w = b * (1.0 + 1e-9)            # the layer and interval counts (ceil of b over the length) come out exact
    return replace(o, layer_size_m=max(o.layer_size_m, w / face_slices),
                   z_spacing_m=max(o.z_spacing_m, w / (2 * face_slices)))


def material_of(gear: Any, plane: str = "stress") -> ElasticMaterial:
    """:class:`~hacgear_core.statics.fe.ElasticMaterial` of a model gear (3D: ``plane`` only labels it)."""
    return ElasticMaterial(gear.material.youngs_modulus_Pa, gear.material.poisson_ratio, plane)


def helical_flank_points(gg: Any, side: str, s_m: Any, zeta_m: Any, n_profile: int = 800):
    """Points [m] and outward unit 3D normals of the ``side`` flank of tooth 0 at profile coordinate ``s_m`` and
    axial coordinate ``zeta_m`` from the gear's mid-face (broadcast): the transverse profile turned by
    ``gg.section_rotation_rad(zeta)``; the normal of the helicoid is ``(n_t, -k (P × n_t)_z)`` normalised, with
    ``k = tan(beta)/r``.  Returns ``(X (...,3), N (...,3), T (...,3))``, ``T`` the profile tangent in the
    transverse plane."""
    prof = gg.flank(side, n_profile)
    ss = np.asarray(prof.s, float)
    o = np.argsort(ss)
    s = np.asarray(s_m, float)
    z = np.asarray(zeta_m, float)
    s, z = np.broadcast_arrays(s, z)
    x = np.interp(s, ss[o], np.asarray(prof.xy)[o, 0])
    y = np.interp(s, ss[o], np.asarray(prof.xy)[o, 1])
    nx = np.interp(s, ss[o], np.asarray(prof.normal)[o, 0])
    ny = np.interp(s, ss[o], np.asarray(prof.normal)[o, 1])
    nn = np.hypot(nx, ny)
    nx, ny = nx / nn, ny / nn
    k = float(np.tan(gg.helix_angle_rad)) / float(gg.pitch_radius_m)
    h = x * ny - y * nx
    N = np.stack([nx, ny, -k * h], axis=-1)
    N /= np.linalg.norm(N, axis=-1, keepdims=True)
    a = np.asarray(gg.section_rotation_rad(z), float)
    c, sn = np.cos(a), np.sin(a)
    X = np.stack([c * x - sn * y, sn * x + c * y, z], axis=-1)
    Nr = np.stack([c * N[..., 0] - sn * N[..., 1], sn * N[..., 0] + c * N[..., 1], N[..., 2]], axis=-1)
    T = np.stack([-c * ny - sn * nx, -sn * ny + c * nx, np.zeros_like(x)], axis=-1)
    return X, Nr, T


# ----------------------------------------------------------------------------- the 3D model
class ToothSectorFE:
    """Factorised 3D P2 model of a helical tooth sector (see the module docstring).

    Attributes: ``mesh`` (scikit-fem MeshTet), ``basis`` (vector P2), ``n_dofs``, ``timings_s``, ``rim_radius_m``,
    ``teeth`` (teeth in the sector).
    """

    def __init__(self, gg: Any, material: ElasticMaterial, options: Mesh3DOptions = Mesh3DOptions()):
        from skfem import Basis, ElementTetP2, ElementVector, MeshTet, asm
        from skfem.models.elasticity import lame_parameters, linear_elasticity

        if bool(getattr(gg, "internal", False)):
            raise GeometryError("the 3D tooth sector is implemented for external gears only")
        t0 = time.perf_counter()
        # how far outside the meshed sector a surface point may lie (projected onto it): 1 mm at the default or finer
        # sizes, 1.5 flank elements where module-scaled elements are larger (NREL stage 3, 2.8 mm elements and
        # 33 mm face layers: a tip corner 3.3 mm outside)
        fl = float(options.flank_size_m)
        self._outside_tol_m = 1e-3 if fl <= Mesh3DOptions.flank_size_m else 1.5 * fl
        P, T, r_cut = self._mesh(gg, options)
        t1 = time.perf_counter()
        d = P[T]
        vol = np.einsum("ij,ij->i", np.cross(d[:, 1] - d[:, 0], d[:, 2] - d[:, 0]), d[:, 3] - d[:, 0])
        if np.any(np.abs(vol) < 1e-22):
            raise GeometryError("gmsh produced degenerate tetrahedra in the 3D tooth sector")
        T[vol < 0] = T[vol < 0][:, [0, 2, 1, 3]]
        self.mesh = MeshTet(np.ascontiguousarray(P.T), np.ascontiguousarray(T.T))
        self._elem = ElementTetP2()
        self.basis = Basis(self.mesh, ElementVector(self._elem))
        lam, mu = lame_parameters(float(material.youngs_modulus_Pa), float(material.poisson_ratio))
        K = asm(linear_elasticity(lam, mu), self.basis).tocsr()
        t2 = time.perf_counter()
        r = np.hypot(*self.basis.doflocs[:2])
        fixed = r < r_cut + 1e-6 * r_cut
        self.free = np.flatnonzero(~fixed)
        K = K[self.free][:, self.free]
        # sparse Cholesky (one triangle, dense supernodal blocks) in a nested-dissection order: NREL stage 3's
        # pinion sector (112 539 free DOF) 134 M entries (1.07 GB), where SuperLU's LU (COLAMD) kept 155 M entries in
        # each of its two triangles (hacgear_core.statics.cholesky)
        try:
            with _single_thread_blas():
                self._chol = SparseCholesky(K, nested_dissection(K, self.basis.doflocs[:, self.free].T))
        except SolverError as exc:
            raise SolverError(f"factorisation of the 3D sector stiffness failed: {exc}") from exc
        del K
        t3 = time.perf_counter()
        self.n_dofs = int(self.basis.N)
        self.rim_radius_m = float(r_cut)
        self.teeth = int(options.teeth)
        self.timings_s = {"mesh": t1 - t0, "assemble": t2 - t1, "factorize": t3 - t2}
        tp = self.mesh.p[:, self.mesh.t]                         # (3, 4, T)
        A = np.stack([tp[:, 1] - tp[:, 0], tp[:, 2] - tp[:, 0], tp[:, 3] - tp[:, 0]], axis=-1)  # (3, T, 3)
        self._A = A.transpose(1, 0, 2)                           # (T, 3, 3) columns = edges
        self._Ainv = np.linalg.inv(self._A)
        self._p0 = tp[:, 0].T
        self._tree = cKDTree(tp.mean(axis=1).T)

    @staticmethod
    def _mesh(gg: Any, o: Mesh3DOptions):
        import gmsh

        z = int(gg.z)
        b = float(gg.face_width_m)
        k = float(np.tan(gg.helix_angle_rad)) / float(gg.pitch_radius_m)
        bnd = gg.tooth_boundary(int(o.n_per_flank))
        xy0, reg0, side0 = np.asarray(bnd.xy, float), np.asarray(bnd.region), np.asarray(bnd.side)
        keep = np.r_[True, np.linalg.norm(np.diff(xy0, axis=0), axis=1) > 1e-12]
        xy0, reg0, side0 = xy0[keep], reg0[keep], side0[keep]
        pts, regs, sides = [], [], []
        for j in range(-(o.teeth // 2), o.teeth // 2 + 1):
            a = 2 * np.pi * j / z
            R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
            sl = slice(1, None) if pts else slice(None)
            pts.append((xy0 @ R.T)[sl])
            regs.append(reg0[sl])
            sides.append(side0[sl])
        xy, reg, side = np.concatenate(pts), np.concatenate(regs), np.concatenate(sides)
        r_cut = float(gg.root_radius_m) - o.rim_depth_modules * float(gg.module_m)
        if r_cut <= 0.25 * float(gg.root_radius_m) or r_cut <= float(gg.bore_radius_m):
            r_cut = max(float(gg.bore_radius_m), 0.25 * float(gg.root_radius_m))
        a0 = -0.5 * b * k
        R0 = np.array([[np.cos(a0), -np.sin(a0)], [np.sin(a0), np.cos(a0)]])
        xy = xy @ R0.T
        nl = max(2, int(np.ceil(b / o.layer_size_m)))
        try:
            with gmsh_model("hacgear_sector3d") as geo:
                ptag = [geo.addPoint(x, y, -b / 2) for x, y in xy]
                curves = []
                for idx, _ in _boundary_pieces(xy, reg, side):
                    tags = [ptag[i] for i in idx]
                    curves.append(geo.addLine(tags[0], tags[1]) if len(tags) == 2 else geo.addSpline(tags))
                lo, hi = np.arctan2(xy[0, 1], xy[0, 0]), np.arctan2(xy[-1, 1], xy[-1, 0])
                pc = geo.addPoint(0.0, 0.0, -b / 2)
                hl = geo.addPoint(r_cut * np.cos(lo), r_cut * np.sin(lo), -b / 2)
                hr = geo.addPoint(r_cut * np.cos(hi), r_cut * np.sin(hi), -b / 2)
                cl, cr = geo.addLine(hl, ptag[0]), geo.addLine(hr, ptag[-1])
                arc = geo.addCircleArc(hr, pc, hl)
                surf = geo.addPlaneSurface([geo.addCurveLoop(curves + [-cr, arc, cl])])
                geo.synchronize()
                fld = gmsh.model.mesh.field
                fd = fld.add("Distance")
                fld.setNumbers(fd, "CurvesList", curves)
                fld.setNumber(fd, "Sampling", 300)
                ft = fld.add("Threshold")
                fld.setNumber(ft, "InField", fd)
                fld.setNumber(ft, "SizeMin", o.flank_size_m)
                fld.setNumber(ft, "SizeMax", o.body_size_m)
                fld.setNumber(ft, "DistMin", o.fine_layer_m)
                fld.setNumber(ft, "DistMax", o.fine_layer_m + o.growth_length_m)
                fld.setAsBackgroundMesh(ft)
                for key, v in (("Mesh.MeshSizeExtendFromBoundary", 0), ("Mesh.MeshSizeFromPoints", 0),
                               ("Mesh.MeshSizeFromCurvature", 0), ("Mesh.MeshSizeMax", o.body_size_m),
                               ("Mesh.Algorithm", 6)):
                    gmsh.option.setNumber(key, v)
                geo.twist([(2, surf)], 0, 0, 0, 0, 0, b, 0, 0, 1, b * k, numElements=[nl], recombine=False)
                geo.synchronize()
                gmsh.model.mesh.generate(3)
                ntags, coords, _ = gmsh.model.mesh.getNodes()
                _, enodes = gmsh.model.mesh.getElementsByType(4)
        except Exception as exc:  # gmsh raises plain Exception
            raise GeometryError(f"gmsh could not mesh the 3D tooth sector: {exc}") from exc
        coords = np.asarray(coords).reshape(-1, 3)
        lookup = np.full(int(np.max(ntags)) + 1, -1, dtype=np.int64)
        lookup[np.asarray(ntags, dtype=np.int64)] = np.arange(len(ntags))
        T = lookup[np.asarray(enodes, dtype=np.int64).reshape(-1, 4)]
        used = np.unique(T)
        remap = np.full(len(coords), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        return coords[used], remap[T], r_cut

    # -- operators
    def _locate(self, pts: np.ndarray):
        pts = np.atleast_2d(np.asarray(pts, float))
        kk = min(32, self.mesh.t.shape[1])
        _, idx = self._tree.query(pts, kk)
        X = np.einsum("nkij,nkj->nki", self._Ainv[idx], pts[:, None, :] - self._p0[idx])
        lam = np.concatenate([1 - X.sum(-1, keepdims=True), X], axis=-1)
        score = lam.min(-1)
        best = np.argmax(score, axis=1)
        rows = np.arange(len(pts))
        el, Xb, sc = idx[rows, best], X[rows, best], score[rows, best]
        out = sc < -1e-9
        if np.any(out):
            L = np.clip(lam[rows, best][out], 0.0, None)
            L /= L.sum(axis=1, keepdims=True)
            q = np.einsum("nv,nvd->nd", L, self.mesh.p[:, self.mesh.t[:, el[out]]].transpose(2, 1, 0))
            dist = np.linalg.norm(q - pts[out], axis=1)
            # points on the sector's surface are projected onto the nearest candidate element; up to 1 mm away
            # (measured on helical_28_33: a coast flank's tip corner at a face end lies 0.64 mm outside the meshed
            # sector on the wheel, 0.53 mm on the pinion with a coarse mesh; every drive-flank point lies within 0.5 mm)
            if np.any(dist > getattr(self, "_outside_tol_m", 1e-3)):
                raise GeometryError(f"point(s) lie outside the 3D tooth sector (by up to {dist.max():.3g} m)")
            Xb[out] = L[:, 1:]
        return el, Xb

    def displacement_operator(self, points_m: np.ndarray, directions: np.ndarray) -> sp.csr_matrix:
        """``(n, n_dofs)``: displacement along unit ``directions`` (n, 3) at ``points_m`` (n, 3)."""
        el, X = self._locate(points_m)
        d = np.asarray(directions, float)
        n = len(el)
        rows, cols, vals = [], [], []
        for i in range(10):
            phi, _ = self._elem.lbasis(X.T, i)
            for c in range(3):
                rows.append(np.arange(n))
                cols.append(self.basis.element_dofs[3 * i + c, el])
                vals.append(phi * d[:, c])
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(n, self.n_dofs))

    def strain_operator(self, points_m: np.ndarray, directions: np.ndarray) -> sp.csr_matrix:
        """``(n, n_dofs)``: normal strain ``t·eps·t`` along unit ``directions`` (n, 3) at ``points_m``."""
        el, X = self._locate(points_m)
        t = np.asarray(directions, float)
        t = t / np.linalg.norm(t, axis=1, keepdims=True)
        Ainv = self._Ainv[el]                                    # (n, 3, 3): ref = Ainv (x - p0)
        n = len(el)
        rows, cols, vals = [], [], []
        for i in range(10):
            _, dphi = self._elem.lbasis(X.T, i)                  # (3, n) reference gradient
            grad = np.einsum("nkj,kn->nj", Ainv, dphi)           # physical gradient
            dt = np.einsum("nj,nj->n", grad, t)
            for c in range(3):
                rows.append(np.arange(n))
                cols.append(self.basis.element_dofs[3 * i + c, el])
                vals.append(t[:, c] * dt)
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(n, self.n_dofs))

    def solve(self, F: np.ndarray) -> np.ndarray:
        """Displacements ``(n_dofs, m)`` for nodal loads ``F`` ``(n_dofs, m)`` (rim cut held)."""
        F = np.asarray(F, float)
        U = np.zeros_like(F)
        with _single_thread_blas():
            U[self.free] = self._chol.solve(F[self.free])
        return U


# ----------------------------------------------------------------------------- influence coefficients
@dataclass(frozen=True)
class FaceInfluence:
    """3D influence of one gear's loaded flank across the face (see the module docstring).

    ``s_m`` (ns,) profile coordinates (arc length from the tip, increasing), ``zeta_m`` (nz,) axial coordinates
    from the gear's mid-face (face edge to face edge), ``depth_m`` (ns,), ``disp`` (ns, nz, ns, nz) [m/N]
    normal displacement at the reading depth of response point (j_s, j_z) per unit normal force at load point
    (i_s, i_z), ``disp_mean`` (ns, ns) its average over both axial positions, ``strain`` (ng, nz, ns, nz) [1/N]
    profile-tangent surface strain at gauge g at axial grid position j_z per unit force at (i_s, i_z),
    ``strain_mean`` (ng, ns); ``strain_prev``, ``strain_prev_mean``: the same at the gauges of the tooth one pitch
    before the loaded one (response tooth - load tooth = -1: the tooth whose gauge shares the loaded tooth's
    compressed root land; zeros for a one-tooth sector, which has no neighbour); ``gauge_names``; ``info`` (mesh,
    timings, cache key)."""

    side: str
    face_width_m: float
    s_m: np.ndarray
    zeta_m: np.ndarray
    depth_m: np.ndarray
    disp: np.ndarray
    disp_mean: np.ndarray
    strain: np.ndarray
    strain_mean: np.ndarray
    strain_prev: np.ndarray
    strain_prev_mean: np.ndarray
    gauge_names: tuple
    info: dict = field(default_factory=dict)

    _ARRAYS = ("s_m", "zeta_m", "depth_m", "disp", "disp_mean", "strain", "strain_mean", "strain_prev",
               "strain_prev_mean")

    @staticmethod
    def _cell(grid: np.ndarray, v: np.ndarray):
        v = np.clip(np.asarray(v, float), grid[0], grid[-1])
        i = np.clip(np.searchsorted(grid, v, side="right") - 1, 0, grid.size - 2)
        return i, (v - grid[i]) / (grid[i + 1] - grid[i])

    def _aligned(self, grid: np.ndarray, v_load, v_resp):
        """Interpolation along one axis pair aligned with the diagonal: for each of the two grid nodes bracketing
        the load coordinate (weight ``w``), the response is read at the same offset from that node as from the
        load, so the peak of the kernel at coincident points is never smeared by the grid."""
        i, f = self._cell(grid, v_load)
        off = np.asarray(v_resp, float) - np.asarray(v_load, float)
        out = []
        for di, w in ((0, 1 - f), (1, f)):
            j, fj = self._cell(grid, grid[i + di] + off)
            out.append((i + di, w, j, fj))
        return out

    def kernel(self, s_load, z_load, s_resp, z_resp) -> np.ndarray:
        """3D normal compliance [m/N] between a load at (s_load, z_load) and the response at (s_resp, z_resp):
        piecewise linear on the grid, aligned with the diagonal in both axes (:meth:`_aligned`); broadcast."""
        s_load, z_load, s_resp, z_resp = np.broadcast_arrays(*(np.asarray(a, float) for a in
                                                               (s_load, z_load, s_resp, z_resp)))
        out = np.zeros(s_load.shape)
        for a, wa, c, fc in self._aligned(self.s_m, s_load, s_resp):
            for b, wb, d, fd in self._aligned(self.zeta_m, z_load, z_resp):
                for dc, wc in ((0, 1 - fc), (1, fc)):
                    for dd, wd in ((0, 1 - fd), (1, fd)):
                        out += wa * wb * wc * wd * self.disp[a, b, c + dc, d + dd]
        return out

    def mean(self, s_load, s_resp) -> np.ndarray:
        """Average of :meth:`kernel` over both axial positions [m/N] (aligned interpolation in s)."""
        s_load, s_resp = np.broadcast_arrays(np.asarray(s_load, float), np.asarray(s_resp, float))
        out = np.zeros(s_load.shape)
        for a, wa, c, fc in self._aligned(self.s_m, s_load, s_resp):
            out += wa * ((1 - fc) * self.disp_mean[a, c] + fc * self.disp_mean[a, c + 1])
        return out

    def correction(self, s_load, z_load, s_resp, z_resp) -> np.ndarray:
        """Face-wise 3D correction [m/N]: :meth:`kernel` minus its average over both axial positions."""
        return self.kernel(s_load, z_load, s_resp, z_resp) - self.mean(s_load, s_resp)

    def slice_correction(self, s_load, z_load, s_resp, z_resp, width_m: float, points: int = 3) -> np.ndarray:
        """:meth:`correction` averaged over two face slices of width ``width_m`` centred on ``z_load`` and
        ``z_resp`` (Gauss-Legendre, ``points`` per slice): the compliance between two slice loads, which the
        kernel's peak at coincident points makes differ from the value at the slice centres."""
        xi, w = np.polynomial.legendre.leggauss(int(points))
        xi, w = 0.5 * width_m * xi, 0.5 * w
        out = 0.0
        for xl, wl in zip(xi, w):
            for xr, wr in zip(xi, w):
                out = out + wl * wr * self.kernel(s_load, np.asarray(z_load) + xl, s_resp, np.asarray(z_resp) + xr)
        return out - self.mean(s_load, s_resp)

    def strain_correction(self, gauge: str, z_gauge: float, s_load, z_load, tooth: int = 0) -> np.ndarray:
        """Face-wise 3D correction [1/N] of the strain at ``gauge`` at axial coordinate ``z_gauge`` (gear frame) on
        the loaded tooth (``tooth`` 0) or on the tooth one pitch before it (``tooth`` -1)."""
        if gauge not in self.gauge_names:
            raise ModelError(f"no gauge {gauge!r} in the 3D face influence; gauges: {list(self.gauge_names)}")
        if tooth not in (0, -1):
            raise ModelError(f"tooth must be 0 (the loaded tooth) or -1 (the one before it), got {tooth!r}")
        g = self.gauge_names.index(gauge)
        S = (self.strain if tooth == 0 else self.strain_prev)[g]          # (nz_resp, ns, nz_load)
        d, fd = self._cell(self.zeta_m, np.asarray(z_gauge, float))
        a, fa = self._cell(self.s_m, s_load)
        b, fb = self._cell(self.zeta_m, z_load)
        out = np.zeros(np.shape(a))
        for dd, wd in ((0, 1 - fd), (1, fd)):
            for da, wa in ((0, 1 - fa), (1, fa)):
                for db, wb in ((0, 1 - fb), (1, fb)):
                    out += wd * wa * wb * S[d + dd, a + da, b + db]
        sm = self.strain_mean if tooth == 0 else self.strain_prev_mean
        mean = (1 - fa) * sm[g, a] + fa * sm[g, a + 1]
        return out - mean

    def save(self, path: str | os.PathLike) -> None:
        meta = dict(side=self.side, face_width_m=self.face_width_m, gauge_names=list(self.gauge_names),
                    info=self.info)
        write_npz(path, meta, {a: getattr(self, a) for a in self._ARRAYS})

    @classmethod
    def load(cls, path: str | os.PathLike) -> "FaceInfluence":
        meta, arrays = read_npz(path, cls._ARRAYS)
        return cls(side=meta["side"], face_width_m=meta["face_width_m"], gauge_names=tuple(meta["gauge_names"]),
                   info=meta["info"], **arrays)


def _face_average(z: np.ndarray) -> np.ndarray:
    """Trapezoid weights (sum 1) of an axial grid."""
    w = np.zeros(z.size)
    dz = np.diff(z)
    w[:-1] += dz / 2
    w[1:] += dz / 2
    return w / w.sum()


def _hash(gg, material, side, options, gauges, s_grid, zeta) -> str:
    h = hashlib.sha256()
    h.update(FE3D_CODE_VERSION.encode())
    bnd = gg.tooth_boundary(int(options.n_per_flank))
    for arr in (bnd.xy, bnd.region, bnd.side):
        h.update(np.ascontiguousarray(np.asarray(arr, dtype=float)).tobytes())
    prof = gg.flank(side, 800)
    for arr in (prof.xy, prof.normal, prof.s):
        h.update(np.ascontiguousarray(np.asarray(arr, dtype=float)).tobytes())
    h.update(json.dumps(dict(z=int(gg.z), b=float(gg.face_width_m), helix=float(gg.helix_angle_rad),
                             r=float(gg.pitch_radius_m), root=float(gg.root_radius_m), module=float(gg.module_m),
                             bore=float(gg.bore_radius_m), material=asdict(material), side=side,
                             options=asdict(options), gauges=[list(g) for g in gauges]),
                        sort_keys=True, default=float).encode())
    h.update(np.ascontiguousarray(s_grid).tobytes())
    h.update(np.ascontiguousarray(zeta).tobytes())
    return h.hexdigest()[:32]


def influence_grid(gg: Any, side: str, options: Mesh3DOptions) -> tuple[np.ndarray, np.ndarray]:
    """Load/response grid: ``n_s`` profile coordinates over the involute (tip corner to the lowest involute point)
    and the axial coordinates ``-b/2 .. b/2`` at about ``z_spacing_m``."""
    prof = gg.flank(side, 800)
    s, reg = np.asarray(prof.s, float), np.asarray(prof.region)
    inv = reg == 2
    if not np.any(inv):
        raise GeometryError(f"the {side} flank profile has no involute points")
    s_grid = np.linspace(s[inv].min(), s[inv].max(), options.n_s)
    b = float(gg.face_width_m)
    nz = max(3, int(np.ceil(b / options.z_spacing_m)) + 1)
    return s_grid, np.linspace(-b / 2, b / 2, nz)


def face_influence(gg: Any, material: Any, side: str, *, gauges: Sequence[tuple[str, str, float, float]] = (),
                   options: Mesh3DOptions | None = None, cache: bool = True, fe: Any = None) -> FaceInfluence:
    """3D face-wise influence coefficients of the ``side`` flank of gear ``gg`` (cached on disk).

    ``gauges``: ``(name, flank, radius_m, face_fraction)``; the strain at each gauge's radius is computed at every
    axial grid position (the face fraction only selects where the solver reads it).  ``fe``: reuse a built
    :class:`ToothSectorFE` (no caching then); or a callable without arguments returning one (it does not depend on
    the flank), called only when the on-disk cache does not hold the result, which is then cached (both flanks, one
    build: :func:`hacgear_core.statics.contact.prebuild_compliances`)."""
    if side not in ("drive", "coast"):
        raise ModelError(f"side must be 'drive' or 'coast', got {side!r}")
    options = options or Mesh3DOptions()
    mat = ElasticMaterial.coerce(material)
    gauges = tuple((str(n), str(f), float(r), float(ff)) for n, f, r, ff in gauges)
    gauge_sig = tuple((n, f, r) for n, f, r, _ in gauges)
    s_grid, zeta = influence_grid(gg, side, options)
    key = _hash(gg, mat, side, options, gauge_sig, s_grid, zeta)
    path = cache_dir() / "fe3d" / f"face_{key}.npz"
    lazy = fe is not None and not isinstance(fe, ToothSectorFE)
    if cache and (fe is None or lazy) and path.exists():
        try:
            return FaceInfluence.load(path)
        except Exception:
            pass  # unreadable cache entry: recompute
    g_loc = [_gauge_location(gg, Gauge(n, f, r), 800) for n, f, r, _ in gauges]   # fails early on a bad gauge
    t0 = time.perf_counter()
    model = fe() if lazy else fe if fe is not None else ToothSectorFE(gg, mat, options)
    t1 = time.perf_counter()
    S, Z = np.meshgrid(s_grid, zeta, indexing="ij")                   # (ns, nz)
    X, N, _ = helical_flank_points(gg, side, S, Z)
    poly = np.asarray(gg.tooth_boundary(int(options.n_per_flank)).xy, dtype=float)
    prof = gg.flank(side, 800)
    ps = np.asarray(prof.s, float)
    o = np.argsort(ps)
    xy2 = np.stack([np.interp(s_grid, ps[o], np.asarray(prof.xy)[o, c]) for c in (0, 1)], axis=1)
    n2 = np.stack([np.interp(s_grid, ps[o], np.asarray(prof.normal)[o, c]) for c in (0, 1)], axis=1)
    n2 /= np.linalg.norm(n2, axis=1, keepdims=True)
    depth = np.minimum(options.depth_m, options.depth_fraction * _chord_inward(xy2, n2, poly))
    Xf, Nf = X.reshape(-1, 3), N.reshape(-1, 3)
    L = model.displacement_operator(Xf, -Nf)                         # loads along the inward normal
    U = model.solve(L.T.toarray())
    R = model.displacement_operator(Xf - np.repeat(depth, zeta.size)[:, None] * Nf, -Nf)
    D = (R @ U).T.reshape(s_grid.size, zeta.size, s_grid.size, zeta.size)
    w = _face_average(zeta)
    D_mean = np.einsum("azcd,z,d->ac", D, w, w)
    strain = np.zeros((2, len(gauges), zeta.size, s_grid.size, zeta.size))
    for k, shift in enumerate((0, -1)):
        if shift != 0 and model.teeth < 3:
            continue                                                   # no neighbouring tooth in the sector
        for gi, (p, t, nn, _, _) in enumerate(g_loc):
            # the gauge point turned with the section at every axial grid position (and by a pitch for shift -1)
            a = np.asarray(gg.section_rotation_rad(zeta), float) + shift * 2.0 * np.pi / int(gg.z)
            c, sn = np.cos(a), np.sin(a)
            q = p - 2e-6 * nn
            pts = np.stack([c * q[0] - sn * q[1], sn * q[0] + c * q[1], zeta], axis=1)
            tt = np.stack([c * t[0] - sn * t[1], sn * t[0] + c * t[1], np.zeros_like(zeta)], axis=1)
            E = model.strain_operator(pts, tt) @ U                   # (nz_resp, ns*nz_load)
            strain[k, gi] = E.reshape(zeta.size, s_grid.size, zeta.size)
    strain_mean = np.einsum("kgzad,z,d->kga", strain, w, w)
    t2 = time.perf_counter()
    info = dict(cache_key=key, n_dofs=model.n_dofs, n_tets=int(model.mesh.t.shape[1]), options=asdict(options),
                rim_radius_m=model.rim_radius_m, timings_s=dict(model.timings_s, build_total=t1 - t0, solve=t2 - t1),
                code_version=FE3D_CODE_VERSION, gauges=[dict(name=n, flank=f, radius_m=r) for n, f, r, _ in gauges])
    out = FaceInfluence(side=side, face_width_m=float(gg.face_width_m), s_m=s_grid, zeta_m=zeta, depth_m=depth,
                        disp=D, disp_mean=D_mean, strain=strain[0], strain_mean=strain_mean[0],
                        strain_prev=strain[1], strain_prev_mean=strain_mean[1],
                        gauge_names=tuple(n for n, _, _, _ in gauges), info=info)
    if cache and (fe is None or lazy):
        try:
            out.save(path)
        except OSError:
            pass
    return out


def influence_check(fi: FaceInfluence, fe: ToothSectorFE, gg: Any, side: str = "drive") -> dict[str, dict]:
    """The influence coefficients ``fi`` against direct solves of the 3D model ``fe`` (the same one or a refined
    one) for two loads off the influence grid on the ``side`` flank of gear ``gg``: ``"point"`` (unit load at a
    profile position between grid nodes, z = 1.37 mm) and ``"contact_line"`` (nine points along an inclined line,
    z = -4 ... 4 mm, total 1 N).  Responses: the normal displacement at the near-field reading depth at 31 points
    along the face (z = -7.5 ... 7.5 mm, on the load's line).  Per load: ``under_load_rel`` (peak predicted /
    peak direct - 1), ``spread_rel`` (largest deviation along the face / peak direct), ``z_m``, ``direct_m``,
    ``predicted_m`` (31,)."""
    s_mid = 0.5 * (fi.s_m[2] + fi.s_m[3]) + 0.1e-3
    z_line = np.linspace(-7.5e-3, 7.5e-3, 31)
    loads = {"point": (np.array([s_mid]), np.array([1.37e-3]), np.array([1.0])),
             "contact_line": (s_mid + np.linspace(-2e-3, 2e-3, 9), np.linspace(-4e-3, 4e-3, 9), np.ones(9) / 9)}
    out = {}
    for name, (s_load, z_load, w) in loads.items():
        X, N, _ = helical_flank_points(gg, side, s_load, z_load)
        U = fe.solve((fe.displacement_operator(X, -N).T.toarray() * w).sum(axis=1, keepdims=True))
        s_resp = np.interp(z_line, z_load, s_load) if s_load.size > 1 else np.full(z_line.size, s_load[0])
        Xr, Nr, _ = helical_flank_points(gg, side, s_resp, z_line)
        depth = np.interp(s_resp, fi.s_m, fi.depth_m)
        direct = (fe.displacement_operator(Xr - depth[:, None] * Nr, -Nr) @ U).ravel()
        pred = np.array([np.sum(w * fi.kernel(s_load, z_load, sr, zr)) for sr, zr in zip(s_resp, z_line)])
        out[name] = dict(under_load_rel=float(pred.max() / direct.max() - 1),
                         spread_rel=float(np.abs(pred - direct).max() / direct.max()),
                         z_m=z_line, direct_m=direct, predicted_m=pred)
    return out
