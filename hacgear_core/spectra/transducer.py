"""What a transducer fixed on the housing of a planetary set sees: the ring-planet mesh forces weighted by each
planet's angular distance to the transducer, and which sidebands of the mesh harmonics that sum can hold.

Signal.  The transducer sits at the fixed angle ``theta_T``; planet ``i`` (at ``psi_i`` in the carrier frame)
passes it as the carrier turns, at the fixed-frame angle ``theta_c(t) + psi_i``.  The transducer picks up each
ring-planet mesh force ``F_i(t)`` through a window ``w`` of that planet's angular distance to it (the transfer
path through the ring: strong while the planet is near, nothing when it is far)::

    s(t) = sum_i w(theta_c(t) + psi_i - theta_T) F_i(t)

``w`` a Hann window ``cos^2(pi d / (2 h))`` of the wrapped distance ``d`` in ``[-pi, pi)``, 0 beyond the half
width ``h`` (:func:`fixed_transducer_signal`); the window of McFadden & Smith (1985) and Inalpolat & Kahraman
(2009) is of this kind.

Sideband rule (McFadden & Smith 1985, "An explanation for the asymmetry of the modulation sidebands about the
tooth meshing frequency in epicyclic gear vibration", Proc. IMechE C 199, 65-70).  Write the mesh force of
planet ``i`` over its mesh position ``c_i = c + phi_i`` (``phi_i`` the mesh's phase, cycles) as ``F_i = sum_m
A_m exp(j 2 pi m c_i)`` and the window of the carrier angle as ``w = sum_k W_k exp(j k (theta_c + psi_i -
theta_T))``.  With the carrier turning ``r`` revolutions per mesh cycle relative to the transducer (``theta_c =
2 pi r c``; a fixed ring: ``r = 1 / z_r``), the product of harmonic ``m`` and window order ``k`` is at carrier
order ``m / r + k``, i.e. at ``m f_m + k f_c`` (``f_c`` the carrier's frequency relative to the transducer,
signed with ``r``), and the planets add with the factor (:func:`planet_sum_factor`)::

    P(m, k) = (1 / N) sum_i exp(j (2 pi m phi_i + k psi_i))

Identical planets (the same ``A_m``) put ``N A_m W_k P(m, k)`` there.  For ``N`` equally spaced planets
(``psi_i = 2 pi (i - 1) / N``) on a fixed ring, ``phi_i = phi_1 - z_r (i - 1) / N`` (mod 1: the ring mesh
delays of :mod:`hacgear_core.geometry.planetary`), so ``|P| = 1`` where ``m z_r + k`` is a multiple of ``N`` and
0 elsewhere: in-phase planets (``z_r`` a multiple of ``N``) keep the mesh harmonics and the sidebands ``k = N,
2N, ..``; sequentially phased planets lose the mesh harmonics whose ``m z_r`` is no multiple of ``N`` and keep
the sidebands ``k = -m z_r (mod N)`` (asymmetric about the harmonic).  Planets that differ (a pin position error,
a runout: unequal loads, each planet's own force) break the cancellation and fill the other sidebands.
"""
from __future__ import annotations

import math

import numpy as np

from hacgear_core.errors import ModelError

__all__ = ["transducer_window", "fixed_transducer_signal", "planet_sum_factor", "carrier_order_amplitudes"]


def transducer_window(distance_rad, half_width_rad: float) -> np.ndarray:
    """Hann window ``cos^2(pi d / (2 h))`` of the angular distances ``distance_rad`` (...) [rad] (wrapped into
    ``[-pi, pi)``), 0 where ``|d| >= h``; ``half_width_rad`` ``h`` [rad] in (0, pi]."""
    h = float(half_width_rad)
    if not (0.0 < h <= math.pi):
        raise ModelError(f"half_width_rad [rad] must be in (0, pi], got {half_width_rad!r}")
    d = np.mod(np.asarray(distance_rad, float) + math.pi, 2.0 * math.pi) - math.pi
    return np.where(np.abs(d) < h, np.cos(0.5 * math.pi * d / h) ** 2, 0.0)


def fixed_transducer_signal(planet_forces_N, carrier_angle_rad, planet_angles_rad, *,
                            transducer_angle_rad: float = 0.0, half_width_rad: float | None = None) -> np.ndarray:
    """The signal (nt,) [N] of a transducer fixed at ``transducer_angle_rad`` [rad]: ``sum_i w(theta_c + psi_i -
    theta_T) F_i`` (module docstring).

    Parameters
    ----------
    planet_forces_N : array (nt, N)
        Each planet's ring-planet mesh force [N] at the ``nt`` samples.
    carrier_angle_rad : array (nt,)
        The carrier's angle in the transducer's (fixed) frame [rad] at the samples.
    planet_angles_rad : array (N,)
        The planets' angles in the carrier frame [rad], counted in the carrier angle's sense.
    half_width_rad : float, optional
        The window's half width [rad] (:func:`transducer_window`); default one planet spacing ``2 pi / N``.
    """
    f = np.asarray(planet_forces_N, float)
    th = np.asarray(carrier_angle_rad, float)
    psi = np.asarray(planet_angles_rad, float)
    if f.ndim != 2 or f.shape != (th.size, psi.size):
        raise ModelError(f"planet_forces_N must be (samples, planets) = ({th.size}, {psi.size}), got {f.shape}")
    h = 2.0 * math.pi / psi.size if half_width_rad is None else float(half_width_rad)
    w = transducer_window(th[:, None] + psi[None, :] - float(transducer_angle_rad), min(h, math.pi))
    return np.sum(w * f, axis=1)


def planet_sum_factor(mesh_phases_cycles, planet_angles_rad, harmonic: int, order: int) -> complex:
    """``P(m, k) = (1 / N) sum_i exp(j (2 pi m phi_i + k psi_i))`` (module docstring): how identical planets add
    at ``m f_m + k f_c`` (``harmonic`` ``m``, carrier order ``order`` ``k``) for the ring meshes' phases
    ``mesh_phases_cycles`` (N,) [cycles] and the planets' angles ``planet_angles_rad`` (N,) [rad]."""
    ph = np.asarray(mesh_phases_cycles, float)
    psi = np.asarray(planet_angles_rad, float)
    return complex(np.mean(np.exp(1j * (2.0 * math.pi * int(harmonic) * ph + int(order) * psi))))


def carrier_order_amplitudes(signal, revolutions: int) -> np.ndarray:
    """Amplitudes (ns // 2 + 1,) of a signal sampled evenly over ``revolutions`` whole carrier revolutions, at
    carrier orders ``0, 1, 2, ..`` (one-sided: ``2 |X_n| / ns``, the mean at order 0)."""
    s = np.asarray(signal, float)
    rev = int(revolutions)
    if rev < 1 or s.size % rev:
        raise ModelError(f"revolutions [-] must be a whole number >= 1 that divides the {s.size} samples, got "
                         f"{revolutions!r}")
    a = np.abs(np.fft.rfft(s)) * 2.0 / s.size
    a[0] *= 0.5
    return a[::rev]
