"""Running a plan: blocks of points as dask tasks, a journal of finished blocks, and a
cube rebuilt from the journal and published atomically (DESIGN.md §4).

The submitting process is the only writer, and only while it holds the sweep's lease in
the catalogue (sweeps.service): a second submitter of a running sweep attaches to it
instead of computing. Workers compute and return arrays; they never touch files. Each
finished block is journaled at once (temporary name, fsync,
rename), so a submitter killed at any instant loses at most the blocks in flight; the
cube is republished every few blocks and at the end. A resubmitted spec computes only
the blocks missing from the journal.

The pieces: the worker's task (sweeps.workers.task), the cluster (sweeps.workers.cluster),
the empty cube of a plan (sweeps.run.new_cube), the sink of finished blocks
(sweeps.run.sink), their dispatch (sweeps.run.dispatch), the error estimate
(sweeps.estimates.error_reruns) and how a run ends (sweeps.run.outcome). This module holds
:func:`submit`, which puts them together under the sweep's lease.
"""
from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np

import store
from engine import status as S
from store.catalogue_db import FINAL

from ..workers import task
from ..workers.cluster import EarlyStart
from .new_cube import empty_cube
from .dispatch import run_blocks
from .local import run_blocks_local
from .lease_holder import LEASE_LOST, Lease, wait_while_held
from ..workers.matching import matched
from .outcome import SubmitResult, abort, attached_result, final_result
from ..planning.plan import Plan, work_s
from .quiet import display_of
from ..estimates.error_reruns import (ESTIMATE_FILE, SampleRuns, attach_saved_estimate,
                                      needs_estimate)
from .sink import BlockSink
from ..version import results_fingerprint

log = logging.getLogger("ditherlab")

# A local cluster's start, in seconds of its workers' time: two single-threaded workers
# were up and warm 1.0 s after the submitter asked for them (issue 37, a quiet 2-core AMD
# EPYC, kernel cache warm). A sweep expected to take less per worker runs on threads here.
IN_PROCESS_BELOW_S = 1.0


def blocks_to_run(plan: Plan, cube) -> list[int]:
    """Blocks with a point whose status is not OK: never computed, or failed before
    (DESIGN.md §4: a resubmitted spec computes only the points whose status is not 0).
    A refined sweep's blocks are known level by level: sweeps.run.refined.replay."""
    if plan.spec.refine:
        from .refined import replay

        return replay(plan, cube)
    status = cube["status"].values.ravel()
    return [b for b, index in enumerate(plan.blocks) if np.any(status[index] != S.OK)]


