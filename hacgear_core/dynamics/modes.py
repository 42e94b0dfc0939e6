"""Natural frequencies of a spur pair: linearised modal analysis and the impulse test.

Linearised modal analysis
    ``(K_s + k v v^T) phi = omega^2 M phi`` with ``k`` the cycle mean of the force law's
    stiffness at the nominal torque (for ``hac`` the local slope of the FDF at the static
    deflection, dissertation Eq. 3.8's ``k_l`` averaged over the cycle).  Rigid-body rotation modes
    (omega = 0) are reported separately.

Impulse test (dissertation Section 3.6.1)
    The gears rest in static equilibrium under the nominal load at a fixed mesh position (no
    rotation); an angular-velocity impulse on gear 1 (and a translational one when translations
    exist) starts a free vibration of small amplitude (1 % of the static deflection), integrated
    with the same kernel and force law (undamped).  The natural frequencies are the peaks of the
    Blackman-windowed, zero-padded spectrum of the mesh deflection and translations.  This is done at a
    single- and at a double-tooth-contact position (middle of the longest run of positions with one
    resp. two loaded pairs at the static load; from ``tooth_load_N`` when the table has it, else
    from the local slope: below/above the cycle mean), and the frequencies are combined with the
    contact-ratio weights: ``f = (2 - eps) f_single + (eps - 1) f_double`` with ``eps`` = 1 + the
    fraction of the cycle in double contact.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hacgear_core.dynamics.fdf import contact_count, static_stiffness
from hacgear_core.dynamics.spur import SpurPairSystem
from hacgear_core.errors import SolverError

__all__ = ["ModalResult", "ImpulseResult", "modal_analysis", "impulse_test", "contact_positions"]


@dataclass
class ModalResult:
    """Elastic modes of the linearised system: ``natural_frequencies_Hz`` ascending, ``mode_shapes``
    (n_dof, n_modes) scaled to max |component| = 1 (rotations as r_b * theta [m] so components
    compare), ``dof_names``, ``mesh_stiffness_N_per_m``, ``rigid_body_modes``."""

    natural_frequencies_Hz: np.ndarray
    mode_shapes: np.ndarray
    dof_names: tuple
    mesh_stiffness_N_per_m: float
    rigid_body_modes: int

    def to_json(self) -> dict:
        return {
            "natural_frequencies_Hz": self.natural_frequencies_Hz.tolist(),
            "mode_shapes": {"dof_names": list(self.dof_names),
                            "note": "columns per mode; rotations given as r_b*theta [m]",
                            "shapes": self.mode_shapes.T.tolist()},
            "mesh_stiffness_N_per_m": self.mesh_stiffness_N_per_m,
            "rigid_body_modes": self.rigid_body_modes,
        }


def modal_analysis(system: SpurPairSystem) -> ModalResult:
    """Linearised modal analysis of ``system`` at its nominal torque (see module docstring)."""
    omega = system.modal_omega
    phi = system.modal_shapes
    el = ~system.rigid_modes
    order = np.argsort(omega[el])
    w = omega[el][order]
    shapes = phi[:, el][:, order].copy()
    # rotations as arc length on the base circle so that components are comparable
    for i, nm in enumerate(system.dof_names):
        if nm == "th1":
            shapes[i] *= system.rb[0]
        elif nm == "th2":
            shapes[i] *= system.rb[1]
    for c in range(shapes.shape[1]):
        col = shapes[:, c]
        k = int(np.argmax(np.abs(col)))
        shapes[:, c] = col / col[k]
    return ModalResult(w / (2 * math.pi), shapes, system.dof_names, system.law.mean_stiffness_N_per_m,
                       int(np.sum(system.rigid_modes)))


def contact_positions(system: SpurPairSystem) -> tuple[float, float, float]:
    """(single-contact position, double-contact position, contact ratio estimate) at the nominal
    static force (see module docstring)."""
    table = system.table
    fs = system.params.static_force_N
    cnt = contact_count(table, fs)
    pos = np.asarray(table.position, float)
    if cnt is None or not (np.any(cnt == 1) and np.any(cnt >= 2)):
        st = static_stiffness(table, fs)
        kl = st.local_slope_N_per_m
        cnt = np.where(kl > np.mean(kl), 2, 1)
    eps = 1.0 + float(np.mean(cnt >= 2))

    def mid_of_longest(mask):
        n = mask.size
        if mask.all():
            return 0.0
        start = int(np.argmin(mask))  # a False entry: runs do not wrap across it
        best, best_len, i = None, 0, 0
        while i < n:
            j = (start + i) % n
            if mask[j]:
                k = i
                while k < n and mask[(start + k) % n]:
                    k += 1
                if k - i > best_len:
                    best_len, best = k - i, (start + i + (k - i - 1) / 2.0) % n
                i = k
            else:
                i += 1
        return float(pos[0] + best / n) if best is not None else 0.0

    return mid_of_longest(cnt == 1), mid_of_longest(cnt >= 2), eps


@dataclass
class ImpulseResult:
    """Impulse-test frequencies [Hz] (ascending peaks) at the single- and double-contact positions,
    their contact-ratio-weighted mean (when both have the same number of peaks), the positions
    [cycles] and the contact ratio used."""

    single_contact_Hz: np.ndarray
    double_contact_Hz: np.ndarray
    weighted_mean_Hz: np.ndarray
    single_position: float
    double_position: float
    contact_ratio: float

    def to_json(self) -> dict:
        return {"single_contact_Hz": self.single_contact_Hz.tolist(),
                "double_contact_Hz": self.double_contact_Hz.tolist(),
                "weighted_mean_Hz": self.weighted_mean_Hz.tolist(),
                "single_contact_position": self.single_position, "double_contact_position": self.double_position,
                "contact_ratio": self.contact_ratio}


def _free_vibration_peaks(system: SpurPairSystem, tau: float, periods: int = 400, rel_peak: float = 0.02):
    sy = SpurPairSystem(system.params.replace(modal_damping_ratio=0.0), system.table, system.law.name)
    n = sy.n
    s = sy.static_state(tau)
    fs = sy.params.static_force_N
    xs = max(abs(float(sy.v @ s[:n])), 1e-7)
    f_lo = max(min(sy.natural_frequencies_Hz()), 1.0)
    w_lo = 2 * math.pi * f_lo
    # velocity impulse: x' = 0.01 * xs * omega on gear 1's rotation, and on the translations
    s[n + sy.ith1] += 0.01 * xs * w_lo / sy.rb[0]
    for nm in ("y1", "y2"):
        if nm in sy.dof_names:
            s[n + sy.dof_names.index(nm)] += 0.005 * xs * w_lo
    dt = 1.0 / (32.0 * sy.max_frequency_Hz)
    nsteps = int(periods / f_lo / dt)
    nsteps = min(nsteps, 2_000_000)
    kin = np.array([tau - math.floor(tau), 0.0, 0.0])
    rs = np.zeros((nsteps, 2 * n))
    ro = np.zeros((nsteps, 5))
    sy.integrate(s, kin, nsteps, dt, sy.fext_speed(), rec_every=1, rec_state=rs, rec_out=ro)
    if not np.all(np.isfinite(rs)):
        raise SolverError("impulse test diverged")
    if np.any(ro[:, 2] <= 0):
        raise SolverError("impulse test lost contact: impulse too large for the static load")
    sigs = [ro[:, 1] - ro[:, 1].mean()]
    for nm in ("y1", "y2"):
        if nm in sy.dof_names:
            y = rs[:, sy.dof_names.index(nm)]
            sigs.append(y - y.mean())
    win = np.blackman(nsteps)  # side lobes -58 dB: below the peak threshold
    nfft = 1 << int(math.ceil(math.log2(8 * nsteps)))
    spec = np.zeros(nfft // 2 + 1)
    for sg in sigs:
        a = np.abs(np.fft.rfft(sg * win, nfft))
        if a.max() > 0:
            spec += a / a.max()
    freqs = np.fft.rfftfreq(nfft, dt)
    peaks = []
    thr = rel_peak * spec.max()
    for i in range(1, spec.size - 1):
        if spec[i] > thr and spec[i] >= spec[i - 1] and spec[i] > spec[i + 1] and freqs[i] > 0.2 * f_lo:
            y0, y1, y2 = np.log(spec[i - 1:i + 2] + 1e-300)
            d = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
            peaks.append((freqs[i] + d * (freqs[1] - freqs[0]), spec[i]))
    # merge peaks closer than 3 %: keep the strongest
    out = []
    for fpk, amp in sorted(peaks):
        if out and fpk <= out[-1][0] * 1.03:
            if amp > out[-1][1]:
                out[-1] = (fpk, amp)
        else:
            out.append((fpk, amp))
    out = sorted(out, key=lambda t: -t[1])[:n]
    out = [f for f, _ in sorted(out)]
    return np.array(out[: n])


def impulse_test(system: SpurPairSystem, positions: tuple[float, float] | None = None) -> ImpulseResult:
    """Impulse test at single- and double-contact positions (see module docstring)."""
    ps, pd, eps = contact_positions(system)
    if positions is not None:
        ps, pd = positions
    fsg = _free_vibration_peaks(system, ps)
    fdb = _free_vibration_peaks(system, pd)
    if fsg.size == fdb.size and fsg.size:
        mean = (2.0 - eps) * fsg + (eps - 1.0) * fdb
    else:
        mean = np.array([])
    return ImpulseResult(fsg, fdb, mean, ps, pd, eps)
