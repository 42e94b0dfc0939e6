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
def _sub_k(n, nnz, kidx, aqv, c, x, ox, out, oo):
    """``out[oo:oo+n] -= c (M^-1 K_eff) x[ox:ox+n]``: the diagonal (``aqv[:n]``) then the nonzero off-diagonal
    entries."""
    for i in range(n):
        out[oo + i] -= c * aqv[i] * x[ox + i]
    for z in range(n, nnz):
        out[oo + kidx[z, 0]] -= c * aqv[z] * x[ox + kidx[z, 1]]


@njit(cache=True, inline="always", fastmath=_FM)
def _sub_c(n, adt, c, x, ox, out, oo):
    """``out[oo:oo+n] -= c (M^-1 C_eff) x[ox:ox+n]`` column by column (``adt`` is its transpose, flat (n*n,))."""
    for j in range(n):
        b = c * x[ox + j]
        for i in range(n):
            out[oo + i] -= adt[j * n + i] * b


@njit(cache=True, inline="always", fastmath=_FM)
def _dot(n, sparse, nz, k, vf, ov, x, ox):
    """``vf[ov + k n : ov + (k+1) n] . x[ox : ox + n]``: mesh k's vector dotted with a state vector, over the
    nonzero pattern ``nz[k]`` of the mesh's vectors when ``sparse`` (the same sum: only zero terms skipped)."""
    a = 0.0
    if sparse:
        for p in range(1, nz[k, 0] + 1):
            j = nz[k, p]
            a += vf[ov + k * n + j] * x[ox + j]
    else:
        for j in range(n):
            a += vf[ov + k * n + j] * x[ox + j]
    return a


@njit(cache=True, inline="always", fastmath=_FM)
def _sub_forces(n, m, sparse, nz, f, of, vmi, ov, out, oo):
    """``out[oo:oo+n] -= sum_k f[of+k] (M^-1 v_k)`` with ``M^-1 v_k = vmi[ov + k n : ov + (k+1) n]``."""
    for k in range(m):
        c = f[of + k]
        if sparse:
            for p in range(1, nz[k, 0] + 1):
                i = nz[k, p]
                out[oo + i] -= c * vmi[ov + k * n + i]
        else:
            for i in range(n):
                out[oo + i] -= c * vmi[ov + k * n + i]


