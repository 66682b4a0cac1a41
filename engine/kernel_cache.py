"""The kernel cache's files, checked: what numba writes into the engine's cache folder
(engine.jit.cache_dir) carries the SHA-256 of its contents, checked when it is read. A file
that fails the check, or that cannot be read, is a cache miss: the kernel is compiled again
and written again. A folder that cannot be written (full, read-only) costs a compile in
every process, said once in a warning, never a failed point.

Before (a fault campaign, 2026-11-29, the cheap sweep of scripts/bench_efficiency.py):
- one bit flipped in a cached block kernel's constants: every point of the next sweep
  differed (v_mean by up to 3.6e-5 relative), ``done``, no warning; a neighbouring bit made
  F_mean = 0 at every point, still ``ok``;
- truncated or garbage cache files: every block failed (``UnpicklingError``), and again at
  each submit; 4 KiB of zeros in one: the submitter died of a segmentation fault, or a
  cluster's warm-up hung;
- a full cache folder: every block failed with ``OSError: [Errno 28]``, naming no folder.

numba internals (``numba.core.caching.IndexDataCacheFile``, pinned in pyproject.toml): its
index and data reads and writes are replaced for the files in the engine's cache folder
only; the caches of other numba code in the process keep numba's format. Only the standard
library at import: engine.jit installs this before numba compiles anything.
"""
from __future__ import annotations

import hashlib
import logging
import os
import pickle

log = logging.getLogger("ditherlab")

MAGIC = b"ditherlab-kernel-cache-sha256\n"   # then 32 bytes of digest, then numba's pickle
_FOLDER: list[str] = []    # the engine's cache folder (engine.jit), once installed
_SAID: set[str] = set()    # the faults already said in this process


def install(folder: str) -> None:
    """Check the files numba keeps in ``folder`` from now on (idempotent)."""
    from numba.core import caching

    _FOLDER[:] = [os.path.join(os.path.abspath(folder), "")]
    cls = caching.IndexDataCacheFile
    if getattr(cls, "_ditherlab", False):
        return
    originals = {name: getattr(cls, name)
                 for name in ("_load_index", "_save_index", "_load_data", "_save_data")}

    def ours(self) -> bool:
        return _inside(self._cache_path)

    def _load_index(self):
        if not ours(self):
            return originals["_load_index"](self)
        payload = _read(self._index_path)
        try:   # (an index another numba wrote may not unpickle: a miss)
            version, stamp, overloads = pickle.loads(payload) if payload else (None,) * 3
        except Exception:  # noqa: BLE001
            return {}
        return overloads if (version, stamp) == (self._version, self._source_stamp) else {}

    def _save_index(self, overloads):
        if not ours(self):
            return originals["_save_index"](self, overloads)
        _write(self, self._index_path, (self._version, self._source_stamp, overloads))

    def _load_data(self, name):
        if not ours(self):
            return originals["_load_data"](self, name)
        payload = _read(self._data_path(name))
        if payload is None:
            raise OSError(f"{self._data_path(name)}: missing or damaged")   # numba: a miss
        return pickle.loads(payload)

    def _save_data(self, name, data):
        if not ours(self):
            return originals["_save_data"](self, name, data)
        _write(self, self._data_path(name), data)

    for fn in (_load_index, _save_index, _load_data, _save_data):
        setattr(cls, fn.__name__, fn)
    cls._ditherlab = True
    save_overload = caching.Cache.save_overload

    def guarded_save(self, sig, data):   # (numba makes the folder first, outside _write)
        try:
            save_overload(self, sig, data)
        except OSError as exc:
            if not _inside(self._cache_path):
                raise
            unwritable(self._cache_path, exc)

    caching.Cache.save_overload = guarded_save


def uncached_elsewhere(dispatcher) -> None:
    """No disk cache for ``dispatcher`` unless numba chose the engine's folder for it: numba
    falls back to the source folder's ``__pycache__`` when a subfolder cannot be made, a
    cache that no engine fingerprint names (stale kernels)."""
    from numba.core.caching import NullCache

    path = getattr(getattr(dispatcher, "_cache", None), "_cache_path", None)
    if path is not None and not _inside(path):
        unwritable(path, OSError(f"numba chose {path} instead"))
        dispatcher._cache = NullCache()


def _inside(path: str) -> bool:
    """``path`` is in the engine's cache folder (once :func:`install` named one)."""
    return bool(_FOLDER) and os.path.join(os.path.abspath(path), "").startswith(_FOLDER[0])


def _read(path: str) -> bytes | None:
    """The checked contents of a cache file; None when it is missing or fails its check."""
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except FileNotFoundError:
        return None
    except OSError as exc:
        _damaged(path, exc.strerror or str(exc))
        return None
    n = len(MAGIC)
    if raw[:n] != MAGIC or hashlib.sha256(raw[n + 32:]).digest() != raw[n:n + 32]:
        _damaged(path, "it fails its checksum")
        return None
    return raw[n + 32:]


def _damaged(path: str, why: str) -> None:
    """Say once per process that a cache file is damaged (each one is compiled again)."""
    if "damaged" not in _SAID:
        _SAID.add("damaged")
        log.warning("the kernel cache file %s is damaged (%s): compiling what it held "
                    "again, and writing it anew (so too any other damaged file, unsaid)",
                    path, why)


def _write(cache_file, path: str, obj) -> None:
    """Write ``obj`` checked (numba's own atomic write); a folder that cannot take it is
    said once per process, and the kernel is used uncached."""
    payload = cache_file._dump(obj)
    try:
        with cache_file._open_for_write(path) as f:
            f.write(MAGIC + hashlib.sha256(payload).digest() + payload)
    except OSError as exc:
        unwritable(os.path.dirname(path), exc)


def unwritable(folder: str, exc: OSError) -> None:
    """Say once per process that ``folder`` cannot take kernels (they run uncached)."""
    if "unwritable" not in _SAID:
        _SAID.add("unwritable")
        folder = _FOLDER[0].rstrip(os.sep) if _FOLDER else folder
        log.warning("the kernel cache %s cannot be written (%s): the kernels are compiled "
                    "in every process until it can (free space there, or set "
                    "DITHERLAB_CACHE_DIR)", folder, exc.strerror or exc)
