"""Replacing files atomically: :func:`atomic_write` is the one crash-safe write used by
the cube and the journal (DESIGN.md §4): write to a temporary name in the destination
folder, flush and fsync it, ``os.replace`` it onto the final name, fsync the folder. A
reader sees the old file or the new one, never a torn one; a writer killed before the
rename leaves only a temporary file, which :func:`remove_stale_temps` deletes later."""

from __future__ import annotations

import errno
import os
import secrets
from collections.abc import Callable
from contextlib import suppress
from pathlib import Path

from .errors import NoSpaceError, ensure_space

TEMP_MARK = ".tmp-"


def temp_name(path: Path) -> Path:
    """A fresh temporary name next to ``path``: ``.<name>.tmp-<pid>-<random>``.

    The leading dot hides it from ``*/cube.nc`` and ``block-*.npz`` globs; the pid
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


def atomic_write(path: Path, write: Callable[[Path], None] | bytes | memoryview) -> Path:
    """Create ``path`` atomically: write a temporary file, fsync, rename, fsync the folder.

    Parameters
    ----------
    path
        Final file name; its folder is created if missing.
    write
        The file's bytes, or a function called with the temporary path that must
        create and close that file. Given bytes, free space is checked first.

    Returns
    -------
    Path
        ``path``. If the write fails, the temporary file is removed and the old
        ``path`` (if any) is untouched; a full disk raises ``NoSpaceError``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not callable(write):
        data = write
        ensure_space(path, len(data))
        write = lambda tmp: tmp.write_bytes(data)  # noqa: E731
    tmp = temp_name(path)
    try:
        write(tmp)
        fsync_file(tmp)
        os.replace(tmp, path)
    except BaseException as err:
        with suppress(OSError):
            tmp.unlink()
        if isinstance(err, OSError) and err.errno in (errno.ENOSPC, errno.EDQUOT):
            # named by the final path (a writer's own NoSpaceError names the temporary one)
            raise NoSpaceError(path, getattr(err, "needed", 0)) from err
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
