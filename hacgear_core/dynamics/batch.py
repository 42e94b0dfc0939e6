"""Batched RK4 kernel: K independent states of one lumped gear system advanced in one call, lanes innermost.

The loop is :mod:`hacgear_core.dynamics.kernels`' speed-mode loop with every per-state quantity a row of K lanes
(structure of arrays: entry ``i`` of lane ``l`` at ``i * K + l``) and each RK4 phase one loop over the lanes, which
the compiler vectorises (the table lookups become gathers).  Lanes share the system (matrices, mesh vectors, tables)
and differ in state, mesh position, speed, step, external load and damping matrix (the modal damping of a system
depends on its operating torque, so sweeps at several torques can share a loop).  Each lane performs the
single-state loop's operations in its order, its multiply-adds written as the fused multiply-adds the single-state
loop's compiler forms (this loop is compiled without contraction, so the vectoriser cannot choose others): a lane's
results equal the single-state kernel's bit for bit (tests/test_batch.py).  Where any lane's coast flanks may touch,
every lane takes the coast terms: a lane whose coast flanks stay apart adds exact zeros (its coast forces are 0
below the coast tables' onset).  Speed per lane against the single-state kernel and what limits it:
docs/dynamics.md, "Batched kernel".

Arguments of the loop :func:`select_batch_kernel` returns (float64, C-contiguous, flat unless noted; K lanes)::

    S (2n K) states, KIN ((3 + m) K) [tau_ref, completed cycles, omega_ref, then per mesh the out-of-range count],
    n_steps int, H (K,) steps [s], FEXT (n, K) external loads, REC_EVERY (K,) int64 (0: no records),
    CNT (K, 2) int64 [steps to the next record, steps done] (in/out: a lane's integration may span several calls;
    ``[REC_EVERY, 0]`` where it starts), rec_state (K, nr, 2n), rec_out (K, nr, REC m + 1) (each call writes from
    record 0), NREC (K,) int64 (records written by the call, out), then :func:`batch_constants`, ADT (n n K) each
    lane's :func:`lane_damping` and the scratch W (:func:`batch_rows` K).  The arrays the loop writes (S, KIN, CNT,
    the records, NREC, W) must not overlap each other or the others (the loop is compiled with its array arguments
    marked ``noalias``).

Speed mode only (each lane's ``omega_ref`` is constant); helical meshes (``LAW_TWIST``) and the torque experiment
use the single-state kernel.  :class:`Lanes` holds the arrays of K lanes, :func:`run_lanes` drives steady-state runs
(:func:`hacgear_core.dynamics.steady.steady_run`) on them.
"""
from __future__ import annotations

import dataclasses
from types import FunctionType

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from hacgear_core.cpu import vector_units
from hacgear_core.dynamics import kernels
from hacgear_core.dynamics.kernels import (LAW_LINEAR, LAW_TABLE, REC, REC_COAST_APPROACH, REC_COAST_FORCE,
                                           REC_DEFLECTION, REC_DTE, REC_FORCE, REC_POSITION, VARIANT_SPARSE,
                                           VARIANT_TWO_SIDED, _NoAliasCompiler, _ix, mesh_base)

__all__ = ["BATCH_COMPILE_CPU_S", "select_batch_kernel", "system_batch_kernel", "batch_constants", "batch_rows",
           "batch_supported", "lane_damping", "lanes_compatible", "Lanes", "run_lanes", "VARIANT_ROTATING",
           "VARIANT_DIAGONAL_K"]

#: compile time of one batched loop (one system variant and lane count) on one core of the 2-core development
#: machine [s]: 19.5-24.9 s measured for the spur pair (2-DOF at 4 lanes, 2- and 4-DOF at 8) with an empty numba
#: cache
BATCH_COMPILE_CPU_S = 25

#: variant bit: the carrier rotates (each lane's effective stiffness and damping depend on its speed)
VARIANT_ROTATING = 16
#: variant bit: M^-1 K and M^-1 K_W are diagonal (no off-diagonal entries to multiply)
VARIANT_DIAGONAL_K = 32
#: variant bit: meshes at their own rates (kinematic positions per mesh and lane, kernels.mesh_base)
VARIANT_RATES = 64

# rows of the per-lane scratch W (the single-state loop's work vector, one row per entry): offsets in units of n
# and m as in kernels._make_loop, then the lane constants and the per-lane matrices
_NW_N = 7
_NW_M = 22
_NW_LANE = 8

# each batched loop's two stage functions (_make_stages: with and without the coast terms); _make_batch_loop gives
# every loop its own
_stages_coast = _stages_plain = None


def batch_rows(n: int, m: int, nnz: int, rotating: bool) -> int:
    """Rows of the batched kernel's scratch ``W`` (rows K) for ``n`` DOFs, ``m`` meshes, ``nnz`` stiffness
    entries."""
    return _NW_N * n + _NW_M * m + _NW_LANE + ((nnz + n * n) if rotating else 0)


def batch_supported(system) -> bool:
    """Whether the batched kernel runs ``system`` (a :class:`~hacgear_core.dynamics.system.LumpedSystem`): the
    table and linear laws' loops, not the twist law of helical meshes, without manufacturing errors and frame
    couplings (such systems run state by state)."""
    return (system.mesh_law.kernel_law in (LAW_TABLE, LAW_LINEAR) and not getattr(system, "has_errors", False)
            and not getattr(system, "frame_couplings", ()))


#: whether the CPU the loops are compiled for has fused multiply-add: the single-state loop's compiler contracts
#: multiply-adds into FMA instructions only where it has; without them (a CPU before FMA3, numba's generic target)
#: it rounds the product and the sum apart, and so must the batched loop (an llvm.fma there would also become a
#: slow library call)
TARGET_FMA = "fma" in vector_units().features


@intrinsic
def _fma(typingctx, a, b, c):
    """``a * b + c`` as the single-state loop's compiler forms it: rounded once (``llvm.fma.f64``) on a CPU with
    fused multiply-add (the contraction made explicit where the vectorised lane loops would otherwise contract the
    other product), the product and the sum rounded apart on one without (:data:`TARGET_FMA`)."""
    def codegen(context, builder, sig, args):
        d = ir.DoubleType()
        if not TARGET_FMA:
            return builder.fadd(builder.fmul(args[0], args[1]), args[2])
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(d, [d, d, d]), "llvm.fma.f64")
        return builder.call(fn, args)
    return types.float64(types.float64, types.float64, types.float64), codegen


