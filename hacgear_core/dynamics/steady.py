"""Steady-state response of a lumped gear system at one mesh frequency: detected, not assumed.

Policy.  The constant-speed model is integrated in whole mesh cycles (``N`` RK4 steps per cycle, a power of
two >= 128, more when the highest natural frequency needs it) and the *elastic* part of the state is sampled
once per mesh cycle (Poincaré section at integer mesh position): every mesh's deflection and its rate, and the
translations and their rates (rigid-body rotation is left out; it is a neutral direction).  Each sample is
scaled by the largest static mesh deflection (positions) and by ``2 pi f_m`` times that (rates).  A
period-``n`` orbit (``n = 1..max_period``) is accepted when the scaled infinity-norm of ``p_k - p_{k-n}`` is below
``rtol`` for the last ``2n + 1`` consecutive cycles (smallest ``n`` wins), after at least ``min_cycles``; for
``n > 1`` the orbit must also differ from a period-1 orbit (lag-1 differences >= 100 ``rtol``), since a decaying
transient whose phase turns by about ``2 pi m / n`` per cycle passes the lag-``n`` test early.  Otherwise
integration stops at ``max_cycles`` and the result says so (``converged = False``, ``status = "cap"``); its
metrics then come from the next ``cap_record_cycles`` cycles (default 4; a quasi-periodic response needs a long
window for its RMS to be a property of the motion rather than of where the window fell).

A gear train whose stages run at different mesh frequencies (rates ``p/q`` of the reference mesh) repeats only
after ``system.period_cycles`` reference mesh cycles (the lcm of the ``q``): its samples are taken once per such
system period, and ``min_cycles``, ``max_cycles``, ``max_period``, ``chunk_cycles`` and ``cap_record_cycles`` count
system periods; the result's ``period_cycles`` and ``cycles_run`` are in reference mesh cycles.

Where that period exceeds ``max_system_period`` reference mesh cycles (default 512; a wind-turbine gearbox repeats
after tens of input revolutions) the response is taken as quasi-periodic: the run first settles for the decay time of the
slowest elastic mode, ``ln(1 / rtol) / (zeta omega_1)`` (modal damping ratio ``zeta``, lowest elastic natural
frequency ``omega_1``), then records two observation windows of ``window_revolutions`` revolutions of the slowest
shaft each (whole reference mesh cycles, every mesh recorded at least 32 times per its own cycle).  The second
window's metrics are the result; it is ``converged`` (status ``quasi-periodic``) when every metric of the two
windows agrees within ``window_rtol`` of the larger, else ``cap``.  ``period_cycles`` is then the window's length
in reference mesh cycles, and the end state lies on a reference mesh cycle boundary only (the faster stages
elsewhere in their cycles: a sweep's next speed starts with a short transient, which its settling absorbs).

Stability (``stability=True``).  Detection alone can accept an unstable orbit: a symmetric system (identical,
in-phase planets) keeps a symmetric solution to rounding even where it is unstable, because the perturbation that
would grow starts at 1e-16 and grows by only a few per cent per cycle.  With ``stability`` every detected orbit is
refined by shooting and its Floquet multipliers computed (:mod:`~hacgear_core.dynamics.floquet`); an orbit with a
multiplier outside the unit circle is pushed along that multiplier's eigenvector (``kick`` of the scale below)
and integrated on, up to ``max_kicks`` times, so the response settles on an attractor.  The result then carries
the largest elastic multiplier modulus of the orbit it returns (``max_multiplier``; < 1 stable).

Metrics over the final period (``n`` cycles, every step), per mesh (arrays of length m): mean and RMS of the
oscillating part of the mesh deflection, dynamic transmission error (mean, RMS, peak-to-peak); on the flanks the
nominal torque loads (the drive flanks, the coast flanks for a negative torque): peak and minimum force, fraction
of the period with contact loss (their force 0), force dynamic factor ``max F / F_s``, the fraction of teeth that
take no load during their whole pass (tooth skipping, :func:`hacgear_core.response.skipped_tooth_fraction`) and,
when the mesh's table has strains, the strain dynamic factor (largest over its gauges,
:func:`hacgear_core.response.strain_dynamic_factor`); on the other flank pair across the backlash (the back side):
the fraction of the period in contact, its peak force and the number of back-side impacts per mesh cycle.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hacgear_core.dynamics import kernels
from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.dynamics.floquet import floquet
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.encodings import contact_state
from hacgear_core.errors import ModelError
from hacgear_core.response import skipped_tooth_fraction, static_strain_max, strain_dynamic_factor

__all__ = ["SteadyStateOptions", "SteadyStateResult", "steady_state", "steady_run", "drive", "METRIC_NAMES", "trace_metrics",
           "window_cycles"]

METRIC_NAMES = (
    "mean_deflection_m",
    "rms_deflection_m",
    "dte_mean_m",
    "dte_rms_m",
    "dte_peak_to_peak_m",
    "peak_force_N",
    "min_force_N",
    "contact_loss_fraction",
    "skipped_tooth_fraction",
    "back_side_contact_fraction",
    "peak_back_side_force_N",
    "back_side_impacts_per_cycle",
    "dynamic_factor_force",
    "dynamic_factor_strain",
)


@dataclass(frozen=True)
class SteadyStateOptions:
    """Steady-state detection settings (see module docstring)."""

    rtol: float = 1e-5
    min_cycles: int = 8
    max_cycles: int = 3000
    max_period: int = 4
    chunk_cycles: int = 16
    min_steps_per_cycle: int = 128
    stability: bool = False
    max_kicks: int = 3
    kick: float = 1e-2
    cap_record_cycles: int = 4
    max_system_period: int = 512
    window_revolutions: int = 1
    window_rtol: float = 1e-2

    def __post_init__(self) -> None:
        if not 1 <= self.max_system_period <= 100000:
            raise ModelError(f"max_system_period [reference mesh cycles] must be in [1, 100000], got "
                             f"{self.max_system_period}")
        if not 1 <= self.window_revolutions <= 100:
            raise ModelError(f"window_revolutions [-] must be in [1, 100], got {self.window_revolutions}")
        if not (0 < self.window_rtol < 1):
            raise ModelError(f"window_rtol [-] must be in (0, 1), got {self.window_rtol}")
        if not (0 < self.rtol < 1):
            raise ModelError(f"rtol [-] must be in (0, 1), got {self.rtol}")
        if not (1 <= self.min_cycles <= self.max_cycles):
            raise ModelError(f"need 1 <= min_cycles <= max_cycles, got {self.min_cycles}, {self.max_cycles}")
        if not 1 <= self.max_period <= 16:
            raise ModelError(f"max_period [cycles] must be in [1, 16], got {self.max_period}")
        if self.chunk_cycles < 1 or self.min_steps_per_cycle < 8:
            raise ModelError("chunk_cycles must be >= 1 and min_steps_per_cycle >= 8")
        if not 1 <= self.cap_record_cycles <= 4096:
            raise ModelError(f"cap_record_cycles [mesh cycles] must be in [1, 4096], got {self.cap_record_cycles}")
        if not 0 <= self.max_kicks <= 10:
            raise ModelError(f"max_kicks must be in [0, 10], got {self.max_kicks}")
        if not (0 < self.kick < 1):
            raise ModelError(f"kick [-] (relative to the static mesh deflection) must be in (0, 1), got {self.kick}")


@dataclass
class SteadyStateResult:
    """Steady state at one mesh frequency.  ``state`` (2n,) is the state at the end of the recorded period (a cycle
    boundary, reference mesh position 0): the start of the next speed of a sweep.  ``metrics``: name → (m,)."""

    mesh_frequency_Hz: float
    converged: bool
    status: str
    period_cycles: int
    cycles_run: int
    steps_per_cycle: int
    state: np.ndarray
    metrics: dict
    trace: dict = field(default_factory=dict)
    #: largest modulus of the orbit's elastic Floquet multipliers (< 1: stable); NaN unless checked
    #: (``SteadyStateOptions.stability``) on a converged orbit
    max_multiplier: float = math.nan
    #: unstable orbits left (pushed off along their growing perturbation) before this one
    kicks: int = 0


def _projection(system: LumpedSystem) -> np.ndarray:
    n = system.n
    rows = []
    for v in system.V:
        rows.append(np.concatenate([v, np.zeros(n)]))
        rows.append(np.concatenate([np.zeros(n), v]))
    rot = {g.rotation for g in system.gears.values()}
    for i in range(n):
        if i in rot:
            continue
        for off in (0, n):
            r = np.zeros(2 * n)
            r[off + i] = 1.0
            rows.append(r)
    return np.array(rows)


def _static_scale(system: LumpedSystem, torque_Nm: float | None) -> float:
    """Largest static mesh deflection [m] at mesh position 0 (the scale of the Poincaré samples)."""
    key = ("scale", system.torque_Nm if torque_Nm is None else float(torque_Nm))
    c = system._cache
    if key not in c:
        eq = static_equilibrium(system, 0.0, system.fext_speed(torque_Nm))
        if np.any(eq.coast_forces_N > 0):  # coast flanks loaded: their approach beyond the backlash
            c[key] = max(float(np.max(np.abs(eq.coast_approach_m - system.backlash_m))), 1e-7)
        else:
            c[key] = max(float(np.max(np.abs(eq.mesh_deflections_m))), 1e-7)
    return c[key]


def _static_strain(system: LumpedSystem, forces: np.ndarray, tables) -> list[dict]:
    key = ("strain_max", tuple(forces), tuple(id(t) for t in tables))
    c = system._cache
    if key not in c:
        c[key] = [static_strain_max(t, f) if getattr(t, "strain", None) else {} for t, f in zip(tables, forces)]
    return c[key]


def _ratio(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a / b`` where ``b > 0``, NaN elsewhere (a flank pair without static force has no dynamic factor)."""
    return np.divide(a, b, out=np.full(np.shape(a), math.nan), where=np.asarray(b) > 0)


