"""The one train assembly: a :class:`~hacgear_core.kinds.base.Train` description -> a
:class:`~hacgear_core.dynamics.system.LumpedSystem`.

One DOF bookkeeping: the bodies in order, each body's DOFs in order, a DOF whose support is rigid left out with
every coefficient on it.  One support rule (:class:`~hacgear_core.kinds.base.Support`): inf rigid (dropped), finite
> 0 a diagonal spring to ground, 0 free.  M holds each DOF's inertia on its diagonal; K the supports, then every
:class:`~hacgear_core.kinds.base.Spring` (``k B^T B``, in the order given); G and K_W the entries the train lists;
the coupling vectors their coefficients at the DOFs kept.
"""
from __future__ import annotations

import numpy as np

from hacgear_core.dynamics.system import FrameCoupling, GearBody, LumpedSystem, MeshCoupling
from hacgear_core.errors import ModelError
from hacgear_core.kinds.base import KeyVector, Train

__all__ = ["DofMap", "assemble"]


class DofMap:
    """The DOF numbering of a train: ``index[(body, label)]`` for every DOF kept, ``names`` in order."""

    def __init__(self, train: Train) -> None:
        self.index: dict[tuple[str, str], int] = {}
        self.names: list[str] = []
        self.dofs = []
        for b in train.bodies:
            for d in b.dofs:
                if d.support.rigid:
                    continue
                key = (b.name, d.label)
                if key in self.index:
                    raise ModelError(f"{train.name}: body '{b.name}' names DOF '{d.label}' twice")
                self.index[key] = len(self.names)
                self.names.append(f"{b.name}.{d.label}")
                self.dofs.append(d)
        self.n = len(self.names)

    def vector(self, kv: KeyVector | None) -> np.ndarray | None:
        """The (n,) array of ``kv``, its coefficients at the DOFs kept (None stays None)."""
        if kv is None:
            return None
        v = np.zeros(self.n)
        for key, c in kv:
            i = self.index.get(key)
            if i is not None:
                v[i] += c
        return v

    def matrix(self, rows) -> np.ndarray:
        """The (len(rows), n) array of KeyVector rows."""
        b = np.zeros((len(rows), self.n))
        for r, kv in enumerate(rows):
            for key, c in kv:
                i = self.index.get(key)
                if i is not None:
                    b[r, i] += c
        return b