#: cell indices of the lane lookups are 32-bit integers, and their fractions are taken from the cell as a float:
#: AVX2 converts float64 to int32 and multiplies int32 in vector registers but has no instruction for either in 64
#: bits, so 64-bit index arithmetic (and the conversion of the cell back to a float for its fraction) left every
#: lane's lookup scalar.  4-DOF spur pair, both flanks, K = 8, on an AVX2 CPU (AMD EPYC, Zen 3): 7.9 -> 4.4 us per
#: mesh cycle and lane, single-state 10.3 us (1.31x -> 2.35x), lanes bit-identical (docs/dynamics.md "Batched
#: kernel").  The tables hold far fewer than 2^31 values; the float is clamped before its conversion.
_I32 = np.int32
_I32_MASK = np.int32(0x7FFFFFFF)
_I32_SPAN = 1.0e9


@njit(cache=True, inline="always", fastmath=False)
def _i32(v):
    """``int(v)`` (truncation) of a float64 as an int32, ``v`` first clamped to +-1e9 (a select: no call)."""
    v = -_I32_SPAN if v < -_I32_SPAN else (_I32_SPAN if v > _I32_SPAN else v)
    return _I32(v)


@njit(cache=True, inline="always", fastmath=False)
def _periodic_cell_l(npos, tau):
    """:func:`hacgear_core.tables.interp.periodic_cell` without branches (its wrap subtracts 0 where ``tau`` lies
    in [0, 1); selects for its clamps): the same cell and fraction, bit for bit, in a form the compiler vectorises
    (numba's ``min``, ``max`` and ``math.floor`` are calls it does not; 64-bit integers AVX2 cannot vectorise)."""
    p = tau * npos
    wrap = npos * np.floor(tau)
    p -= wrap if (p < 0.0) | (p >= npos) else 0.0
    # the cell as a float (the same integer value the truncation gives, p >= 0 here) so that the fraction needs no
    # conversion back from the integer
    c = np.floor(p)
    c = npos - 1.0 if c >= npos else c
    a = p - c
    i = _i32(c)
    i1 = i + _I32(1)
    i1 = _I32(0) if i1 == _I32(npos) else i1
    return i, i1, a


@njit(cache=True, inline="always", fastmath=False)
def _deflection_cell_l(nd, x0, inv_dx, x):
    """:func:`hacgear_core.tables.interp.deflection_cell` with selects for its clamps (the same cell and
    fraction; the cell an int32)."""
    r = (x - x0) * inv_dx
    c = np.trunc(r)   # int() truncates toward zero; as a float, the fraction needs no conversion back
    top = nd - 2.0
    c = 0.0 if c < 0.0 else (top if c > top else c)
    return _i32(c), r - c


@njit(cache=True, inline="always", fastmath=False)
def _lerp(y0, y1, a):
    """``y0 + a (y1 - y0)`` with the product and sum fused, as the single-state kernel's compiler forms it."""
    return _fma(a, y1 - y0, y0)


@njit(cache=True, inline="always", fastmath=False)
def _table_force_l(tab, off, npos, nd, x0, inv_dx, tau, x):
    """The single-state kernel's bilinear drive-flank lookup (``kernels._table_force``) for one lane: the two
    position rows' values at the deflection, then between the rows; clipped at 0."""
    i, i1, a = _periodic_cell_l(npos, tau)
    j, b = _deflection_cell_l(nd, x0, inv_dx, x)
    o, n_ = _I32(off), _I32(nd)
    c0 = (o + i * n_ + j) & _I32_MASK
    c1 = (o + i1 * n_ + j) & _I32_MASK
    f = _lerp(_lerp(tab[c0], tab[c0 + _I32(1)], b), _lerp(tab[c1], tab[c1 + _I32(1)], b), a)
    return 0.0 if f < 0.0 else f


@njit(cache=True, inline="always", fastmath=False)
def _linear_force_l(lin, off, npos, tau, x):
    """The single-state kernel's conventional law (``kernels._linear_force``) for one lane."""
    i, i1, a = _periodic_cell_l(npos, tau)
    o, np_, i, i1 = _ix(off), _ix(npos), _ix(i), _ix(i1)
    k = _lerp(lin[o + i], lin[o + i1], a)
    e = _lerp(lin[o + np_ + i], lin[o + np_ + i1], a)
    f0 = _lerp(lin[o + 2 * np_ + i], lin[o + 2 * np_ + i1], a)
    f = _fma(k, x - e, f0)
    return 0.0 if f < 0.0 else f


@njit(cache=True, inline="always", fastmath=False)
def _drive_force_l(law, k, tab, tint, tflt, lin, lint, tau, x):
    """Drive-flank force [N] of mesh ``k`` for one lane under force law ``law`` (``kernels.mesh_force``)."""
    if law == LAW_TABLE:
        return _table_force_l(tab, tint[k, 0], tint[k, 1], tint[k, 2], tflt[k, 0], tflt[k, 1], tau, x)
    return _linear_force_l(lin, lint[k, 0], lint[k, 1], tau, x)


@njit(cache=True, inline="always", fastmath=False)
def _coast_row_l(tab, tint, tflt, r, tau, x):
    """Force [N] of table row ``r`` for one lane, 0 below its onset (``kernels.table_row_force``)."""
    return _coast_force_l(tab, tint[r, 0], tint[r, 1], tint[r, 2], tflt[r, 0], tflt[r, 1], tflt[r, 2], tau, x)


@njit(cache=True, inline="always", fastmath=False)
def _coast_force_l(tab, off, npos, nd, x0, inv_dx, x_on, tau, x):
    """``kernels.table_row_force`` for one lane: 0 below the onset ``x_on`` (the lookup is made either way: its
    cell is clamped to the table, and a select is cheaper than a branch across lanes)."""
    f = _table_force_l(tab, off, npos, nd, x0, inv_dx, tau, x)
    return 0.0 if x < x_on else f


@njit(cache=True, inline="always", fastmath=False)
def _l_dot(n, sparse, nz, k, vf, ov, x, ox, B, l, a=0.0):
    """Lane ``l``'s ``a + vf[ov + k n : ov + (k+1) n] . x[ox : ox + n]`` (``kernels._dot``, its order; ``x`` rows
    of ``B`` lanes)."""
    if sparse:
        for p in range(1, nz[k, 0] + 1):
            j = _ix(nz[k, p])
            a = _fma(vf[ov + k * n + j], x[(ox + j) * B + l], a)
    else:
        for j in range(n):
            a = _fma(vf[ov + k * n + j], x[(ox + j) * B + l], a)
    return a


