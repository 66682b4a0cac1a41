"""Where finished blocks go in the submitting process (:class:`BlockSink`): the journal
first (durable), then the in-memory cube, republished every few seconds, and progress to
the catalogue under the sweep's lease; and the counts of a cube's points and blocks."""
from __future__ import annotations

import logging
import time

import numpy as np

import store
from engine import status as S
from store.record import BlockRecord

from .lease_holder import LEASE_LOST
from ..planning.plan import Plan
from ..version import results_fingerprint

PUBLISH_EVERY_S = 5.0     # republish the cube at most this often while running ...
PUBLISH_SHARE = 0.03      # ... and spend at most this share of the run's time on it: the
                          # submitter shares the machine with the workers (a 961-point Fig. 14
                          # cube takes 0.35 s to write: every ~12 s, not every 5 s)

log = logging.getLogger("ditherlab")


class BlockSink:
    """Receives finished blocks in the submitting process: journal first (durable), then
    the in-memory cube, republished atomically every PUBLISH_EVERY_S seconds (longer when
    a publish is slow: PUBLISH_SHARE); progress
    (journaled blocks, points) goes to the catalogue under the lease. Between blocks the
    dispatch loop asks :meth:`should_stop` (cancel, serve shutdown, lease lost)."""

    def __init__(self, plan: Plan, cube, journal, sweep, lease):
        self.plan, self.cube, self.journal = plan, cube, journal
        self.sweep, self.lease = sweep, lease
        self.last_publish, self.publish_s = time.monotonic(), 0.0
        self.done = set(done_blocks(plan, cube))    # blocks with every point computed
        self.blocks_run = 0
        self._unfilled: list[tuple[int, BlockRecord]] = []   # journaled, not yet in the cube
        self._before = None   # the journal's last group before theirs
        self.fingerprint = results_fingerprint()     # what every journaled block must carry
        self.foreign_blocks = 0                      # blocks refused for another engine
        self.stopped: str | None = None              # lease_holder.CANCELLED, SHUTDOWN, ...
        self.timings: dict[str, float] = {}          # phase -> seconds (SubmitResult.timings)
        self._report(force=True)

    def __call__(self, b: int, record: BlockRecord) -> None:
        self.many([(b, record)])

    def many(self, items: list[tuple[int, BlockRecord]]) -> None:
        """Finished blocks ``(b, record)``, as many as the dispatch found ready: journaled
        as one group file (one fsync for them all: store.journal_groups; a file per block
        cost 2.8 ms of CPU and two fsyncs a block, scripts/bench_scale.py), then into the
        cube, then one progress report and at most one publish."""
        ours = [(b, r) for b, r in items if self._ours(b, r)]
        self._before = self.journal.last_group()   # (set first: settle() reads both)
        self._unfilled = ours   # until they are in the cube: settle() after an interrupt
        if ours:
            self.journal.write_group(ours)
        self._fill(ours)
        self._unfilled = []
        self.blocks_run += len(ours)
        since = time.monotonic() - self.last_publish
        if since > max(PUBLISH_EVERY_S, self.publish_s / PUBLISH_SHARE) and \
                self.stopped != LEASE_LOST:
            t = time.monotonic()
            store.publish(self.cube, self.sweep.cube)
            self.last_publish = time.monotonic()
            self.publish_s = self.last_publish - t
        self._report()

    def _fill(self, items: list[tuple[int, BlockRecord]]) -> None:
        for b, record in items:
            store.fill(self.cube, record)
            self.done.add(b)

    def settle(self) -> None:
        """After an interrupt inside :meth:`many` (a Ctrl-C between the journal's write and
        the cube): the blocks that reached the journal go into the cube and the count too,
        so the cube published and the catalogue's ``done_blocks`` agree with the journal
        (before, a Ctrl-C there recorded one block fewer than was kept)."""
        group = self.journal.last_group()   # this call's group, if it got that far ...
        if self._unfilled and group not in (None, self._before) and group.exists():
            self._fill(self._unfilled)   # ... and its rename was reached
        self._unfilled = []

    def _ours(self, b: int, record: BlockRecord) -> bool:
        """The block's engine is this sweep's: the last line of defence
        (sweeps.workers.matching)."""
        if record.fingerprint != self.fingerprint:
            self.foreign_blocks += 1
            log.warning("block %d came back from another engine (results fingerprint %s, "
                        "this sweep's %s): not journaled; its points stay to compute",
                        b, record.fingerprint, self.fingerprint)
            return False
        if record.error:
            log.warning("block %d failed: %s", b, record.error)
        return True

    def _report(self, force: bool = False, **extra) -> None:
        if force or self.lease.due():
            if self.plan.spec.refine:   # its blocks are known level by level
                extra["n_blocks"] = len(self.plan.blocks)
            self.lease.progress(force=True, done_blocks=len(self.done), **point_counts(self.cube),
                                **extra)

    def started(self) -> None:
        """Blocks begin to flow now (cluster up, kernels warm): the origin of the ETA."""
        self._report(force=True, run_started=time.time(), run_start_blocks=len(self.done))

    def should_stop(self) -> bool:
        """True when no further block should be submitted (the reason in ``stopped``)."""
        if self.stopped is None:
            self.stopped = self.lease.stop_reason()
            if self.stopped is not None:
                log.warning("sweep %s: stopping after the blocks in flight (%s)",
                            self.plan.sweep_id, self.stopped)
        return self.stopped is not None


def done_blocks(plan: Plan, cube) -> list[int]:
    status = cube["status"].values.ravel()
    return [b for b, index in enumerate(plan.blocks) if np.all(status[index] != S.NOT_COMPUTED)]


def point_counts(cube) -> dict:
    status = cube["status"].values
    n_ok = int((status == S.OK).sum())
    n_missing = int((status == S.NOT_COMPUTED).sum())
    n_failed = int(status.size - n_ok - n_missing)
    return {"done_points": n_ok + n_failed, "failed_points": n_failed}
