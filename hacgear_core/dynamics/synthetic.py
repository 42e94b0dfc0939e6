"""Synthetic mesh tables (tables contract) for tests, demonstrations and benchmarks.

These are **not** results of the static contact solver: they are made from an explicit per-tooth-pair
stiffness model so the dynamics can be developed and tested before real tables exist.  Everything
computed from them must be labelled *synthetic*.

Model (spur pair, mesh position ``tau`` in mesh cycles, integer ``tau`` = pitch-point contact of the
reference pair, offsets ``k`` = tooth pairs relative to the reference pair):

* pair ``k`` has the contact coordinate ``s = tau - k`` (mesh cycles from its pitch point) and is in
  the path of contact for ``-eps_c/2 <= s <= eps_c/2`` (``eps_c`` = contact ratio, pitch point centred);
* its stiffness is ``k_p(s) = k_pair (1 - c_var (2 s / eps_c)^2)`` (stiffest at the pitch point);
* its initial separation (no-load gap) from tip relief is parabolic,
  ``g(s) = C_a ((|s| - s_r) / (eps_c/2 - s_r))^2`` for ``|s| > s_r``, else 0;
* its force is ``F_k = k_p(s) max(0, x - g(s))``, the mesh force ``F = sum_k F_k``, so the
  no-load mesh deflection is ``min_k g(s_k)`` and ``F = 0`` below it (contact loss).

With the reference pair leaving and pair ``k = +1`` entering, a physical tooth that is the reference
pair at cycle 0 is offset ``-n`` at cycle ``n`` (convention used by :mod:`hacgear_core.response`).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from hacgear_core.dynamics.parameters import SpurPairParameters
from hacgear_core.tables import MeshTable
from hacgear_core.tables.interp import deflection_at_force

__all__ = [
    "spur_fdf_table",
    "linear_fdf_table",
    "disk_mass_inertia",
    "synthetic_28t_parameters",
    "softening_example",
]


def _make_table(**kw):
    """A :class:`hacgear_core.tables.MeshTable`, labelled as synthetic."""
    fields = dict(kw)
    fields.pop("synthetic", None)
    fields["solver"] = "synthetic (hacgear_core.dynamics.synthetic, not a contact solution)"
    return MeshTable(**fields)


def _static_deflections(force, x0, dx, nlmd, loads):
    """Load-control static deflections (Np, Nl) of an FDF: the NLMD at zero load, else the inverse of each row
    (:func:`~hacgear_core.tables.interp.deflection_at_force`)."""
    npos = force.shape[0]
    out = np.empty((npos, len(loads)))
    for k in range(npos):
        for m, fl in enumerate(loads):
            out[k, m] = nlmd[k] if fl <= 0 else deflection_at_force(force, x0, dx, k / npos, float(fl))
    return out


def spur_fdf_table(
    *,
    name: str = "m12",
    teeth: tuple[int, int] = (28, 28),
    module_m: float = 5e-3,
    pressure_angle_deg: float = 25.0,
    contact_ratio: float = 1.45,
    mean_stiffness_N_per_m: float = 150e6,
    stiffness_variation: float = 0.15,
    tip_relief_m: float = 0.0,
    relief_start: float = 0.5,
    nominal_torque_Nm: float = 300.0,
    max_force_factor: float = 4.0,
    n_positions: int = 128,
    n_deflections: int = 160,
    n_loads: int = 16,
    face_width_m: float = 15e-3,
    youngs_modulus_Pa: float = 201.5e9,
    poisson_ratio: float = 0.3,
    strain_per_N: float = 1.3e-7,
    gear_names: tuple[str, str] = ("pinion", "wheel"),
):
    """Synthetic spur-pair mesh table (see module docstring for the model).

    Parameters
    ----------
    contact_ratio : float
        Involute contact ratio, in (1, 2).
    mean_stiffness_N_per_m : float
        Mean over the mesh cycle of the summed pair stiffness (no relief) [N/m].
    stiffness_variation : float
        ``c_var`` in [0, 0.9]: drop of pair stiffness at the ends of its path relative to the pitch point.
    tip_relief_m : float
        Parabolic tip relief (initial separation at the ends of the path of contact) [m].
    relief_start : float
        Start of relief as a fraction of the half path of contact, in [0, 1).
    nominal_torque_Nm : float
        Torque on gear 1 used to size the deflection/load grids [N m].
    max_force_factor : float
        The deflection grid reaches the deflection carrying ``max_force_factor`` x nominal force in
        single contact.

    Returns
    -------
    MeshTable-like object with the tables-contract attributes (and ``synthetic = True`` when the
    local class is used).
    """
    if not 1.0 < contact_ratio < 2.0:
        raise ValueError(f"contact_ratio [-] must be in (1, 2), got {contact_ratio}")
    if not 0.0 <= stiffness_variation <= 0.9:
        raise ValueError(f"stiffness_variation [-] must be in [0, 0.9], got {stiffness_variation}")
    if not 0.0 <= relief_start < 1.0:
        raise ValueError(f"relief_start [-] must be in [0, 1), got {relief_start}")
    if tip_relief_m < 0:
        raise ValueError(f"tip_relief_m [m] must be >= 0, got {tip_relief_m}")
    alpha = math.radians(pressure_angle_deg)
    rb = tuple(0.5 * module_m * z * math.cos(alpha) for z in teeth)
    pb = 2 * math.pi * rb[0] / teeth[0]
    half = 0.5 * contact_ratio
    offsets = np.arange(-2, 3)
    pos = np.arange(n_positions) / n_positions
    # pair stiffness scale so that the cycle mean of the summed stiffness is the requested mean
    s_fine = np.linspace(-half, half, 20001)
    mean_shape = np.trapezoid(1 - stiffness_variation * (s_fine / half) ** 2, s_fine)  # per cycle
    k_pair = mean_stiffness_N_per_m / mean_shape
    fs_nom = nominal_torque_Nm / rb[0]
    k_min = k_pair * (1 - stiffness_variation)
    x_max = max_force_factor * fs_nom / k_min + tip_relief_m
    # the tables' grid rule (hacgear_core.statics.grid.deflection_grid): the first column one step below every
    # no-load deflection, so the force and strain are zero in the first two columns and below the grid
    dx = x_max / (n_deflections - 2)
    xd = -dx + dx * np.arange(n_deflections)
    s = pos[:, None] - offsets[None, :]  # (Np, Nw)
    inpath = np.abs(s) <= half + 1e-12
    kp = np.where(inpath, k_pair * (1 - stiffness_variation * (s / half) ** 2), 0.0)
    sr = relief_start * half
    g = np.where(np.abs(s) > sr, tip_relief_m * ((np.abs(s) - sr) / (half - sr)) ** 2, 0.0)
    g = np.where(inpath, g, np.inf)
    pen = xd[None, :, None] - g[:, None, :]  # (Np, Nd, Nw)
    tooth_load = np.where(inpath[:, None, :], kp[:, None, :] * np.maximum(pen, 0.0), 0.0)
    force = tooth_load.sum(axis=2)
    nlmd = np.min(g, axis=1)
    # contact roll angle on gear b's flank (deg): contact moves from gear b's tip towards its root
    roll_pitch_deg = math.degrees(math.tan(alpha))
    roll = roll_pitch_deg - s * 360.0 / teeth[1]
    roll = np.where(inpath[:, None, :] & (tooth_load > 0), roll[:, None, :], np.nan)
    # Hertz line contact: p = sqrt(w E* / (pi R')), w = load per face width
    e_star = youngs_modulus_Pa / (2 * (1 - poisson_ratio**2))
    rho1 = rb[0] * math.tan(alpha) + s * pb
    rho2 = rb[1] * math.tan(alpha) - s * pb
    r_eff = np.where(inpath, rho1 * rho2 / np.maximum(rho1 + rho2, 1e-12), 1.0)
    p = np.sqrt(np.maximum(tooth_load, 0.0) / face_width_m * e_star / (math.pi * r_eff[:, None, :]))
    peak_p = p.max(axis=2)
    # root strain at one gauge per gear: own-tooth load times a lever factor, neighbour compression
    lev_b = 0.6 + 0.4 * (half - s) / (2 * half)  # driven gear: contact starts at its tip
    lev_a = 0.6 + 0.4 * (s + half) / (2 * half)  # driving gear: contact ends at its tip
    strain = {}
    for gname, lev in ((gear_names[1], lev_b), (gear_names[0], lev_a)):
        own = strain_per_N * tooth_load * np.where(inpath, lev, 0.0)[:, None, :]
        nb = np.zeros_like(own)
        nb[:, :, :-1] -= 0.12 * strain_per_N * tooth_load[:, :, 1:]
        strain[f"{gname}/SG"] = own + nb
    loads = np.linspace(0.0, max_force_factor * fs_nom, n_loads)
    xstat = _static_deflections(force, xd[0], xd[1] - xd[0], nlmd, loads)
    return _make_table(
        name=name, gear_names=tuple(gear_names), teeth=tuple(int(z) for z in teeth),
        base_radius_m=rb, position=pos, deflection_m=xd, force_N=np.ascontiguousarray(force),
        no_load_deflection_m=nlmd, load_N=loads, static_deflection_m=xstat, tooth_offsets=offsets,
        tooth_load_N=tooth_load, contact_roll_deg=roll, peak_pressure_Pa=peak_p, strain=strain,
        synthetic=True,
    )


def linear_fdf_table(
    stiffness_N_per_m: float,
    *,
    teeth: tuple[int, int] = (28, 28),
    base_radius_m: tuple[float, float] = (0.0634, 0.0634),
    offset_amplitude_m: float = 0.0,
    offset_mean_m: float = 0.0,
    x_max_m: float = 400e-6,
    n_positions: int = 256,
    n_deflections: int = 64,
    name: str = "linear",
    coast_stiffness_N_per_m: float | None = None,
    backlash_m: float = 100e-6,
    coast_base_radius_m: tuple[float, float] | None = None,
):
    """Constant-stiffness FDF ``F = k max(0, x - e(tau))``, ``e = offset_mean + offset_amplitude
    sin(2 pi tau)`` on the deflection grid [0, ``x_max_m``].

    While the deflection stays above ``max e`` the dynamics are exactly linear with constant
    stiffness and a harmonic displacement (transmission-error) excitation: closed-form natural
    frequency and forced response.  Larger vibrations lose contact (``F = 0`` below ``e``, the
    NLMD): the classical piecewise-linear, softening gear oscillator.

    ``coast_stiffness_N_per_m``: add a coast side ``Fc = k_c max(0, xc - backlash_m)`` over the coast approach
    ``xc`` (grid [0, backlash + x_max]; coast base radii ``coast_base_radius_m``, default the drive ones): with
    rigid bearings and equal base-radius ratios ``xc = -x``, a piecewise-linear oscillator with a gap.
    """
    coast = None
    if coast_stiffness_N_per_m is not None:
        rbc = tuple(base_radius_m) if coast_base_radius_m is None else tuple(coast_base_radius_m)
        coast = linear_fdf_table(coast_stiffness_N_per_m, teeth=teeth, base_radius_m=rbc, offset_mean_m=backlash_m,
                                 x_max_m=backlash_m + x_max_m, n_positions=n_positions,
                                 n_deflections=2 * n_deflections, name=name)
        coast = replace(coast, side="coast", backlash_normal_m=float(backlash_m),
                        backlash_circular_m=float(backlash_m), position_offset=-0.5,
                        pair_shift={"gear1": 1, "gear2": 0})
    pos = np.arange(n_positions) / n_positions
    xd = np.linspace(0.0, x_max_m, n_deflections)
    e = offset_mean_m + offset_amplitude_m * np.sin(2 * np.pi * pos)
    force = np.maximum(stiffness_N_per_m * (xd[None, :] - e[:, None]), 0.0)
    z = np.zeros((n_positions, n_deflections, 1))
    return _make_table(
        name=name, gear_names=("gear1", "gear2"), teeth=tuple(teeth), base_radius_m=tuple(base_radius_m),
        position=pos, deflection_m=xd, force_N=np.ascontiguousarray(force),
        no_load_deflection_m=np.maximum(e, 0.0), load_N=np.array([0.0]),
        static_deflection_m=np.maximum(e, 0.0)[:, None], tooth_offsets=np.array([0]),
        tooth_load_N=force[:, :, None], contact_roll_deg=z + np.nan, peak_pressure_Pa=np.zeros_like(force),
        strain={}, synthetic=True, coast=coast,
    )


def disk_mass_inertia(density_kg_per_m3: float, face_width_m: float, tip_diameter_m: float,
                      root_diameter_m: float, bore_diameter_m: float, tooth_fill: float = 0.5):
    """Mass [kg] and polar inertia [kg m^2] of a gear blank: solid annulus bore..root plus the
    tooth ring root..tip filled to ``tooth_fill`` (teeth ~ half the ring)."""
    def ring(d_o, d_i, fill):
        m = fill * density_kg_per_m3 * math.pi / 4 * (d_o**2 - d_i**2) * face_width_m
        return m, 0.5 * m * ((d_o / 2) ** 2 + (d_i / 2) ** 2)

    m1, i1 = ring(root_diameter_m, bore_diameter_m, 1.0)
    m2, i2 = ring(tip_diameter_m, root_diameter_m, tooth_fill)
    return m1 + m2, i1 + i2


def synthetic_28t_parameters(table, *, bearing_stiffness_N_per_m: float = math.inf,
                             modal_damping_ratio: float = 0.02, torque_Nm: float = 300.0):
    """:class:`~hacgear_core.dynamics.parameters.SpurPairParameters` of the dissertation's 28-tooth pair
    (steel 7850 kg/m^3, face 15 mm, tip 149.9 mm, root 126.4 mm, bore 40 mm) on ``table``."""
    m, j = disk_mass_inertia(7850.0, 15e-3, 149.9e-3, 126.4e-3, 40e-3)
    return SpurPairParameters(
        mass_kg=(m, m), inertia_kg_m2=(j, j), base_radius_m=tuple(table.base_radius_m),
        teeth=tuple(table.teeth), bearing_stiffness_N_per_m=(bearing_stiffness_N_per_m,) * 2,
        modal_damping_ratio=modal_damping_ratio, torque_Nm=torque_Nm,
    )


def softening_example(damping_ratio: float = 0.03):
    """The classical softening oscillator used in tests and figures: constant mesh stiffness 150 N/um,
    a sinusoidal no-load deflection of 20 % of the static deflection (contact loss at large amplitude),
    28-tooth blanks, 100 N m.  Returns ``(params, table, static_deflection_m)``."""
    k, rb = 150e6, 0.0634
    xs0 = 100.0 / rb / k
    table = linear_fdf_table(k, offset_amplitude_m=0.2 * xs0, x_max_m=6 * xs0)
    params = SpurPairParameters(mass_kg=(1.6, 2.1), inertia_kg_m2=(0.0044, 0.0061), base_radius_m=(rb, rb),
                                teeth=(28, 28), modal_damping_ratio=damping_ratio, torque_Nm=100.0)
    return params, table, xs0