def trace_metrics(system: LumpedSystem, x, f, dte, tau=None, static_forces_N=None, fc=None, cycles: int = 1,
                  coast_static_forces_N=None, xc=None, coast_loaded=None, periodic: bool = True) -> dict:
    """Response metrics (:data:`METRIC_NAMES`, each an (m,) array) of a record of ``cycles`` mesh cycles: ``x``,
    ``f``, ``dte``, ``tau``, coast force ``fc`` and coast approach ``xc`` (nr, m).
    ``static_forces_N`` (m,) the drive-flank and ``coast_static_forces_N`` the coast-flank static forces (default:
    the system's nominal ones).  The loaded flanks are the coast flanks when the static forces load them (a
    negative torque), else the drive flanks; ``coast_loaded`` (bool, or (m,) bools) overrides that per mesh (a
    record driven by shaft torques).  The dynamic factors are taken on the loaded flanks (for the coast side: its
    table at the coast approach); the other flank pair loads the far side of a tooth's root and only compresses the
    loaded side's gauges, so it cannot raise their maximum.  ``periodic``: the record is one period (a back-side
    impact may begin at its first sample); else impacts are counted from the second sample on."""
    x, f, dte = (np.atleast_2d(np.asarray(a, float)) for a in (x, f, dte))
    if x.shape[0] == 1 and x.shape[1] != system.m:
        x, f, dte = x.T, f.T, dte.T
    fc = np.zeros_like(f) if fc is None else np.atleast_2d(np.asarray(fc, float)).reshape(f.shape)
    fs = system.nominal_forces_N() if static_forces_N is None else np.asarray(static_forces_N, float)
    fsc = system.nominal_coast_forces_N() if coast_static_forces_N is None else np.asarray(coast_static_forces_N,
                                                                                             float)
    if coast_loaded is None:
        coast_loaded = np.all(fs <= 0) and np.any(fsc > 0)
    coast = np.broadcast_to(np.asarray(coast_loaded, bool), (f.shape[1],))
    fl, fb = np.where(coast, fc, f), np.where(coast, f, fc)   # the loaded flanks' force, the back side's
    on = fb > 0.0
    starts = on & ~np.roll(on, 1, axis=0)
    if not periodic:
        starts[0] = False
    xm = np.mean(x, axis=0)
    dm = np.mean(dte, axis=0)
    m = {
        "mean_deflection_m": xm,
        "rms_deflection_m": np.sqrt(np.mean((x - xm) ** 2, axis=0)),
        "dte_mean_m": dm,
        "dte_rms_m": np.sqrt(np.mean((dte - dm) ** 2, axis=0)),
        "dte_peak_to_peak_m": np.ptp(dte, axis=0),
        "peak_force_N": np.max(fl, axis=0),
        "min_force_N": np.min(fl, axis=0),
        "contact_loss_fraction": np.mean(fl <= 0.0, axis=0),
        "skipped_tooth_fraction": np.full(system.m, math.nan),
        "back_side_contact_fraction": np.mean(on, axis=0),
        "peak_back_side_force_N": np.max(fb, axis=0),
        "back_side_impacts_per_cycle": np.sum(starts, axis=0) / np.maximum(cycles * system.rates, 1.0),
        "dynamic_factor_force": _ratio(np.max(fl, axis=0), np.where(coast, fsc, fs)),
        "dynamic_factor_strain": np.full(system.m, math.nan),
    }
    if tau is not None:
        tau = np.atleast_2d(np.asarray(tau, float))
        if tau.shape[0] == 1 and tau.shape[1] != system.m:
            tau = tau.T
        xc = x if xc is None else np.atleast_2d(np.asarray(xc, float)).reshape(x.shape)
        side = coast & (xc is not x)   # the coast side where it is loaded and its approach is given
        tabs = [c.coast_table if side[k] else c.table for k, c in enumerate(system.meshes)]
        fl_s, xl = np.where(side, fsc, fs), np.where(side, xc, x)
        smax = _static_strain(system, fl_s, tabs)
        for k, t in enumerate(tabs):
            if getattr(t, "tooth_load_N", None) is not None:
                m["skipped_tooth_fraction"][k] = skipped_tooth_fraction(t, tau[:, k], xl[:, k],
                                                                        int(round(cycles * system.rates[k])))
            if not smax[k]:
                continue
            dfs = strain_dynamic_factor(t, tau[:, k], xl[:, k], fl_s[k], smax[k])
            if dfs:
                m["dynamic_factor_strain"][k] = float(max(dfs.values()))
    return m


