"""Output paths checked before a command or a figure script starts its work, so that a long run never ends in a
traceback, and files written whole or not at all (shared by the command line, the library's result files and the
plots)."""
from __future__ import annotations

import os
import shutil
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from hacgear_core.errors import HacgearError
from hacgear_core.model import shipped_systems_dir

__all__ = ["check_out_path", "check_out_dir", "check_not_shipped", "written_whole", "save_figure", "WRITING_SUFFIX"]

#: suffix of the temporary file a result is written to before it replaces its target (a kill leaves only this)
WRITING_SUFFIX = ".writing"


@contextmanager
def written_whole(path: str | Path, *, start_from_existing: bool = False) -> Iterator[Path]:
    """Write ``path`` atomically: yields a temporary path beside it (``<name>.writing``) to write, which replaces
    ``path`` in one rename when the block ends without an exception; on an exception it is removed and ``path``
    stays as it was.  A kill (even ``kill -9``) therefore leaves ``path`` whole (old or new) and at most the
    temporary file, which the next write of ``path`` replaces.  ``start_from_existing``: the temporary file starts
    as a copy of ``path`` (for files that are updated, such as a results file that gains a branch)."""
    path = Path(path)
    tmp = path.with_name(path.name + WRITING_SUFFIX)
    if tmp.exists():
        tmp.unlink()   # an earlier write of ours that was killed
    if start_from_existing and path.exists():
        shutil.copyfile(path, tmp)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        if tmp.exists():
            tmp.unlink()
        raise


def _writable_folder(folder: Path, what: str) -> None:
    if not folder.is_dir():
        raise HacgearError(f"{what}: folder {folder} does not exist (create it first)")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise HacgearError(f"{what}: folder {folder} is not writable")


def check_out_path(path: str | Path, option: str = "--out", *, suffixes: tuple[str, ...] | None = None) -> Path:
    """Check that the file ``path`` can be written: a known suffix (when ``suffixes`` are given), an existing
    writable folder, not a folder itself.  Returns the path; raises :class:`HacgearError` naming the option."""
    p = Path(path)
    what = f"{option} {str(path)!r}"
    if p.is_dir():
        raise HacgearError(f"{what} is a folder; give a file name"
                           + (f" ending in {' or '.join(suffixes)}" if suffixes else ""))
    if suffixes and p.suffix.lower() not in suffixes:
        raise HacgearError(f"{what}: the file must end in {' or '.join(suffixes)}")
    if p.exists() and not os.access(p, os.W_OK):
        raise HacgearError(f"{what}: the file exists and is not writable")
    _writable_folder(p.parent if str(p.parent) else Path("."), what)
    return p


def check_not_shipped(path: str | Path, option: str = "--out") -> None:
    """Refuse an output folder that is, or lies inside, the shipped systems' folder (``models/`` of the checkout,
    the installed ``hacgear_core.systems``) or a system folder (one holding a model.toml): outputs do not go among
    the shipped files."""
    p = Path(path).resolve()
    shipped = shipped_systems_dir().resolve()
    if p == shipped or shipped in p.parents or (p / "model.toml").is_file():
        raise HacgearError(f"{option} {str(path)!r} is the shipped systems' folder or a system folder ({shipped}); "
                           "write outputs to a folder of their own (e.g. --out demo_out)")


def check_out_dir(path: str | Path, option: str = "--out") -> Path:
    """Check that the folder ``path`` exists and is writable, or can be created in an existing writable folder
    (it is not created here).  Returns the path; raises :class:`HacgearError` naming the option."""
    p = Path(path)
    what = f"{option} {str(path)!r}"
    if p.exists():
        if not p.is_dir():
            raise HacgearError(f"{what} is a file; give a folder")
        _writable_folder(p, what)
        return p
    parent = p.parent if str(p.parent) else Path(".")
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise HacgearError(f"{what}: the folder cannot be created ({parent} is not a writable folder)")
    return p


def save_figure(fig, path: str | Path, **kwargs) -> Path:
    """``fig.savefig`` written whole (:func:`written_whole`; the format from the suffix of ``path``)."""
    path = Path(path)
    with written_whole(path) as tmp:
        fig.savefig(tmp, format=path.suffix.lstrip(".").lower() or "png", **kwargs)
    return path
