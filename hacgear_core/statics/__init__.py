"""Static contact analysis of gear meshes and its grids → force-deflection tables.

:mod:`.fe` (finite-element far field of whole gears, cyclic symmetry, compliance cache), :mod:`.nearfield`
(analytical Hertz/half-space near field), :mod:`.lcp` (the contact complementarity problem),
:mod:`.contact` (static contact solver of one mesh), :mod:`.helical` (the face-resolving solver: helix,
mesh twist, generalized forces), :mod:`.fe3d` (3D face-wise influence of a tooth), :mod:`.coast` (the coast side
of a mesh in the drive side's coordinates), :mod:`.contract` (what a solver returns and provides),
:mod:`.reference` (analytical reference solver for tests), :mod:`.grid` (statics grid → ``tables.h5``,
parallel, resumable), :mod:`.studies` (stiffness curves, model variants, root-strain scans).
"""
from __future__ import annotations

from hacgear_core.statics.contact import ContactOptions, MeshContactSolver, make_mesh_solver
from hacgear_core.statics.coast import CoastMapping, CoastSideSolver, coast_mapping, make_coast_solver
from hacgear_core.statics.helical import HelicalMeshContactSolver, MeshFrame, make_helical_solver, make_solver
from hacgear_core.statics.lcp import LCPResult, StripContact, solve_contact_lcp, solve_strip_contact
from hacgear_core.statics.contract import MeshInfo, MeshStaticSolver, SolverFactory, StaticSolution, describe_solver
from hacgear_core.statics.grid import (
    DEFAULT_DEFLECTION_MARGIN,
    SIDES,
    region_key,
    region_mesh,
    ModelSolverFactory,
    StaticsReport,
    compute_statics,
    deflection_grid,
    load_grid,
    nominal_mesh_forces,
    twist_grid,
    run_statics,
)
from hacgear_core.statics.reference import AnalyticFactory, AnalyticPairSolver
from hacgear_core.statics.studies import (
    RootStrainScan,
    StiffnessCurve,
    mesh_stiffness_curve,
    mesh_stiffness_report,
    model_variant,
    root_strain_scan,
)

__all__ = [
    "LCPResult",
    "StripContact",
    "solve_contact_lcp",
    "solve_strip_contact",
    "ContactOptions",
    "MeshContactSolver",
    "make_mesh_solver",
    "CoastMapping",
    "CoastSideSolver",
    "coast_mapping",
    "make_coast_solver",
    "SIDES",
    "region_key",
    "region_mesh",
    "HelicalMeshContactSolver",
    "MeshFrame",
    "make_helical_solver",
    "make_solver",
    "StaticSolution",
    "MeshStaticSolver",
    "SolverFactory",
    "MeshInfo",
    "describe_solver",
    "AnalyticPairSolver",
    "AnalyticFactory",
    "ModelSolverFactory",
    "StaticsReport",
    "DEFAULT_DEFLECTION_MARGIN",
    "deflection_grid",
    "load_grid",
    "twist_grid",
    "nominal_mesh_forces",
    "run_statics",
    "compute_statics",
    "StiffnessCurve",
    "mesh_stiffness_curve",
    "mesh_stiffness_report",
    "model_variant",
    "RootStrainScan",
    "root_strain_scan",
]
