"""Time-stepping simulator of any lumped gear system: the object the library, the CLI and every FMU step.

Two experiments (:class:`~hacgear_core.encodings.Experiment`, attribute ``mode``):

* ``Experiment.SPEED`` (constant-speed experiment): :meth:`Simulator.set_speed_input` sets the reference gear's speed,
  :meth:`Simulator.set_torque_set_point` the torque on the input gear; the deviations are integrated around
  the imposed rotation (dissertation Eqs. 3.1, 4.1);
* ``Experiment.TORQUE`` (drivetrain coupling): :meth:`Simulator.set_torque_inputs` sets shaft torques on the port gears
  (the gears that carry external torque: input and output gears); absolute angles and speeds follow from the
  dynamics.  Needs a train that turns freely (no rotational supports: the drivetrain model owns the shafts).

Signs of the outputs: angles, speeds and shaft torques of a gear are positive in that gear's operating sense of
rotation (a braking load torque is negative); mesh forces and deflections positive when the loaded flanks are
pressed together.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.encodings import Experiment, contact_state, contact_state_of
from hacgear_core.errors import ModelError, SolverError
from hacgear_core.response import dynamic_contact_pressure

__all__ = ["GaugePassage", "PASSAGE_MARGIN_CYCLES", "Simulator", "StepResult", "gauge_passage", "passage_cycles",
           "passage_window", "static_gauge_passage", "strain_of_tooth", "system_gauges"]


@dataclass(frozen=True)
class StepResult:
    """Outcome of :meth:`Simulator.advance`: ``success``, ``message`` (why not), ``n_substeps``."""

    success: bool
    message: str
    n_substeps: int


def _pair_phase(tau: np.ndarray, passage: int, z: int) -> np.ndarray:
    """Pair phase of the tooth of a gear with ``z`` teeth that is at the pitch point at mesh position ``passage``,
    at unwrapped mesh position ``tau``: 0 at its pitch-point passage, wrapped into [-z/2, z/2) (the tooth is back
    in mesh every z mesh cycles)."""
    return ((np.asarray(tau, float) - passage + 0.5 * z) % z) - 0.5 * z


def _gauge_gear(system: LumpedSystem, gauge: str, tooth: int = 0) -> tuple[str, str, int]:
    """(gear, gauge name, teeth) of ``gauge`` = ``"<gear>/<gauge>"``; checks the gear and the tooth index."""
    gear, _, gname = gauge.partition("/")
    if gear not in system.gears:
        raise ModelError(f"gauge {gauge!r}: no gear {gear!r} in {system.name}; gears: {sorted(system.gears)}")
    z = system.gears[gear].teeth
    if isinstance(tooth, bool) or not isinstance(tooth, (int, np.integer)) or not 0 <= tooth < z:
        raise ModelError(f"tooth index of gauge {gauge!r} must be an integer in [0, {z - 1}] (gear {gear!r} has "
                         f"{z} teeth), got {tooth!r}")
    return gear, gname, z


def strain_of_tooth(system: LumpedSystem, gauge: str, tau: np.ndarray, x: np.ndarray,
                    xc: np.ndarray | None = None, twist: np.ndarray | None = None, tooth: int = 0) -> np.ndarray:
    """Root strain [-] at ``gauge`` (``"<gear>/<gauge>"``) on tooth ``tooth`` of its gear along a trajectory: the
    sum over every mesh of that gear of its strain-deflection functions at the tooth's pair phase — the drive
    side's at the mesh deflection and, where the table has one, the coast side's at the coast approach (its pair
    ``phase - pair_shift[gear]``, docs/tables.md "The coast side").  An idler's tooth is loaded on one flank by one
    mesh and on the other by the next; any tooth is loaded on its other flank across the backlash.

    ``tau``, ``x``, ``xc``: (nr, m) unwrapped mesh positions [cycles], deflections [m] and coast approaches [m] of
    all meshes (``xc`` None: the drive sides only).  ``twist`` (nr, m) [rad]: mesh twists of helical meshes, whose
    strains are then read at (pair phase, deflection, twist) (:meth:`~hacgear_core.tables.MeshTable.sdf_twist`;
    None: at zero twist).  ``tooth`` in [0, z): teeth are counted in the order they reach the mesh, so tooth ``j``
    is at the pitch point of mesh ``k`` at mesh position ``tooth_passage[gear] + j`` (mod z) of that mesh, j mesh
    cycles after tooth 0 (the same physical tooth in every mesh of the gear: all mesh positions advance together).
    """
    gear, gname, z = _gauge_gear(system, gauge, tooth)
    tau = np.atleast_2d(np.asarray(tau, float))
    x = np.atleast_2d(np.asarray(x, float))
    xc = None if xc is None else np.atleast_2d(np.asarray(xc, float))
    total = np.zeros(tau.shape[0])
    found = False
    for k, c in enumerate(system.meshes):
        if gear not in (c.gear_a, c.gear_b):
            continue
        strain = getattr(c.table, "strain", None) or {}
        key = f"{c.gear_alias.get(gear, gear)}/{gname}"   # a planet instance's gauge is the table's planet gauge
        if key not in strain:
            continue
        found = True
        phase = _pair_phase(tau[:, k], c.tooth_passage.get(gear, 0) + int(tooth), z)
        tw = getattr(c.table, "twist", None)
        if c.t is not None and tw is not None and key in tw.strain:
            g = np.zeros(tau.shape[0]) if twist is None else np.atleast_2d(np.asarray(twist, float))[:, k]
            total = total + c.table.sdf_twist(key, phase, x[:, k], g)
            continue
        total = total + c.table.sdf(key, phase, x[:, k])
        coast = c.coast_table
        if coast is not None and xc is not None and key in (getattr(coast, "strain", None) or {}):
            shift = coast.pair_shift.get(c.gear_alias.get(gear, gear), 0)
            total = total + coast.sdf(key, phase - shift, xc[:, k])
    if not found:
        raise ModelError(f"no strain gauge {gauge!r} in the tables of {system.name}; gauges: {system_gauges(system)}")
    return total


def system_gauges(system: LumpedSystem) -> tuple[str, ...]:
    """Every strain gauge of a system as ``"<gear>/<gauge>"`` (a table gauge of a planet appears once per planet
    instance), sorted."""
    out = set()
    for c in system.meshes:
        inv: dict[str, list[str]] = {}
        for g in (c.gear_a, c.gear_b):
            inv.setdefault(c.gear_alias.get(g, g), []).append(g)
        for key in (getattr(c.table, "strain", None) or {}):
            tg, _, gname = key.partition("/")
            for g in inv.get(tg, [tg] if tg in system.gears else []):
                out.add(f"{g}/{gname}")
    return tuple(sorted(out))


#: margin [mesh cycles] kept between a tooth's passage and the ends of a record: the recorded mesh positions carry
#: the vibration (``W q``, thousandths of a cycle) on top of the kinematic mesh position
PASSAGE_MARGIN_CYCLES = 0.05


def _pair_window(table) -> tuple[float, float]:
    """The pair phases [mesh cycles] ``[-max offset, 1 - min offset)`` over which a table holds a tooth's
    per-pair quantities (:func:`~hacgear_core.tables.interp.pair_rows`); 0 outside."""
    offs = np.asarray(table.tooth_offsets, dtype=int)
    return -float(offs.max()), 1.0 - float(offs.min())


def _gauge_mesh(system: LumpedSystem, gear: str) -> int:
    """The mesh whose kinematic position counts the passages of ``gear``'s teeth: the reference mesh (0) where every
    mesh runs at the reference rate, else the gear's first mesh (its meshes all run at one rate: its speed times
    its teeth)."""
    if system.unit_rates:
        return 0
    return next(k for k, c in enumerate(system.meshes) if gear in (c.gear_a, c.gear_b))


def passage_window(system: LumpedSystem, gauge: str) -> tuple[float, float]:
    """Where tooth 0 of the gear of ``gauge`` passes through its meshes: ``(start, length)`` [mesh cycles] of the
    shortest stretch of the kinematic mesh position ``c`` (mesh k is at ``c + phase[k]``) that holds every pair
    phase of that tooth at which a table of the gauge holds strain (each table's pair window, the coast side's
    moved by its pair shift), ``start`` in [0, z).  Tooth ``j`` passes over the same stretch ``j`` cycles later
    (mod z, :func:`strain_of_tooth`); outside it the tooth's root strain is 0.  A gear in several meshes (an
    idler, a sun) spans all of them: its tooth passes one after the other.  In a train whose meshes run at their own
    rates, ``c`` is the kinematic position of the gear's first mesh (:func:`_gauge_mesh`): mesh k of the gear is at
    ``c + phase[k]``, the meshes of one gear sharing its rate."""
    gear, gname, z = _gauge_gear(system, gauge)
    arcs = []
    for k, c in enumerate(system.meshes):
        if gear not in (c.gear_a, c.gear_b):
            continue
        key = f"{c.gear_alias.get(gear, gear)}/{gname}"
        if key not in (getattr(c.table, "strain", None) or {}):
            continue
        base = c.tooth_passage.get(gear, 0) - float(system.phase[k])
        lo, hi = _pair_window(c.table)
        arcs.append((base + lo, hi - lo))
        tw = getattr(c.table, "twist", None)
        coast = c.coast_table
        if (not (c.t is not None and tw is not None and key in tw.strain) and coast is not None
                and key in (getattr(coast, "strain", None) or {})):
            shift = coast.pair_shift.get(c.gear_alias.get(gear, gear), 0)
            lo, hi = _pair_window(coast)
            arcs.append((base + lo + shift, hi - lo))
    if not arcs:
        raise ModelError(f"no strain gauge {gauge!r} in the tables of {system.name}; gauges: {system_gauges(system)}")
    # the shortest covering stretch of arcs on a circle of z cycles starts where one of them starts
    best = min(((s0 % z, max((s - s0) % z + n for s, n in arcs)) for s0, _ in arcs), key=lambda a: a[1])
    return best[0], min(best[1], float(z))


def passage_cycles(system: LumpedSystem, gauge: str) -> int:
    """Reference mesh cycles a record must span to hold one whole tooth passage at ``gauge``
    (:func:`passage_window`), with :data:`PASSAGE_MARGIN_CYCLES` at both ends, wherever the record starts."""
    span = passage_window(system, gauge)[1] + 2 * PASSAGE_MARGIN_CYCLES
    if system.unit_rates:
        return int(math.ceil(span)) + 1
    # in the gear's mesh cycles: the span and one cycle for where the record starts, over the mesh's rate
    rate = float(system.rates[_gauge_mesh(system, _gauge_gear(system, gauge)[0])])
    return int(math.ceil((span + 1.0) / rate))


@dataclass(frozen=True, eq=False)
class GaugePassage:
    """Root strain at one gauge over one tooth's whole passage through the meshes of its gear.

    Attributes
    ----------
    gauge : str
        ``"<gear>/<gauge>"``.
    tooth : int
        Index of the tooth in [0, z), counted in the order the teeth reach the mesh (:func:`strain_of_tooth`).
    cycles : tuple of float
        (first, last) kinematic mesh position [mesh cycles since the start] of the passage.
    time_s : tuple of float or None
        (first, last) time [s] of its samples; None for a static passage.
    strain : numpy.ndarray
        (n,) root strain [-] at the samples, in order.
    """

    gauge: str
    tooth: int
    cycles: tuple[float, float]
    time_s: tuple[float, float] | None
    strain: np.ndarray

    def __post_init__(self) -> None:
        a = np.asarray(self.strain, dtype=float)
        if a.ndim != 1 or a.size < 2 or not np.all(np.isfinite(a)):
            raise ModelError(f"passage strain of {self.gauge!r} must be a finite 1-D array of >= 2 samples [-]")
        if not (isinstance(self.tooth, (int, np.integer)) and self.tooth >= 0):
            raise ModelError(f"passage tooth index of {self.gauge!r} must be an integer >= 0, got {self.tooth!r}")
        if not self.cycles[1] > self.cycles[0]:
            raise ModelError(f"passage of {self.gauge!r}: cycles [mesh cycles] must increase, got {self.cycles}")
        object.__setattr__(self, "strain", a)
        object.__setattr__(self, "tooth", int(self.tooth))

    @property
    def max_strain(self) -> float:
        """Largest (most tensile) strain of the passage [-]."""
        return float(self.strain.max())

    @property
    def min_strain(self) -> float:
        """Smallest (most compressive) strain of the passage [-]."""
        return float(self.strain.min())

    @property
    def extreme(self) -> float:
        """Strain of largest magnitude of the passage, with its sign [-]."""
        return float(self.strain[np.argmax(np.abs(self.strain))])

    def factor_over(self, static: "GaugePassage") -> float:
        """Dynamic factor of the strain [-]: this passage's peak on the side (tension or compression) of the
        ``static`` passage's extreme, over that extreme; NaN when the static passage is all zero."""
        e = static.extreme
        if e == 0.0:
            return math.nan
        return (self.max_strain if e > 0 else self.min_strain) / e


