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
from collections.abc import Callable
from contextlib import suppress
from pathlib import Path

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


class SweepDir:
    """The folder of one sweep inside a store, and the paths within it.

    Parameters
    ----------
    store_root
        The store folder.
    sweep_id
        The sweep id (the hash of its canonical spec); a plain folder name.

    Attributes
    ----------
    root
        ``<store>/<sweep-id>`` (created by ``write_spec`` or the first publish).
    cube, journal, spec
        ``root / "cube.h5"``, ``root / "journal"``, ``root / "spec.json"``.
    """

    def __init__(self, store_root, sweep_id: str):
        sid = str(sweep_id)
        if not sid or "/" in sid or "\\" in sid or sid.startswith("."):
            raise ValueError(f"sweep_id must be a plain folder name, got {sid!r}")
        self.store_root = Path(store_root)
        self.sweep_id = sid
        self.root = self.store_root / sid
        self.cube = self.root / CUBE_NAME
        self.journal = self.root / JOURNAL_DIR
        self.spec = self.root / SPEC_NAME

    def __repr__(self) -> str:
        return f"SweepDir({str(self.store_root)!r}, {self.sweep_id!r})"

    def __eq__(self, other) -> bool:
        return isinstance(other, SweepDir) and (self.store_root, self.sweep_id) == (
            other.store_root,
            other.sweep_id,
        )

    def __hash__(self) -> int:
        return hash((self.store_root, self.sweep_id))

    def write_spec(self, spec_json: str) -> Path:
        """Write ``spec.json`` atomically (the spec as submitted); returns its path."""
        return atomic_write(self.spec, lambda tmp: tmp.write_text(spec_json, encoding="utf-8"))


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
