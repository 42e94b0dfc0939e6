"""Analytical near field of a line contact: Hertz theory and the elastic half-space.

The finite-element far field (:mod:`hacgear_core.statics.fe`) cannot resolve the displacement
under a concentrated contact load: in 2D it grows like ``ln(1/h)`` with the element
size ``h``.  The contact model therefore reads the finite-element normal displacement at
a depth ``d`` below the contact point (where the mesh does resolve the field) and adds
the analytical approach between the surface and that depth, taken from the elastic
half-space loaded by a Hertz pressure distribution.  This module holds those closed
forms and the discrete half-space kernel used to check them.

Conventions
-----------
* Loads are **per unit face width**: ``w`` [N/m] (a slice of width ``b`` carrying ``F``
  newtons has ``w = F / b``).
* ``plane="stress"`` (thin slices, the default of the whole project) uses
  ``E' = E`` and ``nu' = nu/(1+nu)`` in the plane-strain formulas; ``plane="strain"``
  uses ``E' = E/(1-nu^2)``.  Both bodies of a pair must use the same ``plane``.
* "Approach" is positive when the surface moves towards the depth point (compression).

Closed forms (plane stress, per body, Hertz pressure of half-width ``a``)::

    approach(surface centre -> depth d on the axis) = 2 w/(pi E) [ln(2 d/a) - nu/2]

(plane strain: ``2 w (1-nu^2)/(pi E) [ln(2d/a) - nu/(2(1-nu))]``), obtained by
integrating the axial strain of the Hertz stress field from 0 to ``d`` (``d >> a``;
the exact finite-``d`` form with ``asinh`` is used here).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hacgear_core.errors import ModelError

__all__ = [
    "plane_modulus",
    "effective_modulus",
    "HertzLineContact",
    "hertz_line_contact",
    "halfspace_approach_hertz",
    "halfspace_approach_point",
    "halfspace_strip_kernel",
]

_PLANES = ("stress", "strain")


def _check_plane(plane: str) -> None:
    if plane not in _PLANES:
        raise ModelError(f"plane must be 'stress' or 'strain', got {plane!r}")


def _check_material(E: float, nu: float, name: str = "") -> None:
    if not (np.isfinite(E) and E > 0):
        raise ModelError(f"youngs_modulus_Pa{name} must be a finite value > 0 Pa, got {E!r}")
    if not (np.isfinite(nu) and -1.0 < nu < 0.5):
        raise ModelError(f"poisson_ratio{name} must lie in (-1, 0.5), got {nu!r}")


def plane_modulus(youngs_modulus_Pa: float, poisson_ratio: float, plane: str = "stress") -> float:
    """In-plane modulus ``E'`` [Pa]: ``E`` (plane stress) or ``E/(1-nu^2)`` (plane strain)."""
    _check_plane(plane)
    _check_material(youngs_modulus_Pa, poisson_ratio)
    if plane == "stress":
        return float(youngs_modulus_Pa)
    return float(youngs_modulus_Pa) / (1.0 - poisson_ratio**2)


def effective_modulus(E1_Pa: float, nu1: float, E2_Pa: float, nu2: float,
                      plane: str = "stress") -> float:
    """Contact modulus ``E*`` [Pa] of two bodies: ``1/E* = 1/E1' + 1/E2'``.

    With ``plane="strain"`` this is the textbook ``[(1-nu1^2)/E1 + (1-nu2^2)/E2]^-1``.
    """
    return 1.0 / (1.0 / plane_modulus(E1_Pa, nu1, plane) + 1.0 / plane_modulus(E2_Pa, nu2, plane))


