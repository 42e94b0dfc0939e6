"""Order spectrum of a steady-state record: amplitude per mesh order and per shaft order, with the mesh harmonics,
their sidebands and the shaft orders marked.

Orders.  A record is sampled uniformly in time at constant speed, ``samples_per_cycle`` samples per mesh cycle, so
its frequencies are *mesh orders* ``o = f / f_m``.  Each shaft ``s`` turns ``r_s`` times per mesh cycle (its *shaft
order ratio*, :class:`OrderBasis`); its *shaft order* of a frequency is ``o / r_s``.  For a gear of ``z`` teeth
``r = 1 / z`` (mesh order = z x shaft order); in a planetary set the meshes run in the carrier frame, so a gear's
shaft order counts its rotation *relative to the carrier* (``f_m = z |f_gear - f_carrier|``) and the carrier itself
is a shaft of ratio ``|f_carrier| / f_m`` (:func:`order_basis`).  Shafts of equal ratio (a 28:28 pair, the planets
of a set, a fixed ring and the carrier) form one group and one label.  In a system whose meshes run at several
rates (gear trains and gearboxes with unequal tooth counts), the orders are those of the reference mesh (the first)
and every other mesh rate ``p / q`` (its mesh frequency over the reference's, :attr:`OrderBasis.meshes`, labelled by
its stage or its meshes' names) has its own harmonics ``k p / q``, labelled ``"k <label>"`` (``"1 m34"``).

Marked lines (:class:`SpectralLine`): mesh harmonics ``k`` (k = 1 .. ``harmonics``; and ``k p / q`` of each other
mesh rate), sidebands ``k +- n r_s`` around each of them (n = 1 .. ``sideband_orders``, every shaft group; a
sideband that falls on a harmonic of its mesh, ``n r_s`` a whole number of its mesh orders, is not one),
and shaft orders ``n r_s`` (the once-, twice-... per revolution lines of runout and pitch errors).  Lines that fall
on one bin share it: their labels are joined and the family is the first of mesh > sideband > shaft.  Combination
sidebands of two shafts (``k + r_a - r_b``) are not marked.

Coherent analysis (the normal case).  When the record holds at least one *common period* ``T`` of the mesh and
every shaft (the smallest number of mesh cycles after which every shaft is back where it started:
:meth:`OrderBasis.common_period_cycles`, e.g. lcm(28, 33, 39) = 12012 mesh cycles for the idler chain) and
``T x samples_per_cycle`` is a whole number of samples, the last whole number of common periods is taken with no
window.  Every marked line then falls exactly on a bin and the discrete Fourier transform gives each periodic
component's amplitude exactly (to rounding, ~1e-12 relative); the power fractions follow from Parseval.

Otherwise (``coherent = False``) the whole record is multiplied by the flat-top window
(:func:`scipy.signal.windows.flattop`, periodic), its mean removed first, and the amplitudes divided by the
window's coherent gain.  A line of amplitude ``A`` whose frequency lies anywhere between bins is then read at its
nearest bin with ``|A_read - A| <= eps_s A + lam sum_j A_j``, ``eps_s`` = :data:`FLATTOP_SCALLOPING` (the window's
largest scalloping loss, 0.11 %) and ``lam`` = :data:`FLATTOP_SIDELOBE` (its highest side lobe, about 1e-4 relative)
times the other lines' amplitudes ``A_j``, provided no other line lies within :data:`FLATTOP_HALF_WIDTH_BINS` (5)
bins (the window's main lobe; a marked line closer than that to another marked line is ``resolved = False``).
Power fractions are not reported then (NaN): the window's leakage makes them approximate.

Amplitudes are single-sided peak amplitudes in the unit of the signal: ``x(t) = mean + sum A cos(2 pi o c + phi)``
with ``c`` the mesh cycles since the first sample analysed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cache
from typing import Mapping

import numpy as np

from hacgear_core.errors import ModelError

__all__ = ["OrderBasis", "SpectralLine", "OrderSpectrum", "order_basis", "order_spectrum", "mesh_rate_groups",
           "mesh_harmonic_label", "FLATTOP_SCALLOPING",
           "FLATTOP_SIDELOBE", "FLATTOP_HALF_WIDTH_BINS", "LINE_FAMILIES"]

#: kinds of marked lines, in the priority that names a bin several lines share
LINE_FAMILIES = ("mesh", "sideband", "shaft")

#: half width of the flat-top window's main lobe [bins]: a line closer than this to another is not resolved
FLATTOP_HALF_WIDTH_BINS = 5

#: largest denominator of a shaft order ratio taken as an exact fraction (a ratio that no fraction with a
#: denominator up to this matches to :data:`_FRACTION_RTOL` has no common period)
_MAX_DENOMINATOR = 10 ** 6
#: relative distance [-] within which a float ratio is taken as its fraction (a few units in the last place: ratios
#: computed from speed ratios, e.g. a carrier's 65/240 over 65 x 175/240 mesh cycles per radian)
_FRACTION_RTOL = 1e-14


@cache
def _flattop_response() -> tuple[float, float]:
    """(largest scalloping loss [-], highest side lobe beyond the main lobe [-, relative]) of the periodic
    flat-top window, from its discrete-time Fourier transform on a 1024-sample window at 1/100-bin offsets."""
    from scipy.signal.windows import flattop

    n = 1024
    w = flattop(n, sym=False)
    k = np.arange(n)

    def gain(offsets):
        return np.abs(np.exp(-2j * np.pi * np.outer(offsets, k) / n) @ w) / w.sum()

    scallop = float(1.0 - gain(np.linspace(0.0, 0.5, 51)).min())
    side = float(gain(np.arange(FLATTOP_HALF_WIDTH_BINS * 20, 60 * 20 + 1) / 20.0).max())
    return scallop, side


#: largest amplitude error of the flat-top window for a line between two bins [-, relative] (0.0011; the computed
#: value with a 1 % margin for other record lengths)
FLATTOP_SCALLOPING = 1.01 * _flattop_response()[0]
#: highest side lobe of the flat-top window >= 5 bins from a line [-, relative to its amplitude] (1 % margin)
FLATTOP_SIDELOBE = 1.01 * _flattop_response()[1]


@dataclass(frozen=True)
class OrderBasis:
    """The shafts of a record: ``shafts`` {name: shaft order ratio r [-] = shaft turns per mesh cycle} (> 0), and
    ``meshes`` {label: rate [-]}: the mesh frequencies of the other meshes over the reference mesh's (> 0, not 1;
    each rate's harmonics are marked as mesh lines "k <label>").

    Names of shafts with equal ratio (to 1e-12 relative) are grouped (:attr:`groups`) and marked as one."""

    shafts: Mapping[str, float] = field(default_factory=dict)
    meshes: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for what, items in (("shaft order ratio", self.shafts), ("mesh rate", self.meshes)):
            for name, r in items.items():
                if not (isinstance(r, (int, float, Fraction)) and math.isfinite(float(r)) and 0 < float(r) < 1e6):
                    raise ModelError(f"{what} of {name!r} [turns or mesh cycles per reference mesh cycle] must be "
                                     f"finite and in (0, 1e6), got {r!r}")
        same = [name for name, r in self.meshes.items() if abs(float(r) - 1.0) <= 1e-12]
        if same:
            raise ModelError(f"mesh rates {same} equal the reference mesh's (1): their harmonics are its own")

    @property
    def groups(self) -> tuple[tuple[str, float], ...]:
        """(label "a/b", ratio) per group of shafts of equal ratio, in ascending ratio."""
        out: list[list] = []
        for name, r in sorted(self.shafts.items(), key=lambda a: float(a[1])):
            r = float(r)
            if out and abs(out[-1][1] - r) <= 1e-12 * r:
                out[-1][0].append(name)
            else:
                out.append([[name], r])
        return tuple(("/".join(names), r) for names, r in out)

    def fraction(self, name: str) -> Fraction | None:
        """Shaft ``name``'s ratio (or mesh rate ``name``) as an exact fraction (None: no fraction with a denominator
        up to 1e6 matches)."""
        r = self.shafts[name] if name in self.shafts else self.meshes[name]
        if isinstance(r, (int, Fraction)):
            return Fraction(r)
        f = Fraction(float(r)).limit_denominator(_MAX_DENOMINATOR)
        return f if abs(float(f) - float(r)) <= _FRACTION_RTOL * float(r) else None

    def common_period_cycles(self) -> Fraction | None:
        """Mesh cycles after which the mesh and every shaft are back in place: the least common multiple of 1 and
        every shaft's period ``1 / r`` (None when a ratio is not a fraction, :meth:`fraction`)."""
        num, den = 1, 0
        for name in (*self.shafts, *self.meshes):
            f = self.fraction(name)
            if f is None:
                return None
            period = 1 / f
            num = math.lcm(num, period.numerator)
            den = math.gcd(den, period.denominator)
        return Fraction(num, den or 1)


