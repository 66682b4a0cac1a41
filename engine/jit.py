"""``njit`` for the whole engine: compiled once per machine, not once per process.

Kernels are built by factories (closures over a Scene's compile-time flags and over
other jitted closures). numba's on-disk cache keys a closure by its pickled cell
contents, and a dispatcher pickles with a random UUID, so every new process misses the
cache and recompiles (numba issue #6264) -- tens of seconds per scene per dask worker.
Giving every dispatcher a *deterministic* UUID (its qualified name plus the factory's
key) makes the pickle, hence the cache key, reproducible: the second process loads the
machine code from ``__pycache__`` (or numba's user cache dir) instead of compiling.

The UUID must be unique per distinct closure: numba's unpickler maps a UUID to the live
dispatcher registered under it (``Dispatcher._rebuild``), so two different closures sharing
one could be confused. It is therefore derived from the function's qualified name and its
closure cells: constants by ``repr`` (numpy arrays by their bytes), jitted callees by their
own (recursively derived) UUID. A cell without a stable representation (a plain Python
object) keeps numba's random UUID: the kernel is then compiled per process -- a cache miss,
never a wrong kernel.

Machine code is named by qualified name plus a per-process counter, so distinct closures
of one factory compiled in different processes could share a symbol and be cross-linked
when a third process loads both from the cache; every closure's qualified name therefore
carries its UUID (:func:`_name_by_uuid`).

numba checks only the source file of a cached function for changes, not the files of the
functions it calls, so an edit elsewhere in the engine could replay stale machine code.
The cache therefore lives in a folder named by a hash of every engine source file (the
engine fingerprint, engine.provenance, also recorded in every cube):
``$DITHERLAB_CACHE_DIR`` (default ``~/.cache/ditherlab``) ``/numba-<fingerprint>``. Any edit of
the engine starts a fresh cache; folders unused for 30 days are removed (engine.cache_folders).
"""
from __future__ import annotations

import hashlib
import os
import secrets
from pathlib import Path

import numba
import numpy

from . import cache_folders, deep_stack, inline_scope, kernel_cache, kernel_parts
from .provenance import cache_root, fingerprint
from .registries import load_numba_registries


def cache_dir() -> Path:
    return cache_root() / f"numba-{fingerprint()}"


_ENGINE_CACHE: str | None = None   # numba's CACHE_DIR for the engine's kernels


