"""Static contact of a helical (or spur) mesh across its face: slices with helix phase, mesh twist, 3D
normals, elastic coupling between slices, generalized forces on both gears (dissertation Sections 5.2-5.3).

The face overlap is cut into ``face_slices`` transverse slices.  Slice ``j`` at axial coordinate
``Z_j = Z_ref + zeta_j`` (``Z_ref`` the middle of the overlap, the *reference plane*) is the transverse
picture of the spur solver (:class:`~hacgear_core.statics.contact.MeshContactSolver`, whose kinematics,
flanks, candidate search, LCP and near-field Newton iteration are reused) at the shifted mesh position

    tau_j = tau + k_a zeta_j z_a / (2 pi),      k_a = tan(beta_a) / r_a   (section rotation per metre),

i.e. the contact lines run across the face.  Each candidate contact (tooth pair x slice) gets

* its 3D contact normal ``n = (n_t, -k_a h_a) / sqrt(1 + k_a^2 h_a^2)`` (``n_t`` the transverse normal,
  ``h_a`` its moment arm about gear_a's axis; ``|n_z| = sin(beta_b)`` on the involute);
* the normal gap ``g = g_t cos(phi)`` (``phi`` the normal's inclination to the transverse plane; tip relief and
  lead crowning are transverse-plane flank deviations, ISO 21771) and the Hertz near field of a line contact
  inclined at ``phi`` (line load ``F cos(phi) / b_s``, normal-section radii ``R_t / cos(phi)``);
* the rigid approach per unit **mesh deflection** ``x`` (``lam``) and per unit **mesh twist** ``gamma``
  (``mu``), the two generalized coordinates defined below.

Definitions (fixing dissertation Eq. 5.4; ``docs/helical.md``)
--------------------------------------------------------------
Global frame: ``x`` along the line of centres (gear_a's axis to gear_b's), ``z`` along the axes (the model's
axial coordinate), ``y = z × x``; gear centres ``O_g`` on the axes in each gear's mid-face plane.  DOF of gear
``g``: translation ``u_g`` and small rotation ``theta_g`` (about ``O_g``), ``q = [u_a, theta_a, u_b, theta_b]``
(12).  ``e2`` = transverse line-of-action direction (force on gear_b), ``e3 = z``, ``e1 = e2 × e3`` (normal to
the plane of action).  ``P_ref`` = the pitch point in the reference plane, ``n_ref`` the involute normal there.

* mesh deflection ``x = r_mesh · q``: the relative rigid displacement of the two gears at ``P_ref`` along
  ``n_ref``; ``r_mesh = [n_ref, (P_ref - O_a) × n_ref, -n_ref, -(P_ref - O_b) × n_ref]``;
* mesh twist ``gamma = r_twist · q = (theta_a - theta_b) · e1``: relative rotation about the normal to the
  plane of action; ``r_twist = [0, e1, 0, -e1]``.

For involute contacts (normal ``n_ref``, point in the plane of action) the rigid closure of any ``q`` is exactly
``x + gamma (S sin(beta_b) - zeta cos(beta_b))`` (``S``, ``zeta``: position of the point along ``e2`` and ``e3``
from ``P_ref``), so the generalized contact force is exactly ``f_d = W r_mesh + M r_twist`` with the mesh force
``W = sum lam_i F_i`` and the twist moment ``M = sum mu_i F_i``.  The static solve turns the hubs about their
axes in equal shares for ``x`` (the spur solver's rule) and about the axis through ``P_ref`` along ``e1`` for
``gamma``; ``f_d`` is also summed contact by contact (:attr:`HelicalSetup.jac`), and the residual of the
identity reported.

Far field across the face (``face_coupling``): ``rigid`` (2D plane-stress gear of the overlap width, uniform
over the face), ``slices`` (independent thin slices), ``elastic`` (each gear's 2D far field over its own face
width plus the face-wise 3D correction of :mod:`hacgear_core.statics.fe3d`: a load at one point deflects the
tooth over a width).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Sequence

import numpy as np

from hacgear_core.errors import ModelError, SolverError
from hacgear_core.model import Model
from hacgear_core.kinds import load_model
from hacgear_core.statics import fe3d
from hacgear_core.statics.contact import (ContactOptions, ContactState, MeshContactSolver, default_contact_options,
                                          make_mesh_solver, mesh_solver_inputs, split_pressure, spur_twist_axis)
from hacgear_core.statics.contract import StaticSolution
from hacgear_core.statics.nearfield import halfspace_approach_hertz

__all__ = ["HelicalSetup", "MeshFrame", "HelicalMeshContactSolver", "make_helical_solver", "make_solver",
           "needs_face_resolving_solver"]


@dataclass(frozen=True)
class MeshFrame:
    """The mesh frame and the generalized coordinates of a mesh (global frame of the module docstring, SI).

    ``e1, e2, e3`` (3,), ``P_ref`` (3,) [m], ``n_ref`` (3,), ``O`` ((3,), (3,)) gear centres [m],
    ``r_mesh`` (12,) [m/m, m/rad], ``r_twist`` (12,), ``base_helix_angle_rad`` (of the loaded flanks, signed,
    positive when the contact normal on gear_b has +z component), ``lever_arm_m`` (torque on each gear per unit
    mesh force for involute contact: ``r_b cos(beta_b)``), ``reference_plane_z_m``."""

    e1: np.ndarray
    e2: np.ndarray
    e3: np.ndarray
    P_ref: np.ndarray
    n_ref: np.ndarray
    O: tuple[np.ndarray, np.ndarray]
    r_mesh: np.ndarray
    r_twist: np.ndarray
    base_helix_angle_rad: float
    lever_arm_m: tuple[float, float]
    reference_plane_z_m: float

    def projections(self, q: np.ndarray) -> tuple[float, float]:
        """``(x, gamma)`` of the 12 DOF ``q`` (m, rad)."""
        q = np.asarray(q, float)
        return float(self.r_mesh @ q), float(self.r_twist @ q)


@dataclass(frozen=True)
class HelicalSetup:
    """Everything that depends on the mesh position (and twist) at one position.  ``n`` candidates = pairs x
    slices (pair-major); arrays (n,) unless noted.  Points and normals in the global frame."""

    position: float
    twist_rad: float
    pairs: np.ndarray            # (Np,)
    g0: np.ndarray               # normal gap at x = 0 and this twist [m] (inf: cannot touch)
    g0_zero_twist: np.ndarray
    lam: np.ndarray              # normal closure per unit mesh deflection [-]
    mu: np.ndarray               # normal closure per unit mesh twist [m/rad]
    C_lin: np.ndarray            # (n, n) [m/N]
    pair_index: np.ndarray
    slice_index: np.ndarray
    slice_width_m: float
    s_a: np.ndarray
    s_b: np.ndarray
    roll_b_rad: np.ndarray
    cos_phi: np.ndarray          # cosine of the normal's inclination to the transverse plane
    R_eff: np.ndarray            # Hertz radius in the normal section [m]
    point: np.ndarray            # (n, 3)
    normal: np.ndarray           # (n, 3) from gear_a into gear_b
    tooth_a: np.ndarray          # (Np,)
    tooth_b: np.ndarray
    tip_contact: np.ndarray
    depth_a: np.ndarray
    depth_b: np.ndarray
    zeta_m: np.ndarray           # axial coordinate from the reference plane [m]
    jac: np.ndarray              # (n, 12) d(closure)/dq per candidate
    strain_op: dict = field(default_factory=dict)   # gauge -> (Nw, n) strain per unit normal force [1/N]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.cross(a, b)


class HelicalMeshContactSolver(MeshContactSolver):
    """Static contact solver of one mesh across its face (helical; helix angle 0 = spur with face physics).

    Extra parameters over :class:`~hacgear_core.statics.contact.MeshContactSolver`
    ----------------------------------------------------------------------------
    helix_k_per_m : float
        Section rotation of gear_a per metre of axial coordinate, ``tan(beta_a)/r_a`` [rad/m] (physical,
        counter-clockwise seen from +z positive).
    helix_k_b_per_m : float
        Same for gear_b (must be conjugate: ``k_b = -k_a z_a / z_b`` external, ``+k_a z_a / z_b`` internal).
    z_centre_m : float
        Reference plane ``Z_ref`` (middle of the face overlap) [m].
    gear_axial_m, gear_face_width_m : (float, float)
        Mid-face axial position and face width of each gear [m].
    gauge_axial_m : sequence of float
        Axial coordinate of each gauge (order of ``gauges``) [m].
    face_influence : (FaceInfluence | None, FaceInfluence | None)
        3D face-wise influence of each gear (``face_coupling="elastic"``).
    """

    _resolves_face = True

    def __init__(self, *, helix_k_per_m: float, helix_k_b_per_m: float, z_centre_m: float,
                 gear_axial_m: tuple[float, float], gear_face_width_m: tuple[float, float],
                 gauge_axial_m: Sequence[float] = (), face_influence: tuple[Any, Any] = (None, None), **kw):
        super().__init__(**kw)
        za, zb = self.teeth
        if not (math.isfinite(helix_k_per_m) and math.isfinite(helix_k_b_per_m)):
            raise ModelError("helix angles must be finite")
        expect = (1.0 if self.internal else -1.0) * helix_k_per_m * za / zb
        if abs(helix_k_b_per_m - expect) > 1e-6 * max(abs(helix_k_per_m), 1e-9):
            raise SolverError(
                f"mesh '{self.mesh_name}': the helices do not mesh: gear_b needs tan(beta_b) = "
                f"{'+' if self.internal else '-'}tan(beta_a) (equal and {'same' if self.internal else 'opposite'} "
                f"hand), got section rotations {helix_k_per_m:.6g} and {helix_k_b_per_m:.6g} rad/m")
        if self.options.face_coupling == "elastic" and any(f is None for f in face_influence):
            raise SolverError("face_coupling 'elastic' needs the 3D face influence of both gears")
        self.k_phys = float(helix_k_per_m)
        self._sy = -1.0 if self._mirror else 1.0          # canonical -> physical: y flips when mirrored
        self.k_canon = self.k_phys * self._sy               # a mirror reverses the hand of the helix
        self.z_centre_m = float(z_centre_m)
        self.gear_axial_m = tuple(float(v) for v in gear_axial_m)
        self.gear_face_width_m = tuple(float(v) for v in gear_face_width_m)
        self.gauge_axial_m = tuple(float(v) for v in gauge_axial_m)
        if len(self.gauge_axial_m) != len(self.gauges):
            raise ModelError("gauge_axial_m needs one axial coordinate per gauge")
        self.face_influence = tuple(face_influence)
        self.slice_phase = self.k_canon * self.slice_z_m * za / (2 * math.pi)   # (ns,) mesh cycles
        self._geo_cache: dict[float, Any] = {}
        self.frame = self._mesh_frame()
        self.lever_arm_m = self.frame.lever_arm_m
        cb = math.cos(self.frame.base_helix_angle_rad)
        self.description = (self.description + f"; helical solver, base helix {math.degrees(self.frame.base_helix_angle_rad):.4g} deg, "
                            f"face coupling {self.options.face_coupling}; x, W normal to the flank (x_t = x / {cb:.6f})")

    # ------------------------------------------------------------------ frame and definitions
    def _to_phys(self, v: np.ndarray) -> np.ndarray:
        out = np.array(v, dtype=float, copy=True)
        out[..., 1] *= self._sy
        return out

    def _normal3(self, c2: np.ndarray, n2: np.ndarray) -> np.ndarray:
        """3D unit normal (canonical) of gear_a's helicoid at transverse point ``c2`` with transverse normal ``n2``."""
        h = c2[..., 0] * n2[..., 1] - c2[..., 1] * n2[..., 0]     # moment arm about gear_a's axis (O_a = 0)
        nz = -self.k_canon * h
        n = np.concatenate([n2, nz[..., None]], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def _mesh_frame(self) -> MeshFrame:
        ref = self._pair_geometry(0, self.frame_angles(0.0))
        if ref is None:
            raise SolverError(f"mesh '{self.mesh_name}': the reference pair does not touch at position 0")
        # the involute normal at the pitch point: tangent to the base circle (exact; the sampled flank only gives
        # the side of the line of action)
        num = np.asarray(ref["normal"], float)
        cos_aw = self.base_radius_m[0] / self.operating_pitch_radius_m[0]
        n2 = np.array([math.copysign(math.sqrt(max(0.0, 1.0 - cos_aw * cos_aw)), num[0]), math.copysign(cos_aw, num[1])])
        P2 = np.array([self.operating_pitch_radius_m[0], 0.0])
        n3c = self._normal3(P2, n2)
        n_ref = self._to_phys(n3c)
        P_ref = self._to_phys(np.array([P2[0], P2[1], self.z_centre_m]))
        e2 = self._to_phys(np.array([n2[0], n2[1], 0.0]))
        e2 /= np.linalg.norm(e2)
        e3 = np.array([0.0, 0.0, 1.0])
        e1 = _cross(e2, e3)
        O = (np.array([0.0, 0.0, self.gear_axial_m[0]]),
             self._to_phys(np.array([self._O[1][0], self._O[1][1], self.gear_axial_m[1]])))
        r_mesh = np.concatenate([n_ref, _cross(P_ref - O[0], n_ref), -n_ref, -_cross(P_ref - O[1], n_ref)])
        r_twist = np.concatenate([np.zeros(3), e1, np.zeros(3), -e1])
        beta_b = math.asin(float(np.clip(n_ref[2], -1.0, 1.0)))
        cb = math.cos(beta_b)
        return MeshFrame(e1=e1, e2=e2, e3=e3, P_ref=P_ref, n_ref=n_ref, O=O, r_mesh=r_mesh, r_twist=r_twist,
                         base_helix_angle_rad=beta_b,
                         lever_arm_m=(self.base_radius_m[0] * cb, self.base_radius_m[1] * cb),
                         reference_plane_z_m=self.z_centre_m)

    # ------------------------------------------------------------------ set-up per position
    def _geo(self, u: float):
        """Pair geometry of the pair at phase ``u`` (mesh position minus pair offset), cached: the spur
        picture of pair ``p`` at position ``tau`` equals pair 0's at ``tau - p`` in global coordinates."""
        key = round(u, 12)
        hit = self._geo_cache.get(key, False)
        if hit is False:
            hit = self._pair_geometry(0, self.frame_angles(u))
            if len(self._geo_cache) > 20000:
                self._geo_cache.clear()
            self._geo_cache[key] = hit
        return hit

    def setup(self, position: float, twist_rad: float = 0.0) -> HelicalSetup:
        """Kinematics, gaps, compliance and operators at ``position`` [mesh cycles] and mesh twist [rad]."""
        position = float(position)
        twist = float(twist_rad)
        if not math.isfinite(position):
            raise SolverError(f"position must be finite (mesh cycles), got {position!r}")
        if not math.isfinite(twist) or abs(twist) > 0.01:
            raise SolverError(f"mesh twist must be finite and within +-0.01 rad, got {twist_rad!r}")
        key = round(position, 12)
        base = self._setup_cache.get(key)
        if base is None:
            base = self._build_setup(position)
            if len(self._setup_cache) > 256:
                self._setup_cache.clear()
            self._setup_cache[key] = base
        if twist == 0.0:
            return base
        return replace(base, twist_rad=twist, g0=base.g0_zero_twist - base.mu * twist)

    def _build_setup(self, position: float) -> HelicalSetup:
        W = self.options.pair_window
        ns = self.options.face_slices
        ph = position + self.slice_phase
        lo, hi = int(math.floor(ph.min() + 0.5)), int(math.floor(ph.max() + 0.5))
        pairs = np.arange(lo - W - 1, hi + W + 2)
        npair = pairs.size
        pair_index = np.repeat(np.arange(npair), ns)
        slice_index = np.tile(np.arange(ns), npair)
        n = npair * ns
        u = ph[slice_index] - pairs[pair_index]
        geo = [self._geo(float(v)) for v in u]
        ok = np.array([g is not None for g in geo])
        get = lambda k, d: np.array([g[k] if g is not None else d for g in geo], dtype=float)  # noqa: E731
        fa, fb = self._flank
        s_a = np.clip(np.nan_to_num(get("s_a", np.nan), nan=fa.s_min), fa.s_min, fa.s_max)
        s_b = np.clip(np.nan_to_num(get("s_b", np.nan), nan=fb.s_min), fb.s_min, fb.s_max)
        c2 = np.array([g["point"] if g is not None else [self.operating_pitch_radius_m[0], 0.0] for g in geo])
        n2 = np.array([g["normal"] if g is not None else [0.0, 1.0] for g in geo])
        n3c = self._normal3(c2, n2)
        cos_phi = np.linalg.norm(n3c[:, :2], axis=1)
        zeta = self.slice_z_m[slice_index]
        crown = self.crowning_slices_m.sum(axis=0)[slice_index]
        g_t = np.where(ok, get("gap", np.inf), np.inf)
        g0 = np.where(ok, (g_t + crown) * cos_phi, np.inf)
        lam = get("lam", 1.0) * cos_phi / math.cos(self.frame.base_helix_angle_rad)
        # 3D points and normals (physical frame)
        point = self._to_phys(np.column_stack([c2, self.z_centre_m + zeta]))
        normal = self._to_phys(n3c)
        Oa, Ob = self.frame.O
        ra, rb = point - Oa, point - Ob
        jac = np.hstack([normal, _cross(ra, normal), -normal, -_cross(rb, normal)])
        mu = np.einsum("i,ni->n", self.frame.e1, _cross(point - self.frame.P_ref, normal))
        tooth_a = np.array([self._actual_tooth(0, self._pair_sign[0] * int(p)) for p in pairs])
        tooth_b = np.array([self._actual_tooth(1, self._pair_sign[1] * int(p)) for p in pairs])
        C = self._compliance(pair_index, tooth_a, tooth_b, s_a, s_b, cos_phi, zeta)
        R_a, R_b = get("R_a", 1.0), get("R_b", 1.0)
        curv = 1.0 / R_a + 1.0 / R_b
        R_eff = 1.0 / np.maximum(curv, 1.0) / cos_phi
        setup = HelicalSetup(
            position=position, twist_rad=0.0, pairs=pairs, g0=g0, g0_zero_twist=g0, lam=lam, mu=mu, C_lin=C,
            pair_index=pair_index, slice_index=slice_index, slice_width_m=self.slice_width_m, s_a=s_a, s_b=s_b,
            roll_b_rad=get("roll_b", np.nan), cos_phi=cos_phi, R_eff=R_eff, point=point, normal=normal,
            tooth_a=tooth_a, tooth_b=tooth_b, tip_contact=np.array([bool(g["tip"]) if g else False for g in geo]),
            depth_a=np.asarray(self.compliance[0].depth(s_a), float),
            depth_b=np.asarray(self.compliance[1].depth(s_b), float), zeta_m=zeta, jac=jac)
        return replace(setup, strain_op=self._strain_op(setup, self.tooth_offsets))

    def _compliance(self, pair_index, tooth_a, tooth_b, s_a, s_b, cos_phi, zeta) -> np.ndarray:
        """Linear normal compliance between all candidates [m/N] (far field; the Hertz self-approach of each
        loaded contact is added by the Newton iteration)."""
        n = pair_index.size
        coupling = self.options.face_coupling
        C = np.zeros((n, n))
        for g, (fc, teeth, s) in enumerate(((self.compliance[0], tooth_a, s_a), (self.compliance[1], tooth_b, s_b))):
            t = teeth[pair_index]
            dk = (t[:, None] - t[None, :]) % self.teeth[g]          # response tooth - load tooth
            Cg = np.zeros((n, n))
            for k in np.unique(dk):
                ii, jj = np.nonzero(dk == k)
                Cg[ii, jj] = fc.far_field(int(k), s[jj], s[ii])
            if coupling == "elastic":
                Cg /= self.gear_face_width_m[g]
                fi = self.face_influence[g]
                zg = self.z_centre_m + zeta - self.gear_axial_m[g]       # axial coordinate in the gear's frame
                same = dk == 0
                ii, jj = np.nonzero(same)
                Cg *= np.outer(cos_phi, cos_phi)
                Cg[ii, jj] += fi.slice_correction(s[jj], zg[jj], s[ii], zg[ii], self.slice_width_m)
            else:
                Cg *= np.outer(cos_phi, cos_phi)
                Cg /= self.face_width_m
            C += Cg
        if coupling == "slices":
            si = np.arange(n) % self.options.face_slices
            C = np.where(si[:, None] == si[None, :], C * self.options.face_slices, 0.0)
        return 0.5 * (C + C.T)

    def _strain_op(self, s: HelicalSetup, offsets: np.ndarray) -> dict[str, np.ndarray]:
        """gauge -> (len(offsets), n) strain on the tooth of each offset per unit normal force of each candidate."""
        out = {}
        coupling = self.options.face_coupling
        ns = self.options.face_slices
        for (gear, gi, name), z_g in zip(self.gauges, self.gauge_axial_m):
            fc = self.compliance[gear]
            z = self.teeth[gear]
            t_load = (s.tooth_a if gear == 0 else s.tooth_b)[s.pair_index]
            s_load = s.s_a if gear == 0 else s.s_b
            resp = np.array([self._actual_tooth(gear, self._pair_sign[gear] * int(k)) for k in offsets])
            dk = (resp[:, None] - t_load[None, :]) % z
            M = np.zeros(dk.shape)
            for k in np.unique(dk):
                ii, jj = np.nonzero(dk == k)
                M[ii, jj] = fc.strain(gi, int(k), s_load[jj])
            M *= s.cos_phi[None, :]
            if coupling == "elastic":
                M /= self.gear_face_width_m[gear]
                fi = self.face_influence[gear]
                zl = self.z_centre_m + s.zeta_m - self.gear_axial_m[gear]
                for tooth, k in ((0, 0), (-1, z - 1)):        # the loaded tooth and the one before it
                    ii, jj = np.nonzero(dk == k)
                    M[ii, jj] += fi.strain_correction(name.split("/", 1)[1], z_g - self.gear_axial_m[gear],
                                                      s_load[jj], zl[jj], tooth=tooth)
            elif coupling == "slices":
                j = int(np.argmin(np.abs(self.slice_z_m - (z_g - self.z_centre_m))))
                M = np.where((s.slice_index == j)[None, :], M * ns / self.face_width_m, 0.0)
            else:
                M /= self.face_width_m
            out[name] = M
        return out

    # ------------------------------------------------------------------ near field (normal section)
    def _hertz(self, setup, w):
        """Half-width [m] and peak pressure [Pa] for ``w`` = force / slice width [N/m] (the contact-line load is
        ``w cos(phi)``, the normal-section radius ``R_eff``)."""
        wl = np.maximum(w, 0.0) * setup.cos_phi
        a = np.sqrt(4.0 * wl * setup.R_eff / (math.pi * self._E_star))
        p0 = np.sqrt(wl * self._E_star / (math.pi * setup.R_eff))
        return a, p0

    def _near_compliance(self, setup, w_eval):
        a, _ = self._hertz(setup, w_eval)
        (Ea, nua), (Eb, nub) = self.materials
        da = halfspace_approach_hertz(1.0, a, setup.depth_a, Ea, nua, self.plane)
        db = halfspace_approach_hertz(1.0, a, setup.depth_b, Eb, nub, self.plane)
        return (da + db) * setup.cos_phi / setup.slice_width_m

    # ------------------------------------------------------------------ solves
    def no_load_deflection(self, position: float, twist_rad: float = 0.0) -> float:
        s = self.setup(position, twist_rad)
        fin = np.isfinite(s.g0)
        if not np.any(fin):
            raise SolverError(f"mesh '{self.mesh_name}': no tooth pair can touch at position {position}")
        return float(np.min(s.g0[fin] / s.lam[fin]))

    def state_load(self, position: float, mesh_force_N: float, warm: np.ndarray | None = None,
                   twist_rad: float = 0.0) -> ContactState:
        W = float(mesh_force_N)
        if not (math.isfinite(W) and W >= 0):
            raise SolverError(f"mesh_force_N must be finite and >= 0 N, got {mesh_force_N!r}")
        return self._solve(self.setup(position, twist_rad), force=W, warm=warm)

    def state_deflection(self, position: float, mesh_deflection_m: float, warm: np.ndarray | None = None,
                         twist_rad: float = 0.0) -> ContactState:
        x = float(mesh_deflection_m)
        if not math.isfinite(x):
            raise SolverError(f"mesh_deflection_m must be finite, got {mesh_deflection_m!r}")
        return self._solve(self.setup(position, twist_rad), deflection=x, warm=warm)

    # ------------------------------------------------------------------ outputs
    def generalized_forces(self, st: ContactState) -> dict[str, Any]:
        """Mesh force ``W`` [N] (= sum lam F), twist moment ``M`` [N m] (= sum mu F), ``f_d`` (12,) (sum over the
        contacts of ``F d(closure)/dq``: minus the contact forces and moments on the gears, Eq. 5.1), the
        contact wrench on each gear about its centre ``[Fx, Fy, Fz, Mx, My, Mz]`` and the residual of
        ``f_d = W r_mesh + M r_twist`` relative to ``|f_d|``."""
        s = st.setup
        F = st.force_N
        fd = F @ s.jac
        W = float(s.lam @ F)
        M = float(s.mu @ F)
        ident = W * self.frame.r_mesh + M * self.frame.r_twist
        scale = max(float(np.linalg.norm(fd)), 1e-30)
        return dict(mesh_force_N=W, twist_moment_Nm=M, f_d=fd, wrench={self.gear_names[0]: -fd[:6],
                                                                          self.gear_names[1]: -fd[6:]},
                    identity_residual=float(np.linalg.norm(fd - ident)) / scale if np.any(F > 0) else 0.0)

    def pattern(self, st: ContactState) -> dict[str, np.ndarray]:
        """Contact pattern: load [N] and peak pressure [Pa] per (tooth offset, slice), slice axial coordinates
        (global) [m]."""
        s = st.setup
        ns = self.options.face_slices
        offs = self.tooth_offsets
        load = np.zeros((offs.size, ns))
        pres = np.zeros((offs.size, ns))
        pk = s.pairs[s.pair_index]
        for w, k in enumerate(offs):
            m = pk == k
            load[w, s.slice_index[m]] = st.force_N[m]
            pres[w, s.slice_index[m]] = st.peak_pressure_Pa[m]
        return dict(load_N=load, peak_pressure_Pa=pres, z_m=self.z_centre_m + self.slice_z_m)

    def pair_results(self, st: ContactState) -> dict[str, np.ndarray]:
        """Per pair of ``setup.pairs``: load [N], load-weighted roll angle on gear_b [rad] and profile coordinates
        [m] (NaN unloaded), max half-width [m] and pressure [Pa] over the slices, tip contact flag."""
        s = st.setup
        npair = s.pairs.size
        F = st.force_N
        load = np.bincount(s.pair_index, weights=F, minlength=npair)
        loaded = load > 0
        den = np.where(loaded, load, 1.0)

        def wmean(v):
            return np.where(loaded, np.bincount(s.pair_index, weights=F * np.nan_to_num(v), minlength=npair) / den,
                            np.nan)

        hw = np.zeros(npair)
        pp = np.zeros(npair)
        np.maximum.at(hw, s.pair_index, st.half_width_m)
        np.maximum.at(pp, s.pair_index, st.peak_pressure_Pa)
        tip = np.zeros(npair, bool)
        np.logical_or.at(tip, s.pair_index, s.tip_contact & (F > 0))
        return dict(load_N=load, roll_b_rad=wmean(s.roll_b_rad), s_a_m=wmean(s.s_a), s_b_m=wmean(s.s_b),
                    half_width_m=hw, peak_pressure_Pa=pp, tip_contact=tip,
                    **split_pressure(npair, s.pair_index, st.peak_pressure_Pa, s.tip_contact))

    def strains(self, st: ContactState, offsets: Sequence[int] | None = None) -> dict[str, np.ndarray]:
        """Gauge strains [-] at each gauge's axial position on the teeth of ``offsets`` (default ``tooth_offsets``)."""
        s = st.setup
        ops = s.strain_op if offsets is None else self._strain_op(s, np.asarray(offsets, int))
        return {name: M @ st.force_N for name, M in ops.items()}

    def hub_reactions(self, st: ContactState) -> dict[str, np.ndarray]:
        """In-plane contact force and torque on each gear ``[Fx N, Fy N, Mz N m]`` (global frame)."""
        wr = self.generalized_forces(st)["wrench"]
        return {g: np.asarray(v)[[0, 1, 5]] for g, v in wr.items()}

    def to_solution(self, st: ContactState) -> StaticSolution:
        base = super().to_solution(st)
        gf = self.generalized_forces(st)
        pat = self.pattern(st)
        return replace(base, twist_rad=float(st.setup.twist_rad), twist_moment_Nm=gf["twist_moment_Nm"],
                       generalized_force=np.asarray(gf["f_d"]), slice_load_N=pat["load_N"].sum(axis=0),
                       slice_pressure_Pa=pat["peak_pressure_Pa"].max(axis=0), pattern_load_N=pat["load_N"],
                       hub_reaction={g: np.asarray(v)[[0, 1, 5]] for g, v in gf["wrench"].items()})

    def solve_load(self, position: float, mesh_force_N: float, twist_rad: float = 0.0):
        return self.to_solution(self.state_load(position, mesh_force_N, twist_rad=twist_rad))

    def solve_deflection(self, position: float, mesh_deflection_m: float, twist_rad: float = 0.0):
        return self.to_solution(self.state_deflection(position, mesh_deflection_m, twist_rad=twist_rad))

    def solve_position(self, position: float, loads_N, deflections_m, twist_rad: float = 0.0):
        """Batch at one position and twist (set-up and warm starts reused)."""
        loads = np.asarray(loads_N, dtype=float).ravel()
        defl = np.asarray(deflections_m, dtype=float).ravel()
        out = []
        for fn, vals in ((self.state_load, loads), (self.state_deflection, defl)):
            res, warm = [], None
            for v in vals:
                st = fn(position, v, warm=warm, twist_rad=twist_rad)
                if st.success and np.any(st.force_N > 0):
                    warm = st.force_N
                res.append(self.to_solution(st))
            out.append(res)
        return out[0], out[1]

    def __getstate__(self):
        d = super().__getstate__()
        d["_geo_cache"] = {}
        return d


# =============================================================================================
# Model -> solver
# =============================================================================================
def make_helical_solver(model: Any, mesh_name: str, *, options: ContactOptions | None = None,
                        fe_options: Any = None, plane: str = "stress", cache: bool = True,
                        gauges: Sequence[tuple[str, Any]] | None = None,
                        fe3d_options: Any = None, side: str = "drive") -> HelicalMeshContactSolver:
    """The face-resolving static contact solver of mesh ``mesh_name`` (helical, or spur with ``elastic`` face
    coupling or a twist axis).  ``options`` default: the model's face slices and ``face_coupling="elastic"``
    (:func:`~hacgear_core.statics.contact.default_contact_options`); ``fe3d_options`` default:
    :func:`~hacgear_core.statics.fe3d.gear_mesh3d_options` per gear with the solver's face slices (module-scaled
    under ``[statics] fe_lengths``); the 3D face influence (:func:`hacgear_core.statics.fe3d.face_influence`, cached on disk) is built only for ``elastic``.
    ``side``: ``"drive"`` loads the mesh's flanks, ``"coast"`` the other flank of each gear (its own canonical
    picture and positions, the physical mesh frame; :func:`hacgear_core.statics.coast.make_coast_solver` maps it
    onto the drive side's positions and deflections)."""
    if not isinstance(model, Model):
        model = load_model(model)
    if options is None:
        options = default_contact_options(model, mesh_name, face_coupling="elastic")
    kw = mesh_solver_inputs(model, mesh_name, fe_options=fe_options, plane=plane, cache=cache, gauges=gauges,
                            side=side)
    ga, gb = kw.pop("gears")
    kw.pop("mesh")
    gmods = kw.pop("gauge_models")
    zc = kw.pop("z_centre_m")
    kw.pop("model")
    ggs = kw["geometry"]
    gauge_axial = []
    for gi, k, _ in kw["gauges"]:
        g = (ga, gb)[gi]
        f = float(getattr(gmods[gi][k], "face_fraction", 0.5))
        gauge_axial.append(g.axial_position_m - g.face_width_m / 2 + f * g.face_width_m)
    infl = (None, None)
    if options.face_coupling == "elastic":
        infl = tuple(
            fe3d.face_influence(gg, fe3d.material_of(g, plane), loaded,
                                gauges=tuple((x.name, x.flank, x.radius_m,
                                              float(getattr(x, "face_fraction", 0.5))) for x in gmods[i]),
                                options=(fe3d_options if fe3d_options is not None
                                         else fe3d.gear_mesh3d_options(g, model.statics.fe_lengths,
                                                                       options.face_slices)), cache=cache)
            for i, (g, gg, loaded) in enumerate(((ga, ggs[0], kw["flanks"][0]), (gb, ggs[1], kw["flanks"][1]))))
    return HelicalMeshContactSolver(
        **kw, options=options,
        helix_k_per_m=math.tan(ga.helix_angle_rad) / ggs[0].pitch_radius_m,
        helix_k_b_per_m=math.tan(gb.helix_angle_rad) / ggs[1].pitch_radius_m,
        z_centre_m=zc, gear_axial_m=(ga.axial_position_m, gb.axial_position_m),
        gear_face_width_m=(ga.face_width_m, gb.face_width_m), gauge_axial_m=gauge_axial, face_influence=infl,
        description=f"FE far field + Hertz near field, {options.face_slices} slices ({options.face_coupling}), "
                    f"mesh {mesh_name} of {model.name}" + ("" if side == "drive" else
                                                           f", {side} side ({kw['flanks'][0]}/{kw['flanks'][1]} flanks)"))


def needs_face_resolving_solver(model: Model, mesh_name: str, options: ContactOptions | None = None) -> bool:
    """True where mesh ``mesh_name`` needs the face-resolving solver: a helical gear in it,
    ``face_coupling="elastic"`` asked for in ``options``, or a spur mesh with a twist axis
    (:func:`spur_twist_axis`)."""
    m = {m.name: m for m in model.meshes}[mesh_name]
    gears = {g.name: g for g in model.gears}
    helical = gears[m.gear_a].is_helical or gears[m.gear_b].is_helical
    return bool(helical or (options is not None and options.face_coupling == "elastic") or spur_twist_axis(model))


def make_solver(model: Any, mesh_name: str, *, options: ContactOptions | None = None, **kw) -> MeshContactSolver:
    """The static contact solver a mesh needs: helical gears (or ``face_coupling="elastic"``) →
    :func:`make_helical_solver`, spur gears → :func:`~hacgear_core.statics.contact.make_mesh_solver`."""
    if not isinstance(model, Model):
        model = load_model(model)
    meshes = {m.name: m for m in model.meshes}
    if mesh_name not in meshes:
        raise ModelError(f"unknown mesh {mesh_name!r}; the model has: {', '.join(meshes) or '(none)'}")
    if spur_twist_axis(model) and options is not None and options.face_coupling == "rigid":
        raise ModelError(f"{model.path or model.name}: [statics] twist_points = {model.statics.twist_points} on the "
                         f"spur mesh '{mesh_name}' with face_coupling 'rigid': a mesh twist loads the face linearly, "
                         "which a face rigid across its width cannot spread (allowed: slices | elastic, the default)")
    if needs_face_resolving_solver(model, mesh_name, options):
        return make_helical_solver(model, mesh_name, options=options, **kw)
    kw.pop("fe3d_options", None)
    return make_mesh_solver(model, mesh_name, options=options, **kw)
