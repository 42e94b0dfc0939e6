"""In-memory force-deflection tables of a gear system: :class:`MeshTable` per mesh, :class:`SystemTables`.

A mesh table holds the static contact analyses of one mesh on a grid of mesh positions (one mesh cycle,
periodic) × loads (load control) and × a regular grid of mesh deflections (deflection control).  The
force-deflection function (FDF) ``force_N[position, deflection]`` drives the dynamics; the other arrays
(tooth loads, contact roll angles, half-widths and pressures, root strains = the strain-deflection
functions, hub reactions) give dynamic stresses and pressures by post-processing (dissertation Sections
3.2.3, 3.3, 4.3.2, 4.4.2).  Queries interpolate with the one rule of :mod:`hacgear_core.tables.interp`
and count every state outside the deflection grid in :attr:`MeshTable.stats`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from hacgear_core.errors import TableError
from hacgear_core.tables.interp import interp_rows, pair_rows, trilinear_many

__all__ = ["CONSTANT_TWIST_RAD", "InterpolationStats", "MeshTable", "PRESSURE_PARTS", "StrainTable", "SystemTables",
           "TwistTable", "with_constant_twist"]


@dataclass
class InterpolationStats:
    """Counts of interpolation queries and of points outside the deflection grid (extrapolated)."""

    n_queries: int = 0
    n_below: int = 0
    n_above: int = 0
    max_below_m: float = 0.0
    max_above_m: float = 0.0

    def add(self, x: np.ndarray, x_first: float, x_last: float) -> None:
        x = x[np.isfinite(x)]
        self.n_queries += int(x.size)
        below, above = x < x_first, x > x_last
        nb, na = int(np.count_nonzero(below)), int(np.count_nonzero(above))
        if nb:
            self.n_below += nb
            self.max_below_m = max(self.max_below_m, float(x_first - x[below].min()))
        if na:
            self.n_above += na
            self.max_above_m = max(self.max_above_m, float(x[above].max() - x_last))

    @property
    def n_extrapolated(self) -> int:
        return self.n_below + self.n_above

    def reset(self) -> None:
        self.n_queries = self.n_below = self.n_above = 0
        self.max_below_m = self.max_above_m = 0.0

    def report(self) -> str:
        if not self.n_extrapolated:
            return f"{self.n_queries} queries, none outside the deflection grid"
        return (f"{self.n_queries} queries, {self.n_above} above the deflection grid (by up to "
                f"{self.max_above_m:.3g} m) and {self.n_below} below it (by up to {self.max_below_m:.3g} m), "
                "linearly extrapolated")



def _f64(a: Any) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=np.float64))


class StrainTable(dict):
    """``MeshTable.strain``: a dict gauge → (Np, Nd, Nw) strain array (the table contract) that can also be
    called to interpolate: ``table.strain(gauge, position, deflection, tooth_offset=0)`` =
    :meth:`MeshTable.strain_at`."""

    def __init__(self, data: Mapping[str, np.ndarray], owner: "MeshTable | None" = None) -> None:
        super().__init__(data)
        self._owner = owner

    def __call__(self, gauge: str, position: Any, deflection: Any, tooth_offset: int = 0) -> np.ndarray:
        if self._owner is None:
            raise TableError("this strain dict is not attached to a MeshTable")
        return self._owner.strain_at(gauge, position, deflection, tooth_offset)



#: the parts of the contact pressure a table holds: over every contact, the flank (Hertzian) contacts, the tip edges
PRESSURE_PARTS = ("peak", "flank", "edge")

#: names of the arrays of a :class:`TwistTable` with their trailing shape after (Np, Nd, Nt) (None: not gridded)
TWIST_GRIDDED = ("generalized_fdf", "generalized_force", "tooth_load_N", "peak_pressure_Pa", "slice_load_N",
                 "slice_pressure_Pa")


@dataclass(frozen=True, eq=False)
class TwistTable:
    """The twist axis of a helical mesh table (docs/tables.md, "Helical meshes").  Nt twists, Ns face slices.

    ``twist_rad`` (Nt,) regular grid containing 0; ``no_load_deflection_m`` (Np, Nt); ``static_deflection_m``
    (Np, Nl, Nt); ``generalized_fdf`` (Np, Nd, Nt, 2): mesh force W [N] and twist moment M [N m], the generalized
    FDF: ``f_d = W r_mesh + M r_twist`` (exact for involute contacts); ``generalized_force`` (Np, Nd, Nt, 12): f_d
    summed contact by contact; ``tooth_load_N`` (Np, Nd, Nt, Nw); ``peak_pressure_Pa`` (Np, Nd, Nt), and split
    into ``flank_pressure_Pa`` / ``edge_pressure_Pa`` (Np, Nd, Nt; None in tables written before the split);
    ``slice_load_N``, ``slice_pressure_Pa`` (Np, Nd, Nt, Ns) at ``slice_z_m`` (Ns,) (global axial coordinate);
    ``strain`` gauge → (Np, Nd, Nt, Nw); ``r_mesh``, ``r_twist`` (12,): x = r_mesh·q, gamma = r_twist·q;
    ``frame``: e1, e2, e3, P_ref, n_ref, O_a, O_b (global frame), ``base_helix_angle_rad``, ``lever_arm_m``
    (2,), ``reference_plane_z_m``.  ``twist_offset_rad`` [rad] (not stored in the file; 0 as read): every lookup
    reads the grid at the mesh twist plus it, the constant twist at which the flanks of a lead slope deviation or an
    in-plane shaft misalignment meet (:mod:`hacgear_core.dynamics.lead`; set on the system's copy of the table)."""

    twist_rad: np.ndarray
    no_load_deflection_m: np.ndarray
    static_deflection_m: np.ndarray
    generalized_fdf: np.ndarray
    generalized_force: np.ndarray
    tooth_load_N: np.ndarray
    peak_pressure_Pa: np.ndarray
    slice_load_N: np.ndarray
    slice_pressure_Pa: np.ndarray
    slice_z_m: np.ndarray
    strain: dict
    r_mesh: np.ndarray
    r_twist: np.ndarray
    frame: dict
    base_helix_angle_rad: float
    lever_arm_m: np.ndarray
    reference_plane_z_m: float
    flank_pressure_Pa: np.ndarray | None = None
    edge_pressure_Pa: np.ndarray | None = None
    twist_offset_rad: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "twist_offset_rad", float(self.twist_offset_rad))
        if not math.isfinite(self.twist_offset_rad):
            raise TableError(f"twist_offset_rad [rad] must be finite, got {self.twist_offset_rad!r}")
        for k in ("flank_pressure_Pa", "edge_pressure_Pa"):
            if getattr(self, k) is not None:
                object.__setattr__(self, k, _f64(getattr(self, k)))
        for k in ("twist_rad", "no_load_deflection_m", "static_deflection_m", "generalized_fdf", "generalized_force",
                  "tooth_load_N", "peak_pressure_Pa", "slice_load_N", "slice_pressure_Pa", "slice_z_m", "r_mesh",
                  "r_twist", "lever_arm_m"):
            object.__setattr__(self, k, _f64(getattr(self, k)))
        object.__setattr__(self, "strain", {k: _f64(v) for k, v in self.strain.items()})
        object.__setattr__(self, "frame", {k: _f64(v) for k, v in self.frame.items()})
        t = self.twist_rad
        if t.size < 1 or (t.size > 1 and not np.allclose(np.diff(t), t[1] - t[0], rtol=1e-9, atol=0)) \
                or not np.any(np.abs(t) < 1e-15):
            raise TableError(f"twist_rad [rad] must be a regular increasing grid containing 0, got {t.tolist()}")
        if self.r_mesh.shape != (12,) or self.r_twist.shape != (12,):
            raise TableError("r_mesh and r_twist must have 12 entries (q = [u_a, theta_a, u_b, theta_b])")
        npos, nd, nt = self.generalized_fdf.shape[:3]
        if self.generalized_fdf.shape != (npos, nd, nt, 2) or nt != t.size:
            raise TableError(f"generalized_fdf has shape {self.generalized_fdf.shape}, expected (Np, Nd, {t.size}, 2)")
        if self.generalized_force.shape != (npos, nd, nt, 12):
            raise TableError(f"generalized_force has shape {self.generalized_force.shape}, expected "
                             f"{(npos, nd, nt, 12)}")
        if self.no_load_deflection_m.shape != (npos, nt):
            raise TableError(f"no_load_deflection_m has shape {self.no_load_deflection_m.shape}, expected {(npos, nt)}")
        for k in ("peak_pressure_Pa", "flank_pressure_Pa", "edge_pressure_Pa"):
            a = getattr(self, k)
            if a is not None and a.shape != (npos, nd, nt):
                raise TableError(f"{k} has shape {a.shape}, expected {(npos, nd, nt)}")

    @property
    def zero_index(self) -> int:
        return int(np.argmin(np.abs(self.twist_rad)))

    @property
    def dg(self) -> float:
        return float(self.twist_rad[1] - self.twist_rad[0]) if self.twist_rad.size > 1 else 1.0

    @property
    def lookup_origin_rad(self) -> float:
        """The mesh twist [rad] that reads the grid's first twist: ``twist_rad[0] - twist_offset_rad`` (every
        lookup of this table, and the kernel's, is at the mesh twist plus :attr:`twist_offset_rad`)."""
        return float(self.twist_rad[0]) - self.twist_offset_rad

    def _lookup(self, values: np.ndarray, x0: float, inv_dx: float, position, deflection, twist) -> np.ndarray:
        p, x, g = np.broadcast_arrays(*(np.asarray(a, float) for a in (position, deflection, twist)))
        v = values
        if v.shape[2] == 1:                          # a single twist: constant along the twist axis
            v = np.concatenate([v, v], axis=2)
        tail = v.shape[3:]
        v4 = np.ascontiguousarray(v.reshape(v.shape[:3] + (-1,)))
        out = np.empty((p.size, v4.shape[3]))
        trilinear_many(v4, x0, inv_dx, self.lookup_origin_rad, 1.0 / self.dg, np.ascontiguousarray(p.ravel()),
                       np.ascontiguousarray(x.ravel()), np.ascontiguousarray(g.ravel()), out)
        return out.reshape(p.shape + tail)


