"""The task a dask worker runs: one block of points through the engine.

:func:`compute_block` never raises (a crash of the engine marks its block FAILED) and
returns the block's :class:`store.record.BlockRecord`, arrays only; workers never touch
files (sweeps.run.submit). :func:`warm_up` compiles the
block kernel once per worker. With ``$DITHERLAB_BLOCK_LOG`` set every computed block is
noted in that file (:func:`block_key`), which is how the tests count block computations
across processes.

The tests hold blocks back with hooks of their own (gates), installed from outside: a
module named :data:`HOOKS_MODULE` on ``sys.path`` (tests/hooks/), looked up once per
process. Its source is not part of this code's (sweeps.version: off the computing path);
it is told the kind of computation alone and nothing it returns is used.
"""
from __future__ import annotations

import functools
import importlib.util
import logging
import os
import time

import numpy as np

from engine import params as P
from engine import status as S
from engine.compiling import compile_lock
from store.record import BlockRecord

log = logging.getLogger("ditherlab")

BLOCK_LOG_ENV = "DITHERLAB_BLOCK_LOG"   # diagnostics: a file every computed block is noted in
HOOKS_MODULE = "ditherlab_test_hooks"   # the tests' hooks (module docstring), where importable


def compute_block(scene, points: np.ndarray, p: np.ndarray, settings,
                  index: np.ndarray | None = None, sizes=None,
                  kind: str = "block") -> BlockRecord:
    """Integrate one block; never raises (a crash of the engine marks the block FAILED).
    ``index``: the points' flat cube indices, carried into the record (default: their
    positions in ``points``); ``sizes``: the points of each of the plan's blocks that
    ``points`` holds one after another (a dask task may compute several:
    sweeps.planning.plan.blocks_per_task; default one block), each told to the tests'
    hook (``kind``: ``"block"``, or ``"rerun"`` for the error estimate's re-runs; module
    docstring) and noted in the block log once. The record's ``fingerprint`` is the results fingerprint of
    the process that computed it (the submitter journals a block only under its own:
    sweeps.run.sink).

    With ``$DITHERLAB_BLOCK_LOG`` set (inherited by local dask workers), appends one line
    per block to that file: pid and :func:`block_key` (how the tests count block
    computations across processes).
    """
    from engine.blocks import run_block

    if scene not in _COMPILED:   # the first block of a scene in this process
        warm_up(scene, p, settings)
    starts = np.cumsum([0, *(sizes or [len(points)])])
    for a, b in zip(starts[:-1], starts[1:]):   # per block
        if (hook := _test_hook()) is not None:   # tests hold blocks back (module docstring)
            hook(kind)
        if os.environ.get(BLOCK_LOG_ENV):
            _note_block(os.environ[BLOCK_LOG_ENV], block_key(scene, points[a:b], settings))
    index = np.arange(len(points)) if index is None else index
    try:
        res = (watched if scene.digests else run_block)(scene, points, p, settings)
    except Exception as exc:  # noqa: BLE001 -- one bad block must not end the sweep
        from engine.contract import ModelError   # (a brought model's fault: its own line)

        why = str(exc) if isinstance(exc, ModelError) else f"{type(exc).__name__}: {exc}"
        return BlockRecord.failed(index, output_shapes(scene.outputs), why,
                                  S.FAILED, fingerprint=_fingerprint())
    return BlockRecord(index, res.status, res.cost_s, res.steps, res.evals, res.outputs,
                       fingerprint=_fingerprint())


LEAVE_WITHIN_S = 30.0   # a worker with a hung model's thread has left by then (else it exits)


def watched(scene, points: np.ndarray, p: np.ndarray, settings):
    """``engine.blocks.run_block`` for a brought model (``scene.digests``), given up after
    ``$DITHERLAB_BLOCK_TIMEOUT_S`` seconds (default 600: a task is seconds). Compiled
    code cannot be interrupted, and a model that loops for ever at some points (the spec's
    first-step check ran another point) kept its worker busy for ever and the sweep's
    progress still (found by a review; nothing else ended it). It runs in a thread of its
    own here; past the limit this raises :class:`engine.user_code.ModelError` (the block is
    FAILED in one warning line, the sweep goes on), and a dask worker leaves
    (:func:`_leave_when_idle`), so that its nanny starts a fresh one in place of the core
    the loop holds."""
    import threading

    from engine.blocks import run_block
    from engine.user_code import BLOCK_TIMEOUT_ENV, ModelError, block_timeout_s

    limit, box = block_timeout_s(), {}

    def run() -> None:
        try:
            box["result"] = run_block(scene, points, p, settings)
        except BaseException as exc:  # noqa: BLE001 -- raised again in the task's thread
            box["error"] = exc

    thread = threading.Thread(target=run, daemon=True, name="ditherlab-model-block")
    thread.start()
    thread.join(limit)
    if thread.is_alive():
        _leave_when_idle()
        raise ModelError(f"no result after {limit:g} s -- an endless loop in the model's "
                         "kernels at these points, or a stiff model spending its step budget "
                         f"(integrator = \"rodas4\")? ({BLOCK_TIMEOUT_ENV} sets how long "
                         "to wait)")
    if "error" in box:
        raise box["error"]
    return box["result"]


