"""The kernel cache's folders: one per engine fingerprint, the unused ones removed.

Every edit of the engine (a new release, a ``git pull`` of a checkout) names a new
``numba-<fingerprint>`` folder under the cache root (engine.jit); the old folder's machine
code can never be loaded again by that engine. Without pruning the root grows by a
folder per engine version (a developer's machine here held 8 of them, 248 MB, after two
days). Each process that uses a folder stamps it (:data:`STAMP`, at most once a day), and
the first process of a new day removes the folders whose last use is older than
``$DITHERLAB_CACHE_KEEP_DAYS`` (default 30; 0 or less keeps every folder). Another engine
version still in use on the machine (a second checkout, a batch job of an older install
sharing the root) stamps its folder when it starts, so it is kept; one that has not
started for a month recompiles its kernels once if it comes back.

Only os, shutil, time and pathlib here: engine.jit calls :func:`use` before numba compiles
anything.
"""
from __future__ import annotations

import os
import re
import shutil
import time
from pathlib import Path

STAMP = ".last-used"
# a kernel folder's name (engine.jit.cache_dir: 12 hex digits of the fingerprint); nothing
# else in the root is touched, whatever folder $DITHERLAB_CACHE_DIR names
FOLDER = re.compile(r"numba-[0-9a-f]{12}")
DAY_S = 86400.0
KEEP_DAYS = 30.0


def keep_days() -> float:
    """``$DITHERLAB_CACHE_KEEP_DAYS`` (a number of days), else :data:`KEEP_DAYS`; an
    unreadable value keeps the default."""
    try:
        return float(os.environ.get("DITHERLAB_CACHE_KEEP_DAYS", KEEP_DAYS))
    except ValueError:
        return KEEP_DAYS


def last_used(folder: Path) -> float:
    """When ``folder`` was last used: its stamp's time, else (a folder from before stamps)
    the folder's own modification time (numba adds files as it compiles)."""
    for path in (folder / STAMP, folder):
        try:
            return path.stat().st_mtime
        except OSError:
            continue
    return 0.0


def stale_folders(root: Path, current: Path, now: float, days: float) -> list[Path]:
    """The kernel folders (:data:`FOLDER`) of ``root`` other than ``current`` unused for
    ``days``."""
    try:
        entries = list(root.iterdir())
    except OSError:
        return []
    return sorted(p for p in entries
                  if FOLDER.fullmatch(p.name) and p.name != current.name and p.is_dir()
                  and now - last_used(p) > days * DAY_S)


def use(current: Path, now: float | None = None) -> list[Path]:
    """Stamp ``current`` as used; when its stamp was a day old or missing (the first
    process of a day), remove the stale folders beside it. Returns the removed folders.
    Never raises: an unwritable root leaves everything as it is."""
    now = time.time() if now is None else now
    stamp = current / STAMP
    if now - last_used(current) < DAY_S and stamp.exists():
        return []
    try:
        stamp.touch()
        os.utime(stamp, (now, now))
    except OSError:
        return []
    days = keep_days()
    if days <= 0:
        return []
    removed = stale_folders(current.parent, current, now, days)
    for folder in removed:
        shutil.rmtree(folder, ignore_errors=True)
    return removed