@dataclass(frozen=True, eq=False)
class MeshTable:
    """Tables of one gear mesh, all SI.  Np positions, Nd deflections, Nl loads, Nw tooth offsets.

    Fields follow the in-memory table contract (``docs/tables.md``); ``half_width_m`` (Np, Nd, Nw) and
    ``hub_reaction`` (gear → (Np, Nd, 3)) are additional outputs, ``solver`` names the static solver.
    Query methods are vectorised (NumPy broadcasting over ``position`` and ``deflection``) and count
    deflection-grid extrapolations in :attr:`stats`.

    Two sides.  A mesh's table is its drive side (``side = "drive"``, the loaded flanks ``flanks``); ``coast``
    holds the tables of its opposite flank pair (``side = "coast"``), or None for a one-sided table (a
    ``format_version`` 1 file: :meth:`require_coast` says so).  The coast table has the drive table's positions
    (row i = the gear pair at drive mesh position ``position[i]``); its deflection axis is the coast approach
    along the coast line of action from the drive kinematic position (coast contact begins near
    ``backlash_normal_m``); ``force_N`` >= 0 is the coast contact force.  Its per-pair arrays follow the same
    phase rule; coast pair ``k`` holds the tooth of gear ``g`` that drive pair ``k - pair_shift[g]`` holds, so
    the strain of one physical tooth whose drive pair phase is ``phi`` is
    ``coast.sdf(gauge, phi - pair_shift[gear], x_c)``.  ``backlash_normal_m`` [m] (along the coast line of
    action), ``backlash_circular_m`` [m] (operating pitch circle) and ``position_offset`` [mesh cycles] (the
    coast solver's own position is ``position_offset - position``) come from the geometry.
    """

    name: str
    gear_names: tuple[str, str]
    teeth: tuple[int, int]
    base_radius_m: tuple[float, float]
    position: np.ndarray
    deflection_m: np.ndarray
    force_N: np.ndarray
    no_load_deflection_m: np.ndarray
    load_N: np.ndarray
    static_deflection_m: np.ndarray
    tooth_offsets: np.ndarray
    tooth_load_N: np.ndarray
    contact_roll_deg: np.ndarray
    peak_pressure_Pa: np.ndarray
    strain: dict[str, np.ndarray]
    half_width_m: np.ndarray | None = None
    hub_reaction: dict[str, np.ndarray] = field(default_factory=dict)
    solver: str = ""
    stats: InterpolationStats = field(default_factory=InterpolationStats, repr=False)
    twist: TwistTable | None = None
    side: str = "drive"
    flanks: tuple[str, ...] = ()
    backlash_normal_m: float = float("nan")
    backlash_circular_m: float = float("nan")
    position_offset: float = float("nan")
    pair_shift: dict[str, int] = field(default_factory=dict)
    coast: "MeshTable | None" = None
    flank_pressure_Pa: np.ndarray | None = None
    edge_pressure_Pa: np.ndarray | None = None

    def __post_init__(self) -> None:
        for k in ("flank_pressure_Pa", "edge_pressure_Pa"):
            if getattr(self, k) is not None:
                object.__setattr__(self, k, _f64(getattr(self, k)))
        conv = {k: _f64(getattr(self, k)) for k in (
            "position", "deflection_m", "force_N", "no_load_deflection_m", "load_N", "static_deflection_m",
            "tooth_load_N", "contact_roll_deg", "peak_pressure_Pa")}
        for k, v in conv.items():
            object.__setattr__(self, k, v)
        object.__setattr__(self, "tooth_offsets", np.asarray(self.tooth_offsets, dtype=np.int64))
        object.__setattr__(self, "strain", StrainTable({k: _f64(v) for k, v in self.strain.items()}, self))
        object.__setattr__(self, "hub_reaction", {k: _f64(v) for k, v in self.hub_reaction.items()})
        if self.half_width_m is not None:
            object.__setattr__(self, "half_width_m", _f64(self.half_width_m))
        object.__setattr__(self, "gear_names", tuple(self.gear_names))
        object.__setattr__(self, "teeth", tuple(int(z) for z in self.teeth))
        object.__setattr__(self, "base_radius_m", tuple(float(r) for r in self.base_radius_m))
        where = f"mesh table '{self.name}'"
        npos, nd, nl, nw = self.position.size, self.deflection_m.size, self.load_N.size, self.tooth_offsets.size
        if npos < 2 or nd < 2 or nw < 1 or nl < 1:
            raise TableError(f"{where}: needs >= 2 positions, >= 2 deflections, >= 1 load and tooth offset; got "
                             f"Np={npos}, Nd={nd}, Nl={nl}, Nw={nw}")
        if not np.allclose(self.position, np.arange(npos) / npos, rtol=0, atol=1e-12):
            raise TableError(f"{where}: position [mesh cycles] must be k/Np, k = 0..Np-1")
        dx = np.diff(self.deflection_m)
        if not (np.all(dx > 0) and np.allclose(dx, dx[0], rtol=1e-9, atol=0)):
            raise TableError(f"{where}: deflection_m [m] must be a uniform increasing grid")
        shapes = {
            "force_N": (npos, nd), "no_load_deflection_m": (npos,), "static_deflection_m": (npos, nl),
            "tooth_load_N": (npos, nd, nw), "contact_roll_deg": (npos, nd, nw), "peak_pressure_Pa": (npos, nd),
        }
        if self.half_width_m is not None:
            shapes["half_width_m"] = (npos, nd, nw)
        for k in ("flank_pressure_Pa", "edge_pressure_Pa"):
            if getattr(self, k) is not None:
                shapes[k] = (npos, nd)
        for k, shp in shapes.items():
            if getattr(self, k).shape != shp:
                raise TableError(f"{where}: {k} has shape {getattr(self, k).shape}, expected {shp}")
        for g, a in self.strain.items():
            if a.shape != (npos, nd, nw):
                raise TableError(f"{where}: strain[{g!r}] has shape {a.shape}, expected {(npos, nd, nw)}")
        for g, a in self.hub_reaction.items():
            if a.shape != (npos, nd, 3):
                raise TableError(f"{where}: hub_reaction[{g!r}] has shape {a.shape}, expected {(npos, nd, 3)}")
        if not np.all(np.isfinite(self.force_N)):
            raise TableError(f"{where}: force_N contains NaN/inf (incomplete table?)")
        object.__setattr__(self, "flanks", tuple(str(f) for f in self.flanks))
        object.__setattr__(self, "pair_shift", {str(g): int(v) for g, v in self.pair_shift.items()})
        for k in ("backlash_normal_m", "backlash_circular_m", "position_offset"):
            object.__setattr__(self, k, float(getattr(self, k)))
        if self.side not in ("drive", "coast"):
            raise TableError(f"{where}: side must be 'drive' or 'coast', got {self.side!r}")
        if self.side == "coast":
            if self.coast is not None:
                raise TableError(f"{where}: a coast table cannot have a coast table")
            for k in ("backlash_normal_m", "backlash_circular_m"):
                v = getattr(self, k)
                if not (math.isfinite(v) and v >= 0):
                    raise TableError(f"{where} (coast side): {k} [m] must be finite and >= 0, got {v!r}")
            if not math.isfinite(self.position_offset):
                raise TableError(f"{where} (coast side): position_offset [mesh cycles] must be finite")
            if sorted(self.pair_shift) != sorted(self.gear_names):
                raise TableError(f"{where} (coast side): pair_shift must give an integer for each of "
                                 f"{list(self.gear_names)}, got {self.pair_shift}")
        elif self.coast is not None:
            c = self.coast
            if not isinstance(c, MeshTable) or c.side != "coast":
                raise TableError(f"{where}: coast must be a MeshTable with side 'coast'")
            if c.gear_names != self.gear_names or c.teeth != self.teeth or not np.array_equal(c.position,
                                                                                               self.position):
                raise TableError(f"{where}: the coast table must have the drive table's gears, teeth and positions")

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k != "_unrolled_cache"}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)

    def require_coast(self) -> "MeshTable":
        """The coast-side table; :class:`TableError` with the remedy when this table is one-sided."""
        if self.coast is None:
            raise TableError(
                f"the tables of mesh '{self.name}' have no coast side (a one-sided table: format_version 1, or "
                "written without it); torque reversal, backlash and coast contact need both sides. Regenerate "
                "the tables with `hacgear statics MODEL`.")
        return self.coast

    # -- grid facts ------------------------------------------------------------------------
    @property
    def n_positions(self) -> int:
        return int(self.position.size)

    @property
    def n_deflections(self) -> int:
        return int(self.deflection_m.size)

    @property
    def dx_m(self) -> float:
        return float(self.deflection_m[1] - self.deflection_m[0])


    @property
    def x0_m(self) -> float:
        return float(self.deflection_m[0])

    @property
    def inv_dx(self) -> float:
        """1 / deflection step [1/m]."""
        return 1.0 / self.dx_m

    # -- interpolation (one rule: hacgear_core.tables.interp) --------------------------------------
    def _count(self, x: np.ndarray) -> None:
        self.stats.add(np.ravel(x), float(self.deflection_m[0]), float(self.deflection_m[-1]))

    def interpolate(self, values: np.ndarray, position: Any, deflection: Any, *, count: bool = True) -> np.ndarray:
        """A quantity of the whole mesh ``values`` (Np, Nd, ...) at mesh ``position`` [mesh cycles] and
        ``deflection`` [m] (broadcast arrays; periodic in position) → array of the broadcast shape + trailing
        axes of ``values``."""
        p, x = np.broadcast_arrays(np.asarray(position, dtype=float), np.asarray(deflection, dtype=float))
        if count:
            self._count(x)
        return self._rows(values, p * self.n_positions, x, periodic=True)

    def interpolate_pair(self, values: np.ndarray, phase: Any, deflection: Any, *, count: bool = True) -> np.ndarray:
        """A per-tooth-pair quantity ``values`` (Np, Nd, Nw) of the tooth pair at pair ``phase`` [mesh cycles]
        (mesh position − tooth offset; 0 at its pitch-point contact) and ``deflection`` [m]; 0 where the pair
        is out of the tabulated window (out of mesh)."""
        ph, x = np.broadcast_arrays(np.asarray(phase, dtype=float), np.asarray(deflection, dtype=float))
        if count:
            self._count(x)
        rows = pair_rows(self.n_positions, self.tooth_offsets, ph)
        return self._rows(self.unrolled(values), rows, x, periodic=False)

    def _rows(self, values: np.ndarray, rows: np.ndarray, x: np.ndarray, periodic: bool) -> np.ndarray:
        v = np.ascontiguousarray(values, dtype=np.float64)
        if v.shape[:2] != (v.shape[0], self.n_deflections):
            raise TableError(f"mesh table '{self.name}': quantity has shape {v.shape}, expected (N, {self.n_deflections}, ...)")
        trail = v.shape[2:]
        v3 = v.reshape(v.shape[0], v.shape[1], -1)
        r = np.ascontiguousarray(rows, dtype=float).ravel()
        xx = np.ascontiguousarray(x, dtype=float).ravel()
        out = np.empty((r.size, v3.shape[2]))
        interp_rows(v3, periodic, self.x0_m, self.inv_dx, r, xx, out)
        return out.reshape(np.shape(rows) + trail)

    def unrolled(self, A: np.ndarray) -> np.ndarray:
        """Per-pair array (Np, Nd, Nw) → (Nw·Np, Nd) over the pair phase ascending (largest offset first),
        the row axis of :meth:`interpolate_pair` (cached per array)."""
        cache = self.__dict__.setdefault("_unrolled_cache", {})
        hit = cache.get(id(A))
        if hit is None or hit[0] is not A:
            offs = np.asarray(self.tooth_offsets)
            order = np.argsort(offs)[::-1]
            if not np.array_equal(np.diff(offs[order]), -np.ones(offs.size - 1, dtype=offs.dtype)):
                raise TableError(f"mesh table '{self.name}': tooth_offsets must be consecutive integers, "
                                 f"got {offs.tolist()}")
            hit = cache[id(A)] = (A, np.ascontiguousarray(np.concatenate([A[:, :, w] for w in order], axis=0)))
        return hit[1]

    def tooth_phase(self, position: Any, tooth_offset: int | np.ndarray = 0) -> np.ndarray:
        """Phase τ = position − k of tooth pair ``k`` [mesh cycles]: τ = 0 at its pitch-point contact.

        A pair's state depends only on τ (``X_k(p + 1) = X_{k−1}(p)``); the tables cover
        ``τ ∈ [−max(k), 1 − min(k))``."""
        return np.asarray(position, float) - np.asarray(tooth_offset)

    # -- public queries ------------------------------------------------------------------------
    def force(self, position: Any, deflection: Any) -> np.ndarray:
        """Mesh force [N] at mesh position [mesh cycles] and mesh deflection [m] (the FDF), >= 0."""
        return np.maximum(self.interpolate(self.force_N, position, deflection), 0.0)

    def pressure(self, position: Any, deflection: Any, part: str = "peak") -> np.ndarray:
        """Maximum contact pressure over all tooth pairs [Pa], >= 0: ``part`` "peak" over every contact, "flank"
        over the flank (Hertzian) contacts, "edge" over the tip-edge contacts (NaN where the table does not tell
        them apart: written before the split)."""
        data = self.pressure_data(part)
        if data is None:
            return np.full(np.broadcast(np.asarray(position), np.asarray(deflection)).shape, np.nan)
        return np.maximum(self.interpolate(data, position, deflection), 0.0)

    def pressure_data(self, part: str = "peak", twist: bool = False) -> np.ndarray | None:
        """The tabulated pressure of ``part`` (see :meth:`pressure`; ``twist``: the twist axis's), or None."""
        if part not in PRESSURE_PARTS:
            raise TableError(f"pressure part {part!r}; allowed: {' | '.join(PRESSURE_PARTS)}")
        owner = self.twist if twist else self
        return getattr(owner, f"{part}_pressure_Pa")

    def strain_at(self, gauge: str, position: Any, deflection: Any, tooth_offset: int = 0) -> np.ndarray:
        """Strain [-] at ``gauge`` ("<gear>/<gauge>") on the tooth of pair ``tooth_offset`` at mesh
        ``position`` [mesh cycles] and ``deflection`` [m] (also reachable as ``table.strain(gauge, ...)``);
        0 where the pair's phase leaves the tabulated window (out of mesh)."""
        return self.sdf(gauge, self.tooth_phase(position, tooth_offset), deflection)

    def sdf(self, gauge: str, tooth_phase: Any, deflection: Any) -> np.ndarray:
        """Strain-deflection function of one physical tooth: strain [-] at ``gauge`` on the tooth whose
        pair is at the pitch point at ``tooth_phase`` = 0 [mesh cycles] (dissertation Fig. 4.6)."""
        if gauge not in self.strain:
            raise TableError(f"mesh '{self.name}' has no gauge {gauge!r}; gauges: {sorted(self.strain)}")
        return self.interpolate_pair(dict.__getitem__(self.strain, gauge), tooth_phase, deflection)

    def sdf_twist(self, gauge: str, tooth_phase: Any, deflection: Any, twist: Any) -> np.ndarray:
        """Strain-deflection function of one physical tooth of a helical mesh at mesh twist ``twist`` [rad]: the
        pair rule of :meth:`sdf` on each twist slice of ``twist.strain[gauge]`` (Np, Nd, Nt, Nw), linear between the
        two slices that bracket each twist (linear extrapolation beyond the grid, the twist axis's rule in
        :mod:`~hacgear_core.tables.interp`)."""
        tw = self._twist()
        if gauge not in tw.strain:
            raise TableError(f"mesh '{self.name}' has no twist-resolved gauge {gauge!r}; gauges: {sorted(tw.strain)}")
        cache = self.__dict__.setdefault("_twist_slices", {})
        slices = cache.get(gauge)
        if slices is None:
            a = tw.strain[gauge]
            slices = cache[gauge] = [np.ascontiguousarray(a[:, :, k, :]) for k in range(a.shape[2])]
        ph, x, g = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (tooth_phase, deflection, twist)))
        nt = len(slices)
        if nt == 1:
            return self.interpolate_pair(slices[0], ph, x)
        r = (g - tw.lookup_origin_rad) / tw.dg
        k = np.clip(np.floor(r).astype(int), 0, nt - 2)
        t = r - k
        out = np.zeros(ph.shape)
        for m in np.unique(k):
            sel = k == m
            lo = self.interpolate_pair(slices[m], ph[sel], x[sel])
            hi = self.interpolate_pair(slices[m + 1], ph[sel], x[sel], count=False)
            out[sel] = lo + t[sel] * (hi - lo)
        return out

    def tooth_load(self, position: Any, deflection: Any, tooth_offset: int = 0) -> np.ndarray:
        """Load of tooth pair ``tooth_offset`` [N] (>= 0; 0 outside the tabulated window)."""
        return np.maximum(self.interpolate_pair(self.tooth_load_N, self.tooth_phase(position, tooth_offset),
                                                deflection), 0.0)

    def no_load_deflection(self, position: Any) -> np.ndarray:
        """NLMD [m], linear and periodic in position."""
        p = np.asarray(position, dtype=float)
        u = np.mod(p, 1.0) * self.n_positions
        i0f = np.floor(u)
        i0 = i0f.astype(np.intp) % self.n_positions
        i1 = (i0 + 1) % self.n_positions
        w = u - i0f
        return (1 - w) * self.no_load_deflection_m[i0] + w * self.no_load_deflection_m[i1]

    def static_deflection(self, position: Any, load_N: Any) -> np.ndarray:
        """Static mesh deflection [m] under mesh force ``load_N`` [N] from the load-control grid, linear in
        load (extrapolated linearly beyond the load grid) and periodic in position."""
        p, f = np.broadcast_arrays(np.asarray(position, float), np.asarray(load_N, float))
        u = np.mod(p, 1.0) * self.n_positions
        i0f = np.floor(u)
        i0 = i0f.astype(np.intp) % self.n_positions
        i1 = (i0 + 1) % self.n_positions
        w = u - i0f
        L = self.load_N
        j = np.clip(np.searchsorted(L, f, side="right") - 1, 0, L.size - 2)
        t = (f - L[j]) / (L[j + 1] - L[j])
        S = self.static_deflection_m
        return ((1 - w) * ((1 - t) * S[i0, j] + t * S[i0, j + 1]) + w * ((1 - t) * S[i1, j] + t * S[i1, j + 1]))

    @property
    def gauge_names(self) -> tuple[str, ...]:
        return tuple(self.strain)

    # -- helical meshes: the twist axis ----------------------------------------------------------
    def _twist(self) -> TwistTable:
        if self.twist is None:
            raise TableError(f"mesh table '{self.name}' has no twist axis (not a helical mesh table)")
        return self.twist

    def generalized(self, position: Any, deflection: Any, twist: Any) -> np.ndarray:
        """Mesh force W [N] and twist moment M [N m] at (position [cycles], deflection [m], twist [rad]) from one
        trilinear lookup → (..., 2); ``f_d = W r_mesh + M r_twist``.  Deflections outside the grid are counted."""
        tw = self._twist()
        self._count(np.ravel(deflection))
        return tw._lookup(tw.generalized_fdf, self.x0_m, self.inv_dx, position, deflection, twist)

    def generalized_force(self, position: Any, deflection: Any, twist: Any) -> np.ndarray:
        """The 12 components of f_d (Eq. 5.1) summed contact by contact → (..., 12)."""
        tw = self._twist()
        self._count(np.ravel(deflection))
        return tw._lookup(tw.generalized_force, self.x0_m, self.inv_dx, position, deflection, twist)

    def twist_quantity(self, values: np.ndarray, position: Any, deflection: Any, twist: Any) -> np.ndarray:
        """Any (Np, Nd, Nt, ...) array of the twist table at (position, deflection, twist)."""
        return self._twist()._lookup(values, self.x0_m, self.inv_dx, position, deflection, twist)


