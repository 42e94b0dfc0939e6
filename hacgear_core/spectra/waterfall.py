"""Run-up waterfall: order spectra of successive segments of a run-up record, over speed.

A run-up record sampled equally in the reference gear's angle (``samples_per_cycle`` per mesh cycle at every
speed: :func:`~hacgear_core.spectra.records.runup_record`) is cut into segments of ``segment_cycles`` mesh cycles,
``hop_cycles`` apart; each segment's :func:`~hacgear_core.spectra.spectrum.order_spectrum` (coherent, without
window, when ``segment_cycles`` is a whole number of common periods of the shafts; else flat-top) is one row of the
waterfall, at the mean mesh frequency of its samples.  In orders the excitations are vertical lines (mesh harmonic
k at order k at every speed); over frequency (``order x f_m``) they are rays through the origin and a resonance is
a horizontal band where a ray's amplitude peaks.  Each row holds a steady spectrum only as far as the speed
changes little within a segment and the response follows it (a slow run-up): the rows are order-tracked spectra of
a transient, not steady states.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hacgear_core.errors import ModelError
from hacgear_core.spectra.spectrum import OrderBasis, order_spectrum

__all__ = ["Waterfall", "waterfall", "resonance_of_track", "system_waterfalls"]


@dataclass(frozen=True, eq=False)
class Waterfall:
    """Result of :func:`waterfall`: ``mesh_frequency_Hz`` (ns,) per segment, ``mesh_order`` (nb,) of the bins,
    ``amplitude`` (ns, nb) single-sided peak amplitude per segment and bin (signal unit), ``tracks`` {line label:
    (ns,) its amplitude per segment} of every marked line (mesh harmonics "1", "2", ..., sidebands, shaft orders),
    ``segment_cycles``, ``hop_cycles``, ``coherent`` (every segment analysed without window)."""

    mesh_frequency_Hz: np.ndarray
    mesh_order: np.ndarray
    amplitude: np.ndarray
    tracks: dict
    segment_cycles: int
    hop_cycles: int
    coherent: bool

    def to_json(self, bins: bool = False) -> dict:
        out = {"mesh_frequency_Hz": self.mesh_frequency_Hz, "segment_cycles": self.segment_cycles,
               "hop_cycles": self.hop_cycles, "coherent": self.coherent, "tracks": self.tracks}
        if bins:
            out.update(mesh_order=self.mesh_order, amplitude=self.amplitude)
        return out


def waterfall(signal, samples_per_cycle: int, mesh_frequency_Hz, basis: OrderBasis | None = None, *,
              segment_cycles: int, hop_cycles: int | None = None, harmonics: int = 5,
              sideband_orders: int = 0) -> Waterfall:
    """Waterfall of a run-up record (see the module docstring).

    Parameters
    ----------
    signal : array_like (nr,)
        Samples equally spaced in the reference gear's angle.
    samples_per_cycle : int
        Samples per mesh cycle [-].
    mesh_frequency_Hz : array_like (nr,)
        Mesh frequency at each sample [Hz].
    basis : OrderBasis, optional
        The shafts (sidebands and shaft orders tracked when ``sideband_orders`` > 0).
    segment_cycles, hop_cycles : int
        Segment length and step [mesh cycles] (hop default: half the segment).
    """
    x = np.asarray(signal, dtype=float)
    fm = np.asarray(mesh_frequency_Hz, dtype=float)
    if x.ndim != 1 or fm.shape != x.shape:
        raise ModelError("signal and mesh_frequency_Hz must be 1-D arrays of one length")
    if isinstance(samples_per_cycle, bool) or not isinstance(samples_per_cycle, (int, np.integer)) \
            or samples_per_cycle < 8:
        raise ModelError(f"samples_per_cycle [-] must be an integer >= 8, got {samples_per_cycle!r}")
    hop_cycles = max(1, segment_cycles // 2) if hop_cycles is None else hop_cycles
    for name, v in (("segment_cycles", segment_cycles), ("hop_cycles", hop_cycles)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ModelError(f"{name} [mesh cycles] must be an integer >= 1, got {v!r}")
    seg, hop = segment_cycles * samples_per_cycle, hop_cycles * samples_per_cycle
    if x.size < seg:
        raise ModelError(f"the record ({x.size / samples_per_cycle:g} mesh cycles) is shorter than one segment "
                         f"({segment_cycles} mesh cycles)")
    starts = range(0, x.size - seg + 1, hop)
    rows, freqs, tracks, coherent = [], [], {}, True
    orders = None
    for s in starts:
        sp = order_spectrum(x[s:s + seg], samples_per_cycle, basis, harmonics=harmonics,
                            sideband_orders=sideband_orders)
        if not sp.success:
            raise ModelError(f"segment at sample {s}: {sp.message}")
        coherent = coherent and sp.coherent
        orders = sp.mesh_order
        rows.append(sp.amplitude)
        freqs.append(float(np.mean(fm[s:s + seg])))
        for ln in sp.lines:
            tracks.setdefault(ln.label, []).append(ln.amplitude)
    tracks = {k: np.asarray(v) for k, v in tracks.items() if len(v) == len(rows)}
    return Waterfall(np.asarray(freqs), orders, np.vstack(rows), tracks, int(segment_cycles), int(hop_cycles),
                     bool(coherent))


def resonance_of_track(wf: Waterfall, label: str = "1") -> tuple[float, float]:
    """(mesh frequency [Hz], amplitude) of the segment where the track ``label`` peaks."""
    if label not in wf.tracks:
        raise ModelError(f"no track {label!r}; tracks: {sorted(wf.tracks)}")
    i = int(np.argmax(wf.tracks[label]))
    return float(wf.mesh_frequency_Hz[i]), float(wf.tracks[label][i])



def system_waterfalls(system, fm_start_Hz: float, fm_end_Hz: float, cycles: int, quantity: str, *,
                      segment_cycles: int | None = None, hop_cycles: int | None = None, samples_per_cycle: int = 64,
                      settle_cycles: int = 200, harmonics: int = 5) -> tuple:
    """The run-up record of ``quantity`` (:func:`~hacgear_core.spectra.records.runup_record`) and the waterfall of
    each of its channels -> (RunUpRecord, {channel: Waterfall}).  ``segment_cycles`` default: one common period of
    the shafts (:meth:`~hacgear_core.spectra.spectrum.OrderBasis.common_period_cycles`), refused when the run-up
    holds fewer than 4 of them."""
    from hacgear_core.spectra.records import runup_record
    from hacgear_core.spectra.spectrum import order_basis

    basis = order_basis(system)
    if segment_cycles is None:
        period = basis.common_period_cycles()
        if period is None or period.denominator != 1 or 4 * period > cycles:
            raise ModelError(f"{system.name}: the run-up of {cycles} mesh cycles holds fewer than 4 common periods of "
                             f"the shafts ({'none' if period is None else f'{float(period):g} mesh cycles'}); give "
                             "the segment length in mesh cycles (segments shorter than a common period are windowed)")
        segment_cycles = int(period)
    rec = runup_record(system, fm_start_Hz, fm_end_Hz, cycles, quantity, samples_per_cycle=samples_per_cycle,
                       settle_cycles=settle_cycles)
    return rec, {ch: waterfall(x, rec.samples_per_cycle, rec.mesh_frequency_Hz, basis, segment_cycles=segment_cycles,
                               hop_cycles=hop_cycles, harmonics=harmonics) for ch, x in rec.channels.items()}
