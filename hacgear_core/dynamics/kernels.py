"""Compiled (numba) kernels of the lumped gear dynamics: force laws and a fixed-step RK4 integrator.

Everything here is a plain function over arrays, allocation-free and without I/O, so the library
(sweeps, impulse tests, post-processing) and the FMU slaves call the same machine code.

State layout (``n`` = number of active degrees of freedom, 2 for a rigid-support spur pair,
up to 4 with line-of-action translations)::

    s    (2n,)  [q_0 .. q_{n-1}, qdot_0 .. qdot_{n-1}]   deviations from the reference rotation
    kin  (3,)   [tau_ref, cycles, omega_ref]

``tau_ref`` in [0, 1) is the fractional mesh position of the reference rotation of gear 1,
``cycles`` the (integer-valued) number of completed mesh cycles, ``omega_ref`` [rad/s] the reference
speed of gear 1.  The mesh position seen by the force law is

    tau = tau_ref + z1 * th1 / (2 pi)

i.e. it follows gear 1's actual rotation (reference + deviation ``th1``).  Keeping the reference
angle as (integer cycles, fraction) keeps float64 precision for arbitrarily long runs.

Force laws (``law``):

``LAW_TABLE`` (0)
    HAC force-deflection function: bilinear interpolation of ``ftab`` (Np, Nd), periodic in
    position, linear extrapolation from the outermost two deflection columns, clipped at >= 0.
``LAW_LINEAR`` (1)
    conventional mesh-stiffness law ``F = max(0, k(tau) (x - e(tau)) + f0(tau))`` with ``lin``
    (3, Np) = [k, e, f0] on the position grid, linearly interpolated and periodic (dissertation
    Eqs. 3.6-3.8).
"""
from __future__ import annotations

import math

from numba import njit

__all__ = [
    "LAW_TABLE",
    "LAW_LINEAR",
    "MODE_SPEED",
    "MODE_TORQUE",
    "table_force",
    "linear_force",
    "mesh_force",
    "integrate",
    "select_kernel",
    "table_force_many",
    "table_slope_many",
]

LAW_TABLE = 0
LAW_LINEAR = 1
MODE_SPEED = 0
MODE_TORQUE = 1

_TWO_PI = 2.0 * math.pi
# only floating-point contraction (fused multiply-add): NaN/inf semantics are kept, so diverged
# states are still detected by the callers (~10 % faster than strict IEEE evaluation here)
_FM = {"contract"}


@njit(cache=True, inline="always", fastmath=_FM)
def periodic_cell(npos, tau):
    """Cell of a periodic position grid ``k/npos``: ``(i, i+1 mod npos, fraction)`` for any real ``tau``."""
    p = tau * npos
    if p < 0.0 or p >= npos:  # tau outside [0, 1): wrap (the usual case skips the floor)
        p -= npos * math.floor(tau)
    i = int(p)
    if i >= npos:
        i = npos - 1
    a = p - i
    i1 = i + 1
    if i1 == npos:
        i1 = 0
    return i, i1, a


@njit(cache=True, inline="always", fastmath=_FM)
def table_force(ftab, x0, inv_dx, tau, x):
    """Bilinear FDF lookup ``F(tau, x)`` [N]; ``tau`` any real (periodic, period 1), ``x`` [m]."""
    npos = ftab.shape[0]
    nd = ftab.shape[1]
    i, i1, a = periodic_cell(npos, tau)
    r = (x - x0) * inv_dx
    j = int(r)  # truncation: r < 0 is clamped to column 0 below (linear extrapolation either way)
    if j < 0:
        j = 0
    elif j > nd - 2:
        j = nd - 2
    b = r - j
    f0 = ftab[i, j] + b * (ftab[i, j + 1] - ftab[i, j])
    f1 = ftab[i1, j] + b * (ftab[i1, j + 1] - ftab[i1, j])
    f = f0 + a * (f1 - f0)
    if f < 0.0:
        f = 0.0
    return f


@njit(cache=True, inline="always", fastmath=_FM)
def linear_force(lin, tau, x):
    """Conventional law ``max(0, k(tau)(x - e(tau)) + f0(tau))`` [N]; ``lin`` (3, Np)."""
    npos = lin.shape[1]
    i, i1, a = periodic_cell(npos, tau)
    k = lin[0, i] + a * (lin[0, i1] - lin[0, i])
    e = lin[1, i] + a * (lin[1, i1] - lin[1, i])
    f0 = lin[2, i] + a * (lin[2, i1] - lin[2, i])
    f = k * (x - e) + f0
    if f < 0.0:
        f = 0.0
    return f


@njit(cache=True, inline="always", fastmath=_FM)
def mesh_force(law, ftab, x0, inv_dx, lin, tau, x):
    """Dispatch on the force law (``LAW_TABLE`` or ``LAW_LINEAR``)."""
    if law == LAW_TABLE:
        return table_force(ftab, x0, inv_dx, tau, x)
    return linear_force(lin, tau, x)