@njit(cache=True, inline="always", fastmath=_FM)
def _integrate_impl(n, m, law, sparse, s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs,
                    mmat, phase, u, scal, iref, tab, tint, tflt, lin, lint, work, eff, kidx, kval, nz):
    # RK4 of q'' = a(q, q', F).  The force-free acceleration is linear in (q, q'), so every stage's is the
    # first stage's g0 plus products with the earlier stages' accelerations a1..a3 (hh = h/2):
    #   a2 = g0 + hh p - hh C a1                  - F2 M^-1 v      (p = -K q')
    #   a3 = g0 + hh p - hh^2 K a1 - hh C a2       - F3 M^-1 v
    #   a4 = g0 + h p  - h hh K a2 - h C a3        - F4 M^-1 v
    #   q  += h q' + h^2/6 (a1 + a2 + a3),   q' += h/6 (a1 + 2 a2 + 2 a3 + a4)
    # (K, C here M^-1 K_eff, M^-1 C_eff).  The stage mesh deflections and positions are formed from scalars:
    # with x_q = v.q, x_d = v.q', g = v.(force-free acceleration) and VV = v M^-1 v^T, stage 2 needs
    # x_q + hh x_d, stage 3 x_q + hh (x_d + hh (g_1 - VV F_1)), stage 4 x_q + h (x_d + hh (g_2 - VV F_2)), so
    # each table lookup waits on a few multiply-adds after an earlier lookup, not on a full stage update.
    # Vectors and matrices are addressed flat at offsets that are compile-time constants in the specialised
    # loops (one base pointer per array keeps the loop's working set in registers).
    minv = mats[0]
    mc = mats[1]
    mg = mats[2]
    mk = kval[0]
    mkw = kval[1]
    aqv = kval[2]
    nnz = kidx.shape[0]
    vf = vecs.reshape(vecs.size)
    mf = mmat.reshape(mmat.size)
    o_wm = m * n
    o_rvm = 2 * m * n
    o_vmi = 3 * m * n
    o_wv = m * m
    c_ratio = scal[0]
    sref = scal[1]
    zref_2pi = scal[2]
    adt = eff.reshape(n * n)
    wk = work
    o_a1 = 0 * n
    o_a2 = 1 * n
    o_a3 = 2 * n
    o_a4 = 3 * n
    o_g0 = 4 * n
    o_p = 5 * n
    o_fm = 6 * n
    o_xq = 7 * n + 0 * m
    o_xd = 7 * n + 1 * m
    o_wq = 7 * n + 2 * m
    o_wd = 7 * n + 3 * m
    o_f1 = 7 * n + 4 * m
    o_f2 = 7 * n + 5 * m
    o_f3 = 7 * n + 6 * m
    o_f4 = 7 * n + 7 * m
    o_g1 = 7 * n + 8 * m
    o_gw1 = 7 * n + 9 * m
    o_g2 = 7 * n + 10 * m
    o_gw2 = 7 * n + 11 * m
    for i in range(n):
        a = 0.0
        for j in range(n):
            a += minv[i, j] * fext[j]
        wk[o_fm + i] = a
    nrec = 0
    nr_cap = rec_state.shape[0]
    rotating = c_ratio != 0.0
    omega_c_set = math.nan
    if not rotating:
        for z in range(nnz):
            aqv[z] = mk[z]
        for i in range(n):
            for j in range(n):
                adt[j * n + i] = mc[i, j]
    hh = 0.5 * h
    hh2 = hh * hh
    hhh = h * hh
    c6 = h / 6.0
    c6q = h * h / 6.0
    countdown = rec_every
    for step in range(n_steps):
        tau_ref = kin[0]
        omega = kin[2]
        if rotating:
            oc = c_ratio * omega
            if oc != omega_c_set:
                for z in range(nnz):
                    aqv[z] = mk[z] - oc * oc * mkw[z]
                for i in range(n):
                    for j in range(n):
                        adt[j * n + i] = mc[i, j] + oc * mg[i, j]
                omega_c_set = oc
        dtau = zref_2pi * omega * h
        for k in range(m):
            wk[o_xq + k] = _dot(n, sparse, nz, k, vf, 0, s, 0)
            wk[o_xd + k] = _dot(n, sparse, nz, k, vf, 0, s, n)
            wk[o_wq + k] = _dot(n, sparse, nz, k, vf, o_wm, s, 0)
            wk[o_wd + k] = _dot(n, sparse, nz, k, vf, o_wm, s, n)
        # stages 1 and 2: their lookups need only the state
        for k in range(m):
            wk[o_f1 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, tau_ref + phase[k] + wk[o_wq + k], wk[o_xq + k])
            wk[o_f2 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, tau_ref + 0.5 * dtau + phase[k] + wk[o_wq + k] + hh * wk[o_wd + k],
                               wk[o_xq + k] + hh * wk[o_xd + k])
        for i in range(n):
            wk[o_g0 + i] = wk[o_fm + i]
            wk[o_p + i] = 0.0
        _sub_k(n, nnz, kidx, aqv, 1.0, s, 0, wk, o_g0)
        _sub_k(n, nnz, kidx, aqv, 1.0, s, n, wk, o_p)
        _sub_c(n, adt, 1.0, s, n, wk, o_g0)
        for k in range(m):
            wk[o_g1 + k] = _dot(n, sparse, nz, k, vf, 0, wk, o_g0)
            wk[o_gw1 + k] = _dot(n, sparse, nz, k, vf, o_wm, wk, o_g0)
        for i in range(n):
            wk[o_a1 + i] = wk[o_g0 + i]
        _sub_forces(n, m, sparse, nz, wk, o_f1, vf, o_vmi, wk, o_a1)
        for i in range(n):
            wk[o_a2 + i] = wk[o_g0 + i] + hh * wk[o_p + i]
        _sub_c(n, adt, hh, wk, o_a1, wk, o_a2)
        for k in range(m):
            wk[o_g2 + k] = _dot(n, sparse, nz, k, vf, 0, wk, o_a2)
            wk[o_gw2 + k] = _dot(n, sparse, nz, k, vf, o_wm, wk, o_a2)
        _sub_forces(n, m, sparse, nz, wk, o_f2, vf, o_vmi, wk, o_a2)
        # stages 3 and 4
        for k in range(m):
            a = wk[o_g1 + k]
            b = wk[o_gw1 + k]
            c = wk[o_g2 + k]
            d = wk[o_gw2 + k]
            for j in range(m):
                a -= mf[k * m + j] * wk[o_f1 + j]
                b -= mf[o_wv + k * m + j] * wk[o_f1 + j]
                c -= mf[k * m + j] * wk[o_f2 + j]
                d -= mf[o_wv + k * m + j] * wk[o_f2 + j]
            wk[o_f3 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint,
                               tau_ref + 0.5 * dtau + phase[k] + wk[o_wq + k] + hh * (wk[o_wd + k] + hh * b),
                               wk[o_xq + k] + hh * (wk[o_xd + k] + hh * a))
            wk[o_f4 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint,
                               tau_ref + dtau + phase[k] + wk[o_wq + k] + h * (wk[o_wd + k] + hh * d),
                               wk[o_xq + k] + h * (wk[o_xd + k] + hh * c))
        for i in range(n):
            wk[o_a3 + i] = wk[o_g0 + i] + hh * wk[o_p + i]
        _sub_k(n, nnz, kidx, aqv, hh2, wk, o_a1, wk, o_a3)
        _sub_c(n, adt, hh, wk, o_a2, wk, o_a3)
        _sub_forces(n, m, sparse, nz, wk, o_f3, vf, o_vmi, wk, o_a3)
        for i in range(n):
            wk[o_a4 + i] = wk[o_g0 + i] + h * wk[o_p + i]
        _sub_k(n, nnz, kidx, aqv, hhh, wk, o_a2, wk, o_a4)
        _sub_c(n, adt, h, wk, o_a3, wk, o_a4)
        _sub_forces(n, m, sparse, nz, wk, o_f4, vf, o_vmi, wk, o_a4)
        for i in range(n):
            s[i] += h * s[n + i] + c6q * (wk[o_a1 + i] + wk[o_a2 + i] + wk[o_a3 + i])
            s[n + i] += c6 * (wk[o_a1 + i] + 2.0 * wk[o_a2 + i] + 2.0 * wk[o_a3 + i] + wk[o_a4 + i])
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
                    x += vf[k * n + j] * s[j]
                    t += vf[o_wm + k * n + j] * s[j]
                    d += vf[o_rvm + k * n + j] * s[j]
                rec_out[nrec, 4 * k] = kin[1] + t
                rec_out[nrec, 4 * k + 1] = x
                rec_out[nrec, 4 * k + 2] = mesh_force(law, k, tab, tint, tflt, lin, lint, t, x)
                rec_out[nrec, 4 * k + 3] = d
            rec_out[nrec, 4 * m] = (step + 1) * h
            nrec += 1
    return nrec


