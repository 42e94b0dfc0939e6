"""ISO 21771 / ISO 53 closed forms: gear data as engineers give it → the transverse form the geometry core reads.

A gear of the ISO form (``[[gears]]`` with ``normal_module_mm``, :class:`~hacgear_core.model.schema.IsoGear`) is
converted once, at load, to the dissertation's transverse form (:class:`~hacgear_core.model.schema.Gear`: transverse
module, transverse pressure angle, tip and root diameters, transverse tooth thickness on the reference circle, tool
tip radius); this module holds the equations of that conversion and the mesh relations ``hacgear info`` reports.
Pure arithmetic on floats (SI: metres, radians), no geometry solve.

Equations (ISO 21771:2007; z > 0 here, internal gears flagged, diameters and centre distances positive as in ISO 21771)::

    tan(alpha_t) = tan(alpha_n) / cos(beta)          m_t = m_n / cos(beta)
    d   = z m_t                                      d_b = d cos(alpha_t)
    d_a = d + 2 m_n (h_aP* + x + k)      external;   d - 2 m_n (h_aP* + x + k)  internal
    d_f = d - 2 m_n (h_fP* - x)          external;   d + 2 m_n (h_fP* - x)      internal
    s_n = m_n (pi/2 + 2 x tan(alpha_n)) + A_sn        s_t = s_n / cos(beta)
    inv(alpha_wt) = inv(alpha_t) + 2 tan(alpha_n) (x_1 + x_2) / (z_1 + z_2)
    a_w = a cos(alpha_t) / cos(alpha_wt),  a = m_t (z_1 + z_2) / 2
    eps_beta = b sin(beta) / (pi m_n)

Sign convention of an internal gear (ISO 21771 as DIN 3960): its tooth count enters the mesh relations negative
(``z_1 + z_2`` is ``z_pinion - z_ring``), its diameters are positive, and its profile shift ``x`` is positive when
the basic rack's datum line moves towards the tips of its teeth, i.e. towards the gear axis: a positive ``x`` thickens
the ring's teeth (``s_n`` as above) and shrinks its tip and root diameters.  The tooth thickness allowance ``A_sn``
(normal, on the reference cylinder, usually negative) thins the tooth, external or internal (DIN 3967).
"""
from __future__ import annotations

import math

__all__ = ["BASIC_RACKS", "MIN_TIP_THICKNESS_FACTOR", "involute", "inverse_involute", "transverse_pressure_angle",
           "transverse_module", "reference_diameter", "tip_diameter", "tip_alteration", "root_diameter",
           "normal_tooth_thickness", "working_pressure_angle", "working_center_distance",
           "center_distance_pressure_angle", "face_contact_ratio", "mesh_tooth_count"]

#: The basic rack profiles of ISO 53:1998 (alpha_P = 20 deg), each (h_aP*, h_fP*, rho_fP*) in units of m_n:
#: A (high torque, 0.38 root radius), B (0.30), C (0.25), D (high-precision ground, full 0.39 root radius, 1.40 dedendum).
BASIC_RACKS: dict[str, tuple[float, float, float]] = {
    "A": (1.0, 1.25, 0.38),
    "B": (1.0, 1.25, 0.30),
    "C": (1.0, 1.25, 0.25),
    "D": (1.0, 1.40, 0.39),
}

#: Smallest normal tooth thickness at the tip circle a gear of the ISO form may have, in units of m_n: the design
#: office's usual minimum s_an >= 0.2 m_n (a rule of thumb for through-hardened teeth, e.g. Niemann/Winter,
#: Maschinenelemente II; case-hardened teeth want more).  ISO 21771 itself sets no limit.
MIN_TIP_THICKNESS_FACTOR = 0.2


def involute(alpha: float) -> float:
    """``inv(alpha) = tan(alpha) - alpha`` [rad]."""
    return math.tan(alpha) - alpha


def inverse_involute(value: float) -> float:
    """The angle ``alpha`` in [0, pi/2) [rad] with ``inv(alpha) = value`` (Newton from Cheng's start, to round-off)."""
    if not value >= 0.0 or not math.isfinite(value):
        raise ValueError(f"inverse_involute: {value!r} is no involute-function value (>= 0)")
    if value == 0.0:
        return 0.0
    a = (3.0 * value) ** (1.0 / 3.0)   # inv(a) ~ a^3 / 3 for small a
    a = min(a, 1.5)
    for _ in range(60):
        t = math.tan(a)
        step = (t - a - value) / (t * t)   # d inv / d alpha = tan^2(alpha)
        a_new = a - step
        if a_new <= 0.0:
            a_new = 0.5 * a
        if a_new >= 0.5 * math.pi:
            a_new = 0.5 * (a + 0.5 * math.pi)
        if abs(a_new - a) <= 1e-16 * max(1.0, a):
            return a_new
        a = a_new
    return a


