"""Physical sanity checks of mesh tables: what no correct static contact solution can contain.

:func:`hard_problems` (run by every read of a complete table) finds values that only corruption or a broken
solver produce: non-finite grids, forces, loads, pressures or strains; negative forces; magnitudes far beyond
the load grid (a force of 8.7e299 N in a table whose largest static load is 40 kN).  :func:`sanity_problems`
(``hacgear statics --check``) adds the properties a correct table has: the force is zero where the teeth do not
touch and non-decreasing in the mesh deflection, the static deflection is non-decreasing in the load, the
grids are regular and the tooth loads add up to the mesh force.  Both return a list of one-line problems (empty:
fine).  :func:`resolution_notes` says when the grids are coarse (a note, not an error).
"""
from __future__ import annotations

import numpy as np

from hacgear_core.tables.table import MeshTable

__all__ = ["hard_problems", "sanity_problems", "resolution_notes", "pressure_notes", "LIMITS", "TOLERANCES",
           "STEEL_PRESSURE_LIMIT_PA"]

#: plausibility bounds (SI): far outside anything a gear mesh produces, far inside what corruption gives
LIMITS = {
    "force_over_max_load": 1000.0,   # largest |force| / largest static load [-]
    "deflection_m": 0.01,            # |mesh deflection| [m]
    "half_width_m": 0.1,             # Hertzian half-width [m]
    "peak_pressure_Pa": 1e12,        # contact pressure [Pa]
    "strain": 0.1,                   # |root strain| [-]
    "roll_deg": 360.0,               # |contact roll angle| [deg]
    "moment_arm_m": 100.0,           # |hub moment| / (force bound) [m]
}

#: relative tolerances of the properties checked by :func:`sanity_problems`
TOLERANCES = {
    "force_decrease": 1e-6,          # largest decrease of F along x / largest load
    "negative": 1e-9,                # most negative force or tooth load / largest load
    "fdf_reproduces_static": 0.05,   # max |F(p, x_static) - load| / largest load
    "tooth_load_sum": 0.02,          # max |sum of tooth loads - F| / largest load
    "grid": 1e-9,                    # relative non-uniformity of the grids
}


def _finite(name: str, a: np.ndarray, out: list[str], allow_nan: bool = False) -> np.ndarray:
    a = np.asarray(a, float)
    bad = np.isinf(a) if allow_nan else ~np.isfinite(a)
    if np.any(bad):
        out.append(f"{name}: {int(np.count_nonzero(bad))} non-finite value(s)")
    return a


def _given(a) -> bool:
    """False for an optional output the solver did not give (absent, or NaN throughout, as ``write_tables``
    stores it: synthetic tables have no half-widths or hub reactions)."""
    return a is not None and not np.all(np.isnan(np.asarray(a, float)))


def _bounded(name: str, a: np.ndarray, lo: float, hi: float, unit: str, out: list[str]) -> None:
    v = a[np.isfinite(a)]
    if v.size and (v.min() < lo or v.max() > hi):
        worst = v.min() if v.min() < lo else v.max()
        out.append(f"{name}: value {worst:.6g} {unit} outside the plausible range [{lo:.6g}, {hi:.6g}] {unit}")


