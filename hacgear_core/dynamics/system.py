"""Lumped gear systems: gear bodies, supports and mesh couplings assembled into M, K, C, G, K_W, mesh vectors.

Coordinates ``q`` (n,) are deviations from the reference motion: rotations [rad] counter-clockwise in the fixed
frame (the dissertation's convention for every shipped system, e.g. Eq. 3.4: ``x = r_b1 th1 + r_b2 th2``) and
translations [m] along given directions.  Equations of motion (dissertation Eqs. 3.1, 4.1, 4.5, 5.1)::

    M q'' + (C + W_c G) q' + (K - W_c^2 K_W) q + sum_k F_k(tau_k, x_k) v_k = f_ext
    x_k = v_k . q                                  (mesh deflection, Eqs. 3.4, 4.4, 4.8)
    tau_k = tau_ref + phase_k + w_k . q            (mesh position follows the gears' rotation)

``K`` holds the supports (bearing and shaft stiffnesses), ``G`` and ``K_W`` the gyroscopic and centripetal
terms of bodies in a rotating frame per unit carrier speed ``W_c = c_ratio omega_ref`` (zero for fixed-axis
trains), ``F_k`` the force law of mesh ``k`` (its force-deflection table, or a conventional law).

Damping: one modal damping ratio ``zeta`` for every elastic mode of the system linearised at the nominal
torque (each mesh's stiffness = the cycle mean of its force law's stiffness at its nominal static force; for
``hac`` the FDF's local slope), ``C = M Phi diag(2 zeta omega_r) Phi^T M`` with mass-normalised modes; modes of
zero frequency (a free rotation of the train) get none, so the mean speed is kept.

Loads of the constant-speed experiment (:meth:`LumpedSystem.fext_speed`): the torques that balance the nominal
mesh forces on the rotation DOFs (input and output gears; free gears such as idlers carry none), plus, on gears
held by shafts (rotational support stiffness), the static twist of the shaft at the mean static mesh
deflections: the shaft ends follow the reference rotation with the twist that transmits the nominal torque, so
the static mesh forces are the nominal ones and the shafts add stiffness to the deviations only.  A builder may
give the loads instead as nominal torques per gear (a planetary set's carrier carries its torque through the
planet bearings, not through a mesh), and constant ``static_forces`` present in every experiment (planet pin
position errors preload the planet bearings).
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Mapping, Sequence

import numpy as np

from hacgear_core.dynamics import kernels
from hacgear_core.dynamics.force_laws import FORCE_LAWS
from hacgear_core.dynamics.laws import MeshLaw, mesh_law
from hacgear_core.dynamics.linear import LinearDynamics, linear_dynamics
from hacgear_core.errors import ModelError
from hacgear_core.model.schema import RANGES
from hacgear_core.tables.fdf import static_stiffness

__all__ = ["GearBody", "MeshCoupling", "FrameCoupling", "LumpedSystem", "KernelArrays"]


def _profile_at(profile: tuple, pos: np.ndarray) -> np.ndarray:
    """An error profile over the position only, ``(samples (L npc,) [m], L, npc)``, at unwrapped positions ``pos``
    [cycles]: linear between samples, periodic over ``L`` cycles (the kernel's :func:`kernels.mesh_error`)."""
    samples, cycles, npc = profile[:3]
    u = np.mod(pos, float(cycles)) * float(npc)
    i = np.floor(u)
    a = u - i
    nt = int(cycles) * int(npc)
    i = np.mod(i.astype(np.int64), nt)
    i1 = (i + 1) % nt
    return samples[i] + a * (samples[i1] - samples[i])


def _check_disjoint(**arrays: np.ndarray) -> None:
    """ValueError naming the first two of ``arrays`` (name -> array) that share memory."""
    items = list(arrays.items())
    for i, (a, x) in enumerate(items):
        for b, y in items[i + 1:]:
            if np.shares_memory(x, y):
                raise ValueError(f"integrate: {a} and {b} share memory; the kernel writes both, so each must be an "
                                 f"array of its own (e.g. {b}.copy())")


@dataclass(frozen=True)
class GearBody:
    """One gear of a lumped system.

    ``sense``: operating sense of rotation (+1 CCW, -1 CW); ``speed_ratio``: its signed kinematic speed over the
    reference gear's speed in the reference gear's sense; ``rotation``: index of its rotation DOF (-1 when it
    does not rotate, e.g. a fixed ring); ``translations``: indices of its translation DOFs with unit
    ``directions`` (k, 2) in the fixed frame; ``radius_m``: characteristic radius (base radius of its first
    mesh) used to express rotations as arc lengths; ``teeth``; ``support``: (translational [N/m],
    rotational [N m/rad]) stiffness; ``frame_ratio``: the speed of the frame its translations live in over the
    reference speed (a planetary stage's carrier; None: the system's ``carrier_ratio``); ``stage``: the stage it
    belongs to (a gearbox's; '' elsewhere).
    """

    name: str
    teeth: int
    sense: float
    speed_ratio: float
    rotation: int
    translations: tuple[int, ...] = ()
    directions: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    radius_m: float = 1.0
    mass_kg: float = 0.0
    inertia_kgm2: float = 0.0
    support: tuple[float, float] = (math.inf, 0.0)
    frame_ratio: float | None = None
    stage: str = ""


@dataclass(frozen=True, eq=False)
class MeshCoupling:
    """One mesh of a lumped system: its table, line-of-action vector ``v`` (n,) (``x = v . q`` [m]), mesh-position
    vector ``w`` (n,) (``tau = tau_ref + phase + w . q`` [cycles]), the rotational part ``v_rot`` of ``v``
    (dynamic transmission error), ``phase`` [cycles], ``nominal_force_N`` (static force at the system's nominal
    torque), ``tooth_passage`` {gear: mesh position at which tooth 0 of that gear is at the pitch point} and the
    unit ``line_of_action`` (2,) in the system's frame along which gear_a pushes gear_b.  ``group``: meshes that
    share one table and the load (the sun meshes of a planetary set; their load sharing is reported);
    ``gear_alias`` {gear of this system: its name in the table} (a planet instance ``planet_2`` is ``planet`` in
    the table, so the table's gauge ``planet/SG`` is ``planet_2/SG`` here).

    Coast side (the opposite flanks, met when the torque reverses or the teeth cross the backlash): ``v_c`` (n,)
    its line-of-action vector (``xc = v_c . q`` [m], the coast approach, positive closing the backlash; None: the
    mesh is one-sided), ``nominal_coast_force_N`` the static coast force when the nominal torque is reversed,
    ``backlash_m`` the normal backlash along the coast line of action (the approach at which the coast flanks of
    ideal teeth touch; beyond it a mesh without a coast table has its teeth passing through each other).  The coast
    table is ``table.coast`` (None: drive-only table).

    Helical meshes (a table with a twist axis, docs/helical.md): ``t`` (n,) the twist vector (``gamma = t . q``
    [rad], the table's ``r_twist`` over the system's DOFs); ``v`` is then the table's ``r_mesh`` and the mesh
    puts the generalized force ``W v + M t`` on the DOFs (W mesh force [N], M twist moment [N m] from one trilinear
    lookup).  Their coast side (a coast table with a twist axis): ``v_c`` and ``t_c`` (n,) the coast table's
    ``r_mesh`` and ``r_twist`` (``xc = v_c . q``, ``gamma_c = t_c . q``), the coast generalized force
    ``Wc v_c + Mc t_c``.  A drive-only table with ``v_c`` and ``t_c`` (the coast flanks' vectors from the
    geometry) keeps its coast side force-free: a zero table whose deflection range ends at ``backlash_m`` (the
    coast approach at which the coast flanks touch), so a state beyond the backlash counts as out of range.
    Without ``t_c`` the helical mesh is one-sided and unguarded.

    ``rate`` ``(p, q)``: the mesh runs at ``p/q`` times the reference mesh frequency (integers > 0; (1, 1) for
    every mesh of a pair, idler chain, planetary set; a gear train's stages with other tooth counts differ): its
    kinematic position is ``p/q`` times the reference position (:meth:`LumpedSystem.kinematic_positions`).

    ``error`` (manufacturing errors of the gears' teeth, :mod:`hacgear_core.dynamics.gear_errors`): None, or the
    mesh's error profile ``(samples (L npc,) [m], L, npc)``: the error ``e`` [m] of the tooth pairs in contact along
    the line of action (positive: the flanks meet earlier) at the unwrapped mesh position ``c`` [cycles], linear
    between samples ``c = i / npc`` and periodic over ``L`` mesh cycles, or ``(samples (L npc nd,), L, npc, nd)``
    the same over the ``nd`` approaches of the drive table's deflection grid too; the drive flanks' force is their
    law at the deflection ``x - e(c[, x])``.  ``coast_error``: None, or the coast flanks' profile ``(samples (L npc,)
    [m], L, npc)`` over the position (the gears' runout and pitch errors; :func:`~hacgear_core.dynamics.gear_errors.
    coast_error_profile`): the coast force is the coast table's at ``xc - e_c(c)``."""

    name: str
    gear_a: str
    gear_b: str
    table: object
    v: np.ndarray
    w: np.ndarray
    v_rot: np.ndarray
    phase: float
    nominal_force_N: float
    teeth: tuple[int, int]
    base_radius_m: tuple[float, float]
    tooth_passage: Mapping[str, int] = field(default_factory=dict)
    line_of_action: tuple[float, float] = (0.0, 1.0)
    group: str = ""
    gear_alias: Mapping[str, str] = field(default_factory=dict)
    v_c: np.ndarray | None = None
    nominal_coast_force_N: float = 0.0
    backlash_m: float = math.inf
    t: np.ndarray | None = None
    t_c: np.ndarray | None = None
    rate: tuple[int, int] = (1, 1)
    error: tuple | None = None
    coast_error: tuple | None = None

    @property
    def coast_table(self):
        """The coast-flank table (``table.coast``), None for a drive-only table."""
        return getattr(self.table, "coast", None)


@dataclass(frozen=True, eq=False)
class FrameCoupling:
    """A spring between translations that live in two frames turning against each other (a shaft's bending between
    members of stages with different carrier frames).  With ``D`` the second frame's angle relative to the first
    (0 at the assembly position, where ``LumpedSystem.K`` holds the spring), the system's stiffness is
    ``K + (cos D - 1) kc + sin D ks``: ``kc``, ``ks`` (n, n) [N/m].  ``rate`` ``(p, q)`` (integers, ``q > 0``): the
    second frame turns ``p / q`` revolutions relative to the first per reference mesh cycle (signed,
    counter-clockwise positive), so ``D = 2 pi p / q`` times the reference mesh position in cycles
    (:func:`~hacgear_core.dynamics.kernels.frame_angle`)."""

    name: str
    kc: np.ndarray
    ks: np.ndarray
    rate: tuple[int, int]


@dataclass(frozen=True, eq=False)
class KernelArrays:
    """Everything the compiled kernel takes besides the state, packed (see :func:`kernels.select_kernel`)."""

    mats: np.ndarray
    kidx: np.ndarray
    kval: np.ndarray
    vecs: np.ndarray
    mmat: np.ndarray
    phase: np.ndarray
    u: np.ndarray
    scal: np.ndarray
    iref: int
    tab: np.ndarray
    tint: np.ndarray
    tflt: np.ndarray
    lin: np.ndarray
    lint: np.ndarray
    nz: np.ndarray


class LumpedSystem:
    """An assembled lumped gear system (any kind): its arrays (M, K, G, K_W, the coupling vectors), its meshes'
    law, and on first use its linearisation, modal damping C and step bound (:mod:`~hacgear_core.dynamics.linear`)
    and the kernel's packed arrays.  Assembled from a kind's train description by
    :func:`hacgear_core.kinds.assembly.assemble`.

    Parameters
    ----------
    name, kind : str
    dof_names : sequence of str (n,)
    mass, stiffness : (n, n) arrays
        Mass matrix [kg, kg m^2] and support stiffness matrix.
    gears : sequence of GearBody
    meshes : sequence of MeshCoupling (m)
    torque_Nm : float
        Nominal torque on the input gear [N m] (> 0) at which ``nominal_force_N`` of the meshes hold.
    input_gear : str
    modal_damping_ratio : float
        In ``RANGES["modal_damping_ratio"]`` (:data:`~hacgear_core.model.schema.RANGES`: [0, 1)).
    force_law : str
        ``hac`` or a conventional law (:data:`~hacgear_core.dynamics.force_laws.FORCE_LAWS`).
    reference_gear : str
        The gear whose rotation defines the reference motion (``u[iref] = 1``).
    gyroscopic, centripetal : (n, n) arrays, optional
        ``G`` and ``K_W`` per unit carrier speed (rotating frames); zero by default.
    carrier_ratio : float
        Carrier speed over the reference speed (``W_c = carrier_ratio omega_ref``).
    rigid_mode : (n,) array or None
        Deviation per radian of the reference gear's rotation (in its sense, ``u[iref] = 1``) that loads no mesh
        and no support (the free rotation of the train); None when the supports hold the train.
    mesh_cycles_per_rad : float, optional
        Mesh cycles per radian of the reference gear (default: its teeth / 2 pi; a planetary set's meshes run at
        the sun's speed relative to the carrier).
    nominal_torques_per_Nm : mapping, optional
        {gear: torque per N m of input torque, in the gear's operating sense}: the loads of the constant-speed
        experiment on the rotation DOFs (default: the torques that balance the nominal mesh forces, see the
        module docstring).  Springs of rotation DOFs then act on the deviations only.
    static_forces : (n,) array, optional
        Constant generalized forces of every experiment (e.g. the preload of bearing springs whose rest position is
        off the nominal one: planet pin position errors).
    bearing_maps : mapping, optional
        {gear: (A (2, n), b (2,), c (2,))}: the force [N] the gear puts on its bearing is ``A q + b + W_c^2 c`` in
        the system's frame (default: its support springs, or the sum of its mesh forces on a rigid bearing).
    reference_motion : (n,) array, optional
        DOF motion per radian of the reference motion (the train's rigid rotation, also where supports hold it):
        the absolute DOF velocities are ``q' + omega_ref * reference_motion`` (default: ``rigid_mode``, else each
        gear's speed ratio on its rotation).
    frame_couplings : sequence of FrameCoupling, optional
        Springs between frames that turn against each other: the stiffness then varies with the reference mesh
        position (:meth:`stiffness_at`); ``stiffness`` is its value at the assembly position, which the linear
        analyses (modes, damping, static equilibrium) take.
    """

    def __init__(self, *, name: str, kind: str, dof_names: Sequence[str], mass: np.ndarray, stiffness: np.ndarray,
                 gears: Sequence[GearBody], meshes: Sequence[MeshCoupling], torque_Nm: float, input_gear: str,
                 modal_damping_ratio: float, force_law: str = "hac", reference_gear: str | None = None,
                 gyroscopic: np.ndarray | None = None, centripetal: np.ndarray | None = None,
                 carrier_ratio: float = 0.0, rigid_mode: np.ndarray | None = None,
                 mesh_cycles_per_rad: float | None = None, nominal_torques_per_Nm: Mapping[str, float] | None = None,
                 static_forces: np.ndarray | None = None,
                 bearing_maps: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None,
                 reference_motion: np.ndarray | None = None,
                 frame_couplings: Sequence[FrameCoupling] = ()) -> None:
        n = len(dof_names)
        self.name = name
        self.kind = kind
        self.dof_names = tuple(dof_names)
        self.n = n
        self.M = np.ascontiguousarray(mass, dtype=float)
        self.K = np.ascontiguousarray(stiffness, dtype=float)
        if self.M.shape != (n, n) or self.K.shape != (n, n):
            raise ModelError(f"{name}: mass and stiffness must be ({n}, {n}), got {self.M.shape}, {self.K.shape}")
        self.G = np.zeros((n, n)) if gyroscopic is None else np.ascontiguousarray(gyroscopic, dtype=float)
        self.K_W = np.zeros((n, n)) if centripetal is None else np.ascontiguousarray(centripetal, dtype=float)
        self.carrier_ratio = float(carrier_ratio)
        self.frame_couplings = tuple(frame_couplings)
        for fc in self.frame_couplings:
            p, q = fc.rate
            if not (isinstance(p, (int, np.integer)) and isinstance(q, (int, np.integer)) and p != 0
                    and 0 < q < 2 ** 31 and abs(p) < 2 ** 31):
                raise ModelError(f"{name}: frame coupling '{fc.name}' rate (p, q) must be integers, p != 0, "
                                 f"0 < q < 2**31, got {fc.rate}")
            if np.shape(fc.kc) != (n, n) or np.shape(fc.ks) != (n, n):
                raise ModelError(f"{name}: frame coupling '{fc.name}' kc and ks must be ({n}, {n}) [N/m]")
        self.gears = {g.name: g for g in gears}
        self.meshes = tuple(meshes)
        self.m = len(self.meshes)
        if self.m < 1:
            raise ModelError(f"{name}: a gear system needs at least one mesh")
        self.mesh_names = tuple(c.name for c in self.meshes)
        if force_law not in FORCE_LAWS:
            raise ModelError(f"force law must be one of {FORCE_LAWS}, got {force_law!r}")
        self.force_law_name = force_law
        if not (math.isfinite(torque_Nm) and torque_Nm != 0):
            raise ModelError(f"torque_Nm [N*m] must be finite and nonzero (negative: the coast flanks carry it), "
                             f"got {torque_Nm!r}")
        self.torque_Nm = float(torque_Nm)
        if input_gear not in self.gears:
            raise ModelError(f"input gear {input_gear!r} is not a gear of {name}: {sorted(self.gears)}")
        self.input_gear = input_gear
        RANGES["modal_damping_ratio"].check("modal_damping_ratio", modal_damping_ratio)
        self.modal_damping_ratio = float(modal_damping_ratio)
        ref = reference_gear or self.meshes[0].gear_a
        self.reference_gear = ref
        rg = self.gears[ref]
        self.iref = rg.rotation
        self.sref = float(rg.sense)
        if rg.rotation < 0:
            raise ModelError(f"{name}: the reference gear '{ref}' needs a rotation DOF (it is held or prescribed)")
        self.zref_2pi = rg.teeth / (2 * math.pi) if mesh_cycles_per_rad is None else float(mesh_cycles_per_rad)
        if not (math.isfinite(self.zref_2pi) and self.zref_2pi > 0):
            raise ModelError(f"{name}: mesh cycles per radian of the reference gear must be > 0, got {self.zref_2pi}")
        self.mesh_cycles_per_rad = self.zref_2pi
        self.rigid_mode = None if rigid_mode is None else np.ascontiguousarray(rigid_mode, dtype=float)
        self.nominal_torques_per_Nm = None if nominal_torques_per_Nm is None else dict(nominal_torques_per_Nm)
        for g in (self.nominal_torques_per_Nm or {}):
            if g not in self.gears or self.gears[g].rotation < 0:
                raise ModelError(f"{name}: nominal torque on '{g}', which has no rotation DOF")
        self.static_forces = np.zeros(n) if static_forces is None else np.ascontiguousarray(static_forces, float)
        if reference_motion is None and self.rigid_mode is not None:
            reference_motion = self.rigid_mode
        if reference_motion is None:
            reference_motion = np.zeros(n)
            for g in self.gears.values():
                if g.rotation >= 0:
                    reference_motion[g.rotation] = g.speed_ratio
        self.reference_motion = np.ascontiguousarray(reference_motion, dtype=float)
        if self.static_forces.shape != (n,):
            raise ModelError(f"{name}: static_forces must have shape ({n},), got {self.static_forces.shape}")
        self.bearing_maps = {} if bearing_maps is None else {
            g: tuple(np.ascontiguousarray(x, float) for x in (tuple(v) + (np.zeros(2),))[:3])
            for g, v in bearing_maps.items()}
        self.V = np.ascontiguousarray(np.array([c.v for c in self.meshes], dtype=float))
        self.W = np.ascontiguousarray(np.array([c.w for c in self.meshes], dtype=float))
        self.V_rot = np.ascontiguousarray(np.array([c.v_rot for c in self.meshes], dtype=float))
        self.phase = np.array([c.phase for c in self.meshes], dtype=float)
        self.rate = np.array([c.rate for c in self.meshes], dtype=float).reshape(-1, 2)
        bad = [c.name for c in self.meshes if len(c.rate) != 2 or not all(
            isinstance(r, (int, np.integer)) and 0 < r < 2 ** 31 for r in c.rate)]
        if bad:
            raise ModelError(f"{name}: mesh rate (p, q) must be two integers in [1, 2**31), got "
                             f"{[c.rate for c in self.meshes if c.name in bad]} for meshes {bad}")
        #: the meshes' rates relative to the reference mesh, p / q
        self.rates = self.rate[:, 0] / self.rate[:, 1]
        #: True when every mesh runs at the reference mesh frequency
        self.unit_rates = bool(np.all(self.rate[:, 0] == self.rate[:, 1]))
        #: reference mesh cycles after which every mesh is back at its start position (lcm of the q / gcd(p, q))
        self.period_cycles = math.lcm(*(q // math.gcd(p, q) for p, q in (c.rate for c in self.meshes)))
        #: any mesh has a manufacturing-error profile (``MeshCoupling.error``): the kernel's error loops
        self.has_errors = any(c.error is not None or c.coast_error is not None for c in self.meshes)
        if self.has_errors:
            # a mesh at rate p/q with an error profile of L of its cycles: N reference cycles advance it N p / q of
            # its cycles, a whole number of profiles first at N = L q / gcd(L q, p) (the hunting-tooth period of its
            # gears in reference cycles)
            self.period_cycles = math.lcm(self.period_cycles, *(
                (int(e[1]) * c.rate[1]) // math.gcd(int(e[1]) * c.rate[1], c.rate[0])
                for c in self.meshes for e in (c.error, c.coast_error) if e is not None))
        # a frame coupling repeats when its frames are back at their relative angle: q / gcd(p, q) reference cycles
        self.period_cycles = math.lcm(self.period_cycles, *(
            fc.rate[1] // math.gcd(int(fc.rate[0]), int(fc.rate[1])) for fc in self.frame_couplings))
        self.Vc = np.ascontiguousarray(np.array([np.zeros(n) if c.v_c is None else c.v_c for c in self.meshes],
                                                dtype=float))
        self.T = np.ascontiguousarray(np.array([np.zeros(n) if c.t is None else c.t for c in self.meshes],
                                               dtype=float))
        self.Tc = np.ascontiguousarray(np.array([np.zeros(n) if c.t_c is None else c.t_c for c in self.meshes],
                                                dtype=float))
        self.backlash_m = np.array([c.backlash_m for c in self.meshes], dtype=float)
        #: the meshes' law (:mod:`~hacgear_core.dynamics.laws`): kernel variant, record fields, numpy twin
        self.mesh_law: MeshLaw = mesh_law(name, self.meshes, force_law)
        self.mesh_law.check_torque(self.torque_Nm)
        self.table_arrays = self.mesh_law.table_arrays
        self.coast_arrays = self.mesh_law.coast_arrays
        self.laws = self.mesh_law.force_laws
        #: any mesh has coast-flank tables the dynamics use (either torque sign is carried)
        self.two_sided = self.mesh_law.two_sided
        #: meshes of the compiled loop
        self.m_kernel = self.mesh_law.m_kernel
        self.kernel = self._select_kernel()
        self._cache: dict = {}
        self._kernel_ready = None  # the kernel prepare_kernel has made ready in this process

    def _select_kernel(self):
        law = self.mesh_law
        return kernels.select_kernel(law.kernel_law, self.n, law.m_kernel, law.kernel_two_sided,
                                     errors=getattr(self, "has_errors", False),
                                     frames=bool(getattr(self, "frame_couplings", ())))

    # ------------------------------------------------------------------ linearisation, damping, step bound
    @cached_property
    def linear(self) -> LinearDynamics:
        """The linearisation at the nominal torque, its modes, the modal damping and the step bound
        (:func:`~hacgear_core.dynamics.linear.linear_dynamics`), computed on first use."""
        return linear_dynamics(self)

    @property
    def k_lin(self) -> np.ndarray:
        return self.linear.k_lin

    @property
    def mesh_stiffness_N_per_m(self) -> np.ndarray:
        return self.linear.mesh_stiffness_N_per_m

    @property
    def generalized_stiffness(self) -> np.ndarray | None:
        """Per mesh (m, 2, 2) of the twist law: [[dW/dx, dW/dgamma], [dM/dx, dM/dgamma]] cycle means [N/m, N/rad,
        N m/m, N m/rad] (None for the other laws)."""
        return self.linear.generalized_stiffness

    @property
    def C(self) -> np.ndarray:
        return self.linear.C

    @property
    def modal_omega(self) -> np.ndarray:
        return self.linear.modal_omega

    @property
    def modal_shapes(self) -> np.ndarray:
        return self.linear.modal_shapes

    @property
    def rigid_modes(self) -> np.ndarray:
        return self.linear.rigid_modes

    @property
    def max_frequency_Hz(self) -> float:
        return self.linear.max_frequency_Hz

    @cached_property
    def minv(self) -> np.ndarray:
        return np.ascontiguousarray(np.linalg.inv(self.M))

    # ------------------------------------------------------------------ kernel arrays
    @cached_property
    def arrays(self) -> KernelArrays:
        """Everything the compiled kernel takes besides the state, packed (see :func:`kernels.select_kernel`)."""
        n, mq = self.n, self.m_kernel
        minv = self.minv
        mk, mkw = minv @ self.K, minv @ self.K_W
        mfr = [minv @ x for fc in self.frame_couplings for x in (fc.kc, fc.ks)]
        nonzero = (mk != 0) | (mkw != 0)
        for x in mfr:
            nonzero |= x != 0
        off = np.argwhere(nonzero & ~np.eye(n, dtype=bool)).reshape(-1, 2)
        kidx = np.ascontiguousarray(np.vstack([np.repeat(np.arange(n), 2).reshape(n, 2), off]).astype(np.int64))
        # the kernel's meshes and each one's second vector (the coast line of action, or a helical mesh's twist)
        kv, kw_, kvr, vc2, kph = self.mesh_law.kernel_meshes(self)
        tab, tint, tflt = self.mesh_law.kernel_tables(self)
        lin, lint = kernels.flatten_linear([lw.lin for lw in self.laws])
        if getattr(self, "has_errors", False):
            # one row per kernel mesh (a helical mesh's coast side is a kernel mesh of its own, without errors)
            lint = np.vstack([lint, np.zeros((mq - lint.shape[0], 2), np.int64)]) if lint.shape[0] < mq else lint
            lin, lint = kernels.flatten_errors(lin, lint, [c.error for c in self.meshes] + [None] * (mq - self.m),
                                               [c.coast_error for c in self.meshes] + [None] * (mq - self.m))
        vmi = kv @ minv.T
        vci = vc2 @ minv.T
        pattern = (kv != 0) | (kw_ != 0) | (vmi != 0) | (vc2 != 0) | (vci != 0)
        width = max(1, int(pattern.sum(axis=1).max()))
        nz = np.zeros((mq, 1 + width), dtype=np.int64)
        for k in range(mq):
            idx = np.flatnonzero(pattern[k])
            nz[k, 0] = idx.size
            nz[k, 1:1 + idx.size] = idx
        return KernelArrays(
            mats=np.ascontiguousarray(np.stack([minv, minv @ self.C, minv @ self.G])),
            kidx=kidx, kval=np.ascontiguousarray(np.stack([mk[kidx[:, 0], kidx[:, 1]], mkw[kidx[:, 0], kidx[:, 1]],
                                                         np.zeros(len(kidx))] + [x[kidx[:, 0], kidx[:, 1]]
                                                                                 for x in mfr])),
            vecs=np.ascontiguousarray(np.stack([kv, kw_, kvr, vmi, vc2, vci])),
            mmat=np.ascontiguousarray(np.stack([kv @ minv @ kv.T, kw_ @ minv @ kv.T, vc2 @ minv @ kv.T,
                                                kv @ minv @ vc2.T, kw_ @ minv @ vc2.T, vc2 @ minv @ vc2.T])),
            phase=np.ascontiguousarray(np.vstack([kph, np.tile(self.rate.T, len(kph) // self.m)]), dtype=float),
            u=np.zeros(n) if self.rigid_mode is None else self.rigid_mode,
            scal=np.array([self.carrier_ratio, self.sref, self.zref_2pi]
                          + [float(r) for fc in self.frame_couplings for r in fc.rate]), iref=int(self.iref), tab=tab,
            tint=tint,
            tflt=tflt, lin=lin, lint=lint, nz=nz)

    @cached_property
    def kernel_constants(self) -> tuple:
        """The kernel's trailing arguments (everything but the state, step, mode, loads and records)."""
        a = self.arrays
        work = np.zeros(7 * self.n + 22 * self.m_kernel + 2 * len(self.frame_couplings))
        eff = np.zeros((self.n, self.n))
        return (a.mats, a.vecs, a.mmat, a.phase, a.u, a.scal, a.iref, a.tab, a.tint, a.tflt, a.lin, a.lint, work, eff,
                a.kidx, a.kval, a.nz)

    def __getstate__(self) -> dict:
        # the compiled kernel travels by name (process pools): reselected on unpickling
        st = dict(self.__dict__)
        st.pop("kernel", None)
        st["_cache"] = {}
        st["_kernel_ready"] = None
        return st

    def __setstate__(self, st: dict) -> None:
        self.__dict__.update(st)
        st.setdefault("frame_couplings", ())
        if "reference_motion" not in st:  # pickled before the attribute existed
            self.reference_motion = self.rigid_mode if self.rigid_mode is not None else np.array(
                [next((g.speed_ratio for g in self.gears.values() if g.rotation == i), 0.0) for i in range(self.n)])
        self.kernel = self._select_kernel()

    def fingerprint(self) -> str:
        """SHA-256 (hex) of everything the dynamics depend on: matrices, mesh vectors, phases, tables, force law,
        torque, damping (the key of resumable sweep results)."""
        h = hashlib.sha256()
        for a in (self.M, self.K, self.G, self.K_W, self.V, self.W, self.phase, self.nominal_forces_N()):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        # terms only some kinds have (fixed-axis trains hash as before)
        if np.any(self.static_forces != 0):
            h.update(self.static_forces.tobytes())
        if not self.unit_rates:
            h.update(self.rate.tobytes())
        if self.nominal_torques_per_Nm is not None or self.zref_2pi != self.gears[self.reference_gear].teeth / (2 * math.pi):
            h.update(repr((sorted((self.nominal_torques_per_Nm or {}).items()), self.zref_2pi)).encode())
        for ta in self.table_arrays:
            h.update(repr(ta.ftab.shape).encode())
            h.update(ta.ftab.tobytes())
            h.update(np.array([ta.x0, ta.dx]).tobytes())
        self.mesh_law.fingerprint(self, h)
        for fc in self.frame_couplings:
            h.update(repr((fc.name, tuple(int(r) for r in fc.rate))).encode())
            h.update(np.ascontiguousarray(fc.kc, np.float64).tobytes())
            h.update(np.ascontiguousarray(fc.ks, np.float64).tobytes())
        if getattr(self, "has_errors", False):
            for c in self.meshes:
                if c.error is not None:
                    h.update(np.ascontiguousarray(c.error[0], np.float64).tobytes())
                    h.update(repr((c.name,) + tuple(int(v) for v in c.error[1:])).encode())
                if c.coast_error is not None:
                    h.update(np.ascontiguousarray(c.coast_error[0], np.float64).tobytes())
                    h.update(repr((c.name, "coast") + tuple(int(v) for v in c.coast_error[1:])).encode())
        h.update(repr((self.force_law_name, self.torque_Nm, self.modal_damping_ratio, self.carrier_ratio,
                       self.dof_names, self.mesh_names, self.reference_gear)).encode())
        return h.hexdigest()

    # ------------------------------------------------------------------ loads
    def nominal_forces_N(self, torque_Nm: float | None = None) -> np.ndarray:
        """Static drive-flank forces (m,) [N] of the constant-speed experiment at ``torque_Nm`` on the input gear
        (default: the nominal torque); the torque flow is linear in the torque; 0 for a negative torque (the
        coast flanks carry it: :meth:`nominal_coast_forces_N`)."""
        t = self.torque_Nm if torque_Nm is None else float(torque_Nm)
        return np.array([c.nominal_force_N for c in self.meshes]) * (max(t, 0.0) / abs(self.torque_Nm))

    def nominal_coast_forces_N(self, torque_Nm: float | None = None) -> np.ndarray:
        """Static coast-flank forces (m,) [N] at ``torque_Nm``: nonzero for a negative torque only."""
        t = self.torque_Nm if torque_Nm is None else float(torque_Nm)
        return np.array([c.nominal_coast_force_N for c in self.meshes]) * (max(-t, 0.0) / abs(self.torque_Nm))

    def loaded_side(self, torque_Nm: float | None = None) -> tuple[np.ndarray, np.ndarray, tuple]:
        """``(V, F, tables)`` of the flanks ``torque_Nm`` loads: the drive vectors, forces and tables for a
        positive torque, the coast ones for a negative torque."""
        t = self.torque_Nm if torque_Nm is None else float(torque_Nm)
        if t >= 0:
            return self.V, self.nominal_forces_N(t), tuple(c.table for c in self.meshes)
        missing = [c.name for c in self.meshes if c.coast_table is None]
        if missing:
            raise ModelError(f"{self.name}: torque {t} N*m loads the coast flanks; meshes {missing} have no coast "
                             "tables (regenerate them: hacgear statics)")
        return self.Vc, self.nominal_coast_forces_N(t), tuple(c.coast_table for c in self.meshes)

    def mean_static_deflections_m(self, torque_Nm: float | None = None) -> np.ndarray:
        """Cycle-mean static deflection (m,) [m] of every mesh's loaded flanks at its static force (for a negative
        torque the coast approach)."""
        t = self.torque_Nm if torque_Nm is None else float(torque_Nm)
        _, f, tabs = self.loaded_side(t)
        key = ("xbar", t)
        if key not in self._cache:
            self._cache[key] = np.array([static_stiffness(t, fk).mean_deflection_m for t, fk in zip(tabs, f)])
        return self._cache[key]

    def _rotation_mask(self) -> np.ndarray:
        mask = np.zeros(self.n, dtype=bool)
        for g in self.gears.values():
            if g.rotation >= 0:
                mask[g.rotation] = True
        return mask

    def fext_speed(self, torque_Nm: float | None = None) -> np.ndarray:
        """External generalized forces (n,) of the constant-speed experiment at ``torque_Nm`` (module docstring)."""
        t = self.torque_Nm if torque_Nm is None else float(torque_Nm)
        key = ("fext", t)
        if key in self._cache:
            return self._cache[key].copy()
        if self.nominal_torques_per_Nm is not None:
            fe = np.zeros(self.n)
            for g, tq in self.nominal_torques_per_Nm.items():
                gb = self.gears[g]
                fe[gb.rotation] += gb.sense * tq * t
        else:
            vl, f, _ = self.loaded_side(t)
            rot = self._rotation_mask()
            fe = np.where(rot, vl.T @ f, 0.0)
            shafts = [g.rotation for g in self.gears.values() if g.rotation >= 0 and g.support[1] > 0]
            if shafts:
                # the shafts' static twist, on the rotations only (the bearings react the mesh forces themselves)
                fe = fe + np.where(rot, self.K @ self.preload_state(t), 0.0)
        fe = np.ascontiguousarray(fe + self.static_forces)
        self._cache[key] = fe
        return fe.copy()

    def preload_state(self, torque_Nm: float | None = None) -> np.ndarray:
        """Static deviations (n,) at the mean static mesh deflections: translations deflected by the bearing
        reactions of the static mesh forces, rotations such that every mesh has its mean static deflection,
        the reference gear's rotation 0."""
        vl, f, _ = self.loaded_side(torque_Nm)
        xbar = self.mean_static_deflections_m(torque_Nm)
        rot = self._rotation_mask()
        q = np.zeros(self.n)
        tr = np.flatnonzero(~rot)
        if tr.size:
            ktt = self.K[np.ix_(tr, tr)]
            q[tr] = np.linalg.solve(ktt, -(vl.T @ f)[tr])
        ri = np.flatnonzero(rot)
        rhs = xbar - vl[:, tr] @ q[tr] if tr.size else xbar.copy()
        a = vl[:, ri]
        cons = np.zeros((1, ri.size))
        cons[0, list(ri).index(self.iref)] = 1.0
        sol, *_ = np.linalg.lstsq(np.vstack([a, cons]), np.concatenate([rhs, [0.0]]), rcond=None)
        q[ri] = sol
        return q

    def fext_torque(self, torques_Nm: Mapping[str, float]) -> np.ndarray:
        """External generalized forces (n,) for shaft torques {gear: T [N m]}, each positive in that gear's
        operating sense of rotation (a braking load is negative)."""
        f = self.static_forces.copy()
        for g, t in torques_Nm.items():
            gb = self.gears[g]
            f[gb.rotation] += gb.sense * float(t)
        return f

    # ------------------------------------------------------------------ force laws in Python
    def mesh_forces(self, tau: np.ndarray, x: np.ndarray, g: np.ndarray | float = 0.0) -> np.ndarray:
        """Forces [N] of every mesh's law at mesh positions ``tau`` (..., m) [cycles] and deflections ``x`` (..., m)
        [m] (a twist law's W at twists ``g`` (..., m) [rad])."""
        tau, x, g = np.broadcast_arrays(np.asarray(tau, float), np.asarray(x, float), np.asarray(g, float))
        out = np.empty(tau.shape)
        for k in range(self.m):
            out[..., k] = self.mesh_law.mesh_force(k, tau[..., k], x[..., k], g[..., k])
        return out

    def mesh_twists(self, q: np.ndarray) -> np.ndarray:
        """Mesh twists (..., m) [rad] of states ``q`` (..., n) (0 for meshes without a twist axis)."""
        return np.asarray(q) @ self.T.T

    def mesh_force(self, k: int, tau, x, g=0.0) -> np.ndarray:
        """Force [N] of mesh ``k``'s law at ``tau`` [cycles], ``x`` [m] (broadcast arrays; a twist law's W at twist
        ``g`` [rad])."""
        return self.mesh_law.mesh_force(k, tau, x, g)

    def mesh_slope(self, k: int, tau, x) -> np.ndarray:
        """Local slope dF/dx [N/m] of mesh ``k``'s law at ``tau``, ``x`` (0 where F = 0)."""
        return self.mesh_law.mesh_slope(k, tau, x)

    def coast_force(self, k: int, tau, xc) -> np.ndarray:
        """Coast-flank force [N] of mesh ``k`` at ``tau`` [cycles] and coast approach ``xc`` [m] (0 without a coast
        table), by the kernels' rule."""
        return self.mesh_law.coast_force(k, tau, xc)

    def coast_forces(self, tau: np.ndarray, xc: np.ndarray) -> np.ndarray:
        """Coast-flank forces [N] of every mesh at ``tau`` (..., m), ``xc`` (..., m)."""
        tau, xc = np.broadcast_arrays(np.asarray(tau, float), np.asarray(xc, float))
        out = np.empty(tau.shape)
        for k in range(self.m):
            out[..., k] = self.coast_force(k, tau[..., k], xc[..., k])
        return out

    def coast_slope(self, k: int, tau, xc) -> np.ndarray:
        """Local slope dFc/dxc [N/m] of mesh ``k``'s coast table (0 without one)."""
        return self.mesh_law.coast_slope(k, tau, xc)

    def frame_ratio(self, gear: str) -> float:
        """The speed of the frame gear ``gear``'s translations live in over the reference speed: its planetary
        stage's carrier (``carrier_ratio`` unless the gear names its own), 0 for the fixed frame."""
        fr = self.gears[gear].frame_ratio
        return self.carrier_ratio if fr is None else fr

    def frame_angles_rad(self, c: float) -> np.ndarray:
        """(P,) each frame coupling's relative angle [rad] at the unwrapped reference mesh position ``c`` [cycles]
        (0 at the assembly position; :class:`FrameCoupling`), by the kernel's :func:`kernels.frame_angle`."""
        whole = math.floor(float(c))
        return np.array([kernels.frame_angle(float(fc.rate[0]), float(fc.rate[1]), float(whole), float(c) - whole)
                         for fc in self.frame_couplings])

    def stiffness_at(self, c: float) -> np.ndarray:
        """(n, n) the stiffness matrix [N/m, N m/rad] at the unwrapped reference mesh position ``c`` [cycles]:
        ``K`` plus each frame coupling's ``(cos D - 1) kc + sin D ks`` (``K`` where there is none)."""
        k = self.K.copy()
        for fc, d in zip(self.frame_couplings, self.frame_angles_rad(float(c))):
            k += (math.cos(d) - 1.0) * fc.kc + math.sin(d) * fc.ks
        return k

    # ------------------------------------------------------------------ energy
    def kinetic_energy_J(self, v: np.ndarray, omega_ref: float) -> float:
        """Kinetic energy [J] ``1/2 u'^T M u'`` of the absolute DOF velocities ``u' = v + omega_ref
        reference_motion`` (``v`` (n,) the deviation velocities, ``omega_ref`` [rad/s] the reference speed)."""
        u = np.asarray(v, float) + float(omega_ref) * self.reference_motion
        return 0.5 * float(u @ self.M @ u)

    def elastic_energy_J(self, q: np.ndarray, tau: np.ndarray, omega_ref: float, reference_cycles: float = 0.0) -> float:
        """Potential energy [J] at deviations ``q`` (n,), mesh positions ``tau`` (m,) and reference speed
        ``omega_ref`` [rad/s]: the supports' and shafts' ``1/2 q^T K q`` less the work of the static spring forces
        ``f_s . q``, the centrifugal potential ``-1/2 W_c^2 q^T K_W q`` of a rotating frame, and the meshes' strain
        energy (:meth:`~hacgear_core.dynamics.laws.MeshLaw.elastic_energy`).  With frame couplings ``K`` is the
        stiffness at the unwrapped reference mesh position ``reference_cycles`` (:meth:`stiffness_at`)."""
        q = np.asarray(q, float)
        wc = self.carrier_ratio * float(omega_ref)
        k = self.stiffness_at(reference_cycles) if self.frame_couplings else self.K
        e = 0.5 * float(q @ k @ q) - float(self.static_forces @ q)
        if wc:
            e -= 0.5 * wc * wc * float(q @ self.K_W @ q)
        return e + self.mesh_law.elastic_energy(self, q, np.asarray(tau, float))

    def dissipated_power_W(self, v: np.ndarray) -> float:
        """Power [W] the modal damping dissipates at deviation velocities ``v`` (n,): ``v^T C v`` (>= 0; the rigid
        rotation is undamped, ``C u = 0``)."""
        v = np.asarray(v, float)
        return float(v @ self.C @ v)

    # ------------------------------------------------------------------ modal facts
    def natural_frequencies_Hz(self) -> np.ndarray:
        """Elastic natural frequencies of the linearisation used for damping [Hz], ascending."""
        return np.sort(self.modal_omega[~self.rigid_modes]) / (2 * math.pi)

    def steps_per_cycle(self, mesh_frequency_Hz: float, minimum: int = 128, per_period: int = 32) -> int:
        """Power-of-two RK4 steps per mesh cycle >= ``minimum`` such that the step also resolves the highest
        natural frequency with >= ``per_period`` steps."""
        need = max(minimum, per_period * self.max_frequency_Hz / mesh_frequency_Hz)
        return int(2 ** math.ceil(math.log2(need)))

    def mesh_kinematics(self, tau_ref, cycles=0.0) -> tuple[np.ndarray, np.ndarray]:
        """``(base, whole)`` (..., m): each mesh's kinematic position [cycles] in [0, 1) and its whole cycles with the
        reference mesh at ``cycles + tau_ref`` (``cycles`` whole reference cycles, ``tau_ref`` (...) in [0, 1)):
        ``(tau_ref, cycles)`` on a mesh at the reference rate, else the mesh's own (the kernel's rule,
        :func:`kernels.mesh_base`)."""
        t = np.asarray(tau_ref, dtype=float)
        c = np.broadcast_to(np.asarray(cycles, dtype=float), t.shape)
        base = np.repeat(t[..., None], self.m, axis=-1)
        whole = np.repeat(c[..., None], self.m, axis=-1)
        for k in np.flatnonzero(self.rate[:, 0] != self.rate[:, 1]):
            p, q = self.rate[k]
            for i in np.ndindex(t.shape):
                base[i + (k,)], whole[i + (k,)] = kernels.mesh_base(p, q, float(c[i]), float(t[i]))
        return base, whole

    def kinematic_positions(self, tau_ref, cycles=0.0) -> np.ndarray:
        """The meshes' kinematic positions [cycles] (..., m) in [0, 1) (:meth:`mesh_kinematics`)."""
        return self.mesh_kinematics(tau_ref, cycles)[0]

    def coast_errors_m(self, positions) -> np.ndarray:
        """The coast flanks' errors [m] (..., m) at unwrapped mesh positions ``positions`` (..., m) [cycles]
        (``MeshCoupling.coast_error``, by the kernel's rule; 0 without one)."""
        pos = np.asarray(positions, dtype=float)
        out = np.zeros(pos.shape)
        for k, c in enumerate(self.meshes):
            if c.coast_error is not None:
                out[..., k] = _profile_at(c.coast_error, pos[..., k])
        return out

    def mesh_errors_m(self, positions, x=None) -> np.ndarray:
        """Manufacturing errors [m] (..., m) of the meshes at unwrapped mesh positions ``positions`` (..., m)
        [cycles] and approaches ``x`` (..., m) [m] (each mesh's error profile, ``MeshCoupling.error``, by the
        kernel's rule, :func:`kernels.mesh_error`; 0 without one; ``x`` is needed by profiles over the approach)."""
        pos = np.asarray(positions, dtype=float)
        xx = None if x is None else np.broadcast_to(np.asarray(x, dtype=float), pos.shape)
        out = np.zeros(pos.shape)
        for k, c in enumerate(self.meshes):
            if c.error is None:
                continue
            samples, cycles, npc = c.error[:3]
            nd = int(c.error[3]) if len(c.error) > 3 else 0
            if nd == 0:
                out[..., k] = _profile_at(c.error, pos[..., k])
                continue
            u = np.mod(pos[..., k], float(cycles)) * float(npc)
            i = np.floor(u)
            a = u - i
            nt = int(cycles) * int(npc)
            i = np.mod(i.astype(np.int64), nt)
            i1 = (i + 1) % nt
            if xx is None:
                raise ValueError(f"mesh '{c.name}': its error profile depends on the approach; give x")
            ta = self.table_arrays[k]
            r = (xx[..., k] - ta.x0) * ta.inv_dx
            j = np.floor(r)
            b = r - j
            b = np.where(j < 0, 0.0, np.where(j > nd - 2, 1.0, b))
            j = np.clip(j, 0, nd - 2).astype(np.int64)
            v0 = samples[i * nd + j] + b * (samples[i * nd + j + 1] - samples[i * nd + j])
            v1 = samples[i1 * nd + j] + b * (samples[i1 * nd + j + 1] - samples[i1 * nd + j])
            out[..., k] = v0 + a * (v1 - v0)
        return out

    def unwrapped_positions(self, c) -> np.ndarray:
        """Kinematic positions [cycles] (..., m) of the meshes, unwrapped, with the reference mesh at ``c`` (...)
        unwrapped reference cycles: ``rate_k c``."""
        return np.asarray(c, dtype=float)[..., None] * self.rates

    def mesh_frequency_Hz(self, omega_ref_rad_s: float) -> float:
        """Mesh frequency [Hz] at reference speed ``omega_ref_rad_s`` [rad/s]."""
        return float(omega_ref_rad_s) * self.zref_2pi

    def reference_speed(self, mesh_frequency_Hz: float) -> float:
        """Reference speed [rad/s] at mesh frequency ``mesh_frequency_Hz`` [Hz]."""
        return float(mesh_frequency_Hz) / self.zref_2pi

    # ------------------------------------------------------------------ the kernel
    @property
    def record_width(self) -> int:
        """Columns of the kernel's ``rec_out`` for this system (:func:`kernels.record_width` of its kernel meshes)."""
        return kernels.record_width(self.m_kernel)

    def record_fields(self, rec_out: np.ndarray) -> dict[str, np.ndarray]:
        """Named per-mesh views of this system's kernel records (its mesh law's fields,
        :meth:`~hacgear_core.dynamics.laws.MeshLaw.record_fields`)."""
        return self.mesh_law.record_fields(rec_out)

    def integrate(self, s: np.ndarray, kin: np.ndarray, n_steps: int, h: float, fext: np.ndarray, *,
                  mode: int = kernels.MODE_SPEED, rec_every: int = 0, rec_state: np.ndarray | None = None,
                  rec_out: np.ndarray | None = None) -> int:
        """Advance ``n_steps`` RK4 steps of ``h`` [s] in place (see :mod:`~hacgear_core.dynamics.kernels`).

        ``s``, ``kin`` and the records are written: each must be an array of its own (ValueError where two share
        memory; the kernel is compiled with its arrays marked ``noalias``)."""
        if rec_state is None:
            rec_state = np.zeros((0, 2 * self.n))
            rec_out = np.zeros((0, self.record_width))
            _check_disjoint(s=s, kin=kin)
        else:
            _check_disjoint(s=s, kin=kin, rec_state=rec_state, rec_out=rec_out)
        if self._kernel_ready is not self.kernel:
            self.prepare_kernel()
        return self.kernel(s, kin, int(n_steps), float(h), int(mode), fext, int(rec_every), rec_state, rec_out,
                           *self.kernel_constants)

    def prepare_kernel(self, notice=None) -> tuple[bool, float]:
        """Load this system's kernel specialisation from numba's cache or compile it (once per machine), saying
        so first through ``notice(message)`` (default: the :data:`~hacgear_core.dynamics.kernels.COMPILE_LOGGER`
        logger); :meth:`integrate` does this on its first call.  Returns ``(compiled, seconds)``
        (:func:`~hacgear_core.dynamics.kernels.prepare_kernel`)."""
        n = self.n
        args = (np.zeros(2 * n), np.zeros(3 + self.m_kernel), 0, 0.0, kernels.MODE_SPEED, np.zeros(n), 0,
                np.zeros((0, 2 * n)), np.zeros((0, self.record_width)), *self.kernel_constants)
        out = kernels.prepare_kernel(self.kernel, args, self.kernel_label, notice)
        self._kernel_ready = self.kernel
        return out

    @property
    def kernel_label(self) -> str:
        """This system's kernel specialisation in words (the compile notice's)."""
        law = self.mesh_law
        return kernels.kernel_label(law.kernel_law, self.n, law.m_kernel, law.kernel_two_sided,
                                    errors=getattr(self, "has_errors", False))

    def with_changes(self, **changes) -> "LumpedSystem":
        """A copy rebuilt with some constructor arguments changed (torque, damping, force law...)."""
        kw = dict(name=self.name, kind=self.kind, dof_names=self.dof_names, mass=self.M, stiffness=self.K,
                  gears=tuple(self.gears.values()), meshes=self.meshes, torque_Nm=self.torque_Nm,
                  input_gear=self.input_gear, modal_damping_ratio=self.modal_damping_ratio,
                  force_law=self.force_law_name, reference_gear=self.reference_gear, gyroscopic=self.G,
                  centripetal=self.K_W, carrier_ratio=self.carrier_ratio, rigid_mode=self.rigid_mode,
                  mesh_cycles_per_rad=self.zref_2pi, nominal_torques_per_Nm=self.nominal_torques_per_Nm,
                  static_forces=self.static_forces, bearing_maps=self.bearing_maps,
                  reference_motion=self.reference_motion, frame_couplings=self.frame_couplings)
        if "torque_Nm" in changes and "meshes" not in changes:
            t = float(changes["torque_Nm"])
            r = abs(t / self.torque_Nm)  # nominal forces are magnitudes; the torque's sign picks the flanks
            kw["meshes"] = tuple(replace(c, nominal_force_N=c.nominal_force_N * r,
                                         nominal_coast_force_N=c.nominal_coast_force_N * r) for c in self.meshes)
        kw.update(changes)
        return LumpedSystem(**kw)


