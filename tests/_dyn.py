"""Shared fixtures of the dynamics tests: a spur pair of two 28-tooth gears on analytic tables; a copy of a shipped
system whose tables lack their coast side (a drive-only file, as older versions wrote)."""
from __future__ import annotations

import math
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np

from hacgear_core.kinds import SpurPairParameters, spur_pair_system
from hacgear_core.dynamics.simulator import Simulator
from hacgear_core.dynamics.synthetic import linear_fdf_table
from hacgear_core.model import resolve_model_path
from hacgear_core.tables import load_system_tables, write_tables

K = 150e6
RB = 0.0634
I1, I2 = 0.0044, 0.0061
M1, M2 = 1.6, 2.1


def params(**kw) -> SpurPairParameters:
    base = dict(mass_kg=(M1, M2), inertia_kg_m2=(I1, I2), base_radius_m=(RB, RB), teeth=(28, 28),
                modal_damping_ratio=0.02, torque_Nm=300.0)
    base.update(kw)
    return SpurPairParameters(**base)


def m_eff() -> float:
    return 1.0 / (RB**2 / I1 + RB**2 / I2)


def fn_rot() -> float:
    return math.sqrt(K / m_eff()) / (2 * math.pi)


def first_harmonic(x: np.ndarray) -> float:
    n = x.size
    return 2 * abs(np.sum(x * np.exp(-2j * np.pi * np.arange(1, n + 1) / n))) / n


def system(p: SpurPairParameters, table, law: str = "hac", **kw):
    return spur_pair_system(p, table, law, **kw)


def simulator(p: SpurPairParameters, table, **kw) -> Simulator:
    return Simulator(spur_pair_system(p, table), **kw)


def softening():
    xs = 100.0 / RB / K
    tab = linear_fdf_table(K, offset_amplitude_m=0.2 * xs, x_max_m=6 * xs)
    return params(modal_damping_ratio=0.03, torque_Nm=100.0), tab


def drive_only_copy(system: str, folder: Path) -> Path:
    """``folder/<system>``: the shipped model file of ``system`` and its committed tables without their coast sides
    (written through the tables API); returns the folder."""
    src = Path(resolve_model_path(system))
    src = src if src.is_dir() else src.parent
    dst = Path(folder) / system
    dst.mkdir(parents=True)
    shutil.copy(src / "model.toml", dst / "model.toml")
    tabs = load_system_tables(src)
    write_tables(dst / "tables.h5", replace(tabs, meshes={k: replace(t, coast=None) for k, t in tabs.meshes.items()}))
    return dst