def _leave_when_idle() -> None:
    """In a dask worker (not a submitter computing on threads): start no other task, and
    once the results this worker holds are taken, leave (dask's graceful close, whose nanny
    starts a fresh worker); at the latest :data:`LEAVE_WITHIN_S` from now, exit.

    It ended itself 5 s after a hung block instead, whatever it held. The next task it had
    started by then died with it and counted as a crash; the results not yet taken (the
    error estimate's re-runs) were computed again, and a re-run that hung again ended the
    next worker. A 6-point sweep whose law loops at 2 points, with a 10 s limit, ended
    after 85 s (35 s now), its 2 blocks given up as "4 worker processes died computing it"
    instead of "no result after 10 s" (tests/e2e/test_crashing_model.py)."""
    import threading

    try:
        from distributed import get_worker
        worker = get_worker()
    except (ImportError, ValueError):
        return
    log.info("a brought model's block hung: this worker leaves once its results are taken")
    worker.loop.add_callback(_leave, worker)   # (before this task's result is handled)
    timer = threading.Timer(LEAVE_WITHIN_S, os._exit, args=(3,))   # (the loop stays)
    timer.daemon = True
    timer.start()


_HELD = ("executing", "long-running", "memory")   # a task this worker runs, or its result


async def _leave(worker) -> None:
    """:func:`_leave_when_idle` on the worker's event loop: paused, the worker starts no
    other task (one started now would die with this process and count as a crash); this
    task ends, and the scheduler forgets its result once the submitter has taken it; then
    retire (what is left moves to another worker, a queued task goes back, not counted as
    a death) and close."""
    import asyncio

    from distributed.core import Status

    if worker.status != Status.running:   # (closing already)
        return
    worker.memory_manager.memory_pause_fraction = False   # (its monitor unpaused, each 1 s)
    worker.status = Status.paused
    while any(ts.state in _HELD for ts in worker.state.tasks.values()):
        await asyncio.sleep(0.1)
    await worker.close_gracefully(restart=True, reason="ditherlab: a brought model hung")


@functools.cache
def _test_hook():
    """The tests' ``before_block(kind)`` (:data:`HOOKS_MODULE`), or None where no test
    put it on ``sys.path`` (every run of users)."""
    if importlib.util.find_spec(HOOKS_MODULE) is None:
        return None
    return importlib.import_module(HOOKS_MODULE).before_block


def output_shapes(outputs) -> dict[str, tuple]:
    """Each output's per-point shape: ``(N_HIST,)`` for the alpha_hist histogram, else ()."""
    from engine.observables import N_HIST

    return {name: (N_HIST,) if name == "alpha_hist" else () for name in outputs}


def identity(models: tuple = ()) -> dict:
    """What a worker runs: its results fingerprint and ditherlab version, computed from
    the modules this process imports (run on each worker as it joins: sweeps.workers.matching),
    and for the models a sweep brings by import path (``models``), the source digest of the
    copy this process would import (None: it has none)."""
    from ..version import __version__

    out = {"fingerprint": _fingerprint(), "version": __version__}
    if models:
        from engine import registry
        out["models"] = {ref: registry.source_digest(ref) for ref in models}
    return out


def _fingerprint() -> str:
    from ..version import results_fingerprint

    return results_fingerprint()


def block_key(scene, points: np.ndarray, settings) -> str:
    """A short hash of one block computation: its points, scene and numerics (the key
    ``$DITHERLAB_BLOCK_LOG`` lines carry; the error estimate's finer re-runs differ)."""
    import hashlib

    h = hashlib.sha1(np.ascontiguousarray(points, np.float64).tobytes())
    h.update(repr((scene, settings)).encode())
    return h.hexdigest()[:16]


def _note_block(path: str, key: str) -> None:
    line = f"{os.getpid()} {key}\n".encode()
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, line)   # one short O_APPEND write: lines of processes never interleave
    finally:
        os.close(fd)


def warm_up(scene, p: np.ndarray, settings) -> float:
    """Compile the block kernel of ``scene`` in this process; returns seconds. Once per
    machine: the first process to need a scene compiles it into the kernel cache
    (engine.jit) holding that scene's lock file there, and the others, waiting for the
    lock, load it from the cache instead of compiling it again (engine.compiling.compile_lock);
    once it is there, warm-ups load it side by side, not one after another.
    Calls the engine directly, not compute_block: no ``$DITHERLAB_BLOCK_LOG`` line."""
    from engine.blocks import run_block

    t0 = time.perf_counter()
    q = p.copy()
    q[P.T_END] = min(q[P.T_END], 1e-3)
    q[P.T_TRANSIENT] = 0.0
    # a brought model's kernel is compiled on no point at all: its code may crash the
    # process at a point the spec-load check did not try (sweeps.workers.deaths)
    point = np.empty((0, 4)) if scene.digests and settings.device != "cuda" else \
        np.array([[0.1, 1000.0, 0.1, 0.1]])
    try:   # (a failed warm-up leaves nothing ready: the next one takes the lock alone)
        with compile_lock(scene, ready=f"warm-up {settings!r}"):
            run_block(scene, point, q, settings)
    except Exception as exc:  # noqa: BLE001 -- the sweep's own blocks report it
        log.debug("warm-up failed: %s", exc)
    _COMPILED.add(scene)
    return time.perf_counter() - t0


_COMPILED: set = set()   # scenes whose kernel this process has (compiled or loaded)
