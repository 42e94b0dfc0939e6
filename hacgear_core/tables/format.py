"""The ``tables.h5`` file format (HDF5): schema, incremental writing by the statics grid, reading and checking.

Root attributes ``format = "hacgear-tables"``, ``format_version``, ``model_values_sha256`` and
``model_values`` (hash and canonical JSON of the model values the tables depend on,
:mod:`hacgear_core.model.provenance`), ``model_sha256`` (hash of the model file's bytes, informative),
``hacgear_version``, ``created``, grid sizes; one group per mesh ``/meshes/<name>/`` (its drive side, attribute
``side = "drive"``) with datasets carrying ``unit`` and ``description`` attributes (:data:`DATASETS`), each
stored with HDF5's Fletcher-32 checksum filter so that corrupted bytes are refused on read; inside it the
subgroup ``coast/`` (``side = "coast"``): the same datasets for the mesh's opposite flank pair, in the drive
side's positions, the deflection axis being the coast approach; helical meshes add the twist-axis datasets.
Versions: 1 = drive side only; 2 = drive side with the twist axis of helical meshes; 3 (written now) = both
sides where computed, the twist axis for helical meshes.  Files without a ``coast/`` subgroup are read with
``coast = None``.  The full description is ``docs/tables.md``.
"""
from __future__ import annotations

import datetime as _dt
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping

import h5py
import numpy as np

from hacgear_core import __version__
from hacgear_core.errors import TableError
from hacgear_core.h5files import TABLES_FORMAT
from hacgear_core.model import model_sha256, read_model, resolve_model_path
from hacgear_core.model.provenance import model_values_json, model_values_sha256, values_diff
from hacgear_core.tables.check import hard_problems
from hacgear_core.tables.table import MeshTable, SystemTables, TwistTable

__all__ = [
    "FORMAT",
    "layout_difference",
    "FORMAT_VERSION",
    "READABLE_VERSIONS",
    "DATASETS",
    "MeshLayout",
    "read_tables",
    "write_tables",
    "load_system_tables",
    "open_statics_file",
    "write_position",
    "completed_table_matches",
    "write_deflection_grid",
    "consistency_summary",
    "seal_file",
    "file_integrity",
    "ATTRS_DIGEST",
]

FORMAT = TABLES_FORMAT
FORMAT_VERSION = 3
#: versions this reader accepts: 1 = drive side only, 2 = drive side + twist axis (helical), 3 = the coast side
#: where computed and the twist axis where helical (a table without its ``coast/`` subgroup reads ``coast = None``)
READABLE_VERSIONS = (1, 2, 3)

