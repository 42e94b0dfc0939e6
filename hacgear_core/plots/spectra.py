"""Figures of order spectra (amplitude over mesh order, mesh harmonics and sidebands labelled) and Campbell
diagrams (natural frequencies and order lines over the input speed, crossings marked)."""
from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hacgear_core.outpaths import save_figure  # noqa: E402

__all__ = ["spectrum_figure", "campbell_figure", "waterfall_figure", "save_spectrum_figure", "save_campbell_figure",
           "save_waterfall_figure"]

_FAMILY_STYLE = {"mesh": ("C3", "o"), "sideband": ("C0", "v"), "shaft": ("C2", "s")}
#: a mesh harmonic's track label: "k" (the reference mesh) or "k <label>" (another mesh rate)
_MESH_TRACK = re.compile(r"^\d+( [^;+\- ]+)?$")


def spectrum_figure(spectra: dict, *, unit: str = "", scale: float = 1.0, title: str = "",
                    max_order: float | None = None, label_fraction: float = 1e-3):
    """Figure of ``spectra`` {channel: :class:`~hacgear_core.spectra.spectrum.OrderSpectrum`}, one panel per
    channel: bin amplitudes (times ``scale``, in ``unit``) over mesh order on a log axis, the marked lines as
    symbols (mesh harmonics red circles, sidebands blue triangles, shaft orders green squares), labelled where
    their amplitude exceeds ``label_fraction`` of the panel's largest AC line.  ``max_order``: right end of the
    axis (default: the highest marked mesh harmonic's order + 0.5)."""
    n = len(spectra)
    fig, axes = plt.subplots(n, 1, figsize=(9.0, 2.9 * n + 0.4), squeeze=False)
    for ax, (name, sp) in zip(axes[:, 0], spectra.items()):
        o, amp = sp.mesh_order[1:], sp.amplitude[1:] * scale
        top = max(o[-1] if o.size else 1.0, 1.0)
        right = max_order or min(top, max([ln.mesh_order for ln in sp.lines if ln.family == "mesh"] + [1]) + 0.5)
        keep = o <= right
        floor = max(float(np.max(amp[keep])) * 1e-9, 1e-300) if np.any(keep) else 1e-300
        ax.semilogy(o[keep], np.maximum(amp[keep], floor), color="0.55", lw=0.7, label="bins")
        peak = float(np.max(amp[keep])) if np.any(keep) else 0.0
        seen = set()
        for ln in sp.lines:
            if ln.mesh_order > right:
                continue
            c, mk = _FAMILY_STYLE[ln.family]
            a = max(ln.amplitude * scale, floor)
            ax.plot(ln.mesh_order, a, mk, color=c, ms=5, mfc="none" if ln.amplitude * scale < peak * label_fraction
                    else c, label=None if ln.family in seen else {"mesh": "mesh harmonic k", "sideband":
                                                                "sideband k ± n shaft orders",
                                                                "shaft": "shaft order n"}[ln.family])
            seen.add(ln.family)
            if ln.amplitude * scale >= peak * label_fraction and peak > 0:
                ax.annotate(ln.label.split("; ")[0], (ln.mesh_order, a), xytext=(0, 4), textcoords="offset points",
                            ha="center", fontsize=6.5, color=c, rotation=90 if ln.family != "mesh" else 0)
        ax.set_xlim(0, right)
        ax.set_ylim(floor, max(peak, floor) * 30)
        ax.set_ylabel(f"amplitude [{unit}]" if unit else "amplitude")
        coh = "coherent, no window" if sp.coherent else "flat-top window"
        ax.set_title(f"{name}  ({sp.cycles_used:g} mesh cycles, {coh})", fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("mesh order  f / f_m  [-]")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def campbell_figure(result, *, title: str = "", show_shaft_lines: bool = True):
    """Figure of a :class:`~hacgear_core.spectra.campbell.CampbellResult`: natural frequencies (black, by rank)
    and order lines (mesh harmonics coloured, shaft orders grey dashed) over the input speed [rpm], crossings
    as red circles with their speed."""
    fig, ax = plt.subplots(figsize=(8.0, 5.5))
    rpm = result.input_speed_rpm
    f = result.natural_frequencies_Hz
    fmax = float(np.max(f)) * 1.1 if f.size else 1.0
    for i in range(f.shape[1]):
        ax.plot(rpm, f[:, i], color="k", lw=1.2, label="natural frequencies" if i == 0 else None)
    for j, ln in enumerate(result.lines):
        if ln.family == "shaft" and not show_shaft_lines:
            continue
        y = ln.hz_per_rad_s * result.input_speed_rad_s
        style = dict(color=f"C{j}", lw=1.0) if ln.family == "mesh" else dict(color="0.6", lw=0.8, ls="--")
        ax.plot(rpm, y, label=ln.label, **style)
    shown: list[tuple[str, float, float]] = []
    span = float(rpm[-1] - rpm[0])
    for c in result.crossings:
        ax.plot(c.input_speed_rpm, c.frequency_Hz, "o", color="C3", mfc="none", ms=6)
        near = any(ln == c.line and abs(r - c.input_speed_rpm) < 0.01 * span and abs(f - c.frequency_Hz) < 0.01 * fmax
                   for ln, r, f in shown)          # split modes of one family: one label
        if not near and any(ln.label == c.line and ln.family == "mesh" for ln in result.lines):
            shown.append((c.line, c.input_speed_rpm, c.frequency_Hz))
            ax.annotate(f"{c.input_speed_rpm:.0f}", (c.input_speed_rpm, c.frequency_Hz), xytext=(3, -9),
                        textcoords="offset points", fontsize=6.5, color="C3")
    ax.set_xlim(rpm[0], rpm[-1])
    ax.set_ylim(0, fmax)
    ax.set_xlabel(f"input speed ({result.input_gear}) [rpm]")
    ax.set_ylabel("frequency [Hz]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title(title or "Campbell diagram", fontsize=9)
    fig.tight_layout()
    return fig


def save_spectrum_figure(spectra: dict, path: str | Path, **kwargs) -> Path:
    """:func:`spectrum_figure` written to ``path`` (format from its suffix)."""
    fig = spectrum_figure(spectra, **kwargs)
    try:
        return save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)


def save_campbell_figure(result, path: str | Path, **kwargs) -> Path:
    """:func:`campbell_figure` written to ``path`` (format from its suffix)."""
    fig = campbell_figure(result, **kwargs)
    try:
        return save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)