def _use_engine_cache_dir() -> None:
    """Point numba's cache at :func:`cache_dir` before any engine function is decorated
    (the locator is chosen at decoration time), its files checked (engine.kernel_cache).
    Unwritable: no disk cache, said once (not numba's fallback, each source folder's
    ``__pycache__``, which no engine fingerprint names: stale kernels).

    :func:`njit` points it there again before each decoration: numba re-reads its whole
    configuration from the environment at the first compile after any ``NUMBA_*`` variable
    changed (``numba.core.config.reload_config``), which sets ``CACHE_DIR`` back to
    ``$NUMBA_CACHE_DIR`` or "" (``__pycache__`` again). engine.gpu sets such a variable;
    after a GPU run every scene a process made next was cached in the checkout's
    ``engine/__pycache__`` and missed this cache (tests/engine/test_disk_cache.py)."""
    global _ENGINE_CACHE
    path = cache_dir()
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".probe-{os.uname().nodename}-{os.getpid()}-{secrets.token_hex(4)}"
        os.close(os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        probe.unlink(missing_ok=True)
    except OSError as exc:
        kernel_cache.unwritable(str(path), exc)
        return
    cache_folders.use(path)
    kernel_cache.install(str(path))
    _ENGINE_CACHE = numba.config.CACHE_DIR = str(path)


_use_engine_cache_dir()


def _helpers_per_fastmath() -> None:
    """Give every fastmath setting its own cache of numba's internal helpers.

    numba compiles a helper such as float ``x ** 2`` once per process and keeps it in
    ``BaseContext.cached_internal_func``, keyed without the fastmath flags; a fastmath
    function's context is a shallow copy (``subtarget``) sharing that dict. So DP5's
    ``attempt`` (``fastmath={'contract'}``) got ``err += (ei / sc) ** 2`` with or without a
    fused multiply-add depending on whether a plain function using ``** 2`` had been
    compiled first in the process -- which depends on what the disk cache held: a worker
    that loaded the other kernels and compiled ``attempt`` differed from one that compiled
    everything by up to 3e-13 relative in v_slow_p2p (found when a LocalCluster's and an
    external cluster's cubes of one spec differed; tests/engine/test_compile_order.py).
    numba internals (pinned to 0.68 in pyproject.toml); if they move, the test says so."""
    from numba.core import base

    original = base.BaseContext.subtarget
    if getattr(original, "_ditherlab", False):
        return

    def subtarget(self, **kws):
        obj = original(self, **kws)
        if obj.cached_internal_func is self.cached_internal_func:
            theirs = frozenset(getattr(obj.fastmath, "flags", None) or ())
            if theirs != frozenset(getattr(self.fastmath, "flags", None) or ()):
                by_flags = self.__dict__.setdefault("_ditherlab_helpers_by_fastmath", {})
                obj.cached_internal_func = by_flags.setdefault(theirs, {})
        return obj

    subtarget._ditherlab = True
    base.BaseContext.subtarget = subtarget


_helpers_per_fastmath()
deep_stack.install()   # no data-stack chunk mapped per call in a compile (engine.deep_stack)
inline_scope.install()   # one scope copy per IR copy when numba inlines (engine.inline_scope)

_STABLE = (bool, int, float, complex, str, bytes, type(None))


def _stable_repr(value) -> str | None:
    """A process-independent text for a closure cell, or None if there is none."""
    if isinstance(value, _STABLE):
        return repr(value)
    if isinstance(value, numpy.ndarray):
        return f"ndarray{value.dtype}{value.shape}:{hashlib.sha256(value.tobytes()).hexdigest()}"
    if isinstance(value, tuple):
        parts = [_stable_repr(v) for v in value]
        return None if None in parts else "(" + ",".join(parts) + ")"
    uuid = getattr(value, "_ditherlab_uuid", None)  # a dispatcher made by this module
    return uuid


def closure_uuid(func) -> str | None:
    """Deterministic UUID of ``func``: its qualified name and the texts of its cells."""
    parts = [f"{func.__module__}.{func.__qualname__}"]
    for cell in func.__closure__ or ():
        try:
            value = cell.cell_contents
        except ValueError:  # a forward reference, filled later: unknown now
            return None
        text = _stable_repr(value)
        if text is None:
            return None
        parts.append(text)
    return "ditherlab-" + hashlib.sha256("|".join(parts).encode()).hexdigest()[:32]


def _name_by_uuid(func, uuid: str | None) -> None:
    """Append the closure's UUID (or, without one, a random tag) to its qualified name.

    numba names a function's machine code by qualified name plus a per-process counter.
    Two closures of one factory compiled in two processes get the same counter, hence the
    same symbol; a third process loading both from the disk cache then linked the first
    one's code for both (measured: a block kernel returned another scene's output columns;
    tests/engine/test_disk_cache.py). Distinct closures must have distinct names; identical
    ones (same UUID) may share theirs. The code object is renamed too, so a dispatcher
    rebuilt from a pickle keeps the name.
    """
    tag = uuid[len("ditherlab-"):][:16] if uuid else secrets.token_hex(8)
    _rename(func, f"{func.__qualname__}__{tag}")


def _rename(func, name: str) -> None:
    func.__qualname__ = name
    if hasattr(func.__code__, "co_qualname"):     # Python >= 3.11
        func.__code__ = func.__code__.replace(co_qualname=name)


def njit(fn=None, *, refcount: bool = True, entry: bool = False, **options):
    """``numba.njit(cache=True, nogil=True, **options)`` with a deterministic dispatcher
    UUID. ``nogil``: a kernel called from Python releases the GIL while it runs, so
    threads of one process compute blocks side by side (a small sweep runs in the
    submitting process on threads, sweeps.run.dispatch).

    ``refcount=False`` compiles without numba's runtime (NRT) for a *loop kernel that
    allocates nothing and returns no array* -- it only borrows its caller's arrays. NRT
    reference-counts every array view with an atomic increment/decrement pair (numba
    issue #2345 shows the cost); in the DP5 step loop those pairs were a quarter of the
    time (50.8 -> 39.4 ns per right-hand-side evaluation on the fig10 benchmark, against
    34 ns for C). Allocation in such a kernel fails at compile time, never silently.

    ``entry=True`` for a function that Python calls (a kernel): the others are kernel parts,
    compiled without a CPython wrapper (engine.kernel_parts).
    """
    if not entry:
        options["no_cpython_wrapper"] = True
    options["cache"] = options.get("cache", True) and _ENGINE_CACHE is not None   # (or none)
    options.setdefault("nogil", True)   # a block kernel lets other threads run (sweeps.run)
    if not refcount:
        options["_nrt"] = False

    def decorate(func):
        if entry and "<locals>" in func.__qualname__:
            # a factory's function can be an entry in one scene and a part in another
            # (engine.systems.probed); their machine code must not share a cache entry: a
            # part's has no wrapper for Python to call (module-level ones are made once)
            _rename(func, func.__qualname__ + "__entry")
        uuid = closure_uuid(func)
        if func.__closure__:
            _name_by_uuid(func, uuid)
        if _ENGINE_CACHE is not None:   # (a config reload may have reset it)
            numba.config.CACHE_DIR = _ENGINE_CACHE
        dispatcher = numba.njit(**options)(func)
        if not entry:
            kernel_parts.part(dispatcher)
        if options["cache"]:
            kernel_cache.uncached_elsewhere(dispatcher)
        if uuid is not None:
            try:
                dispatcher._set_uuid(uuid)
                dispatcher._ditherlab_uuid = uuid
            except (AttributeError, AssertionError):  # numba internals changed: a cache miss
                pass
        return dispatcher

    return decorate(fn) if fn is not None else decorate