#: dataset name → (unit, description); ``strain/<gear>/<gauge>`` and ``hub_reaction/<gear>`` are per gauge/gear
DATASETS: dict[str, tuple[str, str]] = {
    "position": ("1", "mesh position [mesh cycles], position[k] = k/Np; integer = pitch-point contact of the "
                      "reference drive tooth pair (offset 0); periodic with period 1 (the coast side uses the same "
                      "positions)"),
    "load_N": ("N", "static mesh-force grid (load control); load_N[0] = 0 gives the no-load mesh deflection"),
    "deflection_m": ("m", "regular mesh-deflection grid of the FDF: drive side x = r_b1*theta1 + r_b2*theta2 "
                          "(+ y1 - y2); coast side the coast approach along the coast line of action from the drive "
                          "kinematic position (coast flanks touch near x = backlash_normal_m)"),
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
    "flank_pressure_Pa": ("Pa", "maximum contact pressure over the flank (Hertzian) contacts of all tooth pairs per "
                                "(position, deflection); 0 where none"),
    "edge_pressure_Pa": ("Pa", "maximum contact pressure over the tip-edge contacts (a tip corner on the mating flank, "
                               "off the line of action; its value is set by the edge radius) per (position, "
                               "deflection); 0 where none"),
    "strain": ("1", "root strain at gauge <gear>/<gauge> on the tooth of pair offset k per (position, "
                    "deflection, offset): the strain-deflection function"),
    "hub_reaction": ("N, N, N*m", "generalized mesh force on the gear [Fx, Fy, Mz] per (position, deflection)"),
    "twist_rad": ("rad", "regular mesh-twist grid gamma = (theta_a - theta_b) . e1 (helical meshes; contains 0; the "
                          "datasets without twist axis hold the gamma = 0 slice)"),
    "slice_z_m": ("m", "axial coordinate of the face slices (global frame)"),
    "no_load_deflection_twist_m": ("m", "NLMD per (position, twist)"),
    "static_deflection_twist_m": ("m", "static mesh deflection per (position, load, twist) under load control"),
    "generalized_fdf": ("N, N*m", "generalized FDF per (position, deflection, twist): [mesh force W, twist moment M]; "
                                  "f_d = W r_mesh + M r_twist (exact for involute contacts)"),
    "generalized_force": ("N, N*m", "f_d of Eq. 5.1 per (position, deflection, twist), 12 components on "
                                    "q = [u_a, theta_a, u_b, theta_b] (global frame), summed contact by contact"),
    "tooth_load_twist_N": ("N", "load of tooth pair k per (position, deflection, twist, offset)"),
    "peak_pressure_twist_Pa": ("Pa", "maximum contact pressure per (position, deflection, twist)"),
    "flank_pressure_twist_Pa": ("Pa", "maximum flank (Hertzian) contact pressure per (position, deflection, twist)"),
    "edge_pressure_twist_Pa": ("Pa", "maximum tip-edge contact pressure per (position, deflection, twist)"),
    "slice_load_N": ("N", "load per face slice (all pairs) per (position, deflection, twist, slice): the contact "
                          "pattern across the face"),
    "slice_pressure_Pa": ("Pa", "peak contact pressure per face slice per (position, deflection, twist, slice)"),
    "strain_twist": ("1", "root strain at gauge <gear>/<gauge> (at its axial position) on the tooth of pair offset k "
                          "per (position, deflection, twist, offset)"),
    "done_loads": ("1", "1 where phase 1 (load control, NLMD) of this position is complete"),
    "done_deflections": ("1", "1 where phase 2 (deflection control) of this position is complete"),
}



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
    twist_rad: np.ndarray | None = None        # helical meshes: the twist grid [rad]
    slice_z_m: np.ndarray | None = None        # and the axial coordinates of the face slices [m]
    mesh_frame: Mapping[str, Any] | None = None  # r_mesh, r_twist, e1.., base_helix_angle_rad, lever_arm_m, ...

    side: str = "drive"
    flanks: tuple[str, ...] = ()
    contact_deflection_m: float = 0.0
    coast: Mapping[str, Any] = field(default_factory=dict)

    #: datasets of every mesh group (format version 1); the twist-axis ones are added for helical meshes
    base_datasets = ("no_load_deflection_m", "static_deflection_m", "deflection_m", "force_N", "tooth_load_N",
                     "contact_roll_deg", "half_width_m", "peak_pressure_Pa", "flank_pressure_Pa", "edge_pressure_Pa")

    @property
    def shapes(self) -> dict[str, tuple[int, ...]]:
        npos, nl, nd, nw = self.position.size, self.load_N.size, self.n_deflections, len(self.tooth_offsets)
        out = {
            "no_load_deflection_m": (npos,), "static_deflection_m": (npos, nl), "deflection_m": (nd,),
            "force_N": (npos, nd), "tooth_load_N": (npos, nd, nw), "contact_roll_deg": (npos, nd, nw),
            "half_width_m": (npos, nd, nw), "peak_pressure_Pa": (npos, nd), "flank_pressure_Pa": (npos, nd),
            "edge_pressure_Pa": (npos, nd),
        }
        if self.twist_rad is not None:
            nt, ns = self.twist_rad.size, self.slice_z_m.size
            out.update({
                "no_load_deflection_twist_m": (npos, nt), "static_deflection_twist_m": (npos, nl, nt),
                "generalized_fdf": (npos, nd, nt, 2), "generalized_force": (npos, nd, nt, 12),
                "tooth_load_twist_N": (npos, nd, nt, nw), "peak_pressure_twist_Pa": (npos, nd, nt),
                "flank_pressure_twist_Pa": (npos, nd, nt), "edge_pressure_twist_Pa": (npos, nd, nt),
                "slice_load_N": (npos, nd, nt, ns), "slice_pressure_Pa": (npos, nd, nt, ns),
            })
        return out


#: twist-axis datasets stored as float32 (post-processing quantities; read back as float64): the generalized FDF
#: and the deflections keep float64
_SINGLE = ("generalized_force", "tooth_load_twist_N", "peak_pressure_twist_Pa", "flank_pressure_twist_Pa",
           "edge_pressure_twist_Pa", "slice_load_N", "slice_pressure_Pa", "strain_twist")


def _dataset(group: Any, name: str, data: np.ndarray, key: str | None = None, compress: bool = False) -> None:
    unit, desc = DATASETS[key or name]
    # per-chunk checksums (verified on every read); the large twist-axis datasets also deflated (deterministic)
    kw = dict(compression="gzip", compression_opts=4, shuffle=True) if compress and np.size(data) > 4096 else {}
    if (key or name) in _SINGLE:
        data = np.asarray(data, dtype=np.float32)
    ds = group.create_dataset(name, data=data, fletcher32=True, **kw)
    ds.attrs["unit"] = unit
    ds.attrs["description"] = desc


def _version(layouts: Mapping[str, MeshLayout]) -> int:
    """The format version a file of ``layouts`` is written with (every new file: :data:`FORMAT_VERSION`)."""
    return FORMAT_VERSION


