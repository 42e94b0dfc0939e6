"""The linearisation of a lumped system at its nominal torque, its modes, the modal damping and the step bound."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["LinearDynamics", "linear_dynamics", "sym_eig"]


@dataclass(frozen=True, eq=False)
class LinearDynamics:
    """A system linearised at its nominal torque (each mesh at the cycle mean of its law's stiffness on the loaded
    flanks; for ``hac`` the FDF's local slope): ``k_lin`` (n, n), ``mesh_stiffness_N_per_m`` (m,),
    ``generalized_stiffness`` (m, 2, 2) of the twist law (None otherwise), its modes ``modal_omega`` (n,) [rad/s]
    (ascending) and M-normalised ``modal_shapes`` (n, n), ``rigid_modes`` (n,) bool (zero frequency), the modal
    damping ``C = M Phi diag(2 zeta omega_r) Phi^T M`` (rigid modes undamped: the mean speed is kept) and
    ``max_frequency_Hz`` the highest frequency the integrator resolves (every mesh at its stiffest slope)."""

    k_lin: np.ndarray
    mesh_stiffness_N_per_m: np.ndarray
    generalized_stiffness: np.ndarray | None
    modal_omega: np.ndarray
    modal_shapes: np.ndarray
    rigid_modes: np.ndarray
    C: np.ndarray
    max_frequency_Hz: float


def sym_eig(k: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenpairs of K phi = w^2 M phi for symmetric K and SPD M: ascending w^2 and M-normalised shapes (numpy
    only: FMUs start faster without scipy.linalg)."""
    lo = np.linalg.cholesky(m)
    li = np.linalg.inv(lo)
    a = li @ k @ li.T
    w2, psi = np.linalg.eigh(0.5 * (a + a.T))
    return w2, li.T @ psi


def linear_dynamics(system) -> LinearDynamics:
    """The :class:`LinearDynamics` of ``system`` (a LumpedSystem) with its modal damping ratio."""
    law = system.mesh_law
    k_lin, kbar, gen = law.linearise(system)
    w2, phi = sym_eig(k_lin, system.M)
    w2 = np.clip(w2, 0.0, None)
    omega = np.sqrt(w2)
    rigid = omega < 1e-6 * max(omega.max(), 1.0)
    d = np.where(rigid, 0.0, 2.0 * system.modal_damping_ratio * omega)
    c = np.ascontiguousarray(system.M @ phi @ np.diag(d) @ phi.T @ system.M)
    w2max, _ = sym_eig(law.stiffest(system, kbar), system.M)
    return LinearDynamics(k_lin=k_lin, mesh_stiffness_N_per_m=kbar, generalized_stiffness=gen, modal_omega=omega,
                          modal_shapes=phi, rigid_modes=rigid, C=c,
                          max_frequency_Hz=float(np.sqrt(max(w2max.max(), 0.0)) / (2 * math.pi)))