def submit(plan: Plan, store_root: str | Path, *, scheduler: str | None = None,
           workers: int = 2, progress=False, max_blocks: int | None = None,
           client=None, owner: str | None = None, stop=None,
           dashboard: str | None = None) -> SubmitResult:
    """Run every block of ``plan`` not yet finished OK; publish the cube.

    Blocks are computed only under the sweep's lease (sweeps.service): when another live
    process holds it, this call attaches, computes nothing, and returns that run's result
    (taking the lease over if the holder dies first).

    ``max_blocks`` stops after that many new blocks (for tests of partial sweeps).
    ``client`` is a dask client to use instead of starting a cluster (``dashboard``: the
    address of a started LocalCluster's dashboard, see :func:`sweeps.workers.cluster.dask_client`;
    ``workers`` a :class:`sweeps.workers.batch.BatchWorkers` for batch jobs);
    ``owner`` the lease owner tag (default this process's ``host:pid``); ``stop`` a
    ``threading.Event`` that, once set, ends the run after its in-flight blocks and
    re-queues the sweep (serve). ``progress`` is the display the run shows
    (sweeps.run.quiet; ``sweeps.run.phases.shown(True)`` for bars on stderr), False for none.
    """
    progress = display_of(progress)
    t0 = time.perf_counter()
    store.layout.check_store(store_root, write=True)   # read-only, a file: one line, now
    sweep = store.SweepDir(store_root, plan.sweep_id)
    journal = store.Journal(sweep.journal)
    # what earlier runs finished; bad blocks are only skipped until this process holds
    # the sweep (their writer may be replacing them right now)
    cube = store.rebuild(empty_cube(plan), journal, _checked_blocks(plan), repair=False)
    attach_saved_estimate(sweep, cube)
    todo = blocks_to_run(plan, cube)
    catalogue = store.Catalogue(store_root)
    if not todo and store.cube_io.disagreement(sweep.cube, cube) is None \
            and not needs_estimate(plan, sweep, cube):
        return final_result(plan, sweep, catalogue, cube, blocks_run=0, t0=t0, timings={},
                            owner=owner)
    _check_space(plan, sweep, cube, todo)
    sweep.root.mkdir(parents=True, exist_ok=True)
    sweep.write_spec(plan.spec.to_json())
    try:
        earlier = catalogue.get(plan.sweep_id)["name"]
    except LookupError:   # a new sweep
        earlier = plan.spec.name
    catalogue.register(plan.sweep_id, plan.spec.name, plan.spec.to_json(), plan.n_points,
                       len(plan.blocks), sweep.root, results_fingerprint())
    renamed = earlier != plan.spec.name
    if renamed:   # the same spec under another name (a name is not part of a sweep's id)
        log.warning("sweep %s is named %r now, %r before (the same spec under another name); "
                    "both names find it", plan.sweep_id, plan.spec.name, earlier)
    lease, attached = _take_lease(plan, catalogue, owner, stop, progress)
    if lease is None:
        return attached_result(plan, sweep, attached, t0)
    sink, timings = None, {}
    # a local cluster starts (and compiles the kernel) while the cube is prepared below;
    # not for a run that only republishes its cube, nor for a small one (on threads here)
    local = plan.path == "simulate" and client is None and scheduler is None
    client = matched(client)   # blocks go only to workers that run this engine
    if not isinstance(workers, int):   # batch jobs (sweeps.workers.batch): no more than blocks
        workers = workers.for_blocks(len(todo))
    here = in_process(plan, scheduler) or (local and not dashboard and
                                           small(plan, todo, workers))
    early = EarlyStart(workers, dashboard, (task.warm_up, plan.scene, plan.params,
                                            plan.numerics.settings)) \
        if local and not here and (todo or needs_estimate(plan, sweep, cube)) else None
    shown = progress.starting(plan, workers)   # while it starts, drawn by client()
    if early is not None:
        shown()
    try:
        # this process alone writes from here on; the journal may have grown since the
        # rebuild above (another writer finished or died in between): read it again
        cube = store.rebuild(empty_cube(plan), journal, _checked_blocks(plan))
        attach_saved_estimate(sweep, cube)
        todo = blocks_to_run(plan, cube)
        if sweep.cube.exists() or not todo or not here:
            _republish(plan, sweep, cube, renamed)  # a valid cube, equal to the journal
        # (an in-process sweep with work to do and no cube yet, seconds of work, publishes
        # after PUBLISH_EVERY_S and at its end: a first publish was 0.13 s of a 1.7 s
        # averaged 400x400 chart)
        whole = max_blocks is None or len(todo) <= max_blocks
        todo = todo[:max_blocks] if max_blocks is not None else todo
        sink = BlockSink(plan, cube, journal, sweep, lease)
        run = run_blocks_local if here else run_blocks
        if plan.spec.refine:
            from .refined import run
        if todo or needs_estimate(plan, sweep, cube):
            extra, t = {}, time.perf_counter()
            if whole and todo and overlaps_estimate(plan, sweep):
                # the error sample's re-runs among the blocks, longest first (its sample is
                # drawn from the sweep id): no tail of re-runs after the last block
                extra["sample"] = SampleRuns(plan)
            if early is not None:   # its workers are warm: the kernel compiled there
                compiling = progress.compiling()
                client = early.client(sink.should_stop, compiling, starting=shown)
                shown.close()
                compiling.close()
                extra["warm_up"] = False
            waited = time.perf_counter() - t
            if early is None or client is not None:   # else stopped while it started
                run(plan, todo, sink, scheduler=scheduler, workers=workers,
                    progress=progress, timings=timings, client=client, dashboard=dashboard,
                    **extra)
            if early is not None:
                timings["cluster_s"] = waited
        shown.close()
        if sink.stopped != LEASE_LOST:   # else the new holder publishes
            progress.say(plan, "publishing the cube")
            t = time.perf_counter()
            store.publish(cube, sweep.cube)
            timings["publish_s"] = time.perf_counter() - t
    except BaseException as exc:
        shown.close()
        abort(plan, sink, lease, exc, serving=stop is not None)
        if early is not None:
            early.close()
        raise
    try:
        # the final state goes to the catalogue (the result is reported) before the
        # cluster stops: nobody waits for the stop to learn the sweep is done
        result = final_result(plan, sweep, catalogue, cube, blocks_run=sink.blocks_run,
                              t0=t0, timings=timings, lease=lease, stopped=sink.stopped,
                              max_blocks=max_blocks)
    except BaseException:
        if early is not None:
            early.close()
        raise
    if early is not None:   # the result is reported first (the process waits at its exit)
        progress.say(plan, "stopping the local cluster")
        early.close_later()
    log.debug("sweep %s timings: %s", plan.sweep_id,
              ", ".join(f"{k} {v:.2f} s" for k, v in timings.items()) or "-")
    return result


