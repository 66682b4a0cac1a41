"""Computing a run's blocks: on a dask cluster, two tasks per worker thread in flight (one
per thread plus one for a brought model: sweeps.run.order.DEPTH), after compiling the kernel
on every worker (:func:`run_blocks`), a task being one block, or several once the workers
would ask the submitter for more tasks a second than it hands out
(sweeps.planning.plan.blocks_per_task), fewer towards the end (sweeps.run.order); or on
threads of this process (sweeps.run.local). Either way the longest expected task starts
first, the error estimate's re-runs among the blocks. Finished blocks go to a
:class:`sweeps.run.sink.BlockSink`, which also says when to stop."""
from __future__ import annotations

import threading
import time

import numpy as np

from engine import status as S
from store.record import BlockRecord

from ..workers import task
from ..workers.deaths import Deaths, crash_line, died_running, killed_worker
from ..workers.matching import ForeignWorkersError, NoGPUWorkersError, matched
from ..version import results_fingerprint
from ..planning.plan import Plan, blocks_per_task, work_s
from ..estimates.error_reruns import complete, estimate_into, needs_estimate
from . import interrupt
from .sink import BlockSink
from .order import (DEPTH, longest_first, outstanding, rerun_first, rerun_group_s,
                    reruns_left, tail_cap_s)

REFRESH_S = 2.0    # how often the dispatch looks at the workers again
TICK_S = 0.02      # how often the threads' dispatch looks for finished blocks (x 5)
WAKE_S = 0.25      # the longest the dask dispatch sleeps (a finished task wakes it at once)


def run_blocks(plan: Plan, todo: list[int], sink: BlockSink, compute, *, progress,
               filler=None, warm_up: bool = True, sample=None) -> None:
    """Compute ``todo`` on the open cluster of ``compute`` (a
    :class:`sweeps.workers.compute.Compute`; batch jobs scaled to the blocks). ``sample``
    (sweeps.estimates.error_reruns.SampleRuns): the error estimate's re-runs, dispatched
    among the blocks, longest expected first, and gathered once the blocks are done.
    ``filler`` (a refined sweep's error sample) gives tasks to run where a worker would
    otherwise idle: once no block is left to submit, while fewer tasks than threads are
    running. ``warm_up=False`` skips compiling the kernel on the workers (done by an
    earlier call on the same client, or by the early start: ``client.run`` would wait for
    the filler tasks still running). Times go to ``sink.timings``."""
    bar = points_bar(plan, todo, progress)
    client = matched(compute.client, [ref for ref, _ in plan.scene.digests],
                     gpu=plan.numerics.settings.device == "cuda")
    if todo:   # batch jobs for these blocks: serve waits without any, a refined level may end some
        compute.start(len(todo))
    t = time.perf_counter()
    warm = _warm_up_workers(client, plan, sink) if warm_up else not sink.should_stop()
    if warm_up:
        sink.timings["warm_up_s"] = time.perf_counter() - t
    t = time.perf_counter()
    if warm:
        sink.started()
        _dispatch(client, plan, todo, sink, bar, filler, sample, compute)
    sink.timings["compute_s"] = time.perf_counter() - t
    bar.close()   # the points are done: say so before the next phase
    finish_estimate(plan, client, todo, sink, sample, progress)


def finish_estimate(plan: Plan, client, todo, sink: BlockSink, sample, progress) -> None:
    """The error estimate once the points are done (its re-runs ``sample``, if given,
    already dispatched among the blocks); a stopped run's re-runs are cancelled. Made
    again when this run computed blocks: ``todo`` here, or before the cluster was up
    (``sink.blocks_run``: sweeps.run.head_start may have taken them all)."""
    ran = bool(todo) or sink.blocks_run > 0
    if sink.stopped is None and (needs_estimate(plan, sink.sweep, sink.cube) or
                                 (ran and plan.path == "simulate" and complete(sink.cube))):
        estimate_into(plan, client, sink.cube, sink.sweep, sink.timings, started=sample,
                      display=progress.display(plan))
    elif sample is not None:
        sample.cancel(client)


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
        interrupt.check()
        if thread.is_alive() and sink.should_stop():
            return False
    if "error" in outcome:
        raise outcome["error"]
    return True