def hard_problems(t: MeshTable) -> list[str]:
    """Values no correct table holds (module docstring); empty list when none."""
    out: list[str] = []
    load = _finite("load_N", t.load_N, out)
    x = _finite("deflection_m", t.deflection_m, out)
    _finite("position", t.position, out)
    nl = _finite("no_load_deflection_m", t.no_load_deflection_m, out)
    sd = _finite("static_deflection_m", t.static_deflection_m, out)
    F = _finite("force_N", t.force_N, out)
    tl = _finite("tooth_load_N", t.tooth_load_N, out)
    pp = _finite("peak_pressure_Pa", t.peak_pressure_Pa, out)
    lmax = float(np.max(load[np.isfinite(load)], initial=0.0))
    if not lmax > 0:
        out.append(f"load_N: largest static load {lmax!r} N; must be > 0")
        lmax = float("nan")
    if load.size and np.isfinite(load[0]) and load[0] != 0.0:
        out.append(f"load_N: first load {load[0]:.6g} N; must be 0 (it gives the no-load mesh deflection)")
    fmax = LIMITS["force_over_max_load"] * lmax
    neg = -TOLERANCES["negative"] * lmax
    for name, a in (("force_N", F), ("tooth_load_N", tl)):
        _bounded(name, a, neg, fmax, "N", out)
    for name, a in (("deflection_m", x), ("no_load_deflection_m", nl), ("static_deflection_m", sd)):
        _bounded(name, a, -LIMITS["deflection_m"], LIMITS["deflection_m"], "m", out)
    _bounded("peak_pressure_Pa", pp, 0.0, LIMITS["peak_pressure_Pa"], "Pa", out)
    for name in ("flank_pressure_Pa", "edge_pressure_Pa"):
        if _given(getattr(t, name)):
            _bounded(name, _finite(name, getattr(t, name), out), 0.0, LIMITS["peak_pressure_Pa"], "Pa", out)
    if _given(t.half_width_m):
        _bounded("half_width_m", _finite("half_width_m", t.half_width_m, out), 0.0, LIMITS["half_width_m"], "m", out)
    _bounded("contact_roll_deg", _finite("contact_roll_deg", t.contact_roll_deg, out, allow_nan=True),
             -LIMITS["roll_deg"], LIMITS["roll_deg"], "deg", out)
    for g, a in t.strain.items():
        _bounded(f"strain/{g}", _finite(f"strain/{g}", a, out), -LIMITS["strain"], LIMITS["strain"], "-", out)
    for g, a in t.hub_reaction.items():
        if not _given(a):
            continue
        a = _finite(f"hub_reaction/{g}", a, out)
        _bounded(f"hub_reaction/{g} (forces)", a[..., :2], -fmax, fmax, "N", out)
        _bounded(f"hub_reaction/{g} (moment)", a[..., 2:], -fmax * LIMITS["moment_arm_m"],
                 fmax * LIMITS["moment_arm_m"], "N*m", out)
    return out


def _regular(name: str, a: np.ndarray, out: list[str]) -> None:
    d = np.diff(np.asarray(a, float))
    if d.size and not (np.all(d > 0) and np.max(np.abs(d - d.mean())) <= TOLERANCES["grid"] * abs(d.mean())):
        out.append(f"{name}: grid not regular (steps {d.min():.6g} … {d.max():.6g})")


def sanity_problems(t: MeshTable) -> list[str]:
    """:func:`hard_problems` plus the properties of a correct table (module docstring)."""
    out = hard_problems(t)
    if out:
        return out
    lmax = float(t.load_N.max())
    npos = t.position.size
    if not np.allclose(t.position, np.arange(npos) / npos, rtol=0, atol=1e-12):
        out.append("position: not k/Np, k = 0 … Np-1")
    _regular("deflection_m", t.deflection_m, out)
    _regular("load_N", t.load_N, out)
    F = t.force_N
    drop = float(np.max(np.maximum(-np.diff(F, axis=1), 0.0), initial=0.0))
    if drop > TOLERANCES["force_decrease"] * lmax:
        i, j = np.unravel_index(np.argmax(-np.diff(F, axis=1)), np.diff(F, axis=1).shape)[:2]
        out.append(f"force_N: decreases by {drop:.6g} N with growing deflection (position {t.position[i]:.4g}, "
                   f"deflection {t.deflection_m[j] * 1e6:.4g} µm); the FDF must be non-decreasing")
    sdrop = float(np.max(np.maximum(-np.diff(t.static_deflection_m, axis=1), 0.0), initial=0.0))
    if sdrop > TOLERANCES["force_decrease"] * float(np.ptp(t.deflection_m)):
        out.append(f"static_deflection_m: decreases by {sdrop:.6g} m with growing load; must be non-decreasing")
    x = t.deflection_m
    below = x[None, :] <= t.no_load_deflection_m[:, None]
    if F.ndim > 2:
        below = below.reshape(below.shape + (1,) * (F.ndim - 2))
    fb = np.abs(np.where(below, F, 0.0)).max(initial=0.0)
    if fb > 0:
        out.append(f"force_N: {fb:.6g} N where the deflection is at or below the no-load mesh deflection "
                   "(the teeth do not touch there)")
    if t.no_load_deflection_m.min() < x[0] or t.static_deflection_m.max() > x[-1]:
        out.append("deflection_m: the grid does not span the no-load and static deflections "
                   f"({t.no_load_deflection_m.min():.6g} … {t.static_deflection_m.max():.6g} m vs "
                   f"{x[0]:.6g} … {x[-1]:.6g} m)")
    if _given(t.flank_pressure_Pa) and _given(t.edge_pressure_Pa):
        split = np.abs(np.maximum(t.flank_pressure_Pa, t.edge_pressure_Pa) - t.peak_pressure_Pa).max()
        if split > 1e-9 * max(float(t.peak_pressure_Pa.max()), 1.0):
            out.append(f"flank_pressure_Pa, edge_pressure_Pa: their larger differs from peak_pressure_Pa by "
                       f"{split:.6g} Pa; the peak is the larger of the two")
    if F.ndim == 2:
        tsum = np.abs(t.tooth_load_N.sum(axis=-1) - F).max() / lmax
        if tsum > TOLERANCES["tooth_load_sum"]:
            out.append(f"tooth_load_N: tooth loads differ from the mesh force by {100 * tsum:.3g} % of the "
                       f"largest load (> {100 * TOLERANCES['tooth_load_sum']:g} %)")
    return out