def in_process(plan: Plan, scheduler: str | None) -> bool:
    """The analysis paths cost microseconds a point: they run in this process, not on a
    cluster (sweeps.run.local.run_blocks_local), unless a scheduler is named."""
    return plan.path != "simulate" and scheduler is None


def small(plan: Plan, todo: list[int], workers) -> bool:
    """A simulated sweep whose estimated work (sweeps.planning.plan.work_s: its blocks
    still to compute and the error sample's re-runs), spread over ``workers`` threads,
    is below IN_PROCESS_BELOW_S, the cost of starting a local cluster: it runs on threads
    of this process (sweeps.run.local.run_blocks_local). Not a refined sweep (its later
    levels are unknown) nor batch jobs."""
    if not isinstance(workers, int) or plan.spec.refine:
        return False
    index = np.concatenate([plan.blocks[b] for b in todo]) if todo else np.arange(0)
    work = work_s(plan, index) + sum(SampleRuns(plan).costs)
    return work / max(workers, 1) < IN_PROCESS_BELOW_S


def overlaps_estimate(plan: Plan, sweep) -> bool:
    """An exhaustive simulated sweep without a saved error estimate: its re-runs are
    dispatched with its blocks (a refined sweep gives them to its levels' tails)."""
    return plan.path == "simulate" and not plan.spec.refine and \
        not (sweep.root / ESTIMATE_FILE).exists()


def _checked_blocks(plan: Plan):
    """The blocks the journal is checked against: a refined sweep's are not known before
    its replay (sweeps.run.refined), so only checksums and index ranges are checked."""
    return None if plan.spec.refine else plan.blocks


def _check_space(plan: Plan, sweep, cube, todo: list[int]) -> None:
    """Refuse to start (``store.errors.NoSpaceError``) unless the journal blocks still to
    write and one more copy of the cube fit on the store's disk, counted generously."""
    per_point = sum(v.size for v in cube.data_vars.values()) // cube["status"].size + 1
    need = sum(store.journal.block_bytes(len(plan.blocks[b]), per_point) for b in todo)
    store.errors.ensure_space(sweep.root, need + store.cube_io.cube_bytes(cube))


def _republish(plan: Plan, sweep, cube, renamed: bool = False) -> None:
    """Publish ``cube`` (rebuilt from the journal), saying so when the published cube
    was missing, unreadable or different (a run killed before its last publish, a
    damaged file), but not for the new name alone of a renamed sweep (said already)."""
    cosmetic = (store.attrs.NAME, store.attrs.SPEC) if renamed else ()   # the new name alone
    why = store.cube_io.disagreement(sweep.cube, cube, cosmetic) if sweep.cube.exists() else None
    store.publish(cube, sweep.cube)
    if why:
        log.warning("sweep %s: %s; republished it from the journal", plan.sweep_id, why)


def _take_lease(plan: Plan, catalogue, owner, stop, progress):
    """``(Lease, None)`` once this process holds the sweep, or ``(None, row)`` with the
    final row of the run it attached to."""
    while True:
        lease, row = Lease.take(catalogue, plan.sweep_id, owner, stop)
        if lease is not None:
            return lease, None
        row = wait_while_held(catalogue, plan.sweep_id, progress.attached(plan.sweep_id))
        if row["state"] in FINAL:
            return None, row
        # queued again (a serve stopped) or stalled (the holder died): take it over
        progress.note(f"sweep {plan.sweep_id}: {row['owner'] or 'its runner'} stopped "
                      f"({catalogue.live_state(row)}); taking it over")
