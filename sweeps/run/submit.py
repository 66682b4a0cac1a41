"""Running a plan: blocks of points as dask tasks, a journal of finished blocks, and a
cube rebuilt from the journal and published atomically (DESIGN.md §4).

The submitting process is the only writer, and only while it holds the sweep's lease in the
catalogue (sweeps.service): a second submitter of a running sweep attaches to it instead of
computing. Workers compute and return arrays; they never touch files. Each finished block
is journaled at once (temporary name, fsync, rename), so a submitter killed at any instant
loses at most the blocks in flight; the cube is republished every few blocks and at the
end. A resubmitted spec computes only the blocks missing from the journal.

The pieces: where blocks are computed (sweeps.workers.compute.Compute), the worker's task
(sweeps.workers.task), what a run starts from (sweeps.run.preparation), the empty cube of a
plan (sweeps.run.new_cube), the sink of finished blocks (sweeps.run.sink), their dispatch
(sweeps.run.dispatch, .local, .head_start), the error estimate (sweeps.estimates.error_reruns)
and how a run ends (sweeps.run.outcome). :func:`submit` puts them together in named steps
(:class:`Submission`).
"""
from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np

import store

from ..workers import task
from ..workers.compute import LOCAL, SCHEDULER, Compute
from .new_cube import empty_cube
from .dispatch import run_blocks
from .head_start import head_start
from .local import run_blocks_local
from .lease_holder import LEASE_LOST
from .outcome import SubmitResult, abort, attached_result, final_result
from .preparation import (blocks_to_run, blocks_unjournaled, check_space, checked_blocks,
                          held_elsewhere, overlaps_estimate, republish, take_lease)
from ..planning.plan import Plan, work_s
from .quiet import display_of
from ..estimates.error_reruns import SampleRuns, attach_saved_estimate, needs_estimate
from .sink import BlockSink
from ..version import results_fingerprint

log = logging.getLogger("ditherlab")

# A local cluster's start, in seconds of its workers' time: two workers were up and warm
# 1.0 s after the submitter asked (issue 37, a quiet 2-core AMD EPYC, kernel cache warm).
IN_PROCESS_BELOW_S = 1.0


def submit(plan: Plan, store_root: str | Path, compute: Compute | None = None, *,
           progress=False, max_blocks: int | None = None, owner: str | None = None,
           stop=None) -> SubmitResult:
    """Run every block of ``plan`` not yet finished OK on ``compute`` (a
    :class:`sweeps.workers.compute.Compute`; default: a local cluster of 2 workers, or
    threads of this process for a small sweep); publish the cube.

    Blocks are computed only under the sweep's lease (sweeps.service): when another live
    process holds it, this call attaches, computes nothing, and returns that run's result
    (taking the lease over if the holder dies first).

    ``progress`` is the display the run shows (sweeps.run.quiet; ``phases.shown(True)``
    for bars on stderr), False for none; ``max_blocks`` stops after that many new blocks.
    ``owner`` the lease owner tag (default this process's ``host:pid``); ``stop`` a
    ``threading.Event`` that, once set, ends the run after its in-flight blocks and
    re-queues the sweep (serve). A cluster this call starts, it stops (after the result
    is reported); one already open (serve's) stays open.
    """
    compute = compute or Compute()
    if plan.numerics.settings.device == "cuda":   # refused before the store is touched
        compute.check_gpu()
    return Submission(plan, store_root, compute, progress=progress, owner=owner,
                      stop=stop).run(max_blocks)