def order_basis(system) -> OrderBasis:
    """The shafts of a :class:`~hacgear_core.dynamics.system.LumpedSystem` with their shaft order ratios: every
    gear with teeth that turns relative to the meshes' frame, ``r = 1 / z`` (checked against its kinematic speed
    ratio: ``|speed_ratio - carrier_ratio| / (z_ref / 2 pi)`` per radian of the reference gear), and, for a
    rotating carrier, the carrier itself at its absolute speed."""
    per_rad = system.zref_2pi * 2 * math.pi          # mesh cycles per turn of the reference gear
    cr = float(system.carrier_ratio)
    shafts: dict[str, float | Fraction] = {}
    for g in system.gears.values():
        fr = system.frame_ratio(g.name)            # its meshes' frame: its stage's carrier (or the fixed frame)
        if g.teeth > 0:
            rel = abs(g.speed_ratio - fr) / per_rad
            if rel <= 0:
                continue
            # its mesh's frequency over the reference mesh's, p / q, over its teeth (1 / z at the reference rate)
            p, q = next((tuple(int(x) for x in r) for c, r in zip(system.meshes, system.rate)
                         if g.name in (c.gear_a, c.gear_b) or g.name in c.gear_alias), (1, 1))
            exact = Fraction(p, q * int(g.teeth))
            shafts[g.name] = exact if abs(rel - float(exact)) <= 1e-9 * rel else rel
        elif g.speed_ratio != 0 and fr != 0 and abs(g.speed_ratio - fr) <= 1e-12 * abs(fr):   # a carrier
            shafts[g.name] = abs(fr) / per_rad
    if cr != 0 and not any(g.teeth == 0 for g in system.gears.values()):
        shafts["carrier"] = abs(cr) / per_rad
    return OrderBasis(shafts, {label: rate for label, (rate, _) in mesh_rate_groups(system).items()})


