"""Reduced elastic body of a gear: fixed-hub modes of the plane finite-element model at its flank samples and gauges.

The body is the finite-element model that gives the contact solver its far-field compliance
(:func:`hacgear_core.statics.fe.gear_compliance`: same mesh, material, web), here the replicated whole-gear mesh
(:class:`~hacgear_core.statics.fe.GearFE`) with the bore tied to the rigid hub, which is held fixed, plus the
consistent P2 mass matrix (:meth:`~hacgear_core.statics.fe.PlaneFE.mass_matrix`, density times the relative
thickness of each triangle).  Everything is per unit face width (thickness 1 m), as in
:class:`~hacgear_core.statics.fe.FlankCompliance`.

Fixed-interface (Craig-Bampton) modes ``K phi = omega^2 M phi`` with ``phi^T M phi = 1`` [m per sqrt(kg/m)] are
found by shift-invert Lanczos (``scipy.sparse.linalg.eigsh``, ``sigma = 0``) on the model's own factorisation.
For a body of face width ``b`` the physical modes are ``phi / sqrt(b)``.  Read out:

* ``flank_normal[k, t, i]``: displacement of mode ``k`` along the inward normal at sample ``i`` (the flank point
  itself, ``FlankCompliance.xy_m``) of tooth ``t``, so that ``sum_k phi phi^T / omega^2`` over all modes is the
  compliance of flank loads at flank points (the contact solver's far field reads it ``depth_m`` below the
  surface; the difference stays in the residual compliance of :mod:`hacgear_core.studies.direct_elastic`);
* ``gauge_strain[k, g, t]``: surface strain of mode ``k`` at gauge ``g`` of tooth ``t`` (the compliance's gauge
  read points);
* ``rotation_participation[k] = phi_k^T M rho`` with ``rho`` the rigid rotation of the body about its axis in
  the sense that closes the mesh on the loaded flank (``closing_sense`` +1: counter-clockwise in the gear frame):
  the modal force ``-L_k theta''`` of a hub that accelerates (Craig-Bampton coupling);
* rigid mass and inertia per unit width of the meshed body (bore to tooth tips).

Mode sets are cut at a frequency and completed to whole degenerate pairs (the mesh is exactly cyclically
symmetric, so harmonics ``0 < h < z/2`` come in pairs): a truncated set is then invariant under the rotation by
one tooth, and so is its modal compliance.  Results are cached on disk beside the compliance
(``cache_dir()/modes``), keyed by the compliance's cache key and the options here.
"""
from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import scipy.sparse.linalg as spla

from hacgear_core.errors import ModelError, SolverError
from hacgear_core.statics.fe import (
    ElasticMaterial,
    FlankCompliance,
    MeshOptions,
    build_gear_fe,
    cache_dir,
    read_npz,
    rotation,
    write_npz,
)

__all__ = ["BODYMODES_CODE_VERSION", "BodyModeOptions", "BodyModes", "gear_body_modes"]

#: bump when anything changes the numbers produced (part of every cache key)
BODYMODES_CODE_VERSION = "bodymodes-1"


@dataclass(frozen=True)
class BodyModeOptions:
    """Which fixed-hub modes to compute.

    Parameters
    ----------
    max_frequency_Hz : float
        Modes up to this frequency [Hz] are kept (then completed to whole degenerate pairs); 100..1e6 Hz.
    max_modes : int
        Upper limit of the number of modes (1..2000); a set that reaches it is reported (``message``).
    degenerate_rtol : float
        Relative frequency difference under which two modes count as one degenerate pair (1e-12..1e-2).
    """

    max_frequency_Hz: float = 40e3
    max_modes: int = 600
    degenerate_rtol: float = 1e-5

    def __post_init__(self):
        if not (isinstance(self.max_frequency_Hz, (int, float)) and 100.0 <= self.max_frequency_Hz <= 1e6):
            raise ModelError(f"max_frequency_Hz must be in [100, 1e6] Hz, got {self.max_frequency_Hz!r}")
        if not (isinstance(self.max_modes, int) and 1 <= self.max_modes <= 2000):
            raise ModelError(f"max_modes must be an integer in [1, 2000], got {self.max_modes!r}")
        if not (1e-12 <= self.degenerate_rtol <= 1e-2):
            raise ModelError(f"degenerate_rtol must be in [1e-12, 1e-2], got {self.degenerate_rtol!r}")