def waterfall_figure(waterfalls: dict, *, unit: str = "", scale: float = 1.0, title: str = "",
                     max_order: float = 5.5, dynamic_range_dB: float = 80.0):
    """Figure of ``waterfalls`` {channel: :class:`~hacgear_core.spectra.waterfall.Waterfall`}, one row per
    channel: left the amplitude (dB re the largest, ``dynamic_range_dB`` shown) over mesh frequency and mesh order
    (order lines horizontal), right the mesh harmonics' tracks (amplitude of order k over the mesh frequency, times
    ``scale`` in ``unit``)."""
    n = len(waterfalls)
    fig, axes = plt.subplots(n, 2, figsize=(11.0, 3.6 * n + 0.4), squeeze=False,
                             gridspec_kw=dict(width_ratios=(1.4, 1.0)))
    for (ax, ax2), (name, wf) in zip(axes, waterfalls.items()):
        keep = (wf.mesh_order > 0) & (wf.mesh_order <= max_order)
        amp = wf.amplitude[:, keep]
        ref = float(np.max(amp)) if amp.size and np.max(amp) > 0 else 1.0
        db = 20 * np.log10(np.maximum(amp / ref, 10 ** (-dynamic_range_dB / 20)))
        im = ax.pcolormesh(wf.mesh_frequency_Hz, wf.mesh_order[keep], db.T, shading="nearest", cmap="viridis",
                           vmin=-dynamic_range_dB, vmax=0)
        fig.colorbar(im, ax=ax, label="dB re max")
        ax.set_xlabel("mesh frequency f_m [Hz]")
        ax.set_ylabel("mesh order [-]")
        ax.set_title(f"{name}: order spectrum over the run-up ({wf.segment_cycles} mesh cycles per segment)",
                     fontsize=9)
        for k, (label, tr) in enumerate((lb, t) for lb, t in wf.tracks.items() if _MESH_TRACK.match(lb)):
            ax2.semilogy(wf.mesh_frequency_Hz, np.maximum(tr * scale, 1e-300), color=f"C{k}", lw=1.2,
                         label=f"order {label}")
        ax2.set_xlabel("mesh frequency f_m [Hz]")
        ax2.set_ylabel(f"amplitude [{unit}]" if unit else "amplitude")
        ax2.grid(True, which="major", alpha=0.3)
        ax2.legend(fontsize=7)
        ax2.set_title("mesh harmonics (order tracks)", fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def save_waterfall_figure(waterfalls: dict, path: str | Path, **kwargs) -> Path:
    """:func:`waterfall_figure` written to ``path`` (format from its suffix)."""
    fig = waterfall_figure(waterfalls, **kwargs)
    try:
        return save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)