@njit(cache=True, fastmath=_FM)
def table_force_many(ftab, x0, inv_dx, tau, x, out):
    """Vectorised :func:`table_force` over equal-length arrays ``tau``, ``x``; writes ``out``."""
    for k in range(tau.shape[0]):
        out[k] = table_force(ftab, x0, inv_dx, tau[k], x[k])


@njit(cache=True, fastmath=_FM)
def table_slope_many(ftab, x0, inv_dx, tau, x, out):
    """Local slope dF/dx [N/m] of the interpolated FDF at (tau, x) (one-sided within the grid cell)."""
    npos = ftab.shape[0]
    nd = ftab.shape[1]
    for k in range(tau.shape[0]):
        i, i1, a = periodic_cell(npos, tau[k])
        r = (x[k] - x0) * inv_dx
        j = int(r)
        if j < 0:
            j = 0
        elif j > nd - 2:
            j = nd - 2
        s0 = ftab[i, j + 1] - ftab[i, j]
        s1 = ftab[i1, j + 1] - ftab[i1, j]
        f = table_force(ftab, x0, inv_dx, tau[k], x[k])
        if f <= 0.0:
            out[k] = 0.0
        else:
            out[k] = (s0 + a * (s1 - s0)) * inv_dx


@njit(cache=True, inline="always", fastmath=_FM)
def _rhs(n, s, tau, x, minv, kd, cm, v, fext, law, ftab, x0, inv_dx, lin, out):
    """Accelerations of the lumped model, M qdd = fext - K q - C qd - F v, at a stage whose mesh
    position ``tau`` and deflection ``x`` (= v.q) the caller supplies.  Returns (F, g) with
    g = v . M^-1 (fext - K q - C qd), the force-free part of the mesh-deflection acceleration."""
    f = mesh_force(law, ftab, x0, inv_dx, lin, tau, x)
    g = 0.0
    for i in range(n):
        out[i] = s[n + i]
        base = fext[i] - kd[i] * s[i]
        for j in range(n):
            base -= cm[i, j] * s[n + j]
        mb = minv[i] * base
        g += v[i] * mb
        out[n + i] = mb - f * (minv[i] * v[i])
    return f, g


@njit(cache=True, inline="always", fastmath=_FM)
def _integrate_impl(n, s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v, fext, law,
                    ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out):
    # inlined into one caller per force law, so `law` is a compile-time constant there and the
    # dispatch in `mesh_force` folds away (a run-time dispatch inside the loop costs ~5x)
    m2 = 2 * n
    k1 = work[0]
    k2 = work[1]
    k3 = work[2]
    k4 = work[3]
    tmp = work[4]
    nrec = 0
    nr_cap = rec_state.shape[0]
    # mesh-deflection acceleration = g - w F with w = v . M^-1 v: the stage deflections are formed
    # from scalars, so each table lookup waits on one fused multiply-add after the previous one
    # instead of on a full stage update and dot product (same RK4, shorter dependency chain)
    w = 0.0
    for i in range(n):
        w += v[i] * v[i] * minv[i]
    for step in range(n_steps):
        tau_ref = kin[0]
        dtau = z1_2pi * kin[2] * h
        xq = 0.0
        xd = 0.0
        for i in range(n):
            xq += v[i] * s[i]
            xd += v[i] * s[n + i]
        f1, g1 = _rhs(n, s, tau_ref + z1_2pi * s[ith1], xq, minv, kd, cm, v, fext, law, ftab, x0, inv_dx,
                      lin, k1)
        for i in range(m2):
            tmp[i] = s[i] + 0.5 * h * k1[i]
        f2, g2 = _rhs(n, tmp, tau_ref + 0.5 * dtau + z1_2pi * tmp[ith1], xq + 0.5 * h * xd, minv, kd, cm, v,
                      fext, law, ftab, x0, inv_dx, lin, k2)
        for i in range(m2):
            tmp[i] = s[i] + 0.5 * h * k2[i]
        x3 = xq + 0.5 * h * (xd + 0.5 * h * (g1 - w * f1))
        f3, g3 = _rhs(n, tmp, tau_ref + 0.5 * dtau + z1_2pi * tmp[ith1], x3, minv, kd, cm, v, fext, law,
                      ftab, x0, inv_dx, lin, k3)
        for i in range(m2):
            tmp[i] = s[i] + h * k3[i]
        x4 = xq + h * (xd + 0.5 * h * (g2 - w * f2))
        _rhs(n, tmp, tau_ref + dtau + z1_2pi * tmp[ith1], x4, minv, kd, cm, v, fext, law, ftab, x0, inv_dx,
             lin, k4)
        c = h / 6.0
        for i in range(m2):
            s[i] += c * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        tau_ref += dtau
        if mode == MODE_TORQUE:
            # move the rigid-body rotation into the reference: th1 -> 0, x unchanged
            a = s[ith1]
            b = s[n + ith1]
            s[ith1] = 0.0
            s[n + ith1] = 0.0
            s[ith2] += ratio * a
            s[n + ith2] += ratio * b
            tau_ref += z1_2pi * a
            kin[2] += b
        while tau_ref >= 1.0:
            tau_ref -= 1.0
            kin[1] += 1.0
        while tau_ref < 0.0:
            tau_ref += 1.0
            kin[1] -= 1.0
        kin[0] = tau_ref
        if rec_every > 0 and (step + 1) % rec_every == 0 and nrec < nr_cap:
            x = 0.0
            for i in range(n):
                x += v[i] * s[i]
            tau = tau_ref + z1_2pi * s[ith1]
            f = mesh_force(law, ftab, x0, inv_dx, lin, tau, x)
            for i in range(m2):
                rec_state[nrec, i] = s[i]
            rec_out[nrec, 0] = kin[1] + tau
            rec_out[nrec, 1] = x
            rec_out[nrec, 2] = f
            rec_out[nrec, 3] = v[ith1] * s[ith1] + v[ith2] * s[ith2]
            rec_out[nrec, 4] = (step + 1) * h
            nrec += 1
    return nrec