@dataclass(frozen=True)
class BodyModes:
    """Fixed-hub modes of one gear body at the samples of one :class:`FlankCompliance` (per unit face width).

    Attributes
    ----------
    success : bool
    message : str
    n_modes : int
    frequency_Hz : ndarray (n,)
        Natural frequencies of the fixed-hub body [Hz], ascending.
    flank_normal : ndarray (n, z, ns)
        Inward-normal displacement at the flank samples per unit modal coordinate [m / sqrt(kg/m)].
    gauge_strain : ndarray (n, g, z)
        Gauge strain per unit modal coordinate [1 / sqrt(kg/m)].
    rotation_participation : ndarray (n,)
        ``phi_k^T M rho`` [sqrt(kg/m) m]: modal participation of the rigid rotation (closing sense).
    translation_participation : ndarray (n, 2)
        ``phi_k^T M e_x``, ``phi_k^T M e_y`` [sqrt(kg/m)] (gear frame).
    mass_kg_per_m : float
        Mass of the meshed body per unit face width [kg/m].
    inertia_kgm2_per_m : float
        Polar inertia about the gear axis per unit face width [kg m^2/m].
    closing_sense : int
        +1 when a counter-clockwise rotation (gear frame) closes the mesh on the loaded flank, else -1.
    s_m : ndarray (ns,)
        Profile coordinates of the samples (those of the compliance) [m].
    side : str
    z : int
    gauge_names : tuple of str
    info : dict
        DOF, timings, cache key, options.
    """

    success: bool
    message: str
    n_modes: int
    frequency_Hz: np.ndarray
    flank_normal: np.ndarray
    gauge_strain: np.ndarray
    rotation_participation: np.ndarray
    translation_participation: np.ndarray
    mass_kg_per_m: float
    inertia_kgm2_per_m: float
    closing_sense: int
    s_m: np.ndarray
    side: str
    z: int
    gauge_names: tuple
    info: dict = field(default_factory=dict)

    _ARRAYS = ("frequency_Hz", "flank_normal", "gauge_strain", "rotation_participation",
               "translation_participation", "s_m")

    @property
    def omega_rad_s(self) -> np.ndarray:
        """Circular natural frequencies [rad/s], (n,)."""
        return 2.0 * np.pi * self.frequency_Hz

    def truncated(self, n: int) -> "BodyModes":
        """The ``n`` lowest modes (0 <= n <= n_modes); ``n`` should end a degenerate pair (:meth:`complete_counts`)."""
        n = int(n)
        if not 0 <= n <= self.n_modes:
            raise ModelError(f"n must be in [0, {self.n_modes}] modes, got {n}")
        return BodyModes(success=self.success, message=self.message, n_modes=n, frequency_Hz=self.frequency_Hz[:n],
                         flank_normal=self.flank_normal[:n], gauge_strain=self.gauge_strain[:n],
                         rotation_participation=self.rotation_participation[:n],
                         translation_participation=self.translation_participation[:n],
                         mass_kg_per_m=self.mass_kg_per_m, inertia_kgm2_per_m=self.inertia_kgm2_per_m,
                         closing_sense=self.closing_sense, s_m=self.s_m, side=self.side, z=self.z,
                         gauge_names=self.gauge_names, info=self.info)

    def complete_counts(self, rtol: float = 1e-5) -> np.ndarray:
        """Mode counts ``n`` (ascending, from 0) that do not split a degenerate pair."""
        f = self.frequency_Hz
        ok = [0] + [n for n in range(1, self.n_modes + 1)
                    if n == self.n_modes or abs(f[n] - f[n - 1]) > rtol * f[n]]
        return np.asarray(ok, dtype=int)

    def count_below(self, frequency_Hz: float) -> int:
        """Largest complete count (:meth:`complete_counts`) whose modes all lie at or below ``frequency_Hz``."""
        c = self.complete_counts()
        ok = [n for n in c if n == 0 or self.frequency_Hz[n - 1] <= frequency_Hz]
        return int(max(ok))

    def at(self, tooth: np.ndarray, s_m: np.ndarray) -> np.ndarray:
        """``(n, p)`` inward-normal modal displacements at profile coordinates ``s_m`` (p,) of teeth ``tooth``
        (p,) (gear numbering, taken modulo z), linear in ``s`` between samples (the interpolation of
        :meth:`FlankCompliance.far_field`)."""
        t = np.asarray(tooth, dtype=int) % self.z
        s = np.asarray(s_m, dtype=float)
        lo, hi = self.s_m[0], self.s_m[-1]
        ns = self.s_m.size
        u = (np.clip(s, lo, hi) - lo) * ((ns - 1) / (hi - lo))
        i0 = np.minimum(u.astype(int), ns - 2)
        f = u - i0
        return self.flank_normal[:, t, i0] * (1 - f) + self.flank_normal[:, t, i0 + 1] * f

    def save(self, path) -> None:
        """Write to an ``.npz`` file (arrays + JSON metadata)."""
        meta = dict(success=self.success, message=self.message, n_modes=self.n_modes,
                    mass_kg_per_m=self.mass_kg_per_m, inertia_kgm2_per_m=self.inertia_kgm2_per_m,
                    closing_sense=self.closing_sense, side=self.side, z=self.z,
                    gauge_names=list(self.gauge_names), info=self.info)
        write_npz(path, meta, {a: getattr(self, a) for a in self._ARRAYS})

    @classmethod
    def load(cls, path) -> "BodyModes":
        """Read a file written by :meth:`save`."""
        meta, arrays = read_npz(path, cls._ARRAYS)
        meta["gauge_names"] = tuple(meta["gauge_names"])
        return cls(**meta, **arrays)


