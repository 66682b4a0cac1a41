"""Tasks whose worker processes died running them.

A task that raises comes back as a failed block (sweeps.workers.task.compute_block). One that
kills its process does not come back at all: a brought model that reads or writes outside its
arrays (numba checks no bounds) takes the whole worker down with a segmentation fault. dask
gives such a task to another worker, and after ``distributed.scheduler.allowed-failures``
deaths (3 by default) errs it with ``KilledWorker``. But our tasks may run only on the workers
that matched when they were submitted (sweeps.workers.matching.MatchedClient), and a local
cluster's nanny restarts a dead worker under a new address: once every allowed worker had
died, the task waited for them for ever and the sweep hung with its progress bar still
ticking (measured: 0 of 164 points after 5 minutes).

So the dispatch submits an orphaned task again (its allowed workers all gone) on the workers
there now, counting the deaths the scheduler saw while it ran (:func:`died_running`). A task
of several blocks that killed a worker is split into one block a task; a block whose tasks
killed more workers than dask allows is given up as FAILED, in one warning line
(:meth:`Deaths.requeue`), and the rest of the sweep goes on. The error estimate's re-runs
are counted the same way (sweeps.estimates.error_reruns.SampleRuns.rescue).
"""
from __future__ import annotations

import functools
import logging

log = logging.getLogger("ditherlab")


def allowed_failures() -> int:
    """Worker deaths a task may cause before it is given up (dask's own setting)."""
    import dask

    return int(dask.config.get("distributed.scheduler.allowed-failures", 3))


def died_running(client, futures) -> dict | None:
    """Task key -> the worker processes that died while it was on them (the scheduler's
    ``suspicious`` count), asked before an orphaned task is cancelled, while the scheduler
    still knows it; None when the scheduler cannot say."""
    if not futures:
        return {}

    def suspicious(keys, dask_scheduler=None) -> dict:   # (nested: pickled by value, so
        tasks = dask_scheduler.tasks                    # a scheduler without ditherlab
        return {k: tasks[k].suspicious for k in keys if k in tasks}   # runs it too)

    try:
        return client.run_on_scheduler(suspicious, keys=[f.key for f in futures])
    except Exception as exc:  # noqa: BLE001 -- e.g. distributed.scheduler.pickle: False
        log.debug("could not ask the scheduler for worker deaths (%s)", exc)
        return None


def killed_worker(future) -> bool:
    """The task erred because its workers kept dying (dask's ``KilledWorker``); never for a
    thread's ``concurrent.futures.Future`` (no worker processes: no ``status`` either)."""
    if getattr(future, "status", None) != "error":
        return False
    from distributed import KilledWorker

    try:
        return isinstance(future.exception(), KilledWorker)
    except Exception:  # noqa: BLE001 -- cancelled or gone meanwhile
        return False


def crash_line(deaths: int) -> str:
    """Why a block or a re-run was given up, for the warning and the cube."""
    return (f"{deaths} worker processes died computing it (a crash in compiled code, not "
            "an exception: a brought model reading or writing outside its arrays? numba "
            "checks no bounds)")


class Deaths:
    """The worker deaths each block of a run caused, and what to do with a task after some:
    run its blocks one a task, or give a block up. Only for a run of a brought model
    (``counting``): the engine's own kernels do not crash their process, and a worker that
    left for another reason (a batch job's walltime, a preemption: dask counts those too)
    must not fail a block; without ``counting`` an orphan is always queued again, as before."""

    def __init__(self, counting: bool = True):
        self.counting = counting
        self.of_block: dict[int, int] = {}
        self.alone: set[int] = set()         # blocks to run one a task from now on

    @functools.cached_property
    def allowed(self) -> int:
        """dask's allowed-failures, read when first needed: a run on threads (no worker
        processes to die) never imports dask for it (0.12 s of a small sweep's start)."""
        return allowed_failures()

    def requeue(self, blocks: list[int], died: int | None) -> tuple[list[int], list[int]]:
        """A task of ``blocks`` did not finish and ``died`` workers died while it was on
        them (``allowed + 1``: dask gave it up; None: the scheduler cannot say, so the
        blocks go alone from now on and a block orphaned again alone counts 1). Returns
        (blocks to queue again, blocks to give up). Several blocks: each alone from now on,
        its count untouched (the culprit is not known). One block: its deaths add up; past
        ``allowed`` it is given up."""
        if not self.counting:
            return blocks, []
        if died is None:
            died = 1 if len(blocks) == 1 and blocks[0] in self.alone else 0
            self.alone.update(blocks)   # (else an unknown count never grows: the old hang)
        if died <= 0:
            return blocks, []
        if len(blocks) > 1:
            self.alone.update(blocks)
            return blocks, []
        b = blocks[0]
        self.of_block[b] = self.of_block.get(b, 0) + died
        self.alone.add(b)
        if self.of_block[b] > self.allowed:   # (the sink says so: "block b failed: ...")
            return [], [b]
        return blocks, []