#: mesh-frame attributes of a helical mesh group (vectors in the global frame, docs/tables.md)
FRAME_KEYS = ("r_mesh", "r_twist", "e1", "e2", "e3", "P_ref", "n_ref", "O_a", "O_b", "base_helix_angle_rad",
              "lever_arm_m", "reference_plane_z_m")


def _create_file(path: Path, layouts: Mapping[str, MeshLayout], root_attrs: Mapping[str, Any]) -> Any:
    f = h5py.File(path, "w")
    f.attrs["format"] = FORMAT
    f.attrs["format_version"] = _version(layouts)
    f.attrs["hacgear_version"] = str(__version__)
    f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    f.attrs["model_sha256"] = str(root_attrs.get("model_sha256", ""))
    f.attrs["model_values_sha256"] = str(root_attrs.get("model_values_sha256", ""))
    f.attrs["model_values"] = str(root_attrs.get("model_values", ""))
    f.attrs["model_file"] = str(root_attrs.get("model_file", ""))
    f.attrs["deflection_margin"] = float(root_attrs.get("deflection_margin", float("nan")))
    meshes = [m for m, lay in layouts.items() if lay.side == "drive"]
    f.attrs["mesh_names"] = np.array(meshes, dtype=h5py.string_dtype())
    f.attrs["n_meshes"] = len(meshes)
    first = next(iter(layouts.values()))
    f.attrs["n_positions"] = int(first.position.size)
    f.attrs["n_loads"] = int(first.load_N.size)
    f.attrs["n_deflections"] = int(first.n_deflections)
    top = f.create_group("meshes")
    for m, lay in layouts.items():
        g = top.create_group(m)       # "<mesh>/coast" inside "<mesh>" (layouts list each mesh's drive side first)
        g.attrs["side"] = lay.side
        g.attrs["flanks"] = np.array(lay.flanks, dtype=h5py.string_dtype())
        if lay.side == "coast":
            for k in ("backlash_normal_m", "backlash_circular_m", "position_offset"):
                g.attrs[k] = float(lay.coast[k])
            g.attrs["pair_shift"] = np.array([int(lay.coast["pair_shift"][gn]) for gn in lay.gear_names],
                                             dtype=np.int64)
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
        base = set(MeshLayout.base_datasets)
        for name, shp in lay.shapes.items():
            _dataset(g, name, np.full(shp, np.nan), compress=name not in base)
        nd_shape = lay.shapes["tooth_load_N"]
        for gauge in lay.gauge_names:
            _dataset(g, f"strain/{gauge}", np.full(nd_shape, np.nan), key="strain")
        for gear in lay.gear_names:
            _dataset(g, f"hub_reaction/{gear}", np.full(nd_shape[:2] + (3,), np.nan), key="hub_reaction")
        if lay.twist_rad is not None:
            _dataset(g, "twist_rad", np.asarray(lay.twist_rad, float))
            _dataset(g, "slice_z_m", np.asarray(lay.slice_z_m, float))
            tw_shape = lay.shapes["tooth_load_twist_N"]
            for gauge in lay.gauge_names:
                _dataset(g, f"strain_twist/{gauge}", np.full(tw_shape, np.nan), key="strain_twist", compress=True)
            for k in FRAME_KEYS:
                g.attrs[k] = np.asarray(lay.mesh_frame[k], dtype=float)
        _dataset(g, "done_loads", np.zeros(lay.position.size, dtype=np.uint8))
        _dataset(g, "done_deflections", np.zeros(lay.position.size, dtype=np.uint8))
    f.attrs["layout_complete"] = 1  # written last: a file killed while being laid out lacks it
    f.flush()
    return f


#: root attribute holding the SHA-256 of every other attribute of the file (except ``created``)
ATTRS_DIGEST = "attributes_sha256"


def _attrs_digest(f: Any) -> str:
    """SHA-256 over every attribute of the file (names, dtypes, values), except :data:`ATTRS_DIGEST` and
    ``created``: attributes (teeth, base radii, gear names, provenance) are not covered by the datasets'
    Fletcher-32 checksums."""
    import hashlib

    h = hashlib.sha256()
    objs = [("/", f)]
    f.visititems(lambda name, obj: objs.append((name, obj)))
    for name, obj in sorted(objs, key=lambda t: t[0]):
        for k in sorted(obj.attrs):
            if name == "/" and k in (ATTRS_DIGEST, "created"):
                continue
            v = np.asarray(obj.attrs[k])
            if v.dtype.kind in "OSU":
                data = "\x1f".join(x.decode() if isinstance(x, bytes) else str(x) for x in v.ravel()).encode()
            else:
                data = v.dtype.str.encode() + v.tobytes()
            h.update(f"{name}\x1e{k}\x1e{v.shape}\x1e".encode() + data + b"\x1d")
    return h.hexdigest()