def _key(compliance: FlankCompliance, density: float, options: BodyModeOptions) -> str:
    h = hashlib.sha256()
    h.update(BODYMODES_CODE_VERSION.encode())
    h.update(json.dumps(dict(compliance=compliance.info.get("cache_key"), density=density, options=asdict(options)),
                        sort_keys=True).encode())
    h.update(np.ascontiguousarray(compliance.xy_m).tobytes())
    return h.hexdigest()[:32]


def gear_body_modes(gg: Any, material: Any, density_kg_m3: float, compliance: FlankCompliance,
                    options: BodyModeOptions = BodyModeOptions(), cache: bool = True) -> BodyModes:
    """Fixed-hub modes of a gear body read at the samples and gauges of ``compliance``.

    Parameters
    ----------
    gg : GearGeometry-like
        The geometry ``compliance`` was computed from (bore, web, teeth).
    material : ElasticMaterial or model material
        Must be the compliance's (E, nu, plane).
    density_kg_m3 : float
        Density [kg/m^3].
    compliance : FlankCompliance
        From :func:`hacgear_core.statics.fe.gear_compliance`; its mesh options are reused.
    options : BodyModeOptions
    cache : bool
        Read/write the on-disk cache.

    Returns
    -------
    BodyModes
    """
    mat = ElasticMaterial.coerce(material, plane=compliance.plane)
    if not (math.isclose(mat.youngs_modulus_Pa, compliance.youngs_modulus_Pa, rel_tol=1e-12)
            and math.isclose(mat.poisson_ratio, compliance.poisson_ratio, rel_tol=1e-12)):
        raise ModelError("material (youngs_modulus_Pa, poisson_ratio) differs from the compliance's")
    rho = float(density_kg_m3)
    if not (np.isfinite(rho) and 100.0 <= rho <= 30000.0):
        raise ModelError(f"density_kg_m3 must be in [100, 30000] kg/m^3, got {density_kg_m3!r}")
    key = _key(compliance, rho, options)
    path = cache_dir() / "modes" / f"modes_{key}.npz"
    if cache and path.exists():
        try:
            return BodyModes.load(path)
        except Exception:
            pass  # unreadable cache entry: recompute
    mopts = MeshOptions(**compliance.info["options"])
    t0 = time.perf_counter()
    fe = build_gear_fe(gg, mat, mopts, method="full")
    t1 = time.perf_counter()
    Mfull = fe.mass_matrix(rho)
    free = fe.free
    Kff = fe.K[free][:, free].tocsr()
    Mff = Mfull[free][:, free].tocsr()

    def kinv(v):
        F = np.zeros(fe.n_dofs)
        F[free] = np.ravel(v)
        return fe.solve(F)[free]

    op = spla.LinearOperator(Kff.shape, matvec=kinv, dtype=float)
    w_max = 2 * np.pi * options.max_frequency_Hz
    k = min(8, options.max_modes + 2, Kff.shape[0] - 2)
    msg = "converged"
    while True:
        try:
            lam, vec = spla.eigsh(Kff, k=k, M=Mff, sigma=0.0, which="LM", OPinv=op, tol=1e-10)
        except (spla.ArpackNoConvergence, RuntimeError) as exc:
            raise SolverError(f"eigensolver failed: {exc}") from exc
        o = np.argsort(lam)
        lam, vec = lam[o], vec[:, o]
        if lam[-1] > w_max ** 2 * 1.05 or k >= options.max_modes + 2:
            break
        k = min(2 * k, options.max_modes + 2)
    om = np.sqrt(np.maximum(lam, 0.0))
    n = int(np.count_nonzero(om <= w_max))
    while 0 < n < len(om) and abs(om[n] - om[n - 1]) <= options.degenerate_rtol * om[n]:
        n += 1          # complete the degenerate pair
    if n > options.max_modes:
        n = options.max_modes
        msg = f"max_modes = {options.max_modes} reached below max_frequency_Hz = {options.max_frequency_Hz:g} Hz"
    if n >= len(om):
        msg = "mode set reached the last computed mode: its degeneracy is unchecked"
    om, vec = om[:n], vec[:, :n]
    Phi = np.zeros((fe.n_dofs, n))
    Phi[free] = vec
    t2 = time.perf_counter()

    z = compliance.z
    ns = compliance.n_samples
    pts, dirs = [], []
    for t in range(z):
        R = rotation(2 * np.pi * t / z)
        pts.append(compliance.xy_m @ R.T)
        dirs.append(-compliance.normal @ R.T)
    pts, dirs = np.concatenate(pts), np.concatenate(dirs)
    D = (fe.displacement_operator(pts) @ Phi).reshape(len(pts), 2, n)
    flank = np.einsum("pc,pcn->np", dirs, D).reshape(n, z, ns)
    ng = len(compliance.gauge_names)
    gs = np.zeros((n, ng, z))
    if ng:
        tg = compliance.gauge_tangent
        ng_ = np.stack([tg[:, 1], -tg[:, 0]], axis=1)             # outward normal of each gauge
        q = compliance.gauge_xy_m - 2e-6 * ng_                      # the compliance's read points
        for t in range(z):
            R = rotation(2 * np.pi * t / z)
            gs[:, :, t] = (fe.strain_operator(q @ R.T, tg @ R.T) @ Phi).T
    X = fe.dof_locations
    cx = fe.dof_component == 0
    sense = int(np.sign(np.mean(compliance.normal[:, 1] * compliance.xy_m[:, 0]
                                - compliance.normal[:, 0] * compliance.xy_m[:, 1])))
    rho_rot = sense * np.where(cx, -X[1], X[0])
    ex, ey = cx.astype(float), (~cx).astype(float)
    Mr, Mx, My = Mfull @ rho_rot, Mfull @ ex, Mfull @ ey
    out = BodyModes(success=bool(n > 0), message=msg if n > 0 else "no mode below max_frequency_Hz", n_modes=n,
                    frequency_Hz=om / (2 * np.pi), flank_normal=flank, gauge_strain=gs,
                    rotation_participation=Phi.T @ Mr, translation_participation=np.stack([Phi.T @ Mx, Phi.T @ My], 1),
                    mass_kg_per_m=float(ex @ Mx), inertia_kgm2_per_m=float(sense * rho_rot @ Mr * sense),
                    closing_sense=sense, s_m=np.asarray(compliance.s_m, float), side=compliance.side, z=z,
                    gauge_names=tuple(compliance.gauge_names),
                    info=dict(cache_key=key, n_dofs=int(fe.n_dofs), n_free=int(fe.n_free), computed_modes=int(len(lam)),
                              options=asdict(options), density_kg_m3=rho, code_version=BODYMODES_CODE_VERSION,
                              timings_s=dict(build=t1 - t0, eigen=t2 - t1, readout=time.perf_counter() - t2)))
    if cache:
        try:
            out.save(path)
        except OSError:
            pass
    return out
