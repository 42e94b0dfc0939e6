"""The closed form the pitch-error spectra are checked against: the Fourier transform of the stiffness-share pulse
of one tooth (the tests of tests/test_gear_errors.py and tests/test_gear_errors_helical.py)."""
from __future__ import annotations

import numpy as np

from hacgear_core.dynamics.gear_errors import load_shares


def share_transform(table, force_N: float, n: int = 512):
    """``G(nu)``: the Fourier transform at ``nu`` [1/mesh cycle] of the pulse one tooth's error makes through the
    tooth pairs' stiffness shares (:func:`~hacgear_core.dynamics.gear_errors.load_shares` of ``table`` at the static
    force ``force_N`` [N], sampled at ``n`` positions per cycle), each pair at its own phase ``tau - o``."""
    tau = np.arange(n) / n
    sh = load_shares(table, force_N, tau)

    def G(nu):
        return sum(np.sum(sh[:, w] * np.exp(-2j * np.pi * nu * (tau - o))) / n
                   for w, o in enumerate(table.tooth_offsets))
    return G