def steady_state(system: LumpedSystem, mesh_frequency_Hz: float, state0: np.ndarray | None = None,
                 options: SteadyStateOptions | None = None, *, torque_Nm: float | None = None,
                 keep_trace: bool = False) -> SteadyStateResult:
    """Integrate the constant-speed model at ``mesh_frequency_Hz`` [Hz] until a periodic steady state is detected
    (or the cycle cap is hit).

    Parameters
    ----------
    system : LumpedSystem
    mesh_frequency_Hz : float
        Mesh frequency [Hz], > 0.
    state0 : (2n,) array, optional
        Start state at reference mesh position 0 (default: static equilibrium).
    options : SteadyStateOptions
    torque_Nm : float, optional
        Torque on the input gear [N m] (default: the system's nominal torque).
    keep_trace : bool
        Return the final period's time histories in ``trace`` (per mesh: (nr, m) arrays).
    """
    return drive(system, steady_run(system, mesh_frequency_Hz, state0, options, torque_Nm=torque_Nm,
                                    keep_trace=keep_trace))


def drive(system: LumpedSystem, run):
    """Do the integrations a :func:`steady_run` generator asks for with the system's single-state kernel; return
    its result."""
    try:
        s, kin, n_steps, h, fext, rec_every, rec_state, rec_out = next(run)
        while True:
            system.integrate(s, kin, n_steps, h, fext, rec_every=rec_every, rec_state=rec_state, rec_out=rec_out)
            s, kin, n_steps, h, fext, rec_every, rec_state, rec_out = run.send(None)
    except StopIteration as done:
        return done.value


