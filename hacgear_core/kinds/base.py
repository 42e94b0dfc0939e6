"""The Kind interface and the train description a kind hands to the one assembly (:mod:`.assembly`).

A gear *kind* (``[system] kind`` of a model file) is one :class:`Kind` object in the registry
(:mod:`hacgear_core.kinds`).  It says how to check a model of its kind (and parse its own model section), which
gear pairs mesh (the statics compute one table per mesh), the nominal mesh forces at a torque, how a model and its
tables become a :class:`Train` (bodies with their supports, couplings with their mesh law), its structural
parameters and its extra FMU outputs.  Nothing outside :mod:`hacgear_core.kinds` matches a kind name.

The train description is index-free: a degree of freedom is named by its key ``(body, label)``; a coupling vector
is a tuple of ``(key, coefficient)`` pairs.  The assembly numbers the DOFs (bodies in order, each body's DOFs in
order), drops every DOF whose support is rigid together with every coefficient on it, and fills M, K, G, K_W and
the coupling vectors.  One rule for supports (:class:`Support`): ``inf`` rigid (the DOF is left out), finite > 0
sprung (a diagonal spring to ground), 0 free.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import numpy as np

from hacgear_core.errors import ModelError
from hacgear_core.geometry import train_geometry

__all__ = ["Key", "KeyVector", "Support", "Dof", "Body", "Coupling", "Spring", "FrameSpring", "Train", "StructuralParameter",
           "ExtraOutput", "MeshPair", "Kind", "mesh_table"]

#: a DOF's name in a train description: (body, label), e.g. ("pinion", "theta")
Key = tuple[str, str]
#: a vector over DOFs: ((key, coefficient), ...); coefficients on DOFs the assembly drops are left out
KeyVector = tuple[tuple[Key, float], ...]


@dataclass(frozen=True)
class Support:
    """A DOF's support to ground: ``stiffness`` [N/m or N m/rad]; inf rigid (the DOF is dropped), finite > 0
    sprung, 0 free."""

    stiffness: float = 0.0

    def __post_init__(self) -> None:
        k = float(self.stiffness)
        if math.isnan(k) or k < 0:
            raise ModelError(f"support stiffness [N/m or N*m/rad] must be in [0, inf] (inf: rigid), got {k!r}")
        object.__setattr__(self, "stiffness", k)

    @property
    def rigid(self) -> bool:
        return math.isinf(self.stiffness)


@dataclass(frozen=True)
class Dof:
    """One coordinate of a body: ``label`` (its key is (body, label)), ``inertia`` [kg or kg m^2] on M's diagonal,
    its ``support``, and for a translation its unit ``direction`` (2,) in the train's frame (None: a rotation or an
    out-of-plane coordinate)."""

    label: str
    inertia: float
    support: Support = Support()
    direction: tuple[float, float] | None = None


@dataclass(frozen=True)
class Body:
    """A gear or a member (carrier) of a train: its DOFs in order, and the facts the outputs need: ``teeth``,
    operating ``sense`` (+1 CCW, -1 CW), ``speed_ratio`` (its kinematic speed over the reference gear's, in the
    reference gear's sense), ``rotation`` (the label of its rotation DOF, '' for none), ``radius_m`` (its
    characteristic radius), ``mass_kg``, ``inertia_kgm2`` and ``support`` (translational [N/m], rotational [N m/rad])
    as reported; ``frame_ratio``: the speed of the frame its translations live in over the reference speed (a
    planetary stage's carrier; None: the train's ``carrier_ratio``); ``stage``: the stage it belongs to (a
    gearbox's; '' elsewhere)."""

    name: str
    dofs: tuple[Dof, ...]
    teeth: int = 0
    sense: float = 1.0
    speed_ratio: float = 1.0
    rotation: str = "theta"
    radius_m: float = 1.0
    mass_kg: float = 0.0
    inertia_kgm2: float = 0.0
    support: tuple[float, float] = (math.inf, 0.0)
    frame_ratio: float | None = None
    stage: str = ""


@dataclass(frozen=True)
class Coupling:
    """A mesh between two bodies: ``table`` (the mesh's force-deflection table), ``law`` its mesh law (every
    coupling of a train shares one; :mod:`hacgear_core.dynamics.laws`): ``"table"`` the force table, or the
    conventional law the system's ``force_law`` names, one- or two-sided by its coast tables (``TableLaw``,
    ``TwoSidedTableLaw``, ``LinearLaw``); ``"twist"`` the generalized table over (position, deflection, twist)
    (``TwistTableLaw``, needs ``t``), and its
    vectors over DOF keys: ``v`` mesh deflection, ``w`` mesh position [cycles per unit], ``v_rot`` the rotational
    part of ``v``, ``v_c`` the coast approach, ``t`` / ``t_c`` the twist vectors (twist law).  The remaining fields
    are those of :class:`hacgear_core.dynamics.system.MeshCoupling`."""

    name: str
    gear_a: str
    gear_b: str
    table: object
    v: KeyVector
    w: KeyVector
    v_rot: KeyVector
    phase: float
    nominal_force_N: float
    teeth: tuple[int, int]
    base_radius_m: tuple[float, float]
    law: str = "table"
    tooth_passage: Mapping[str, int] = field(default_factory=dict)
    line_of_action: tuple[float, float] = (0.0, 1.0)
    group: str = ""
    gear_alias: Mapping[str, str] = field(default_factory=dict)
    v_c: KeyVector | None = None
    nominal_coast_force_N: float = 0.0
    backlash_m: float = math.inf
    t: KeyVector | None = None
    t_c: KeyVector | None = None
    rate: tuple[int, int] = (1, 1)


@dataclass(frozen=True)
class Spring:
    """A spring between DOFs: stiffness ``k`` [N/m] on the deflection ``d = B q - e`` with ``B`` the rows ``rows``
    (each a KeyVector) and rest offset ``preload`` e (len(rows),) [m]: adds ``k B^T B`` to K and the constant force
    ``k B^T e``.  ``reports``: the body whose bearing force this spring is (``frame`` (2, 2): columns the
    directions of the rows in the train's frame, ``centrifugal`` (2,) the force per unit carrier speed squared)."""

    k: float
    rows: tuple[KeyVector, ...]
    preload: tuple[float, ...] = ()
    reports: str = ""
    frame: np.ndarray | None = None
    centrifugal: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class FrameSpring:
    """An isotropic spring of stiffness ``k`` [N/m] between the in-plane displacements of two points whose
    translations live in frames that turn against each other: ``rows_a`` and ``rows_b`` (two KeyVectors each) the
    displacement's x and y in its own frame; the second frame turns ``rate`` = ``(p, q)`` revolutions
    (counter-clockwise, p / q) relative to the first per reference mesh cycle, and the frames coincide at the
    assembly position (:class:`~hacgear_core.dynamics.system.FrameCoupling`)."""

    name: str
    k: float
    rows_a: tuple[KeyVector, KeyVector]
    rows_b: tuple[KeyVector, KeyVector]
    rate: tuple[int, int]


@dataclass(frozen=True, eq=False)
class Train:
    """Everything the assembly needs: bodies (DOFs and supports), couplings (meshes), springs between DOFs, and
    the experiment's facts (see :class:`hacgear_core.dynamics.system.LumpedSystem` for their meaning).

    ``gyroscopic`` / ``centripetal``: ((key_i, key_j, value), ...) entries of G and K_W per unit carrier speed;
    ``rigid_mode``: the free rotation of the train as a KeyVector (None: the assembly decides from K whether the
    supports hold it); ``bearing_reports``: bodies whose bearing force is the sum of the reporting springs'
    (a carrier on rigid bearings); ``support_reports``: bodies whose bearing force is their translational supports'."""

    name: str
    kind: str
    bodies: tuple[Body, ...]
    couplings: tuple[Coupling, ...]
    torque_Nm: float
    input_gear: str
    reference_gear: str
    modal_damping_ratio: float
    force_law: str = "hac"
    springs: tuple[Spring, ...] = ()
    gyroscopic: tuple[tuple[Key, Key, float], ...] = ()
    centripetal: tuple[tuple[Key, Key, float], ...] = ()
    carrier_ratio: float = 0.0
    rigid_mode: KeyVector | None = None
    held_tolerance: float = 0.0
    mesh_cycles_per_rad: float | None = None
    nominal_torques_per_Nm: Mapping[str, float] | None = None
    support_reports: tuple[str, ...] = ()
    bearing_reports: tuple[str, ...] = ()
    frame_springs: tuple[FrameSpring, ...] = ()


def mesh_table(tables: Any, name: str, single: bool = True):
    """Mesh ``name``'s table from ``tables``: a :class:`~hacgear_core.tables.SystemTables`, a {mesh: MeshTable}
    mapping or (``single``) one table used as it is."""
    if hasattr(tables, "mesh"):
        return tables.mesh(name)
    if isinstance(tables, Mapping):
        if name not in tables:
            raise ModelError(f"no table for mesh '{name}'; tables for {sorted(tables)}")
        return tables[name]
    if not single:
        raise ModelError(f"no tables for mesh '{name}' (give SystemTables or {{mesh: MeshTable}})")
    return tables


@dataclass(frozen=True)
class StructuralParameter:
    """An integer option of a kind that changes the structure of the system (its DOFs and meshes), e.g. the planet
    count of a planetary set: ``name`` (the build keyword), ``start``, ``min``, ``max`` and a ``description``
    (FMUs declare their outputs for ``max`` and take the value as a fixed parameter)."""

    name: str
    start: int
    min: int
    max: int
    description: str


@dataclass(frozen=True)
class ExtraOutput:
    """An FMU output a kind adds after the common ones: ``name``, ``unit`` (FMI unit name: "N", "N.m", "rad", "1"),
    ``description`` and ``read(simulator)`` -> float, evaluated on the FMU's
    :class:`~hacgear_core.dynamics.simulator.Simulator` when the output is read."""

    name: str
    unit: str
    description: str
    read: Any


def shaft_torque_output(name: str, member_a: str, member_b: str, stiffness_Nm_per_rad: float) -> ExtraOutput:
    """The ``<name>.torque`` output of a torsional shaft from ``member_a`` to ``member_b``: its elastic torque k (the
    twist of the two members' rotation deviations, each in its sense of rotation) [N m], positive when member_a
    drives member_b (the kinematic rotations of the members of one shaft are equal and cancel)."""
    k = float(stiffness_Nm_per_rad)

    def read(sim: Any) -> float:
        ga, gb = sim.system.gears[member_a], sim.system.gears[member_b]
        return k * (ga.sense * sim.s[ga.rotation] - gb.sense * sim.s[gb.rotation])
    return ExtraOutput(name=f"{name}.torque", unit="N.m",
                       description=f"elastic torque of shaft {name} ({member_a} -> {member_b}): k (angle of "
                                   f"{member_a} - angle of {member_b}), k = {k:g} N m/rad, positive when {member_a} "
                                   f"drives {member_b}",
                       read=read)


@dataclass(frozen=True)
class MeshPair:
    """A pair of gears that mesh, for the statics (one table per pair): the table's mesh name and its gears."""

    name: str
    gear_a: str
    gear_b: str


class Kind:
    """A gear kind.  Subclasses set :attr:`name` and implement :meth:`train`; the rest has defaults for a fixed-axis
    train of the model's gears and meshes.

    Attributes
    ----------
    name : str
        The ``[system] kind`` value.
    section : str or None
        The kind's own top-level model table: given raw to :meth:`parse_section` (None: the kind has none; any
        table no generic section reads is then refused).  ``[planetary]`` is read by the model layer itself (the
        planetary geometry and the tables' provenance depend on it): the planetary kind only names it.
    lumped : bool
        Whether ``[system] lumped = true`` models (no tooth geometry) are allowed.
    helical : bool or None
        True: the gears must be helical; False: spur; None: either.
    mesh_count : int or None
        The number of ``[[meshes]]`` a model needs (None: one or more).
    synthetic_tables : bool
        Whether ``hacgear`` can make synthetic tables for it (a spur pair's analytic FDF, before the statics).
    rotating_carrier : bool
        Whether its system turns in a rotating carrier frame (modal analysis over the carrier speed).
    face_twist : bool
        Whether its spur meshes take tables with a twist axis (``[statics] twist_points > 1``: the face-resolving
        statics tabulate the mesh twist, and the builder models the pair with six DOFs per gear, as a helical pair
        at helix angle 0), so that lead slope deviations and shaft misalignment act on them.
    """

    name: str = ""
    section: str | None = None
    lumped: bool = False
    helical: bool | None = False
    mesh_count: int | None = None
    synthetic_tables: bool = False
    rotating_carrier: bool = False
    face_twist: bool = False

    # ------------------------------------------------------------------ the model file
    def parse_section(self, reader: Any) -> Any:
        """The kind's section (a :class:`hacgear_core.model.toml.SectionReader` over ``[<section>]``, None when the
        file has none) -> a frozen dataclass stored as ``Model.section``; errors name file, key, unit and range
        (``reader.number(key, unit, lo, hi)``, ``reader.string``, ``reader.array_of_tables``, ``reader.done``).
        The tables' provenance does not cover it: a kind's section holds dynamics parameters, not what the tables
        depend on.  Default: no section (None)."""
        return None

    def members(self, model: Any) -> tuple[str, ...]:
        """Names a torque or a bearing output may refer to: the gears (and members such as a carrier)."""
        return tuple(g.name for g in model.gears)

    def bearing_stiffness(self, model: Any, member: str) -> float:
        """The translational support stiffness [N/m] of ``member`` (a gear; kinds with other members such as a
        carrier override this)."""
        return float(model.gear(member).support.translational_stiffness_N_per_m)

    def with_bearing_stiffness(self, model: Any, stiffness: Mapping[str, float]) -> Any:
        """``model`` with the translational support stiffness [N/m] of each member ``stiffness`` names."""
        return replace(model, gears=tuple(
            replace(g, support=replace(g.support, translational_stiffness_N_per_m=float(stiffness[g.name])))
            if g.name in stiffness else g for g in model.gears))

    def check(self, model: Any) -> None:
        """Refuse a model of this kind that the kind cannot build (mesh count, helix, section, members); raises
        ModelError naming the key."""
        if model.planetary is not None and self.section != "planetary":
            raise ModelError(f"[planetary] is only allowed for kind 'planetary', not '{self.name}'")
        if self.mesh_count is not None and len(model.meshes) != self.mesh_count:
            raise ModelError(f"system.kind = '{self.name}' needs exactly {self.mesh_count} [[meshes]], found "
                             f"{len(model.meshes)}")
        if model.lumped and not self.lumped:
            raise ModelError(f"system.lumped = true is not supported for kind '{self.name}'")
        if not model.lumped:
            helical = [g.name for g in model.gears if g.is_helical]
            if self.helical is True and not helical:
                raise ModelError(f"system.kind = '{self.name}' needs gears with helix_angle_deg != 0")
            if self.helical is False and helical:
                raise ModelError(f"system.kind = '{self.name}' is spur: helix_angle_deg must be 0 (gears {helical})")
        members = self.members(model)
        if model.operating.torque_gear not in members:
            raise ModelError(f"operating.torque_gear = {model.operating.torque_gear!r} names no gear (no [[gears]] "
                             f"with that name); allowed: {list(members)}")

    # ------------------------------------------------------------------ statics
    def mesh_pairs(self, model: Any) -> tuple[MeshPair, ...]:
        """The pairs that mesh, one table each (default: the model's meshes)."""
        return tuple(MeshPair(m.name, m.gear_a, m.gear_b) for m in model.meshes)

    def placement(self, model: Any, gears: Mapping, meshes: Mapping) -> Any:
        """The placed train (:class:`~hacgear_core.geometry.train.TrainGeometry`: gear centres, senses, mesh
        phases) of ``model`` from its ``gears`` and ``meshes`` geometry (default: one group of meshed gears,
        :func:`~hacgear_core.geometry.train_geometry`)."""
        return train_geometry(model, gears=gears, meshes=meshes)

    def nominal_mesh_forces(self, model: Any, base_radii: Mapping[str, tuple[float, float]]) -> dict[str, float]:
        """{table mesh: nominal force per contact [N]} at the model's operating torque, ``base_radii[mesh]`` the
        loaded flanks' base radii (r_b of gear_a, r_b of gear_b) [m]."""
        raise NotImplementedError

    # ------------------------------------------------------------------ dynamics
    def train(self, model: Any, tables: Any, **options) -> Train:
        """The train description of ``model`` on its ``tables``; ``options``: ``force_law``, ``torque_Nm``,
        ``bearing_stiffness_N_per_m``, ``modal_damping_ratio``, ``shafts`` and the kind's structural parameters."""
        raise NotImplementedError

    def structural_parameters(self, model: Any) -> tuple[StructuralParameter, ...]:
        """The kind's structural options (none by default)."""
        return ()

    def extra_outputs(self, model: Any, system: Any) -> tuple[ExtraOutput, ...]:
        """FMU outputs beyond the common ones of ``model``'s lumped ``system`` (none by default; a kind's own
        section, e.g. a gear train's shafts, lives in ``model``)."""
        return ()
