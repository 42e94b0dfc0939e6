"""Campbell diagram of a gear system: natural frequencies over the input speed with the excitation order lines,
and the speeds where an order line crosses a natural frequency (the resonances a run-up passes through).

Order lines.  At input speed ``w_in`` [rad/s] the mesh frequency is ``f_m = a w_in`` with ``a = (z_ref / 2 pi) /
|i_in|`` [Hz per rad/s] (``z_ref / 2 pi`` mesh cycles per radian of the reference gear, ``i_in`` the input gear's
speed ratio to it).  The lines are the mesh harmonics ``k f_m`` (k = 1 .. ``harmonics``; in a gear train or
gearbox whose stages run at their own mesh frequencies ``r f_m``, the harmonics ``k r f_m`` of every stage,
labelled by the stage) and the shaft orders
``n r_s f_m`` (n = 1 .. ``shaft_orders``) of each shaft group of :func:`~hacgear_core.spectra.spectrum.order_basis`
(``r_s = 1 / z`` for a gear: the once-per-revolution excitation of runout, relative to the carrier in a planetary
set).  Every line is a ray through the origin, ``f = c w_in``.

Natural frequencies.  Systems without a rotating frame (``carrier_ratio = 0``: spur, idler, helical) have modes
that do not depend on speed: the linearised modal analysis (:func:`~hacgear_core.dynamics.modes.modal_analysis`,
elastic modes), so a crossing of mode ``f_i`` by line ``c`` is at ``w_in = f_i / c`` exactly.  A rotating carrier
(planetary sets) adds gyroscopic and centripetal terms that move the modes with the carrier speed
``W_c = carrier_ratio w_in / i_in``: the modes of :func:`~hacgear_core.dynamics.modes.gyroscopic_modes` at each
speed, tracked by their rank (the i-th lowest elastic frequency; where two modes cross, the ranks swap curves), and
each crossing found where ``f_i(w) - c w`` changes sign between two grid speeds, refined by bisection to 1e-12
relative in speed.  The modes are those at the nominal torque (the mesh stiffnesses linearised there).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hacgear_core.dynamics.modes import gyroscopic_modes, modal_analysis
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError
from hacgear_core.spectra.spectrum import order_basis

__all__ = ["OrderLine", "Crossing", "CampbellResult", "campbell", "RPM_PER_RAD_S"]

#: revolutions per minute per rad/s
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


@dataclass(frozen=True)
class OrderLine:
    """An excitation order line ``f = hz_per_rad_s * w_in``: ``label`` ("1 x f_m", "1 x sun"), ``family`` ("mesh" or
    "shaft"), ``order`` (k or n), ``shaft`` (group label, "" for mesh harmonics), ``mesh_order`` (its frequency over
    the mesh frequency) and ``hz_per_rad_s`` [Hz per rad/s of input speed]."""

    label: str
    family: str
    order: int
    shaft: str
    mesh_order: float
    hz_per_rad_s: float


@dataclass(frozen=True)
class Crossing:
    """Where order line ``line`` (its label) meets elastic mode ``mode`` (rank, 0 = lowest): input speed
    ``input_speed_rad_s`` [rad/s] and ``input_speed_rpm``, ``frequency_Hz`` (the mode's and the line's),
    ``mesh_frequency_Hz`` there; ``closed_form`` True where the modes do not depend on speed."""

    line: str
    mode: int
    input_speed_rad_s: float
    input_speed_rpm: float
    frequency_Hz: float
    mesh_frequency_Hz: float
    closed_form: bool

    def to_json(self) -> dict:
        return {"line": self.line, "mode": self.mode, "input_speed_rad_s": self.input_speed_rad_s,
                "input_speed_rpm": self.input_speed_rpm, "frequency_Hz": self.frequency_Hz,
                "mesh_frequency_Hz": self.mesh_frequency_Hz, "closed_form": self.closed_form}


@dataclass(frozen=True, eq=False)
class CampbellResult:
    """Result of :func:`campbell`: ``input_gear``; ``input_speed_rad_s`` (ns,); ``natural_frequencies_Hz`` (ns,
    n_modes) elastic modes by rank; ``mode_types`` (n_modes,) at the first speed ("" where not classified);
    ``mesh_hz_per_rad_s`` (``a``); ``lines`` (OrderLine); ``crossings`` (Crossing) in ascending speed within the
    speed range; ``speed_dependent`` (a rotating carrier)."""

    input_gear: str
    input_speed_rad_s: np.ndarray
    natural_frequencies_Hz: np.ndarray
    mode_types: tuple
    mesh_hz_per_rad_s: float
    lines: tuple
    crossings: tuple
    speed_dependent: bool

    @property
    def input_speed_rpm(self) -> np.ndarray:
        return self.input_speed_rad_s * RPM_PER_RAD_S

    @property
    def mesh_frequency_Hz(self) -> np.ndarray:
        return self.input_speed_rad_s * self.mesh_hz_per_rad_s

    def to_json(self) -> dict:
        return {"input_gear": self.input_gear, "speed_dependent": self.speed_dependent,
                "mesh_frequency_Hz_per_rpm": self.mesh_hz_per_rad_s / RPM_PER_RAD_S,
                "input_speed_rpm": self.input_speed_rpm, "mesh_frequency_Hz": self.mesh_frequency_Hz,
                "natural_frequencies_Hz": self.natural_frequencies_Hz, "mode_types": list(self.mode_types),
                "lines": [{"label": ln.label, "family": ln.family, "order": ln.order, "shaft": ln.shaft,
                           "mesh_order": ln.mesh_order} for ln in self.lines],
                "crossings": [c.to_json() for c in self.crossings]}


def _modes(system: LumpedSystem, speed: float, a_ref: float) -> tuple[np.ndarray, tuple]:
    """Elastic natural frequencies [Hz] ascending and their types at input speed ``speed`` [rad/s]
    (``a_ref``: reference speed per input speed)."""
    g = gyroscopic_modes(system, system.carrier_ratio * speed * a_ref)
    keep = np.array([t != "rigid" and f > 0 for f, t in zip(g.natural_frequencies_Hz, g.types)])
    return g.natural_frequencies_Hz[keep], tuple(t for t, k in zip(g.types, keep) if k)


def _mesh_rates(system: LumpedSystem) -> list[tuple[str, float]]:
    """The distinct mesh frequencies of ``system`` over the reference mesh's, each with the label its lines carry:
    '' for a system at one mesh frequency, else `` <stage>`` (a gearbox's stage, else the first mesh at that
    rate)."""
    out: dict[float, str] = {}
    for c, r in zip(system.meshes, system.rates):
        out.setdefault(float(r), system.gears[c.gear_a].stage or c.name)
    if len(out) == 1:
        return [("", next(iter(out)))]
    return [(f" {label}", r) for r, label in out.items()]


def campbell(system: LumpedSystem, input_speeds_rad_s, *, harmonics: int = 3, shaft_orders: int = 1) -> CampbellResult:
    """Campbell diagram of ``system`` over ``input_speeds_rad_s`` [rad/s] (ascending, >= 2 values, >= 0) with
    ``harmonics`` mesh harmonics and ``shaft_orders`` shaft orders per shaft group (see the module docstring)."""
    w = np.asarray(input_speeds_rad_s, dtype=float)
    if w.ndim != 1 or w.size < 2 or not np.all(np.isfinite(w)) or np.any(w < 0) or np.any(np.diff(w) <= 0):
        raise ModelError("input speeds [rad/s] must be >= 2 finite values >= 0 in ascending order")
    for name, v, lo in (("harmonics", harmonics, 1), ("shaft_orders", shaft_orders, 0)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
            raise ModelError(f"{name} [-] must be an integer >= {lo}, got {v!r}")
    gin = system.gears[system.input_gear]
    if gin.speed_ratio == 0:
        raise ModelError(f"{system.name}: the input gear {gin.name!r} does not turn")
    a_ref = 1.0 / abs(gin.speed_ratio)              # reference speed per input speed
    a = system.zref_2pi * a_ref                     # mesh frequency [Hz] per input rad/s
    lines = []
    for label, rate in _mesh_rates(system):
        lines += [OrderLine(f"{k} x f_m{label}", "mesh", k, "", k * rate, k * rate * a) for k in range(1, harmonics + 1)]
    for label, r in order_basis(system).groups:
        lines += [OrderLine(f"{n} x {label}", "shaft", n, label, n * r, n * r * a) for n in range(1, shaft_orders + 1)]
    rotating = system.carrier_ratio != 0.0
    if not rotating:
        mr = modal_analysis(system)
        f0 = np.asarray(mr.natural_frequencies_Hz, float)
        freqs = np.tile(f0, (w.size, 1))
        types = tuple("" for _ in f0)
        crossings = []
        for ln in lines:
            for i, f in enumerate(f0):
                s = f / ln.hz_per_rad_s
                if w[0] <= s <= w[-1]:
                    crossings.append(Crossing(ln.label, i, s, s * RPM_PER_RAD_S, float(f), s * a, True))
    else:
        rows = [_modes(system, s, a_ref) for s in w]
        nmod = min(len(r[0]) for r in rows)
        freqs = np.array([r[0][:nmod] for r in rows])
        types = rows[0][1][:nmod]
        crossings = []
        for ln in lines:
            c = ln.hz_per_rad_s
            for i in range(nmod):
                g = freqs[:, i] - c * w
                for j in np.nonzero(np.sign(g[:-1]) * np.sign(g[1:]) <= 0)[0]:
                    lo, hi = float(w[j]), float(w[j + 1])
                    glo = g[j]
                    if g[j] == 0 and j > 0:
                        continue                      # counted as the end of the previous interval
                    for _ in range(200):
                        if hi - lo <= 1e-12 * max(hi, 1e-300):
                            break
                        mid = 0.5 * (lo + hi)
                        gm = _modes(system, mid, a_ref)[0][i] - c * mid
                        if (gm > 0) == (glo > 0):
                            lo, glo = mid, gm
                        else:
                            hi = mid
                    s = 0.5 * (lo + hi)
                    crossings.append(Crossing(ln.label, i, s, s * RPM_PER_RAD_S, c * s, s * a, False))
    crossings.sort(key=lambda c: (c.input_speed_rad_s, c.line, c.mode))
    return CampbellResult(gin.name, w, freqs, types, a, tuple(lines), tuple(crossings), rotating)
