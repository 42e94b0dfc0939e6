"""Compiled (numba) fixed-step RK4 integrator of the lumped gear dynamics: n DOFs, m meshes, full matrices.

One kernel serves every gear system (spur pairs, idler chains, planetary sets, helical pairs), the library
(simulator, steady state, sweeps, impulse tests) and every FMU.  It is a plain function over arrays,
allocation-free and without I/O.

Equations (deviations ``q`` from the reference motion, see :mod:`hacgear_core.dynamics.system`)::

    M q'' + (C + W_c G) q' + (K - W_c^2 K_W) q + sum_k [F_k(tau_k, x_k) v_k + Fc_k(tau_k, xc_k) vc_k] = f_ext
    x_k = v_k . q,   xc_k = vc_k . q,   tau_k = b_k + phase_k + w_k . q,   W_c = c_ratio * omega_ref

``b_k`` is mesh k's kinematic position: ``tau_ref`` on a mesh at the reference mesh frequency, else the fraction of
``(p_k / q_k) (cycles + tau_ref)`` (:func:`mesh_base`, exact in the whole cycles), so a gear train's stages run at
their own mesh frequencies (rate ``p_k / q_k``) while the state keeps the one reference position.

``F_k`` is mesh k's drive-flank force (its force law), ``Fc_k`` its coast-flank force (the coast table: contact
of the opposite flanks across the backlash, ``xc_k`` the coast approach along the coast line of action ``vc_k``).
Loops compiled one-sided skip every coast term; a system without coast tables uses them.

State::

    s    (2n,)     [q_0 .. q_{n-1}, q'_0 .. q'_{n-1}]
    kin  (3,) or (3 + m,)  [tau_ref in [0, 1), completed reference mesh cycles, omega_ref rad/s, then per mesh
                   the count of steps whose state lay beyond its tables' deflection range (added to)]

``tau_ref`` is the mesh position of the reference motion (the first mesh), advancing by
``zref_2pi * omega_ref`` per second; keeping it as (integer cycles, fraction) keeps float64 precision for
arbitrarily long runs.

Force laws (one per kernel variant, so the dispatch folds away at compile time):

``LAW_TABLE`` (0)
    HAC force-deflection function of each mesh: :func:`hacgear_core.tables.interp` bilinear rule on its table,
    clipped at >= 0 (teeth cannot pull).
``LAW_LINEAR`` (1)
    conventional mesh-stiffness law ``F = max(0, k(tau) (x - e(tau)) + f0(tau))`` with ``[k, e, f0]`` per
    mesh on its position grid, linear and periodic in position (dissertation Eqs. 3.6-3.8).
``LAW_TWIST`` (2)
    helical meshes (one-sided): the generalized FDF over (position, deflection x_k = v_k . q, twist
    g_k = t_k . q), mesh force W and twist moment M from one trilinear lookup
    (:func:`hacgear_core.tables.interp.trilinear_flat`), generalized force ``W v_k + M t_k``; the twist vector
    ``t_k`` and M ride in the coast slots (``vc_k``, ``Fc_k`` above), which such meshes do not use otherwise.
    A two-sided helical mesh is two meshes of this loop: its drive side k and its coast side m' + k (``m'`` the
    system's meshes), the coast side with the coast flanks' vectors and generalized FDF (0 below its onset); a
    drive-only table's coast side is a zero table whose range ends at the backlash (:func:`flatten_twist_tables`).
The coast side is always its table.

Manufacturing errors (variant bit ``VARIANT_ERRORS``, the generic table and linear-law loops): the drive-flank
force of mesh k is its law at ``x_k - e_k(c_k, x_k)``, ``c_k`` the unwrapped mesh position (whole cycles + ``tau_k``)
and ``e_k`` its error profile (:func:`mesh_error`; :mod:`hacgear_core.dynamics.gear_errors`), carried after the
conventional-law arrays in ``lin`` / ``lint`` (:func:`flatten_errors`); the coast-flank force of a two-sided mesh
is its coast table at ``xc_k - ec_k(c_k)``, ``ec_k`` its coast flanks' profile (the gears' runout), and these loops
take the coast terms in every step.  Loops without the bit are the error-free loops, unchanged.

Tables travel flattened: row ``r`` (drive tables of meshes 0..m-1, then their coast tables m..2m-1) is
``tab[o : o + Np * Nd]`` reshaped (Np, Nd) with ``(o, Np, Nd) = tint[r]`` and ``(x0, 1/dx, x_on, x_max) =
tflt[r]``: below ``x_on`` the table's force is 0 (no lookup), beyond ``x_max`` the state has left the table
(counted); the linear law's arrays likewise (``lin[o : o + 3 Np]``, rows k, e, f0, with ``(o, Np) = lint[k]``).

Modes: ``MODE_SPEED`` integrates the deviations around an imposed reference speed; ``MODE_TORQUE`` moves the
rigid-body rotation into the reference after every step (``q -= q_ref u``, ``tau_ref += sref zref_2pi q_ref``,
``omega_ref += sref q'_ref``, ``sref`` the reference gear's sense of rotation), so the reference follows the
reference gear exactly (drivetrain coupling; needs a rigid-body mode ``u`` with ``u[iref] = 1``).

Records (every ``rec_every`` steps): ``rec_state`` (nr, 2n); ``rec_out`` (nr, REC * m + 1) with, per mesh k at
``REC * k + j``: ``j = REC_POSITION`` unwrapped mesh position (cycles + fraction), ``REC_DEFLECTION`` mesh
deflection [m], ``REC_FORCE`` drive-flank force [N], ``REC_DTE`` dynamic transmission error (rotational part of
``v_k . q``) [m], ``REC_COAST_APPROACH`` coast approach ``xc_k`` [m], ``REC_COAST_FORCE`` coast-flank force [N];
and at ``REC * m`` the time since the call started [s].
"""
from __future__ import annotations

import logging
import math
import time

import numpy as np
from numba import njit, typeof
from numba.core import event
from numba.core.compiler import CompilerBase, DefaultPassBuilder

from hacgear_core.encodings import Experiment
from hacgear_core.tables.interp import periodic_cell, deflection_cell, trilinear_flat

__all__ = [
    "LAW_TABLE",
    "LAW_LINEAR",
    "LAW_TWIST",
    "REC",
    "REC_POSITION",
    "REC_DEFLECTION",
    "REC_FORCE",
    "REC_DTE",
    "REC_COAST_APPROACH",
    "REC_COAST_FORCE",
    "MODE_SPEED",
    "MODE_TORQUE",
    "mesh_force",
    "twist_force",
    "flatten_twist_tables",
    "table_row_force",
    "select_kernel",
    "kernel_label",
    "prepare_kernel",
    "COMPILE_LOGGER",
    "flatten_tables",
    "table_onset",
    "record_width",
    "record_fields",
    "flatten_linear",
    "flatten_errors",
    "mesh_error",
    "coast_error",
    "frame_angle",
    "VARIANT_ERRORS",
]

LAW_TABLE = 0
LAW_LINEAR = 1
LAW_TWIST = 2
#: the experiment as the kernel reads it (plain ints of :class:`~hacgear_core.encodings.Experiment`)
MODE_SPEED = int(Experiment.SPEED)
MODE_TORQUE = int(Experiment.TORQUE)
VARIANT_SPARSE = 2
VARIANT_TWO_SIDED = 4
VARIANT_TWIST = 8
#: manufacturing errors (pitch, runout): each mesh's drive-flank lookup deflection is shifted by its error profile
#: (:func:`mesh_error`); loops without the bit are the error-free loops, unchanged
VARIANT_ERRORS = 16
REC = 6
REC_POSITION = 0
REC_DEFLECTION = 1
REC_FORCE = 2
REC_DTE = 3
REC_COAST_APPROACH = 4
REC_COAST_FORCE = 5

_FM = {"contract"}


class _NoAliasCompiler(CompilerBase):
    """numba's nopython pipeline with the array arguments marked ``noalias`` (``Flags.noalias``), for the compiled
    loops whose arrays never overlap: without the mark the compiler must assume that a store into the scratch or
    the state may change the mesh vectors, matrices and tables, and loads them again after every store (and, in the
    batched loop, cannot vectorise the lane loops)."""

    def define_pipelines(self):
        self.state.flags.noalias = True
        return [DefaultPassBuilder.define_nopython_pipeline(self.state)]