def _dispatch(client, plan: Plan, todo: list[int], sink: BlockSink, bar,
              filler=None, sample=None, compute=None) -> None:
    """Keep DEPTH tasks per matching worker thread in flight (one per thread plus one for a
    brought model), the next submitted as one finishes; once ``sink.should_stop()``,
    submit no more and collect those in flight (a stop loses no finished work, computes no
    block twice, and waits for at most DEPTH tasks per thread). A task
    computes ``blocks_per_task`` blocks (by the mean block's measured seconds: one until
    blocks are back), fewer towards the end (:func:`tail_cap_s`), journaled as blocks.
    Blocks go longest expected first, and the error sample's re-runs (``sample``) among
    them by the same expected cost (:func:`longest_first`); the dispatch ends once they
    are back too (:func:`reruns_left`).

    Every REFRESH_S the workers are looked at again (``client`` is a
    :class:`sweeps.workers.matching.MatchedClient`): joiners are checked, a block whose allowed
    workers have all gone is submitted again, and a batch cluster's idle jobs end once
    fewer blocks are left than workers (``compute.shrink``: the run's
    :class:`sweeps.workers.compute.Compute`)."""
    from distributed import as_completed

    cost_of = {b: work_s(plan, plan.blocks[b]) for b in todo}
    queue = list(reversed(longest_first(todo, cost_of)))   # popped from the end
    queued = [sum(cost_of.values())]   # the queue's expected seconds (tail_cap_s)
    inflight: dict = {}        # future -> (its blocks, the workers it may run on)
    cost = [0.0, 0, 0.0]       # seconds computed, blocks back, their expected seconds
    done = as_completed(loop=client.loop, with_results=True)   # results fetched in dask's
    # event loop as each block finishes: one f.result() per block costs a round trip to that
    # loop (23 ms per block with the machine loaded; scripts/bench_scale.py)
    good: dict[str, int] = {}
    looked = -1e9
    deaths = Deaths(counting=bool(plan.scene.digests))   # workers a brought model killed

    def fill() -> None:
        threads, groups = sum(good.values()), []
        window = threads + 1 if deaths.counting else threads * DEPTH
        reruns = sample.running() if sample is not None else 0
        while good and len(inflight) + len(groups) + reruns < window:
            cap = tail_cap_s(queued[0] + (sample.left_s() if sample is not None else 0.0),
                             threads, cost)
            if rerun_first(sample, queue, cost_of):
                sample.submit_next(client, min(rerun_group_s(cost), cap))
                done.update([sample.last_task])   # its end wakes the loop too
                reruns += 1
                continue
            if not queue:
                break
            k = blocks_per_task(threads, cost[0] / max(cost[1], 1), len(queue))
            group = [queue.pop()]   # (a block whose task killed a worker goes alone)
            group_s = cost_of[group[0]]
            while len(group) < k and queue and not {group[0], queue[-1]} & deaths.alone \
                    and group_s + cost_of[queue[-1]] <= cap:
                group.append(queue.pop())
                group_s += cost_of[group[-1]]
            queued[0] -= group_s
            groups.append(group)
        if groups:   # one message to the scheduler for them all: a submit each costs
            # 3.3x the submitter's CPU (5.4 against 1.7 ms a task; scripts/bench_scale.py)
            allowed, n = list(good), len(groups)
            futures = client.map(task.compute_block, [plan.scene] * n,
                                 [np.concatenate([plan.block_points(b) for b in group])
                                  for group in groups],
                                 [plan.params] * n, [plan.numerics.settings] * n,
                                 [np.concatenate([plan.blocks[b] for b in group])
                                  for group in groups],
                                 [[len(plan.blocks[b]) for b in group] for group in groups],
                                 pure=False, workers=allowed)
            inflight.update((f, (group, frozenset(allowed))) for f, group in zip(futures, groups))
            done.update(futures)
        while filler is not None and good and not queue and \
                len(inflight) + filler.running() < threads and filler.submit_next(client):
            done.update([filler.last_task])

    while True:
        interrupt.check()   # a Ctrl-C that a dask callback swallowed (sweeps.run.interrupt)
        if time.monotonic() - looked > REFRESH_S:   # workers may join or leave
            try:
                good, looked = client.check.matching(), time.monotonic()
            except (ForeignWorkersError, NoGPUWorkersError):
                if inflight or queue:
                    raise
                break   # only re-runs were left: the estimate's gather says why, a warning
            n_queued = len(queue)
            given_up = _resubmit_orphans(client, inflight, good, queue, deaths)
            if len(queue) != n_queued:   # (orphans put back)
                queued[0] = sum(cost_of[b] for b in queue)
            for runs in filter(None, (sample, filler)):   # (the error sample's re-runs:
                runs.harvest()                           # those not in ``done`` taken too)
                if good:
                    done.update(runs.rescue(client, good))
            if given_up:
                _give_up(plan, given_up, deaths, sink, bar)
            if compute is not None:   # the re-runs still to come need workers too
                compute.shrink(len(queue) + len(inflight) + outstanding(sample, filler))
        stopping = sink.should_stop()
        if not stopping:
            fill()
        if not inflight and (stopping or not queue and not reruns_left(sample)):
            show_reruns(bar, sample)   # (the estimate counts on from what is shown)
            break
        show_reruns(bar, sample)
        if not done.has_ready():
            bar.keep_alive()
            sleep_until_one(done, WAKE_S)
            continue
        finished, given_up = [], []
        for f, result in done.next_batch(block=False):
            if f not in inflight:   # a re-run's result, held (or: cancelled, submitted again)
                for runs in filter(None, (sample, filler)):
                    runs.take(f, result)
                continue
            group = inflight.pop(f)[0]
            if deaths.counting and killed_worker(f):   # dask gave up: workers kept dying
                again, lost = deaths.requeue(group, deaths.allowed + 1)
                queue.extend(again)
                queued[0] += sum(cost_of[b] for b in again)
                given_up += lost
                continue
            result = f.result() if f.status == "error" else result   # an error raises
            finished += split_result(result, group, [len(plan.blocks[b]) for b in group])
            if not result.error:   # (a failed block's cost_s is zeros: not a price)
                cost[0] += float(np.sum(result.cost_s))
                cost[1] += len(group)
                cost[2] += sum(cost_of[b] for b in group)
        f = result = None   # (no future held here: a worker that hung waits for its release)
        if finished:   # (not: only re-runs ended, which the estimate gathers)
            sink.many(finished)   # journaled as one group
            bar.update(sum(len(plan.blocks[b]) for b, _ in finished))
        if given_up:
            _give_up(plan, given_up, deaths, sink, bar)


