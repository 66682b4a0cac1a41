"""Computing a run's blocks on threads of this process (:func:`run_blocks_local`): the
analysis paths, which cost microseconds per point, a simulated sweep whose estimated
work is below the cost of starting a cluster (sweeps.run.submit.small), and a sweep on
this machine's GPU (a launch a thread; the error estimate's re-runs, CPU work, on threads
of their own). The engine's kernels release the GIL, so the threads compute side by side;
the same task, journal, checks and order as on a cluster (sweeps.run.dispatch)."""
from __future__ import annotations

import threading
import time
from contextlib import contextmanager

from ..workers import task
from ..workers.cluster import NOTICE_AFTER_S
from ..workers.threads import ThreadClient
from ..planning.plan import Plan, work_s
from . import interrupt
from .dispatch import TICK_S, finish_estimate, points_bar, show_reruns
from .order import longest_first, rerun_first
from .sink import BlockSink

# Blocks of a GPU sweep launched at a time, at least (engine.gpu.run: a stream each; more
# when more workers are asked for): a launch lasts as long as its slowest warp, and the
# launches beside it can fill the SMs it leaves idle (not yet measured on a GPU)
GPU_LAUNCHES = 4


def run_blocks_local(plan: Plan, todo: list[int], sink: BlockSink, compute, *, progress,
                     sample=None, warm_up: bool = True) -> None:
    """Compute ``todo`` on threads of this process, as many as ``compute`` asks for
    (:attr:`sweeps.workers.compute.Compute.threads`, at least GPU_LAUNCHES for a sweep on
    the GPU; it opens no cluster): the analysis paths
    (they cost microseconds per point), and a simulated sweep whose estimated work is
    below the cost of starting a cluster (sweeps.run.submit.small). The same task, journal
    and checks as on a cluster, the same longest-first order, the error sample's re-runs
    (``sample``) among the blocks (on a GPU sweep beside them, on threads of their own:
    :func:`_rerun_pool`); the kernel is compiled once first (``warm_up``). Times go to
    ``sink.timings``."""
    gpu = plan.numerics.settings.device == "cuda"
    with ThreadClient(max(compute.threads, GPU_LAUNCHES if gpu else 1)) as pool, \
            _rerun_pool(pool, compute.threads, gpu) as reruns_on:
        if plan.path == "simulate" and warm_up:
            t = time.perf_counter()
            if not _warm_up_here(plan, sink, progress):
                return
            sink.timings["warm_up_s"] = time.perf_counter() - t
        bar = points_bar(plan, todo, progress)   # its clock starts with the points
        t = time.perf_counter()
        sink.started()
        _dispatch_local(pool, plan, todo, sink, bar, sample, reruns_on)
        sink.timings["compute_s"] = time.perf_counter() - t
        bar.close()
        if plan.path == "simulate":
            finish_estimate(plan, reruns_on, todo, sink, sample, progress)


@contextmanager
def _rerun_pool(pool: ThreadClient, threads: int, gpu: bool):
    """Where the error sample's re-runs go: ``pool`` itself, or, for a sweep on the GPU,
    ``threads`` CPU threads of their own. The re-runs run on the CPU whatever the sweep's
    device (sweeps.estimates.error_estimate.finer_numerics), and the GPU's launches hold
    every thread of ``pool`` while they wait on the device, so in ``pool`` a re-run waited
    for a launch to end: on an H200 a 1,000 x 1,000 map's 12 re-runs had not started 125 s
    into its launches (docs/GPU.md)."""
    if not gpu:
        yield pool
        return
    with ThreadClient(threads, name="ditherlab-rerun") as own:
        yield own


def _warm_up_here(plan: Plan, sink: BlockSink, progress) -> bool:
    """Compile the kernel in this process, on a daemon thread (a Ctrl-C or a cancel during
    a first compilation, which cannot be interrupted, leaves it behind instead of waiting
    for it), saying so after NOTICE_AFTER_S (the display's ``compiling``); False if
    ``sink.should_stop()`` turned true meanwhile."""
    thread = threading.Thread(target=task.warm_up, daemon=True, name="ditherlab-compile",
                              args=(plan.scene, plan.params, plan.numerics.settings))
    thread.start()
    t0, compiling = time.monotonic(), progress.compiling()
    try:
        while thread.is_alive():
            thread.join(0.1)
            interrupt.check()
            if thread.is_alive() and sink.should_stop():
                return False
            if time.monotonic() - t0 > NOTICE_AFTER_S:
                compiling()
    finally:
        compiling.close()
    return True


def _dispatch_local(pool, plan: Plan, todo: list[int], sink: BlockSink, bar,
                    sample=None, reruns_on=None) -> None:
    """:func:`_dispatch` on threads: one task per thread (plus one) in flight, longest
    expected first, the re-runs among the blocks; each finished block journaled. Re-runs
    on a pool of their own (``reruns_on``, :func:`_rerun_pool`) are all submitted first
    and take no place among the blocks."""
    apart = reruns_on is not None and reruns_on is not pool
    if apart and sample is not None and not sink.should_stop():
        while sample.submit_next(reruns_on):
            pass
    cost_of = {b: work_s(plan, plan.blocks[b]) for b in todo}
    queue = list(reversed(longest_first(todo, cost_of)))
    inflight: dict = {}   # future -> block
    window = pool.threads + 1
    while True:
        interrupt.check()
        stopping = sink.should_stop()
        reruns = sample.pending() if sample is not None and not apart else []
        while not stopping and len(inflight) + len(reruns) < window:
            if not apart and rerun_first(sample, queue, cost_of):
                sample.submit_next(pool)
                reruns.append(None)
                continue
            if not queue:
                break
            b = queue.pop()
            inflight[pool.submit(task.compute_block, plan.scene, plan.block_points(b),
                                 plan.params, plan.numerics.settings, plan.blocks[b])] = b
        if not inflight and (stopping or not queue):
            show_reruns(bar, sample)   # (the estimate counts on from what is shown)
            break
        running = sample.pending() if sample is not None else []
        done = pool.wait_any([*inflight, *running], TICK_S * 5)
        failed = _collect(plan, [f for f in done if f in inflight], inflight, sink, bar)
        if failed is not None:   # (compute_block never raises: a crash of this process's
            # machinery) what the other threads finish is kept, as a serial run kept the
            # blocks before the crash; then the error goes up
            for f in list(inflight):
                f.cancel()   # not started yet
            _collect(plan, [f for f in inflight if not f.cancelled()], inflight, sink, bar)
            raise failed
        show_reruns(bar, sample)
        bar.keep_alive()


def _collect(plan: Plan, futures, inflight: dict, sink: BlockSink, bar):
    """Journal the blocks of finished ``futures`` (waiting for them), each in its own
    file (few blocks here, and a block's file is what a repair sets aside); the first
    exception a future raised, or None."""
    failed = None
    for f in futures:
        b = inflight.pop(f)
        try:
            record = f.result()
        except Exception as exc:  # noqa: BLE001 -- raised by the caller, once
            failed = failed or exc
            continue
        sink(b, record)
        bar.update(len(plan.blocks[b]))
    return failed
