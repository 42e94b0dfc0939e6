"""Steady-state records of a gear system at constant speed, for order spectra: the dynamic transmission error,
mesh forces, bearing forces or root strains per sample, or the static transmission error of the same positions.

The constant-speed experiment (:class:`~hacgear_core.dynamics.simulator.Simulator`) starts from static equilibrium,
runs ``settle_cycles`` mesh cycles for the transient to decay, then records ``record_cycles`` mesh cycles at
``samples_per_cycle`` samples per cycle (a whole number, so the record is coherent with the mesh; with
``record_cycles`` a multiple of the common period of the shafts, :meth:`~hacgear_core.spectra.spectrum.OrderBasis.
common_period_cycles`, it is coherent with every shaft).  How far the record is from periodic is measured: the
largest change of the elastic state (the mesh deflections and translations) over the record, from its first
sample to one sample past its end, over the state's range in the record (``periodicity_error``; 0 for an exactly
periodic steady state whose period divides the record).

Quantities (:data:`QUANTITIES`), channel names and units:

``dte``
    Dynamic transmission error per mesh ``<mesh>`` [m] (the rotational part of the mesh deflection; equal to the
    deflection when no gear translates).
``force``
    Mesh force on the loaded (drive) flanks per mesh ``<mesh>`` [N].
``bearing_force``
    Force each gear puts on its bearing, fixed-frame components ``<gear>.x``, ``<gear>.y`` [N]
    (:meth:`~hacgear_core.dynamics.simulator.Simulator.bearing_force_N`; gears that do not turn are left out).
``root_strain``
    Root strain at every gauge on tooth 0 of its gear ``<gear>/<gauge>`` [-]: the tooth passes the mesh once per
    revolution of its gear (relative to the carrier in a planetary set), so the record holds shaft orders.
``ste``
    Static transmission error per mesh ``<mesh>`` [m]: the mesh deflection of the static equilibrium under the
    nominal torque (:func:`~hacgear_core.dynamics.equilibrium.static_equilibrium`) at the kinematic mesh positions
    of the samples (no speed, no transient).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.dynamics.simulator import Simulator, strain_of_tooth, system_gauges
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError
from hacgear_core.spectra.spectrum import order_basis, order_spectrum

__all__ = ["QUANTITIES", "UNITS", "SteadyRecord", "steady_record", "record_cycles_for", "system_spectra",
           "bearing_forces", "RUNUP_QUANTITIES", "RunUpRecord", "runup_record"]

#: quantities :func:`steady_record` records
QUANTITIES = ("dte", "force", "bearing_force", "root_strain", "ste")
#: unit of each quantity's channels
UNITS = {"dte": "m", "force": "N", "bearing_force": "N", "root_strain": "-", "ste": "m"}


@dataclass(frozen=True, eq=False)
class SteadyRecord:
    """A record of :func:`steady_record`: ``quantity``, ``unit``, ``channels`` {name: (nr,) samples},
    ``samples_per_cycle``, ``record_cycles``, ``settle_cycles``, ``mesh_frequency_Hz``, ``time_s`` (nr,) and
    ``periodicity_error`` [-] (see the module docstring; NaN for ``ste``, which has no transient)."""

    quantity: str
    unit: str
    channels: dict
    samples_per_cycle: int
    record_cycles: int
    settle_cycles: int
    mesh_frequency_Hz: float
    time_s: np.ndarray
    periodicity_error: float


def _elastic(system: LumpedSystem, state: np.ndarray) -> np.ndarray:
    """Mesh deflections and translations of states (nr, 2n) -> (nr, m + translations)."""
    q = state[:, :system.n]
    tr = [i for g in system.gears.values() for i in g.translations]
    return np.column_stack([q @ system.V.T, q[:, tr]]) if tr else q @ system.V.T


def bearing_forces(system: LumpedSystem, raw: dict, reference_speed_rad_s: float) -> dict:
    """Force [N] each turning gear puts on its bearing at every sample of a recorded run ``raw``
    (:meth:`~hacgear_core.dynamics.simulator.Simulator.run` at constant reference speed ``reference_speed_rad_s``
    [rad/s]), {gear: (nr, 2)} in the fixed frame: the rule of
    :meth:`~hacgear_core.dynamics.simulator.Simulator.bearing_force_N` (the system's bearing map, else its support
    springs, else the sum of its mesh forces; carrier-frame forces turned by the carrier's angle) over the record."""
    n = system.n
    q = raw["state"][:, :n]
    force = raw["mesh_force_N"]
    out = {}
    for g in system.gears.values():
        if g.rotation < 0 and not g.translations:
            continue
        fr = system.frame_ratio(g.name)
        wc = fr * float(reference_speed_rad_s)
        f = np.zeros((q.shape[0], 2))
        if g.name in system.bearing_maps:
            a, b, c = system.bearing_maps[g.name]
            f = q @ np.asarray(a).T + np.asarray(b) + wc ** 2 * np.asarray(c)
        elif g.translations:
            for i, d in zip(g.translations, g.directions):
                f += np.outer(g.support[0] * q[:, i], d)
        else:
            for k, c in enumerate(system.meshes):
                if g.name in (c.gear_a, c.gear_b):
                    f += np.outer((1.0 if g.name == c.gear_b else -1.0) * force[:, k],
                                  np.asarray(c.line_of_action, float))
        if fr != 0.0:
            # the reference gear's angle from the kinematic mesh position of mesh 0: tau = c + phase + W q
            cyc = raw["mesh_position"][:, 0] - system.phase[0] - q @ system.W[0]
            ang = fr * cyc / system.zref_2pi
            ca, sa = np.cos(ang), np.sin(ang)
            f = np.column_stack([ca * f[:, 0] - sa * f[:, 1], sa * f[:, 0] + ca * f[:, 1]])
        out[g.name] = f
    return out


def _channels(system: LumpedSystem, quantity: str, raw: dict) -> dict[str, np.ndarray]:
    """The recorded channels of ``quantity`` ("dte", "force" per mesh, else "root_strain" per gauge of tooth 0) in
    a simulator record ``raw``."""
    if quantity == "dte":
        return {c.name: raw["dynamic_transmission_error_m"][:, k] for k, c in enumerate(system.meshes)}
    if quantity == "force":
        return {c.name: raw["mesh_force_N"][:, k] for k, c in enumerate(system.meshes)}
    gauges = system_gauges(system)
    if not gauges:
        raise ModelError(f"the tables of {system.name} hold no strain gauges")
    return {g: strain_of_tooth(system, g, raw["mesh_position"], raw["mesh_deflection_m"], raw["coast_approach_m"],
                               raw.get("mesh_twist_rad")) for g in gauges}


def steady_record(system: LumpedSystem, mesh_frequency_Hz: float, quantity: str, record_cycles: int, *,
                  samples_per_cycle: int = 128, settle_cycles: int = 400) -> SteadyRecord:
    """Record ``quantity`` (:data:`QUANTITIES`) of ``system`` at constant mesh frequency ``mesh_frequency_Hz`` [Hz]
    over ``record_cycles`` mesh cycles after ``settle_cycles`` (see the module docstring)."""
    if quantity not in QUANTITIES:
        raise ModelError(f"quantity must be one of {QUANTITIES}, got {quantity!r}")
    for name, v, lo in (("record_cycles", record_cycles, 1), ("samples_per_cycle", samples_per_cycle, 8),
                        ("settle_cycles", settle_cycles, 0)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
            raise ModelError(f"{name} [-] must be an integer >= {lo}, got {v!r}")
    fm = float(mesh_frequency_Hz)
    if not (math.isfinite(fm) and fm > 0):
        raise ModelError(f"mesh_frequency_Hz [Hz] must be finite and > 0, got {mesh_frequency_Hz!r}")
    nr = int(record_cycles) * int(samples_per_cycle)
    dt = 1.0 / (fm * samples_per_cycle)
    if quantity == "ste":
        pos = np.arange(nr) / samples_per_cycle
        fext = system.fext_speed()
        chans = np.array([static_equilibrium(system, float(c), fext).mesh_deflections_m for c in pos])
        return SteadyRecord(quantity, UNITS[quantity], {c.name: chans[:, k] for k, c in enumerate(system.meshes)},
                            int(samples_per_cycle), int(record_cycles), 0, fm, pos / fm, math.nan)
    sim = Simulator(system)
    sim.set_speed_input(mesh_frequency_Hz=fm)
    for _ in range(int(settle_cycles)):
        r = sim.advance(1.0 / fm)
        if not r.success:
            raise ModelError(r.message)
    start = sim.s.copy()
    raw = sim.run(nr * dt, dt)                # samples at the end of each interval
    states = np.vstack([start, raw["state"]])
    t = raw["time_s"]
    if quantity == "bearing_force":
        channels = {f"{g}.{a}": f[:, i] for g, f in bearing_forces(system, raw, sim.kin[2]).items()
                    for i, a in enumerate("xy")}
    else:
        channels = _channels(system, quantity, raw)
    el = _elastic(system, states)             # the state at the record's start and after each sample
    span = np.max(np.ptp(el, axis=0))
    err = float(np.max(np.abs(el[-1] - el[0])) / span) if span > 0 else 0.0
    return SteadyRecord(quantity, UNITS[quantity], channels, int(samples_per_cycle), int(record_cycles),
                        int(settle_cycles), fm, np.asarray(t, float), err)


def record_cycles_for(system: LumpedSystem, periods: int = 1, max_record_cycles: int = 30000) -> int:
    """Mesh cycles of ``periods`` common periods of ``system``'s shafts
    (:meth:`~hacgear_core.spectra.spectrum.OrderBasis.common_period_cycles`; 1 mesh cycle when it has no shaft);
    :class:`ModelError` when that exceeds ``max_record_cycles`` or the shafts have no common period."""
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or periods < 1:
        raise ModelError(f"periods [-] must be an integer >= 1, got {periods!r}")
    period = order_basis(system).common_period_cycles()
    if period is None:
        raise ModelError(f"{system.name}: the shafts' order ratios have no common period; give the record length in "
                         "mesh cycles (the spectrum is then taken with the flat-top window)")
    cycles = period * periods
    if cycles.denominator != 1 or cycles > max_record_cycles:
        raise ModelError(f"{system.name}: {periods} common period(s) of the shafts = {float(cycles):g} mesh cycles "
                         + ("(not whole)" if cycles.denominator != 1 else f"> {max_record_cycles} (the limit)")
                         + "; give the record length in mesh cycles (the spectrum is then taken with the flat-top "
                         "window when it is shorter than the common period) or raise the limit")
    return int(cycles)


def system_spectra(system: LumpedSystem, mesh_frequency_Hz: float, quantity: str, *, record_cycles: int | None = None,
                   periods: int = 1, max_record_cycles: int = 30000, samples_per_cycle: int = 128,
                   settle_cycles: int = 400, harmonics: int = 5, sideband_orders: int = 3) -> tuple:
    """The steady-state record of ``quantity`` (:func:`steady_record`) over ``record_cycles`` mesh cycles (default:
    ``periods`` common periods, :func:`record_cycles_for`) and the order spectrum of each of its channels
    (:func:`~hacgear_core.spectra.spectrum.order_spectrum` with the system's :func:`order_basis`) ->
    (SteadyRecord, {channel: OrderSpectrum})."""
    if record_cycles is None:
        record_cycles = record_cycles_for(system, periods, max_record_cycles)
    rec = steady_record(system, mesh_frequency_Hz, quantity, record_cycles, samples_per_cycle=samples_per_cycle,
                        settle_cycles=settle_cycles)
    basis = order_basis(system)
    return rec, {ch: order_spectrum(x, rec.samples_per_cycle, basis, harmonics=harmonics,
                                    sideband_orders=sideband_orders, mesh_frequency_Hz=rec.mesh_frequency_Hz)
                 for ch, x in rec.channels.items()}


@dataclass(frozen=True, eq=False)
class RunUpRecord:
    """A record of :func:`runup_record`: ``quantity``, ``unit``, ``channels`` {name: (nr,) samples},
    ``samples_per_cycle``, ``mesh_frequency_Hz`` (nr,) the prescribed mesh frequency at each sample (constant over
    each mesh cycle), ``time_s`` (nr,)."""

    quantity: str
    unit: str
    channels: dict
    samples_per_cycle: int
    mesh_frequency_Hz: np.ndarray
    time_s: np.ndarray


#: quantities :func:`runup_record` records
RUNUP_QUANTITIES = ("dte", "force", "root_strain")


def runup_record(system: LumpedSystem, fm_start_Hz: float, fm_end_Hz: float, cycles: int, quantity: str, *,
                 samples_per_cycle: int = 64, settle_cycles: int = 200) -> RunUpRecord:
    """Record ``quantity`` (:data:`RUNUP_QUANTITIES`) over a linear run-up of the mesh frequency from
    ``fm_start_Hz`` to ``fm_end_Hz`` [Hz] in ``cycles`` mesh cycles, after ``settle_cycles`` at the start speed.
    The speed is prescribed and stepped once per mesh cycle (its value at the cycle's middle, as ``hacgear
    simulate --fm-end``), and each cycle is sampled ``samples_per_cycle`` times at equal intervals, so the samples
    are equally spaced in the reference gear's angle (computed order tracking: the record's frequencies are mesh
    orders at every speed)."""
    if quantity not in RUNUP_QUANTITIES:
        raise ModelError(f"run-up quantity must be one of {RUNUP_QUANTITIES}, got {quantity!r}")
    for name, v, lo in (("cycles", cycles, 1), ("samples_per_cycle", samples_per_cycle, 8),
                        ("settle_cycles", settle_cycles, 0)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
            raise ModelError(f"{name} [-] must be an integer >= {lo}, got {v!r}")
    f0, f1 = float(fm_start_Hz), float(fm_end_Hz)
    if not (math.isfinite(f0) and math.isfinite(f1) and f0 > 0 and f1 > 0):
        raise ModelError(f"mesh frequencies [Hz] must be finite and > 0, got {fm_start_Hz!r}, {fm_end_Hz!r}")
    sim = Simulator(system)
    sim.set_speed_input(mesh_frequency_Hz=f0)
    for _ in range(int(settle_cycles)):
        r = sim.advance(1.0 / f0)
        if not r.success:
            raise ModelError(r.message)
    chunks, fms = [], []
    for c in range(int(cycles)):
        fm = f0 + (f1 - f0) * (c + 0.5) / cycles
        sim.set_speed_input(mesh_frequency_Hz=fm)
        chunks.append(sim.run(1.0 / fm, 1.0 / (fm * samples_per_cycle)))
        fms.append(np.full(samples_per_cycle, fm))
    raw = {k: np.concatenate([ch[k] for ch in chunks]) for k in chunks[0] if k != "state"}
    channels = _channels(system, quantity, raw)
    return RunUpRecord(quantity, UNITS[quantity], channels, int(samples_per_cycle), np.concatenate(fms),
                       raw["time_s"])