@njit(cache=True, inline="always")
def mesh_base(p, q, cycles, tau_ref):
    """Kinematic position of a mesh running at ``p/q`` (integers as floats) times the reference mesh frequency,
    the reference at ``cycles`` (an integer as a float) + ``tau_ref`` [0, 1): its fraction in [0, 1) and its
    whole cycles, exact in the integer parts while ``p cycles < 2**53`` (any run length in float64)."""
    cm = cycles - q * math.floor(cycles / q)
    pm = p * cm
    r = pm - q * math.floor(pm / q)
    # a quotient, not a product: no multiply-add for the compiler to fuse, so every loop (contracting or not) and
    # the numpy twin round it alike
    s = r / q + tau_ref / (q / p)
    f = math.floor(s)
    return s - f, (p * cycles - r) / q + f


@njit(cache=True, inline="always")
def frame_angle(p, q, cycles, tau_ref):
    """The angle [rad] of one frame relative to another that turns ``p / q`` revolutions against it per
    reference mesh cycle, after ``cycles`` whole reference mesh cycles and ``tau_ref`` more (0 at the assembly
    position): ``2 pi ((p cycles mod q) + p tau_ref) / q``, exact in the whole cycles (``p cycles`` is an
    integer below 2**53, so the remainder is exact)."""
    pc = p * cycles
    return 2.0 * math.pi * (pc - q * math.floor(pc / q) + p * tau_ref) / q


@njit(cache=True, inline="always", fastmath=_FM)
def coast_error(lin, lint, m, k, pos):
    """Error [m] of mesh ``k``'s coast flanks at unwrapped mesh position ``pos`` [cycles]: the profile
    :func:`flatten_errors` keeps in rows ``3 m + k`` and ``4 m + k``, read by :func:`mesh_error` as mesh ``2 m + k``
    (over the position only; 0 without one)."""
    return mesh_error(lin, lint, m, 2 * m + k, pos, 0.0, 0.0, 0.0)


@njit(cache=True, inline="always", fastmath=_FM)
def mesh_error(lin, lint, m, k, pos, x, x0, inv_dx):
    """Error [m] of mesh ``k`` (of ``m``) at unwrapped mesh position ``pos`` [cycles] and approach ``x`` [m]: its
    error profile, linear and periodic over ``L`` mesh cycles at ``npc`` samples per cycle, ``lin[o : o + L npc]``
    (``nd = 0``: the same at every approach) or ``lin[o : o + L npc nd]`` (rows of ``nd`` approaches on the drive
    table's deflection grid ``x0 + j / inv_dx``, linear between them, constant beyond), with ``(o, npc) =
    lint[m + k]`` and ``(L, nd) = lint[2 m + k]`` (:func:`flatten_errors`; ``npc = 0``: no error, 0)."""
    npc = lint[m + k, 1]
    if npc == 0:
        return 0.0
    o = lint[m + k, 0]
    cyc = float(lint[2 * m + k, 0])
    nd = lint[2 * m + k, 1]
    u = (pos - cyc * math.floor(pos / cyc)) * npc
    ntot = lint[2 * m + k, 0] * npc
    i = int(math.floor(u))
    a = u - i
    if i >= ntot:
        i -= ntot
    if i < 0:
        i += ntot
    i1 = i + 1
    if i1 >= ntot:
        i1 = 0
    if nd == 0:
        return lin[o + i] + a * (lin[o + i1] - lin[o + i])
    r = (x - x0) * inv_dx
    j = int(math.floor(r))
    b = r - j
    if j < 0:
        j = 0
        b = 0.0
    elif j > nd - 2:
        j = nd - 2
        b = 1.0
    r0 = o + i * nd + j
    r1 = o + i1 * nd + j
    v0 = lin[r0] + b * (lin[r0 + 1] - lin[r0])
    v1 = lin[r1] + b * (lin[r1 + 1] - lin[r1])
    return v0 + a * (v1 - v0)


@njit(cache=True, inline="always")
def _ix(i):
    """``i`` itself, an index or count known to lie in [0, 2^31): the mask (a no-op on such values) tells the
    compiler that it is not negative, so numba's negative-index wraparound (a shift, an and and an add on every
    array access) folds away and the loops over runtime lengths vectorise.  Measured on the generic loop of the
    planetary sets: 1.2-1.9 x faster (docs/dynamics.md, "Kernel speed"), results bit-identical."""
    return i & 0x7FFFFFFF


@njit(cache=True, inline="always", fastmath=_FM)
def _table_force(tab, off, npos, nd, x0, inv_dx, tau, x):
    i, i1, a = periodic_cell(npos, tau)
    j, b = deflection_cell(nd, x0, inv_dx, x)
    off = _ix(off)
    nd = _ix(nd)
    r0 = off + _ix(i) * nd + _ix(j)
    r1 = off + _ix(i1) * nd + _ix(j)
    v0 = tab[r0] + b * (tab[r0 + 1] - tab[r0])
    v1 = tab[r1] + b * (tab[r1 + 1] - tab[r1])
    f = v0 + a * (v1 - v0)
    if f < 0.0:
        f = 0.0
    return f


@njit(cache=True, inline="always", fastmath=_FM)
def _linear_force(lin, off, npos, tau, x):
    i, i1, a = periodic_cell(npos, tau)
    off, npos, i, i1 = _ix(off), _ix(npos), _ix(i), _ix(i1)
    k = lin[off + i] + a * (lin[off + i1] - lin[off + i])
    e = lin[off + npos + i] + a * (lin[off + npos + i1] - lin[off + npos + i])
    f0 = lin[off + 2 * npos + i] + a * (lin[off + 2 * npos + i1] - lin[off + 2 * npos + i])
    f = k * (x - e) + f0
    if f < 0.0:
        f = 0.0
    return f


@njit(cache=True, inline="always", fastmath=_FM)
def table_row_force(tab, tint, tflt, r, tau, x):
    """Force [N] of table row ``r`` at ``tau`` [cycles], ``x`` [m]; 0 without a lookup below its onset.

    The coast lookups use it (the coast flanks are apart for most steps).  Drive-flank lookups go straight to the
    bilinear rule: the onset branch costs about 50 % of a one-sided step (measured) and gives the same 0 there.
    """
    if x < tflt[r, 2]:
        return 0.0
    return _table_force(tab, tint[r, 0], tint[r, 1], tint[r, 2], tflt[r, 0], tflt[r, 1], tau, x)


@njit(cache=True, inline="always", fastmath=_FM)
def mesh_force(law, k, tab, tint, tflt, lin, lint, tau, x):
    """Drive-flank force [N] of mesh ``k`` under force law ``law`` at mesh position ``tau`` [cycles], deflection
    ``x`` [m]."""
    if law == LAW_TABLE:
        return _table_force(tab, tint[k, 0], tint[k, 1], tint[k, 2], tflt[k, 0], tflt[k, 1], tau, x)
    return _linear_force(lin, lint[k, 0], lint[k, 1], tau, x)


@njit(cache=True, inline="always", fastmath=_FM)
def twist_force(k, m, tab, tint, tflt, tau, x, g):
    """Mesh force W [N] and twist moment M [N m] of helical mesh ``k`` (of ``m``) at mesh position ``tau``
    [cycles], deflection ``x`` [m] and twist ``g`` [rad]: the trilinear rule of :mod:`hacgear_core.tables.interp`
    on its generalized FDF (row ``k``: ``(offset, Np, Nd)``, ``(x0, 1/dx, ., .)``; row ``m + k``: ``(offset, Nt,
    2)``, ``(g0, 1/dg, ., .)``).  Teeth apart (W <= 0): both 0 (teeth cannot pull, an open mesh carries no
    moment)."""
    npos = _ix(tint[k, 1])
    nd = _ix(tint[k, 2])
    nt = _ix(tint[m + k, 1])
    i, i1, a = periodic_cell(npos, tau)
    j, b = deflection_cell(nd, tflt[k, 0], tflt[k, 1], x)
    mm, t = deflection_cell(nt, tflt[m + k, 0], tflt[m + k, 1], g)
    off = _ix(tint[k, 0])
    i, i1, j, mm = _ix(i), _ix(i1), _ix(j), _ix(mm)
    w = trilinear_flat(tab, off, nd, nt, 2, 0, i, i1, a, j, b, mm, t)
    if w <= 0.0:
        return 0.0, 0.0
    return w, trilinear_flat(tab, off, nd, nt, 2, 1, i, i1, a, j, b, mm, t)


