"""Leases and heartbeats: one writer per sweep (store.catalogue).

A process computes a sweep's blocks only while it holds the sweep's lease, taken in one
``BEGIN IMMEDIATE`` transaction by :meth:`LeaseMixin.acquire` (or
:meth:`LeaseMixin.claim_next` for ``serve``), kept alive by :meth:`LeaseMixin.beat` and given
back by :meth:`LeaseMixin.finish`. A holder that died cannot give it back: a ``running`` row
reads ``stalled`` (:meth:`LeaseMixin.live_state`) when its owner (``host:pid``) is a
process of this host that no longer exists, or its heartbeat is older than ``STALE_S``
seconds. The ``servers`` table lists running ``ditherlab serve`` processes.

:class:`LeaseMixin` holds these methods of :class:`store.catalogue.Catalogue`; it uses the
catalogue's ``_connection()`` and ``_query()``.
"""
from __future__ import annotations

import json
import os
import socket
import time
from contextlib import contextmanager

from .catalogue_db import FINAL, STATES, check_count, utc_now

STALLED = "stalled"   # derived, never stored: running, but its submitter is gone
HEARTBEAT_S = 5.0     # a lease holder (and serve) beats this often
STALE_S = float(os.environ.get("DITHERLAB_STALE_S") or 60.0)   # silent longer: gone


def owner_tag() -> str:
    """``host:pid`` of this process, for the ``owner`` of a running sweep."""
    return f"{socket.gethostname()}:{os.getpid()}"


def _owner_alive(owner: str) -> bool:
    """False only when ``owner`` is a process of this host that no longer exists."""
    host, _, pid = owner.rpartition(":")
    if host != socket.gethostname() or not pid.isdigit():
        return True
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except PermissionError:       # exists, someone else's
        return True
    try:                          # Linux: a killed child its parent has not reaped yet
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rpartition(")")[2].split()[0] != "Z"
    except (OSError, IndexError):
        return True


def queued_device(spec_json: str) -> str:
    """The device a queued sweep's spec asks for (``cpu`` without the key). A spec that
    does not parse reads ``cpu``: a serve claims it, and its planning fails the row with
    the reason, as before devices were told apart (never a serve stopped by one bad row)."""
    try:
        spec = json.loads(spec_json)
    except ValueError:
        return "cpu"
    return str(spec.get("device", "cpu")) if isinstance(spec, dict) else "cpu"


