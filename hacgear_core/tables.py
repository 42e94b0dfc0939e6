"""Force-deflection tables (``tables.h5``): HDF5 format, reading/writing, interpolation.

A table holds, per gear mesh, the results of the static contact analyses on a grid of mesh positions
(one mesh cycle, periodic) × loads (load control) and × a regular grid of mesh deflections
(deflection control).  The force-deflection function (FDF) ``force_N[position, deflection]`` drives the
dynamics; the other arrays (tooth loads, contact positions and pressures, root strains = the
strain-deflection functions, hub reactions) give dynamic stresses and pressures by post-processing
(dissertation Sections 3.2.3, 3.3, 4.3.2, 4.4.2).  The file format is documented in ``docs/tables.md``.

Interpolation policy (all ``MeshTable`` queries, vectorised over broadcast arrays):

* linear in both axes; periodic in position with period 1 mesh cycle for quantities of the whole mesh
  (force, peak pressure); quantities of one tooth pair (tooth load, strain on tooth offset k) follow the
  pair: ``X_k(p + 1) = X_{k-1}(p)`` (see :meth:`MeshTable.tooth_phase`);
* beyond the deflection grid: linear extrapolation from the first/last two grid columns; every query
  point outside the grid is counted in :class:`InterpolationStats` (``MeshTable.stats``);
* force, pressure and tooth loads are clipped at >= 0 (so a force is never negative, also when
  extrapolated); strains are not clipped.

For compiled dynamics kernels use :meth:`MeshTable.kernel_arrays` and :func:`fdf_force` (numba).
"""
from __future__ import annotations

import datetime as _dt
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping, NamedTuple

import numpy as np

from hacgear_core.errors import TableError

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "DATASETS",
    "InterpolationStats",
    "KernelArrays",
    "MeshTable",
    "StrainTable",
    "SystemTables",
    "MeshLayout",
    "read_tables",
    "write_tables",
    "load_system_tables",
    "fdf_force",
    "open_statics_file",
    "write_position",
    "completed_table_matches",
    "write_deflection_grid",
    "consistency_summary",
]

FORMAT = "hacgear-tables"
FORMAT_VERSION = 1

#: dataset name → (unit, description); ``strain/<gear>/<gauge>`` and ``hub_reaction/<gear>`` are per gauge/gear
DATASETS: dict[str, tuple[str, str]] = {
    "position": ("1", "mesh position [mesh cycles], position[k] = k/Np; integer = pitch-point contact of the "
                      "reference tooth pair (offset 0); periodic with period 1"),
    "load_N": ("N", "static mesh-force grid (load control); load_N[0] = 0 gives the no-load mesh deflection"),
    "deflection_m": ("m", "regular mesh-deflection grid of the FDF, x = r_b1*theta1 + r_b2*theta2 (+ y1 - y2)"),
    "no_load_deflection_m": ("m", "no-load mesh deflection (NLMD) per position: teeth touch for x > NLMD"),
    "static_deflection_m": ("m", "static mesh deflection per (position, load) under load control"),
    "force_N": ("N", "force-deflection function: mesh force along the line of action per (position, "
                     "deflection); 0 where x <= NLMD"),
    "tooth_offsets": ("1", "tooth-pair offsets k relative to the reference pair; +1 = the pair reaching the "
                           "pitch point one mesh cycle later"),
    "tooth_load_N": ("N", "load of tooth pair k per (position, deflection, offset)"),
    "contact_roll_deg": ("deg", "roll angle of the contact on gear_b's loaded flank per (position, deflection, "
                                "offset); NaN where the pair is unloaded"),
    "half_width_m": ("m", "Hertzian contact half-width per (position, deflection, offset); 0 where unloaded"),
    "peak_pressure_Pa": ("Pa", "maximum contact pressure over all tooth pairs per (position, deflection)"),
    "strain": ("1", "root strain at gauge <gear>/<gauge> on the tooth of pair offset k per (position, "
                    "deflection, offset): the strain-deflection function"),
    "hub_reaction": ("N, N, N*m", "generalized mesh force on the gear [Fx, Fy, Mz] per (position, deflection)"),
    "done_loads": ("1", "1 where phase 1 (load control, NLMD) of this position is complete"),
    "done_deflections": ("1", "1 where phase 2 (deflection control) of this position is complete"),
}