@njit(cache=True, inline="always", fastmath=_FM)
def _sub_k(n, sparse, nnz, kidx, aqv, c, x, ox, out, oo):
    """``out[oo:oo+n] -= c (M^-1 K_eff) x[ox:ox+n]``: the diagonal (``aqv[:n]``) then the nonzero off-diagonal
    entries.  Only the generic (``sparse``) loops mask the indices: in the loops specialised to constant sizes the
    mask changes how the compiler contracts the multiply-adds of the off-diagonal entries (results move by
    rounding, 1e-14 relative) without making them faster."""
    for i in range(n):
        out[oo + i] -= c * aqv[i] * x[ox + i]
    if sparse:
        for z in range(n, nnz):
            out[oo + _ix(kidx[z, 0])] -= c * aqv[z] * x[ox + _ix(kidx[z, 1])]
    else:
        for z in range(n, nnz):
            out[oo + kidx[z, 0]] -= c * aqv[z] * x[ox + kidx[z, 1]]


@njit(cache=True, inline="always", fastmath=_FM)
def _sub_c(n, sparse, adt, c, x, ox, out, oo):
    """``out[oo:oo+n] -= c (M^-1 C_eff) x[ox:ox+n]`` column by column (``adt`` is its transpose, flat (n*n,)).

    The generic (``sparse``) loops take the columns eight, then four at a time: each ``out`` entry is loaded and
    stored once per block instead of once per column (the compiler cannot keep it in a register, as it cannot tell
    ``out`` from ``adt``), with the same subtractions in the same order, so the same result (bit-identical on
    every shipped system).  Measured per mesh cycle of the planetary sets (n = 14, 20): 1.04-1.10x
    (docs/dynamics.md, "Kernel speed")."""
    j = 0
    if sparse:
        while j + 7 < n:
            b0 = c * x[ox + j]
            b1 = c * x[ox + j + 1]
            b2 = c * x[ox + j + 2]
            b3 = c * x[ox + j + 3]
            b4 = c * x[ox + j + 4]
            b5 = c * x[ox + j + 5]
            b6 = c * x[ox + j + 6]
            b7 = c * x[ox + j + 7]
            r = _ix(j * n)
            for i in range(n):
                out[oo + i] = (((((((out[oo + i] - adt[r + i] * b0) - adt[r + n + i] * b1)
                                   - adt[r + 2 * n + i] * b2) - adt[r + 3 * n + i] * b3)
                                 - adt[r + 4 * n + i] * b4) - adt[r + 5 * n + i] * b5)
                               - adt[r + 6 * n + i] * b6) - adt[r + 7 * n + i] * b7
            j += 8
        while j + 3 < n:
            b0 = c * x[ox + j]
            b1 = c * x[ox + j + 1]
            b2 = c * x[ox + j + 2]
            b3 = c * x[ox + j + 3]
            r = _ix(j * n)
            for i in range(n):
                out[oo + i] = (((out[oo + i] - adt[r + i] * b0) - adt[r + n + i] * b1)
                               - adt[r + 2 * n + i] * b2) - adt[r + 3 * n + i] * b3
            j += 4
    for j in range(j, n):
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
            j = _ix(nz[k, p])
            a += vf[ov + k * n + j] * x[ox + j]
    else:
        for j in range(n):
            a += vf[ov + k * n + j] * x[ox + j]
    return a


@njit(cache=True, inline="always", fastmath=_FM)
def _dot3(n, nz, k, vf, o1, o2, o3, x, ox):
    """Three sparse :func:`_dot` products in one pass over mesh k's pattern: its vectors at offsets ``o1``,
    ``o2``, ``o3`` of ``vf`` with ``x[ox : ox + n]`` (each sum in the same order as ``_dot``'s)."""
    a = 0.0
    b = 0.0
    c = 0.0
    for p in range(1, nz[k, 0] + 1):
        j = _ix(nz[k, p])
        y = x[ox + j]
        a += vf[o1 + k * n + j] * y
        b += vf[o2 + k * n + j] * y
        c += vf[o3 + k * n + j] * y
    return a, b, c


@njit(cache=True, inline="always", fastmath=_FM)
def _dot_state(n, nz, k, vf, o_w, o_vc, s):
    """Mesh k's ``v.q, v.q', w.q, w.q', vc.q, vc.q'`` of the state ``s`` in one pass over its sparse pattern (the
    sums of :func:`_dot`, in its order)."""
    xq = 0.0
    xd = 0.0
    wq = 0.0
    wd = 0.0
    cq = 0.0
    cd = 0.0
    for p in range(1, nz[k, 0] + 1):
        j = _ix(nz[k, p])
        q = s[j]
        d = s[n + j]
        v = vf[k * n + j]
        w = vf[o_w + k * n + j]
        c = vf[o_vc + k * n + j]
        xq += v * q
        xd += v * d
        wq += w * q
        wd += w * d
        cq += c * q
        cd += c * d
    return xq, xd, wq, wd, cq, cd


@njit(cache=True, inline="always", fastmath=_FM)
def _sub_forces(n, m, sparse, nz, f, of, vmi, ov, out, oo):
    """``out[oo:oo+n] -= sum_k f[of+k] (M^-1 v_k)`` with ``M^-1 v_k = vmi[ov + k n : ov + (k+1) n]``."""
    for k in range(m):
        c = f[of + k]
        if sparse:
            for p in range(1, nz[k, 0] + 1):
                i = _ix(nz[k, p])
                out[oo + i] -= c * vmi[ov + k * n + i]
        else:
            for i in range(n):
                out[oo + i] -= c * vmi[ov + k * n + i]


@njit(cache=True, inline="always", fastmath=_FM)
def _sub_coast_forces(n, m, sparse, nz, f, of, vci, ov, out, oo):
    """``out[oo:oo+n] -= sum_k f[of+k] (M^-1 vc_k)`` over the meshes in coast contact (most steps: none)."""
    for k in range(m):
        c = f[of + k]
        if c != 0.0:
            if sparse:
                for p in range(1, nz[k, 0] + 1):
                    i = _ix(nz[k, p])
                    out[oo + i] -= c * vci[ov + k * n + i]
            else:
                for i in range(n):
                    out[oo + i] -= c * vci[ov + k * n + i]