def steady_run(system: LumpedSystem, mesh_frequency_Hz: float, state0: np.ndarray | None = None,
               options: SteadyStateOptions | None = None, *, torque_Nm: float | None = None,
               keep_trace: bool = False):
    """:func:`steady_state` as a generator that leaves the integration to its caller: it yields each run it needs,
    ``(s, kin, n_steps, h, fext, rec_every, rec_state, rec_out)`` (the arguments of
    :meth:`~hacgear_core.dynamics.system.LumpedSystem.integrate`, in speed mode), expects them done in place when
    resumed, and returns the :class:`SteadyStateResult`.  The batched sweeps advance several of them at once
    (:func:`hacgear_core.dynamics.batch.run_lanes`)."""
    fm = float(mesh_frequency_Hz)
    if not (math.isfinite(fm) and fm > 0):
        raise ModelError(f"mesh frequency [Hz] must be finite and > 0, got {mesh_frequency_Hz!r}")
    opt = options or SteadyStateOptions()
    n, mm = system.n, system.m
    n2 = 2 * n
    fext = system.fext_speed(torque_Nm)
    if state0 is None:
        s = np.concatenate([static_equilibrium(system, 0.0, fext).q, np.zeros(n)])
    else:
        s = np.array(state0, dtype=float)
    if s.shape != (n2,):
        raise ModelError(f"state0 must have shape ({n2},), got {s.shape}")
    nsp = system.steps_per_cycle(fm, minimum=opt.min_steps_per_cycle)
    h = 1.0 / (fm * nsp)
    if system.period_cycles > opt.max_system_period:
        return (yield from _quasi_periodic_run(system, fm, s, opt, fext, nsp, h, torque_Nm, keep_trace))
    # one sample per system period (every mesh back at its start position): 1 reference mesh cycle, or
    # period_cycles of them for meshes at different rates; the options' cycles count these periods
    per_p = system.period_cycles
    nsp_p = nsp * per_p
    omega = system.reference_speed(fm)
    fs = system.nominal_forces_N(torque_Nm)
    fsc = system.nominal_coast_forces_N(torque_Nm)
    xs = _static_scale(system, torque_Nm)
    proj = _projection(system)
    scale = np.ones(len(proj))
    scale[1::2] = 2 * math.pi * fm  # rates
    proj = proj / (xs * scale[:, None])
    hist = np.empty((opt.max_cycles + 1, proj.shape[0]))
    hist[0] = proj @ s
    kin = np.zeros(3)
    rec_s = np.zeros((opt.chunk_cycles, n2))
    rec_o = np.zeros((opt.chunk_cycles, system.record_width))
    cycles = 0
    period = 0
    kicks = 0
    mu_max = math.nan
    while cycles < opt.max_cycles and period == 0:
        nc = min(opt.chunk_cycles, opt.max_cycles - cycles)
        kin[:] = (0.0, 0.0, omega)
        yield s, kin, nc * nsp_p, h, fext, nsp_p, rec_s, rec_o
        if not np.all(np.isfinite(s)):
            raise ModelError(f"integration diverged at f_m = {fm:g} Hz (state not finite)")
        hist[cycles + 1: cycles + 1 + nc] = rec_s[:nc] @ proj.T
        cycles += nc
        if cycles < opt.min_cycles:
            continue
        for per in range(1, opt.max_period + 1):
            need = 2 * per + 1
            if cycles - per - need + 1 < 0:
                break
            d = np.abs(hist[cycles - need + 1: cycles + 1] - hist[cycles - need + 1 - per: cycles + 1 - per])
            if np.max(d) < opt.rtol:
                if per > 1:
                    d1 = np.abs(hist[cycles - per + 1: cycles + 1] - hist[cycles - per: cycles])
                    if np.max(d1) < 100 * opt.rtol:
                        continue
                period = per
                break
        if period and opt.stability:
            fq = floquet(system, fm, s, period * per_p, torque_Nm=torque_Nm, steps_per_cycle=nsp)
            mu_max = fq.max_multiplier
            if fq.success and not fq.stable and kicks < opt.max_kicks and cycles < opt.max_cycles:
                # push the orbit off along its growing perturbation, sized ``kick`` in the scaled coordinates
                v = np.real(fq.vectors[:, 0])
                if not np.any(np.abs(proj @ v) > 0):
                    v = np.imag(fq.vectors[:, 0])
                s = fq.state + v * (opt.kick / np.max(np.abs(proj @ v)))
                hist[cycles] = proj @ s
                kicks += 1
                period = 0
                mu_max = math.nan
    converged = period > 0
    nrec_cyc = period if converged else opt.cap_record_cycles
    nrec = nrec_cyc * nsp_p
    rs = np.zeros((nrec, n2))
    ro = np.zeros((nrec, system.record_width))
    kin[:] = (0.0, 0.0, omega)
    yield s, kin, nrec, h, fext, 1, rs, ro
    rf = system.record_fields(ro)
    tau, x, f, dte = rf["mesh_position"], rf["mesh_deflection_m"], rf["mesh_force_N"], rf["dynamic_transmission_error_m"]
    metrics = trace_metrics(system, x, f, dte, tau=tau, static_forces_N=fs, fc=rf["coast_force_N"],
                            cycles=nrec_cyc * per_p, coast_static_forces_N=fsc, xc=rf["coast_approach_m"])
    trace = {}
    if keep_trace:
        trace = dict(rf)
        trace["contact_state"] = contact_state(rf["mesh_force_N"], rf["coast_force_N"])
        trace["state"] = rs
    status = f"period-{period}" if converged else "cap"
    return SteadyStateResult(fm, converged, status, period * per_p if converged else 0, (cycles + nrec_cyc) * per_p,
                             nsp, s.copy(),
                             metrics, trace, mu_max, kicks)


