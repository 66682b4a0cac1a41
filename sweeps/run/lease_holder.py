"""A runner's hold on one sweep (:class:`Lease`): the heartbeat thread, progress counts
written to the catalogue, and the question asked between blocks, whether to stop
(cancelled, serve shutting down, lease taken over). The lease itself, one row's ``owner``
and ``heartbeat`` changed in SQLite transactions, is :mod:`store.lease` (sweeps.service)."""
from __future__ import annotations

import logging
import threading
import time

from store.catalogue import Catalogue
from store.lease import HEARTBEAT_S, owner_tag

log = logging.getLogger("ditherlab")

ATTACH_POLL_S = 0.5        # a submitter waiting for another's run reads the catalogue this often
PROGRESS_EVERY_S = 0.5     # a runner writes its counts to the catalogue at most this often
CANCEL_POLL_S = 0.25       # ... and asks whether it was cancelled at most this often

# why a run stopped before its last block
CANCELLED, SHUTDOWN, LEASE_LOST = "cancelled", "shutdown", "lease lost"


class Lease:
    """A held lease on one sweep: heartbeat thread, progress, and the stop question.

    Create it with :meth:`take` (foreground submit) or, when the row is already ``running``
    under ``owner`` (serve's claim), :meth:`take` as well: the same owner may re-take it.
    """

    def __init__(self, catalogue: Catalogue, sweep_id: str, owner: str,
                 stop: threading.Event | None = None):
        self.catalogue, self.sweep_id, self.owner = catalogue, sweep_id, owner
        self.shutdown = stop or threading.Event()   # set by serve's signal handler
        self.lost = threading.Event()               # a beat found the lease taken over
        self.counts: dict = {}
        self._last_progress = 0.0
        self._last_cancel_poll = 0.0
        self._cancelled = False
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._beat_loop, daemon=True,
                                        name=f"ditherlab-lease-{sweep_id}")

    @classmethod
    def take(cls, catalogue: Catalogue, sweep_id: str, owner: str | None = None,
             stop: threading.Event | None = None) -> tuple[Lease | None, dict]:
        """``(Lease, row)`` when this process now holds the sweep, else ``(None, row)``
        with the row of the live holder."""
        owner = owner or owner_tag()
        got, row = catalogue.acquire(sweep_id, owner)
        if not got:
            return None, row
        lease = cls(catalogue, sweep_id, owner, stop)
        lease._thread.start()
        return lease, row

    def _beat_loop(self) -> None:
        while not self._done.wait(HEARTBEAT_S):
            try:
                if not self.catalogue.beat(self.sweep_id, self.owner):
                    self.lost.set()
                    return
            except Exception as err:  # noqa: BLE001 -- a busy catalogue: try again next beat
                log.warning("heartbeat of sweep %s failed: %s", self.sweep_id, err)

    def due(self) -> bool:
        """True when the next :meth:`progress` would be written (PROGRESS_EVERY_S)."""
        return time.monotonic() - self._last_progress >= PROGRESS_EVERY_S

    def progress(self, force: bool = False, **counts) -> None:
        """Record counts (``done_points``, ``failed_points``, ``done_blocks``,
        ``run_started``, ``run_start_blocks``); written at most every PROGRESS_EVERY_S."""
        self.counts.update(counts)
        now = time.monotonic()
        if force or now - self._last_progress >= PROGRESS_EVERY_S:
            self._last_progress = now
            if not self.catalogue.beat(self.sweep_id, self.owner, **self.counts):
                self.lost.set()

    def stop_reason(self) -> str | None:
        """Why the runner should submit no more blocks, or None to go on."""
        if self.lost.is_set():
            return LEASE_LOST
        if self._cancelled:
            return CANCELLED
        now = time.monotonic()
        if now - self._last_cancel_poll >= CANCEL_POLL_S:
            self._last_cancel_poll = now
            if not self.catalogue.holds(self.sweep_id, self.owner):   # taken over
                self.lost.set()
                return LEASE_LOST
            self._cancelled = self.catalogue.cancel_requested(self.sweep_id)
            if self._cancelled:
                return CANCELLED
        if self.shutdown.is_set():
            return SHUTDOWN
        return None

    def close(self) -> None:
        """Stop the heartbeat (the row's state is set by :meth:`end`)."""
        self._done.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=HEARTBEAT_S + 1)

    def end(self, state: str, message: str = "", **counts) -> bool:
        """Give the lease back with the final ``state`` (``queued`` puts the sweep back in
        the queue). False if the lease had been taken over (the row is left alone)."""
        self.close()
        counts = {k: v for k, v in {**self.counts, **counts}.items()
                  if k in ("done_points", "failed_points", "done_blocks")}
        if state == "queued":
            return self.catalogue.requeue(self.sweep_id, self.owner, message, **counts)
        changed, _ = self.catalogue.finish(self.sweep_id, state, owner=self.owner,
                                           message=message, **counts)
        return changed


def wait_while_held(catalogue: Catalogue, sweep_id: str, show=None,
                    poll_s: float = ATTACH_POLL_S) -> dict:
    """Wait while another live process runs the sweep (a second submitter attaches: it
    computes nothing), calling ``show(row)`` on every poll (its display's, sweeps.run.quiet);
    returns the row once nobody holds the lease (final, queued or stalled), with
    ``attached_to``: the owner it waited for."""
    row = catalogue.get(sweep_id)
    holder = row["owner"]
    while row["state"] == "running" and Catalogue.alive(row):
        if show is not None:
            show(row)
        time.sleep(poll_s)
        row = catalogue.get(sweep_id)
    return {**row, "attached_to": holder}