@njit(cache=True, inline="always", fastmath=False)
def _l_sub_k(n, sparse, diag, nnz, kidx, kval, kd, rot, w, oq, c, x, ox, out, oo, B, l):
    """Lane ``l``'s ``out[oo:oo+n] -= c (M^-1 K_eff) x[ox:ox+n]`` (``kernels._sub_k``); the entries shared
    (``kval[0]``) or (``rot``) the lane's rows of ``w`` from ``oq``.  The dense loops (not ``sparse``, not ``rot``)
    take the off-diagonal entries from the full matrix ``kd`` (n*n, row-major, the order of ``kidx``): its zeros
    subtract nothing, and loops of constant length leave the lane loop innermost (vectorisable).  ``diag``: no
    off-diagonal entries (``kidx`` holds the diagonal only)."""
    for i in range(n):
        q = w[(oq + i) * B + l] if rot else kval[0, i]
        o = (oo + i) * B + l
        out[o] = _fma(-(c * q), x[(ox + i) * B + l], out[o])
    if diag:
        return
    if not sparse and not rot:
        for r in range(n):
            for t in range(n):
                if r != t:
                    o = (oo + r) * B + l
                    out[o] = _fma(-(c * kd[r * n + t]), x[(ox + t) * B + l], out[o])
        return
    for z in range(n, nnz):
        r = _ix(kidx[z, 0]) if sparse else kidx[z, 0]
        t = _ix(kidx[z, 1]) if sparse else kidx[z, 1]
        q = w[(oq + z) * B + l] if rot else kval[0, z]
        o = (oo + r) * B + l
        out[o] = _fma(-(c * q), x[(ox + t) * B + l], out[o])


@njit(cache=True, inline="always", fastmath=False)
def _l_sub_c(n, sparse, adt, rot, w, oc, c, x, ox, out, oo, B, l):
    """Lane ``l``'s ``out[oo:oo+n] -= c (M^-1 C_eff) x[ox:ox+n]``, column by column (``kernels._sub_c``: its
    column blocks subtract in the same order, each a fused multiply-add, so the same result); the entries from the
    lane's rows of ``adt`` (its own damping) or (``rot``) of ``w`` from ``oc``."""
    for j in range(n):
        b = c * x[(ox + j) * B + l]
        for i in range(n):
            e = w[(oc + j * n + i) * B + l] if rot else adt[(j * n + i) * B + l]
            o = (oo + i) * B + l
            out[o] = _fma(-e, b, out[o])


@njit(cache=True, inline="always", fastmath=False)
def _l_sub_forces(n, m, sparse, nz, w, of, vmi, ov, out, oo, B, l):
    """Lane ``l``'s ``out[oo:oo+n] -= sum_k w[of+k] (M^-1 v_k)`` (``kernels._sub_forces``; also the coast forces,
    whose zeros subtract nothing)."""
    for k in range(m):
        c = w[(of + k) * B + l]
        if sparse:
            for p in range(1, nz[k, 0] + 1):
                i = _ix(nz[k, p])
                o = (oo + i) * B + l
                out[o] = _fma(-c, vmi[ov + k * n + i], out[o])
        else:
            for i in range(n):
                o = (oo + i) * B + l
                out[o] = _fma(-c, vmi[ov + k * n + i], out[o])


@njit(cache=True, inline="always", fastmath=False)
def _layout(n, m, nnz):
    """Offsets of the blocks of ``vf`` and ``mf`` (kernels.select_kernel's ``vecs`` and ``mmat``) and of the rows
    of the scratch ``W`` (each K lanes) for ``n`` DOFs, ``m`` meshes, ``nnz`` stiffness entries."""
    mn, mm = m * n, m * m
    o_w, o_rv, o_vmi, o_vc, o_vci = mn, 2 * mn, 3 * mn, 4 * mn, 5 * mn
    o_wv, o_cv, o_vvc, o_wvc, o_cvc = mm, 2 * mm, 3 * mm, 4 * mm, 5 * mm
    # W rows (each B lanes): the single-state loop's work vector (a1..a4, g0, p, M^-1 f_ext; per mesh the
    # products and forces), then the lane constants, then (rotating carrier) each lane's M^-1 K_eff entries and
    # M^-1 C_eff^T
    o_a1, o_a2, o_a3, o_a4, o_g0, o_p, o_fm = 0, n, 2 * n, 3 * n, 4 * n, 5 * n, 6 * n
    r0 = 7 * n
    o_xq, o_xd, o_wq, o_wd, o_f1, o_f2, o_f3 = r0, r0 + m, r0 + 2 * m, r0 + 3 * m, r0 + 4 * m, r0 + 5 * m, r0 + 6 * m
    o_f4, o_g1, o_gw1, o_g2, o_gw2 = r0 + 7 * m, r0 + 8 * m, r0 + 9 * m, r0 + 10 * m, r0 + 11 * m
    o_cq, o_cd, o_c1, o_c2, o_c3 = r0 + 12 * m, r0 + 13 * m, r0 + 14 * m, r0 + 15 * m, r0 + 16 * m
    o_c4, o_gc1, o_gc2 = r0 + 17 * m, r0 + 18 * m, r0 + 19 * m
    # per mesh its kinematic position at the step start and its advance over the step (meshes at their own rates)
    o_tb, o_td, o_h = r0 + 20 * m, r0 + 21 * m, r0 + 22 * m
    o_hh = o_h + 1
    o_hh2 = o_h + 2
    o_hhh = o_h + 3
    o_c6 = o_h + 4
    o_c6q = o_h + 5
    o_dtau = o_h + 6
    o_tau = o_h + 7
    o_aq = o_h + 8
    o_ad = o_aq + nnz
    return (mn, mm, o_w, o_rv, o_vmi, o_vc, o_vci, o_wv, o_cv, o_vvc, o_wvc, o_cvc, o_a1, o_a2, o_a3, o_a4, o_g0,
            o_p, o_fm, r0, o_xq, o_xd, o_wq, o_wd, o_f1, o_f2, o_f3, o_f4, o_g1, o_gw1, o_g2, o_gw2, o_cq, o_cd,
            o_c1, o_c2, o_c3, o_c4, o_gc1, o_gc2, o_h, o_hh, o_hh2, o_hhh, o_c6, o_c6q, o_dtau, o_tau, o_aq, o_ad,
            o_tb, o_td)