def window_cycles(system: LumpedSystem, revolutions: int = 1) -> int:
    """Whole reference mesh cycles that cover ``revolutions`` revolutions of the system's slowest turning body."""
    slow = min(abs(g.speed_ratio) for g in system.gears.values() if abs(g.speed_ratio) > 1e-12)
    return int(math.ceil(revolutions * 2 * math.pi * system.zref_2pi / slow - 1e-9))


def _quasi_periodic_run(system: LumpedSystem, fm: float, s: np.ndarray, opt: SteadyStateOptions, fext: np.ndarray,
                        nsp: int, h: float, torque_Nm: float | None, keep_trace: bool):
    """The steady state of a system whose period exceeds ``opt.max_system_period`` (module docstring)."""
    n2 = 2 * system.n
    omega = system.reference_speed(fm)
    el = np.sort(system.natural_frequencies_Hz())
    f1 = float(el[el > 0][0]) if np.any(el > 0) else fm
    zeta = max(system.modal_damping_ratio, 1e-6)
    settle = int(math.ceil(math.log(1.0 / opt.rtol) / (zeta * 2 * math.pi * f1) * fm))
    win = window_cycles(system, opt.window_revolutions)
    dec = max(1, int(nsp // (32 * max(1.0, float(np.max(system.rates))))))
    while nsp % dec:
        dec -= 1
    kin = np.array([0.0, 0.0, omega])
    one_s, one_o = np.zeros((1, n2)), np.zeros((1, system.record_width))
    yield s, kin, settle * nsp, h, fext, settle * nsp, one_s, one_o
    if not np.all(np.isfinite(s)):
        raise ModelError(f"integration diverged at f_m = {fm:g} Hz (state not finite)")
    fs = system.nominal_forces_N(torque_Nm)
    fsc = system.nominal_coast_forces_N(torque_Nm)
    windows = []
    for _ in range(2):
        nr = win * nsp // dec
        rs, ro = np.zeros((nr, n2)), np.zeros((nr, system.record_width))
        yield s, kin, win * nsp, h, fext, dec, rs, ro
        if not np.all(np.isfinite(s)):
            raise ModelError(f"integration diverged at f_m = {fm:g} Hz (state not finite)")
        rf = system.record_fields(ro)
        metrics = trace_metrics(system, rf["mesh_deflection_m"], rf["mesh_force_N"],
                                rf["dynamic_transmission_error_m"], tau=rf["mesh_position"], static_forces_N=fs,
                                fc=rf["coast_force_N"], cycles=win, coast_static_forces_N=fsc,
                                xc=rf["coast_approach_m"], periodic=False)
        windows.append((metrics, rf, rs))
    (m1, _, _), (m2, rf, rs) = windows
    converged = True
    for name in METRIC_NAMES:
        a, b = np.asarray(m1[name], float), np.asarray(m2[name], float)
        ok = np.isfinite(a) & np.isfinite(b)
        top = np.maximum(np.abs(a), np.abs(b))
        if np.any(np.abs(a - b)[ok] > opt.window_rtol * top[ok] + 1e-300):
            converged = False
    trace = {}
    if keep_trace:
        trace = dict(rf)
        trace["contact_state"] = contact_state(rf["mesh_force_N"], rf["coast_force_N"])
        trace["state"] = rs
    return SteadyStateResult(fm, converged, "quasi-periodic" if converged else "cap", win, settle + 2 * win, nsp,
                             s.copy(), m2, trace)