@dataclass(frozen=True)
class HertzLineContact:
    """Hertz line contact of two cylinders (per unit face width).

    Attributes
    ----------
    half_width_m : float
        Contact half-width ``a = sqrt(4 w R / (pi E*))`` [m].
    peak_pressure_Pa : float
        ``p0 = sqrt(w E* / (pi R)) = 2 w / (pi a)`` [Pa].
    effective_radius_m : float
        ``R = (1/R1 + 1/R2)^-1`` [m] (concave body: negative radius).
    effective_modulus_Pa : float
        ``E*`` [Pa].
    load_per_width_N_m : float
        ``w`` [N/m].
    """

    half_width_m: float
    peak_pressure_Pa: float
    effective_radius_m: float
    effective_modulus_Pa: float
    load_per_width_N_m: float

    def pressure(self, x_m: np.ndarray) -> np.ndarray:
        """Hertz pressure ``p0 sqrt(1 - x^2/a^2)`` [Pa] at offsets ``x_m`` [m] (0 outside)."""
        x = np.asarray(x_m, dtype=float) / self.half_width_m
        return self.peak_pressure_Pa * np.sqrt(np.clip(1.0 - x * x, 0.0, None))


def hertz_line_contact(load_per_width_N_m: float, R1_m: float, R2_m: float,
                       E1_Pa: float, nu1: float, E2_Pa: float | None = None,
                       nu2: float | None = None, plane: str = "stress") -> HertzLineContact:
    """Hertz closed form for two cylinders in line contact.

    Parameters
    ----------
    load_per_width_N_m : float
        Normal load per unit face width ``w = P/b`` [N/m], >= 0.
    R1_m, R2_m : float
        Radii of curvature [m]; convex > 0, concave < 0 (internal mesh); ``np.inf`` for a flat.
    E1_Pa, nu1, E2_Pa, nu2 : float
        Elastic constants (body 2 defaults to body 1).
    plane : {"stress", "strain"}

    Returns
    -------
    HertzLineContact
        ``a = sqrt(4 w R/(pi E*))``, ``p0 = sqrt(w E*/(pi R))`` (the brief's
        ``sqrt(P E*/(pi b R))`` with ``w = P/b``).
    """
    if E2_Pa is None:
        E2_Pa = E1_Pa
    if nu2 is None:
        nu2 = nu1
    w = float(load_per_width_N_m)
    if not (np.isfinite(w) and w >= 0):
        raise ModelError(f"load_per_width_N_m must be finite and >= 0 N/m, got {load_per_width_N_m!r}")
    k = 0.0
    for name, R in (("R1_m", R1_m), ("R2_m", R2_m)):
        if R == 0 or np.isnan(R):
            raise ModelError(f"{name} must be a non-zero radius of curvature in m (inf for flat), got {R!r}")
        k += 0.0 if np.isinf(R) else 1.0 / R
    if not k > 0:
        raise ModelError(f"combined curvature 1/R1 + 1/R2 must be > 0 1/m (conforming or diverging surfaces "
                         f"are not a Hertz contact), got R1_m={R1_m!r}, R2_m={R2_m!r}")
    R = 1.0 / k
    Es = effective_modulus(E1_Pa, nu1, E2_Pa, nu2, plane)
    a = np.sqrt(4.0 * w * R / (np.pi * Es))
    p0 = np.sqrt(w * Es / (np.pi * R))
    return HertzLineContact(float(a), float(p0), float(R), float(Es), w)


def halfspace_approach_hertz(load_per_width_N_m, half_width_m, depth_m, youngs_modulus_Pa: float,
                             poisson_ratio: float, plane: str = "stress"):
    """Approach of one body's surface centre towards the point at depth ``d`` under it.

    Elastic half-space under a Hertz pressure of total ``w`` [N/m] and half-width ``a``;
    exact for any ``d/a`` (the asinh form); for ``d >> a`` it is
    ``2w/(pi E')[ln(2d/a) - nu'/(2(1-nu'))]`` = (plane stress) ``2w/(pi E)[ln(2d/a) - nu/2]``.

    Parameters
    ----------
    load_per_width_N_m, half_width_m, depth_m : float or array (broadcast)
        ``w`` [N/m], ``a`` [m] (> 0), ``d`` [m] (> 0).

    Returns
    -------
    ndarray
        Approach [m] (positive = compression).
    """
    _check_plane(plane)
    _check_material(youngs_modulus_Pa, poisson_ratio)
    w = np.asarray(load_per_width_N_m, dtype=float)
    a = np.asarray(half_width_m, dtype=float)
    d = np.asarray(depth_m, dtype=float)
    if np.any(~(a > 0)) or np.any(~(d > 0)):
        raise ModelError("half_width_m and depth_m must be > 0 m")
    Ep = plane_modulus(youngs_modulus_Pa, poisson_ratio, plane)
    nup = poisson_ratio / (1.0 + poisson_ratio) if plane == "stress" else poisson_ratio
    # plane-strain-form integrals of sigma_z and sigma_x along the axis, 0..d, divided by p0*a
    t = d / a
    Iz = np.arcsinh(t)                              # int a/sqrt(a^2+z^2) dz / a
    Ix = t * np.sqrt(1.0 + t * t) - t * t           # int [(a^2+2z^2)/sqrt(a^2+z^2) - 2z] dz / a^2
    p0a = 2.0 * w / np.pi
    # eps_z = ((1-nu'^2) sigma_z - nu'(1+nu') sigma_x)/E'' with E'' the 3D-equivalent modulus:
    # written with E' = E''/(1-nu'^2): eps_z = (sigma_z - nu'/(1-nu') sigma_x)/E'
    return p0a * (Iz - nup / (1.0 - nup) * Ix) / Ep


