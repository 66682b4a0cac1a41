"""One compile of a scene per machine: the lock file that the processes needing a scene's
kernels take in turn (:func:`compile_lock`), and a compile for a call's argument types
under it (:func:`compile_once`)."""
from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import threading
from pathlib import Path

import numba

from .jit import cache_dir
from .registries import load_numba_registries

_HELD = threading.local()   # the scenes whose compile lock this thread holds


@contextlib.contextmanager
def compile_lock(scene, ready: str | None = None):
    """Held while this process compiles or loads ``scene``'s kernels: an exclusive ``flock``
    on ``<kernel cache>/compiling/<scene hash>.lock``, so that the processes of one machine
    (dask workers, pytest workers, two commands at once) compile a scene once, not once
    each: the others wait, then load it from the cache. Re-entrant in a thread (a sweep's
    warm-up holds it around :func:`engine.blocks.run_block`, which takes it too); released
    by the kernel when a holder dies; without a writable cache folder, no lock (each
    process compiles).

    ``ready`` names what the holder makes (a sweep's warm-up and its settings). The first
    holder of that name to finish leaves a file saying so (``<scene hash>-<ready hash>.ready``),
    and from then on holders of the name share the lock: they only load from the cache, all
    at once. Taken in turn, 16 workers loading a kernel of 0.06 s waited ~1 s for the last
    (issue 37). A holder that waits for a compile in progress waits sharing, and shares once
    it is ready. Should the cache have lost what the file promises, each sharing holder
    compiles it: redundant work, never a wrong kernel."""
    import fcntl

    name = hashlib.sha1(repr(scene).encode()).hexdigest()[:16]
    held = _HELD.__dict__.setdefault("names", set())
    if name in held:
        yield
        return
    try:
        folder = cache_dir() / "compiling"
        folder.mkdir(parents=True, exist_ok=True)
        fd = os.open(folder / f"{name}.lock", os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:
        yield
        return
    done = None if ready is None else \
        folder / f"{name}-{hashlib.sha1((ready + _target()).encode()).hexdigest()[:16]}.ready"
    try:
        shared = _take(fd, done)
        held.add(name)
        yield
        if done is not None and not shared:   # (not after an exception: nothing is ready)
            with contextlib.suppress(OSError):
                done.touch()
    finally:
        held.discard(name)
        os.close(fd)   # releases the lock


@functools.cache
def _target() -> str:
    """numba's version and the machine code's target (CPU name and features: numba's cache
    index keys its entries by them), so that a cache folder shared by machines of other
    CPUs, or kept across a numba upgrade, promises nothing it has not got: there a holder
    compiles alone, as the first did."""
    from numba.core.registry import cpu_target

    return f"{numba.__version__} {cpu_target.target_context.codegen().magic_tuple()}"


def _take(fd: int, done: Path | None) -> bool:
    """Lock ``fd`` for :func:`compile_lock`: shared (returns True) once ``done`` exists,
    else exclusive (False). Waiting for another process's compile, it waits sharing."""
    import fcntl

    if done is None:
        fcntl.flock(fd, fcntl.LOCK_EX)
        return False
    if not done.exists():
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pass   # compiled by another process now: wait for it below, sharing
        else:
            if not done.exists():
                return False
    fcntl.flock(fd, fcntl.LOCK_SH)   # (from exclusive: converted)
    if done.exists():
        return True
    fcntl.flock(fd, fcntl.LOCK_EX)   # the compiling holder failed: compile it here
    return False


def compile_once(dispatcher, args: tuple, scene) -> None:
    """Compile ``dispatcher`` for the types of ``args`` (or load it from the disk cache)
    under ``scene``'s :func:`compile_lock`, unless this process has it already; the call
    that follows runs outside the lock."""
    sig = tuple(dispatcher.typeof_pyval(a) for a in args)
    if sig in dispatcher.overloads:
        return
    load_numba_registries()
    with compile_lock(scene):
        dispatcher.compile(sig)