def gauge_passage(system: LumpedSystem, gauge: str, trace: Mapping[str, np.ndarray]) -> GaugePassage | None:
    """Root strain at ``gauge`` over the last whole tooth passage in a recorded ``trace`` (the dict of
    :meth:`Simulator.run`, or several concatenated: ``time_s`` (nr,), ``mesh_position``, ``mesh_deflection_m``,
    ``coast_approach_m`` and for helical meshes ``mesh_twist_rad`` (nr, m)), following the tooth that passes
    then; None when the trace holds no whole passage (it must span :func:`passage_cycles` mesh cycles)."""
    start, length = passage_window(system, gauge)
    z = system.gears[_gauge_gear(system, gauge)[0]].teeth
    tau = np.atleast_2d(np.asarray(trace["mesh_position"], float))
    j = _gauge_mesh(system, _gauge_gear(system, gauge)[0])
    c = tau[:, j] - float(system.phase[j])
    n = math.floor(c[-1] - PASSAGE_MARGIN_CYCLES - length - start)
    a = start + n
    if a < c[0] + PASSAGE_MARGIN_CYCLES:
        return None
    sel = (c >= a) & (c <= a + length)
    if np.count_nonzero(sel) < 2:
        return None
    tooth = int(n % z)
    tw = trace.get("mesh_twist_rad")
    xc = trace.get("coast_approach_m")
    eps = strain_of_tooth(system, gauge, tau[sel], np.atleast_2d(np.asarray(trace["mesh_deflection_m"], float))[sel],
                          None if xc is None else np.atleast_2d(np.asarray(xc, float))[sel],
                          None if tw is None else np.atleast_2d(np.asarray(tw, float))[sel], tooth=tooth)
    t = np.asarray(trace["time_s"], float)[sel]
    return GaugePassage(gauge, tooth, (float(a), float(a + length)), (float(t[0]), float(t[-1])), eps)