def assemble(train: Train) -> LumpedSystem:
    """The lumped system of ``train`` (module docstring)."""
    bad = [c.name for c in train.couplings if c.law not in ("table", "twist") or (c.law == "twist") != (c.t is not None)]
    if bad:
        raise ModelError(f"{train.name}: couplings {bad} must have the mesh law 'table' (no twist vector) or 'twist' "
                         "(with its twist vector t); a train may mix them (its spur meshes then run on the twist law)")
    dm = DofMap(train)
    n = dm.n
    M = np.zeros((n, n))
    K = np.zeros((n, n))
    for i, d in enumerate(dm.dofs):
        M[i, i] = d.inertia
        K[i, i] += d.support.stiffness
    bad = [dm.names[i] for i in range(n) if not M[i, i] > 0]
    if bad:
        raise ModelError(f"{train.name}: masses and inertias must be > 0 (kg, kg*m^2) where a body has DOFs; zero "
                         f"for {bad}")
    G = np.zeros((n, n))
    KW = np.zeros((n, n))
    for target, entries in ((G, train.gyroscopic), (KW, train.centripetal)):
        for a, b, val in entries:
            if a in dm.index and b in dm.index:
                target[dm.index[a], dm.index[b]] += val
    fstat = np.zeros(n)
    bmaps: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    for s in train.springs:
        B = dm.matrix(s.rows)
        K += s.k * B.T @ B
        if s.preload:
            fstat += s.k * B.T @ np.asarray(s.preload, float)
        if s.reports:
            e = np.asarray(s.preload, float) if s.preload else np.zeros(len(s.rows))
            bmaps[s.reports] = (s.k * s.frame @ B, -s.k * s.frame @ e, np.asarray(s.centrifugal, float))
    frames = []
    turn = np.array([[0.0, -1.0], [1.0, 0.0]])
    for fs in train.frame_springs:
        # energy k/2 |R_a a - R_b b|^2 (a = B_a q, b = B_b q in their frames): k/2 (|a|^2 + |b|^2) - k a . R(D) b with
        # R(D) = cos D I + sin D J the second frame's turn relative to the first; K holds it at D = 0
        ba, bb = dm.matrix(fs.rows_a), dm.matrix(fs.rows_b)
        K += fs.k * (ba - bb).T @ (ba - bb)
        frames.append(FrameCoupling(name=fs.name, kc=-fs.k * (ba.T @ bb + bb.T @ ba),
                                    ks=-fs.k * (ba.T @ turn @ bb + bb.T @ turn.T @ ba), rate=tuple(fs.rate)))
    for name in train.support_reports:
        body = next(b for b in train.bodies if b.name == name)
        a = np.zeros((2, n))
        kept = False
        for d in body.dofs:
            i = dm.index.get((name, d.label))
            if i is not None and d.direction is not None:
                a[:, i] += d.support.stiffness * np.asarray(d.direction, float)
                kept = True
        if kept:
            bmaps[name] = (a, np.zeros(2), np.zeros(2))
    for name in train.bearing_reports:
        a, b_ = np.zeros((2, n)), np.zeros(2)
        for s in train.springs:
            if s.reports and s.reports != name:
                a += bmaps[s.reports][0]
                b_ += bmaps[s.reports][1]
        bmaps[name] = (a, b_, np.zeros(2))
    couplings = [MeshCoupling(
        name=c.name, gear_a=c.gear_a, gear_b=c.gear_b, table=c.table, v=dm.vector(c.v), w=dm.vector(c.w),
        v_rot=dm.vector(c.v_rot), phase=float(c.phase), nominal_force_N=float(c.nominal_force_N), teeth=tuple(c.teeth),
        base_radius_m=tuple(c.base_radius_m), tooth_passage=dict(c.tooth_passage),
        line_of_action=tuple(c.line_of_action), group=c.group, gear_alias=dict(c.gear_alias), v_c=dm.vector(c.v_c),
        nominal_coast_force_N=float(c.nominal_coast_force_N), backlash_m=float(c.backlash_m), t=dm.vector(c.t),
        t_c=dm.vector(c.t_c), rate=tuple(c.rate)) for c in train.couplings]
    bodies = []
    for b in train.bodies:
        tr = [(dm.index[(b.name, d.label)], d.direction) for d in b.dofs
              if d.direction is not None and (b.name, d.label) in dm.index]
        bodies.append(GearBody(name=b.name, teeth=int(b.teeth), sense=float(b.sense), speed_ratio=float(b.speed_ratio),
                               rotation=dm.index.get((b.name, b.rotation), -1), translations=tuple(i for i, _ in tr),
                               directions=np.array([d for _, d in tr], dtype=float).reshape(-1, 2),
                               radius_m=float(b.radius_m), mass_kg=b.mass_kg, inertia_kgm2=b.inertia_kgm2,
                               support=tuple(b.support),
                               frame_ratio=None if b.frame_ratio is None else float(b.frame_ratio),
                               stage=b.stage))
    u = dm.vector(train.rigid_mode)
    motion = u
    if u is not None:
        # a held member stops the free rotation through a support or shaft (K), or through a mesh whose other gear
        # the motion turns (a mesh deflected by it: e.g. a planetary set's sun held, its carrier driven)
        held = bool(np.any(np.abs(K @ u) > train.held_tolerance * max(1.0, float(np.max(np.abs(K))))))
        scale = 1e-6 * float(np.max(np.abs(u)))  # a kinematic motion deflects no mesh (beyond rounded radii)
        held = held or any(abs(float(c.v @ u)) > scale * float(np.max(np.abs(c.v))) for c in couplings)
        u = None if held else u
    return LumpedSystem(
        name=train.name, kind=train.kind, dof_names=dm.names, mass=M, stiffness=K, gears=bodies, meshes=couplings,
        torque_Nm=train.torque_Nm, input_gear=train.input_gear, modal_damping_ratio=train.modal_damping_ratio,
        force_law=train.force_law, reference_gear=train.reference_gear,
        gyroscopic=G if train.gyroscopic else None, centripetal=KW if train.centripetal else None,
        carrier_ratio=train.carrier_ratio, rigid_mode=u, mesh_cycles_per_rad=train.mesh_cycles_per_rad,
        nominal_torques_per_Nm=train.nominal_torques_per_Nm, static_forces=fstat if fstat.any() else None,
        bearing_maps=bmaps or None, reference_motion=motion, frame_couplings=tuple(frames))