# ---------------------------------------------------------------------------------------------
# In-memory tables
# ---------------------------------------------------------------------------------------------
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


class KernelArrays(NamedTuple):
    """Plain arrays of the FDF for compiled kernels (see :func:`fdf_force`)."""

    force_N: np.ndarray  # (Np, Nd) C-contiguous float64
    x0: float  # deflection_m[0] [m]
    dx: float  # grid step [m]
    n_positions: int
    n_deflections: int


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


@dataclass(frozen=True, eq=False)
class MeshTable:
    """Tables of one gear mesh, all SI.  Np positions, Nd deflections, Nl loads, Nw tooth offsets.

    Fields follow the in-memory table contract (``docs/tables.md``); ``half_width_m`` (Np, Nd, Nw) and
    ``hub_reaction`` (gear → (Np, Nd, 3)) are additional outputs, ``solver`` names the static solver.
    Query methods are vectorised (NumPy broadcasting over ``position`` and ``deflection``) and count
    deflection-grid extrapolations in :attr:`stats`.
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

    def __post_init__(self) -> None:
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

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k != "_unrolled_cache"}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)

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

    def kernel_arrays(self) -> KernelArrays:
        """``force_N`` (Np, Nd) C-contiguous float64, ``x0``, ``dx``, Np, Nd for :func:`fdf_force`."""
        return KernelArrays(self.force_N, float(self.deflection_m[0]), self.dx_m, self.n_positions,
                            self.n_deflections)

    # -- interpolation machinery -------------------------------------------------------------
    def _columns(self, x: np.ndarray, count: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if count:
            self.stats.add(x, float(self.deflection_m[0]), float(self.deflection_m[-1]))
        v = (x - self.deflection_m[0]) / self.dx_m
        ok = np.isfinite(v)
        j = np.clip(np.floor(np.where(ok, v, 0.0)), 0, self.n_deflections - 2).astype(np.intp)
        t = np.where(ok, v, np.nan) - j
        return j, t, ok

    def _interp(self, A: np.ndarray, rows: np.ndarray, x: np.ndarray, periodic: bool,
                count: bool = True) -> np.ndarray:
        """Bilinear interpolation of A (N, Nd, *trail) at fractional row ``rows`` and deflection ``x``."""
        n = A.shape[0]
        j, t, okx = self._columns(x, count)
        okr = np.isfinite(rows)
        r = np.where(okr, rows, 0.0)
        i0f = np.floor(r)
        w = r - i0f
        if periodic:
            i0 = i0f.astype(np.intp) % n
            i1 = (i0 + 1) % n
        else:
            okr &= (r >= 0) & (r < n)
            i0 = np.clip(i0f, 0, n - 1).astype(np.intp)
            i1 = np.minimum(i0 + 1, n - 1)  # last cell: held at the last row
        trail = A.ndim - 2
        ex = (slice(None),) * w.ndim + (None,) * trail
        w_, t_ = w[ex], t[ex]
        val = ((1 - w_) * ((1 - t_) * A[i0, j] + t_ * A[i0, j + 1])
               + w_ * ((1 - t_) * A[i1, j] + t_ * A[i1, j + 1]))
        bad = ~(okr & okx)
        if np.any(bad):
            val = np.where(bad[ex], np.nan, val)
        return val

    def _prep(self, position: Any, deflection: Any) -> tuple[np.ndarray, np.ndarray]:
        p, x = np.broadcast_arrays(np.asarray(position, dtype=float), np.asarray(deflection, dtype=float))
        return p, x

    def _unrolled(self, A: np.ndarray) -> np.ndarray:
        """Per-pair array (Np, Nd, Nw) → (Nw·Np, Nd) over the pair phase τ = p − k ascending (cached)."""
        cache = self.__dict__.setdefault("_unrolled_cache", {})
        hit = cache.get(id(A))
        if hit is None or hit[0] is not A:
            hit = cache[id(A)] = (A, np.ascontiguousarray(
                np.concatenate([A[:, :, i] for i in range(self.tooth_offsets.size - 1, -1, -1)], axis=0)))
        return hit[1]

    def tooth_phase(self, position: Any, tooth_offset: int | np.ndarray = 0) -> np.ndarray:
        """Phase τ = position − k of tooth pair ``k`` [mesh cycles]: τ = 0 at its pitch-point contact.

        A pair's state depends only on τ (``X_k(p + 1) = X_{k−1}(p)``); the tables cover
        ``τ ∈ [−max(k), 1 − min(k))``."""
        return np.asarray(position, float) - np.asarray(tooth_offset)

    def _pair_interp(self, A: np.ndarray, tau: Any, deflection: Any, clip: bool) -> np.ndarray:
        tau, x = self._prep(tau, deflection)
        rows = (tau + float(self.tooth_offsets[-1])) * self.n_positions
        val = self._interp(self._unrolled(A), rows, x, periodic=False)
        return np.maximum(val, 0.0) if clip else val

    # -- public queries ------------------------------------------------------------------------
    def force(self, position: Any, deflection: Any) -> np.ndarray:
        """Mesh force [N] at mesh position [mesh cycles] and mesh deflection [m] (the FDF), >= 0."""
        p, x = self._prep(position, deflection)
        return np.maximum(self._interp(self.force_N, p * self.n_positions, x, periodic=True), 0.0)

    def pressure(self, position: Any, deflection: Any) -> np.ndarray:
        """Maximum contact pressure over all tooth pairs [Pa], >= 0."""
        p, x = self._prep(position, deflection)
        return np.maximum(self._interp(self.peak_pressure_Pa, p * self.n_positions, x, periodic=True), 0.0)

    def strain_at(self, gauge: str, position: Any, deflection: Any, tooth_offset: int = 0) -> np.ndarray:
        """Strain [-] at ``gauge`` ("<gear>/<gauge>") on the tooth of pair ``tooth_offset`` at mesh
        ``position`` [mesh cycles] and ``deflection`` [m] (also reachable as ``table.strain(gauge, ...)``).
        NaN where the pair's phase leaves the tabulated window."""
        return self.sdf(gauge, self.tooth_phase(position, tooth_offset), deflection)

    def sdf(self, gauge: str, tooth_phase: Any, deflection: Any) -> np.ndarray:
        """Strain-deflection function of one physical tooth: strain [-] at ``gauge`` on the tooth whose
        pair is at the pitch point at ``tooth_phase`` = 0 [mesh cycles] (dissertation Fig. 4.6)."""
        if gauge not in self.strain:
            raise TableError(f"mesh '{self.name}' has no gauge {gauge!r}; gauges: {sorted(self.strain)}")
        return self._pair_interp(dict.__getitem__(self.strain, gauge), tooth_phase, deflection, clip=False)

    def tooth_load(self, position: Any, deflection: Any, tooth_offset: int = 0) -> np.ndarray:
        """Load of tooth pair ``tooth_offset`` [N] (>= 0; NaN outside the tabulated window)."""
        return self._pair_interp(self.tooth_load_N, self.tooth_phase(position, tooth_offset), deflection, True)

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
        """Static mesh deflection [m] under mesh force ``load_N`` [N] (load control), linear in load
        (extrapolated linearly beyond the load grid) and periodic in position."""
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

    def contact_regions(self, deflection_index: int, threshold_N: float = 1e-6) -> np.ndarray:
        """Number of loaded tooth pairs (load > ``threshold_N``) per position at grid column
        ``deflection_index`` → (Np,) int (1: single-, 2: double-tooth contact...)."""
        return np.count_nonzero(self.tooth_load_N[:, deflection_index, :] > threshold_N, axis=1)