def static_gauge_passage(system: LumpedSystem, gauge: str, samples_per_cycle: int = 64) -> GaugePassage:
    """Root strain at ``gauge`` over tooth 0's passage (:func:`passage_window`) with the system in static
    equilibrium at every mesh position under the constant-speed experiment's loads at the nominal torque
    (:func:`~hacgear_core.dynamics.equilibrium.static_equilibrium`, ``samples_per_cycle`` positions per mesh
    cycle; the equilibrium repeats every mesh cycle where every mesh runs at the reference rate, else each sample
    has its own).  Every tooth passes the same way."""
    if isinstance(samples_per_cycle, bool) or not isinstance(samples_per_cycle, (int, np.integer)) \
            or samples_per_cycle < 8:
        raise ModelError(f"samples_per_cycle [-] must be an integer >= 8, got {samples_per_cycle!r}")
    start, length = passage_window(system, gauge)
    npts = int(math.ceil(length * samples_per_cycle)) + 1
    cs = start + np.arange(npts) / samples_per_cycle
    # the reference position of each sample (cs counts the gear's own mesh cycles)
    ref = cs / float(system.rates[_gauge_mesh(system, _gauge_gear(system, gauge)[0])])
    if system.unit_rates:   # the equilibrium repeats every mesh cycle: one per sample position of a cycle
        one = [static_equilibrium(system, start + i / samples_per_cycle) for i in range(samples_per_cycle)]
        eq = [one[i] for i in np.arange(npts) % samples_per_cycle]
    else:                   # the other meshes' positions differ from cycle to cycle: each sample its own
        eq = [static_equilibrium(system, float(c)) for c in ref]
    q = np.array([e.q for e in eq])
    tau = system.unwrapped_positions(ref) + system.phase[None, :] + q @ system.W.T
    x = np.array([e.mesh_deflections_m for e in eq])
    xc = None if eq[0].coast_approach_m is None else np.array([e.coast_approach_m for e in eq])
    tw = None if eq[0].twist_rad is None else np.array([e.twist_rad for e in eq])
    eps = strain_of_tooth(system, gauge, tau, x, xc if tw is None else None, tw)
    return GaugePassage(gauge, 0, (float(cs[0]), float(cs[-1])), None, eps)


