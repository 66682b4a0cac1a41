"""Where things live in a store folder, and how files are replaced atomically.

A store is one folder::

    <store>/catalogue.sqlite          the catalogue of sweeps (store.catalogue)
    <store>/<sweep-id>/cube.h5        the result cube (store.cube)
    <store>/<sweep-id>/journal/       one small file per finished block (store.journal)
    <store>/<sweep-id>/spec.json      the spec as submitted (written by the runner)

The store root defaults to ``$DITHERLAB_STORE`` or ``./ditherlab-store`` (DESIGN.md §5).

``atomic_write`` is the one crash-safe write used by the cube and the journal
(DESIGN.md §4): write to a temporary name in the destination folder, flush and
fsync it, ``os.replace`` it onto the final name, fsync the folder. A reader sees
the old file or the new one, never a torn one; a writer killed before the rename
leaves only a temporary file, which ``remove_stale_temps`` deletes later.
"""
from __future__ import annotations

import os
import secrets
from contextlib import suppress
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

CATALOGUE_NAME = "catalogue.sqlite"
CUBE_NAME = "cube.h5"
JOURNAL_DIR = "journal"
SPEC_NAME = "spec.json"
ENV_STORE = "DITHERLAB_STORE"
DEFAULT_STORE = "ditherlab-store"
TEMP_MARK = ".tmp-"


def default_store() -> Path:
    """The store root: ``$DITHERLAB_STORE`` if set, else ``./ditherlab-store``."""
    return Path(os.environ.get(ENV_STORE) or DEFAULT_STORE)


@dataclass(frozen=True)
class SweepPaths:
    """The paths of one sweep inside a store.

    Parameters
    ----------
    root
        The store folder.
    sweep_id
        The sweep id (the hash of its canonical spec).
    """

    root: Path
    sweep_id: str

    def __post_init__(self):
        sid = str(self.sweep_id)
        if not sid or "/" in sid or sid.startswith("."):
            raise ValueError(f"sweep_id must be a plain folder name, got {sid!r}")
        object.__setattr__(self, "root", Path(self.root))
        object.__setattr__(self, "sweep_id", sid)

    @property
    def folder(self) -> Path:
        """``<store>/<sweep-id>``."""
        return self.root / self.sweep_id

    @property
    def cube(self) -> Path:
        """``<store>/<sweep-id>/cube.h5``."""
        return self.folder / CUBE_NAME

    @property
    def spec(self) -> Path:
        """``<store>/<sweep-id>/spec.json``."""
        return self.folder / SPEC_NAME

    @property
    def journal(self) -> Path:
        """``<store>/<sweep-id>/journal``."""
        return self.folder / JOURNAL_DIR


def temp_name(path: Path) -> Path:
    """A fresh temporary name next to ``path``: ``.<name>.tmp-<pid>-<random>``.

    The leading dot hides it from ``*/cube.h5`` and ``block-*.npz`` globs; the pid
    lets ``remove_stale_temps`` tell a dead writer's leftover from a live one's.
    """
    path = Path(path)
    return path.with_name(f".{path.name}{TEMP_MARK}{os.getpid()}-{secrets.token_hex(4)}")


def fsync_dir(folder: Path) -> None:
    """fsync a folder so that a rename inside it survives a power cut (POSIX)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - platforms without directory fds
        return
    try:
        with suppress(OSError):
            os.fsync(fd)
    finally:
        os.close(fd)


def fsync_file(path: Path) -> None:
    """fsync a file that a library (h5py) has already written and closed."""
    fd = os.open(path, os.O_RDWR)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def atomic_write(path: Path, write: Callable[[Path], None]) -> Path:
    """Create ``path`` atomically: ``write(tmp)``, fsync, rename, fsync the folder.

    Parameters
    ----------
    path
        Final file name; its folder is created if missing.
    write
        Called with the temporary path; must create and close that file.

    Returns
    -------
    Path
        ``path``. If ``write`` raises, the temporary file is removed and the old
        ``path`` (if any) is untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_name(path)
    try:
        write(tmp)
        fsync_file(tmp)
        os.replace(tmp, path)
    except BaseException:
        with suppress(OSError):
            tmp.unlink()
        raise
    fsync_dir(path.parent)
    return path


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def remove_stale_temps(folder: Path) -> list[Path]:
    """Delete temporary files in ``folder`` whose writing process is gone.

    Returns the removed paths. Files of a live process (this one included) and
    names that do not parse are left alone, so a concurrent writer is never hurt.
    """
    removed = []
    for tmp in Path(folder).glob(f".*{TEMP_MARK}*"):
        pid_text = tmp.name.rsplit(TEMP_MARK, 1)[1].split("-", 1)[0]
        if pid_text.isdigit() and not _pid_alive(int(pid_text)):
            with suppress(OSError):
                tmp.unlink()
                removed.append(tmp)
    return removed