def seal_file(f: Any) -> None:
    """Store :data:`ATTRS_DIGEST` in a finished file (the last write of a statics run or of
    :func:`write_tables`)."""
    f.attrs[ATTRS_DIGEST] = _attrs_digest(f)
    f.flush()


def _same_layout(f: Any, layouts: Mapping[str, MeshLayout], root_attrs: Mapping[str, Any]) -> str | None:
    """None if ``f`` was created for these layouts/settings, else what differs."""
    if f.attrs.get("format") != FORMAT or int(f.attrs.get("format_version", -1)) != _version(layouts):
        return "format/format_version"
    for k in ("model_values_sha256", "deflection_margin"):
        a, b = f.attrs.get(k), root_attrs.get(k)
        if (a != b) if not isinstance(b, float) else not (a == b):
            return f"{k} ({a!r} in the file, {b!r} now)"
    if "meshes" not in f or sorted(_regions(f["meshes"])) != sorted(layouts):
        return "mesh names / sides"
    for m, lay in layouts.items():
        g = f["meshes"][m]
        if str(g.attrs.get("side", "drive")) != lay.side:
            return f"mesh '{m}': side"
        checks = {
            "position": np.asarray(lay.position, float), "load_N": np.asarray(lay.load_N, float),
            "tooth_offsets": np.asarray(lay.tooth_offsets),
        }
        if lay.twist_rad is not None:
            checks["twist_rad"] = np.asarray(lay.twist_rad, float)
            checks["slice_z_m"] = np.asarray(lay.slice_z_m, float)
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


def _regions(top: Any) -> list[str]:
    """Region keys below ``/meshes``: ``<mesh>`` and, where present, ``<mesh>/coast``."""
    out = []
    for m, g in top.items():
        out.append(m)
        if "coast" in g and isinstance(g["coast"], h5py.Group):
            out.append(f"{m}/coast")
    return out


def open_statics_file(path: str | Path, layouts: Mapping[str, MeshLayout], root_attrs: Mapping[str, Any],
                      *, resume: bool) -> tuple[Any, str]:
    """Open the partial file of a statics run for writing → (h5py.File, note saying what happened).

    ``resume`` (the default of ``hacgear statics``) and a partial file made for the same layouts and model
    values: continue it.  A partial file made for other settings is refused (:class:`TableError` saying what
    differs and how many position tasks it holds), never silently replaced.  ``resume=False`` (``--fresh``)
    discards an existing partial file and says so.  A partial file that cannot be opened at all is moved
    aside to ``<path>.unreadable``.  A new file has every dataset pre-allocated and NaN-filled, so later writes
    only touch raw data and never the file's metadata — a run killed at any moment leaves a readable file.
    """
    path = Path(path)
    note = ""
    f = None
    if path.exists():
        try:
            f = h5py.File(path, "r+")
        except BlockingIOError:
            raise TableError(f"{path} is open in another process (another `hacgear statics` still running?); "
                             "wait for it or stop it first") from None
        except OSError as exc:
            bad = path.with_name(path.name + ".unreadable")
            os.replace(path, bad)
            note = f"{path.name} could not be opened ({exc}); moved aside to {bad.name} and started again"
    if f is not None:
        diff = _same_layout(f, layouts, root_attrs) if "layout_complete" in f.attrs else "unfinished"
        done = _done_tasks(f)
        if diff == "unfinished":
            f.close()
            note = f"{path.name} was interrupted while being created (nothing computed yet); started again"
        elif not resume:
            f.close()
            note = f"discarded {path.name} ({done} position task(s) done) as asked (--fresh); started from scratch"
        elif diff is None:
            return f, f"resumed {path.name}: {done} position task(s) already done (--fresh discards it)"
        else:
            f.close()
            raise TableError(
                f"{path} holds an interrupted run ({done} position task(s) done) made with different settings "
                f"({diff} differ). Rerun with the settings it was made for to continue it, or discard it with "
                "`hacgear statics MODEL --fresh` (library: resume=False)."
            )
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists():
        path.unlink()
    return _create_file(path, layouts, root_attrs), note


def _done_tasks(f: Any) -> int:
    """Position tasks flagged done in an open statics file (0 where the flags are missing or unreadable)."""
    n = 0
    try:
        top = f["meshes"]
        for key in _regions(top):
            g = top[key]
            for d in ("done_loads", "done_deflections"):
                if d in g:
                    n += int(np.count_nonzero(g[d][()]))
    except (KeyError, OSError, AttributeError):
        pass
    return n


def completed_table_matches(path: str | Path, layouts: Mapping[str, MeshLayout], root_attrs: Mapping[str, Any]
                            ) -> dict[str, dict[str, float]] | None:
    """For ``--resume`` after a finished run: the :func:`consistency_summary` of every mesh when ``path``
    is a complete table made with these layouts and settings, else None."""
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