@dataclass(frozen=True, eq=False)
class SystemTables:
    """All mesh tables of one system plus provenance (root attributes of ``tables.h5``)."""

    meshes: dict[str, MeshTable]
    model_sha256: str
    format_version: int = FORMAT_VERSION
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

    @property
    def grid_sizes(self) -> dict[str, dict[str, int]]:
        return {m: {"positions": t.n_positions, "deflections": t.n_deflections, "loads": int(t.load_N.size),
                    "tooth_offsets": int(t.tooth_offsets.size)} for m, t in self.meshes.items()}

    def extrapolation_report(self) -> str:
        return "; ".join(f"{m}: {t.stats.report()}" for m, t in self.meshes.items())


# ---------------------------------------------------------------------------------------------
# Numba kernel
# ---------------------------------------------------------------------------------------------
def _fdf_force_py(force_N: np.ndarray, x0: float, dx: float, position: float, deflection: float) -> float:
    """FDF lookup for compiled kernels: bilinear, periodic in position, linear extrapolation beyond the
    deflection grid, clipped at >= 0 (same policy as :meth:`MeshTable.force`; no counting)."""
    n_p, n_d = force_N.shape
    u = (position - math.floor(position)) * n_p
    i0 = int(math.floor(u))
    w = u - i0
    i0 = i0 % n_p
    i1 = (i0 + 1) % n_p
    v = (deflection - x0) / dx
    j = int(math.floor(v))
    if j < 0:
        j = 0
    elif j > n_d - 2:
        j = n_d - 2
    t = v - j
    f = ((1.0 - w) * ((1.0 - t) * force_N[i0, j] + t * force_N[i0, j + 1])
         + w * ((1.0 - t) * force_N[i1, j] + t * force_N[i1, j + 1]))
    return f if f > 0.0 else 0.0