def integrate(s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v, fext, law,
              ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out):
    """Advance the lumped model ``n_steps`` fixed RK4 steps of ``h`` [s] in place.

    Parameters
    ----------
    s : (2n,) float64
        State [q, qdot] (deviations), updated in place.
    kin : (3,) float64
        [tau_ref in [0, 1), completed mesh cycles, omega_ref rad/s], updated in place.
    n_steps : int
    h : float
        Step [s].
    mode : int
        ``MODE_SPEED``: the reference speed is an input, the deviations are integrated around it.
        ``MODE_TORQUE``: after every step the rigid-body rotation is moved from the deviation state
        into the reference rotation (``th1 -> 0``), so the reference follows gear 1 exactly and
        ``omega_ref`` is gear 1's speed (drivetrain coupling; needs zero rotational supports).
    z1_2pi : float
        z1 / (2 pi) [mesh cycles per rad of gear 1].
    ith1, ith2 : int
        Indices of th1, th2 in q.
    ratio : float
        r_b1 / r_b2 (used by the rebase in ``MODE_TORQUE``).
    minv, kd, v, fext : (n,) float64
        Inverse masses, support stiffnesses, mesh direction vector (Eq. 3.3b) and external
        generalized forces.
    cm : (n, n) float64
        Damping matrix.
    law : int
        Force law (module docstring); ``ftab`` (Np, Nd), ``x0`` [m], ``inv_dx`` [1/m] the FDF table,
        ``lin`` (3, Np') the conventional law's arrays (either may be a dummy for the other law).
    work : (5, 2n) float64
        Scratch.
    rec_every : int
        Record after every ``rec_every``-th step (0: never).
    rec_state : (nr, 2n) float64
        Recorded states (rows beyond ``nr`` are not written).
    rec_out : (nr, 5) float64
        Recorded [unwrapped mesh position tau (cycles + fraction), mesh deflection x [m], mesh force
        F [N], dynamic transmission error r_b1 th1 + r_b2 th2 [m], time offset from the call start [s]].

    Returns
    -------
    int
        Number of records written.
    """
    kern = select_kernel(law, s.shape[0] // 2)
    return kern(s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v, fext,
                ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out)


def select_kernel(law: int, n: int):
    """The compiled loop for force law ``law`` and ``n`` degrees of freedom.  Each loop is compiled
    on first use only (cached on disk), so a run pays only for the variants it uses.  Same
    arguments as :func:`integrate` without ``law``."""
    if law == LAW_TABLE:
        if n == 2:
            return _integrate_table2
        if n == 4:
            return _integrate_table4
        return _integrate_table
    return _integrate_linear


# One compiled loop per (force law, DOF count): constant trip counts let LLVM unroll the small loops.
@njit(cache=True, fastmath=_FM)
def _integrate_table2(s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v, fext,
                      ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out):
    return _integrate_impl(2, s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v, fext,
                           LAW_TABLE, ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out)


@njit(cache=True, fastmath=_FM)
def _integrate_table4(s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v, fext,
                      ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out):
    return _integrate_impl(4, s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v, fext,
                           LAW_TABLE, ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out)


@njit(cache=True, fastmath=_FM)
def _integrate_table(s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v, fext,
                     ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out):
    return _integrate_impl(s.shape[0] // 2, s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v,
                           fext, LAW_TABLE, ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out)


@njit(cache=True, fastmath=_FM)
def _integrate_linear(s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v, fext,
                      ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out):
    return _integrate_impl(s.shape[0] // 2, s, kin, n_steps, h, mode, z1_2pi, ith1, ith2, ratio, minv, kd, cm, v,
                           fext, LAW_LINEAR, ftab, x0, inv_dx, lin, work, rec_every, rec_state, rec_out)
