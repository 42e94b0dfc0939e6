"""What an HDF5 file of hacgear is, read from its root attribute ``format``, so that no command writes into a file
of another kind (sweep rows into a tables file, a table over sweep results).

Kinds: ``"tables"`` (``format = "hacgear-tables"``, written by ``hacgear statics``), ``"sweep"`` (``format =
"hacgear-sweep"``, or the group ``sweeps`` of files written before the attribute; ``hacgear sweep --out``),
``"study"`` (``format = "hacgear-study"``, ``hacgear study``), ``"empty"`` (an HDF5 file without objects or
attributes), ``"stub"`` (the first bytes of an HDF5 file that HDF5 cannot open, under 4 kB: a write killed at its
start, as sweep and study files were left before they were written atomically), ``"hdf5"`` (any other HDF5
file) and ``"other"`` (not an HDF5 file).  ``empty`` and ``stub`` files hold nothing and may be written over."""
from __future__ import annotations

from pathlib import Path

import h5py

from hacgear_core.errors import TableError

__all__ = ["TABLES_FORMAT", "SWEEP_FORMAT", "STUDY_FORMAT", "file_kind", "check_writable_kind", "holds_nothing"]

#: the HDF5 format signature (the superblock's first bytes)
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: largest file taken for an interrupted write's stub
_STUB_BYTES = 4096

TABLES_FORMAT = "hacgear-tables"
SWEEP_FORMAT = "hacgear-sweep"
STUDY_FORMAT = "hacgear-study"

_WHAT = {
    "tables": "a hacgear tables file (root attribute format = 'hacgear-tables', from `hacgear statics`)",
    "sweep": "a hacgear sweep results file (from `hacgear sweep --out`)",
    "study": "a hacgear study results file (from `hacgear study`)",
    "hdf5": "an HDF5 file that hacgear did not write",
    "other": "not an HDF5 file",
}


def file_kind(path: str | Path) -> str:
    """The kind of the existing file ``path`` (see the module docstring)."""
    try:
        with h5py.File(path, "r") as f:
            fmt = f.attrs.get("format")
            fmt = fmt.decode() if isinstance(fmt, bytes) else fmt
            if fmt == TABLES_FORMAT:
                return "tables"
            if fmt == STUDY_FORMAT:
                return "study"
            if fmt == SWEEP_FORMAT or (fmt is None and "sweeps" in f):
                return "sweep"
            if fmt is None and len(f) == 0 and len(f.attrs) == 0:
                return "empty"
            return "hdf5"
    except OSError:
        p = Path(path)
        try:
            with open(p, "rb") as fh:
                head = fh.read(len(_HDF5_SIGNATURE))
            if head == _HDF5_SIGNATURE and p.stat().st_size < _STUB_BYTES:
                return "stub"
        except OSError:
            pass
        return "other"


def holds_nothing(path: str | Path) -> bool:
    """True where ``path`` exists and is an empty HDF5 file or an interrupted write's stub (nothing to keep)."""
    return Path(path).is_file() and file_kind(path) in ("empty", "stub")


def check_writable_kind(path: str | Path, kind: str, what: str, option: str = "--out") -> None:
    """Raise :class:`TableError` when ``path`` exists and is not a file of ``kind`` (or an empty HDF5 file): the
    message names the path, what the file is and what ``what`` (the data to be written) would have done to it."""
    p = Path(path)
    if not p.is_file():
        return
    found = file_kind(p)
    if found in (kind, "empty", "stub"):
        return
    raise TableError(f"{option} {str(p)!r} is {_WHAT[found]}; refusing to write {what} into it (that would destroy "
                     f"it). Give another {option} file")