def mesh_rate_groups(system) -> dict[str, tuple[Fraction, tuple[str, ...]]]:
    """{label: (rate p / q, mesh names)} of the meshes of ``system`` that run at a rate other than the reference
    mesh's, one entry per rate: labelled by the stage of their gears where the system has stages (a gearbox), else by
    their names joined with "/"."""
    by_rate: dict[Fraction, list[str]] = {}
    stage: dict[Fraction, str] = {}
    for c, (p, q) in zip(system.meshes, system.rate):
        rate = Fraction(int(p), int(q))
        if rate == 1:
            continue
        by_rate.setdefault(rate, []).append(c.name)
        g = system.gears.get(c.gear_a)
        if g is not None and getattr(g, "stage", ""):
            stage.setdefault(rate, g.stage)
    return {(stage.get(r) or "/".join(names)): (r, tuple(names)) for r, names in sorted(by_rate.items())}


def mesh_harmonic_label(system, mesh: str, k: int = 1) -> str:
    """The label of mesh ``mesh``'s ``k``-th harmonic in the spectra of ``system``: ``"k"`` at the reference rate,
    else ``"k <label>"`` (:func:`mesh_rate_groups`)."""
    for label, (_, names) in mesh_rate_groups(system).items():
        if mesh in names:
            return f"{k} {label}"
    if mesh not in {c.name for c in system.meshes}:
        raise ModelError(f"no mesh {mesh!r}; meshes: {[c.name for c in system.meshes]}")
    return str(k)


@dataclass(frozen=True)
class SpectralLine:
    """One marked line: ``family`` (:data:`LINE_FAMILIES`), ``label`` ("1", "1-1 pinion/wheel", "2 x sun", joined by
    "; " where lines share a bin), ``mesh_order`` [-] (the exact order of the line), ``harmonic`` k (0 for a shaft
    order), ``shaft`` (group label, "" for a mesh harmonic), ``n`` (signed shaft orders off the harmonic),
    ``amplitude`` and ``phase_rad`` at its bin, ``bin`` index, ``resolved`` (no other marked line within the
    window's main lobe; always True for a coherent record)."""

    family: str
    label: str
    mesh_order: float
    harmonic: int
    shaft: str
    n: int
    amplitude: float
    phase_rad: float
    bin: int
    resolved: bool = True

    def to_json(self) -> dict:
        return {"family": self.family, "label": self.label, "mesh_order": self.mesh_order, "harmonic": self.harmonic,
                "shaft": self.shaft, "n": self.n, "amplitude": self.amplitude, "phase_rad": self.phase_rad,
                "resolved": self.resolved}