def halfspace_approach_point(load_per_width_N_m, offset_m, depth_m, youngs_modulus_Pa: float,
                             poisson_ratio: float, plane: str = "stress"):
    """Approach of a surface point towards the point at depth ``d`` under it, for a
    concentrated (Flamant) line load ``w`` at horizontal distance ``x`` (x != 0).

    ``(w/(pi E'))[ln(1 + d^2/x^2) - (1 + nu'')d^2/(x^2 + d^2)]`` with ``nu'' = nu``
    (plane stress) or ``nu/(1-nu)`` (plane strain); tends to 0 like ``d^2/x^2`` far away.
    Used for the mutual near-field correction between two contact points on one flank.
    """
    _check_plane(plane)
    _check_material(youngs_modulus_Pa, poisson_ratio)
    w = np.asarray(load_per_width_N_m, dtype=float)
    x2 = np.asarray(offset_m, dtype=float) ** 2
    d2 = np.asarray(depth_m, dtype=float) ** 2
    if np.any(x2 <= 0):
        raise ModelError("offset_m must be non-zero for a point load (use halfspace_approach_hertz at x=0)")
    Ep = plane_modulus(youngs_modulus_Pa, poisson_ratio, plane)
    nup = poisson_ratio / (1.0 + poisson_ratio) if plane == "stress" else poisson_ratio
    nuq = nup / (1.0 - nup)       # = nu in plane stress
    return w / (np.pi * Ep) * (np.log1p(d2 / x2) - (1.0 + nuq) * d2 / (x2 + d2))


def halfspace_strip_kernel(x_m: np.ndarray, centres_m: np.ndarray, half_width_m: float,
                           youngs_modulus_Pa: float, poisson_ratio: float,
                           plane: str = "stress") -> np.ndarray:
    """Surface normal displacement of an elastic half-space under uniform strips.

    ``K[i, j]`` [m per Pa] is the inward surface displacement at ``x_m[i]`` caused by a
    unit pressure on the strip ``[c_j - h, c_j + h]`` (``h = half_width_m``):
    ``-(2/(pi E')) int ln|x - xi| dxi``.  The 2D half-space displacement is defined up to a
    rigid constant; this kernel fixes it at a reference distance of 1 m, so only
    differences (and gaps with a free rigid approach) are meaningful.

    Shapes: ``x_m`` (n,), ``centres_m`` (m,) -> (n, m).
    """
    Ep = plane_modulus(youngs_modulus_Pa, poisson_ratio, plane)
    h = float(half_width_m)
    if not h > 0:
        raise ModelError(f"half_width_m must be > 0 m, got {half_width_m!r}")
    x = np.asarray(x_m, dtype=float)[:, None] - np.asarray(centres_m, dtype=float)[None, :]

    def F(t):  # antiderivative of ln|t|: t ln|t| - t (0 at t = 0)
        at = np.abs(t)
        with np.errstate(divide="ignore", invalid="ignore"):
            v = np.where(at > 0, t * np.log(np.where(at > 0, at, 1.0)), 0.0)
        return v - t

    integral = F(x + h) - F(x - h)       # int_{c-h}^{c+h} ln|x - xi| dxi
    return -(2.0 / (np.pi * Ep)) * integral