try:  # compiled on first call, cached on disk
    import numba as _nb

    fdf_force = _nb.njit(cache=True, nogil=True, fastmath=False)(_fdf_force_py)
except Exception:  # pragma: no cover - numba missing: plain Python, same results
    fdf_force = _fdf_force_py


# ---------------------------------------------------------------------------------------------
# HDF5 layout (shared by the incremental statics writer and write_tables)
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class MeshLayout:
    """Everything needed to pre-allocate one mesh group of ``tables.h5``."""

    name: str
    gear_names: tuple[str, str]
    teeth: tuple[int, int]
    base_radius_m: tuple[float, float]
    tooth_offsets: np.ndarray
    gauge_names: tuple[str, ...]
    position: np.ndarray
    load_N: np.ndarray
    n_deflections: int
    solver_description: str = ""

    @property
    def shapes(self) -> dict[str, tuple[int, ...]]:
        npos, nl, nd, nw = self.position.size, self.load_N.size, self.n_deflections, len(self.tooth_offsets)
        return {
            "no_load_deflection_m": (npos,), "static_deflection_m": (npos, nl), "deflection_m": (nd,),
            "force_N": (npos, nd), "tooth_load_N": (npos, nd, nw), "contact_roll_deg": (npos, nd, nw),
            "half_width_m": (npos, nd, nw), "peak_pressure_Pa": (npos, nd),
        }


def _hacgear_version() -> str:
    from hacgear_core import __version__

    return str(__version__)


def _dataset(group: Any, name: str, data: np.ndarray, key: str | None = None) -> None:
    unit, desc = DATASETS[key or name]
    ds = group.create_dataset(name, data=data)
    ds.attrs["unit"] = unit
    ds.attrs["description"] = desc