def layout_difference(path: str | Path, layouts: Mapping[str, MeshLayout], root_attrs: Mapping[str, Any]) -> str:
    """What differs between the table ``path`` and these layouts/settings (empty when nothing does)."""
    try:
        with h5py.File(path, "r") as f:
            return _same_layout(f, layouts, root_attrs) or ""
    except OSError as exc:
        return f"unreadable: {exc}"


def write_position(f: Any, mesh: str, phase: int, ip: int, payload: Mapping[str, Any]) -> None:
    """Write one position's results (phase 1: NLMD and static deflections; phase 2: deflection-grid
    results), flush, then set its done flag and flush again."""
    g = f["meshes"][mesh]
    if phase == 1:
        g["no_load_deflection_m"][ip] = payload["no_load_deflection_m"]
        g["static_deflection_m"][ip, :] = payload["static_deflection_m"]
        for k in ("no_load_deflection_twist_m", "static_deflection_twist_m"):
            if k in payload:
                g[k][ip] = payload[k]
        flag = "done_loads"
    else:
        for k in ("force_N", "tooth_load_N", "contact_roll_deg", "half_width_m", "peak_pressure_Pa",
                  "flank_pressure_Pa", "edge_pressure_Pa"):
            g[k][ip] = payload[k]
        for gauge, a in payload["strain"].items():
            g[f"strain/{gauge}"][ip] = a
        for gear, a in payload["hub_reaction"].items():
            g[f"hub_reaction/{gear}"][ip] = a
        for k in ("generalized_fdf", "generalized_force", "tooth_load_twist_N", "peak_pressure_twist_Pa",
                  "flank_pressure_twist_Pa", "edge_pressure_twist_Pa", "slice_load_N", "slice_pressure_Pa"):
            if k in payload:
                g[k][ip] = payload[k]
        for gauge, a in payload.get("strain_twist", {}).items():
            g[f"strain_twist/{gauge}"][ip] = a
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
    for k, v in group.items():
        if isinstance(v, h5py.Group):
            yield from _walk(v, f"{prefix}{k}/")
        else:
            yield f"{prefix}{k}", v


def _provenance_problem(path: Path, attrs: Any, mp: Path) -> str | None:
    """None when the table at ``path`` (root attributes ``attrs``) belongs to the model file ``mp``, else why not.

    Tables with ``model_values_sha256`` are compared by the canonical model values
    (:mod:`hacgear_core.model.provenance`): comments, damping, the operating point or supports may change, the
    geometry, materials, meshes or statics grid may not, and the message names each value that differs.  Older
    tables hold only ``model_sha256``, the hash of the model file's bytes: they are accepted while the file is
    byte-identical and refused otherwise, since which values changed cannot be told.
    """
    regen = (f"Regenerate the table with `hacgear statics {mp}` (or override with allow_hash_mismatch=True / "
             "--ignore-model-hash to use it anyway).")
    stored = _attr_str(attrs.get("model_values_sha256", ""))
    if stored:
        model = read_model(mp)
        if model_values_sha256(model) == stored:
            return None
        diff = values_diff(_attr_str(attrs.get("model_values", "")) or "{}", model_values_json(model))
        return (f"{path} does not belong to {mp}: model values the tables depend on differ ("
                + "; ".join(diff or ["the stored values are unreadable"]) + f"). {regen}")
    old = _attr_str(attrs.get("model_sha256", ""))
    actual = model_sha256(mp)
    if old and old == actual:
        return None
    return (f"{path} does not belong to {mp}: the table was written before hacgear stored the model values it "
            f"depends on and holds only the SHA-256 of the model file's bytes ({old[:16] or 'none'}…); the model "
            f"file now has sha256 {actual[:16]}…, so whether its values still match cannot be told. {regen}")


def _attr_str(v: Any) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


def _read(path: Path, ds: Any) -> np.ndarray:
    """Read a whole dataset; a failed Fletcher-32 checksum (or any other read error) → :class:`TableError`."""
    try:
        return ds[()]
    except OSError as exc:
        what = "fails its Fletcher-32 checksum" if ds.fletcher32 else "cannot be read"
        raise TableError(f"{path}: dataset {ds.name} {what} ({exc}); the file is corrupted. Regenerate it "
                         "with `hacgear statics MODEL` (or restore it from version control)") from None