@dataclass(frozen=True, eq=False)
class OrderSpectrum:
    """Result of :func:`order_spectrum`.

    Attributes
    ----------
    success, message : bool, str
        False with the reason when no spectrum could be taken (arrays then empty).
    mesh_order : ndarray (nb,)
        Mesh order of each bin [-].
    amplitude : ndarray (nb,)
        Single-sided peak amplitude per bin, in the signal's unit (bin 0: the mean).
    phase_rad : ndarray (nb,)
        Phase of each bin's cosine at the first analysed sample [rad].
    shaft_order : dict
        {shaft group label: (nb,) shaft order of each bin [-]}.
    lines : tuple of SpectralLine
        The marked lines, in ascending order.
    coherent : bool
        Whether a whole number of common periods was analysed without window (exact amplitudes).
    window : str
        "rectangular" or "flattop".
    samples_used, cycles_used : int, float
        Samples and mesh cycles analysed (the end of the record).
    common_period_cycles : float
        Common period of the mesh and every shaft [mesh cycles] (NaN: none).
    amplitude_error_bound : float
        Relative amplitude error bound of a resolved line (0: exact to rounding; flat-top:
        :data:`FLATTOP_SCALLOPING`, plus :data:`FLATTOP_SIDELOBE` times the other lines' amplitudes).
    mean : float
        Mean of the analysed samples.
    ac_rms : float
        RMS about the mean of the analysed samples.
    mesh_harmonic_power_fraction : float
        Share of the AC power at the mesh harmonics (integer mesh orders and every other mesh rate's multiples, up to
        Nyquist) [-]; NaN when not coherent.
    marked_power_fraction : float
        Share of the AC power at marked lines plus every mesh harmonic [-]; NaN when not coherent.
    mesh_frequency_Hz : float
        Mesh frequency the orders refer to (NaN when not given); ``frequency_Hz`` = mesh order times it.
    """

    success: bool
    message: str
    mesh_order: np.ndarray
    amplitude: np.ndarray
    phase_rad: np.ndarray
    shaft_order: dict
    lines: tuple
    coherent: bool
    window: str
    samples_used: int
    cycles_used: float
    common_period_cycles: float
    amplitude_error_bound: float
    mean: float
    ac_rms: float
    mesh_harmonic_power_fraction: float
    marked_power_fraction: float
    mesh_frequency_Hz: float = math.nan

    @property
    def frequency_Hz(self) -> np.ndarray:
        """Frequency of each bin [Hz] (NaN without a mesh frequency)."""
        return self.mesh_order * self.mesh_frequency_Hz

    def line(self, label: str) -> SpectralLine:
        """The marked line whose label (or one of its joined labels) is ``label``."""
        for ln in self.lines:
            if label in ln.label.split("; "):
                return ln
        raise ModelError(f"no marked line {label!r}; lines: {[ln.label for ln in self.lines]}")

    def to_json(self, bins: bool = False) -> dict:
        """JSON summary: the marked lines, the analysis facts; ``bins``: every bin too."""
        out = {"success": self.success, "message": self.message, "coherent": self.coherent, "window": self.window,
               "samples_used": self.samples_used, "cycles_used": self.cycles_used,
               "common_period_cycles": self.common_period_cycles, "amplitude_error_bound": self.amplitude_error_bound,
               "mean": self.mean, "ac_rms": self.ac_rms,
               "mesh_harmonic_power_fraction": self.mesh_harmonic_power_fraction,
               "marked_power_fraction": self.marked_power_fraction, "mesh_frequency_Hz": self.mesh_frequency_Hz,
               "lines": [ln.to_json() for ln in self.lines]}
        if bins:
            out["bins"] = {"mesh_order": self.mesh_order, "amplitude": self.amplitude, "phase_rad": self.phase_rad}
        return out


def _failed(message: str, mesh_frequency_Hz: float) -> OrderSpectrum:
    e = np.zeros(0)
    nan = math.nan
    return OrderSpectrum(False, message, e, e, e, {}, (), False, "", 0, 0.0, nan, nan, nan, nan, nan, nan,
                         mesh_frequency_Hz)