#: contact pressure above which a gear steel flank is overloaded even once [Pa]: ISO 6336-5 allows case-hardened
#: gear steel of the best grade (ME) sigma_Hlim = 1.65 GPa, and ISO 6336-2's life factor Z_NT for static load
#: (N_L <= 1e5 cycles) at most 1.6 of that: 2.6 GPa; 3 GPa is beyond any gear steel's static capacity
STEEL_PRESSURE_LIMIT_PA = 3.0e9


def pressure_notes(t: MeshTable) -> list[str]:
    """Notes on the tabulated contact pressures (not errors): where tip-edge contact occurs and how high its
    pressure is (set by the edge radius the model gives, or the solver's default for a sharp corner, not by the
    load alone).  Flank pressures are not judged here: the tables span loads up to several times the nominal one
    (the dynamics say which states are reached, and warn there)."""
    out = []
    if not (_given(t.flank_pressure_Pa) and _given(t.edge_pressure_Pa)):
        return ["flank and tip-edge contact pressures are not told apart in this table (written before the split): "
                "regenerate it with `hacgear statics MODEL --fresh`"]
    edge = float(np.nanmax(t.edge_pressure_Pa))
    if edge > 0:
        share = float(np.mean(np.nanmax(t.edge_pressure_Pa, axis=1) > 0))
        out.append(f"tip-edge contact at {100 * share:.3g} % of the positions, pressure up to {edge / 1e9:.3g} GPa: "
                   "a tip corner pressing on the mating flank (premature or late contact off the line of action); its "
                   "pressure follows from the edge radius (tip_edge_radius_mm, or 0.1 mm for a sharp corner), not "
                   "from the flank geometry: enough tip relief, or a rounded tip edge, avoids it")
    return out


def resolution_notes(t: MeshTable) -> list[str]:
    """Notes on the grid resolution (not errors): how well the FDF, interpolated linearly along each row,
    reproduces the load-control results (> 5 % of the largest load: the deflection grid is coarse)."""
    F = t.force_N
    if F.ndim != 2 or hard_problems(t):
        return []
    lmax = float(t.load_N.max())
    rec = np.array([np.interp(t.static_deflection_m[i], t.deflection_m, F[i]) for i in range(t.position.size)])
    err = float(np.max(np.abs(rec - t.load_N[None, :])) / lmax)
    if err > TOLERANCES["fdf_reproduces_static"]:
        return [f"the FDF reproduces the load-control results within {100 * err:.3g} % of the largest load "
                f"(> {100 * TOLERANCES['fdf_reproduces_static']:g} %): the deflection grid is coarse"]
    return []