class LeaseMixin:
    """The lease and ``serve`` methods of :class:`store.catalogue.Catalogue`."""

    @staticmethod
    def alive(row: dict, now: float | None = None) -> bool:
        """True while the row's ``owner`` holds a live lease: its process exists (when on
        this host) and its heartbeat, if it ever beat, is younger than ``STALE_S``."""
        owner = row.get("owner") or ""
        if not owner or not _owner_alive(owner):
            return False
        beat = float(row.get("heartbeat") or 0.0)
        return not beat or (time.time() if now is None else now) - beat <= STALE_S

    @classmethod
    def live_state(cls, row: dict) -> str:
        """The row's state, except ``stalled`` for a ``running`` row whose owner is gone
        (see :meth:`alive`)."""
        if row["state"] == "running" and row.get("owner") and not cls.alive(row):
            return STALLED
        return row["state"]

    # --- the lease: one writer per sweep, every state change in one transaction ------

    @contextmanager
    def _transaction(self):
        """``BEGIN IMMEDIATE`` ... ``COMMIT`` on this object's connection: the write lock
        is taken before the first read, so a read-decide-write cannot interleave with
        another process's."""
        with self._connection() as con:
            try:
                # (inside the try: a Ctrl-C raised as BEGIN returns -- it may wait up to the
                # busy timeout -- left the shared connection in a transaction, and every
                # later one, the run's final state included, failed)
                con.execute("BEGIN IMMEDIATE")
                yield con
                con.execute("COMMIT")   # (a failed COMMIT, e.g. disk full, rolls back too)
            except BaseException:
                if con.in_transaction:
                    con.execute("ROLLBACK")
                raise

    @staticmethod
    def _row(con, sweep_id: str) -> dict:
        row = con.execute("SELECT * FROM sweeps WHERE sweep_id = ?", (sweep_id,)).fetchone()
        if row is None:
            raise LookupError(f"no sweep with id {sweep_id!r}; register it first")
        return dict(row)

    def _set(self, con, sweep_id: str, **fields) -> None:
        fields["updated"] = utc_now(self.clock)
        assignments = ", ".join(f"{k} = :{k}" for k in fields)
        con.execute(f"UPDATE sweeps SET {assignments} WHERE sweep_id = :_id",
                    {**fields, "_id": sweep_id})

    def _take(self, con, sweep_id: str, owner: str, row: dict) -> dict:
        now = time.time()
        self._set(con, sweep_id, state="running", owner=owner, heartbeat=now,
                  cancel_requested=0, message="", run_started=0.0,
                  run_start_blocks=row["done_blocks"])
        return self._row(con, sweep_id)

    def acquire(self, sweep_id: str, owner: str | None = None) -> tuple[bool, dict]:
        """Take the lease of a registered sweep: ``(True, row)`` with the row now
        ``running`` under ``owner`` (default: this process), or ``(False, row)`` when
        another owner holds it alive. A stalled holder's lease is taken over."""
        owner = owner or owner_tag()
        with self._transaction() as con:
            row = self._row(con, sweep_id)
            if row["state"] == "running" and row["owner"] != owner and self.alive(row):
                return False, row
            return True, self._take(con, sweep_id, owner, row)

    def claim_next(self, owner: str | None = None,
                   devices: tuple[str, ...] | None = None) -> dict | None:
        """For ``serve``: the oldest ``queued`` sweep, now ``running`` under ``owner``;
        ``None`` when the queue is empty. Two servers never claim the same sweep.
        ``devices``: only sweeps whose spec's ``device`` is one of them (a serve without a
        GPU leaves the GPU's sweeps queued for one that has it)."""
        owner = owner or owner_tag()
        with self._transaction() as con:
            queued = con.execute("SELECT * FROM sweeps WHERE state = 'queued' "
                                 "ORDER BY queued_at, created, sweep_id").fetchall()
            row = next((r for r in queued if devices is None
                        or queued_device(r["spec_json"]) in devices), None)
            return None if row is None else self._take(con, row["sweep_id"], owner, dict(row))

    def beat(self, sweep_id: str, owner: str | None = None, **counts) -> bool:
        """The lease holder's heartbeat, with progress counts if given (``done_points``,
        ``failed_points``, ``done_blocks``, ``n_blocks`` (a refined sweep's grow level by
        level), ``run_started``, ``run_start_blocks``).
        False when ``owner`` no longer holds the lease: it must stop computing."""
        unknown = sorted(set(counts) - {"done_points", "failed_points", "done_blocks",
                                        "n_blocks", "run_started", "run_start_blocks"})
        if unknown:
            raise ValueError(f"Catalogue.beat: unknown field(s) {unknown}")
        fields = {"heartbeat": time.time(), **counts}
        assignments = ", ".join(f"{k} = :{k}" for k in fields)
        with self._connection() as con:
            cur = con.execute(
                f"UPDATE sweeps SET {assignments} WHERE sweep_id = :_id AND owner = :_owner "
                "AND state = 'running'",
                {**fields, "_id": sweep_id, "_owner": owner or owner_tag()})
        return cur.rowcount == 1

    def cancel_requested(self, sweep_id: str) -> bool:
        """True once ``ditherlab cancel`` asked the running sweep to stop."""
        rows = self._query("SELECT cancel_requested FROM sweeps WHERE sweep_id = ?", (sweep_id,))
        return bool(rows and rows[0]["cancel_requested"])

    def holds(self, sweep_id: str, owner: str | None = None) -> bool:
        """True while ``owner`` (default: this process) holds the sweep's lease."""
        rows = self._query("SELECT state, owner FROM sweeps WHERE sweep_id = ?", (sweep_id,))
        return bool(rows) and rows[0]["state"] == "running" and \
            rows[0]["owner"] == (owner or owner_tag())

    def finish(self, sweep_id: str, state: str, *, owner: str | None = None, message: str = "",
               **counts) -> tuple[bool, dict]:
        """End a run: set ``state`` (not ``running``), ``message`` and counts, and give the
        lease back. With ``owner``: only if that owner still holds the lease. Without:
        only if no live owner holds it (a submitter that found nothing to compute).
        Returns ``(changed, row)``."""
        if state not in STATES or state == "running":
            raise ValueError(f"Catalogue.finish: state must be one of {STATES[:1] + FINAL}, "
                             f"got {state!r}")
        counts = {k: check_count(k, v) for k, v in counts.items()
                  if k in ("done_points", "failed_points", "done_blocks")}
        with self._transaction() as con:
            row = self._row(con, sweep_id)
            held = row["state"] == "running" and bool(row["owner"])
            if owner is not None and (not held or row["owner"] != owner):
                return False, row
            if owner is None and held and self.alive(row):
                return False, row
            self._set(con, sweep_id, state=state, owner="", message=str(message),
                      cancel_requested=0, **counts)
            return True, self._row(con, sweep_id)

    def enqueue(self, sweep_id: str) -> dict:
        """``submit --detach``: queue a registered sweep for ``serve``. A sweep that is
        running (live) or done is left as it is; any other (new, partial, failed,
        cancelled, stalled) is queued. Returns the row."""
        with self._transaction() as con:
            row = self._row(con, sweep_id)
            if row["state"] == "done" or (row["state"] == "running" and self.alive(row)):
                return row
            if row["state"] != "queued":
                self._set(con, sweep_id, state="queued", owner="", heartbeat=0.0, message="",
                          cancel_requested=0, queued_at=utc_now(self.clock))
            return self._row(con, sweep_id)

    def requeue(self, sweep_id: str, owner: str, message: str = "", **counts) -> bool:
        """A lease holder puts its sweep back in the queue (``serve`` stopping)."""
        with self._transaction() as con:
            row = self._row(con, sweep_id)
            if row["state"] != "running" or row["owner"] != owner:
                return False
            counts = {k: check_count(k, v) for k, v in counts.items()
                      if k in ("done_points", "failed_points", "done_blocks")}
            self._set(con, sweep_id, state="queued", owner="", heartbeat=0.0,
                      message=str(message), cancel_requested=0, **counts)
            return True

    def request_cancel(self, sweep_id: str) -> dict:
        """``ditherlab cancel``: a queued (or stalled) sweep becomes ``cancelled`` at once;
        a running one is flagged and its runner stops after its in-flight blocks; a
        finished one is left alone. Returns the row."""
        with self._transaction() as con:
            row = self._row(con, sweep_id)
            if row["state"] == "queued":
                self._set(con, sweep_id, state="cancelled", message="cancelled while queued")
            elif row["state"] == "running" and not self.alive(row):
                self._set(con, sweep_id, state="cancelled", owner="", message=(
                    f"cancelled after its runner ({row['owner']}) was gone"))
            elif row["state"] == "running":
                self._set(con, sweep_id, cancel_requested=1)
            return self._row(con, sweep_id)

    # --- serve processes ---------------------------------------------------------------

    def server_beat(self, owner: str | None = None, sweep_id: str = "", cluster: str = "",
                    device: str = "cpu") -> None:
        """Register or refresh a ``serve`` process (the sweep it is running, and ``device``:
        ``cuda`` when it also runs the sweeps queued for the GPU)."""
        with self._connection() as con:
            con.execute(
                "INSERT INTO servers (owner, started, heartbeat, sweep_id, cluster, device) "
                "VALUES (?, ?, ?, ?, ?, ?) ON CONFLICT(owner) DO UPDATE SET "
                "heartbeat = excluded.heartbeat, sweep_id = excluded.sweep_id, "
                "cluster = excluded.cluster, device = excluded.device",
                (owner or owner_tag(), utc_now(self.clock), time.time(), sweep_id, cluster,
                 device))

    def server_gone(self, owner: str | None = None) -> None:
        with self._connection() as con:
            con.execute("DELETE FROM servers WHERE owner = ?", (owner or owner_tag(),))

    def servers(self) -> list[dict]:
        """The ``serve`` processes that are alive (dead ones are left in the table)."""
        rows = self._query("SELECT * FROM servers ORDER BY started")
        return [r for r in rows if self.alive(r)]