def _candidates(basis: OrderBasis, harmonics: int, sideband_orders: int, max_order: float) -> list[tuple]:
    """(order, family, label, k, shaft, n) of every line to mark below ``max_order``: each mesh rate's harmonics
    (the reference mesh's first, labelled "k"; another rate's "k <label>"), their sidebands, the shaft orders."""
    out = []
    for mesh, rate in (("", 1.0), *((m, float(r)) for m, r in basis.meshes.items())):
        tag = f" {mesh}" if mesh else ""
        out += [(k * rate, "mesh", f"{k}{tag}", k, "", 0) for k in range(1, harmonics + 1) if k * rate < max_order]
        for label, r in basis.groups:
            for n in range(1, sideband_orders + 1):
                nr = n * r / rate          # in orders of this mesh
                if abs(nr - round(nr)) <= 1e-9 * max(1.0, nr):
                    continue               # on a harmonic of this mesh: not a sideband
                for k in range(1, harmonics + 1):
                    for sign in (-1, 1):
                        o = (k + sign * nr) * rate
                        if 0 < o < max_order:
                            out.append((o, "sideband", f"{k}{tag}{'+' if sign > 0 else '-'}{n} {label}", k, label,
                                        sign * n))
    for label, r in basis.groups:
        for n in range(1, sideband_orders + 1):
            nr = n * r
            if abs(nr - round(nr)) <= 1e-9 * max(1.0, nr):
                continue               # on a mesh harmonic: not a shaft order line
            if nr < max_order:
                out.append((nr, "shaft", f"{n} x {label}" if n > 1 else f"1 x {label}", 0, label, n))
    return out


