"""What a static contact solver of one mesh returns and must provide (the protocol the statics grid uses)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Protocol, runtime_checkable

import numpy as np

from hacgear_core.errors import SolverError

__all__ = ["StaticSolution", "MeshStaticSolver", "SolverFactory", "MeshInfo", "describe_solver", "COAST_ATTRIBUTES"]

# Solver protocol
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class StaticSolution:
    """Result of one static contact solve of one mesh (SI).  ``Nw`` = number of tooth offsets.

    Attributes
    ----------
    success, message, iterations
        solver outcome; ``success=False`` aborts a statics run with the message.
    position : float
        mesh position [mesh cycles].
    mesh_force_N : float
        total mesh force along the line of action [N].
    mesh_deflection_m : float
        mesh deflection ``x = r_b1 θ1 + r_b2 θ2 (+ y1 − y2)`` [m].
    tooth_load_N : (Nw,) array
        load of each tooth pair (offset k of :attr:`MeshStaticSolver.tooth_offsets`) [N].
    contact_roll_deg : (Nw,) array
        roll angle of the contact on gear_b's loaded flank [deg]; NaN where the pair is unloaded.
    half_width_m : (Nw,) array
        Hertzian contact half-width [m] (0 where unloaded).
    peak_pressure_Pa : (Nw,) array
        maximum contact pressure of each pair [Pa] (0 where unloaded).
    flank_pressure_Pa, edge_pressure_Pa : (Nw,) arrays or None
        the same maximum over the pair's flank contacts (Hertzian: involute on involute or on a relieved flank)
        and over its tip-edge contacts (a tip corner pressing on the mating flank, off the line of action, whose
        pressure the edge radius sets) [Pa]; 0 where there is none; None when the solver does not tell them apart.
    strain : dict gauge → (Nw,) array
        strain [-] at gauge ``"<gear>/<gauge>"`` on the tooth belonging to pair offset k.
    stress : dict gauge → (Nw,) array
        surface stress along the profile [Pa] at the same gauges (empty when the solver gives none).
    contact_s_m : (Nw, 2) array or None
        profile coordinate of the contact (arc length from the tip) on gear_a's and gear_b's loaded flank
        [m]; NaN where the pair is unloaded (None when the solver gives none).
    hub_reaction : dict gear → (3,) array
        generalized mesh force on each gear ``[Fx N, Fy N, Mz N·m]``.
    twist_rad, twist_moment_Nm : float
        mesh twist and the twist moment conjugate to it (face-resolving solvers; 0 / NaN otherwise).
    generalized_force : (12,) array or None
        ``f_d`` of dissertation Eq. 5.1 on ``q = [u_a, theta_a, u_b, theta_b]`` (global frame,
        :mod:`hacgear_core.statics.helical`); None when the solver gives none.
    slice_load_N, slice_pressure_Pa : (Ns,) arrays or None
        load and peak contact pressure per face slice (contact pattern across the face).
    pattern_load_N : (Nw, Ns) array or None
        load per tooth pair and face slice.
    """

    success: bool
    message: str
    iterations: int
    position: float
    mesh_force_N: float
    mesh_deflection_m: float
    tooth_load_N: np.ndarray
    contact_roll_deg: np.ndarray
    half_width_m: np.ndarray
    peak_pressure_Pa: np.ndarray
    strain: dict[str, np.ndarray] = field(default_factory=dict)
    hub_reaction: dict[str, np.ndarray] = field(default_factory=dict)
    stress: dict[str, np.ndarray] = field(default_factory=dict)
    contact_s_m: np.ndarray | None = None
    twist_rad: float = 0.0
    twist_moment_Nm: float = float("nan")
    generalized_force: np.ndarray | None = None
    slice_load_N: np.ndarray | None = None
    slice_pressure_Pa: np.ndarray | None = None
    pattern_load_N: np.ndarray | None = None
    flank_pressure_Pa: np.ndarray | None = None
    edge_pressure_Pa: np.ndarray | None = None


@runtime_checkable
class MeshStaticSolver(Protocol):
    """What the statics grid needs from a static contact solver of one mesh.

    ``position`` is the mesh position in mesh cycles (an integer = pitch-point contact of the reference
    tooth pair, offset 0).  Tooth offset ``k`` is the pair that reaches the pitch point ``k`` mesh
    cycles after the reference pair (``+1`` = next pair to come into mesh).  Results must be periodic:
    the state at ``position + 1`` equals the state at ``position`` with offsets shifted by one.
    ``solve_position`` is optional: a batch of all loads and deflections at one position, reusing the
    per-position set-up; when absent the grid calls ``solve_load``/``solve_deflection`` one by one.

    Optional attributes a solver of a mesh's coast side has (:class:`hacgear_core.statics.coast.CoastSideSolver`):
    ``side = "coast"``, ``flanks`` (its flank of gear_a, gear_b), ``contact_deflection_m`` (the deflection at
    which ideal flanks touch: 0 on the drive side, the normal backlash on the coast side), ``backlash_normal_m``,
    ``backlash_circular_m``, ``position_offset``, ``pair_shift``.
    """

    mesh_name: str
    gear_names: tuple[str, str]
    teeth: tuple[int, int]
    base_radius_m: tuple[float, float]
    tooth_offsets: np.ndarray
    gauge_names: tuple[str, ...]

    def no_load_deflection(self, position: float) -> float: ...

    def solve_load(self, position: float, mesh_force_N: float) -> StaticSolution: ...

    def solve_deflection(self, position: float, mesh_deflection_m: float) -> StaticSolution: ...


#: a picklable callable without arguments returning a :class:`MeshStaticSolver`
SolverFactory = Callable[[], MeshStaticSolver]


@dataclass(frozen=True)
class MeshInfo:
    """Static description of a mesh solver (what the table layout needs)."""

    mesh_name: str
    gear_names: tuple[str, str]
    teeth: tuple[int, int]
    base_radius_m: tuple[float, float]
    tooth_offsets: tuple[int, ...]
    gauge_names: tuple[str, ...]
    description: str
    lever_arm_m: tuple[float, float] = ()
    mesh_frame: dict | None = None
    slice_z_m: tuple[float, ...] = ()
    side: str = "drive"
    flanks: tuple[str, ...] = ()
    contact_deflection_m: float = 0.0
    coast: dict = field(default_factory=dict, compare=False)


#: attributes of a coast-side solver stored with its table region
COAST_ATTRIBUTES = ("backlash_normal_m", "backlash_circular_m", "position_offset", "pair_shift")


def describe_solver(solver: MeshStaticSolver) -> MeshInfo:
    """Check that ``solver`` follows :class:`MeshStaticSolver` and return its :class:`MeshInfo`."""
    missing = [a for a in ("mesh_name", "gear_names", "teeth", "base_radius_m", "tooth_offsets", "gauge_names",
                           "no_load_deflection", "solve_load", "solve_deflection") if not hasattr(solver, a)]
    if missing:
        raise SolverError(f"{type(solver).__name__} does not follow the MeshStaticSolver protocol: missing {missing}")
    offsets = tuple(int(k) for k in np.asarray(solver.tooth_offsets).ravel())
    if not offsets or len(set(offsets)) != len(offsets) or list(offsets) != sorted(offsets):
        raise SolverError(f"solver.tooth_offsets must be distinct increasing integers, got {offsets}")
    gauges = tuple(str(g) for g in solver.gauge_names)
    for g in gauges:
        if g.count("/") != 1 or not all(g.split("/")):
            raise SolverError(f"gauge name {g!r} must read '<gear>/<gauge>'")
    rb = tuple(float(r) for r in solver.base_radius_m)
    if len(rb) != 2 or not all(r > 0 and math.isfinite(r) for r in rb):
        raise SolverError(f"solver.base_radius_m must be two positive radii [m], got {rb}")
    side = str(getattr(solver, "side", "drive"))
    if side not in ("drive", "coast"):
        raise SolverError(f"solver.side must be 'drive' or 'coast', got {side!r}")
    coast = {}
    if side == "coast":
        missing = [a for a in COAST_ATTRIBUTES if not hasattr(solver, a)]
        if missing:
            raise SolverError(f"coast-side solver {type(solver).__name__} lacks {missing}")
        coast = {a: getattr(solver, a) for a in COAST_ATTRIBUTES}
        coast["pair_shift"] = {str(g): int(v) for g, v in coast["pair_shift"].items()}
    return MeshInfo(
        mesh_name=str(solver.mesh_name),
        gear_names=tuple(str(g) for g in solver.gear_names),
        teeth=tuple(int(z) for z in solver.teeth),
        base_radius_m=rb,
        tooth_offsets=offsets,
        gauge_names=gauges,
        description=str(getattr(solver, "description", type(solver).__name__)),
        lever_arm_m=tuple(float(r) for r in getattr(solver, "lever_arm_m", rb)),
        mesh_frame=_frame_dict(getattr(solver, "frame", None)),
        slice_z_m=tuple(float(z) for z in (getattr(solver, "z_centre_m", 0.0) + np.asarray(solver.slice_z_m))
                        ) if getattr(solver, "frame", None) is not None else (),
        side=side, flanks=tuple(str(f) for f in getattr(solver, "flanks", ())),
        contact_deflection_m=float(getattr(solver, "contact_deflection_m", 0.0)), coast=coast,
    )


def _frame_dict(frame) -> dict | None:
    """The mesh frame of a face-resolving solver as the table attributes (docs/tables.md)."""
    if frame is None:
        return None
    return dict(r_mesh=frame.r_mesh, r_twist=frame.r_twist, e1=frame.e1, e2=frame.e2, e3=frame.e3,
                P_ref=frame.P_ref, n_ref=frame.n_ref, O_a=frame.O[0], O_b=frame.O[1],
                base_helix_angle_rad=frame.base_helix_angle_rad, lever_arm_m=np.asarray(frame.lever_arm_m),
                reference_plane_z_m=frame.reference_plane_z_m)


# ---------------------------------------------------------------------------------------------