def _give_up(plan: Plan, blocks: list[int], deaths: Deaths, sink: BlockSink, bar) -> None:
    """Journal ``blocks``, which kept killing their workers, as FAILED (sweeps.workers.deaths)."""
    shapes = task.output_shapes(plan.scene.outputs)
    sink.many([(b, BlockRecord.failed(plan.blocks[b], shapes, crash_line(deaths.of_block[b]),
                                      S.FAILED, fingerprint=results_fingerprint()))
               for b in blocks])
    bar.update(sum(len(plan.blocks[b]) for b in blocks))


def sleep_until_one(done, timeout: float) -> None:
    """Sleep until a task of ``done`` (dask's ``as_completed``) finishes, or ``timeout``
    seconds: its thread condition is notified as each result arrives, so the next task
    is submitted at once, and the submitter, which shares the workers' cores on a local
    cluster, does not wake 50 times a second to poll."""
    condition = getattr(done, "thread_condition", None)   # (public, not documented:
    if condition is None:                                 # a dask without it, a 20 ms poll)
        time.sleep(TICK_S)
        return
    with condition:
        if not done.has_ready():
            condition.wait(timeout)


def show_reruns(bar, sample) -> None:
    """The re-runs finished so far, beside the points (``error estimate k/N``); the
    error estimate's own bar goes on from the last count shown (``sample.shown``)."""
    if sample is not None and (k := sample.finished()) != sample.shown:
        sample.shown = k
        bar.set_postfix_str(f"error estimate {k}/{len(sample.order)}")


def split_result(record, group: list[int], sizes: list[int]) -> list[tuple[int, object]]:
    """One task's record (the points of the blocks ``group``, ``sizes`` points each, one
    after another) as ``(block, record)`` per block."""
    return list(zip(group, record.split(sizes))) if len(group) > 1 else [(group[0], record)]


def _resubmit_orphans(client, inflight: dict, good: dict, queue: list,
                      deaths: Deaths) -> list[int]:
    """Blocks restricted to workers that have all gone (batch jobs ended, or workers that
    died running them and came back under new addresses) wait for ever in dask: cancel
    them and put them first in the queue, counting the deaths (``deaths``). Returns the
    blocks given up (sweeps.workers.deaths)."""
    orphans = [f for f, (_, allowed) in inflight.items()
               if not f.done() and not allowed & good.keys()]
    died = died_running(client, orphans) if deaths.counting else {}
    given_up = []
    for future in orphans:
        blocks = inflight.pop(future)[0]
        client.cancel(future)
        again, lost = deaths.requeue(blocks, None if died is None else died.get(future.key, 0))
        queue.extend(again)
        given_up += lost
    return given_up


def points_bar(plan: Plan, todo: list[int], progress):
    """Progress in points (blocks are small and cost-balanced: sweeps.planning.plan), with tqdm's
    rate and ETA."""
    return progress.bar(plan, "points", sum(len(plan.blocks[b]) for b in todo), "point")