@dataclass(frozen=True, eq=False)
class SystemTables:
    """All mesh tables of one system plus provenance (root attributes of ``tables.h5``)."""

    meshes: dict[str, MeshTable]
    model_sha256: str
    format_version: int | None = None  # of the file it was read from (None: built in memory)
    hacgear_version: str = ""
    created: str = ""
    model_file: str = ""
    path: Path | None = None
    attrs: dict[str, Any] = field(default_factory=dict)

    def mesh(self, name: str | None = None) -> MeshTable:
        if name is None:
            return next(iter(self.meshes.values()))
        if name not in self.meshes:
            raise TableError(f"no mesh {name!r} in {self.path or 'tables'}; meshes: {list(self.meshes)}")
        return self.meshes[name]

    def extrapolation_report(self) -> str:
        return "; ".join(f"{m}: {t.stats.report()}" for m, t in self.meshes.items())


#: the twist grid [rad] of a table lifted to a constant twist axis (:func:`with_constant_twist`): 0 a grid point
CONSTANT_TWIST_RAD = (-1.0, 0.0, 1.0)


def with_constant_twist(table: MeshTable) -> MeshTable:
    """``table`` (a spur mesh's, no twist axis) with a twist axis on which nothing depends: the generalized FDF is
    its force at every twist of :data:`CONSTANT_TWIST_RAD` with zero twist moment, every per-pair array repeated
    along the twist; its coast side likewise.  A system mixing helical meshes (generalized law) and spur meshes
    runs the spur meshes on it with a zero twist vector: the twist is 0, a grid point, so every lookup returns the
    spur table's own value (trilinear at a grid point of the twist axis = bilinear on the table)."""
    if table.twist is not None:
        return table
    nt = len(CONSTANT_TWIST_RAD)

    def rep(a: np.ndarray | None, axis: int) -> np.ndarray | None:
        return None if a is None else np.repeat(np.expand_dims(np.asarray(a, float), axis), nt, axis=axis)

    npos, nd = table.force_N.shape
    gfdf = np.zeros((npos, nd, nt, 2))
    gfdf[..., 0] = table.force_N[:, :, None]
    twist = TwistTable(
        twist_rad=np.array(CONSTANT_TWIST_RAD), no_load_deflection_m=rep(table.no_load_deflection_m, 1),
        static_deflection_m=rep(table.static_deflection_m, 2), generalized_fdf=gfdf,
        generalized_force=np.zeros((npos, nd, nt, 12)), tooth_load_N=rep(table.tooth_load_N, 2),
        peak_pressure_Pa=rep(table.peak_pressure_Pa, 2), slice_load_N=rep(table.force_N, 2)[..., None],
        slice_pressure_Pa=rep(table.peak_pressure_Pa, 2)[..., None], slice_z_m=np.zeros(1),
        strain={g: rep(a, 2) for g, a in table.strain.items()}, r_mesh=np.zeros(12), r_twist=np.zeros(12), frame={},
        base_helix_angle_rad=0.0, lever_arm_m=np.asarray(table.base_radius_m, float), reference_plane_z_m=0.0,
        flank_pressure_Pa=rep(table.flank_pressure_Pa, 2), edge_pressure_Pa=rep(table.edge_pressure_Pa, 2))
    coast = None if table.coast is None else with_constant_twist(table.coast)
    return replace(table, twist=twist, coast=coast, stats=InterpolationStats())
