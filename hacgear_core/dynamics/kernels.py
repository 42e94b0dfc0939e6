"""Compiled (numba) fixed-step RK4 integrator of the lumped gear dynamics: n DOFs, m meshes, full matrices.

One kernel serves every gear system (spur pairs, idler chains, planetary sets, helical pairs), the library
(simulator, steady state, sweeps, impulse tests) and every FMU.  It is a plain function over arrays,
allocation-free and without I/O.

Equations (deviations ``q`` from the reference motion, see :mod:`hacgear_core.dynamics.system`)::

    M q'' + (C + W_c G) q' + (K - W_c^2 K_W) q + sum_k F_k(tau_k, x_k) v_k = f_ext
    x_k = v_k . q,    tau_k = tau_ref + phase_k + w_k . q,    W_c = c_ratio * omega_ref

State::

    s    (2n,)  [q_0 .. q_{n-1}, q'_0 .. q'_{n-1}]
    kin  (3,)   [tau_ref in [0, 1), completed reference mesh cycles, omega_ref rad/s]

``tau_ref`` is the mesh position of the reference motion (the first mesh), advancing by
``zref_2pi * omega_ref`` per second; keeping it as (integer cycles, fraction) keeps float64 precision for
arbitrarily long runs.

Force laws (one per kernel variant, so the dispatch folds away at compile time):

``LAW_TABLE`` (0)
    HAC force-deflection function of each mesh: :func:`hacgear_core.tables.interp.bilinear` on its table,
    clipped at >= 0 (teeth cannot pull).
``LAW_LINEAR`` (1)
    conventional mesh-stiffness law ``F = max(0, k(tau) (x - e(tau)) + f0(tau))`` with ``[k, e, f0]`` per
    mesh on its position grid, linear and periodic in position (dissertation Eqs. 3.6-3.8).

Tables of all meshes travel flattened: mesh ``k``'s table is ``tab[o : o + Np * Nd]`` reshaped (Np, Nd) with
``(o, Np, Nd) = tint[k]`` and ``(x0, 1/dx) = tflt[k]``; the linear law's arrays likewise
(``lin[o : o + 3 Np]``, rows k, e, f0, with ``(o, Np) = lint[k]``).

Modes: ``MODE_SPEED`` integrates the deviations around an imposed reference speed; ``MODE_TORQUE`` moves the
rigid-body rotation into the reference after every step (``q -= q_ref u``, ``tau_ref += sref zref_2pi q_ref``,
``omega_ref += sref q'_ref``, ``sref`` the reference gear's sense of rotation), so the reference follows the reference gear exactly (drivetrain coupling; needs a
rigid-body mode ``u`` with ``u[iref] = 1``).

Records (every ``rec_every`` steps): ``rec_state`` (nr, 2n); ``rec_out`` (nr, 4m + 1) with, per mesh k,
``[4k]`` unwrapped mesh position (cycles + fraction), ``[4k+1]`` mesh deflection [m], ``[4k+2]`` mesh force
[N], ``[4k+3]`` dynamic transmission error (rotational part of ``v_k . q``) [m], and ``[4m]`` the time since
the call started [s].
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from hacgear_core.tables.interp import periodic_cell, deflection_cell

__all__ = [
    "LAW_TABLE",
    "LAW_LINEAR",
    "MODE_SPEED",
    "MODE_TORQUE",
    "mesh_force",
    "select_kernel",
    "flatten_tables",
    "flatten_linear",
]

LAW_TABLE = 0
LAW_LINEAR = 1
MODE_SPEED = 0
MODE_TORQUE = 1

_FM = {"contract"}


@njit(cache=True, inline="always", fastmath=_FM)
def _table_force(tab, off, npos, nd, x0, inv_dx, tau, x):
    i, i1, a = periodic_cell(npos, tau)
    j, b = deflection_cell(nd, x0, inv_dx, x)
    r0 = off + i * nd + j
    r1 = off + i1 * nd + j
    v0 = tab[r0] + b * (tab[r0 + 1] - tab[r0])
    v1 = tab[r1] + b * (tab[r1 + 1] - tab[r1])
    f = v0 + a * (v1 - v0)
    if f < 0.0:
        f = 0.0
    return f


@njit(cache=True, inline="always", fastmath=_FM)
def _linear_force(lin, off, npos, tau, x):
    i, i1, a = periodic_cell(npos, tau)
    k = lin[off + i] + a * (lin[off + i1] - lin[off + i])
    e = lin[off + npos + i] + a * (lin[off + npos + i1] - lin[off + npos + i])
    f0 = lin[off + 2 * npos + i] + a * (lin[off + 2 * npos + i1] - lin[off + 2 * npos + i])
    f = k * (x - e) + f0
    if f < 0.0:
        f = 0.0
    return f


@njit(cache=True, inline="always", fastmath=_FM)
def mesh_force(law, k, tab, tint, tflt, lin, lint, tau, x):
    """Force [N] of mesh ``k`` under force law ``law`` at mesh position ``tau`` [cycles], deflection ``x`` [m]."""
    if law == LAW_TABLE:
        return _table_force(tab, tint[k, 0], tint[k, 1], tint[k, 2], tflt[k, 0], tflt[k, 1], tau, x)
    return _linear_force(lin, lint[k, 0], lint[k, 1], tau, x)


@njit(cache=True, inline="always", fastmath=_FM)
def _free_acc(n, q, qd, kidx, aqv, adt, fm, out):
    """Force-free acceleration ``M^-1 f_ext - (M^-1 K_eff) q - (M^-1 C_eff) q'`` into ``out``; the stiffness part
    over its nonzero entries ``kidx`` (supports are sparse), the damping part dense (modal damping is full) from its
    transpose ``adt`` column by column: every row still sums in the order j = 0..n-1, but the rows are independent
    in the inner loop, which the compiler vectorises (a row-by-row dot product is one long dependency chain)."""
    for i in range(n):
        out[i] = fm[i]
    for j in range(n):
        c = qd[j]
        for i in range(n):
            out[i] -= adt[j, i] * c
    for z in range(kidx.shape[0]):
        out[kidx[z, 0]] -= aqv[z] * q[kidx[z, 1]]


@njit(cache=True, inline="always", fastmath=_FM)
def _integrate_impl(n, m, law, s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat,
                    phase, u, scal, iref, tab, tint, tflt, lin, lint, work, eff, mw, kidx, kval, nz):
    # RK4 whose stage mesh deflections and positions are formed from scalars: with x_q = v.q, x_d = v.q' and
    # g = v.(force-free acceleration), stage 2 needs x_q + h/2 x_d, stage 3 x_q + h/2 (x_d + h/2 (g_1 - VV F_1)),
    # stage 4 x_q + h (x_d + h/2 (g_2 - VV F_2)) (VV = v M^-1 v^T), so each table lookup waits on a few
    # multiply-adds after an earlier lookup instead of on a full stage update and dot products (the same RK4)
    minv = mats[0]
    mc = mats[1]
    mg = mats[2]
    mk = kval[0]
    mkw = kval[1]
    aqv = kval[2]
    vm = vecs[0]
    wm = vecs[1]
    rvm = vecs[2]
    vmi = vecs[3]
    vv = mmat[0]
    wv = mmat[1]
    c_ratio = scal[0]
    sref = scal[1]
    zref_2pi = scal[2]
    ad = eff
    a1 = work[0]
    a2 = work[1]
    a3 = work[2]
    a4 = work[3]
    q2 = work[4]
    d2 = work[5]
    q3 = work[6]
    d3 = work[7]
    fm = work[8]
    xq = mw[0]
    xd = mw[1]
    wq = mw[2]
    wd = mw[3]
    f1 = mw[4]
    f2 = mw[5]
    f3 = mw[6]
    f4 = mw[7]
    g1 = mw[8]
    gw1 = mw[9]
    g2 = mw[10]
    gw2 = mw[11]
    for i in range(n):
        a = 0.0
        for j in range(n):
            a += minv[i, j] * fext[j]
        fm[i] = a
    nrec = 0
    nr_cap = rec_state.shape[0]
    rotating = c_ratio != 0.0
    omega_c_set = math.nan
    if not rotating:
        for z in range(kidx.shape[0]):
            aqv[z] = mk[z]
        for i in range(n):
            for j in range(n):
                ad[j, i] = mc[i, j]
    hh = 0.5 * h
    countdown = rec_every
    for step in range(n_steps):
        tau_ref = kin[0]
        omega = kin[2]
        if rotating:
            oc = c_ratio * omega
            if oc != omega_c_set:
                for z in range(kidx.shape[0]):
                    aqv[z] = mk[z] - oc * oc * mkw[z]
                for i in range(n):
                    for j in range(n):
                        ad[j, i] = mc[i, j] + oc * mg[i, j]
                omega_c_set = oc
        dtau = zref_2pi * omega * h
        for k in range(m):
            a = 0.0
            b = 0.0
            c = 0.0
            d = 0.0
            for p in range(1, nz[k, 0] + 1):
                j = nz[k, p]
                a += vm[k, j] * s[j]
                b += vm[k, j] * s[n + j]
                c += wm[k, j] * s[j]
                d += wm[k, j] * s[n + j]
            xq[k] = a
            xd[k] = b
            wq[k] = c
            wd[k] = d
        # stages 1 and 2: their lookups need only the state
        for k in range(m):
            f1[k] = mesh_force(law, k, tab, tint, tflt, lin, lint, tau_ref + phase[k] + wq[k], xq[k])
            f2[k] = mesh_force(law, k, tab, tint, tflt, lin, lint, tau_ref + 0.5 * dtau + phase[k] + wq[k] + hh * wd[k],
                               xq[k] + hh * xd[k])
        _free_acc(n, s, s[n:], kidx, aqv, ad, fm, a1)
        for k in range(m):
            a = 0.0
            b = 0.0
            for p in range(1, nz[k, 0] + 1):
                i = nz[k, p]
                a += vm[k, i] * a1[i]
                b += wm[k, i] * a1[i]
            g1[k] = a
            gw1[k] = b
        for k in range(m):
            for p in range(1, nz[k, 0] + 1):
                i = nz[k, p]
                a1[i] -= f1[k] * vmi[k, i]
        for i in range(n):
            q2[i] = s[i] + hh * s[n + i]
            d2[i] = s[n + i] + hh * a1[i]
        _free_acc(n, q2, d2, kidx, aqv, ad, fm, a2)
        for k in range(m):
            a = 0.0
            b = 0.0
            for p in range(1, nz[k, 0] + 1):
                i = nz[k, p]
                a += vm[k, i] * a2[i]
                b += wm[k, i] * a2[i]
            g2[k] = a
            gw2[k] = b
        for k in range(m):
            for p in range(1, nz[k, 0] + 1):
                i = nz[k, p]
                a2[i] -= f2[k] * vmi[k, i]
        # stages 3 and 4
        for k in range(m):
            a = g1[k]
            b = gw1[k]
            c = g2[k]
            d = gw2[k]
            for j in range(m):
                a -= vv[k, j] * f1[j]
                b -= wv[k, j] * f1[j]
                c -= vv[k, j] * f2[j]
                d -= wv[k, j] * f2[j]
            f3[k] = mesh_force(law, k, tab, tint, tflt, lin, lint,
                               tau_ref + 0.5 * dtau + phase[k] + wq[k] + hh * (wd[k] + hh * b),
                               xq[k] + hh * (xd[k] + hh * a))
            f4[k] = mesh_force(law, k, tab, tint, tflt, lin, lint,
                               tau_ref + dtau + phase[k] + wq[k] + h * (wd[k] + hh * d),
                               xq[k] + h * (xd[k] + hh * c))
        for i in range(n):
            q3[i] = s[i] + hh * d2[i]
            d3[i] = s[n + i] + hh * a2[i]
        _free_acc(n, q3, d3, kidx, aqv, ad, fm, a3)
        for k in range(m):
            for p in range(1, nz[k, 0] + 1):
                i = nz[k, p]
                a3[i] -= f3[k] * vmi[k, i]
        # stage 4 state (q3 <- q4, d2 <- qd4 after their last use)
        for i in range(n):
            q3[i] = s[i] + h * d3[i]
        for i in range(n):
            b = s[n + i] + h * a3[i]
            q2[i] = b
        _free_acc(n, q3, q2, kidx, aqv, ad, fm, a4)
        for k in range(m):
            for p in range(1, nz[k, 0] + 1):
                i = nz[k, p]
                a4[i] -= f4[k] * vmi[k, i]
        c6 = h / 6.0
        for i in range(n):
            # qd1 = s_qd, qd2 = d2, qd3 = d3, qd4 = q2 (stage-4 velocity)
            s[i] += c6 * (s[n + i] + 2.0 * d2[i] + 2.0 * d3[i] + q2[i])
            s[n + i] += c6 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i])
        tau_ref += dtau
        if mode == MODE_TORQUE:
            a = s[iref]
            b = s[n + iref]
            for i in range(n):
                s[i] -= a * u[i]
                s[n + i] -= b * u[i]
            tau_ref += sref * zref_2pi * a
            kin[2] += sref * b
        while tau_ref >= 1.0:
            tau_ref -= 1.0
            kin[1] += 1.0
        while tau_ref < 0.0:
            tau_ref += 1.0
            kin[1] -= 1.0
        kin[0] = tau_ref
        countdown -= 1
        if countdown == 0:
            countdown = rec_every
            if nrec >= nr_cap:
                continue
            for i in range(2 * n):
                rec_state[nrec, i] = s[i]
            for k in range(m):
                x = 0.0
                t = tau_ref + phase[k]
                d = 0.0
                for j in range(n):
                    x += vm[k, j] * s[j]
                    t += wm[k, j] * s[j]
                    d += rvm[k, j] * s[j]
                rec_out[nrec, 4 * k] = kin[1] + t
                rec_out[nrec, 4 * k + 1] = x
                rec_out[nrec, 4 * k + 2] = mesh_force(law, k, tab, tint, tflt, lin, lint, t, x)
                rec_out[nrec, 4 * k + 3] = d
            rec_out[nrec, 4 * m] = (step + 1) * h
            nrec += 1
    return nrec


@njit(cache=True, fastmath=_FM)
def _integrate_table_2_1(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u,
                         scal, iref, tab, tint, tflt, lin, lint, work, eff, mw, kidx, kval, nz):
    return _integrate_impl(2, 1, LAW_TABLE, s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats,
                           vecs, mmat, phase, u, scal, iref, tab, tint, tflt, lin, lint, work, eff, mw, kidx,
                           kval, nz)


@njit(cache=True, fastmath=_FM)
def _integrate_table_4_1(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u,
                         scal, iref, tab, tint, tflt, lin, lint, work, eff, mw, kidx, kval, nz):
    return _integrate_impl(4, 1, LAW_TABLE, s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats,
                           vecs, mmat, phase, u, scal, iref, tab, tint, tflt, lin, lint, work, eff, mw, kidx,
                           kval, nz)


@njit(cache=True, fastmath=_FM)
def _integrate_table_3_2(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u,
                         scal, iref, tab, tint, tflt, lin, lint, work, eff, mw, kidx, kval, nz):
    return _integrate_impl(3, 2, LAW_TABLE, s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats,
                           vecs, mmat, phase, u, scal, iref, tab, tint, tflt, lin, lint, work, eff, mw, kidx,
                           kval, nz)


@njit(cache=True, fastmath=_FM)
def _integrate_table(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u,
                     scal, iref, tab, tint, tflt, lin, lint, work, eff, mw, kidx, kval, nz):
    return _integrate_impl(s.shape[0] // 2, phase.shape[0], LAW_TABLE, s, kin, n_steps, h, mode, fext,
                           rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u, scal, iref, tab, tint,
                           tflt, lin, lint, work, eff, mw, kidx, kval, nz)


@njit(cache=True, fastmath=_FM)
def _integrate_linear(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u,
                      scal, iref, tab, tint, tflt, lin, lint, work, eff, mw, kidx, kval, nz):
    return _integrate_impl(s.shape[0] // 2, phase.shape[0], LAW_LINEAR, s, kin, n_steps, h, mode, fext,
                           rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u, scal, iref, tab, tint,
                           tflt, lin, lint, work, eff, mw, kidx, kval, nz)


_SPECIAL = {(LAW_TABLE, 2, 1): _integrate_table_2_1, (LAW_TABLE, 4, 1): _integrate_table_4_1,
            (LAW_TABLE, 3, 2): _integrate_table_3_2}


def select_kernel(law: int, n: int, m: int):
    """The compiled loop for force law ``law``, ``n`` DOFs and ``m`` meshes.

    Arguments of the returned function (float64 arrays, C-contiguous, unless noted)::

        s (2n,), kin (3,), n_steps int, h [s], mode int, fext (n,), rec_every int, rec_state (nr, 2n),
        rec_out (nr, 4m + 1),
        mats (3, n, n) = [M^-1, M^-1 C, M^-1 G], vecs (4, m, n) = [v, w, v_rot, (M^-1 v)],
        mmat (2, m, m) = [v M^-1 v^T, w M^-1 v^T], phase (m,), u (n,), scal (3,) = [c_ratio, sref, zref_2pi],
        iref int, tab (flat FDFs), tint (m, 3) int64 = [offset, Np, Nd], tflt (m, 2) = [x0, 1/dx],
        lin (flat conventional-law arrays), lint (m, 2) int64 = [offset, Np],
        work (9, n), eff (n, n), mw (12, m) scratch,
        kidx (nnz, 2) int64 rows/columns of the nonzero entries of M^-1 K and M^-1 K_W,
        kval (3, nnz) = [their values in M^-1 K, in M^-1 K_W, scratch],
        nz (m, 1 + L) int64: per mesh [count, DOF indices...] of the nonzero entries of its v, w and M^-1 v
           (a mesh couples a few DOFs: the sparse loops keep many-mesh systems fast)

    and it returns the number of records written (module docstring).
    """
    if law == LAW_TABLE:
        return _SPECIAL.get((law, n, m), _integrate_table)
    return _integrate_linear


def flatten_tables(tables) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Flatten the FDFs of several meshes for the kernel: ``(tab, tint, tflt)`` from a sequence of
    ``(force (Np, Nd), x0 [m], inv_dx [1/m])``."""
    parts, tint, tflt = [], [], []
    o = 0
    for f, a0, idx in tables:
        f = np.ascontiguousarray(f, dtype=np.float64)
        parts.append(f.ravel())
        tint.append((o, f.shape[0], f.shape[1]))
        tflt.append((a0, idx))
        o += f.size
    cat = np.concatenate(parts) if parts else np.zeros(0)
    return (np.ascontiguousarray(cat), np.array(tint, np.int64).reshape(-1, 3),
            np.array(tflt, float).reshape(-1, 2))


def flatten_linear(lins) -> tuple[np.ndarray, np.ndarray]:
    """Flatten the conventional laws' arrays (3, Np_k) of several meshes: ``(lin, lint)``."""
    parts, lint = [], []
    o = 0
    for a in lins:
        a = np.ascontiguousarray(a, dtype=np.float64)
        parts.append(a.ravel())
        lint.append((o, a.shape[1]))
        o += a.size
    cat = np.concatenate(parts) if parts else np.zeros(0)
    return np.ascontiguousarray(cat), np.array(lint, np.int64).reshape(-1, 2)
