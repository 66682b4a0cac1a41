"""The store's faults a user can meet, each one line that says what to do
(:class:`StoreError`; ``exit_status``: 1 a run failed, 2 input refused), and the
free-space check that raises :class:`NoSpaceError` before anything is written
(:func:`ensure_space`; store.layout, store.atomic)."""

from __future__ import annotations

import errno
import os
from pathlib import Path

MB = 1 << 20
SPACE_MARGIN = 64 << 10   # keep this much free beyond a write (file-system metadata, SQLite)


class StoreError(Exception):
    """A store problem told to the user as one line (no traceback)."""

    exit_status = 1


class StorePathError(StoreError):
    """The store path itself is unusable (a file, a name too long): input refused."""

    exit_status = 2


class NoSpaceError(StoreError, OSError):
    """Not enough free space to write ``path``; nothing was replaced.

    ``needed`` and ``free`` are bytes (``needed`` may be 0 when the file system said
    ENOSPC without a size known in advance).
    """

    def __init__(self, path, needed: int = 0, free: int | None = None):
        self.path, self.needed = Path(path), int(needed)
        self.free = free_bytes(self.path) if free is None else int(free)
        short = max(self.needed + SPACE_MARGIN - self.free, MB // 10)
        self.short_mb = short / MB
        super().__init__(errno.ENOSPC, f"no space left on device writing {self.path}: "
                         f"free {self.short_mb:.1f} MB and submit again")

    def __str__(self) -> str:
        return self.strerror


def free_bytes(path) -> int:
    """Bytes free to an unprivileged writer on the file system holding ``path`` (or its
    nearest existing parent)."""
    path = Path(path).absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    st = os.statvfs(path)
    return st.f_bavail * st.f_frsize


def ensure_space(path, needed: int) -> None:
    """Raise ``NoSpaceError`` unless ``needed`` bytes (plus ``SPACE_MARGIN``) are free
    where ``path`` lives; called before writing, so nothing is torn or replaced."""
    free = free_bytes(path)
    if free < needed + SPACE_MARGIN:
        raise NoSpaceError(path, needed, free)
