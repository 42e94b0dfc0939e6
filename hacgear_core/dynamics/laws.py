"""Mesh laws as objects: each names its kernel variant and its record fields and has one numpy twin of the kernel.

A lumped system's meshes share one mesh law (the compiled loop is specialised on it):

===================  =====================================================  ===============================
law                  mesh force                                             kernel variant
===================  =====================================================  ===============================
:class:`TableLaw`    the force table F(tau, x) (``hac``), drive flanks      ``LAW_TABLE``
:class:`TwoSided`    ... and the coast table Fc(tau, xc) across the         ``LAW_TABLE``, two-sided loop
TableLaw             backlash
:class:`LinearLaw`   a conventional law (``ste``, ``average_slope``,        ``LAW_LINEAR`` (two-sided loop
                     ``local_slope``), coast table if any                   with coast tables)
:class:`TwistTable   the generalized table (W, M)(tau, x, gamma) of a       ``LAW_TWIST`` (2 m meshes with
Law`                 helical mesh: ``W v + M t``; coast side ``Wc v_c +     the coast side)
                     Mc t_c``
===================  =====================================================  ===============================

A system mixing spur and helical meshes (a gear train with a helical stage) runs the twist law: each spur mesh on
its tables lifted to a constant twist axis with zero twist vectors (:func:`_on_twist_axis`), so its force is its
spur table's and its twist fields are 0.

Consumers read the kernel's records by field name (:meth:`MeshLaw.record_fields`): every law has
``mesh_position``, ``mesh_deflection_m``, ``mesh_force_N``, ``dynamic_transmission_error_m``, ``coast_approach_m``,
``coast_force_N``, ``time_s``; the twist law adds ``mesh_twist_rad``, ``twist_moment_Nm`` and, with its coast side,
``coast_twist_rad``, ``coast_twist_moment_Nm``.  The numpy twin (:meth:`MeshLaw.state_fields`,
:meth:`MeshLaw.static_forces`, :meth:`MeshLaw.tangent`) evaluates the same forces from a state.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Sequence

import numpy as np

from hacgear_core.dynamics import kernels
from hacgear_core.dynamics.force_laws import FORCE_LAWS, ForceLaw, make_force_law
from hacgear_core.errors import ModelError
from hacgear_core.tables import with_constant_twist
from hacgear_core.tables.fdf import TableArrays, generalized_slopes, generalized_stiffness, static_stiffness, table_arrays
from hacgear_core.tables.interp import bilinear_many, slope_many

__all__ = ["MeshLaw", "TableLaw", "TwoSidedTableLaw", "LinearLaw", "TwistTableLaw", "MESH_LAWS", "mesh_law", "ENERGY_NODES"]

#: the per-mesh fields every law's records have
BASE_FIELDS = ("mesh_position", "mesh_deflection_m", "mesh_force_N", "dynamic_transmission_error_m",
               "coast_approach_m", "coast_force_N")


class MeshLaw:
    """The mesh law of a system's ``meshes`` (MeshCoupling) with ``force_law`` (one of
    :data:`~hacgear_core.dynamics.force_laws.FORCE_LAWS`).

    Attributes
    ----------
    kernel_law : int
        The kernel's law code (``kernels.LAW_*``).
    kernel_two_sided : bool
        Whether the kernel runs its two-sided loop (coast tables of the table laws).
    two_sided : bool
        Whether the dynamics carry both flanks (either torque sign).
    m_kernel : int
        Meshes of the compiled loop.
    fields : tuple of str
        The per-mesh record fields (:meth:`record_fields`).
    """

    name = ""
    kernel_law = kernels.LAW_TABLE
    kernel_two_sided = False
    #: a coast table needs the coast line-of-action vector (the twist law checks its coast side itself)
    needs_coast_vectors = True
    fields: tuple[str, ...] = BASE_FIELDS

    def __init__(self, system_name: str, meshes: Sequence[Any], force_law: str) -> None:
        self.system_name = system_name
        self.meshes = tuple(meshes)
        self.m = len(self.meshes)
        self.table_arrays: tuple[TableArrays, ...] = tuple(table_arrays(c.table) for c in self.meshes)
        self.force_laws: tuple[ForceLaw, ...] = tuple(make_force_law(c.table, force_law, c.nominal_force_N)
                                                       for c in self.meshes)
        self.coast_arrays: tuple[TableArrays | None, ...] = tuple(
            None if c.coast_table is None else table_arrays(c.coast_table) for c in self.meshes)
        self.two_sided = any(ca is not None for ca in self.coast_arrays)
        self.m_kernel = self.m
        for c in self.meshes:
            if c.coast_table is not None and c.v_c is None and self.needs_coast_vectors:
                raise ModelError(f"{system_name}: mesh '{c.name}' has a coast table but no coast line-of-action "
                                 "vector v_c")

    # ------------------------------------------------------------------ kernel
    @property
    def label(self) -> str:
        return self.name

    def record_fields(self, rec_out: np.ndarray) -> dict[str, np.ndarray]:
        """Named per-mesh views (..., m) of kernel records ``rec_out`` (..., record width) and ``time_s``."""
        return kernels.record_fields(rec_out, self.m)

    def kernel_meshes(self, system) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The kernel's per-mesh vectors ``(v, w, v_rot, second, phase)`` (m_kernel rows); ``second`` the coast
        line of action (table laws) or the twist vector (twist law)."""
        return system.V, system.W, system.V_rot, system.Vc, system.phase

    def kernel_tables(self, system) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(tab, tint, tflt)``: the flattened tables of the kernel's meshes."""
        return kernels.flatten_tables(
            [(ta.ftab, ta.x0, ta.inv_dx) for ta in self.table_arrays]
            + [(None, c.backlash_m) if ca is None else (ca.ftab, ca.x0, ca.inv_dx)
               for c, ca in zip(self.meshes, self.coast_arrays)])

    def fingerprint(self, system, h) -> None:
        """Add what the law's dynamics depend on beyond the common arrays to the hash ``h``."""
        if self.two_sided:
            h.update(system.Vc.tobytes())
            for ca in self.coast_arrays:
                if ca is not None:
                    h.update(repr(ca.ftab.shape).encode())
                    h.update(ca.ftab.tobytes())
                    h.update(np.array([ca.x0, ca.dx]).tobytes())

    # ------------------------------------------------------------------ linearisation and step bound
    def linearise(self, system) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``(k_lin, kbar, generalized)``: the stiffness of the linearisation at the nominal torque (supports plus
        every mesh at the cycle mean of its law's stiffness on the loaded flanks), the mesh stiffnesses (m,) and
        (twist law) the per-mesh 2 x 2 generalized stiffnesses."""
        kbar, vl = self._loaded_stiffness(system)
        return system.K + (vl.T * kbar) @ vl, kbar, None

    def check_torque(self, torque_Nm: float) -> None:
        """Refuse a torque whose loaded flanks have no tables (a negative torque needs every coast table)."""
        if torque_Nm < 0 and any(ca is None for ca in self.coast_arrays):
            raise ModelError(f"{self.system_name}: a negative torque loads the coast flanks; meshes "
                             f"{[c.name for c in self.meshes if c.coast_table is None]} have no coast tables "
                             "(regenerate them: hacgear statics)")

    def _loaded_stiffness(self, system) -> tuple[np.ndarray, np.ndarray]:
        if system.torque_Nm > 0:
            return np.array([lw.mean_stiffness_N_per_m for lw in self.force_laws]), system.V
        self.check_torque(system.torque_Nm)
        return np.array([static_stiffness(c.coast_table, c.nominal_coast_force_N).mean_local_slope_N_per_m
                         for c in self.meshes]), system.Vc

    def stiffest(self, system, kbar: np.ndarray) -> np.ndarray:
        """The stiffness matrix the integrator's step must resolve: supports plus each mesh at its stiffest slope
        (of the flanks the nominal torque loads: a coast contact across the backlash is as stiff as the loaded
        flanks, and the step resolves it as well)."""
        kstiff = system.K.copy()
        vl = system.V if system.torque_Nm > 0 else system.Vc
        kstiff += (vl.T * self._kmax(system, kbar)) @ vl
        return kstiff

    def _kmax(self, system, kbar: np.ndarray) -> np.ndarray:
        """Each mesh's stiffest slope of its loaded flanks' table (and of a conventional law) [N/m]."""
        kmax = np.array([max(kb, float(np.max(np.diff(ta.ftab, axis=1))) * ta.inv_dx,
                             float(np.max(lw.lin[0])) if lw.law == kernels.LAW_LINEAR else 0.0)
                         for kb, ta, lw in zip(kbar, self.table_arrays, self.force_laws)])
        if system.torque_Nm < 0:
            kmax = np.array([max(kb, float(np.max(np.diff(ca.ftab, axis=1))) * ca.inv_dx)
                             for kb, ca in zip(kbar, self.coast_arrays)])
        return kmax

    # ------------------------------------------------------------------ numpy twin
    def mesh_force(self, k: int, tau, x, g=0.0) -> np.ndarray:
        """Force [N] of mesh ``k``'s law at ``tau`` [cycles], ``x`` [m] (broadcast arrays)."""
        lw = self.force_laws[k]
        if lw.law == kernels.LAW_TABLE:
            return np.maximum(_on_table(bilinear_many, self.table_arrays[k], tau, x), 0.0)
        tau, x = np.broadcast_arrays(np.asarray(tau, float), np.asarray(x, float))
        kk, e, f0 = _linear_law_at(lw.lin, tau)
        return np.maximum(kk * (x - e) + f0, 0.0)

    def mesh_slope(self, k: int, tau, x) -> np.ndarray:
        """Local slope dF/dx [N/m] of mesh ``k``'s law at ``tau``, ``x`` (0 where F = 0)."""
        lw = self.force_laws[k]
        if lw.law == kernels.LAW_TABLE:
            return _on_table(slope_many, self.table_arrays[k], tau, x)
        tau, x = np.broadcast_arrays(np.asarray(tau, float), np.asarray(x, float))
        return np.where(self.mesh_force(k, tau, x) > 0, _linear_law_at(lw.lin, tau)[0], 0.0)

    def coast_force(self, k: int, tau, xc) -> np.ndarray:
        """Coast-flank force [N] of mesh ``k`` at ``tau`` [cycles], coast approach ``xc`` [m] (0 without a coast
        table), by the kernels' rule."""
        return np.maximum(_on_table(bilinear_many, self.coast_arrays[k], tau, xc), 0.0)

    def coast_slope(self, k: int, tau, xc) -> np.ndarray:
        """Local slope dFc/dxc [N/m] of mesh ``k``'s coast table (0 without one)."""
        return _on_table(slope_many, self.coast_arrays[k], tau, xc)

    def state_fields(self, system, q: np.ndarray, tau: np.ndarray, offset: float, rec: np.ndarray) -> None:
        """Fill the record ``rec`` (record width,) as the kernel would at state ``q`` and mesh positions ``tau``
        (m,) (``offset``: the unwrapping added to the recorded positions)."""
        f, x = self._kinematic_fields(system, q, tau, offset, rec)
        m = self.m
        xc = system.Vc @ q
        xl = _lookup_deflections(system, x, offset + np.asarray(tau, float))
        xcl = _coast_lookup(system, xc, offset + np.asarray(tau, float))
        f["mesh_force_N"][:] = [float(self.mesh_force(k, tau[k], xl[k])) for k in range(m)]
        f["coast_approach_m"][:] = xc
        f["coast_force_N"][:] = [float(self.coast_force(k, tau[k], xcl[k])) for k in range(m)]

    def _kinematic_fields(self, system, q, tau, offset, rec) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """The raw record columns of ``rec`` by name with the system's meshes' positions, deflections and DTE at
        ``q`` filled in; and the deflections ``x`` (m,)."""
        f = kernels.record_fields(rec, self.m_kernel)
        m = self.m
        x = system.V @ q
        f["mesh_position"][:m] = offset + tau
        f["mesh_deflection_m"][:m] = x
        f["dynamic_transmission_error_m"][:m] = system.V_rot @ q
        return f, x

    def static_forces(self, system, q: np.ndarray, tau: np.ndarray) -> tuple[list[np.ndarray], dict[str, np.ndarray]]:
        """``(terms, fields)``: the generalized mesh forces at state ``q`` and positions ``tau`` as a list of (n,)
        terms (their sum, in this order, is the meshes' force on the DOFs), and the per-mesh fields
        (``mesh_deflection_m``, ``mesh_force_N``, ``coast_approach_m``, ``coast_force_N``, and the twist law's) they
        came from."""
        m = self.m
        x = system.V @ q
        xl = _lookup_deflections(system, x, tau)
        f = np.array([float(self.mesh_force(k, tau[k], xl[k])) for k in range(m)])
        terms = [system.V.T @ f]
        xc = system.Vc @ q
        xcl = _coast_lookup(system, xc, tau)
        fc = np.zeros(m)
        if self.two_sided:
            fc = np.array([float(self.coast_force(k, tau[k], xcl[k])) for k in range(m)])
            terms.append(system.Vc.T @ fc)
        fields = {"mesh_deflection_m": x, "mesh_force_N": f, "coast_approach_m": xc, "coast_force_N": fc}
        if xl is not x:
            fields["lookup_deflection_m"] = xl
        if xcl is not xc:
            fields["coast_lookup_approach_m"] = xcl
        return terms, fields

    def elastic_energy(self, system, q: np.ndarray, tau: np.ndarray) -> float:
        """Strain energy [J] of the meshes at state ``q`` (n,) and positions ``tau`` (m,): the work of their forces
        along the straight path from the undeflected state to ``q`` at these positions, ``sum_k int_0^x_k F_k(tau_k,
        s) ds`` (and the coast flanks' across the backlash), by :data:`ENERGY_NODES`-point Gauss-Legendre quadrature
        of the numpy twin of the kernel's law."""
        s, w = _energy_rule()
        x = system.V @ q
        e = sum(float(w @ np.asarray(self.mesh_force(k, np.full(s.size, tau[k]), s * x[k]))) * x[k]
                for k in range(self.m))
        if self.two_sided:
            xc = system.Vc @ q
            e += sum(float(w @ np.asarray(self.coast_force(k, np.full(s.size, tau[k]), s * xc[k]))) * xc[k]
                     for k in range(self.m))
        return float(e)

    def tangent(self, system, keff: np.ndarray, tau: np.ndarray, fields: dict, kbar_floor: np.ndarray,
                coast_loaded: bool) -> np.ndarray:
        """The tangent stiffness ``keff`` plus the meshes' slopes at ``fields`` (of :meth:`static_forces`), each
        loaded flank's slope at least ``kbar_floor`` (m,)."""
        m = self.m
        x = fields.get("lookup_deflection_m", fields["mesh_deflection_m"])
        xc = fields.get("coast_lookup_approach_m", fields["coast_approach_m"])
        ks = np.array([float(self.mesh_slope(k, tau[k], x[k])) for k in range(m)])
        a = keff + (system.V.T * np.maximum(ks, 0.0 if coast_loaded else kbar_floor)) @ system.V
        if self.two_sided:
            kc = np.array([float(self.coast_slope(k, tau[k], xc[k])) for k in range(m)])
            kc = np.where(np.array([float(self.coast_force(k, tau[k], xc[k])) for k in range(m)]) > 0, kc, 0.0)
            a = a + (system.Vc.T * np.maximum(kc, kbar_floor if coast_loaded else 0.0)) @ system.Vc
        return a


class TableLaw(MeshLaw):
    """The force tables (``hac``), drive flanks only."""

    name = "force tables"


class TwoSidedTableLaw(TableLaw):
    """The force tables (``hac``) of both flanks: the coast table across the backlash."""

    kernel_two_sided = True


class LinearLaw(MeshLaw):
    """A conventional law (periodic, linear in the deflection) on the drive flanks; with coast tables the kernel's
    two-sided loop takes the coast side from them."""

    name = "conventional force law"
    kernel_law = kernels.LAW_LINEAR

    def __init__(self, system_name: str, meshes: Sequence[Any], force_law: str) -> None:
        super().__init__(system_name, meshes, force_law)
        self.kernel_two_sided = self.two_sided


class TwistTableLaw(MeshLaw):
    """The generalized tables of helical meshes over (position, deflection, twist): the mesh puts ``W v + M t`` on
    the DOFs (one trilinear lookup).  With the coast side (coast vectors ``v_c``, ``t_c`` and a coast table with a
    twist axis, or for a drive-only table the zero table that ends at the backlash) the kernel runs 2 m meshes,
    the coast side of mesh ``k`` as mesh ``m + k``; without it the mesh is one-sided and unguarded."""

    name = "helical"
    kernel_law = kernels.LAW_TWIST
    needs_coast_vectors = False

    def __init__(self, system_name: str, meshes: Sequence[Any], force_law: str) -> None:
        bad = [c.name for c in meshes if c.t is None or getattr(c.table, "twist", None) is None]
        if bad:
            raise ModelError(f"{system_name}: meshes {bad} lack a twist vector or a table with a twist axis (a system "
                             "with helical meshes needs both on every mesh)")
        if force_law != "hac":
            raise ModelError(f"{system_name}: helical meshes take the HAC generalized force law only, got "
                             f"{force_law!r}")
        super().__init__(system_name, meshes, force_law)
        #: the coast side is present (the kernel runs 2 m meshes)
        self.coast = any(c.t_c is not None for c in self.meshes)
        if self.coast:
            bad = [c.name for c in self.meshes if c.t_c is None or c.v_c is None
                   or (c.coast_table is not None and getattr(c.coast_table, "twist", None) is None)
                   or (c.coast_table is None and not (math.isfinite(c.backlash_m) and c.backlash_m >= 0))]
            if bad:
                raise ModelError(f"{system_name}: helical meshes {bad} lack the coast side (coast vectors v_c, t_c "
                                 "and a coast table with a twist axis, or for a drive-only table a finite backlash_m "
                                 "[m] >= 0) that the others have")
            self.m_kernel = 2 * self.m
        else:
            self.coast_arrays = (None,) * self.m
        self.two_sided = self.coast and any(ca is not None for ca in self.coast_arrays)
        self.fields = BASE_FIELDS + ("mesh_twist_rad", "twist_moment_Nm") + (
            ("coast_twist_rad", "coast_twist_moment_Nm") if self.coast else ())

    def record_fields(self, rec_out: np.ndarray) -> dict[str, np.ndarray]:
        return kernels.record_fields(rec_out, self.m, not self.coast, self.coast)

    def kernel_meshes(self, system):
        if self.coast:
            return (np.vstack([system.V, system.Vc]), np.vstack([system.W, system.W]),
                    np.vstack([system.V_rot, np.zeros_like(system.V_rot)]), np.vstack([system.T, system.Tc]),
                    np.concatenate([system.phase, system.phase]))
        return system.V, system.W, system.V_rot, system.T, system.phase

    def kernel_tables(self, system):
        sides = [(c.table, ta) for c, ta in zip(self.meshes, self.table_arrays)]
        if self.coast:
            sides += [(c.coast_table, ca) if ca is not None else (None, c.backlash_m)
                      for c, ca in zip(self.meshes, self.coast_arrays)]
        return kernels.flatten_twist_tables(
            [(None, ta) if t is None else
             (t.twist.generalized_fdf, ta.x0, ta.inv_dx, t.twist.lookup_origin_rad, 1.0 / t.twist.dg)
             for t, ta in sides])

    def fingerprint(self, system, h) -> None:
        h.update(system.T.tobytes())
        for c in self.meshes:
            h.update(np.ascontiguousarray(c.table.twist.generalized_fdf).tobytes())
            h.update(np.ascontiguousarray(c.table.twist.twist_rad).tobytes())
            if c.table.twist.twist_offset_rad != 0.0:
                h.update(np.float64(c.table.twist.twist_offset_rad).tobytes())
        if self.coast:
            h.update(system.Tc.tobytes())
            for c in self.meshes:
                if c.coast_table is not None:
                    h.update(np.ascontiguousarray(c.coast_table.twist.generalized_fdf).tobytes())
                    if c.coast_table.twist.twist_offset_rad != 0.0:
                        h.update(np.float64(c.coast_table.twist.twist_offset_rad).tobytes())
            if any(c.coast_table is None for c in self.meshes):
                # drive-only tables: the coast approach and the backlash of the range guard
                h.update(system.Vc.tobytes())
                h.update(system.backlash_m.tobytes())
        super().fingerprint(system, h)

    def linearise(self, system):
        # the generalized law linearised at zero twist (cycle means; coupling symmetrised: the table's two
        # couplings agree within 1 %, a potential): K + [v t] [[k_xx, k_xg], [k_gx, k_gg]] [v t]^T, on the coast
        # side's vectors and table for a negative torque
        self._loaded_stiffness(system)
        coast = system.torque_Nm < 0
        gs = [generalized_stiffness(c.coast_table, c.nominal_coast_force_N).means() if coast
              else generalized_stiffness(c.table, c.nominal_force_N).means() for c in self.meshes]
        gen = np.array([[[g["k_xx_N_per_m"], g["k_xg_N_per_rad"]], [g["k_gx_Nm_per_m"], g["k_gg_Nm_per_rad"]]]
                        for g in gs])
        kbar = gen[:, 0, 0].copy()
        k_lin = system.K.copy()
        for k in range(self.m):
            b = np.vstack([system.Vc[k], system.Tc[k]]) if coast else np.vstack([system.V[k], system.T[k]])
            kg = gen[k]
            k_lin += b.T @ (0.5 * (kg + kg.T)) @ b
        return k_lin, kbar, gen

    def stiffest(self, system, kbar):
        # the stiffest slopes of each generalized table (any cell, any twist): dW/dx on v, dM/dgamma on t (of the
        # flanks the nominal torque loads)
        kmax = self._kmax(system, kbar)
        kstiff = system.K.copy()
        for k, c in enumerate(self.meshes):
            tw = (c.coast_table if system.torque_Nm < 0 else c.table).twist
            ta = (self.coast_arrays if system.torque_Nm < 0 else self.table_arrays)[k]
            kmax[k] = max(kmax[k], float(np.max(np.diff(tw.generalized_fdf[..., 0], axis=1))) * ta.inv_dx)
            kgg = float(np.max(np.abs(np.diff(tw.generalized_fdf[..., 1], axis=2)))) / tw.dg
            tv = system.Tc[k] if system.torque_Nm < 0 else system.T[k]
            kstiff += kgg * np.outer(tv, tv)
        vl = system.V if system.torque_Nm > 0 else system.Vc
        kstiff += (vl.T * kmax) @ vl
        return kstiff

    def generalized(self, k: int, tau, x, g, coast: bool = False) -> np.ndarray:
        """Mesh ``k``: mesh force W [N] and twist moment M [N m] -> (..., 2) at ``tau`` [cycles], ``x`` [m], ``g``
        [rad] (broadcast arrays), by the kernel's rule (the table's trilinear lookup; both 0 where W <= 0).
        ``coast``: the coast side (coast approach ``x``, coast twist ``g``; zeros for a drive-only table)."""
        c = self.meshes[k]
        table = c.coast_table if coast else c.table
        if table is None:
            return np.zeros(np.broadcast(np.asarray(tau), np.asarray(x), np.asarray(g)).shape + (2,))
        wm = np.asarray(table.twist_quantity(table.twist.generalized_fdf, tau, x, g))
        return np.where((wm[..., :1] > 0), wm, 0.0)

    def mesh_force(self, k: int, tau, x, g=0.0) -> np.ndarray:
        return self.generalized(k, tau, x, g)[..., 0]

    def state_fields(self, system, q, tau, offset, rec) -> None:
        # the kernel's record layout: twist and twist moment in the coast columns; the coast sides as meshes
        # m..2m-1
        f, x = self._kinematic_fields(system, q, tau, offset, rec)
        m = self.m
        g = system.T @ q
        xl = _lookup_deflections(system, x, offset + np.asarray(tau, float))
        wm = np.array([self.generalized(k, tau[k], xl[k], g[k]) for k in range(m)]).reshape(m, 2)
        f["mesh_force_N"][:m] = wm[:, 0]
        f["coast_approach_m"][:m] = g
        f["coast_force_N"][:m] = wm[:, 1]
        if self.coast:
            xc, gc = system.Vc @ q, system.Tc @ q
            wmc = np.array([self.generalized(k, tau[k], xc[k], gc[k], coast=True) for k in range(m)]).reshape(m, 2)
            f["mesh_position"][m:] = offset + tau
            f["mesh_deflection_m"][m:] = xc
            f["mesh_force_N"][m:] = wmc[:, 0]
            f["coast_approach_m"][m:] = gc
            f["coast_force_N"][m:] = wmc[:, 1]

    def elastic_energy(self, system, q, tau) -> float:
        # the generalized force along the straight path: int_0^1 (W x + M gamma)(s x, s gamma) ds, and the coast side
        s, w = _energy_rule()
        x, g = system.V @ q, system.T @ q
        sides = [(x, g, False)]
        if self.coast:
            sides.append((system.Vc @ q, system.Tc @ q, True))
        e = 0.0
        for xs, gs, coast in sides:
            for k in range(self.m):
                wm = self.generalized(k, np.full(s.size, tau[k]), s * xs[k], s * gs[k], coast=coast)
                e += float(w @ (wm[..., 0] * xs[k] + wm[..., 1] * gs[k]))
        return float(e)

    def static_forces(self, system, q, tau):
        # the generalized force W v + M t (twist gamma = t . q), and with the coast side Wc v_c + Mc t_c (coast
        # approach xc = v_c . q, coast twist gamma_c = t_c . q)
        m = self.m
        x, g = system.V @ q, system.T @ q
        xl = _lookup_deflections(system, x, tau)
        wm = np.array([self.generalized(k, tau[k], xl[k], g[k]) for k in range(m)]).reshape(m, 2)
        terms = [system.V.T @ wm[:, 0], system.T.T @ wm[:, 1]]
        xc, gc = system.Vc @ q, system.Tc @ q
        wmc = np.zeros((m, 2))
        if self.coast:
            wmc = np.array([self.generalized(k, tau[k], xc[k], gc[k], coast=True) for k in range(m)]).reshape(m, 2)
            terms += [system.Vc.T @ wmc[:, 0], system.Tc.T @ wmc[:, 1]]
        fields = {"mesh_deflection_m": x, "mesh_force_N": wm[:, 0], "mesh_twist_rad": g,
                  "twist_moment_Nm": wm[:, 1], "coast_approach_m": xc if self.coast else np.zeros(m),
                  "coast_force_N": wmc[:, 0], "coast_twist_rad": gc, "coast_twist_moment_Nm": wmc[:, 1]}
        if xl is not x:
            fields["lookup_deflection_m"] = xl
        return terms, fields

    def tangent(self, system, keff, tau, fields, kbar_floor, coast_loaded):
        # the generalized law's 2 x 2 slopes per mesh (the table's rule) on [v t] (and [v_c t_c]); the floor on
        # the flanks the load presses
        x, g = fields.get("lookup_deflection_m", fields["mesh_deflection_m"]), fields["mesh_twist_rad"]
        a = keff.copy()
        for k in range(self.m):
            c = self.meshes[k]
            sides = [(c.table, x[k], g[k], system.V[k], system.T[k], not coast_loaded)]
            if self.coast and c.coast_table is not None:
                sides.append((c.coast_table, fields["coast_approach_m"][k], fields["coast_twist_rad"][k],
                              system.Vc[k], system.Tc[k], coast_loaded))
            for table, xk, gk, v, t, floored in sides:
                jac = generalized_slopes(table, tau[k], xk, gk)[0]
                if table is c.coast_table and table.twist_quantity(table.twist.generalized_fdf, tau[k], xk,
                                                                   gk)[..., 0] <= 0:
                    jac = np.zeros((2, 2))
                if floored:
                    jac[0, 0] = max(jac[0, 0], kbar_floor[k])
                b = np.vstack([v, t])
                a += b.T @ jac @ b
        return a


#: the mesh laws by name (a coupling's ``law``)
MESH_LAWS = {"table": TableLaw, "two_sided_table": TwoSidedTableLaw, "linear": LinearLaw, "twist": TwistTableLaw}


#: Gauss-Legendre points of :meth:`MeshLaw.elastic_energy` (the tables are piecewise linear in the deflection: the
#: quadrature's error is set by the kinks, below 1e-4 of the energy on the shipped tables)
ENERGY_NODES = 32


def _energy_rule() -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [0, 1] (:data:`ENERGY_NODES` points)."""
    return _RULE


_RULE = tuple(np.array(a) for a in (0.5 * (np.polynomial.legendre.leggauss(ENERGY_NODES)[0] + 1.0),
                                    0.5 * np.polynomial.legendre.leggauss(ENERGY_NODES)[1]))


def _lookup_deflections(system, x: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """The drive flanks' lookup deflections (m,): ``x`` itself without manufacturing errors, else ``x`` less each
    mesh's error at its unwrapped position (:meth:`~hacgear_core.dynamics.system.LumpedSystem.mesh_errors_m`, the
    kernel's rule)."""
    if not getattr(system, "has_errors", False):
        return x
    return x - system.mesh_errors_m(positions, x)


def _coast_lookup(system, xc: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """The coast flanks' lookup approaches (m,): ``xc`` itself without coast-flank errors, else ``xc`` less each
    mesh's coast error at its unwrapped position (:meth:`~hacgear_core.dynamics.system.LumpedSystem.coast_errors_m`,
    the kernel's rule)."""
    if not any(getattr(c, "coast_error", None) is not None for c in system.meshes):
        return xc
    return xc - system.coast_errors_m(positions)


def mesh_law(system_name: str, meshes: Sequence[Any], force_law: str) -> MeshLaw:
    """The mesh law of ``meshes``: the twist law where the meshes have twist vectors, else the table law of
    ``force_law`` (``hac``: one- or two-sided by the coast tables; the conventional laws: :class:`LinearLaw`)."""
    if force_law not in FORCE_LAWS:
        raise ModelError(f"force law must be one of {FORCE_LAWS}, got {force_law!r}")
    if any(c.t is not None for c in meshes):
        return TwistTableLaw(system_name, [_on_twist_axis(c) for c in meshes], force_law)
    if force_law != "hac":
        return LinearLaw(system_name, meshes, force_law)
    law = TableLaw(system_name, meshes, force_law)
    return TwoSidedTableLaw(system_name, meshes, force_law) if law.two_sided else law


def _on_twist_axis(c: Any) -> Any:
    """A spur mesh ``c`` (no twist vector) of a system with helical meshes as the generalized law takes it: its
    tables on a constant twist axis (:func:`hacgear_core.tables.with_constant_twist`, the same force at every
    twist, no twist moment) and zero twist vectors, so the mesh's force is its spur table's and it puts no moment
    on the DOFs; a helical mesh as it is."""
    if getattr(c.table, "twist", None) is not None:
        return c
    zero = np.zeros(np.shape(c.v))
    return dataclasses.replace(c, table=with_constant_twist(c.table), t=zero if c.t is None else c.t,
                               t_c=None if c.v_c is None else zero if c.t_c is None else c.t_c)


def _on_table(rule, ta: TableArrays | None, tau, x) -> np.ndarray:
    """``rule`` (the interpolation's ``bilinear_many`` or ``slope_many``) on the table arrays ``ta`` at broadcast
    ``tau`` [cycles], ``x`` [m] (zeros without a table)."""
    tau, x = np.broadcast_arrays(np.asarray(tau, float), np.asarray(x, float))
    if ta is None:
        return np.zeros(tau.shape)
    out = np.empty(tau.size)
    rule(ta.ftab, ta.x0, ta.inv_dx, np.ascontiguousarray(tau.ravel()), np.ascontiguousarray(x.ravel()), out)
    return out.reshape(tau.shape)


def _linear_law_at(lin: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows ``[k, e, f0]`` of a conventional law ``lin`` (3, Np), periodic and linear in position, at ``tau``
    [cycles] (the kernel's rule)."""
    npos = lin.shape[1]
    t = (tau - np.floor(tau)) * npos
    i = np.minimum(t.astype(int), npos - 1)
    a = t - i
    i1 = (i + 1) % npos
    return tuple(lin[r, i] + a * (lin[r, i1] - lin[r, i]) for r in range(3))
