"""Computing a run's blocks: on a dask cluster, one block per worker thread (plus one) in
flight, after compiling the kernel on every worker (:func:`run_blocks`); or, for the
analysis paths, which cost microseconds per point, in this process (:func:`run_blocks_local`).
Finished blocks go to a :class:`sweeps.run.sink.BlockSink`, which also says when to stop."""
from __future__ import annotations

import threading
import time
from contextlib import nullcontext

from ..workers import task
from ..workers.cluster import dask_client
from ..planning.plan import Plan
from ..estimates.error_reruns import complete, estimate_into, needs_estimate
from .sink import BlockSink


def run_blocks(plan: Plan, todo: list[int], sink: BlockSink, *, scheduler, workers,
               progress, timings, client=None, dashboard=None, filler=None,
               warm_up: bool = True) -> None:
    """Compute ``todo`` on the cluster. ``filler`` (e.g. a refined sweep's error sample,
    sweeps.estimates.error_reruns.SampleRuns) gives tasks to run where a worker would otherwise
    idle: once no block is left to submit, while fewer tasks than threads are running.
    ``warm_up=False`` skips compiling the kernel on the workers (done by an earlier call on
    the same client: ``client.run`` would wait for the filler tasks still running)."""
    bar = _progress_bar(plan, todo, progress)
    t = time.perf_counter()
    with (nullcontext(client) if client is not None
          else dask_client(scheduler, workers, dashboard)) as cluster_client:
        client = cluster_client
        timings["cluster_s"] = time.perf_counter() - t
        t = time.perf_counter()
        warm = _warm_up_workers(client, plan, sink) if warm_up else not sink.should_stop()
        timings["warm_up_s"] = time.perf_counter() - t
        t = time.perf_counter()
        if warm:
            sink.started()
            _dispatch(client, plan, todo, sink, bar, filler)
        timings["compute_s"] = time.perf_counter() - t
        if needs_estimate(plan, sink.sweep, sink.cube) or \
                (todo and plan.path == "simulate" and complete(sink.cube)):
            estimate_into(plan, client, sink.cube, sink.sweep, timings)
    bar.close()


def _warm_up_workers(client, plan: Plan, sink: BlockSink) -> bool:
    """Compile the kernel on every worker (``warm_up``), asking ``sink.should_stop()`` while
    it runs (a first compilation can take a minute on a busy machine). False if stopped."""
    outcome: dict = {}

    def run() -> None:
        try:
            client.run(task.warm_up, plan.scene, plan.params, plan.numerics.settings)
        except BaseException as exc:  # noqa: BLE001 -- handed to the calling thread
            outcome["error"] = exc

    thread = threading.Thread(target=run, daemon=True, name="ditherlab-warm-up")
    thread.start()
    while thread.is_alive():
        thread.join(0.25)
        if thread.is_alive() and sink.should_stop():
            return False
    if "error" in outcome:
        raise outcome["error"]
    return True


def _dispatch(client, plan: Plan, todo: list[int], sink: BlockSink, bar,
              filler=None) -> None:
    """Keep one block per worker thread (plus one) in flight, the next submitted as one
    finishes; once ``sink.should_stop()``, submit no more and collect those in flight (a
    stop loses no finished work and waits for at most one block per worker)."""
    from distributed import as_completed

    queue = list(reversed(todo))
    inflight: dict = {}
    done = as_completed(loop=client.loop)
    window, window_at = 1, -1e9

    def fill() -> None:
        nonlocal window, window_at
        if time.monotonic() - window_at > 5.0:   # workers may join or leave
            window = max(1, sum(client.nthreads().values())) + 1
            window_at = time.monotonic()
        while queue and len(inflight) < window:
            b = queue.pop()
            future = client.submit(task.compute_block, plan.scene, plan.block_points(b),
                                   plan.params, plan.numerics.settings, plan.blocks[b],
                                   pure=False)
            inflight[future] = b
            done.add(future)
        while filler is not None and not queue and \
                len(inflight) + filler.running() < window - 1 and filler.submit_next(client):
            pass

    if not sink.should_stop():
        fill()
    for future in done:
        b = inflight.pop(future)
        sink(b, future.result())
        bar.update(len(plan.blocks[b]))
        if not sink.should_stop():
            fill()


def run_blocks_local(plan: Plan, todo: list[int], sink: BlockSink, *, scheduler, workers,
                     progress, timings, client=None, dashboard=None) -> None:
    """The analysis paths cost microseconds per point: starting a cluster would cost
    more than the whole sweep, so they run in this process."""
    bar = _progress_bar(plan, todo, progress)
    t = time.perf_counter()
    sink.started()
    for b in todo:
        if sink.should_stop():
            break
        sink(b, task.compute_block(plan.scene, plan.block_points(b), plan.params,
                                   plan.numerics.settings, plan.blocks[b]))
        bar.update(len(plan.blocks[b]))
    timings["compute_s"] = time.perf_counter() - t
    bar.close()


def _progress_bar(plan: Plan, todo: list[int], enabled: bool):
    """Progress in points (blocks are small and cost-balanced: sweeps.planning.plan), with tqdm's
    rate and ETA."""
    from tqdm import tqdm

    return tqdm(total=sum(len(plan.blocks[b]) for b in todo), unit="point",
                desc=f"{plan.spec.name} [{plan.sweep_id}]", disable=not enabled,
                mininterval=0.5)