def _create_file(path: Path, layouts: Mapping[str, MeshLayout], root_attrs: Mapping[str, Any]) -> Any:
    import h5py

    f = h5py.File(path, "w")
    f.attrs["format"] = FORMAT
    f.attrs["format_version"] = FORMAT_VERSION
    f.attrs["hacgear_version"] = _hacgear_version()
    f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    f.attrs["model_sha256"] = str(root_attrs.get("model_sha256", ""))
    f.attrs["model_file"] = str(root_attrs.get("model_file", ""))
    f.attrs["deflection_margin"] = float(root_attrs.get("deflection_margin", float("nan")))
    f.attrs["mesh_names"] = np.array(list(layouts), dtype=h5py.string_dtype())
    f.attrs["n_meshes"] = len(layouts)
    first = next(iter(layouts.values()))
    f.attrs["n_positions"] = int(first.position.size)
    f.attrs["n_loads"] = int(first.load_N.size)
    f.attrs["n_deflections"] = int(first.n_deflections)
    top = f.create_group("meshes")
    for m, lay in layouts.items():
        g = top.create_group(m)
        g.attrs["gear_names"] = np.array(lay.gear_names, dtype=h5py.string_dtype())
        g.attrs["teeth"] = np.array(lay.teeth, dtype=np.int64)
        g.attrs["base_radius_m"] = np.array(lay.base_radius_m, dtype=float)
        g.attrs["solver"] = lay.solver_description
        g.attrs["gauge_names"] = np.array(lay.gauge_names, dtype=h5py.string_dtype())
        g.attrs["n_positions"] = int(lay.position.size)
        g.attrs["n_loads"] = int(lay.load_N.size)
        g.attrs["n_deflections"] = int(lay.n_deflections)
        g.attrs["n_tooth_offsets"] = int(len(lay.tooth_offsets))
        _dataset(g, "position", np.asarray(lay.position, float))
        _dataset(g, "load_N", np.asarray(lay.load_N, float))
        _dataset(g, "tooth_offsets", np.asarray(lay.tooth_offsets, dtype=np.int64))
        for name, shp in lay.shapes.items():
            _dataset(g, name, np.full(shp, np.nan))
        nd_shape = lay.shapes["tooth_load_N"]
        for gauge in lay.gauge_names:
            _dataset(g, f"strain/{gauge}", np.full(nd_shape, np.nan), key="strain")
        for gear in lay.gear_names:
            _dataset(g, f"hub_reaction/{gear}", np.full(nd_shape[:2] + (3,), np.nan), key="hub_reaction")
        _dataset(g, "done_loads", np.zeros(lay.position.size, dtype=np.uint8))
        _dataset(g, "done_deflections", np.zeros(lay.position.size, dtype=np.uint8))
    f.attrs["layout_complete"] = 1  # written last: a file killed while being laid out lacks it
    f.flush()
    return f


def _same_layout(f: Any, layouts: Mapping[str, MeshLayout], root_attrs: Mapping[str, Any]) -> str | None:
    """None if ``f`` was created for these layouts/settings, else what differs."""
    if f.attrs.get("format") != FORMAT or int(f.attrs.get("format_version", -1)) != FORMAT_VERSION:
        return "format/format_version"
    for k in ("model_sha256", "deflection_margin"):
        a, b = f.attrs.get(k), root_attrs.get(k)
        if (a != b) if not isinstance(b, float) else not (a == b):
            return f"{k} ({a!r} in the file, {b!r} now)"
    if "meshes" not in f or sorted(f["meshes"]) != sorted(layouts):
        return "mesh names"
    for m, lay in layouts.items():
        g = f["meshes"][m]
        checks = {
            "position": np.asarray(lay.position, float), "load_N": np.asarray(lay.load_N, float),
            "tooth_offsets": np.asarray(lay.tooth_offsets),
        }
        for k, v in checks.items():
            if k not in g or g[k].shape != v.shape or not np.array_equal(g[k][()], v):
                return f"mesh '{m}': {k}"
        if int(g.attrs.get("n_deflections", -1)) != lay.n_deflections:
            return f"mesh '{m}': n_deflections"
        if tuple(g.attrs.get("gauge_names", ())) != tuple(lay.gauge_names):
            return f"mesh '{m}': gauge names"
        for name, shp in lay.shapes.items():
            if name not in g or g[name].shape != shp:
                return f"mesh '{m}': dataset {name}"
        for k in ("done_loads", "done_deflections"):
            if k not in g:
                return f"mesh '{m}': {k}"
    return None


def open_statics_file(path: str | Path, layouts: Mapping[str, MeshLayout], root_attrs: Mapping[str, Any],
                      *, resume: bool) -> tuple[Any, str]:
    """Open the partial file of a statics run for writing → (h5py.File, note).

    ``resume`` and a readable file made for the same layouts and settings: continue it.  Otherwise a
    new file is created (every dataset pre-allocated and NaN-filled, so later writes only touch raw
    data and never the file's metadata — a run killed at any moment leaves a readable file).
    """
    import h5py

    path = Path(path)
    note = ""
    if path.exists():
        try:
            f = h5py.File(path, "r+")
        except BlockingIOError:
            raise TableError(f"{path} is open in another process (another `hacgear statics` still running?); "
                             "wait for it or stop it first") from None
        except OSError as exc:
            f = None
            note = f"could not reopen {path.name} ({exc}); started again"
        if f is not None and not resume:
            f.close()
            f = None
    else:
        f = None
    if f is not None:
        diff = _same_layout(f, layouts, root_attrs) if "layout_complete" in f.attrs else "unfinished"
        if diff == "unfinished":
            f.close()
            note = f"{path.name} was interrupted while being created; started again"
        elif diff is None:
            done = sum(int(np.count_nonzero(f[f"meshes/{m}/{d}"][()])) for m in layouts
                       for d in ("done_loads", "done_deflections"))
            return f, f"resumed {path.name}: {done} position task(s) already done"
        else:
            f.close()
            raise TableError(
                f"cannot resume {path}: it was started with different settings ({diff} differ). Run "
                "`hacgear statics` without --resume to start again (the partial file is replaced)."
            )
    elif resume and not note:
        note = f"nothing to resume ({path.name} absent); started from scratch"
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists():
        path.unlink()
    return _create_file(path, layouts, root_attrs), note


