"""Steady-state response at one mesh frequency: detected, not assumed.

Policy.  The constant-speed model is integrated in whole mesh cycles (``N`` RK4 steps per cycle, a
power of two >= 128, more when the highest natural frequency needs it) and the *elastic* part of the
state is sampled once per mesh cycle (Poincaré section at integer mesh position): mesh deflection
``x`` and its rate, and the translations ``y_i`` and their rates (the rigid-body rotation is left
out; it is a neutral direction).  Each sample is scaled by the mean static deflection (positions)
and by ``2 pi f_m`` times that (rates).  A period-``n`` orbit (``n = 1..max_period``) is accepted
when the scaled infinity-norm of ``p_k - p_{k-n}`` is below ``rtol`` for the last ``2n + 1``
consecutive cycles (smallest ``n`` wins), after at least ``min_cycles``; for ``n > 1`` the orbit
must also differ from a period-1 orbit (lag-1 differences >= 100 ``rtol``), since a decaying
transient whose phase turns by about ``2 pi m / n`` per cycle passes the lag-``n`` test early.  Otherwise integration stops
at ``max_cycles`` and the result says so (``converged = False``, ``status = "cap"``); its metrics
then come from the last 4 cycles.

Metrics over the final period (``n`` cycles, every step): mean and RMS of the oscillating part of
the mesh deflection, dynamic transmission error ``r_b1 th1 + r_b2 th2`` (mean, RMS, peak-to-peak),
peak and minimum mesh force, fraction of the period with contact loss (mesh force 0), force dynamic
factor ``max F / F_s`` and, when the table has strains, the strain dynamic factor per gauge
(:func:`hacgear_core.post.strain_dynamic_factor`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hacgear_core.dynamics.spur import SpurPairSystem
from hacgear_core.errors import ModelError

__all__ = ["SteadyStateOptions", "SteadyStateResult", "steady_state", "METRIC_NAMES", "trace_metrics"]

METRIC_NAMES = (
    "mean_deflection_m",
    "rms_deflection_m",
    "dte_mean_m",
    "dte_rms_m",
    "dte_peak_to_peak_m",
    "peak_force_N",
    "min_force_N",
    "contact_loss_fraction",
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

    def __post_init__(self) -> None:
        if not (0 < self.rtol < 1):
            raise ModelError(f"rtol [-] must be in (0, 1), got {self.rtol}")
        if not (1 <= self.min_cycles <= self.max_cycles):
            raise ModelError(f"need 1 <= min_cycles <= max_cycles, got {self.min_cycles}, {self.max_cycles}")
        if not 1 <= self.max_period <= 16:
            raise ModelError(f"max_period [cycles] must be in [1, 16], got {self.max_period}")
        if self.chunk_cycles < 1 or self.min_steps_per_cycle < 8:
            raise ModelError("chunk_cycles must be >= 1 and min_steps_per_cycle >= 8")


@dataclass
class SteadyStateResult:
    """Steady state at one mesh frequency.  ``state`` (2n,) is the state at the end of the recorded
    period (a cycle boundary, mesh position 0): the start of the next speed of a sweep."""

    mesh_frequency_Hz: float
    converged: bool
    status: str
    period_cycles: int
    cycles_run: int
    steps_per_cycle: int
    state: np.ndarray
    metrics: dict
    trace: dict = field(default_factory=dict)


def _projection(system: SpurPairSystem) -> np.ndarray:
    n = system.n
    rows = [np.concatenate([system.v, np.zeros(n)]), np.concatenate([np.zeros(n), system.v])]
    for nm in ("y1", "y2"):
        if nm in system.dof_names:
            i = system.dof_names.index(nm)
            for off in (0, n):
                r = np.zeros(2 * n)
                r[off + i] = 1.0
                rows.append(r)
    return np.array(rows)


def trace_metrics(system: SpurPairSystem, x, f, dte, tau=None, static_force_N=None) -> dict:
    """Steady-state metrics (:data:`METRIC_NAMES`) of one recorded period."""
    x, f, dte = np.asarray(x), np.asarray(f), np.asarray(dte)
    fs = system.params.static_force_N if static_force_N is None else static_force_N
    m = {
        "mean_deflection_m": float(np.mean(x)),
        "rms_deflection_m": float(np.sqrt(np.mean((x - np.mean(x)) ** 2))),
        "dte_mean_m": float(np.mean(dte)),
        "dte_rms_m": float(np.sqrt(np.mean((dte - np.mean(dte)) ** 2))),
        "dte_peak_to_peak_m": float(np.ptp(dte)),
        "peak_force_N": float(np.max(f)),
        "min_force_N": float(np.min(f)),
        "contact_loss_fraction": float(np.mean(f <= 0.0)),
        "dynamic_factor_force": float(np.max(f) / fs),
        "dynamic_factor_strain": math.nan,
    }
    strain = getattr(system.table, "strain", None)
    if tau is not None and strain:
        from hacgear_core.post import strain_dynamic_factor

        dfs = strain_dynamic_factor(system.table, tau, x, fs, system.cached("static_strain_max", fs))
        if dfs:
            m["dynamic_factor_strain"] = float(max(dfs.values()))
    return m


def steady_state(system: SpurPairSystem, mesh_frequency_Hz: float, state0: np.ndarray | None = None,
                 options: SteadyStateOptions | None = None, *, torque_Nm: float | None = None,
                 keep_trace: bool = False) -> SteadyStateResult:
    """Integrate the constant-speed model at ``mesh_frequency_Hz`` [Hz] until a periodic steady
    state is detected (or the cycle cap is hit).

    Parameters
    ----------
    system : SpurPairSystem
    mesh_frequency_Hz : float
        Mesh frequency f_m = z1 Omega_1 / (2 pi) [Hz], > 0.
    state0 : (2n,) array, optional
        Start state at mesh position 0 (default: static equilibrium).
    options : SteadyStateOptions
    torque_Nm : float, optional
        Torque on gear 1 [N m] (default: the parameters' nominal torque).
    keep_trace : bool
        Return the final period's time histories in ``trace``.
    """
    fm = float(mesh_frequency_Hz)
    if not (math.isfinite(fm) and fm > 0):
        raise ModelError(f"mesh frequency [Hz] must be finite and > 0, got {mesh_frequency_Hz!r}")
    opt = options or SteadyStateOptions()
    n2 = 2 * system.n
    s = (system.static_state(0.0, torque_Nm) if state0 is None else np.array(state0, dtype=float))
    if s.shape != (n2,):
        raise ModelError(f"state0 must have shape ({n2},), got {s.shape}")
    fext = system.fext_speed(torque_Nm)
    nsp = system.steps_per_cycle(fm, minimum=opt.min_steps_per_cycle)
    h = 1.0 / (fm * nsp)
    omega = fm / system.z1_2pi
    fs = (system.params.torque_Nm if torque_Nm is None else torque_Nm) / system.rb[0]
    xs = max(abs(system.cached("deflection_at_0", fs)), 1e-7)
    scale = np.ones(len(_projection(system)))
    scale[1::2] = 2 * math.pi * fm  # rates
    proj = _projection(system) / (xs * scale[:, None])
    hist = np.empty((opt.max_cycles + 1, proj.shape[0]))
    hist[0] = proj @ s
    kin = np.zeros(3)
    rec_s = np.zeros((opt.chunk_cycles, n2))
    rec_o = np.zeros((opt.chunk_cycles, 5))
    cycles = 0
    period = 0
    while cycles < opt.max_cycles and period == 0:
        nc = min(opt.chunk_cycles, opt.max_cycles - cycles)
        kin[:] = (0.0, 0.0, omega)
        system.integrate(s, kin, nc * nsp, h, fext, rec_every=nsp, rec_state=rec_s, rec_out=rec_o)
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
                    # a decaying transient whose phase turns by ~2 pi m / per each cycle also passes
                    # the lag-per test: accept a period-per orbit only if it is distinct from period 1
                    d1 = np.abs(hist[cycles - per + 1: cycles + 1] - hist[cycles - per: cycles])
                    if np.max(d1) < 100 * opt.rtol:
                        continue
                period = per
                break
    converged = period > 0
    nrec_cyc = period if converged else 4
    nrec = nrec_cyc * nsp
    rs = np.zeros((nrec, n2))
    ro = np.zeros((nrec, 5))
    kin[:] = (0.0, 0.0, omega)
    system.integrate(s, kin, nrec, h, fext, rec_every=1, rec_state=rs, rec_out=ro)
    metrics = trace_metrics(system, ro[:, 1], ro[:, 2], ro[:, 3], tau=ro[:, 0], static_force_N=fs)
    trace = {}
    if keep_trace:
        trace = {"time_s": ro[:, 4], "mesh_position": ro[:, 0], "mesh_deflection_m": ro[:, 1],
                 "mesh_force_N": ro[:, 2], "dynamic_transmission_error_m": ro[:, 3], "state": rs}
    status = f"period-{period}" if converged else "cap"
    return SteadyStateResult(fm, converged, status, period if converged else 0, cycles + nrec_cyc, nsp,
                             s.copy(), metrics, trace)