class Submission:
    """One :func:`submit`, in named steps: :meth:`read` what earlier runs finished,
    :meth:`register` the sweep, :meth:`take_lease`, :meth:`prepare` the cube under it,
    :meth:`compute_blocks` (:meth:`connect` to the cluster first), :meth:`publish`,
    :meth:`finish`. A cluster to be started starts before the store is read, for the
    blocks without a journal file (:meth:`start_early`). ``timings`` (phase -> seconds)
    goes to ``SubmitResult.timings``."""

    def __init__(self, plan: Plan, store_root, compute: Compute, *, progress,
                 owner: str | None, stop):
        self.t0 = time.perf_counter()
        store.layout.check_store(store_root, write=True)   # read-only, a file: one line, now
        self.plan, self.compute = plan, compute
        self.progress, self.owner, self.stop = display_of(progress), owner, stop
        self.sweep = store.SweepDir(store_root, plan.sweep_id)
        self.journal = store.Journal(self.sweep.journal)
        self.catalogue = store.Catalogue(store_root)
        self.opened = False        # this call started the cluster: it stops it
        self.here = False          # the blocks run on threads of this process
        self.sink = self.lease = None
        self.todo: list[int] = []
        self.whole = self.renamed = False
        self.timings: dict[str, float] = {}
        self.shown = self.progress.starting(plan, compute.workers)   # drawn while it starts

    def run(self, max_blocks: int | None) -> SubmitResult:
        try:
            unjournaled = blocks_unjournaled(self.plan, self.journal)
            if unjournaled != [] and not held_elsewhere(self.catalogue, self.sweep,
                                                        self.plan.sweep_id, self.owner):
                self.start_early(unjournaled)   # (all journaled: after the read)
            cube = self.read()
            if self.complete(cube):
                return self.result(cube, blocks_run=0)
            self.register(cube)
            attached = self.take_lease()
            if attached is not None:
                self.close_compute(later=True)
                return attached_result(self.plan, self.sweep, attached, self.t0)
            self.here = self.runs_here(self.todo)
            if needs_estimate(self.plan, self.sweep, cube) or self.todo:
                self.start_early(self.todo)   # (unless started above)
            self.prepare(max_blocks)
            self.compute_blocks()
            self.publish()
        except BaseException as exc:
            if self.lease is not None:   # (before it, nothing of the run is this call's)
                abort(self.plan, self.sink, self.lease, exc, serving=self.stop is not None)
            self.close_compute()
            raise
        return self.finish(max_blocks)

    def runs_here(self, todo: list[int]) -> bool:
        """On threads of this process: a sweep on this machine's GPU, the analysis paths
        unless a scheduler is named, and a simulated sweep priced below a local cluster's
        start (not when the cluster is open already, serve's, nor with a dashboard); not a
        brought model on our local cluster's CPUs (a crash costs a worker: workers.deaths)."""
        c = self.compute
        if self.plan.numerics.settings.device == "cuda":   # else a cluster's GPU workers
            return c.kind == LOCAL
        return not (self.plan.scene.digests and c.kind == LOCAL) and (
            (self.plan.path != "simulate" and c.kind != SCHEDULER) or
            (c.kind == LOCAL and not c.dashboard and not c.is_open and
             small(self.plan, todo, c.threads)))

    def start_early(self, todo: list[int] | None) -> None:
        """Start the cluster of our own a simulated run of ``todo`` (None: not known yet, a
        refined sweep's first level) will need, and compile its kernel there, on a thread
        while this process reads the store and prepares the cube (issue 37;
        sweeps.workers.cluster.EarlyStart); nothing if it runs on threads here, if the
        cluster is open (serve's) or not ours (a scheduler, a client)."""
        c = self.compute
        if self.plan.path != "simulate" or not c.starts_cluster or c.is_open or \
                self.runs_here(todo):
            return
        warm = (task.warm_up, self.plan.scene, self.plan.params, self.plan.numerics.settings)
        c.start_early(None if todo is None else len(todo), warm)
        self.opened = True
        self.shown()

    def read(self):
        """The cube of what earlier runs finished, rebuilt from the journal, and the blocks
        still to run (``todo``); bad blocks are only skipped until this process holds the
        sweep (their writer may be replacing them right now)."""
        cube = store.rebuild(empty_cube(self.plan), self.journal, checked_blocks(self.plan),
                             repair=False)
        attach_saved_estimate(self.sweep, cube)
        self.todo = blocks_to_run(self.plan, cube)
        return cube

    def complete(self, cube) -> bool:
        """Nothing to compute, the published cube equal to the journal's, the estimate
        made: the call returns at once."""
        return not self.todo and store.cube_io.disagreement(self.sweep.cube, cube) is None \
            and not needs_estimate(self.plan, self.sweep, cube)

    def register(self, cube) -> None:
        """Refuse a run that would not fit on disk; write the spec and the catalogue row."""
        plan, catalogue = self.plan, self.catalogue
        check_space(plan, self.sweep, cube, self.todo)
        self.sweep.root.mkdir(parents=True, exist_ok=True)
        self.sweep.write_spec(plan.spec.to_json())
        try:
            earlier = catalogue.get(plan.sweep_id)["name"]
        except LookupError:   # a new sweep
            earlier = plan.spec.name
        catalogue.register(plan.sweep_id, plan.spec.name, plan.spec.to_json(), plan.n_points,
                           len(plan.blocks), self.sweep.root, results_fingerprint())
        self.renamed = earlier != plan.spec.name
        if self.renamed:   # the same spec under another name (a name is not in its id)
            log.warning("sweep %s is named %r now, %r before (the same spec under another "
                        "name); both names find it", plan.sweep_id, plan.spec.name, earlier)

    def take_lease(self):
        """None once this process holds the sweep (``self.lease``), or the final row of the
        run it attached to."""
        self.lease, attached = take_lease(self.plan, self.catalogue, self.owner, self.stop,
                                           self.progress)
        return attached

    def prepare(self, max_blocks: int | None) -> None:
        """This process alone writes from here on; the journal may have grown since
        :meth:`read` (another writer finished or died in between): read it again, publish
        a valid cube equal to the journal, and make the sink of finished blocks."""
        plan, sweep = self.plan, self.sweep
        cube = store.rebuild(empty_cube(plan), self.journal, checked_blocks(plan))
        attach_saved_estimate(sweep, cube)
        todo = blocks_to_run(plan, cube)
        if sweep.cube.exists() or not todo or not self.here:
            republish(plan, sweep, cube, self.renamed)
        # (an in-process sweep with work to do and no cube yet, seconds of work, publishes
        # after PUBLISH_EVERY_S and at its end: a first publish was 0.13 s of a 1.7 s
        # averaged 400x400 chart)
        self.whole = max_blocks is None or len(todo) <= max_blocks
        self.todo = todo[:max_blocks] if max_blocks is not None else todo
        self.sink = BlockSink(plan, cube, self.journal, sweep, self.lease)
        self.sink.timings = self.timings

    def compute_blocks(self) -> None:
        """Run the blocks (and the error estimate's re-runs, among them when the run is
        whole) on threads here or on the cluster."""
        plan, sink = self.plan, self.sink
        if not (self.todo or needs_estimate(plan, self.sweep, sink.cube)):
            return
        extra = {}
        if self.whole and self.todo and overlaps_estimate(plan, self.sweep):
            # the error sample's re-runs among the blocks (known from the sweep id): no tail
            extra["sample"] = SampleRuns(plan)
        warm = not self.compute.early   # an early start's workers are warm
        if not self.here and not self.connect():
            return   # stopped while the cluster started
        self.shown.close()
        blocks = run_blocks_local if self.here else run_blocks
        if plan.spec.refine:
            from .refined import run

            run(plan, self.todo, sink, self.compute, blocks=blocks, progress=self.progress,
                warm_up=warm)
        else:
            blocks(plan, self.todo, sink, self.compute, progress=self.progress,
                   warm_up=warm, **extra)

    def connect(self) -> bool:
        """The cluster's client: an early start's once warm (meanwhile blocks run here:
        sweeps.run.head_start), or made now (``cluster_s`` the wait); False if stopped."""
        t, c = time.perf_counter(), self.compute
        if c.early:
            self.todo = head_start(self.plan, self.todo, self.sink, c, self.shown)
            t = time.perf_counter()   # (cluster_s: the wait for the cluster alone)
            compiling = self.progress.compiling()
            client = c.wait(self.sink.should_stop, compiling, starting=self.shown)
            compiling.close()
        else:
            self.opened = not c.is_open
            client = c.open(len(self.todo))
        self.timings["cluster_s"] = time.perf_counter() - t
        return client is not None

    def publish(self) -> None:
        self.shown.close()
        if self.sink.stopped != LEASE_LOST:   # else the new holder publishes
            self.progress.say(self.plan, "publishing the cube")
            t = time.perf_counter()
            store.publish(self.sink.cube, self.sweep.cube)
            self.timings["publish_s"] = time.perf_counter() - t

    def finish(self, max_blocks: int | None) -> SubmitResult:
        """The final state in the catalogue (the result is reported) before the cluster
        stops: nobody waits for the stop to learn the sweep is done."""
        try:
            result = self.result(self.sink.cube, blocks_run=self.sink.blocks_run, lease=self.lease,
                                 stopped=self.sink.stopped, max_blocks=max_blocks)
        except BaseException as exc:   # (else a Ctrl-C here left the row running: stalled)
            abort(self.plan, self.sink, self.lease, exc, serving=self.stop is not None,
                  publish=False)   # (published just before)
            self.close_compute()
            raise
        if self.opened and self.compute.early:
            self.progress.say(self.plan, "stopping the local cluster")
        self.close_compute(later=True)   # (the process waits for it at its exit)
        log.debug("sweep %s timings: %s", self.plan.sweep_id,
                  ", ".join(f"{k} {v:.2f} s" for k, v in self.timings.items()) or "-")
        return result

    def result(self, cube, **kw) -> SubmitResult:
        return final_result(self.plan, self.sweep, self.catalogue, cube, t0=self.t0,
                            timings=self.timings, owner=self.owner, **kw)

    def close_compute(self, later: bool = False) -> None:
        """Stop the cluster this call started (``later``: on a thread, EarlyStart)."""
        self.shown.close()
        if self.opened:
            self.opened = False
            self.compute.close_later() if later else self.compute.close()


def small(plan: Plan, todo: list[int], threads: int) -> bool:
    """A simulated sweep whose estimated work (sweeps.planning.plan.work_s: blocks, the error
    sample's re-runs) over ``threads`` is below IN_PROCESS_BELOW_S, a local cluster's start:
    it runs on threads here (sweeps.run.local); not a refined sweep (its levels unknown)."""
    if plan.spec.refine:
        return False
    index = np.concatenate([plan.blocks[b] for b in todo]) if todo else np.arange(0)
    work = work_s(plan, index) + sum(SampleRuns(plan).costs)
    return work / max(threads, 1) < IN_PROCESS_BELOW_S