def _make_stages(name: str, n_fixed: int, m_fixed: int, variant: int, lanes: int, coast: bool):
    """Compile every lane's four RK4 stages of one step from the step-start products in ``w`` (``a1``..``a4``
    written), with the coast terms (``coast``) or without; without them and with ``two_sided``, the function
    returns whether the coast approaches of stages 3 and 4 may touch in any lane (the step is then redone with
    them).  A function of its own per ``coast``, so that the caller decides it outside the lane loop (decided
    inside, the compiler keeps both paths in the vectorised loop, masked, and a step without coast contact costs
    twice as much) and so that numba compiles the stages once, not at each call site (its inliner copies a
    callee's IR block by block, each copy with the callee's whole scope, which made the stages most of the loop's
    compile time); LLVM inlines them (``forceinline``), so the loop is the same as with the stages written in it."""
    law = variant & 1
    sparse = (variant & VARIANT_SPARSE) != 0
    two_sided = (variant & VARIANT_TWO_SIDED) != 0
    rot = (variant & VARIANT_ROTATING) != 0
    diag = (variant & VARIANT_DIAGONAL_K) != 0
    rates = (variant & VARIANT_RATES) != 0
    B = lanes

    def stages(sf, w, vf, mf, phase, tab, tint, tflt, lin, lint, kidx, kval, kd, nz, adt):
        n = _ix(n_fixed if n_fixed else sf.shape[0] // (2 * B))
        m = _ix(m_fixed if m_fixed else phase.shape[1])
        nnz = kidx.shape[0]
        (mn, mm, o_w, o_rv, o_vmi, o_vc, o_vci, o_wv, o_cv, o_vvc, o_wvc, o_cvc, o_a1, o_a2, o_a3, o_a4, o_g0, o_p,
         o_fm, r0, o_xq, o_xd, o_wq, o_wd, o_f1, o_f2, o_f3, o_f4, o_g1, o_gw1, o_g2, o_gw2, o_cq, o_cd, o_c1, o_c2,
         o_c3, o_c4, o_gc1, o_gc2, o_h, o_hh, o_hh2, o_hhh, o_c6, o_c6q, o_dtau, o_tau, o_aq, o_ad, o_tb,
         o_td) = _layout(n, m, nnz)
        recheck = False
        for l in range(B):
            h = w[o_h * B + l]
            hh = w[o_hh * B + l]
            tau = w[o_tau * B + l]
            dtau = w[o_dtau * B + l]
            # stages 1 and 2: their lookups need only the state
            for k in range(m):
                xq = w[(o_xq + k) * B + l]
                tk = w[(o_tb + k) * B + l] if rates else tau
                dk = w[(o_td + k) * B + l] if rates else dtau
                t1 = tk + phase[0, k] + w[(o_wq + k) * B + l]
                t2 = _fma(hh, w[(o_wd + k) * B + l], tk + 0.5 * dk + phase[0, k] + w[(o_wq + k) * B + l])
                x2 = _fma(hh, w[(o_xd + k) * B + l], xq)
                w[(o_f1 + k) * B + l] = _drive_force_l(law, k, tab, tint, tflt, lin, lint, t1, xq)
                w[(o_f2 + k) * B + l] = _drive_force_l(law, k, tab, tint, tflt, lin, lint, t2, x2)
                if coast:
                    cq = w[(o_cq + k) * B + l]
                    w[(o_c1 + k) * B + l] = _coast_row_l(tab, tint, tflt, m + k, t1, cq)
                    w[(o_c2 + k) * B + l] = _coast_row_l(tab, tint, tflt, m + k, t2,
                                                         _fma(hh, w[(o_cd + k) * B + l], cq))
            for i in range(n):
                w[(o_g0 + i) * B + l] = w[(o_fm + i) * B + l]
                w[(o_p + i) * B + l] = 0.0
            _l_sub_k(n, sparse, diag, nnz, kidx, kval, kd, rot, w, o_aq, 1.0, sf, 0, w, o_g0, B, l)
            _l_sub_k(n, sparse, diag, nnz, kidx, kval, kd, rot, w, o_aq, 1.0, sf, n, w, o_p, B, l)
            _l_sub_c(n, sparse, adt, rot, w, o_ad, 1.0, sf, n, w, o_g0, B, l)
            for k in range(m):
                w[(o_g1 + k) * B + l] = _l_dot(n, sparse, nz, k, vf, 0, w, o_g0, B, l)
                w[(o_gw1 + k) * B + l] = _l_dot(n, sparse, nz, k, vf, o_w, w, o_g0, B, l)
                if coast:
                    w[(o_gc1 + k) * B + l] = _l_dot(n, sparse, nz, k, vf, o_vc, w, o_g0, B, l)
            for i in range(n):
                w[(o_a1 + i) * B + l] = w[(o_g0 + i) * B + l]
            _l_sub_forces(n, m, sparse, nz, w, o_f1, vf, o_vmi, w, o_a1, B, l)
            if coast:
                _l_sub_forces(n, m, sparse, nz, w, o_c1, vf, o_vci, w, o_a1, B, l)
            for i in range(n):
                w[(o_a2 + i) * B + l] = _fma(hh, w[(o_p + i) * B + l], w[(o_g0 + i) * B + l])
            _l_sub_c(n, sparse, adt, rot, w, o_ad, hh, w, o_a1, w, o_a2, B, l)
            for k in range(m):
                w[(o_g2 + k) * B + l] = _l_dot(n, sparse, nz, k, vf, 0, w, o_a2, B, l)
                w[(o_gw2 + k) * B + l] = _l_dot(n, sparse, nz, k, vf, o_w, w, o_a2, B, l)
                if coast:
                    w[(o_gc2 + k) * B + l] = _l_dot(n, sparse, nz, k, vf, o_vc, w, o_a2, B, l)
            _l_sub_forces(n, m, sparse, nz, w, o_f2, vf, o_vmi, w, o_a2, B, l)
            if coast:
                _l_sub_forces(n, m, sparse, nz, w, o_c2, vf, o_vci, w, o_a2, B, l)
            # stages 3 and 4
            for k in range(m):
                a = w[(o_g1 + k) * B + l]
                b = w[(o_gw1 + k) * B + l]
                c = w[(o_g2 + k) * B + l]
                d = w[(o_gw2 + k) * B + l]
                for j in range(m):
                    a = _fma(-mf[k * m + j], w[(o_f1 + j) * B + l], a)
                    b = _fma(-mf[o_wv + k * m + j], w[(o_f1 + j) * B + l], b)
                    c = _fma(-mf[k * m + j], w[(o_f2 + j) * B + l], c)
                    d = _fma(-mf[o_wv + k * m + j], w[(o_f2 + j) * B + l], d)
                e1 = 0.0
                e2 = 0.0
                if coast:
                    e1 = w[(o_gc1 + k) * B + l]
                    e2 = w[(o_gc2 + k) * B + l]
                    for j in range(m):
                        a = _fma(-mf[o_vvc + k * m + j], w[(o_c1 + j) * B + l], a)
                        b = _fma(-mf[o_wvc + k * m + j], w[(o_c1 + j) * B + l], b)
                        c = _fma(-mf[o_vvc + k * m + j], w[(o_c2 + j) * B + l], c)
                        d = _fma(-mf[o_wvc + k * m + j], w[(o_c2 + j) * B + l], d)
                        e1 -= _fma(mf[o_cv + k * m + j], w[(o_f1 + j) * B + l],
                                   mf[o_cvc + k * m + j] * w[(o_c1 + j) * B + l])
                        e2 -= _fma(mf[o_cv + k * m + j], w[(o_f2 + j) * B + l],
                                   mf[o_cvc + k * m + j] * w[(o_c2 + j) * B + l])
                tk = w[(o_tb + k) * B + l] if rates else tau
                dk = w[(o_td + k) * B + l] if rates else dtau
                t3 = _fma(hh, _fma(hh, b, w[(o_wd + k) * B + l]),
                          tk + 0.5 * dk + phase[0, k] + w[(o_wq + k) * B + l])
                t4 = _fma(h, _fma(hh, d, w[(o_wd + k) * B + l]), tk + dk + phase[0, k] + w[(o_wq + k) * B + l])
                x3 = _fma(hh, _fma(hh, a, w[(o_xd + k) * B + l]), w[(o_xq + k) * B + l])
                x4 = _fma(h, _fma(hh, c, w[(o_xd + k) * B + l]), w[(o_xq + k) * B + l])
                w[(o_f3 + k) * B + l] = _drive_force_l(law, k, tab, tint, tflt, lin, lint, t3, x3)
                w[(o_f4 + k) * B + l] = _drive_force_l(law, k, tab, tint, tflt, lin, lint, t4, x4)
                if coast:
                    cq = w[(o_cq + k) * B + l]
                    cd = w[(o_cd + k) * B + l]
                    w[(o_c3 + k) * B + l] = _coast_row_l(tab, tint, tflt, m + k, t3,
                                                         _fma(hh, _fma(hh, e1, cd), cq))
                    w[(o_c4 + k) * B + l] = _coast_row_l(tab, tint, tflt, m + k, t4, _fma(h, _fma(hh, e2, cd), cq))
            # a3 = g0 + hh p - hh^2 K a1 - hh C a2 - F3 M^-1 v (- Fc3 M^-1 vc); a4 with h, h hh, a2, a3 (written
            # out twice: a loop over the two stages here is not vectorised)
            for i in range(n):
                w[(o_a3 + i) * B + l] = _fma(hh, w[(o_p + i) * B + l], w[(o_g0 + i) * B + l])
            _l_sub_k(n, sparse, diag, nnz, kidx, kval, kd, rot, w, o_aq, w[o_hh2 * B + l], w, o_a1, w, o_a3, B, l)
            _l_sub_c(n, sparse, adt, rot, w, o_ad, hh, w, o_a2, w, o_a3, B, l)
            _l_sub_forces(n, m, sparse, nz, w, o_f3, vf, o_vmi, w, o_a3, B, l)
            if coast:
                _l_sub_forces(n, m, sparse, nz, w, o_c3, vf, o_vci, w, o_a3, B, l)
            for i in range(n):
                w[(o_a4 + i) * B + l] = _fma(h, w[(o_p + i) * B + l], w[(o_g0 + i) * B + l])
            _l_sub_k(n, sparse, diag, nnz, kidx, kval, kd, rot, w, o_aq, w[o_hhh * B + l], w, o_a2, w, o_a4, B, l)
            _l_sub_c(n, sparse, adt, rot, w, o_ad, h, w, o_a3, w, o_a4, B, l)
            _l_sub_forces(n, m, sparse, nz, w, o_f4, vf, o_vmi, w, o_a4, B, l)
            if coast:
                _l_sub_forces(n, m, sparse, nz, w, o_c4, vf, o_vci, w, o_a4, B, l)
            if two_sided and not coast:
                # staged one-sided: do the coast approaches of stages 3 and 4 stay apart?
                for k in range(m):
                    lim = tflt[m + k, 2] - 1e-12
                    e1 = _l_dot(n, sparse, nz, k, vf, o_vc, w, o_a1, B, l)
                    e2 = _l_dot(n, sparse, nz, k, vf, o_vc, w, o_a2, B, l)
                    cq = w[(o_cq + k) * B + l]
                    cd = w[(o_cd + k) * B + l]
                    recheck = (recheck | (_fma(hh, _fma(hh, e1, cd), cq) >= lim)
                               | (_fma(h, _fma(hh, e2, cd), cq) >= lim))
        return recheck

    stages.__name__ = stages.__qualname__ = name
    return njit(cache=True, fastmath=False, forceinline=True, pipeline_class=_NoAliasCompiler)(stages)


def _make_batch_loop(name: str, n_fixed: int, m_fixed: int, variant: int, lanes: int):
    """Compile the batched loop for ``n_fixed`` DOFs and ``m_fixed`` meshes (0: read from the arguments),
    ``variant`` (bit 0 the force law, bits as :func:`kernels._make_loop`'s: sparse, two-sided; plus
    :data:`VARIANT_ROTATING`) and ``lanes`` lanes."""
    law_c = variant & 1
    sparse_c = (variant & VARIANT_SPARSE) != 0
    two_sided_c = (variant & VARIANT_TWO_SIDED) != 0
    rot_c = (variant & VARIANT_ROTATING) != 0
    rates_c = (variant & VARIANT_RATES) != 0
    B = lanes

    def loop(sf, kf, n_steps, H, FEXT, REC_EVERY, CNT, rec_state, rec_out, NREC, mats, vf, mf, phase, scal, tab,
             tint, tflt, lin, lint, kidx, kval, kd, nz, adt, w):
        n = _ix(n_fixed if n_fixed else mats.shape[1])
        m = _ix(m_fixed if m_fixed else phase.shape[1])
        law = law_c
        sparse = sparse_c
        two_sided = two_sided_c
        rot = rot_c
        rates = rates_c
        nnz = kidx.shape[0]
        # vector and matrix blocks of vf and mf (kernels.select_kernel's vecs and mmat)
        (mn, mm, o_w, o_rv, o_vmi, o_vc, o_vci, o_wv, o_cv, o_vvc, o_wvc, o_cvc, o_a1, o_a2, o_a3, o_a4, o_g0, o_p,
         o_fm, r0, o_xq, o_xd, o_wq, o_wd, o_f1, o_f2, o_f3, o_f4, o_g1, o_gw1, o_g2, o_gw2, o_cq, o_cd, o_c1, o_c2,
         o_c3, o_c4, o_gc1, o_gc2, o_h, o_hh, o_hh2, o_hhh, o_c6, o_c6q, o_dtau, o_tau, o_aq, o_ad, o_tb,
         o_td) = _layout(n, m, nnz)
        c_ratio = scal[0]
        zref_2pi = scal[2]
        for l in range(B):
            h = H[l]
            w[o_h * B + l] = h
            w[o_hh * B + l] = 0.5 * h
            w[o_hh2 * B + l] = w[o_hh * B + l] * w[o_hh * B + l]
            w[o_hhh * B + l] = h * w[o_hh * B + l]
            w[o_c6 * B + l] = h / 6.0
            w[o_c6q * B + l] = h * h / 6.0
            w[o_dtau * B + l] = zref_2pi * kf[2 * B + l] * h
            for i in range(n):
                a = 0.0
                for j in range(n):
                    a = _fma(mats[0, i, j], FEXT[j, l], a)
                w[(o_fm + i) * B + l] = a
            for k in range(m):
                w[(o_c1 + k) * B + l] = 0.0
                w[(o_c2 + k) * B + l] = 0.0
                w[(o_c3 + k) * B + l] = 0.0
                w[(o_c4 + k) * B + l] = 0.0
            if rot:
                oc = c_ratio * kf[2 * B + l]
                for z in range(nnz):
                    w[(o_aq + z) * B + l] = _fma(-(oc * oc), kval[1, z], kval[0, z])
                for i in range(n):
                    for j in range(n):
                        w[(o_ad + j * n + i) * B + l] = _fma(oc, mats[2, i, j], adt[(j * n + i) * B + l])
            NREC[l] = 0
        nr_cap = rec_state.shape[1]
        recs = False
        for l in range(B):
            recs = recs or REC_EVERY[l] > 0
        for step in range(n_steps):
            # step-start products, out-of-range counts, may the coast flanks touch in any lane?
            coast_on = False
            for l in range(B):
                w[o_tau * B + l] = kf[l]
                hh = w[o_hh * B + l]
                if rates:
                    for k in range(m):
                        w[(o_tb + k) * B + l], _ = mesh_base(phase[1, k], phase[2, k], kf[B + l], kf[l])
                        w[(o_td + k) * B + l] = (phase[1, k] / phase[2, k]) * w[o_dtau * B + l]
                for k in range(m):
                    xq = _l_dot(n, sparse, nz, k, vf, 0, sf, 0, B, l)
                    w[(o_xq + k) * B + l] = xq
                    w[(o_xd + k) * B + l] = _l_dot(n, sparse, nz, k, vf, 0, sf, n, B, l)
                    w[(o_wq + k) * B + l] = _l_dot(n, sparse, nz, k, vf, o_w, sf, 0, B, l)
                    w[(o_wd + k) * B + l] = _l_dot(n, sparse, nz, k, vf, o_w, sf, n, B, l)
                    # bitwise, not short-circuit, logic: no branches in the lane loop
                    out_of_range = xq > tflt[k, 3]
                    if two_sided:
                        cq = _l_dot(n, sparse, nz, k, vf, o_vc, sf, 0, B, l)
                        cd = _l_dot(n, sparse, nz, k, vf, o_vc, sf, n, B, l)
                        w[(o_cq + k) * B + l] = cq
                        w[(o_cd + k) * B + l] = cd
                        out_of_range = out_of_range | (cq > tflt[m + k, 3])
                        lim = tflt[m + k, 2] - 1e-12
                        coast_on = coast_on | (cq >= lim) | (_fma(hh, cd, cq) >= lim)
                    kf[(3 + k) * B + l] += 1.0 if out_of_range else 0.0
            while True:
                if coast_on:
                    _stages_coast(sf, w, vf, mf, phase, tab, tint, tflt, lin, lint, kidx, kval, kd, nz, adt)
                    break
                if not _stages_plain(sf, w, vf, mf, phase, tab, tint, tflt, lin, lint, kidx, kval, kd, nz, adt):
                    break
                coast_on = True
            for l in range(B):
                h = w[o_h * B + l]
                c6 = w[o_c6 * B + l]
                c6q = w[o_c6q * B + l]
                for i in range(n):
                    a1 = w[(o_a1 + i) * B + l]
                    a2 = w[(o_a2 + i) * B + l]
                    a3 = w[(o_a3 + i) * B + l]
                    a4 = w[(o_a4 + i) * B + l]
                    sf[i * B + l] += _fma(h, sf[(n + i) * B + l], c6q * (a1 + a2 + a3))
                    o = (n + i) * B + l
                    sf[o] = _fma(c6, a1 + 2.0 * a2 + 2.0 * a3 + a4, sf[o])
                tau_ref = w[o_tau * B + l] + w[o_dtau * B + l]
                if tau_ref >= 1.0:
                    tau_ref -= 1.0
                    kf[B + l] += 1.0
                elif tau_ref < 0.0:
                    tau_ref += 1.0
                    kf[B + l] -= 1.0
                kf[l] = tau_ref
            for l in range(B):
                # a step longer than a mesh cycle wraps more than once
                while kf[l] >= 1.0:
                    kf[l] -= 1.0
                    kf[B + l] += 1.0
                while kf[l] < 0.0:
                    kf[l] += 1.0
                    kf[B + l] -= 1.0
            if not recs:
                continue
            for l in range(B):
                if CNT[l, 0] <= 0:
                    continue
                CNT[l, 0] -= 1
                if CNT[l, 0] != 0:
                    continue
                CNT[l, 0] = REC_EVERY[l]
                nrec = NREC[l]
                if nrec >= nr_cap:
                    continue
                for i in range(2 * n):
                    rec_state[l, nrec, i] = sf[i * B + l]
                tau_ref = kf[l]
                for k in range(m):
                    # the record's products run over every DOF, as the single-state loop's do
                    x = _l_dot(n, False, nz, k, vf, 0, sf, 0, B, l)
                    base, whole = tau_ref, kf[B + l]
                    if rates:
                        base, whole = mesh_base(phase[1, k], phase[2, k], kf[B + l], tau_ref)
                    t = _l_dot(n, False, nz, k, vf, o_w, sf, 0, B, l, base + phase[0, k])
                    d = _l_dot(n, False, nz, k, vf, o_rv, sf, 0, B, l)
                    xc = _l_dot(n, False, nz, k, vf, o_vc, sf, 0, B, l)
                    rec_out[l, nrec, REC * k + REC_POSITION] = whole + t
                    rec_out[l, nrec, REC * k + REC_DEFLECTION] = x
                    rec_out[l, nrec, REC * k + REC_DTE] = d
                    rec_out[l, nrec, REC * k + REC_COAST_APPROACH] = xc
                    rec_out[l, nrec, REC * k + REC_FORCE] = _drive_force_l(law, k, tab, tint, tflt, lin, lint, t, x)
                    rec_out[l, nrec, REC * k + REC_COAST_FORCE] = (_coast_row_l(tab, tint, tflt, m + k, t, xc)
                                                                   if two_sided else 0.0)
                rec_out[l, nrec, REC * m] = (CNT[l, 1] + step + 1) * w[o_h * B + l]
                NREC[l] = nrec + 1
        for l in range(B):
            CNT[l, 1] += n_steps
        return 0

    # the stage functions reach the loop as globals of its own, not as closure cells: numba keys its on-disk cache
    # by the closure cells' pickled contents, and a pickled dispatcher differs from process to process
    stage_globals = dict(globals(), _stages_coast=_make_stages(f"{name}_stages1", n_fixed, m_fixed, variant, lanes,
                                                               True),
                         _stages_plain=_make_stages(f"{name}_stages0", n_fixed, m_fixed, variant, lanes, False))
    loop = FunctionType(loop.__code__, stage_globals, name, loop.__defaults__, loop.__closure__)
    loop.__qualname__ = name
    return njit(cache=True, fastmath=False, pipeline_class=_NoAliasCompiler)(loop)


_LOOPS: dict = {}


def select_batch_kernel(law: int, n: int, m: int, two_sided: bool, rotating: bool, lanes: int,
                        diagonal_k: bool = False, rates: bool = False):
    """The batched loop for force law ``law`` (``LAW_TABLE`` or ``LAW_LINEAR``), ``n`` DOFs, ``m`` meshes, with
    coast-flank contact or without, a rotating carrier or not: specialised to the sizes the single-state kernel
    specialises (:func:`kernels.select_kernel`; its dense or sparse mesh products, so that the sums are the
    same), compiled on first use."""
    if law not in (LAW_TABLE, LAW_LINEAR):
        raise ValueError(f"the batched kernel runs force laws LAW_TABLE and LAW_LINEAR, not {law}")
    special = law == LAW_TABLE and (n, m) in ((2, 1), (4, 1), (3, 2))
    variant = law | (0 if special else VARIANT_SPARSE) | (VARIANT_TWO_SIDED if two_sided else 0) | (
        VARIANT_ROTATING if rotating else 0) | (VARIANT_DIAGONAL_K if diagonal_k else 0) | (
        VARIANT_RATES if rates else 0)
    key = ((n, m, variant) if special else (0, 0, variant)) + (lanes,)
    if key not in _LOOPS:
        nf, mf = key[0], key[1]
        _LOOPS[key] = _make_batch_loop(f"_batch_{nf}_{mf}_{variant}_{lanes}", nf, mf, variant, lanes)
    return _LOOPS[key]


def system_batch_kernel(system, lanes: int):
    """The batched loop of ``lanes`` lanes for ``system`` (a :class:`~hacgear_core.dynamics.system.LumpedSystem`),
    or None where the batched kernel does not run it (helical meshes)."""
    if not batch_supported(system):
        return None
    law = system.mesh_law
    return select_batch_kernel(law.kernel_law, system.n, system.m_kernel, law.kernel_two_sided,
                               system.carrier_ratio != 0.0, lanes, system.arrays.kidx.shape[0] == system.n,
                               not system.unit_rates)


def batch_constants(system) -> tuple:
    """The batched loop's arguments from ``mats`` on that do not depend on the lanes, for ``system``:
    ``(mats, vf, mf, phase, scal, tab, tint, tflt, lin, lint, kidx, kval, kd, nz)`` (``vf``, ``mf`` the flat
    ``vecs``, ``mmat``; ``kd`` the full M^-1 K (n*n, row-major)); the damping is each lane's
    (:func:`lane_damping`)."""
    c = system._cache
    if "batch_constants" not in c:
        a = system.arrays
        n = system.n
        kd = np.zeros((n, n))
        kd[a.kidx[:, 0], a.kidx[:, 1]] = a.kval[0]
        c["batch_constants"] = (a.mats, np.ascontiguousarray(a.vecs.reshape(-1)),
                                np.ascontiguousarray(a.mmat.reshape(-1)),
                                a.phase, a.scal, a.tab, a.tint, a.tflt, a.lin, a.lint, a.kidx, a.kval,
                                np.ascontiguousarray(kd.reshape(-1)), a.nz)
    return c["batch_constants"]


def lane_damping(system) -> np.ndarray:
    """``system``'s M^-1 C as a lane of the batched loop takes it: its transpose, flat (n*n,)."""
    return np.ascontiguousarray(system.arrays.mats[1].T).reshape(-1)


def lanes_compatible(a, b) -> bool:
    """Whether runs of systems ``a`` and ``b`` can be lanes of one batched loop: the same loop and the same kernel
    arrays but for the damping matrix (each lane has its own; e.g. the same pair at two torques, whose modal damping
    is taken at each torque)."""
    if a is b:
        return True
    if not (batch_supported(a) and batch_supported(b)):
        return False
    la, lb = a.mesh_law, b.mesh_law
    if (la.kernel_law, a.n, a.m_kernel, la.kernel_two_sided, a.carrier_ratio) != (
            lb.kernel_law, b.n, b.m_kernel, lb.kernel_two_sided, b.carrier_ratio):
        return False
    for f in dataclasses.fields(a.arrays):
        x, y = getattr(a.arrays, f.name), getattr(b.arrays, f.name)
        if f.name == "mats":
            x, y = np.delete(x, 1, axis=0), np.delete(y, 1, axis=0)
        if not np.array_equal(x, y):
            return False
    return True


class Lanes:
    """``lanes`` lanes of the batched loop for one system: their states, kinematics, steps and loads as the loop
    takes them (flat, lanes innermost), the scratch and the records of one call.

    ``load(j, s, kin, h, fext, rec_every[, damping])`` starts lane ``j`` on an integration (``s`` (2n,), ``kin``
    (3,) as for :meth:`~hacgear_core.dynamics.system.LumpedSystem.integrate` in speed mode; ``damping`` its own
    :func:`lane_damping`), ``run(n_steps, n_rec)`` advances every lane (records: at most ``n_rec`` per lane, in
    ``rec_state``/``rec_out``, ``nrec`` written), ``state(j)``/``kin(j)`` read a lane back."""

    def __init__(self, system, lanes: int) -> None:
        kernel = system_batch_kernel(system, lanes)
        if kernel is None:
            raise ValueError(f"{system.name}: the batched kernel does not run helical meshes (force law "
                             f"{system.force_law_name})")
        self.system = system
        self.kernel = kernel
        self.B = B = int(lanes)
        n, m = system.n, system.m_kernel
        self.n = n
        self.consts = batch_constants(system)
        self.ADT = np.zeros((n * n, B))
        self.ADT[:] = lane_damping(system)[:, None]
        self.S = np.zeros(2 * n * B)
        self.KIN = np.zeros((3 + m) * B)
        self.H = np.zeros(B)
        self.FEXT = np.zeros((n, B))
        self.RE = np.zeros(B, np.int64)
        self.CNT = np.zeros((B, 2), np.int64)
        self.nrec = np.zeros(B, np.int64)
        self.W = np.zeros(batch_rows(n, m, system.arrays.kidx.shape[0], system.carrier_ratio != 0.0) * B)
        self._ready = False
        self.rec_state = np.zeros((B, 0, 2 * n))
        self.rec_out = np.zeros((B, 0, system.record_width))

    def prepare(self, notice=None) -> tuple[bool, float]:
        """Load this loop from numba's cache or compile it (once per machine and lane count), saying so first
        (:func:`hacgear_core.dynamics.kernels.prepare_kernel`); :meth:`run` does it on its first call.  Returns
        ``(compiled, seconds)``."""
        law = self.system.mesh_law
        label = (f"the batched loop ({self.B} lanes) of "
                 + kernels.kernel_label(law.kernel_law, self.n, law.m_kernel, law.kernel_two_sided))
        return kernels.prepare_kernel(self.kernel, self._args(0), label, notice, cpu_s=BATCH_COMPILE_CPU_S)

    def _args(self, n_steps: int) -> tuple:
        return (self.S, self.KIN, int(n_steps), self.H, self.FEXT, self.RE, self.CNT, self.rec_state, self.rec_out,
                self.nrec, *self.consts, self.ADT.reshape(-1), self.W)

    def load(self, j: int, s, kin, h: float, fext, rec_every: int, damping=None) -> None:
        """``damping``: the lane's :func:`lane_damping` (default: the system's)."""
        B = self.B
        if damping is not None:
            self.ADT[:, j] = damping
        self.S.reshape(-1, B)[:, j] = s
        k = self.KIN.reshape(-1, B)
        k[:, j] = 0.0
        k[:3, j] = kin
        self.H[j] = h
        self.FEXT[:, j] = fext
        self.RE[j] = rec_every
        self.CNT[j] = (rec_every, 0)

    def copy_lane(self, j: int, src: int) -> None:
        """Lane ``j`` repeats lane ``src``'s integration without records (an idle lane: its results are not read)."""
        B = self.B
        self.S.reshape(-1, B)[:, j] = self.S.reshape(-1, B)[:, src]
        self.KIN.reshape(-1, B)[:, j] = self.KIN.reshape(-1, B)[:, src]
        self.H[j] = self.H[src]
        self.FEXT[:, j] = self.FEXT[:, src]
        self.ADT[:, j] = self.ADT[:, src]
        self.RE[j] = 0
        self.CNT[j] = (0, 0)

    def state(self, j: int) -> np.ndarray:
        return self.S.reshape(-1, self.B)[:, j]

    def kin(self, j: int) -> np.ndarray:
        return self.KIN.reshape(-1, self.B)[:3, j]

    def run(self, n_steps: int, n_rec: int = 0) -> None:
        if self.rec_state.shape[1] < n_rec:
            self.rec_state = np.zeros((self.B, n_rec, 2 * self.n))
            self.rec_out = np.zeros((self.B, n_rec, self.rec_out.shape[2]))
        if not self._ready:
            self.prepare()
            self._ready = True
        self.kernel(*self._args(n_steps))


def run_lanes(system, lanes, width: int | None = None, systems=None) -> list:
    """Advance lanes of runs of ``system`` together with the batched kernel.

    Each lane is a generator that yields :func:`~hacgear_core.dynamics.steady.steady_run` generators (one speed at
    a time), receives each one's result and returns when it has no more (a sweep branch: its speeds in order, each
    from the previous one's state).  Every call of the kernel advances the lanes by the steps the nearest end of a
    lane's current integration leaves, so each integration is done exactly as
    :meth:`~hacgear_core.dynamics.system.LumpedSystem.integrate` does it (the kernel's lanes equal the single-state
    kernel bit for bit); a finished lane repeats another's work without records until all are done (the loop is
    compiled for a lane count).  ``width``: run the loop compiled for that many lanes (at least ``len(lanes)``; the
    lanes beyond them idle from the start), so that a few lane counts serve any number of runs.  ``systems``: each
    lane's system where they differ in damping only (:func:`lanes_compatible` with ``system``; default ``system``
    for every lane).  Returns the lanes' return values, in order.
    """
    lanes = list(lanes)
    out = [None] * len(lanes)
    if not lanes:
        return out
    runs = [None] * len(lanes)
    B = max(len(lanes), int(width or 0))
    batch = Lanes(system, B)
    damping = [None] * len(lanes) if systems is None else [lane_damping(sy) for sy in systems]

    def pull(i, result):
        """Lane i's next integration request (its current run's, else its next run's), None when it is done."""
        while True:
            if runs[i] is None:
                try:
                    runs[i] = lanes[i].send(result)
                except StopIteration as stop:
                    out[i] = stop.value
                    return None
            try:
                return runs[i].send(None)
            except StopIteration as stop:
                result = stop.value
                runs[i] = None

    reqs: list = [None] * B   # per lane: [request, steps left, records copied]
    for i in range(len(lanes)):
        r = pull(i, None)
        if r is not None:
            reqs[i] = [r, int(r[2]), 0]
            batch.load(i, r[0], r[1], r[3], r[4], r[5], damping[i])
    idle = [i for i in range(B) if reqs[i] is None]
    while len(idle) < B:
        src = next(i for i in range(B) if reqs[i] is not None)
        for i in idle:
            batch.copy_lane(i, src)
        steps = min(v[1] for v in reqs if v is not None)
        n_rec = max(v[0][6].shape[0] - v[2] for v in reqs if v is not None)
        batch.run(steps, n_rec)
        for i, v in enumerate(reqs):
            if v is None:
                continue
            r, left, done = v
            rec_s, rec_o = r[6], r[7]
            c = min(int(batch.nrec[i]), rec_s.shape[0] - done)
            if c > 0:
                rec_s[done:done + c] = batch.rec_state[i, :c]
                rec_o[done:done + c] = batch.rec_out[i, :c]
            v[1] = left - steps
            v[2] = done + c
            if v[1] > 0:
                continue
            r[0][:] = batch.state(i)
            r[1][:3] = batch.kin(i)
            nxt = pull(i, None)
            if nxt is None:
                reqs[i] = None
                idle.append(i)
            else:
                reqs[i] = [nxt, int(nxt[2]), 0]
                batch.load(i, nxt[0], nxt[1], nxt[3], nxt[4], nxt[5], damping[i])
    return out