def file_integrity(path: str | Path) -> dict[str, Any]:
    """Read every dataset of a tables file through its checksum and report, without raising on corruption.

    Returns ``{"datasets": n, "checksummed": k, "unreadable": [dataset: error, ...], "attributes":
    "verified" | "no digest" | "corrupted"}``; ``checksummed < datasets`` for files written before hacgear
    stored checksums (their corruption cannot be detected).
    """
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise TableError(f"{path} is not a readable HDF5 file ({exc})") from None
    out: dict[str, Any] = {"datasets": 0, "checksummed": 0, "unreadable": []}
    with f:
        def visit(name: str, obj: Any) -> None:
            if isinstance(obj, h5py.Dataset):
                out["datasets"] += 1
                out["checksummed"] += int(bool(obj.fletcher32))
                try:
                    obj[()]
                except OSError as exc:
                    what = "Fletcher-32 checksum failed" if obj.fletcher32 else "cannot be read"
                    out["unreadable"].append(f"{name}: {what} ({exc})")
        f.visititems(visit)
        if ATTRS_DIGEST not in f.attrs:
            out["attributes"] = "no digest"
        else:
            out["attributes"] = "verified" if _attr_str(f.attrs[ATTRS_DIGEST]) == _attrs_digest(f) else "corrupted"
    return out


def read_tables(path: str | Path, model_path: str | Path | None = None, *, allow_hash_mismatch: bool = False,
                allow_incomplete: bool = False, check_values: bool = True) -> SystemTables:
    """Read ``tables.h5`` → :class:`SystemTables`.

    Every dataset is read through its Fletcher-32 checksum (tables written by this version): corrupted bytes
    raise :class:`TableError` naming the dataset, and so do non-finite or physically impossible values
    (:func:`hacgear_core.tables.check.hard_problems`: negative or absurdly large forces...).

    ``model_path``: when given, the table must belong to that model file (:func:`_provenance_problem`),
    otherwise :class:`TableError` names what differs and the command that regenerates the table, unless
    ``allow_hash_mismatch``.  A table with positions not flagged done (interrupted run) is refused
    unless ``allow_incomplete``.  ``check_values=False`` skips the value checks (``hacgear statics --check`` runs
    :func:`hacgear_core.tables.check.sanity_problems` itself and lists every problem).
    """
    path = Path(path)
    if not path.exists():
        hint = f" (an interrupted run left {path.name}.partial: `hacgear statics MODEL` continues it)" \
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
        if version not in READABLE_VERSIONS:
            raise TableError(f"{path} has format_version {version}; this hacgear reads versions "
                             f"{', '.join(map(str, READABLE_VERSIONS))}. Regenerate it with `hacgear statics MODEL`.")
        sha = _attr_str(f.attrs.get("model_sha256", ""))
        if model_path is not None:
            mp = Path(model_path)
            if mp.is_dir():
                mp = mp / "model.toml"
            if not mp.exists():
                raise TableError(f"model file not found: {mp}")
            problem = _provenance_problem(path, f.attrs, mp)
            if problem and not allow_hash_mismatch:
                raise TableError(problem)
        if ATTRS_DIGEST in f.attrs and _attr_str(f.attrs[ATTRS_DIGEST]) != _attrs_digest(f):
            raise TableError(f"{path}: its attributes (grid sizes, gear names, teeth, base radii, provenance) do "
                             f"not match their checksum {ATTRS_DIGEST}; the file is corrupted. Regenerate it with "
                             "`hacgear statics MODEL` (or restore it from version control)")
        if "meshes" not in f:
            raise TableError(f"{path}: no /meshes group")
        meshes = {}
        for m, g in f["meshes"].items():
            meshes[m] = _read_mesh(path, m, g, allow_incomplete, check_values)
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
        return SystemTables(
            meshes=meshes, model_sha256=sha, format_version=version,
            hacgear_version=str(f.attrs.get("hacgear_version", "")), created=str(f.attrs.get("created", "")),
            model_file=str(f.attrs.get("model_file", "")), path=path, attrs=attrs,
        )


def _read_mesh(path: Path, m: str, g: Any, allow_incomplete: bool, check_values: bool = True) -> MeshTable:
    """One mesh group → :class:`MeshTable` (drive side) with its ``coast/`` subgroup as ``.coast`` (None when
    absent: a format_version 1 or 2 file or a table written without the coast side)."""
    coast = None
    if "coast" in g and isinstance(g["coast"], h5py.Group):
        coast = _read_side(path, f"{m}/coast", g["coast"], allow_incomplete, None, check_values)
    return _read_side(path, m, g, allow_incomplete, coast, check_values)


def _optional(path: Path, g: Any, name: str) -> np.ndarray | None:
    """Dataset ``name`` of group ``g``, or None where it is absent or NaN throughout (not given)."""
    if name not in g:
        return None
    a = _read(path, g[name])
    return None if np.all(np.isnan(np.asarray(a, float))) else a