def transverse_pressure_angle(alpha_n: float, beta: float) -> float:
    """``alpha_t = atan(tan(alpha_n) / cos(beta))`` [rad] (``beta`` the reference helix angle, either sign)."""
    return math.atan(math.tan(alpha_n) / math.cos(beta))


def transverse_module(m_n: float, beta: float) -> float:
    """``m_t = m_n / cos(beta)`` [m]."""
    return m_n / math.cos(beta)


def reference_diameter(z: int, m_n: float, beta: float) -> float:
    """``d = z m_n / cos(beta)`` [m] (positive for internal gears too)."""
    return z * m_n / math.cos(beta)


def tip_diameter(z: int, m_n: float, beta: float, h_ap: float, x: float, k: float, internal: bool) -> float:
    """``d_a = d +- 2 m_n (h_aP* + x + k)`` [m] (``-`` for an internal gear; ``k`` the tip alteration coefficient)."""
    d = reference_diameter(z, m_n, beta)
    h = 2.0 * m_n * (h_ap + x + k)
    return d - h if internal else d + h


def tip_alteration(z: int, m_n: float, beta: float, h_ap: float, x: float, d_a: float, internal: bool) -> float:
    """The tip alteration coefficient ``k`` [-] that gives tip diameter ``d_a`` [m] (inverse of :func:`tip_diameter`)."""
    d = reference_diameter(z, m_n, beta)
    return ((d - d_a) if internal else (d_a - d)) / (2.0 * m_n) - h_ap - x


def root_diameter(z: int, m_n: float, beta: float, h_fp: float, x: float, internal: bool) -> float:
    """``d_f = d -+ 2 m_n (h_fP* - x)`` [m] (``+`` for an internal gear), the nominal root diameter of ISO 21771."""
    d = reference_diameter(z, m_n, beta)
    h = 2.0 * m_n * (h_fp - x)
    return d + h if internal else d - h


def normal_tooth_thickness(m_n: float, alpha_n: float, x: float, allowance: float = 0.0) -> float:
    """``s_n = m_n (pi/2 + 2 x tan(alpha_n)) + A_sn`` [m] on the reference cylinder (external and internal, ISO sign)."""
    return m_n * (0.5 * math.pi + 2.0 * x * math.tan(alpha_n)) + allowance


def mesh_tooth_count(z: int, internal: bool) -> int:
    """The tooth count as it enters the mesh relations: ``-z`` for an internal gear (ISO 21771, DIN 3960)."""
    return -z if internal else z


def working_pressure_angle(alpha_n: float, beta: float, z1: int, z2: int, x1: float, x2: float) -> float:
    """Operating transverse pressure angle [rad] of a backlash-free pair with profile shifts ``x1``, ``x2``:
    ``inv(alpha_wt) = inv(alpha_t) + 2 tan(alpha_n) (x1 + x2) / (z1 + z2)`` (signed tooth counts,
    :func:`mesh_tooth_count`)."""
    alpha_t = transverse_pressure_angle(alpha_n, beta)
    return inverse_involute(involute(alpha_t) + 2.0 * math.tan(alpha_n) * (x1 + x2) / (z1 + z2))


def working_center_distance(m_n: float, alpha_n: float, beta: float, z1: int, z2: int, x1: float,
                            x2: float) -> float:
    """Centre distance [m] of a backlash-free pair (nominal thicknesses): ``a_w = a cos(alpha_t) / cos(alpha_wt)``,
    ``a = m_t |z1 + z2| / 2`` (signed tooth counts; positive result, internal pairs too)."""
    alpha_t = transverse_pressure_angle(alpha_n, beta)
    a = 0.5 * transverse_module(m_n, beta) * abs(z1 + z2)
    return a * math.cos(alpha_t) / math.cos(working_pressure_angle(alpha_n, beta, z1, z2, x1, x2))


def center_distance_pressure_angle(m_n: float, alpha_n: float, beta: float, z1: int, z2: int, a_w: float) -> float:
    """Operating transverse pressure angle [rad] at centre distance ``a_w`` [m]: ``cos(alpha_wt) = a cos(alpha_t) /
    a_w`` (signed tooth counts)."""
    alpha_t = transverse_pressure_angle(alpha_n, beta)
    a = 0.5 * transverse_module(m_n, beta) * abs(z1 + z2)
    return math.acos(a * math.cos(alpha_t) / a_w)


def face_contact_ratio(b: float, m_n: float, beta: float) -> float:
    """Overlap ratio ``eps_beta = b sin|beta| / (pi m_n)`` [-] (``b`` the common face width [m])."""
    return b * abs(math.sin(beta)) / (math.pi * m_n)