def _make_loop(name: str, n_fixed: int, m_fixed: int, variant: int):
    """The compiled RK4 loop of one specialisation, called ``name`` (see :func:`select_kernel` for its arguments).

    ``n_fixed``, ``m_fixed``: DOFs and meshes the loop is specialised to (0: the sizes of its arguments, the generic
    loop); ``variant``: bit 0 the force law, bit 1 sparse mesh loops, bit 2 two-sided meshes, bit 3 helical meshes
    (law ``LAW_TWIST``: the coast slots carry the mesh twist, vc = the twist vectors t_k and Fc = the twist moments
    M_k, in every step; the drive slots the mesh force W of the same trilinear lookup).  Sizes and flags are
    constants of the returned function (closure variables), so numba drops the branches of the other force laws and
    variants before it inlines the helpers into the loop: it types and lowers only this specialisation's code
    (about a sixth of the compile time and memory of one body holding every variant, whose dead branches only
    LLVM removed; docs/dynamics.md, "Compile time").  Each loop carries ``name`` as its own name, so numba keeps
    a cache index per specialisation (processes compiling different ones at the same time never share an index).
    """
    law_c = variant & 1
    sparse_c = (variant & 2) != 0
    two_sided_c = (variant & 4) != 0
    twist_c = (variant & 8) != 0
    errors_c = (variant & VARIANT_ERRORS) != 0

    def loop(s, kin, n_steps, h, mode, fext, rec_every, rec_state, rec_out, mats, vecs, mmat, phase, u, scal, iref,
             tab, tint, tflt, lin, lint, work, eff, kidx, kval, nz):
        n = _ix(n_fixed if n_fixed else s.shape[0] // 2)
        m = _ix(m_fixed if m_fixed else phase.shape[1])
        law = law_c
        sparse = sparse_c
        two_sided = two_sided_c
        twist = twist_c
        errors = errors_c
        # RK4 of q'' = a(q, q', F).  The force-free acceleration is linear in (q, q'), so every stage's is the
        # first stage's g0 plus products with the earlier stages' accelerations a1..a3 (hh = h/2):
        #   a2 = g0 + hh p - hh C a1                  - F2 M^-1 v - Fc2 M^-1 vc      (p = -K q')
        #   a3 = g0 + hh p - hh^2 K a1 - hh C a2       - F3 M^-1 v - Fc3 M^-1 vc
        #   a4 = g0 + h p  - h hh K a2 - h C a3        - F4 M^-1 v - Fc4 M^-1 vc
        #   q  += h q' + h^2/6 (a1 + a2 + a3),   q' += h/6 (a1 + 2 a2 + 2 a3 + a4)
        # (K, C here M^-1 K_eff, M^-1 C_eff).  The stage mesh deflections and positions are formed from scalars:
        # with x_q = v.q, x_d = v.q', g = v.(force-free acceleration), stage 2 needs x_q + hh x_d, stage 3
        # x_q + hh (x_d + hh v.a1), stage 4 x_q + h (x_d + hh v.a2), where v.a1 = g_1 - VV F_1 - VVc Fc_1 (VV =
        # v M^-1 v^T, VVc = v M^-1 vc^T); likewise for w (positions) and vc (coast approaches).  So each table
        # lookup waits on a few multiply-adds after an earlier lookup, not on a full stage update.
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
        mn = m * n
        mm = m * m
        o_w = mn
        o_rv = 2 * mn
        o_vmi = 3 * mn
        o_vc = 4 * mn
        o_vci = 5 * mn
        o_wv = mm
        o_cv = 2 * mm
        o_vvc = 3 * mm
        o_wvc = 4 * mm
        o_cvc = 5 * mm
        c_ratio = scal[0]
        sref = scal[1]
        zref_2pi = scal[2]
        # frame couplings (the generic loops only): springs between translations in frames that turn against each
        # other, K(t) = K + sum_p [(cos D_p - 1) Kc_p + sin D_p Ks_p] (:func:`frame_angle`), M^-1 Kc_p and M^-1 Ks_p
        # in kval rows 3 + 2p and 4 + 2p, each frame pair's rate (p, q) in scal[3 + 2p], scal[4 + 2p]
        nfr = (scal.shape[0] - 3) // 2 if sparse_c else 0
        o_fr = 7 * n + 22 * m
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
        o_cq = 7 * n + 12 * m
        o_cd = 7 * n + 13 * m
        o_c1 = 7 * n + 14 * m
        o_c2 = 7 * n + 15 * m
        o_c3 = 7 * n + 16 * m
        o_c4 = 7 * n + 17 * m
        o_gc1 = 7 * n + 18 * m
        o_gc2 = 7 * n + 19 * m
        o_tb = 7 * n + 20 * m
        o_td = 7 * n + 21 * m
        unit_rates = True
        for k in range(m):
            if phase[1, k] != phase[2, k]:
                unit_rates = False
        for i in range(n):
            a = 0.0
            for j in range(n):
                a += minv[i, j] * fext[j]
            wk[o_fm + i] = a
        for k in range(m):
            wk[o_c1 + k] = 0.0
            wk[o_c2 + k] = 0.0
            wk[o_c3 + k] = 0.0
            wk[o_c4 + k] = 0.0
        count = kin.shape[0] >= 3 + m
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
            dtau = zref_2pi * omega * h
            if nfr > 0:
                # the frames' relative angles at the step's middle, held over the step
                oc = c_ratio * omega
                for ip in range(nfr):
                    ang = frame_angle(scal[3 + 2 * ip], scal[4 + 2 * ip], kin[1], tau_ref + 0.5 * dtau)
                    wk[o_fr + 2 * ip] = math.cos(ang) - 1.0
                    wk[o_fr + 2 * ip + 1] = math.sin(ang)
                for z in range(nnz):
                    a = mk[z] - oc * oc * mkw[z]
                    for ip in range(nfr):
                        a += wk[o_fr + 2 * ip] * kval[3 + 2 * ip, z] + wk[o_fr + 2 * ip + 1] * kval[4 + 2 * ip, z]
                    aqv[z] = a
                if rotating and oc != omega_c_set:
                    for i in range(n):
                        for j in range(n):
                            adt[j * n + i] = mc[i, j] + oc * mg[i, j]
                    omega_c_set = oc
            elif rotating:
                oc = c_ratio * omega
                if oc != omega_c_set:
                    for z in range(nnz):
                        aqv[z] = mk[z] - oc * oc * mkw[z]
                    for i in range(n):
                        for j in range(n):
                            adt[j * n + i] = mc[i, j] + oc * mg[i, j]
                    omega_c_set = oc
            # each mesh's kinematic position at the step start and its advance over the step (mesh_base)
            for k in range(m):
                if unit_rates:
                    wk[o_tb + k] = tau_ref
                    wk[o_td + k] = dtau
                else:
                    wk[o_tb + k], _ = mesh_base(phase[1, k], phase[2, k], kin[1], tau_ref)
                    wk[o_td + k] = (phase[1, k] / phase[2, k]) * dtau
            # the generic loops form each mesh's step-start products (and below its stage products) in one pass over
            # its pattern: fewer index loads, the same sums (1.04-1.17x per mesh cycle on the planetary sets, measured);
            # the coast products come along in the same pass and are read only where the coast terms are on
            for k in range(m):
                if sparse:
                    wk[o_xq + k], wk[o_xd + k], wk[o_wq + k], wk[o_wd + k], wk[o_cq + k], wk[o_cd + k] = _dot_state(
                        n, nz, k, vf, o_w, o_vc, s)
                    continue
                # all products first, then their stores (each product reads only s and vf)
                xq = _dot(n, sparse, nz, k, vf, 0, s, 0)
                xd = _dot(n, sparse, nz, k, vf, 0, s, n)
                wq = _dot(n, sparse, nz, k, vf, o_w, s, 0)
                wd = _dot(n, sparse, nz, k, vf, o_w, s, n)
                if two_sided or twist:
                    cq = _dot(n, sparse, nz, k, vf, o_vc, s, 0)
                    cd = _dot(n, sparse, nz, k, vf, o_vc, s, n)
                    wk[o_cq + k] = cq
                    wk[o_cd + k] = cd
                wk[o_xq + k] = xq
                wk[o_xd + k] = xd
                wk[o_wq + k] = wq
                wk[o_wd + k] = wd
            if count:
                for k in range(m):
                    # a helical side's twist counts where its flanks touch (an open side carries no moment)
                    if wk[o_xq + k] > tflt[k, 3] or (two_sided and wk[o_cq + k] > tflt[m + k, 3]) or (
                            twist and wk[o_xq + k] > tflt[k, 2]
                            and (wk[o_cq + k] < tflt[m + k, 2] or wk[o_cq + k] > tflt[m + k, 3])):
                        kin[3 + k] += 1.0
            # Coast terms only in steps where the coast flanks may touch: stages 1 and 2 are checked from the
            # step-start scalars; a step staged without them is checked again with its stage accelerations (vc . a1,
            # vc . a2 are the coast stages' e1, e2) and restaged with them if a coast approach reaches within 1e-12 m
            # of its table's onset (far above the rounding of the two ways of forming it), so skipping is exact.  Under
            # load the coast flanks stay apart and a two-sided step costs four dot products per mesh more than a
            # one-sided one (measured on the spur 4-DOF pair: about 1.04x per mesh cycle, against 1.3x with the coast
            # terms in every step; docs/dynamics.md, "What the check costs").
            coast_on = twist
            if errors and two_sided:
                # the coast flanks' errors move their onset: the error loops take the coast terms in every step
                coast_on = True
            elif two_sided:
                for k in range(m):
                    lim = tflt[m + k, 2] - 1e-12
                    if wk[o_cq + k] >= lim or wk[o_cq + k] + hh * wk[o_cd + k] >= lim:
                        coast_on = True
            while True:
                # stages 1 and 2: their lookups need only the state
                for k in range(m):
                    t1 = wk[o_tb + k] + phase[0, k] + wk[o_wq + k]
                    t2 = wk[o_tb + k] + 0.5 * wk[o_td + k] + phase[0, k] + wk[o_wq + k] + hh * wk[o_wd + k]
                    if twist and errors:
                        wh = kin[1] if unit_rates else mesh_base(phase[1, k], phase[2, k], kin[1], tau_ref)[1]
                        x1 = wk[o_xq + k]
                        x2 = wk[o_xq + k] + hh * wk[o_xd + k]
                        wk[o_f1 + k], wk[o_c1 + k] = twist_force(
                            k, m, tab, tint, tflt, t1, x1 - mesh_error(lin, lint, m, k, wh + t1, x1, tflt[k, 0], tflt[k, 1]),
                            wk[o_cq + k])
                        wk[o_f2 + k], wk[o_c2 + k] = twist_force(
                            k, m, tab, tint, tflt, t2, x2 - mesh_error(lin, lint, m, k, wh + t2, x2, tflt[k, 0], tflt[k, 1]),
                            wk[o_cq + k] + hh * wk[o_cd + k])
                        continue
                    if twist:
                        wk[o_f1 + k], wk[o_c1 + k] = twist_force(k, m, tab, tint, tflt, t1, wk[o_xq + k], wk[o_cq + k])
                        wk[o_f2 + k], wk[o_c2 + k] = twist_force(k, m, tab, tint, tflt, t2, wk[o_xq + k] + hh * wk[o_xd + k],
                                                                 wk[o_cq + k] + hh * wk[o_cd + k])
                        continue
                    if errors:
                        # the drive flanks' lookup deflection less the error of the tooth pairs in contact
                        wh = kin[1] if unit_rates else mesh_base(phase[1, k], phase[2, k], kin[1], tau_ref)[1]
                        x1 = wk[o_xq + k]
                        x2 = wk[o_xq + k] + hh * wk[o_xd + k]
                        wk[o_f1 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, t1,
                                                  x1 - mesh_error(lin, lint, m, k, wh + t1, x1, tflt[k, 0], tflt[k, 1]))
                        wk[o_f2 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, t2,
                                                  x2 - mesh_error(lin, lint, m, k, wh + t2, x2, tflt[k, 0], tflt[k, 1]))
                    else:
                        wk[o_f1 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, t1, wk[o_xq + k])
                        wk[o_f2 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, t2,
                                                  wk[o_xq + k] + hh * wk[o_xd + k])
                    if coast_on:
                        c1x = wk[o_cq + k]
                        c2x = wk[o_cq + k] + hh * wk[o_cd + k]
                        if errors:
                            wh = kin[1] if unit_rates else mesh_base(phase[1, k], phase[2, k], kin[1], tau_ref)[1]
                            c1x -= coast_error(lin, lint, m, k, wh + t1)
                            c2x -= coast_error(lin, lint, m, k, wh + t2)
                        wk[o_c1 + k] = table_row_force(tab, tint, tflt, m + k, t1, c1x)
                        wk[o_c2 + k] = table_row_force(tab, tint, tflt, m + k, t2, c2x)
                for i in range(n):
                    wk[o_g0 + i] = wk[o_fm + i]
                    wk[o_p + i] = 0.0
                _sub_k(n, sparse, nnz, kidx, aqv, 1.0, s, 0, wk, o_g0)
                _sub_k(n, sparse, nnz, kidx, aqv, 1.0, s, n, wk, o_p)
                _sub_c(n, sparse, adt, 1.0, s, n, wk, o_g0)
                for k in range(m):
                    if sparse:
                        wk[o_g1 + k], wk[o_gw1 + k], wk[o_gc1 + k] = _dot3(n, nz, k, vf, 0, o_w, o_vc, wk, o_g0)
                        continue
                    wk[o_g1 + k] = _dot(n, sparse, nz, k, vf, 0, wk, o_g0)
                    wk[o_gw1 + k] = _dot(n, sparse, nz, k, vf, o_w, wk, o_g0)
                    if coast_on:
                        wk[o_gc1 + k] = _dot(n, sparse, nz, k, vf, o_vc, wk, o_g0)
                for i in range(n):
                    wk[o_a1 + i] = wk[o_g0 + i]
                _sub_forces(n, m, sparse, nz, wk, o_f1, vf, o_vmi, wk, o_a1)
                if coast_on:
                    _sub_coast_forces(n, m, sparse, nz, wk, o_c1, vf, o_vci, wk, o_a1)
                for i in range(n):
                    wk[o_a2 + i] = wk[o_g0 + i] + hh * wk[o_p + i]
                _sub_c(n, sparse, adt, hh, wk, o_a1, wk, o_a2)
                for k in range(m):
                    if sparse:
                        wk[o_g2 + k], wk[o_gw2 + k], wk[o_gc2 + k] = _dot3(n, nz, k, vf, 0, o_w, o_vc, wk, o_a2)
                        continue
                    wk[o_g2 + k] = _dot(n, sparse, nz, k, vf, 0, wk, o_a2)
                    wk[o_gw2 + k] = _dot(n, sparse, nz, k, vf, o_w, wk, o_a2)
                    if coast_on:
                        wk[o_gc2 + k] = _dot(n, sparse, nz, k, vf, o_vc, wk, o_a2)
                _sub_forces(n, m, sparse, nz, wk, o_f2, vf, o_vmi, wk, o_a2)
                if coast_on:
                    _sub_coast_forces(n, m, sparse, nz, wk, o_c2, vf, o_vci, wk, o_a2)
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
                    # the coast stages' products, read only where the coast terms are on (defined on every path:
                    # numba types a loop whose pruned variants leave them unset on some)
                    e1 = 0.0
                    e2 = 0.0
                    if coast_on:
                        e1 = wk[o_gc1 + k]
                        e2 = wk[o_gc2 + k]
                        for j in range(m):
                            a -= mf[o_vvc + k * m + j] * wk[o_c1 + j]
                            b -= mf[o_wvc + k * m + j] * wk[o_c1 + j]
                            c -= mf[o_vvc + k * m + j] * wk[o_c2 + j]
                            d -= mf[o_wvc + k * m + j] * wk[o_c2 + j]
                            e1 -= mf[o_cv + k * m + j] * wk[o_f1 + j] + mf[o_cvc + k * m + j] * wk[o_c1 + j]
                            e2 -= mf[o_cv + k * m + j] * wk[o_f2 + j] + mf[o_cvc + k * m + j] * wk[o_c2 + j]
                    t3 = wk[o_tb + k] + 0.5 * wk[o_td + k] + phase[0, k] + wk[o_wq + k] + hh * (wk[o_wd + k] + hh * b)
                    t4 = wk[o_tb + k] + wk[o_td + k] + phase[0, k] + wk[o_wq + k] + h * (wk[o_wd + k] + hh * d)
                    if twist and errors:
                        wh = kin[1] if unit_rates else mesh_base(phase[1, k], phase[2, k], kin[1], tau_ref)[1]
                        x3 = wk[o_xq + k] + hh * (wk[o_xd + k] + hh * a)
                        x4 = wk[o_xq + k] + h * (wk[o_xd + k] + hh * c)
                        wk[o_f3 + k], wk[o_c3 + k] = twist_force(
                            k, m, tab, tint, tflt, t3, x3 - mesh_error(lin, lint, m, k, wh + t3, x3, tflt[k, 0], tflt[k, 1]),
                            wk[o_cq + k] + hh * (wk[o_cd + k] + hh * e1))
                        wk[o_f4 + k], wk[o_c4 + k] = twist_force(
                            k, m, tab, tint, tflt, t4, x4 - mesh_error(lin, lint, m, k, wh + t4, x4, tflt[k, 0], tflt[k, 1]),
                            wk[o_cq + k] + h * (wk[o_cd + k] + hh * e2))
                        continue
                    if twist:
                        wk[o_f3 + k], wk[o_c3 + k] = twist_force(k, m, tab, tint, tflt, t3,
                                                                 wk[o_xq + k] + hh * (wk[o_xd + k] + hh * a),
                                                                 wk[o_cq + k] + hh * (wk[o_cd + k] + hh * e1))
                        wk[o_f4 + k], wk[o_c4 + k] = twist_force(k, m, tab, tint, tflt, t4,
                                                                 wk[o_xq + k] + h * (wk[o_xd + k] + hh * c),
                                                                 wk[o_cq + k] + h * (wk[o_cd + k] + hh * e2))
                        continue
                    if errors:
                        wh = kin[1] if unit_rates else mesh_base(phase[1, k], phase[2, k], kin[1], tau_ref)[1]
                        x3 = wk[o_xq + k] + hh * (wk[o_xd + k] + hh * a)
                        x4 = wk[o_xq + k] + h * (wk[o_xd + k] + hh * c)
                        wk[o_f3 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, t3,
                                                  x3 - mesh_error(lin, lint, m, k, wh + t3, x3, tflt[k, 0], tflt[k, 1]))
                        wk[o_f4 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, t4,
                                                  x4 - mesh_error(lin, lint, m, k, wh + t4, x4, tflt[k, 0], tflt[k, 1]))
                    else:
                        wk[o_f3 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, t3,
                                                  wk[o_xq + k] + hh * (wk[o_xd + k] + hh * a))
                        wk[o_f4 + k] = mesh_force(law, k, tab, tint, tflt, lin, lint, t4,
                                                  wk[o_xq + k] + h * (wk[o_xd + k] + hh * c))
                    if coast_on:
                        c3x = wk[o_cq + k] + hh * (wk[o_cd + k] + hh * e1)
                        c4x = wk[o_cq + k] + h * (wk[o_cd + k] + hh * e2)
                        if errors:
                            wh = kin[1] if unit_rates else mesh_base(phase[1, k], phase[2, k], kin[1], tau_ref)[1]
                            c3x -= coast_error(lin, lint, m, k, wh + t3)
                            c4x -= coast_error(lin, lint, m, k, wh + t4)
                        wk[o_c3 + k] = table_row_force(tab, tint, tflt, m + k, t3, c3x)
                        wk[o_c4 + k] = table_row_force(tab, tint, tflt, m + k, t4, c4x)
                for i in range(n):
                    wk[o_a3 + i] = wk[o_g0 + i] + hh * wk[o_p + i]
                _sub_k(n, sparse, nnz, kidx, aqv, hh2, wk, o_a1, wk, o_a3)
                _sub_c(n, sparse, adt, hh, wk, o_a2, wk, o_a3)
                _sub_forces(n, m, sparse, nz, wk, o_f3, vf, o_vmi, wk, o_a3)
                if coast_on:
                    _sub_coast_forces(n, m, sparse, nz, wk, o_c3, vf, o_vci, wk, o_a3)
                for i in range(n):
                    wk[o_a4 + i] = wk[o_g0 + i] + h * wk[o_p + i]
                _sub_k(n, sparse, nnz, kidx, aqv, hhh, wk, o_a2, wk, o_a4)
                _sub_c(n, sparse, adt, h, wk, o_a3, wk, o_a4)
                _sub_forces(n, m, sparse, nz, wk, o_f4, vf, o_vmi, wk, o_a4)
                if coast_on:
                    _sub_coast_forces(n, m, sparse, nz, wk, o_c4, vf, o_vci, wk, o_a4)
                if not two_sided or coast_on:
                    break
                # staged one-sided in a two-sided loop: do the coast approaches of stages 3 and 4 stay apart?
                for k in range(m):
                    lim = tflt[m + k, 2] - 1e-12
                    e1 = _dot(n, sparse, nz, k, vf, o_vc, wk, o_a1)
                    e2 = _dot(n, sparse, nz, k, vf, o_vc, wk, o_a2)
                    if (wk[o_cq + k] + hh * (wk[o_cd + k] + hh * e1) >= lim
                            or wk[o_cq + k] + h * (wk[o_cd + k] + hh * e2) >= lim):
                        coast_on = True
                if not coast_on:
                    break
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
                    if unit_rates:
                        base, whole = tau_ref, kin[1]
                    else:
                        base, whole = mesh_base(phase[1, k], phase[2, k], kin[1], tau_ref)
                    t = base + phase[0, k]
                    d = 0.0
                    xc = 0.0
                    for j in range(n):
                        x += vf[k * n + j] * s[j]
                        t += vf[o_w + k * n + j] * s[j]
                        d += vf[o_rv + k * n + j] * s[j]
                        xc += vf[o_vc + k * n + j] * s[j]
                    rec_out[nrec, REC * k + REC_POSITION] = whole + t
                    rec_out[nrec, REC * k + REC_DEFLECTION] = x
                    rec_out[nrec, REC * k + REC_DTE] = d
                    rec_out[nrec, REC * k + REC_COAST_APPROACH] = xc
                    if twist:
                        xl = x - mesh_error(lin, lint, m, k, whole + t, x, tflt[k, 0], tflt[k, 1]) if errors else x
                        wt, mt = twist_force(k, m, tab, tint, tflt, t, xl, xc)
                        rec_out[nrec, REC * k + REC_FORCE] = wt
                        rec_out[nrec, REC * k + REC_COAST_FORCE] = mt
                    else:
                        xl = x - mesh_error(lin, lint, m, k, whole + t, x, tflt[k, 0], tflt[k, 1]) if errors else x
                        rec_out[nrec, REC * k + REC_FORCE] = mesh_force(law, k, tab, tint, tflt, lin, lint, t, xl)
                        xcl = xc - coast_error(lin, lint, m, k, whole + t) if errors else xc
                        rec_out[nrec, REC * k + REC_COAST_FORCE] = (table_row_force(tab, tint, tflt, m + k, t, xcl)
                                                                    if two_sided else 0.0)
                rec_out[nrec, REC * m] = (step + 1) * h
                nrec += 1
        return nrec

    loop.__name__ = loop.__qualname__ = name
    return njit(cache=True, fastmath=_FM, pipeline_class=_NoAliasCompiler)(loop)




_table_2_1_s1 = _make_loop("_table_2_1_s1", 2, 1, LAW_TABLE)
_table_4_1_s1 = _make_loop("_table_4_1_s1", 4, 1, LAW_TABLE)
_table_3_2_s1 = _make_loop("_table_3_2_s1", 3, 2, LAW_TABLE)
_table_s1 = _make_loop("_table_s1", 0, 0, LAW_TABLE | VARIANT_SPARSE)
_linear_s1 = _make_loop("_linear_s1", 0, 0, LAW_LINEAR | VARIANT_SPARSE)
_table_2_1_s2 = _make_loop("_table_2_1_s2", 2, 1, LAW_TABLE | VARIANT_TWO_SIDED)
_table_4_1_s2 = _make_loop("_table_4_1_s2", 4, 1, LAW_TABLE | VARIANT_TWO_SIDED)
_table_3_2_s2 = _make_loop("_table_3_2_s2", 3, 2, LAW_TABLE | VARIANT_TWO_SIDED)
_table_s2 = _make_loop("_table_s2", 0, 0, LAW_TABLE | VARIANT_SPARSE | VARIANT_TWO_SIDED)
_linear_s2 = _make_loop("_linear_s2", 0, 0, LAW_LINEAR | VARIANT_SPARSE | VARIANT_TWO_SIDED)
_twist_12_1 = _make_loop("_twist_12_1", 12, 1, LAW_TABLE | VARIANT_TWIST)
_twist_s = _make_loop("_twist_s", 0, 0, LAW_TABLE | VARIANT_SPARSE | VARIANT_TWIST)

_twist_s_e = _make_loop("_twist_s_e", 0, 0, LAW_TABLE | VARIANT_SPARSE | VARIANT_TWIST | VARIANT_ERRORS)
_table_s1_e = _make_loop("_table_s1_e", 0, 0, LAW_TABLE | VARIANT_SPARSE | VARIANT_ERRORS)
_linear_s1_e = _make_loop("_linear_s1_e", 0, 0, LAW_LINEAR | VARIANT_SPARSE | VARIANT_ERRORS)
_table_s2_e = _make_loop("_table_s2_e", 0, 0, LAW_TABLE | VARIANT_SPARSE | VARIANT_TWO_SIDED | VARIANT_ERRORS)
_linear_s2_e = _make_loop("_linear_s2_e", 0, 0, LAW_LINEAR | VARIANT_SPARSE | VARIANT_TWO_SIDED | VARIANT_ERRORS)

_SPECIAL = {(LAW_TABLE, 2, 1, False): _table_2_1_s1, (LAW_TABLE, 4, 1, False): _table_4_1_s1,
            (LAW_TABLE, 3, 2, False): _table_3_2_s1, (LAW_TABLE, 2, 1, True): _table_2_1_s2,
            (LAW_TABLE, 4, 1, True): _table_4_1_s2, (LAW_TABLE, 3, 2, True): _table_3_2_s2}
_GENERIC = {(LAW_TABLE, False): _table_s1, (LAW_TABLE, True): _table_s2, (LAW_LINEAR, False): _linear_s1,
            (LAW_LINEAR, True): _linear_s2}
_ERRORS = {(LAW_TABLE, False): _table_s1_e, (LAW_TABLE, True): _table_s2_e, (LAW_LINEAR, False): _linear_s1_e,
           (LAW_LINEAR, True): _linear_s2_e}


def select_kernel(law: int, n: int, m: int, two_sided: bool = False, errors: bool = False, frames: bool = False):
    """The compiled loop for force law ``law``, ``n`` DOFs, ``m`` meshes, with coast-flank contact or without,
    with manufacturing errors (``errors``: the generic loops of bit ``VARIANT_ERRORS``; ``lin``, ``lint`` then
    carry the error profiles, :func:`flatten_errors`) or without, with frame couplings (``frames``: a generic loop)
    or without.

    Arguments of the returned function (float64 arrays, C-contiguous, unless noted)::

        s (2n,), kin (3,) or (3 + m,), n_steps int, h [s], mode int, fext (n,), rec_every int,
        rec_state (nr, 2n), rec_out (nr, REC m + 1),
        mats (3, n, n) = [M^-1, M^-1 C, M^-1 G],
        vecs (6, m, n) = [v, w, v_rot, M^-1 v, vc, M^-1 vc],
        mmat (6, m, m) = [v M^-1 v^T, w M^-1 v^T, vc M^-1 v^T, v M^-1 vc^T, w M^-1 vc^T, vc M^-1 vc^T],
        phase (3, m) = [phase [cycles], rate numerator p, rate denominator q] (integers as floats; the mesh runs at
            p/q times the reference mesh frequency), u (n,), scal (3 + 2P,) = [c_ratio, sref, zref_2pi, frame rates],
        iref int, tab (flat FDFs), tint (2m, 3) int64 = [offset, Np, Nd], tflt (2m, 4) = [x0, 1/dx, x_on, x_max]
            (rows: the drive tables, then the coast tables),
        lin (flat conventional-law arrays), lint (m, 2) int64 = [offset, Np],
        work (7n + 22m + 2P,), eff (n, n) scratch,
        kidx (nnz, 2) int64 rows/columns of the entries of M^-1 K and M^-1 K_W the kernel multiplies: the n
            diagonal entries first (row i = column i = i), then the nonzero off-diagonal ones,
        kval (3 + 2P, nnz) = [their values in M^-1 K, in M^-1 K_W, scratch, then per frame coupling p M^-1 Kc_p,
            M^-1 Ks_p],

    ``P`` frame couplings (springs between translations in frames that turn against each other, e.g. a shaft's
    bending between two planetary stages' carrier frames; generic loops only): ``scal`` (3 + 2P,) then holds each
    one's rate ``(p, q)``, ``p / q`` revolutions of its second frame relative to its first per reference mesh
    cycle, and the stiffness is ``K + sum_p [(cos D_p - 1) Kc_p + sin D_p Ks_p]`` at ``D_p`` =
    :func:`frame_angle` of the step's middle, held over the step (a frame turns ``2 pi p h f_ref / q`` in a step,
    e.g. 1e-4 rad: the error of holding it is of second order in that);
        nz (m, 1 + w) int64: per mesh the count then the indices of the DOFs where its v, w, vc, M^-1 v or
            M^-1 vc is nonzero (the generic loop runs its mesh products over them; the specialised loops are dense)

    and it returns the number of records written (module docstring).  The arrays the loop writes (``s``, ``kin``,
    the records, ``work``, ``eff``, ``kval``) must not overlap each other or the others: the loop is compiled with
    its array arguments marked ``noalias``.  ``law = LAW_TWIST`` (helical meshes, one-sided):
    ``vecs[4]``, ``vecs[5]`` and the coast entries of ``mmat`` hold the twist vectors t_k and M^-1 t_k, the table
    rows are those of :func:`flatten_twist_tables`.
    """
    if law == LAW_TWIST:
        if two_sided:
            raise ValueError("helical meshes (LAW_TWIST) take their coast side as meshes m..2m-1 of the same loop "
                             "(two_sided = False)")
        if errors:
            return _twist_s_e
        return _twist_12_1 if (n, m) == (12, 1) and not frames else _twist_s
    two_sided = bool(two_sided)
    if errors:
        return _ERRORS[(law, two_sided)]
    if frames:
        return _GENERIC[(law, two_sided)]
    return _SPECIAL.get((law, n, m, two_sided), _GENERIC[(law, two_sided)])


#: name of the :mod:`logging` logger of the compile notices of :func:`prepare_kernel` (INFO; silent unless the
#: application attaches a handler: the ``hacgear`` commands print them on stderr)
COMPILE_LOGGER = "hacgear.compile"

#: CPU seconds numba 0.68 takes to compile one specialisation on a cold cache (measured: 15-17 s on one core of the
#: 2-core development machine, peak resident memory 0.5-0.6 GB; docs/dynamics.md "Compile time"): the estimate
#: the compile notice gives
COMPILE_CPU_S = 15


def kernel_label(law: int, n: int, m: int, two_sided: bool = False, errors: bool = False) -> str:
    """What :func:`select_kernel` selects, in words: ``"the integration kernel for 12 DOF x 1 mesh (helical)"``."""
    kind = {LAW_TABLE: "force tables", LAW_LINEAR: "conventional force law", LAW_TWIST: "helical"}[law]
    sides = (", both flanks" if two_sided else "") + (", with tooth errors" if errors else "")
    return f"the integration kernel for {n} DOF x {m} mesh{'es' if m != 1 else ''} ({kind}{sides})"


class _CompileWatch(event.Listener):
    """Calls ``notice`` when numba starts compiling ``dispatcher`` (not when it loads it from its cache)."""

    def __init__(self, dispatcher, notice) -> None:
        self.dispatcher = dispatcher
        self.notice = notice
        self.compiled = False

    def on_start(self, ev) -> None:
        if ev.data.get("dispatcher") is self.dispatcher and not self.compiled:
            self.compiled = True
            self.notice()

    def on_end(self, ev) -> None:
        pass


def prepare_kernel(kernel, args, label: str, notice=None, cpu_s: float = COMPILE_CPU_S) -> tuple[bool, float]:
    """Make ``kernel`` (a :func:`select_kernel` loop) ready for arguments like ``args`` (the tuple a call passes):
    numba loads it from its on-disk cache or, the first time on a machine (or after an upgrade of numba or of
    this file), compiles it and writes the cache.  Before compiling, ``notice(message)`` is called with a line
    that says so (default: an INFO record of the :data:`COMPILE_LOGGER` logger); loading from the cache is
    silent.

    Parameters
    ----------
    kernel : numba dispatcher
    args : tuple
        Arguments of a call (only their numba types matter).
    label : str
        What is compiled, in words (:func:`kernel_label`).
    notice : callable(str), optional
    cpu_s : float
        The compile time the notice announces [s on one core].

    Returns
    -------
    (compiled, seconds) : (bool, float)
        Whether it compiled (False: it was loaded or already in memory) and the wall time taken [s].
    """
    t0 = time.perf_counter()
    sig = tuple(typeof(a) for a in args)
    if sig in kernel.overloads:
        return False, 0.0
    if notice is None:
        notice = logging.getLogger(COMPILE_LOGGER).info
    watch = _CompileWatch(kernel, lambda: notice(
        f"compiling {label}: once per machine (numba caches it), about {cpu_s:g} s on one core"))
    with event.install_listener("numba:compile", watch):
        kernel.compile(sig)
    return watch.compiled, time.perf_counter() - t0


def record_width(m: int) -> int:
    """Columns of ``rec_out`` for ``m`` meshes."""
    return REC * m + 1


def record_fields(rec_out: np.ndarray, m: int, twist: bool = False, coast_twist: bool = False) -> dict[str, np.ndarray]:
    """Named views of kernel records ``rec_out`` (..., REC m + 1): per mesh (..., m) ``mesh_position``
    (unwrapped) [cycles], ``mesh_deflection_m``, ``mesh_force_N`` (drive flanks), ``dynamic_transmission_error_m``,
    ``coast_approach_m``, ``coast_force_N`` (coast flanks); ``time_s`` (...) since the call started.  ``twist``
    (records of the ``LAW_TWIST`` loop, helical meshes): ``mesh_twist_rad`` and ``twist_moment_Nm`` are the coast
    columns, and ``coast_approach_m``, ``coast_force_N`` zeros (one-sided helical meshes).  ``coast_twist``
    (two-sided helical meshes: the ``LAW_TWIST`` loop over 2 m meshes, mesh ``m + k`` the coast side of mesh
    ``k``; ``rec_out`` (..., 2 REC m + 1)): ``coast_approach_m``, ``coast_force_N``, ``coast_twist_rad`` and
    ``coast_twist_moment_Nm`` are the deflection, force, twist and twist moment of those coast meshes."""
    w = REC * m
    wk = 2 * w if coast_twist else w
    out = {"mesh_position": rec_out[..., REC_POSITION:w:REC], "mesh_deflection_m": rec_out[..., REC_DEFLECTION:w:REC],
           "mesh_force_N": rec_out[..., REC_FORCE:w:REC],
           "dynamic_transmission_error_m": rec_out[..., REC_DTE:w:REC],
           "coast_approach_m": rec_out[..., REC_COAST_APPROACH:w:REC],
           "coast_force_N": rec_out[..., REC_COAST_FORCE:w:REC], "time_s": rec_out[..., wk]}
    if twist or coast_twist:
        out["mesh_twist_rad"] = out["coast_approach_m"]
        out["twist_moment_Nm"] = out["coast_force_N"]
        out["coast_approach_m"] = np.zeros_like(out["mesh_twist_rad"])
        out["coast_force_N"] = np.zeros_like(out["mesh_twist_rad"])
    if coast_twist:
        out["coast_approach_m"] = rec_out[..., w + REC_DEFLECTION:wk:REC]
        out["coast_force_N"] = rec_out[..., w + REC_FORCE:wk:REC]
        out["coast_twist_rad"] = rec_out[..., w + REC_COAST_APPROACH:wk:REC]
        out["coast_twist_moment_Nm"] = rec_out[..., w + REC_COAST_FORCE:wk:REC]
    return out


def table_onset(force: np.ndarray, x0: float, dx: float) -> float:
    """Smallest deflection [m] at which the bilinear rule on ``force`` (Np, Nd) can give a positive force: the
    column before each row's first positive value (-inf when a row is positive in its first column)."""
    pos = np.asarray(force) > 0
    if not pos.any():
        return math.inf
    first = np.where(pos.any(axis=1), pos.argmax(axis=1), force.shape[1])
    if np.any(first == 0):
        return -math.inf
    return float(x0 + (first.min() - 1) * dx)


def flatten_tables(tables) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Flatten the tables of several meshes for the kernel: ``(tab, tint, tflt)`` from a sequence whose entries
    are ``(force (Np, Nd), x0 [m], inv_dx [1/m])`` or, for an absent table (zero force everywhere),
    ``(None, x_max [m])`` with ``x_max`` the deflection beyond which the state counts as out of range."""
    parts, tint, tflt = [], [], []
    o = 0
    for entry in tables:
        if entry[0] is None:
            f = np.zeros((2, 2))
            row = (0.0, 1.0, math.inf, float(entry[1]))
        else:
            f, a0, idx = entry
            f = np.ascontiguousarray(f, dtype=np.float64)
            row = (a0, idx, table_onset(f, a0, 1.0 / idx), a0 + (f.shape[1] - 1) / idx)
        parts.append(f.ravel())
        tint.append((o, f.shape[0], f.shape[1]))
        tflt.append(row)
        o += f.size
    cat = np.concatenate(parts) if parts else np.zeros(0)
    return (np.ascontiguousarray(cat), np.array(tint, np.int64).reshape(-1, 3),
            np.array(tflt, float).reshape(-1, 4))


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


def flatten_twist_tables(tables) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Flatten the generalized FDFs of ``m`` helical meshes for the kernel's ``LAW_TWIST`` loop: from a sequence of
    ``(gfdf (Np, Nd, Nt, 2) [W N, M N m], x0 [m], inv_dx [1/m], g0 [rad], inv_dg [1/rad])`` → ``(tab, tint,
    tflt)`` with rows k: ``(offset, Np, Nd)``, ``(x0, 1/dx, x_on, x_max)`` (x_on: the onset of W over every twist)
    and rows m + k: ``(offset, Nt, 2)``, ``(g0, 1/dg, g_min, g_max)`` (beyond the twist grid the state is
    counted as out of range).  An entry ``(None, x_max [m])`` is an absent table (the coast side of a drive-only
    table): W = M = 0 everywhere, the state out of range beyond deflection ``x_max`` at any twist."""
    parts, rows_d, rows_t, fl_d, fl_t = [], [], [], [], []
    o = 0
    for entry in tables:
        if entry[0] is None:
            g = np.zeros((2, 2, 2, 2))
            parts.append(g.ravel())
            rows_d.append((o, 2, 2))
            rows_t.append((o, 2, 2))
            fl_d.append((0.0, 1.0, math.inf, float(entry[1])))
            fl_t.append((0.0, 1.0, -math.inf, math.inf))
            o += g.size
            continue
        g, a0, idx, g0, idg = entry
        g = np.ascontiguousarray(g, dtype=np.float64)
        if g.ndim != 4 or g.shape[3] != 2 or g.shape[2] < 2:
            raise ValueError(f"generalized FDF must be (Np, Nd, Nt >= 2, 2), got {g.shape}")
        npos, nd, nt, _ = g.shape
        w = np.moveaxis(g[..., 0], 2, 1).reshape(npos * nt, nd)
        parts.append(g.ravel())
        rows_d.append((o, npos, nd))
        rows_t.append((o, nt, 2))
        fl_d.append((a0, idx, table_onset(w, a0, 1.0 / idx), a0 + (nd - 1) / idx))
        fl_t.append((g0, idg, g0, g0 + (nt - 1) / idg))
        o += g.size
    cat = np.concatenate(parts) if parts else np.zeros(0)
    return (np.ascontiguousarray(cat), np.array(rows_d + rows_t, np.int64).reshape(-1, 3),
            np.array(fl_d + fl_t, float).reshape(-1, 4))


def flatten_errors(lin: np.ndarray, lint: np.ndarray, profiles, coast_profiles=None) -> tuple[np.ndarray, np.ndarray]:
    """``(lin, lint)`` of :func:`flatten_linear` extended by the error profiles of the kernel's ``m`` meshes
    (``profiles``: per mesh None, ``(samples (L npc,) [m], L cycles, npc samples per cycle)`` or ``(samples (L npc
    nd,), L, npc, nd)`` over the drive table's ``nd`` deflections): the samples appended to ``lin``, rows ``m + k`` =
    (offset, npc) and ``2 m + k`` = (L, nd) appended to ``lint`` (npc = 0: no error on that mesh; nd = 0: the same
    error at every approach), as :func:`mesh_error` reads them; then the coast flanks' profiles (``coast_profiles``,
    per mesh None or over the position only; default none) in rows ``3 m + k`` and ``4 m + k``, which
    :func:`mesh_error` reads as mesh ``2 m + k``."""
    m = len(profiles)
    lint = np.asarray(lint, np.int64).reshape(-1, 2)
    if lint.shape[0] != m:
        raise ValueError(f"lint must have one row per mesh ({m}), got {lint.shape[0]}")
    coast = [None] * m if coast_profiles is None else list(coast_profiles)
    if len(coast) != m or any(p is not None and len(p) > 3 for p in coast):
        raise ValueError(f"coast_profiles must have one entry per mesh ({m}), each over the position only")
    parts = [np.asarray(lin, float)]
    o = parts[0].size
    rows_a, rows_b = [], []
    for p in list(profiles) + coast:
        if p is None:
            rows_a.append((0, 0))
            rows_b.append((1, 0))
            continue
        samples, cycles, npc = p[:3]
        nd = int(p[3]) if len(p) > 3 else 0
        samples = np.ascontiguousarray(samples, dtype=np.float64)
        if samples.shape != (int(cycles) * int(npc) * max(nd, 1),) or nd == 1:
            raise ValueError(f"an error profile of {cycles} cycles x {npc} samples per cycle x {nd} approaches needs "
                             f"{int(cycles) * int(npc) * max(nd, 1)} samples (nd = 0 or >= 2), got {samples.shape}")
        parts.append(samples)
        rows_a.append((o, int(npc)))
        rows_b.append((int(cycles), nd))
        o += samples.size
    return (np.ascontiguousarray(np.concatenate(parts)),
            np.ascontiguousarray(np.vstack([lint, np.array(rows_a[:m], np.int64), np.array(rows_b[:m], np.int64),
                                            np.array(rows_a[m:], np.int64), np.array(rows_b[m:], np.int64)])))
