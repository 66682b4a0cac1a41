"""Where things live in a store folder, and how files are replaced atomically.

A store is one folder::

    <store>/catalogue.sqlite          the catalogue of sweeps (store.catalogue)
    <store>/<sweep-id>/cube.nc        the result cube (store.cube; cube.h5 in older stores)
    <store>/<sweep-id>/journal/       one small file per finished block (store.journal)
    <store>/<sweep-id>/spec.json      the spec as submitted (written by the runner)

The store root defaults to ``$DITHERLAB_STORE`` or ``./ditherlab-store`` (DESIGN.md §5).

``atomic_write`` (store.atomic) is the one crash-safe write used by the cube and the
journal (DESIGN.md §4): write to a temporary name in the destination folder, flush and
fsync it, ``os.replace`` it onto the final name, fsync the folder. A reader sees
the old file or the new one, never a torn one; a writer killed before the rename
leaves only a temporary file, which ``remove_stale_temps`` deletes later.

Faults a user can meet are ``StoreError``s (store.errors), each one line that says
what to do: ``NoSpaceError`` (disk full: checked before writing, and ENOSPC/EDQUOT while
writing), ``check_store`` (a store path that is a file, a name too long, a
read-only store asked to take writes). ``exit_status`` says which exit status the
command line gives (README: 1 a run failed, 2 input refused).
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

from .atomic import atomic_write, temp_name
from .errors import NoSpaceError, StoreError, StorePathError

CATALOGUE_NAME = "catalogue.sqlite"
CUBE_NAME = "cube.nc"
LEGACY_CUBE_NAME = "cube.h5"   # stores written before 0.2 (same format, old suffix)
JOURNAL_DIR = "journal"
SPEC_NAME = "spec.json"
ENV_STORE = "DITHERLAB_STORE"     # the default store: sweeps.lookup.store_root
DEFAULT_STORE = "ditherlab-store"


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
        ``root / "cube.nc"`` (``cube.h5`` when only that exists: an older store),
        ``root / "journal"``, ``root / "spec.json"``.
    """

    def __init__(self, store_root, sweep_id: str):
        sid = str(sweep_id)
        if not sid or "/" in sid or "\\" in sid or sid.startswith("."):
            raise ValueError(f"sweep_id must be a plain folder name, got {sid!r}")
        self.store_root = Path(store_root)
        self.sweep_id = sid
        self.root = self.store_root / sid
        self.journal = self.root / JOURNAL_DIR
        self.spec = self.root / SPEC_NAME

    @property
    def cube(self) -> Path:
        """The cube file: ``cube.nc``, or an older store's ``cube.h5`` while it is the only one."""
        legacy = self.root / LEGACY_CUBE_NAME
        return legacy if legacy.exists() and not (self.root / CUBE_NAME).exists() \
            else self.root / CUBE_NAME

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


def check_store(root, write: bool) -> Path:
    """The store folder ``root`` checked for use, as a ``Path``.

    A path that is not a folder (or has a component too long) raises
    ``StorePathError``. With ``write``, the folder is created if missing and a probe
    file is written and removed: a read-only store raises ``StoreError`` saying that
    read commands still work; a full one ``NoSpaceError``.
    """
    root = Path(root)
    try:
        exists = root.exists()
        if exists and not root.is_dir():
            raise StorePathError(f"store path {root} is not a folder; pass --store DIR "
                                 "(or set $DITHERLAB_STORE) naming a folder")
        if not exists:   # a store to be made: no file may stand where a folder must be
            above = next((a for a in root.absolute().parents if a.exists()), None)
            if above is not None and not above.is_dir():
                raise StorePathError(f"store path {root} cannot be used: {above} is a file; "
                                     "pass --store DIR naming a folder")
    except OSError as err:   # ENAMETOOLONG, ELOOP, EACCES on a parent
        raise StorePathError(f"store path {_short(root)} cannot be used: "
                             f"{err.strerror}") from None
    if not write:
        return root
    try:
        root.mkdir(parents=True, exist_ok=True)
        probe = temp_name(root / ".write-probe")
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as err:
        if err.errno in (errno.ENOSPC, errno.EDQUOT):
            raise NoSpaceError(root) from None
        if err.errno in (errno.EROFS, errno.EACCES, errno.EPERM):
            raise StoreError(f"store {root} is read-only ({err.strerror}): cannot write "
                             "there; status, query and map still read it") from None
        if err.errno in (errno.ENOTDIR, errno.ENAMETOOLONG, errno.EEXIST):
            raise StorePathError(f"store path {_short(root)} cannot be used: "
                                 f"{err.strerror}") from None
        raise StoreError(f"cannot write to store {root}: {err.strerror}") from None
    return root


def writable(folder) -> bool:
    """True if this process may create files in the existing folder ``folder``
    (``access(2)``: false on a read-only mount, even for root; no side effects)."""
    return os.access(folder, os.W_OK | os.X_OK)


def _short(path: Path, width: int = 80) -> str:
    text = str(path)
    return text if len(text) <= width else f"{text[:width // 2]}...{text[-width // 2:]}"
