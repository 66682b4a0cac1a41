"""``njit`` for the whole engine: compiled once per machine, not once per process.

Kernels are built by factories (closures over a Scene's compile-time flags and over
other jitted closures). numba's on-disk cache keys a closure by its pickled cell
contents, and a dispatcher pickles with a random UUID, so every new process misses the
cache and recompiles (numba issue #6264) -- tens of seconds per scene per dask worker.
Giving every dispatcher a *deterministic* UUID (its qualified name plus the factory's
key) makes the pickle, hence the cache key, reproducible: the second process loads the
machine code from ``__pycache__`` (or numba's user cache dir) instead of compiling.

The UUID only names the dispatcher for pickling; two dispatchers share one only if they
come from the same function with the same key, i.e. they are the same kernel.

numba checks only the source file of a cached function for changes, not the files of the
functions it calls, so an edit elsewhere in the engine could replay stale machine code.
The cache therefore lives in a folder named by a hash of every engine source file:
``$DITHERLAB_CACHE_DIR`` (default ``~/.cache/ditherlab``) ``/numba-<hash>``. Any edit of
the engine starts a fresh cache; delete old ``numba-*`` folders at will.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba

ENGINE_ROOT = Path(__file__).resolve().parent


def source_hash() -> str:
    """12 hex digits of sha256 over the engine's Python sources (paths and contents)."""
    digest = hashlib.sha256()
    for path in sorted(ENGINE_ROOT.rglob("*.py")):
        digest.update(str(path.relative_to(ENGINE_ROOT)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def cache_dir() -> Path:
    base = os.environ.get("DITHERLAB_CACHE_DIR") or Path.home() / ".cache" / "ditherlab"
    return Path(base) / f"numba-{source_hash()}"


def _use_engine_cache_dir() -> None:
    """Point numba's cache at :func:`cache_dir` before any engine function is decorated
    (the locator is chosen at decoration time). Unwritable -> numba's own default."""
    path = cache_dir()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return
    numba.config.CACHE_DIR = str(path)


_use_engine_cache_dir()


def njit(fn=None, *, key: object = "", **options):
    """``numba.njit(cache=True, **options)`` with a deterministic dispatcher UUID.

    Parameters
    ----------
    fn
        The function (when used as a bare decorator ``@njit``).
    key
        For closures made by a factory: everything that distinguishes one closure from
        another of the same function (the Scene, flags, ...), as a value whose ``repr``
        is stable across processes.
    """
    options.setdefault("cache", True)

    def decorate(func):
        dispatcher = numba.njit(**options)(func)
        uuid = f"ditherlab:{func.__module__}.{func.__qualname__}:{key!r}"
        try:
            dispatcher._set_uuid(uuid)
        except (AttributeError, AssertionError):  # numba internals changed: only a cache miss
            pass
        return dispatcher

    return decorate(fn) if fn is not None else decorate