def _read_side(path: Path, m: str, g: Any, allow_incomplete: bool, coast: MeshTable | None,
               check_values: bool) -> MeshTable:
    required = ("position", "load_N", "deflection_m", "no_load_deflection_m", "static_deflection_m", "force_N",
                "tooth_offsets", "tooth_load_N", "contact_roll_deg", "peak_pressure_Pa", "done_loads",
                "done_deflections")
    for k in required:
        if k not in g:
            raise TableError(f"{path}: mesh '{m}' lacks dataset {k!r}")
    if not allow_incomplete:
        for k in ("done_loads", "done_deflections"):
            d = _read(path, g[k])
            if not np.all(d == 1):
                raise TableError(f"{path}: mesh '{m}' is incomplete ({int(np.count_nonzero(d))}/{d.size} positions "
                                 f"in {k}); finish it with `hacgear statics MODEL`")
    strain = ({name[len("strain/"):]: _read(path, ds) for name, ds in _walk(g["strain"], "strain/")}
              if "strain" in g else {})
    hub = ({name[len("hub_reaction/"):]: _read(path, ds) for name, ds in _walk(g["hub_reaction"], "hub_reaction/")}
           if "hub_reaction" in g else {})
    order = _str_list(g.attrs.get("gauge_names", ()))
    strain = {k: strain[k] for k in order if k in strain} | {k: v for k, v in strain.items() if k not in order}
    F = _read(path, g["force_N"])
    if allow_incomplete:
        F = np.nan_to_num(F, nan=0.0)
    r = {k: _read(path, g[k]) for k in ("position", "deflection_m", "no_load_deflection_m", "load_N",
                                        "static_deflection_m", "tooth_offsets", "tooth_load_N", "contact_roll_deg",
                                        "peak_pressure_Pa")}
    # flank and edge pressures apart: None in tables written before the split (absent) and in tables written from
    # tables that lacked them (NaN throughout)
    r.update({k: _optional(path, g, k) for k in ("flank_pressure_Pa", "edge_pressure_Pa")})
    twist = None
    if "twist_rad" in g:
        # a model without gauges has no strain datasets
        strain_tw = ({name[len("strain_twist/"):]: _read(path, ds) for name, ds in _walk(g["strain_twist"],
                                                                                        "strain_twist/")}
                     if "strain_twist" in g else {})
        fr = {k: g.attrs[k] for k in FRAME_KEYS}
        twist = TwistTable(
            twist_rad=_read(path, g["twist_rad"]), no_load_deflection_m=g["no_load_deflection_twist_m"][()],
            static_deflection_m=g["static_deflection_twist_m"][()], generalized_fdf=g["generalized_fdf"][()],
            generalized_force=g["generalized_force"][()], tooth_load_N=g["tooth_load_twist_N"][()],
            peak_pressure_Pa=g["peak_pressure_twist_Pa"][()], slice_load_N=g["slice_load_N"][()],
            slice_pressure_Pa=g["slice_pressure_Pa"][()], slice_z_m=g["slice_z_m"][()],
            flank_pressure_Pa=_optional(path, g, "flank_pressure_twist_Pa"),
            edge_pressure_Pa=_optional(path, g, "edge_pressure_twist_Pa"),
            strain={k: strain_tw[k] for k in order if k in strain_tw}, r_mesh=fr["r_mesh"], r_twist=fr["r_twist"],
            frame={k: fr[k] for k in ("e1", "e2", "e3", "P_ref", "n_ref", "O_a", "O_b")},
            base_helix_angle_rad=float(fr["base_helix_angle_rad"]), lever_arm_m=fr["lever_arm_m"],
            reference_plane_z_m=float(fr["reference_plane_z_m"]))
    side = str(g.attrs.get("side", "drive"))
    gear_names = _str_list(g.attrs["gear_names"])
    extra: dict[str, Any] = {"side": side, "flanks": _str_list(g.attrs.get("flanks", ()))}
    if side == "coast":
        for k in ("backlash_normal_m", "backlash_circular_m", "position_offset"):
            if k not in g.attrs:
                raise TableError(f"{path}: coast side of mesh '{m}' lacks attribute {k!r}")
            extra[k] = float(g.attrs[k])
        extra["pair_shift"] = {gn: int(v) for gn, v in zip(gear_names, g.attrs["pair_shift"])}
    table = MeshTable(
        twist=twist,
        name=m.split("/")[0], gear_names=gear_names, teeth=tuple(int(z) for z in g.attrs["teeth"]),
        base_radius_m=tuple(float(rb) for rb in g.attrs["base_radius_m"]), force_N=F, strain=strain,
        half_width_m=_read(path, g["half_width_m"]) if "half_width_m" in g else None, hub_reaction=hub,
        solver=str(g.attrs.get("solver", "")), coast=coast, **extra, **r,
    )
    if check_values and not allow_incomplete:
        bad = hard_problems(table)
        if bad:
            raise TableError(f"{path}: mesh '{m}' holds impossible values ({'; '.join(bad)}); the file is corrupted "
                             "or was written by a faulty solver. Regenerate it with `hacgear statics MODEL`; "
                             "`hacgear statics MODEL --check` lists every problem")
    return table


