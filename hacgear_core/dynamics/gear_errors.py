"""Manufacturing errors of gear teeth (pitch deviations, runout) as the error profile of each mesh.

A pitch or runout error of a gear moves the flanks of its teeth along the line of action: the tooth pairs in
contact meet earlier or later than ideal teeth would.  The dynamics take that as a shift of the drive flanks'
lookup deflection: the mesh force is the table's force at ``x - e(c)`` (``x = v . q`` the approach of the gear
bodies, ``c`` the unwrapped mesh position [cycles], ``e`` the mesh's *error profile*: the opening of the flanks,
positive where they meet later (the bodies must approach by ``e`` more for the same force), minus the closings
``E`` and ``R`` below, which may depend on ``x`` too; :class:`~hacgear_core.dynamics.system.MeshCoupling` ``error``, the
kernel's ``VARIANT_ERRORS`` loops).  This module builds ``e(c)`` from each gear's :class:`~hacgear_core.model.GearErrors`.

Conventions.  Teeth are counted in the order they reach a mesh: tooth ``j`` of gear ``g`` is at the pitch point of
mesh ``k`` at mesh position ``tooth_passage[g] + j`` (mod ``z_g``).  At mesh position ``c = n + tau`` (``n``
whole cycles, ``tau`` in [0, 1)) the table's tooth pair of offset ``o`` (its pair phase ``tau - o``) is tooth
``j_g = (n - tooth_passage[g] + o) mod z_g`` of each gear.  ``gear_a`` pushes ``gear_b`` (drive flanks).

Pitch.  The single pitch deviations ``f_p,j`` (pitch ending at tooth ``j``, on the reference circle, positive: a
longer pitch) give each tooth's cumulative pitch deviation ``F_j = sum_{i <= j} f_p,i`` less its mean (a common
offset is a rotation of the whole gear, not an error): tooth ``j`` arrives ``F_j`` late on the reference circle,
``F_j r_b / r`` along the line of action.  A late tooth of the driving gear (gear_a) meets its partner later
(``E = -F_j r_b / r``); a late tooth of the driven gear (gear_b) waits nearer the driving flank (``E = +F_j r_b /
r``).  ``E`` is a closing, positive where the pair meets earlier; the pair's closing is ``E_a(j_a) + E_b(j_b)``.

Runout.  The teeth of gear ``g`` turn about a centre offset by ``e_g`` (eccentricity) in the direction
``beta_g(c) = 2 pi (c - tooth_passage[g]) / z_g + phi_g`` from the direction of the pitch point, measured in the
gear's sense of rotation (``phi_g`` from tooth 0's centre line).  The offset's component along the line of action
moves every flank of the gear alike: ``R_a(c) = e_a sin(beta_a + alpha_w)``, ``R_b(c) = e_b sin(alpha_w -
beta_b)`` (``alpha_w`` the operating pressure angle of the drive flanks; an offset towards the mating gear,
``beta = 0``, closes the mesh by ``e sin alpha_w``: ``R`` is a closing, as ``E``); an internal gear's offset towards the pitch point moves its
teeth away from the mating gear: ``R_a(c) = e_a sin(beta_a - alpha_w)``, ``R_b(c) = -e_b sin(alpha_w + beta_b)``
(``internal``).  A planetary set is the fixed-axis train of its gear instances in the carrier frame, each mesh
instance with its own passages (:func:`~hacgear_core.kinds.planetary.planetary_error_inputs`).  The offset's
component across the line of action (a change of the centre distance and of the roll angles) is left out: it
changes the contact ratio and the mesh position by ``e / p_b`` of a cycle at most, a second-order effect for ``e``
of micrometres.

Several pairs in contact.  The table holds the force of all pairs together at one approach; with pairs of different
openings ``e_o(c) = -(E_a(j_a,o) + E_b(j_b,o))`` in contact each pair is taken at its own approach: the mesh force
is ``sum_o P_o(tau, x - e_o - R)`` (``P_o`` the table's tooth load of pair ``o``, here ``R = -(R_a + R_b)`` the
runout's opening; a pair an error lifts off carries nothing).  The kernel keeps its one table lookup: the profile is tabulated over (mesh position,
approach) on the drive table's deflection grid, ``e(c, x)`` such that ``F(tau, x - e) = sum_o P_o(tau, x - e_o -
R)`` at every grid approach, less the same without errors (:func:`approach_profile`; the tooth loads sum to the
table's force within 0.2 % on spur_28t_asym), linear between grid approaches.  Measured against solving the pair
sum directly (one tooth displaced 2-20 um, 0.5-1.5 x the nominal force): within 1.4 % RMS of the pulse
(docs/validation.md "Manufacturing errors").  Runout alone (every pair alike) is a profile over the position only,
exact at any load.  A conventional force law (no tooth loads) takes the static shift at the nominal force
(:func:`pair_solve_shift`), a linearisation (20 % RMS of a single pitch error's pulse at 0.5 and 1.5 x the torque on
spur_28t_asym).  A helical mesh (the twist law: its tooth pairs over the face are the table's tooth offsets) takes
the static shift at the nominal force too, on the table's tooth loads (its zero-twist slice; the static twist at
the nominal torque is a few microradians), along the flank normal (``cos beta_b`` of the transverse shift, as its
runout): against the pair solve at 0.5 and 1.5 x the nominal force, 8.6 / 5.5 % RMS of a 5 um tooth's pulse on
helical_28_33 (tests/test_gear_errors_helical.py).  Meshes at their own rates (gear trains, gearboxes) take their
profiles over their own positions (:func:`with_gear_errors`).  Not held: the coupling of the pairs through the gear
bodies when their approaches differ (the table's tooth loads come from the coupled solve at one common approach),
and the pairs' own approaches on the coast flanks (their runout and pitch errors are held, the pitch part as the
static shift at the nominal coast force: :func:`coast_error_profile`).  The profile is sampled at the table's
positions per cycle (``npc``) over ``L = lcm`` of the tooth counts of the gears that carry errors, linear between samples (as the table itself); it takes
``L npc nd`` floats (28 x 256 x 64 = 3.7 MB for the 28:28 pair).  For small errors the pair sum is the
stiffness-share rule ``e = R + sum_o (k_o / K) e_o`` (openings; :func:`load_shares`), the closed form the tests
compare spectra with.  Checked physically: a floating sun (or ring) takes up its runout by translating against its
offset (``tests/test_planetary_errors.py``), and under a fixed torque a pinion runout towards the wheel lowers the
static transmission error by ``e sin alpha_w`` (``tests/test_gear_errors.py``).
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Mapping

import numpy as np

from hacgear_core.dynamics.kernels import LAW_TWIST

__all__ = ["iso1328_single_pitch_tolerance_m", "single_pitch_deviations_m", "cumulative_pitch_deviations_m",
           "load_shares", "pair_solve_shift", "approach_profile", "mesh_error_profile", "coast_error_profile",
           "with_gear_errors", "GearErrorData"]


def iso1328_single_pitch_tolerance_m(grade: int, reference_diameter_m: float, normal_module_m: float) -> float:
    """Single pitch tolerance ``f_pT`` [m] of ISO 1328-1:2013 (its Eq. for ``f_pT``, unrounded): ``(0.001 d + 0.4
    m_n + 5) sqrt(2)^(A - 5)`` micrometres with ``d``, ``m_n`` in millimetres, ``A`` the accuracy grade."""
    d, mn = reference_diameter_m * 1e3, normal_module_m * 1e3
    return (0.001 * d + 0.4 * mn + 5.0) * math.sqrt(2.0) ** (int(grade) - 5) * 1e-6


def single_pitch_deviations_m(errors: Any, teeth: int, reference_diameter_m: float, normal_module_m: float) -> np.ndarray:
    """The single pitch deviations (z,) [m] of a gear's :class:`~hacgear_core.model.GearErrors`: as given, or drawn
    for its ``iso1328_grade``: uniform in ``[-f_pT, f_pT]`` (:func:`iso1328_single_pitch_tolerance_m`) with
    ``numpy.random.default_rng(seed)``, closed by subtracting their mean (so a few may exceed ``f_pT`` slightly; the
    cumulative deviation that results is not checked against ``F_pT``); zeros without pitch errors."""
    if errors is None:
        return np.zeros(teeth)
    if errors.single_pitch_deviations_m:
        return np.asarray(errors.single_pitch_deviations_m, float)
    if errors.iso1328_grade is None:
        return np.zeros(teeth)
    fpt = iso1328_single_pitch_tolerance_m(errors.iso1328_grade, reference_diameter_m, normal_module_m)
    f = np.random.default_rng(int(errors.seed)).uniform(-fpt, fpt, int(teeth))
    return f - f.mean()


def cumulative_pitch_deviations_m(single_m: np.ndarray) -> np.ndarray:
    """Cumulative pitch deviation (z,) [m] of every tooth (how late it arrives, on the reference circle) from the
    single pitch deviations (z,): ``F_j = sum_{i=1..j} f_p,i`` (``F_0 = 0``; ``f_p,0`` closes the circle), less
    the mean of ``F``."""
    f = np.asarray(single_m, float)
    F = np.concatenate([[0.0], np.cumsum(f[1:])])
    return F - F.mean()


def load_shares(table: Any, force_N: float, positions: np.ndarray, *, stiffness: bool = True,
                step_m: float = 0.5e-6) -> np.ndarray:
    """Share (Np, w) of each tooth pair (the table's ``tooth_offsets``, w of them) at mesh positions ``positions``
    (Np,) in [0, 1) under the static mesh force ``force_N`` [N], at the table's static deflection ``x_s``:
    ``stiffness`` (default) the pairs' stiffness shares, each pair's load change over ``x_s +- step_m`` over the
    sum of them (the first-order rule, module docstring); else their load shares, the tooth loads over their sum.
    The offset-0 pair alone where the table holds no tooth loads or no pair takes load."""
    offs = np.asarray(getattr(table, "tooth_offsets", [0]), int)
    pos = np.asarray(positions, float)
    out = np.zeros((pos.size, offs.size))
    i0 = int(np.flatnonzero(offs == 0)[0]) if np.any(offs == 0) else 0
    if getattr(table, "tooth_load_N", None) is None:
        out[:, i0] = 1.0
        return out
    x = np.asarray(table.static_deflection(pos, np.full(pos.size, float(force_N))), float)
    if stiffness:
        h = float(step_m)
        loads = np.stack([np.asarray(table.tooth_load(pos, x + h, int(o)), float)
                          - np.asarray(table.tooth_load(pos, x - h, int(o)), float) for o in offs], axis=1)
        loads = np.maximum(loads, 0.0)
    else:
        loads = np.stack([np.asarray(table.tooth_load(pos, x, int(o)), float) for o in offs], axis=1)
    tot = loads.sum(axis=1)
    ok = tot > 0
    out[ok] = loads[ok] / tot[ok, None]
    out[~ok, i0] = 1.0
    return out


def pair_solve_shift(table: Any, force_N: float, positions: np.ndarray, pair_errors_m: np.ndarray,
                     iterations: int = 60) -> np.ndarray:
    """Static approach change (Np,) [m] that errors ``pair_errors_m`` (Np, w) of the tooth pairs (the table's
    ``tooth_offsets``) cause at mesh positions ``positions`` (Np,) in [0, 1) under the static force ``force_N``
    [N]: ``x - x_0`` with ``sum_o P_o(tau, x - e_o) = F`` and ``sum_o P_o(tau, x_0) = F`` (``P_o`` the table's tooth
    load of pair ``o``; each pair at its own approach, so a pair that an error lifts off loses its load), solved by
    bisection on the bracket ``[x_0 + min e, x_0 + max e]`` (the sum is nondecreasing in ``x``).  A table without
    tooth loads: the offset-0 pair alone, ``e_0``."""
    pos = np.asarray(positions, float)
    eo = np.asarray(pair_errors_m, float)
    offs = np.asarray(getattr(table, "tooth_offsets", [0]), int)
    if getattr(table, "tooth_load_N", None) is None:
        return eo[:, int(np.flatnonzero(offs == 0)[0]) if np.any(offs == 0) else 0].copy()
    f = float(force_N)

    def total(x, e):
        return sum(np.asarray(table.tooth_load(pos, x - e[:, w], int(o)), float) for w, o in enumerate(offs))

    def solve(e):
        lo = x0_guess + e.min(axis=1) - 60e-6
        hi = x0_guess + e.max(axis=1) + 60e-6
        for _ in range(iterations):
            mid = 0.5 * (lo + hi)
            up = total(mid, e) >= f
            hi = np.where(up, mid, hi)
            lo = np.where(up, lo, mid)
        return 0.5 * (lo + hi)

    x0_guess = np.asarray(table.static_deflection(pos, np.full(pos.size, f)), float)
    return solve(eo) - solve(np.zeros_like(eo))


def _inverse_rows(frow: np.ndarray, xg: np.ndarray, f: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Deflection at which the table row ``frow`` (nd,) over the grid ``xg`` gives the forces ``f`` (...): linear on
    the row from its last zero on, extrapolated with its last slope beyond the grid; where ``f <= 0`` the smaller of
    ``x`` (the approach it belongs to) and the row's last zero (the teeth apart)."""
    zero = np.flatnonzero(frow <= 0.0)
    jz = int(zero[-1]) if zero.size else 0
    fr, xr = frow[jz:], xg[jz:]
    out = np.interp(f, fr, xr)
    slope = (fr[-1] - fr[-2]) / (xr[-1] - xr[-2]) if fr.size > 1 and fr[-1] > fr[-2] else np.inf
    beyond = f > fr[-1]
    out = np.where(beyond, xr[-1] + (f - fr[-1]) / slope, out)
    return np.where(f <= 0.0, np.minimum(x, xg[jz] if zero.size else x), out)


def approach_profile(table: Any, force: Any, tau: np.ndarray, npc: int, pair_errors_m: np.ndarray,
                     common_m: np.ndarray, grid: tuple[float, float, int]) -> np.ndarray:
    """Error profile over (mesh position, approach) (S, nd) [m]: at each sample ``s`` (table position ``tau[s]`` =
    ``(s mod npc) / npc``) and approach ``x_j = x0 + j dx`` of ``grid = (x0, dx, nd)``, the error ``e`` for which the
    table's force at ``x_j - e`` is the force of the pairs at their own approaches, ``F(tau, x_j - e) = sum_o
    P_o(tau, x_j - e_o - r)`` (``pair_errors_m`` (S, w) the pairs' own errors ``e_o``, ``common_m`` (S,) the error
    common to them ``r``, the table's tooth loads ``P_o``), less the same with no errors (so a table whose tooth
    loads do not sum to its force exactly has no error without errors).  ``force(tau (n,), x (n,))``: the table
    force the kernel reads."""
    x0, dx, nd = float(grid[0]), float(grid[1]), int(grid[2])
    xg = x0 + dx * np.arange(nd)
    offs = np.asarray(table.tooth_offsets, int)
    S = tau.size
    X = xg[None, :] - np.asarray(common_m, float)[:, None]                  # (S, nd)
    pos = np.repeat(tau, nd)
    fb = sum(np.asarray(table.tooth_load(pos, (X - pair_errors_m[:, w, None]).ravel(), int(o)), float)
             for w, o in enumerate(offs)).reshape(S, nd)
    tg = np.arange(npc) / npc
    fb0 = sum(np.asarray(table.tooth_load(np.repeat(tg, nd), np.tile(xg, npc), int(o)), float)
              for o in offs).reshape(npc, nd)
    ft = np.maximum(np.asarray(force(np.repeat(tg, nd), np.tile(xg, npc)), float).reshape(npc, nd), 0.0)
    row = np.rint(tau * npc).astype(np.int64) % npc
    e = np.empty((S, nd))
    xj = np.broadcast_to(xg, (S, nd))
    for i in range(npc):
        sel = row == i
        if not np.any(sel):
            continue
        xl = _inverse_rows(ft[i], xg, fb[sel], xj[sel])
        xl0 = _inverse_rows(ft[i], xg, fb0[i], xg)
        e[sel] = xl0[None, :] - xl
    return e


def mesh_error_profile(*, teeth: tuple[int, int], passage: tuple[float, float], pitch_m: tuple[np.ndarray | None,
                       np.ndarray | None], runout: tuple[tuple[float, float], tuple[float, float]],
                       pitch_to_loa: tuple[float, float], pressure_angle_rad: float, table: Any, force_N: float,
                       samples_per_cycle: int | None = None, approach_grid: tuple[float, float, int] | None = None,
                       table_force: Any = None, internal: tuple[bool, bool] = (False, False)) -> tuple | None:
    """Error profile ``(samples (L npc,) [m], L, npc)`` of one mesh (module docstring), None when neither gear has
    an error.

    ``teeth`` (z_a, z_b); ``passage`` their tooth passages in this mesh [cycles]; ``pitch_m`` each gear's
    cumulative pitch deviations (z,) [m] on the reference circle (None: none); ``runout`` each gear's
    (eccentricity [m], phase [rad]); ``pitch_to_loa`` each gear's ``r_b / r`` (reference circle to line of
    action); ``pressure_angle_rad`` the drive flanks' operating pressure angle; ``table`` the mesh table (load
    shares, positions per cycle); ``force_N`` the static mesh force the shares are taken at; ``internal`` whether
    each gear is an internal (ring) gear: its offset towards the pitch point moves its teeth away from the mating
    gear, ``R_a = e_a sin(beta_a - alpha_w)``, ``R_b = -e_b sin(alpha_w + beta_b)`` (the tangential part as for an
    external gear).

    ``approach_grid`` ``(x0, dx, nd)`` (the drive table's deflection grid) and ``table_force`` (the force the
    kernel reads, ``f(tau, x)``): with pitch errors and a table with tooth loads, the profile over (position,
    approach) of :func:`approach_profile`, ``(samples (L npc nd,), L, npc, nd)``: the pairs at their own approaches
    at every load.  Without them the pitch part is the static shift at ``force_N`` (:func:`pair_solve_shift`)."""
    za, zb = (int(z) for z in teeth)
    has_pitch = [p is not None and np.any(np.asarray(p) != 0) for p in pitch_m]
    has_run = [r[0] != 0.0 for r in runout]
    carriers = [z for z, p, r in zip((za, zb), has_pitch, has_run) if p or r]
    if not carriers:
        return None
    L = math.lcm(*carriers)
    npc = int(samples_per_cycle or getattr(table, "n_positions", 0) or 64)
    c = np.arange(L * npc) / npc
    n = np.arange(L * npc) // npc
    tau = (np.arange(L * npc) % npc) / npc
    e = np.zeros(L * npc)
    alpha = float(pressure_angle_rad)
    run = np.zeros(L * npc)       # the runout's closing R_a + R_b, then its opening
    for g, (z, tp, (ecc, phi)) in enumerate(zip((za, zb), passage, runout)):
        if ecc == 0.0:
            continue
        beta = 2.0 * math.pi * (c - float(tp)) / z + float(phi)
        if internal[g]:
            run += ecc * (np.sin(beta - alpha) if g == 0 else -np.sin(alpha + beta))
        else:
            run += ecc * (np.sin(beta + alpha) if g == 0 else np.sin(alpha - beta))
    run = -run                    # the kernel reads the force at x - e: e opens the flanks
    if any(has_pitch):
        offs = np.asarray(getattr(table, "tooth_offsets", [0]), int)
        eo = np.zeros((L * npc, offs.size))                              # each pair's own opening
        for g, (z, tp, p, sign) in enumerate(zip((za, zb), passage, pitch_m, (-1.0, 1.0))):
            if not has_pitch[g]:
                continue
            E = sign * pitch_to_loa[g] * np.asarray(p, float)        # each tooth's closing
            tp_i = int(round(float(tp)))
            for w, o in enumerate(offs):
                eo[:, w] -= E[np.mod(n - tp_i + int(o), z)]
        if approach_grid is not None and table_force is not None and getattr(table, "tooth_load_N", None) is not None:
            e2 = approach_profile(table, table_force, tau, npc, eo, run, approach_grid)
            return np.ascontiguousarray(e2.ravel()), int(L), npc, int(approach_grid[2])
        e += pair_solve_shift(table, force_N, tau, eo)
    e += run
    return np.ascontiguousarray(e), int(L), npc


def coast_error_profile(*, teeth: tuple[int, int], passage: tuple[float, float],
                        runout: tuple[tuple[float, float], tuple[float, float]], pressure_angle_rad: float,
                        samples_per_cycle: int, internal: tuple[bool, bool] = (False, False),
                        pitch_m: tuple[np.ndarray | None, np.ndarray | None] = (None, None),
                        pitch_to_loa: tuple[float, float] = (1.0, 1.0), table: Any = None,
                        force_N: float = 0.0) -> tuple | None:
    """Error profile ``(samples (L npc,) [m], L, npc)`` of one mesh's coast flanks over the position, None without
    runout or pitch errors, over ``L`` = lcm of the tooth counts of the gears that carry them.

    Runout: the coast line of action is the drive one mirrored about the line of centres, so the offset's
    component towards the mating gear closes both flanks alike and its tangential component opens the coast flanks
    by what it closes the drive ones: ``R_a,c = e_a sin(alpha_c - beta_a)``, ``R_b,c = e_b sin(alpha_c + beta_b)``
    (external), ``R_a,c = -e_a sin(beta_a + alpha_c)``, ``R_b,c = e_b sin(beta_b - alpha_c)`` (internal), with
    ``beta_g`` as in :func:`mesh_error_profile` and ``alpha_c`` the coast flanks' operating pressure angle
    (``pressure_angle_rad``).  An offset ``e`` of gear_a towards gear_b (a centre distance shorter by ``e``) so closes
    the backlash by ``e (sin alpha_w + sin alpha_c)`` along the transverse (``2 e sin alpha_w`` for symmetric teeth,
    the textbook ``j_n = 2 Delta_a sin alpha_w``).

    Pitch (``pitch_m``: each gear's cumulative pitch deviations (z,) [m], the whole tooth displaced, both flanks
    alike): a late tooth of the driving gear (gear_a) has its coast flank nearer its partner's (closing ``+F_j
    r_bc / r``), a late tooth of the driven gear the opposite (``-F_j r_bc / r``; ``pitch_to_loa`` each gear's
    ``r_bc / r``).  The coast pair of offset ``o`` (the coast ``table``'s ``tooth_offsets``) holds gear_a's tooth of
    drive pair ``o - 1`` and gear_b's of drive pair ``o`` (:data:`~hacgear_core.statics.coast.COAST_PAIR_SHIFT`);
    the pairs are taken at their own approaches by the static shift at the coast force ``force_N``
    (:func:`pair_solve_shift` on the coast table's tooth loads), a linearisation in the load."""
    za, zb = (int(z) for z in teeth)
    has_pitch = [p is not None and np.any(np.asarray(p) != 0) for p in pitch_m]
    carriers = [z for z, p, r in zip((za, zb), has_pitch, runout) if p or r[0] != 0.0]
    if not carriers:
        return None
    L = math.lcm(*carriers)
    npc = int(samples_per_cycle)
    c = np.arange(L * npc) / npc
    n = np.arange(L * npc) // npc
    tau = (np.arange(L * npc) % npc) / npc
    alpha = float(pressure_angle_rad)
    run = np.zeros(L * npc)
    for g, (z, tp, (ecc, phi)) in enumerate(zip((za, zb), passage, runout)):
        if ecc == 0.0:
            continue
        beta = 2.0 * math.pi * (c - float(tp)) / z + float(phi)
        if internal[g]:
            run += ecc * (-np.sin(beta + alpha) if g == 0 else np.sin(beta - alpha))
        else:
            run += ecc * (np.sin(alpha - beta) if g == 0 else np.sin(alpha + beta))
    e = -run
    if any(has_pitch):
        if table is None:
            raise ValueError("coast pitch errors need the coast table (its tooth offsets and loads)")
        offs = np.asarray(getattr(table, "tooth_offsets", [0]), int)
        eo = np.zeros((L * npc, offs.size))                              # each coast pair's own opening
        for g, (z, tp, p, sign, shift) in enumerate(zip((za, zb), passage, pitch_m, (1.0, -1.0), (1, 0))):
            if not has_pitch[g]:
                continue
            E = sign * pitch_to_loa[g] * np.asarray(p, float)        # each tooth's coast closing
            tp_i = int(round(float(tp)))
            for w, o in enumerate(offs):
                eo[:, w] -= E[np.mod(n - tp_i + int(o) - shift, z)]
        e = e + pair_solve_shift(table, force_N, tau, eo)
    return np.ascontiguousarray(e), int(L), npc


#: per gear: (its GearErrors, reference radius [m], normal module [m]) as :func:`with_gear_errors` takes them
GearErrorData = tuple


def with_gear_errors(system: Any, gears: Mapping[str, GearErrorData],
                     pressure_angles_rad: Mapping[str, float], *, approach: bool = True,
                     normal_factor: Mapping[str, float] | None = None, internal_gears: tuple[str, ...] = (),
                     runout_passage: Mapping[str, Mapping[str, float]] | None = None,
                     coast_pressure_angles_rad: Mapping[str, float] | None = None) -> Any:
    """``system`` (a :class:`~hacgear_core.dynamics.system.LumpedSystem` of a fixed-axis train) with the error
    profile of every mesh one of whose gears has errors (:func:`mesh_error_profile`); the system itself when no
    gear has any.

    ``gears`` {gear: (GearErrors or None, reference radius [m], normal module [m])}; ``pressure_angles_rad``
    {mesh: operating pressure angle of its drive flanks [rad]}.  ``approach`` (default): meshes with pitch errors
    on force tables get profiles over (position, approach) (:func:`approach_profile`: the pairs at their own
    approaches at every load); False, a conventional law or the twist law (helical meshes, and the spur meshes of
    a train with a helical stage): the static shift at each mesh's nominal force.
    ``normal_factor`` {mesh: factor}: the mesh deflection's share of a transverse line-of-action displacement
    (``cos beta_b`` for a helical mesh, whose deflection is along the flank normal; default 1).  ``internal_gears``:
    the internal (ring) gears (:func:`mesh_error_profile` ``internal``).  ``runout_passage`` {mesh: {gear: tooth
    passage [cycles]}}: the exact (fractional) passage the runout's direction is counted from, within half a cycle
    of the coupling's integer ``tooth_passage`` (a planet's two meshes on opposite sides of it,
    :func:`~hacgear_core.kinds.planetary.planetary_error_inputs`); the pitch errors keep the integer passage.
    ``coast_pressure_angles_rad`` {mesh: operating pressure angle of its coast flanks [rad]}: the meshes with a coast
    table on the table or conventional laws (not the helical meshes' twist law) get the coast flanks' profile of
    runout and pitch errors (:func:`coast_error_profile`, ``MeshCoupling.coast_error``; the pitch part at the
    nominal coast force).

    Meshes at their own rates (a gear train's or gearbox's stages, ``MeshCoupling.rate``): each profile is over its
    own mesh's unwrapped position (the kernel's ``c_k``, ``p/q`` times the reference position), so the tooth count
    of a gear indexes the cycles of the meshes it is in; the system's period counts it in reference cycles
    (:attr:`~hacgear_core.dynamics.system.LumpedSystem.period_cycles`)."""
    if not any(ge is not None and ge.any for ge, _, _ in gears.values()):
        return system
    cum = {}
    for name, (ge, r_ref, mn) in gears.items():
        if ge is None or name not in system.gears:
            continue
        z = system.gears[name].teeth
        f = single_pitch_deviations_m(ge, z, 2.0 * r_ref, mn)
        cum[name] = cumulative_pitch_deviations_m(f) if np.any(f != 0) else None
    meshes = []
    for c in system.meshes:
        ga, gb = c.gear_a, c.gear_b
        ea, eb = gears.get(ga, (None, 1.0, 0.0))[0], gears.get(gb, (None, 1.0, 0.0))[0]
        if not ((ea is not None and ea.any) or (eb is not None and eb.any)):
            meshes.append(c)
            continue
        ratio = tuple(float(c.base_radius_m[i]) / float(gears[g][1]) if g in gears else 1.0
                      for i, g in enumerate((ga, gb)))
        k = system.mesh_names.index(c.name)
        grid = force = None
        if approach and system.mesh_law.kernel_law == 0:
            ta = system.table_arrays[k]
            grid = (float(ta.x0), float(ta.dx), int(ta.ftab.shape[1]))
            force = (lambda kk: (lambda t, x: system.mesh_force(kk, t, x)))(k)
        passage = tuple(float((runout_passage or {}).get(c.name, {}).get(g, c.tooth_passage.get(g, 0)))
                        for g in (ga, gb))
        prof = mesh_error_profile(
            teeth=tuple(c.teeth), passage=passage, internal=(ga in internal_gears, gb in internal_gears),
            pitch_m=(cum.get(ga), cum.get(gb)),
            runout=tuple(((ge.runout_m, ge.runout_phase_rad) if ge is not None else (0.0, 0.0)) for ge in (ea, eb)),
            pitch_to_loa=ratio, pressure_angle_rad=float(pressure_angles_rad[c.name]), table=c.table,
            force_N=float(c.nominal_force_N), approach_grid=grid, table_force=force)
        fac = float((normal_factor or {}).get(c.name, 1.0))
        if prof is not None and fac != 1.0:
            prof = (np.ascontiguousarray(prof[0] * fac),) + tuple(prof[1:])
        cprof = None
        if (coast_pressure_angles_rad is not None and c.name in coast_pressure_angles_rad
                and c.coast_table is not None and system.mesh_law.kernel_law != LAW_TWIST):
            ct = c.coast_table
            cprof = coast_error_profile(
                teeth=tuple(c.teeth), passage=passage, internal=(ga in internal_gears, gb in internal_gears),
                runout=tuple(((ge.runout_m, ge.runout_phase_rad) if ge is not None else (0.0, 0.0))
                             for ge in (ea, eb)),
                pressure_angle_rad=float(coast_pressure_angles_rad[c.name]),
                samples_per_cycle=int(getattr(c.table, "n_positions", 0) or 64),
                pitch_m=(cum.get(ga), cum.get(gb)),
                pitch_to_loa=tuple(float(ct.base_radius_m[i]) / float(gears[g][1]) if g in gears else 1.0
                                   for i, g in enumerate((ga, gb))),
                table=ct, force_N=float(c.nominal_coast_force_N))
        meshes.append(c if prof is None and cprof is None else replace(c, error=prof, coast_error=cprof))
    return system.with_changes(meshes=tuple(meshes))
