"""Force laws: the HAC force-deflection function and the conventional lumped-parameter laws of
dissertation Section 3.5, all evaluated by the same compiled integrator.

=================  ========================================================  ===========
name               mesh force F(tau, x)                                      dissertation
=================  ========================================================  ===========
``hac``            FDF table lookup (bilinear), 0 below the NLMD             Sec. 3.2
``ste``            max(0, k_mean [x - x_s(tau)] + F_s)                       Eq. 3.6
``average_slope``  max(0, k_a(tau) [x - eps(tau)])                           Eq. 3.7
``local_slope``    max(0, k_l(tau) [x - x_s(tau)] + F_s)                     Eq. 3.8
=================  ========================================================  ===========

``x_s``, ``eps``, ``k_a = F_s / (x_s - eps)`` and ``k_l = dF/dx|x_s`` come from the same table at
the nominal static mesh force ``F_s = T_1 / r_b1`` (:func:`~hacgear_core.tables.fdf.static_stiffness`);
``k_mean`` is the cycle mean of ``k_a`` (so the STE and average-slope models share their mean
stiffness, as in the dissertation's Table of natural frequencies).  The contact-loss nonlinearity
(F >= 0) is kept in all laws.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hacgear_core.dynamics import kernels
from hacgear_core.tables.fdf import static_stiffness
from hacgear_core.errors import ModelError

__all__ = ["FORCE_LAWS", "ForceLaw", "make_force_law"]

FORCE_LAWS = ("hac", "ste", "average_slope", "local_slope")


@dataclass(frozen=True)
class ForceLaw:
    """A force law ready for the kernel: ``law`` (kernel code), ``lin`` (3, Np) arrays [k, e, f0]
    for the conventional laws (a dummy for ``hac``), and ``mean_stiffness_N_per_m`` (the stiffness
    of the linearisation used for modal damping and modal analysis)."""

    name: str
    law: int
    lin: np.ndarray
    mean_stiffness_N_per_m: float
    static_force_N: float


def make_force_law(table, name: str, static_force_N: float) -> ForceLaw:
    """Build force law ``name`` (one of :data:`FORCE_LAWS`) for ``table`` at mesh force ``static_force_N`` [N]."""
    if name not in FORCE_LAWS:
        raise ModelError(f"force law must be one of {FORCE_LAWS}, got {name!r}")
    st = static_stiffness(table, static_force_N)
    np_ = st.position.size
    if name == "hac":
        lin = np.zeros((3, 2))
        k = st.mean_local_slope_N_per_m
        return ForceLaw(name, kernels.LAW_TABLE, lin, k, float(static_force_N))
    if name == "ste":
        km = st.mean_average_slope_N_per_m
        lin = np.vstack([np.full(np_, km), st.deflection_m, np.full(np_, static_force_N)])
        k = km
    elif name == "average_slope":
        lin = np.vstack([st.average_slope_N_per_m, st.no_load_deflection_m, np.zeros(np_)])
        k = st.mean_average_slope_N_per_m
    else:
        lin = np.vstack([st.local_slope_N_per_m, st.deflection_m, np.full(np_, static_force_N)])
        k = st.mean_local_slope_N_per_m
    return ForceLaw(name, kernels.LAW_LINEAR, np.ascontiguousarray(lin), float(k), float(static_force_N))