def write_tables(path: str | Path, tables: SystemTables) -> None:
    """Write complete in-memory tables to ``path`` (atomically: via ``<path>.tmp`` and rename)."""
    path = Path(path)
    layouts = {}
    sides = {}
    for m, t0 in tables.meshes.items():
        for key, t in ((m, t0), (f"{m}/coast", t0.coast)):
            if t is None:
                continue
            sides[key] = t
            coast = {}
            if t.side == "coast":
                coast = {"backlash_normal_m": t.backlash_normal_m, "backlash_circular_m": t.backlash_circular_m,
                         "position_offset": t.position_offset, "pair_shift": dict(t.pair_shift)}
            layouts[key] = MeshLayout(
                name=key, gear_names=t.gear_names, teeth=t.teeth, base_radius_m=t.base_radius_m,
                tooth_offsets=t.tooth_offsets, gauge_names=t.gauge_names, position=t.position, load_N=t.load_N,
                n_deflections=t.n_deflections, solver_description=t.solver, side=t.side, flanks=t.flanks,
                coast=coast,
                twist_rad=None if t.twist is None else t.twist.twist_rad,
                slice_z_m=None if t.twist is None else t.twist.slice_z_m,
                mesh_frame=None if t.twist is None else _frame_of(t.twist),
            )
    root = {"model_sha256": tables.model_sha256, "model_file": tables.model_file,
            "model_values_sha256": tables.attrs.get("model_values_sha256", ""),
            "model_values": tables.attrs.get("model_values", ""),
            "deflection_margin": float(tables.attrs.get("deflection_margin", float("nan")))}
    tmp = path.with_name(path.name + ".tmp")
    path.parent.mkdir(parents=True, exist_ok=True)
    f = _create_file(tmp, layouts, root)
    try:
        if tables.created:
            f.attrs["created"] = tables.created
        for m, t in sides.items():
            g = f["meshes"][m]
            for k in ("deflection_m", "no_load_deflection_m", "static_deflection_m", "force_N", "tooth_load_N",
                      "contact_roll_deg", "peak_pressure_Pa"):
                g[k][...] = getattr(t, k)
            for k in ("flank_pressure_Pa", "edge_pressure_Pa"):   # NaN: not told apart in the source table
                g[k][...] = getattr(t, k) if getattr(t, k) is not None else np.nan
            g["half_width_m"][...] = t.half_width_m if t.half_width_m is not None else np.nan
            for gauge, a in t.strain.items():
                g[f"strain/{gauge}"][...] = a
            for gear in t.gear_names:
                g[f"hub_reaction/{gear}"][...] = t.hub_reaction.get(gear, np.nan)
            tw = t.twist
            if tw is not None:
                for k, attr in (("no_load_deflection_twist_m", "no_load_deflection_m"),
                                ("static_deflection_twist_m", "static_deflection_m"),
                                ("generalized_fdf", "generalized_fdf"), ("generalized_force", "generalized_force"),
                                ("tooth_load_twist_N", "tooth_load_N"), ("peak_pressure_twist_Pa", "peak_pressure_Pa"),
                                ("slice_load_N", "slice_load_N"), ("slice_pressure_Pa", "slice_pressure_Pa")):
                    g[k][...] = getattr(tw, attr)
                for k, attr in (("flank_pressure_twist_Pa", "flank_pressure_Pa"),
                                ("edge_pressure_twist_Pa", "edge_pressure_Pa")):
                    g[k][...] = getattr(tw, attr) if getattr(tw, attr) is not None else np.nan
                for gauge, a in tw.strain.items():
                    g[f"strain_twist/{gauge}"][...] = a
            g["done_loads"][...] = 1
            g["done_deflections"][...] = 1
        seal_file(f)
    finally:
        f.close()
    os.replace(tmp, path)


def _frame_of(tw: TwistTable) -> dict[str, Any]:
    return dict(tw.frame, r_mesh=tw.r_mesh, r_twist=tw.r_twist, base_helix_angle_rad=tw.base_helix_angle_rad,
                lever_arm_m=tw.lever_arm_m, reference_plane_z_m=tw.reference_plane_z_m)


def load_system_tables(model_path: str | Path, tables_path: str | Path | None = None, *,
                       allow_hash_mismatch: bool = False) -> SystemTables:
    """Tables of a model (default ``<model folder>/tables.h5``), checked against the model file."""
    mp = resolve_model_path(model_path)
    tp = Path(tables_path) if tables_path is not None else mp.parent / "tables.h5"
    if not tp.exists():
        raise TableError(f"no tables for {mp}: {tp} does not exist; generate it with `hacgear statics {mp}`")
    return read_tables(tp, mp, allow_hash_mismatch=allow_hash_mismatch)