@njit(cache=True, fastmath=_FM)
def _integrate_table_2_1(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u,
                         scal, iref, tab, tint, tflt, lin, lint, work, eff, kidx, kval, nz):
    return _integrate_impl(2, 1, LAW_TABLE, False, s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out,
                           mats, vecs, mmat, phase, u, scal, iref, tab, tint, tflt, lin, lint, work, eff, kidx,
                           kval, nz)


@njit(cache=True, fastmath=_FM)
def _integrate_table_4_1(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u,
                         scal, iref, tab, tint, tflt, lin, lint, work, eff, kidx, kval, nz):
    return _integrate_impl(4, 1, LAW_TABLE, False, s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out,
                           mats, vecs, mmat, phase, u, scal, iref, tab, tint, tflt, lin, lint, work, eff, kidx,
                           kval, nz)


@njit(cache=True, fastmath=_FM)
def _integrate_table_3_2(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u,
                         scal, iref, tab, tint, tflt, lin, lint, work, eff, kidx, kval, nz):
    return _integrate_impl(3, 2, LAW_TABLE, False, s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out,
                           mats, vecs, mmat, phase, u, scal, iref, tab, tint, tflt, lin, lint, work, eff, kidx,
                           kval, nz)


@njit(cache=True, fastmath=_FM)
def _integrate_table(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u, scal,
                     iref, tab, tint, tflt, lin, lint, work, eff, kidx, kval, nz):
    return _integrate_impl(s.shape[0] // 2, phase.shape[0], LAW_TABLE, True, s, kin, n_steps, h, mode, fext,
                           rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u, scal, iref, tab, tint, tflt,
                           lin, lint, work, eff, kidx, kval, nz)


@njit(cache=True, fastmath=_FM)
def _integrate_linear(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u, scal,
                      iref, tab, tint, tflt, lin, lint, work, eff, kidx, kval, nz):
    return _integrate_impl(s.shape[0] // 2, phase.shape[0], LAW_LINEAR, True, s, kin, n_steps, h, mode, fext,
                           rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u, scal, iref, tab, tint, tflt,
                           lin, lint, work, eff, kidx, kval, nz)


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
        work (7n + 12m,), eff (n, n) scratch,
        kidx (nnz, 2) int64 rows/columns of the entries of M^-1 K and M^-1 K_W the kernel multiplies: the n
            diagonal entries first (row i = column i = i), then the nonzero off-diagonal ones,
        kval (3, nnz) = [their values in M^-1 K, in M^-1 K_W, scratch],
        nz (m, 1 + w) int64: per mesh the count then the indices of the DOFs where its v, w or M^-1 v is nonzero
            (the generic loop runs its mesh products over them; the specialised loops are dense)

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