def completed_table_matches(path: str | Path, layouts: Mapping[str, MeshLayout], root_attrs: Mapping[str, Any]
                            ) -> dict[str, dict[str, float]] | None:
    """For ``--resume`` after a finished run: the :func:`consistency_summary` of every mesh when ``path``
    is a complete table made with these layouts and settings, else None."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            if "layout_complete" not in f.attrs or _same_layout(f, layouts, root_attrs) is not None:
                return None
            if not all(np.all(f[f"meshes/{m}/{d}"][()] == 1) for m in layouts
                       for d in ("done_loads", "done_deflections")):
                return None
            return {m: consistency_summary(f[f"meshes/{m}"]) for m in layouts}
    except OSError:
        return None


def write_position(f: Any, mesh: str, phase: int, ip: int, payload: Mapping[str, Any]) -> None:
    """Write one position's results (phase 1: NLMD and static deflections; phase 2: deflection-grid
    results), flush, then set its done flag and flush again."""
    g = f["meshes"][mesh]
    if phase == 1:
        g["no_load_deflection_m"][ip] = payload["no_load_deflection_m"]
        g["static_deflection_m"][ip, :] = payload["static_deflection_m"]
        flag = "done_loads"
    else:
        for k in ("force_N", "tooth_load_N", "contact_roll_deg", "half_width_m", "peak_pressure_Pa"):
            g[k][ip] = payload[k]
        for gauge, a in payload["strain"].items():
            g[f"strain/{gauge}"][ip] = a
        for gear, a in payload["hub_reaction"].items():
            g[f"hub_reaction/{gear}"][ip] = a
        flag = "done_deflections"
    f.flush()
    g[flag][ip] = 1
    f.flush()


def write_deflection_grid(f: Any, mesh: str, grid: np.ndarray) -> None:
    """Store the deflection grid (after phase 1).  A grid already in the file (resumed run) must be
    identical, since phase-2 rows were computed on it."""
    ds = f["meshes"][mesh]["deflection_m"]
    old = ds[()]
    if np.all(np.isfinite(old)):
        if not np.array_equal(old, grid):
            raise TableError(f"mesh '{mesh}': the deflection grid in the partial file differs from the one "
                             "recomputed from its phase-1 results; run without --resume")
        return
    done2 = f["meshes"][mesh]["done_deflections"][()]
    if np.any(done2):
        raise TableError(f"mesh '{mesh}': phase-2 rows exist but no deflection grid; run without --resume")
    ds[:] = grid
    f.flush()


def consistency_summary(g: Any) -> dict[str, float]:
    """Figures of one finished mesh group: NLMD range, force range, the FDF's reproduction of the
    load-control results (max |F(p, x_static) − F| / max load at the grid positions), and the largest
    decrease of the force along the deflection axis and of the static deflection along the load axis
    (both should be ~0: the FDF is monotone)."""
    F = g["force_N"][()]
    x = g["deflection_m"][()]
    S = g["static_deflection_m"][()]
    L = g["load_N"][()]
    nl = g["no_load_deflection_m"][()]
    rec = np.array([np.interp(S[i], x, F[i]) for i in range(F.shape[0])])
    err = float(np.max(np.abs(rec - L[None, :])) / L.max())
    drop = float(np.max(np.maximum(-np.diff(F, axis=1), 0.0)))
    sdrop = float(np.max(np.maximum(-np.diff(S, axis=1), 0.0)))
    return {
        "no_load_deflection_min_m": float(nl.min()), "no_load_deflection_max_m": float(nl.max()),
        "deflection_grid_min_m": float(x[0]), "deflection_grid_max_m": float(x[-1]),
        "static_deflection_max_m": float(S.max()), "force_max_N": float(F.max()), "load_max_N": float(L.max()),
        "fdf_reproduces_static_rel_err": err, "fdf_max_decrease_N": drop,
        "static_deflection_max_decrease_m": sdrop,
    }


# ---------------------------------------------------------------------------------------------
# Reading / writing whole files
# ---------------------------------------------------------------------------------------------
def _str_list(a: Any) -> tuple[str, ...]:
    return tuple(s.decode() if isinstance(s, bytes) else str(s) for s in np.asarray(a).ravel())


def _walk(group: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    import h5py

    for k, v in group.items():
        if isinstance(v, h5py.Group):
            yield from _walk(v, f"{prefix}{k}/")
        else:
            yield f"{prefix}{k}", v


def read_tables(path: str | Path, model_path: str | Path | None = None, *, allow_hash_mismatch: bool = False,
                allow_incomplete: bool = False) -> SystemTables:
    """Read ``tables.h5`` → :class:`SystemTables`.

    ``model_path``: when given, the SHA-256 of that file must equal the table's ``model_sha256``,
    otherwise :class:`TableError` names both files and the command that regenerates the table, unless
    ``allow_hash_mismatch``.  A table with positions not flagged done (interrupted run) is refused
    unless ``allow_incomplete``.
    """
    import h5py

    path = Path(path)
    if not path.exists():
        hint = f" (an interrupted run left {path.name}.partial: `hacgear statics MODEL --resume`)" \
            if path.with_name(path.name + ".partial").exists() else ""
        raise TableError(f"table file not found: {path}{hint}")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise TableError(f"{path} is not a readable HDF5 file ({exc})") from None
    with f:
        if f.attrs.get("format") != FORMAT:
            raise TableError(f"{path} is not a hacgear table (root attribute format = {f.attrs.get('format')!r}, "
                             f"expected {FORMAT!r})")
        version = int(f.attrs.get("format_version", -1))
        if version != FORMAT_VERSION:
            raise TableError(f"{path} has format_version {version}; this hacgear reads version {FORMAT_VERSION}. "
                             "Regenerate it with `hacgear statics MODEL`.")
        sha = str(f.attrs.get("model_sha256", ""))
        if model_path is not None:
            from hacgear_core.model import model_sha256 as _sha

            mp = Path(model_path)
            if mp.is_dir():
                mp = mp / "model.toml"
            if not mp.exists():
                raise TableError(f"model file not found: {mp}")
            actual = _sha(mp)
            if actual != sha and not allow_hash_mismatch:
                raise TableError(
                    f"{path} does not belong to {mp}: the table was generated from a model file with "
                    f"sha256 {sha[:16]}…, the model file now has sha256 {actual[:16]}…. Regenerate the table "
                    f"with `hacgear statics {mp}` (or override with allow_hash_mismatch=True / "
                    "--ignore-model-hash to use it anyway)."
                )
        if "meshes" not in f:
            raise TableError(f"{path}: no /meshes group")
        meshes = {}
        for m, g in f["meshes"].items():
            meshes[m] = _read_mesh(path, m, g, allow_incomplete)
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
        return SystemTables(
            meshes=meshes, model_sha256=sha, format_version=version,
            hacgear_version=str(f.attrs.get("hacgear_version", "")), created=str(f.attrs.get("created", "")),
            model_file=str(f.attrs.get("model_file", "")), path=path, attrs=attrs,
        )


def _read_mesh(path: Path, m: str, g: Any, allow_incomplete: bool) -> MeshTable:
    required = ("position", "load_N", "deflection_m", "no_load_deflection_m", "static_deflection_m", "force_N",
                "tooth_offsets", "tooth_load_N", "contact_roll_deg", "peak_pressure_Pa", "done_loads",
                "done_deflections")
    for k in required:
        if k not in g:
            raise TableError(f"{path}: mesh '{m}' lacks dataset {k!r}")
    if not allow_incomplete:
        for k in ("done_loads", "done_deflections"):
            d = g[k][()]
            if not np.all(d == 1):
                raise TableError(f"{path}: mesh '{m}' is incomplete ({int(np.count_nonzero(d))}/{d.size} positions "
                                 f"in {k}); finish it with `hacgear statics MODEL --resume`")
    strain = {name[len("strain/"):]: ds[()] for name, ds in _walk(g) if name.startswith("strain/")}
    hub = {name[len("hub_reaction/"):]: ds[()] for name, ds in _walk(g) if name.startswith("hub_reaction/")}
    order = _str_list(g.attrs.get("gauge_names", ()))
    strain = {k: strain[k] for k in order if k in strain} | {k: v for k, v in strain.items() if k not in order}
    F = g["force_N"][()]
    if allow_incomplete:
        F = np.nan_to_num(F, nan=0.0)
    return MeshTable(
        name=m, gear_names=_str_list(g.attrs["gear_names"]), teeth=tuple(int(z) for z in g.attrs["teeth"]),
        base_radius_m=tuple(float(r) for r in g.attrs["base_radius_m"]), position=g["position"][()],
        deflection_m=g["deflection_m"][()], force_N=F, no_load_deflection_m=g["no_load_deflection_m"][()],
        load_N=g["load_N"][()], static_deflection_m=g["static_deflection_m"][()],
        tooth_offsets=g["tooth_offsets"][()], tooth_load_N=g["tooth_load_N"][()],
        contact_roll_deg=g["contact_roll_deg"][()], peak_pressure_Pa=g["peak_pressure_Pa"][()], strain=strain,
        half_width_m=g["half_width_m"][()] if "half_width_m" in g else None, hub_reaction=hub,
        solver=str(g.attrs.get("solver", "")),
    )


def write_tables(path: str | Path, tables: SystemTables) -> None:
    """Write complete in-memory tables to ``path`` (atomically: via ``<path>.tmp`` and rename)."""
    path = Path(path)
    layouts = {}
    for m, t in tables.meshes.items():
        layouts[m] = MeshLayout(
            name=m, gear_names=t.gear_names, teeth=t.teeth, base_radius_m=t.base_radius_m,
            tooth_offsets=t.tooth_offsets, gauge_names=t.gauge_names, position=t.position, load_N=t.load_N,
            n_deflections=t.n_deflections, solver_description=t.solver,
        )
    root = {"model_sha256": tables.model_sha256, "model_file": tables.model_file,
            "deflection_margin": float(tables.attrs.get("deflection_margin", float("nan")))}
    tmp = path.with_name(path.name + ".tmp")
    path.parent.mkdir(parents=True, exist_ok=True)
    f = _create_file(tmp, layouts, root)
    try:
        if tables.created:
            f.attrs["created"] = tables.created
        for m, t in tables.meshes.items():
            g = f["meshes"][m]
            for k in ("deflection_m", "no_load_deflection_m", "static_deflection_m", "force_N", "tooth_load_N",
                      "contact_roll_deg", "peak_pressure_Pa"):
                g[k][...] = getattr(t, k)
            g["half_width_m"][...] = t.half_width_m if t.half_width_m is not None else np.nan
            for gauge, a in t.strain.items():
                g[f"strain/{gauge}"][...] = a
            for gear in t.gear_names:
                g[f"hub_reaction/{gear}"][...] = t.hub_reaction.get(gear, np.nan)
            g["done_loads"][...] = 1
            g["done_deflections"][...] = 1
    finally:
        f.close()
    os.replace(tmp, path)


def load_system_tables(model_path: str | Path, tables_path: str | Path | None = None, *,
                       allow_hash_mismatch: bool = False) -> SystemTables:
    """Tables of a model (default ``<model folder>/tables.h5``), checked against the model file."""
    from hacgear_core.model import resolve_model_path

    mp = resolve_model_path(model_path)
    tp = Path(tables_path) if tables_path is not None else mp.parent / "tables.h5"
    if not tp.exists():
        raise TableError(f"no tables for {mp}: {tp} does not exist; generate it with `hacgear statics {mp}`")
    return read_tables(tp, mp, allow_hash_mismatch=allow_hash_mismatch)