def order_spectrum(signal, samples_per_cycle: float, basis: OrderBasis | None = None, *, harmonics: int = 5,
                   sideband_orders: int = 3, mesh_frequency_Hz: float = math.nan,
                   window: str = "auto") -> OrderSpectrum:
    """Order spectrum of a uniformly sampled steady-state record (see the module docstring).

    Parameters
    ----------
    signal : array_like (n,)
        The record, in any unit; finite.
    samples_per_cycle : float
        Samples per mesh cycle [-] (> 2).
    basis : OrderBasis, optional
        The shafts (default: none: mesh orders only, common period one mesh cycle).
    harmonics : int
        Mesh harmonics to mark (>= 1), and the harmonics sidebands are marked around.
    sideband_orders : int
        Shaft orders n marked on each side of each harmonic, and as shaft orders (>= 0).
    mesh_frequency_Hz : float, optional
        Mesh frequency [Hz] for :attr:`OrderSpectrum.frequency_Hz`.
    window : {"auto", "flattop"}
        "auto": no window over a whole number of common periods, else flat-top; "flattop": always the window.

    Returns
    -------
    OrderSpectrum
        ``success`` False with a message for a record that cannot be analysed (fewer than 16 samples, not finite,
        or shorter than one mesh cycle).
    """
    basis = basis if basis is not None else OrderBasis()
    x = np.asarray(signal, dtype=float)
    if window not in ("auto", "flattop"):
        raise ModelError(f"window must be 'auto' or 'flattop', got {window!r}")
    if isinstance(harmonics, bool) or not isinstance(harmonics, (int, np.integer)) or harmonics < 1:
        raise ModelError(f"harmonics [-] must be an integer >= 1, got {harmonics!r}")
    if isinstance(sideband_orders, bool) or not isinstance(sideband_orders, (int, np.integer)) or sideband_orders < 0:
        raise ModelError(f"sideband_orders [-] must be an integer >= 0, got {sideband_orders!r}")
    spc = float(samples_per_cycle)
    if not (math.isfinite(spc) and spc > 2):
        raise ModelError(f"samples_per_cycle [-] must be finite and > 2, got {samples_per_cycle!r}")
    if x.ndim != 1 or x.size < 16:
        return _failed(f"need a 1-D record of at least 16 samples, got shape {x.shape}", mesh_frequency_Hz)
    if not np.all(np.isfinite(x)):
        return _failed("the record holds non-finite samples", mesh_frequency_Hz)
    if x.size < spc:
        return _failed(f"the record ({x.size} samples) is shorter than one mesh cycle ({spc:g} samples)",
                       mesh_frequency_Hz)
    period = basis.common_period_cycles()
    per_samples = float(period) * spc if period is not None else math.inf
    whole = math.isfinite(per_samples) and abs(per_samples - round(per_samples)) <= 1e-9 * per_samples
    coherent = window == "auto" and whole and x.size >= round(per_samples)
    notes = []
    if coherent:
        p = int(round(per_samples))
        seg = x[x.size - (x.size // p) * p:]
        w = np.ones(seg.size)
        bound = 0.0
    else:
        seg = x
        from scipy.signal.windows import flattop
        w = flattop(seg.size, sym=False)
        bound = FLATTOP_SCALLOPING
        why = ("window='flattop' asked" if window == "flattop" else
               "no common period of the shafts" if period is None else
               f"the record ({x.size} samples) is shorter than one common period ({per_samples:.6g} samples)"
               if whole else f"a common period ({float(period):g} mesh cycles) is not a whole number of samples "
               f"({per_samples:.9g})")
        notes.append(f"not coherent ({why}): flat-top window, amplitude error <= {FLATTOP_SCALLOPING:.2e} relative "
                     f"+ {FLATTOP_SIDELOBE:.1e} x the other lines' amplitudes")
    n = seg.size
    mean = float(np.sum(w * seg) / np.sum(w))
    X = np.fft.rfft(w * (seg - mean)) / np.sum(w)
    amp = 2.0 * np.abs(X)
    if n % 2 == 0:
        amp[-1] = np.abs(X[-1])
    amp[0] = abs(mean)
    phase = np.angle(X)
    phase[0] = 0.0 if mean >= 0 else math.pi
    orders = np.arange(X.size) * spc / n
    max_order = orders[-1] if n % 2 else orders[-1] - 0.5 * spc / n   # the Nyquist bin holds no line's phase
    ac_power = float(np.mean((seg - np.mean(seg)) ** 2)) if coherent else math.nan
    # the marked lines, merged per bin
    by_bin: dict[int, list] = {}
    for o, fam, label, k, shaft, nn in _candidates(basis, harmonics, sideband_orders, max_order):
        b = int(round(o * n / spc))
        if coherent and abs(o * n / spc - b) > 1e-6:
            continue                   # cannot happen for a shaft of the basis (whole common periods)
        by_bin.setdefault(b, []).append((LINE_FAMILIES.index(fam), o, fam, label, k, shaft, nn))
    bins_sorted = sorted(by_bin)
    lines = []
    for i, b in enumerate(bins_sorted):
        entries = sorted(by_bin[b])
        _, o, fam, _, k, shaft, nn = entries[0]
        label = "; ".join(e[3] for e in entries)
        near = [c for c in bins_sorted[max(0, i - 1):i + 2] if c != b]
        resolved = coherent or all(abs(c - b) >= FLATTOP_HALF_WIDTH_BINS for c in near)
        lines.append(SpectralLine(fam, label, float(o), int(k), shaft, int(nn), float(amp[b]), float(phase[b]), b,
                                  resolved))
    if coherent:
        power = 0.5 * amp ** 2
        if n % 2 == 0:
            power[-1] = amp[-1] ** 2
        power[0] = 0.0
        total = float(power.sum())
        step = int(round(n / spc))                      # bins per mesh order (whole: coherent)
        hbins = set(range(step, power.size, step))
        for rate in basis.meshes.values():              # every other mesh's harmonics (whole bins: coherent)
            per = float(rate) * n / spc
            hbins.update(int(round(k * per)) for k in range(1, int(power.size / per) + 1)
                         if round(k * per) < power.size and abs(k * per - round(k * per)) <= 1e-6)
        harm = float(power[sorted(hbins)].sum())
        marked = harm + float(sum(power[b] for b in bins_sorted if b not in hbins))
        fh = harm / total if total > 0 else math.nan
        fmk = marked / total if total > 0 else math.nan
        if total > 0 and abs(total - ac_power) > 1e-9 * ac_power + 1e-300:
            notes.append(f"Parseval check off by {abs(total - ac_power) / ac_power:.1e}")
    else:
        fh = fmk = math.nan
    shaft_order = {label: orders / r for label, r in basis.groups}
    return OrderSpectrum(True, "; ".join(notes), orders, amp, phase, shaft_order, tuple(lines), coherent,
                         "rectangular" if coherent else "flattop", int(n), n / spc,
                         float(period) if period is not None else math.nan, bound, mean,
                         float(math.sqrt(np.mean((seg - np.mean(seg)) ** 2))), fh, fmk, float(mesh_frequency_Hz))