class Simulator:
    """Time-stepping simulator of a :class:`~hacgear_core.dynamics.system.LumpedSystem`.

    Parameters
    ----------
    system : LumpedSystem
    internal_step_s : float, optional
        Largest internal RK4 step [s]; default: mesh period / 128 at the current speed and 1/32 of the period of
        the highest natural frequency.
    """

    def __init__(self, system: LumpedSystem, internal_step_s: float | None = None) -> None:
        if internal_step_s is not None and not (math.isfinite(internal_step_s) and internal_step_s > 0):
            raise ModelError(f"internal_step_s [s] must be > 0 and finite, got {internal_step_s!r}")
        self.system = system
        self.internal_step_s = internal_step_s
        n, m = system.n, system.m
        self.s = np.zeros(2 * n)
        # kinematics, then per kernel mesh the steps beyond its tables (kernels docstring)
        self.kin = np.zeros(3 + system.m_kernel)
        self._rec_s = np.zeros((1, 2 * n))
        self._rec_o = np.zeros((1, system.record_width))
        self.gear_names = tuple(system.gears)
        self._backlash = [float(b) if math.isfinite(b) else 0.0 for b in system.backlash_m]
        self._gears = tuple(system.gears[g] for g in self.gear_names)
        fe = system.fext_speed()
        self.ports = tuple(g.name for g in self._gears if g.rotation >= 0 and abs(fe[g.rotation]) > 1e-9 * np.max(np.abs(fe)))
        self.reset()

    # ------------------------------------------------------------------ inputs
    def reset(self, speed_rad_s: float = 0.0) -> None:
        """Static equilibrium at the nominal torque, first mesh at position 0, speed mode at ``speed_rad_s``."""
        sy = self.system
        self.mode = Experiment.SPEED
        self.torque_Nm = sy.torque_Nm
        self.fext = sy.fext_speed(self.torque_Nm)
        self.port_torques_Nm = {g: sy.gears[g].sense * self.fext[sy.gears[g].rotation] for g in self.ports}
        self.kin[:] = 0.0
        self.kin[2] = float(speed_rad_s)
        self.s[:sy.n] = static_equilibrium(sy, 0.0, self.fext).q
        self.s[sy.n:] = 0.0
        self.time_s = 0.0
        self._update_outputs()

    def set_speed_input(self, speed_rad_s: float | None = None, mesh_frequency_Hz: float | None = None) -> None:
        """Constant-speed experiment: the reference gear's speed [rad/s] (in its sense) or the mesh frequency [Hz]."""
        if (speed_rad_s is None) == (mesh_frequency_Hz is None):
            raise ModelError("give exactly one of speed_rad_s [rad/s] or mesh_frequency_Hz [Hz]")
        if mesh_frequency_Hz is not None:
            speed_rad_s = self.system.reference_speed(mesh_frequency_Hz)
        speed_rad_s = float(speed_rad_s)
        if not math.isfinite(speed_rad_s):
            raise ModelError(f"speed [rad/s] must be finite, got {speed_rad_s!r}")
        if self.mode != Experiment.SPEED:
            self.mode = Experiment.SPEED
            self.fext = self.system.fext_speed(self.torque_Nm)
        self.kin[2] = speed_rad_s

    def set_torque_set_point(self, torque_Nm: float) -> None:
        """Constant-speed experiment: torque on the input gear [N m] (nonzero; the others carry theirs by the torque
        flow; negative: the coast flanks carry it, which needs coast tables)."""
        torque_Nm = float(torque_Nm)
        if not (math.isfinite(torque_Nm) and torque_Nm != 0):
            raise ModelError(f"torque [N*m] must be finite and nonzero, got {torque_Nm!r}")
        if torque_Nm < 0 and not all(c.coast_table is not None for c in self.system.meshes):
            raise ModelError(f"torque {torque_Nm} N*m loads the coast flanks, but the tables of {self.system.name} "
                             "are drive-only (regenerate them: hacgear statics)")
        self.torque_Nm = torque_Nm
        if self.mode == Experiment.SPEED:
            self.fext = self.system.fext_speed(torque_Nm)

    def set_torque_inputs(self, torques_Nm: Mapping[str, float]) -> None:
        """Drivetrain coupling: shaft torques [N m] {port gear: T}, each positive in that gear's sense of rotation
        (a load is negative); ports not named get 0.  Switches to torque mode."""
        sy = self.system
        if sy.rigid_mode is None:
            raise ModelError(f"{sy.name}: torque inputs need a train that turns freely (rotational support "
                             "stiffness 0 on every gear): in drivetrain coupling the shafts belong to the "
                             "drivetrain model; build the system with shafts=False")
        tq = {}
        for g, t in torques_Nm.items():
            if g not in self.ports:
                raise ModelError(f"torque input on {g!r}: not a port gear of {sy.name}; ports: {self.ports}")
            t = float(t)
            if not math.isfinite(t):
                raise ModelError(f"shaft torque on {g!r} [N*m] must be finite, got {t!r}")
            tq[g] = t
        if self.mode != Experiment.TORQUE:
            self.mode = Experiment.TORQUE
            # move any rigid-body deviation into the reference: the reference gear's deviation -> 0
            n = sy.n
            a, b = self.s[sy.iref], self.s[n + sy.iref]
            self.s[:n] -= a * sy.rigid_mode
            self.s[n:] -= b * sy.rigid_mode
            self.kin[0] += sy.sref * sy.zref_2pi * a
            self.kin[2] += sy.sref * b
            while self.kin[0] >= 1.0:
                self.kin[0] -= 1.0
                self.kin[1] += 1.0
            while self.kin[0] < 0.0:
                self.kin[0] += 1.0
                self.kin[1] -= 1.0
        self.port_torques_Nm = {g: tq.get(g, 0.0) for g in self.ports}
        self.fext = sy.fext_torque(self.port_torques_Nm)

    # ------------------------------------------------------------------ stepping
    @property
    def current_internal_step_s(self) -> float:
        """The largest RK4 sub-step [s] :meth:`advance` would use now (depends on the speed)."""
        return self._internal_step()

    def _internal_step(self) -> float:
        sy = self.system
        h = 1.0 / (32.0 * sy.max_frequency_Hz)
        fm = (abs(self.kin[2]) + abs(self.s[sy.n + sy.iref])) * sy.zref_2pi
        if fm > 0:
            h = min(h, 1.0 / (128.0 * fm))
        if self.internal_step_s is not None:
            h = min(h, self.internal_step_s)
        return h

    def advance(self, dt: float) -> StepResult:
        """Advance by ``dt`` [s] (any size > 0) with equal RK4 sub-steps no larger than the internal step.  On
        failure (non-finite state) the state is left unchanged and ``success`` is False."""
        try:
            dt = float(dt)
        except (TypeError, ValueError):
            return StepResult(False, f"step size dt [s] must be a number, got {dt!r}", 0)
        if not (math.isfinite(dt) and dt > 0):
            return StepResult(False, f"step size dt [s] must be finite and > 0, got {dt!r}", 0)
        nsub = max(1, int(math.ceil(dt / self._internal_step() - 1e-9)))
        s, kin = self.s, self.kin
        s0, k0 = s.copy(), kin.copy()
        self.system.integrate(s, kin, nsub, dt / nsub, self.fext, mode=int(self.mode), rec_every=nsub,
                              rec_state=self._rec_s, rec_out=self._rec_o)
        st, kt = s.tolist(), kin.tolist()
        isf = math.isfinite
        if not (all(map(isf, st)) and all(map(isf, kt))):
            s[:], kin[:] = s0, k0
            return StepResult(False, f"integration diverged within dt = {dt:g} s (state not finite); state restored",
                              nsub)
        self.time_s += dt
        self._set_outputs(st, kt, self._rec_o[0].tolist())
        return StepResult(True, "", nsub)

    def run(self, duration_s: float, record_dt_s: float) -> dict:
        """Integrate ``duration_s`` [s] recording every ``record_dt_s`` [s].

        Returns
        -------
        dict
            ``time_s`` (nr,); per mesh (nr, m): ``mesh_position`` (unwrapped) [cycles], ``mesh_deflection_m``,
            ``mesh_force_N`` (drive flanks), ``dynamic_transmission_error_m``, ``coast_approach_m``,
            ``coast_force_N`` (coast flanks), ``contact_state`` (:class:`~hacgear_core.encodings.ContactState`);
            ``state`` (nr, 2n).
        """
        nrec = int(round(duration_s / record_dt_s))
        if nrec < 1:
            raise ModelError("duration_s must be >= record_dt_s > 0")
        h0 = self._internal_step()
        per = max(1, int(math.ceil(record_dt_s / h0 - 1e-9)))
        h = record_dt_s / per
        sy = self.system
        rs, ro = np.zeros((nrec, 2 * sy.n)), np.zeros((nrec, sy.record_width))
        t0 = self.time_s
        sy.integrate(self.s, self.kin, nrec * per, h, self.fext, mode=int(self.mode), rec_every=per,
                     rec_state=rs, rec_out=ro)
        if not np.all(np.isfinite(rs)):
            raise SolverError("integration diverged (state not finite)")
        self.time_s = t0 + nrec * record_dt_s
        self._update_outputs()
        out = sy.record_fields(ro)
        out["time_s"] = t0 + out["time_s"]
        out["contact_state"] = contact_state(out["mesh_force_N"], out["coast_force_N"])
        out["state"] = rs
        return out

    # ------------------------------------------------------------------ state snapshots (FMI get/set state)
    def get_state(self) -> dict:
        """A snapshot of everything :meth:`advance` depends on (arrays copied) and of the outputs as they are (the
        kernel's end-of-step record), so that :meth:`set_state` restores both bit for bit."""
        return {"s": self.s.copy(), "kin": self.kin.copy(), "time_s": self.time_s, "mode": self.mode,
                "fext": self.fext.copy(), "torque_Nm": self.torque_Nm, "port_torques_Nm": dict(self.port_torques_Nm),
                "outputs": tuple(list(v) for v in self._output_source)}

    def set_state(self, snap: dict) -> None:
        """Restore a snapshot of :meth:`get_state` (in place; outputs updated)."""
        if snap["s"].shape != self.s.shape:
            raise ModelError(f"state snapshot has {snap['s'].size} entries, this simulator {self.s.size}")
        self.s[:] = snap["s"]
        self.kin[:] = snap["kin"]
        self.fext = snap["fext"].copy()
        self.time_s, self.mode = snap["time_s"], Experiment(snap["mode"])
        self.torque_Nm, self.port_torques_Nm = snap["torque_Nm"], dict(snap["port_torques_Nm"])
        if "outputs" in snap:
            self._set_outputs(*(list(v) for v in snap["outputs"]))
        else:
            self._update_outputs()

    # ------------------------------------------------------------------ outputs
    def _update_outputs(self) -> None:
        """Outputs from the state, the force laws evaluated in Python (after reset, set_state, run)."""
        sy = self.system
        q = self.s[:sy.n]
        base, whole = (self.kin[0], self.kin[1]) if sy.unit_rates else sy.mesh_kinematics(self.kin[0], self.kin[1])
        tau = base + sy.phase + sy.W @ q
        rec = np.zeros(sy.record_width)
        sy.mesh_law.state_fields(sy, q, tau, whole, rec)
        self._set_outputs(self.s.tolist(), self.kin.tolist(), rec.tolist())

    def _set_outputs(self, st: list, kt: list, rec: list) -> None:
        """Output attributes from the state ``st`` (2n floats), kinematics ``kt`` (3 + m floats) and the kernel's
        record ``rec`` (REC m + 1 floats)."""
        sy = self.system
        n, m = sy.n, sy.m
        self._output_source = (st, kt, rec)
        f = sy.record_fields(np.asarray(rec, dtype=float))
        self.mesh_position = f["mesh_position"].tolist()
        self.mesh_deflection_m = f["mesh_deflection_m"].tolist()
        self.mesh_force_N = f["mesh_force_N"].tolist()
        self.dynamic_transmission_error_m = f["dynamic_transmission_error_m"].tolist()
        self.coast_approach_m = f["coast_approach_m"].tolist()
        self.coast_force_N = f["coast_force_N"].tolist()
        #: twist law (helical meshes): mesh twist [rad] and twist moment [N m] per mesh (empty for other laws)
        self.mesh_twist_rad = f["mesh_twist_rad"].tolist() if "mesh_twist_rad" in f else []
        self.twist_moment_Nm = f["twist_moment_Nm"].tolist() if "twist_moment_Nm" in f else []
        #: twist law with its coast side: coast twist [rad] and coast twist moment [N m] per mesh
        self.coast_twist_rad = f["coast_twist_rad"].tolist() if "coast_twist_rad" in f else []
        self.coast_twist_moment_Nm = f["coast_twist_moment_Nm"].tolist() if "coast_twist_moment_Nm" in f else []
        self.in_contact = [f > 0.0 for f in self.mesh_force_N]
        self.coast_contact = [f > 0.0 for f in self.coast_force_N]
        #: per mesh: :class:`~hacgear_core.encodings.ContactState` (drive flanks, coast flanks, in the
        #: backlash)
        self.contact_state = [contact_state_of(f, fc) for f, fc in zip(self.mesh_force_N, self.coast_force_N)]
        #: per mesh: where the teeth are in the backlash, 0 at the drive flanks' kinematic contact, 1 where the
        #: coast flanks of ideal teeth touch (the coast approach over the normal backlash)
        self.backlash_position = [xc / b if b > 0 else 0.0 for xc, b in zip(self.coast_approach_m, self._backlash)]
        #: per mesh: integration steps whose state lay beyond the mesh's tables (deflection or load range, twist
        #: range; either side)
        self.out_of_range_steps = [int(c) for c in kt[3:3 + m]]
        if sy.m_kernel > m:
            self.out_of_range_steps = [a + int(b) for a, b in zip(self.out_of_range_steps, kt[3 + m:3 + 2 * m])]
        phi = (kt[1] + kt[0]) / sy.zref_2pi  # reference gear's rotation in its sense [rad]
        w = kt[2]
        self._frame = (phi, w)  # the reference motion: angle [rad], speed [rad/s] (a body's frame turns fr times it)
        self.angle_rad = [g.sense * (g.speed_ratio * phi + (st[g.rotation] if g.rotation >= 0 else 0.0))
                          for g in self._gears]
        self.speed_rad_s = [g.sense * (g.speed_ratio * w + (st[n + g.rotation] if g.rotation >= 0 else 0.0))
                            for g in self._gears]

    # ------------------------------------------------------------------ energy (drivetrain coupling)
    def kinetic_energy_J(self) -> float:
        """Kinetic energy [J] of the system now (absolute motion: the reference motion and the deviations)."""
        sy = self.system
        return sy.kinetic_energy_J(self.s[sy.n:], self.kin[2])

    def elastic_energy_J(self) -> float:
        """Potential energy [J] of the system now: supports, shafts and meshes
        (:meth:`~hacgear_core.dynamics.system.LumpedSystem.elastic_energy_J`)."""
        sy = self.system
        q = self.s[:sy.n]
        base = self.kin[0] if sy.unit_rates else sy.kinematic_positions(self.kin[0], self.kin[1])
        return sy.elastic_energy_J(q, base + sy.phase + sy.W @ q, self.kin[2],
                                   reference_cycles=float(self.kin[1] + self.kin[0]))

    def dissipated_power_W(self) -> float:
        """Power [W] the modal damping dissipates now."""
        sy = self.system
        return sy.dissipated_power_W(self.s[sy.n:])

    def port_power_W(self, gear: str) -> float:
        """Power [W] into the system at port ``gear``: the torque on it during the last step (drivetrain coupling:
        its shaft torque input; constant speed: the torque set-point's load on it, 0 on a gear held by its shaft)
        times its speed now, each in the gear's sense of rotation (negative: power leaves, e.g. into a load)."""
        return float(self.port_torques_Nm.get(gear, 0.0) * self.speed_rad_s[self.gear_index(gear)])

    def gear_index(self, gear: str) -> int:
        """Index of ``gear`` in :attr:`gear_names` (and in ``angle_rad``, ``speed_rad_s``)."""
        try:
            return self.gear_names.index(gear)
        except ValueError:
            raise ModelError(f"no gear {gear!r} in {self.system.name}; gears: {self.gear_names}") from None

    def bearing_force_N(self, gear: str) -> np.ndarray:
        """Force the gear puts on its bearing now (2,) [N] in the fixed frame: the system's bearing map where it has
        one (planetary sets: planet bearings on their pins, centrifugal load included), else the support springs'
        force where the bearing is elastic, else the sum of the mesh forces on the gear.  Forces computed in a
        rotating carrier frame are turned into the fixed frame by the carrier's angle."""
        sy = self.system
        g = sy.gears[gear]
        fr = sy.frame_ratio(gear)
        out = np.zeros(2)
        if gear in sy.bearing_maps:
            a, b, c = sy.bearing_maps[gear]
            out = a @ self.s[:sy.n] + b + (fr * self._frame[1]) ** 2 * c
        elif g.translations:
            # its own support springs (a shaft's bending spring on the same DOFs is not its bearing)
            for i, d in zip(g.translations, g.directions):
                out += g.support[0] * self.s[i] * d
        else:
            for k, c in enumerate(sy.meshes):
                if gear in (c.gear_a, c.gear_b):
                    nvec = np.asarray(c.line_of_action, float)
                    out += (1.0 if gear == c.gear_b else -1.0) * self.mesh_force_N[k] * nvec
        if fr != 0.0:
            ca, sa = math.cos(fr * self._frame[0]), math.sin(fr * self._frame[0])
            out = np.array([ca * out[0] - sa * out[1], sa * out[0] + ca * out[1]])
        return out

    def support_reaction(self, dof: str) -> float:
        """Load the support spring of DOF ``dof`` (a name of ``system.dof_names``, e.g. ``"wheel.z"``,
        ``"wheel.theta_x"``) takes now: ``(K q)[dof]`` [N or N m] in the fixed frame (the force or moment the gear
        puts on its bearing along that DOF; 0 for an unsupported DOF).  The 12-DOF helical pairs' axial forces and
        tilting moments."""
        sy = self.system
        try:
            i = sy.dof_names.index(dof)
        except ValueError:
            raise ModelError(f"no DOF {dof!r} in {sy.name}; DOFs: {sy.dof_names}") from None
        return float(sy.K[i] @ self.s[:sy.n])

    def load_share(self, mesh: int) -> float:
        """Load-sharing factor of mesh ``mesh`` now [-]: its force over the mean force of its group (the meshes that
        share the load, e.g. the sun meshes of all planets); 1 for a mesh without a group; 0 while the whole group
        carries no load (every mesh of it separated at once: each carries nothing)."""
        sy = self.system
        grp = sy.meshes[mesh].group
        if not grp:
            return 1.0
        idx = [k for k, c in enumerate(sy.meshes) if c.group == grp]
        tot = sum(self.mesh_force_N[k] for k in idx)
        return self.mesh_force_N[mesh] * len(idx) / tot if tot > 0 else 0.0

    def strain(self, gauge: str, tooth: int = 0) -> float:
        """Root strain [-] now at ``gauge`` ("<gear>/<gauge>") on tooth ``tooth`` of its gear, counted in the order
        the teeth reach the mesh (:func:`strain_of_tooth`; 0 while that tooth is out of mesh).  The strain over a
        tooth's whole passage from a recorded run: :func:`gauge_passage`."""
        return float(strain_of_tooth(self.system, gauge, [self.mesh_position], [self.mesh_deflection_m],
                                     [self.coast_approach_m],
                                     [self.mesh_twist_rad] if self.mesh_twist_rad else None, tooth=tooth)[0])

    def peak_pressure_Pa(self, mesh: int = 0, part: str = "peak") -> float:
        """Maximum contact pressure over all teeth of mesh ``mesh`` now [Pa] (table lookup), on the flanks in
        contact: the drive table's, or the coast table's when the teeth have crossed the backlash.  ``part``:
        "peak" every contact, "flank" the flank (Hertzian) contacts, "edge" the tip-edge contacts (NaN where the
        tables do not tell them apart)."""
        c = self.system.meshes[mesh]
        g = [self.mesh_twist_rad[mesh]] if c.t is not None else None      # helical: at the mesh twist
        p = float(dynamic_contact_pressure(c.table, [self.mesh_position[mesh]], [self.mesh_deflection_m[mesh]], g,
                                           part)[0])
        if c.coast_table is not None:
            pc = float(c.coast_table.pressure(self.mesh_position[mesh], self.coast_approach_m[mesh], part))
            p = max(p, pc) if not (math.isnan(p) or math.isnan(pc)) else math.nan
        return p
