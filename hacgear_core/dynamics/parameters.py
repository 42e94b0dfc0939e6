"""Lumped parameters of a spur pair without a model file (:class:`SpurPairParameters`), validated."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from hacgear_core.errors import ModelError
from hacgear_core.model.schema import RANGES

__all__ = ["SpurPairParameters"]


def _pair(name, value, unit, lo, hi, *, lo_open=True, allow_inf=False, integer=False):
    try:
        a, b = value
    except (TypeError, ValueError):
        raise ModelError(f"{name} [{unit}] must be a pair (gear 1, gear 2), got {value!r}") from None
    out = []
    for v in (a, b):
        if integer:
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise ModelError(f"{name} [{unit}] must be integers in [{lo}, {hi}], got {value!r}")
            out.append(int(v))
            continue
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise ModelError(f"{name} [{unit}] must be numbers, got {value!r}") from None
        if math.isnan(v) or (math.isinf(v) and not allow_inf):
            raise ModelError(f"{name} [{unit}] must be finite{' or inf' if allow_inf else ''}, got {value!r}")
        bad_lo = v <= lo if lo_open else v < lo
        if bad_lo or (not math.isinf(v) and v > hi):
            br = "(" if lo_open else "["
            raise ModelError(f"{name} [{unit}] must be in {br}{lo:g}, {hi:g}]"
                             f"{' or inf' if allow_inf else ''}, got {value!r}")
        out.append(v)
    return tuple(out)


@dataclass(frozen=True)
class SpurPairParameters:
    """Lumped parameters of a spur pair without a model file (SI).  Pairs are (gear 1 = driver, gear 2).

    Attributes
    ----------
    mass_kg, inertia_kg_m2 : (float, float)
        Masses [kg] (used for translations with finite bearing stiffness) and polar inertias [kg m^2].
    base_radius_m : (float, float)
        Base radii of the loaded flanks [m].
    teeth : (int, int)
    bearing_stiffness_N_per_m : (float, float)
        Translational support stiffness along the line of action [N/m]; ``inf`` = rigid.
    rotational_stiffness_Nm_per_rad : (float, float)
        Rotational support stiffness [N m/rad]; 0 = free rotation.
    modal_damping_ratio : float in [0, 1)
    torque_Nm : float
        Nominal torque on gear 1 [N m] (nonzero; negative loads the coast flanks, which needs a coast table).
    mesh_phase : float
        Mesh position [cycles] at zero rotation of gear 1.
    pressure_angles_deg : (float, float)
        Operating pressure angles of the drive and the coast flanks [deg]: the coast line of action makes their sum
        with the drive one (used when the table has a coast side and the bearings are elastic).
    """

    mass_kg: tuple[float, float]
    inertia_kg_m2: tuple[float, float]
    base_radius_m: tuple[float, float]
    teeth: tuple[int, int]
    bearing_stiffness_N_per_m: tuple[float, float] = (math.inf, math.inf)
    rotational_stiffness_Nm_per_rad: tuple[float, float] = (0.0, 0.0)
    modal_damping_ratio: float = 0.02
    torque_Nm: float = 300.0
    mesh_phase: float = 0.0
    pressure_angles_deg: tuple[float, float] = (25.0, 20.0)

    def __post_init__(self) -> None:
        s = object.__setattr__
        s(self, "mass_kg", _pair("mass_kg", self.mass_kg, "kg", 0.0, 1e6))
        s(self, "inertia_kg_m2", _pair("inertia_kg_m2", self.inertia_kg_m2, "kg*m^2", 0.0, 1e6))
        s(self, "base_radius_m", _pair("base_radius_m", self.base_radius_m, "m", 0.0, 20.0))
        s(self, "teeth", _pair("teeth", self.teeth, "-", 6, 1000, integer=True))
        k_range = RANGES["translational_stiffness_N_per_m"]  # > 0 here: a spur pair's gears need a bearing
        s(self, "bearing_stiffness_N_per_m",
          _pair("bearing_stiffness_N_per_m", self.bearing_stiffness_N_per_m, "N/m", k_range.lo, k_range.hi,
                allow_inf=k_range.allow_inf))
        s(self, "rotational_stiffness_Nm_per_rad",
          _pair("rotational_stiffness_Nm_per_rad", self.rotational_stiffness_Nm_per_rad, "N*m/rad", 0.0, 1e12,
                lo_open=False))
        for name, unit in (("modal_damping_ratio", "-"), ("torque_Nm", "N*m")):
            v = getattr(self, name)
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise ModelError(f"{name} [{unit}] must be a number, got {v!r}") from None
            r = RANGES[name]
            if not r.contains(abs(v) if name == "torque_Nm" else v):
                rng = r.text if name == "modal_damping_ratio" else f"[-{r.hi:g}, {r.hi:g}] without 0"
                raise ModelError(f"{name} [{unit}] must be in {rng}, got {getattr(self, name)!r}")
            s(self, name, v)
        ph = float(self.mesh_phase)
        if not math.isfinite(ph):
            raise ModelError(f"mesh_phase [cycles] must be finite, got {self.mesh_phase!r}")
        s(self, "mesh_phase", ph)
        s(self, "pressure_angles_deg", _pair("pressure_angles_deg", self.pressure_angles_deg, "deg", 0.0, 60.0))

    @property
    def static_force_N(self) -> float:
        """Nominal static force of the drive flanks F_s = |T_1| / r_b1 [N] (a magnitude: the torque's sign picks
        the flanks)."""
        return abs(self.torque_Nm) / self.base_radius_m[0]

    def replace(self, **changes) -> "SpurPairParameters":
        return replace(self, **changes)
