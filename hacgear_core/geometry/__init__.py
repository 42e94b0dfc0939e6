"""Gear geometry (SI): :mod:`.tooth` (generated tooth profiles), :mod:`.gear` (one gear: flanks, blank, mass
properties), :mod:`.mesh` (one mesh: centre distance, line of action, contact ratios), :mod:`.train` (gears
placed in a train: line-of-action vectors, mesh phases, the torque through each mesh)."""
from __future__ import annotations

from hacgear_core.geometry.gear import GearGeometry, WebGeometry, gear_geometry
from hacgear_core.geometry.mesh import MeshGeometry, mesh_backlash, mesh_geometry, model_geometry
from hacgear_core.geometry.train import (
    MeshPlacement,
    TrainGeometry,
    nominal_mesh_forces,
    rotation_senses,
    train_geometry,
)
from hacgear_core.geometry.tooth import (
    REGION_FILLET,
    REGION_INVOLUTE,
    REGION_ROOT_LAND,
    REGION_TIP_LAND,
    REGION_TIP_ROUNDING,
    SHAPER_TEETH,
    SIDES,
    Boundary,
    FlankProfile,
    fillet_root_curvature_radius_rack,
    fillet_root_curvature_radius_shaper,
    involute_function,
    max_hob_tip_radius_m,
    zero_backlash_center_distance,
)

__all__ = [
    "SIDES",
    "SHAPER_TEETH",
    "REGION_ROOT_LAND",
    "REGION_FILLET",
    "REGION_INVOLUTE",
    "REGION_TIP_ROUNDING",
    "REGION_TIP_LAND",
    "involute_function",
    "max_hob_tip_radius_m",
    "FlankProfile",
    "Boundary",
    "WebGeometry",
    "GearGeometry",
    "MeshGeometry",
    "gear_geometry",
    "mesh_geometry",
    "mesh_backlash",
    "model_geometry",
    "zero_backlash_center_distance",
    "fillet_root_curvature_radius_rack",
    "fillet_root_curvature_radius_shaper",
    "MeshPlacement",
    "TrainGeometry",
    "train_geometry",
    "nominal_mesh_forces",
    "rotation_senses",
]
