"""The catalogue of sweeps in a store: ``<store>/catalogue.sqlite`` (DESIGN.md §6).

One row per sweep: id, name, state, counts, paths and times. SQLite in WAL mode
with a busy timeout and autocommit statements, so several processes (a
running sweep, ``ditherlab status`` in another shell, a future ``serve``) can share
it on a local disk (WAL does not work over network file systems).

The cubes are the truth and the catalogue an index: a cube folder without a row
(a crash between publish and register, a copied store, a deleted catalogue) gets
its row back from the cube's attributes on the next ``list``/``find``/``get``.

Counts: ``done_points`` have a final status (ok, failed or non-finite),
``failed_points`` are those of them that failed or went non-finite, ``done_blocks``
the blocks in the sweep's journal (of ``n_blocks``).

States (DESIGN.md §5), changed only inside transactions (``BEGIN IMMEDIATE``):

==========  ==============================================================
queued      waiting for ``ditherlab serve`` (``submit --detach``)
running     one process holds the sweep's lease (``owner``, ``heartbeat``)
done        every point computed ok
partial     the run finished, some points failed or went non-finite
failed      the run itself crashed; ``message`` holds the error
cancelled   stopped before finishing (``ditherlab cancel``, Ctrl-C); the
            journal is kept and submitting again resumes
==========  ==============================================================

One writer per sweep: a process computes blocks only while it holds the sweep's
lease, taken by :meth:`Catalogue.acquire` (or :meth:`Catalogue.claim_next` for
``serve``) in one transaction, kept alive by :meth:`Catalogue.beat` and given back
by :meth:`Catalogue.finish`. A second submitter finds the lease held and attaches
(sweeps.service). A holder that died cannot give it back, so readers ask
:meth:`Catalogue.live_state`: a ``running`` row reads ``stalled`` when its owner
(``host:pid``) is a process of this host that no longer exists, or its heartbeat is
older than ``STALE_S`` seconds (owners on other hosts are judged by the heartbeat
alone). A stalled sweep can be taken over; resubmitting resumes it from the journal.

The ``servers`` table lists running ``ditherlab serve`` processes and their heartbeat.

The lease and ``serve`` methods are :class:`store.lease.LeaseMixin`; the schema, the
statements and the rows of adopted cubes are :mod:`store.catalogue_db`.
"""

from __future__ import annotations

import os
import sqlite3
import threading
from contextlib import contextmanager
from pathlib import Path

from .catalogue_db import (
    ADDED_COLUMNS,
    ADOPT,
    SCHEMA,
    SERVERS,
    STATES,
    UPSERT,
    check_count,
    check_readable,
    row_from_cube,
    snapshot,
    utc_now,
)
from .layout import CATALOGUE_NAME, CUBE_NAME, LEGACY_CUBE_NAME, check_store, writable
from .lease import STALLED, LeaseMixin  # noqa: F401  (STALLED: sweeps.cli reads it here)

UPDATABLE = ("state", "done_points", "failed_points", "done_blocks", "n_blocks", "message", "path",
             "owner", "heartbeat", "cancel_requested", "run_started", "run_start_blocks")


class Catalogue(LeaseMixin):
    """The SQLite catalogue of the store at ``store_root`` (created if missing).

    Parameters
    ----------
    store_root
        The store folder; the database is ``<store_root>/catalogue.sqlite``.
    timeout_s
        How long a call waits for another process's write lock before failing.
    readonly
        Read a snapshot of the catalogue copied into memory and never write the store
        (writes go to the copy). Default: when the store folder exists but is not
        writable (a read-only mount), so ``status``, ``query`` and ``map`` work there.
        A damaged catalogue raises ``store.errors.StoreError`` saying what to do.
    clock
        What the catalogue reads the time from for the times it writes (``created``,
        ``updated``, ``queued_at``): a callable returning a timezone-aware ``datetime``;
        default the wall clock. Tests inject a clock that ticks, instead of sleeping
        until two milliseconds differ.
    """

    def __init__(self, store_root, timeout_s: float = 30.0, readonly: bool | None = None,
                 clock=None):
        self.root = Path(store_root)
        self.clock = clock   # of the times it writes (catalogue_db.utc_now)
        self.path = self.root / CATALOGUE_NAME
        self.timeout_s = float(timeout_s)
        self._con: sqlite3.Connection | None = None
        self._pid = os.getpid()
        self._lock = threading.RLock()
        check_store(self.root, write=False)
        self.readonly = (self.root.is_dir() and not writable(self.root)) if readonly is None \
            else bool(readonly)
        if not self.readonly:
            check_store(self.root, write=True)
        with self._connection() as con:
            con.execute("PRAGMA journal_mode=WAL")
            con.execute(SCHEMA)
            con.execute(SERVERS)
            for table, added in ADDED_COLUMNS.items():   # a catalogue written before them
                columns = {row["name"] for row in con.execute(f"PRAGMA table_info({table})")}
                for name, decl in added:
                    if name in columns:
                        continue
                    try:
                        con.execute(f"ALTER TABLE {table} ADD COLUMN {name} {decl}")
                    except sqlite3.OperationalError as err:   # another process added it first
                        if "duplicate column" not in str(err):
                            raise

    def __repr__(self) -> str:
        return f"Catalogue({str(self.root)!r})"

    def close(self) -> None:
        """Close this object's connection (it reopens on the next call)."""
        with self._lock:
            if self._con is not None:
                self._con.close()
                self._con = None

    @contextmanager
    def _connection(self):
        """This object's connection, opened once per process and used under a lock.

        Reusing it matters: closing the last connection to a WAL database checkpoints
        and fsyncs, ~5 ms each time. A forked child opens its own.
        """
        with self._lock:
            if self._con is None or self._pid != os.getpid():
                self._con = self._connect()
                self._pid = os.getpid()
            yield self._con

    def _connect(self) -> sqlite3.Connection:
        if self.readonly:
            con = snapshot(self.path)
        else:
            con = sqlite3.connect(
                self.path, timeout=self.timeout_s, isolation_level=None, check_same_thread=False
            )
            check_readable(con, self.path)
        con.row_factory = sqlite3.Row
        con.execute(f"PRAGMA busy_timeout={int(self.timeout_s * 1000)}")
        # WAL + NORMAL: a commit survives a killed process (not a power cut) and costs no
        # fsync; the catalogue is an index that scan() can rebuild from the cubes.
        con.execute("PRAGMA synchronous=NORMAL")
        return con

    def _query(self, sql: str, args=()) -> list[dict]:
        with self._connection() as con:
            return [dict(row) for row in con.execute(sql, args)]

    def register(
        self, sweep_id: str, name: str, spec_json: str, n_points: int, n_blocks: int, path,
        engine_fingerprint: str = "",
    ) -> dict:
        """Add a sweep in state ``queued``, or refresh a known one (resubmission).

        ``path`` is the sweep's folder (``SweepDir.root``), as for adopted cubes;
        ``engine_fingerprint`` names the engine that computes it (the cube attribute of
        the same name; readers compare it with the installed engine's).

        A known sweep keeps its state, counts and creation time; its name, spec,
        sizes, path and fingerprint are overwritten. An earlier name is kept in ``aliases``
        (the same spec submitted under another name: a name is not part of a sweep's
        identity) and still finds the sweep. Returns the row.
        """
        now = utc_now(self.clock)
        row = dict(
            sweep_id=str(sweep_id),
            name=str(name),
            state="queued",
            spec_json=str(spec_json),
            n_points=check_count("n_points", n_points),
            n_blocks=check_count("n_blocks", n_blocks),
            done_points=0,
            failed_points=0,
            done_blocks=0,
            path=str(path),
            created=now,
            updated=now,
            engine_fingerprint=str(engine_fingerprint),
        )
        with self._connection() as con:
            con.execute(UPSERT, row)
        return self.get(sweep_id)

    def update(self, sweep_id: str, **fields) -> dict:
        """Set some of ``UPDATABLE`` (``state=``, ``done_points=`` ...) and the update time.

        Returns the row. Raises ``ValueError`` for an unknown field or state and
        ``LookupError`` for an unknown sweep.
        """
        unknown = sorted(set(fields) - set(UPDATABLE))
        if unknown:
            raise ValueError(
                f"Catalogue.update: unknown field(s) {unknown}; updatable: {UPDATABLE}"
            )
        if "state" in fields and fields["state"] not in STATES:
            raise ValueError(
                f"Catalogue.update: state must be one of {STATES}, got {fields['state']!r}"
            )
        for key in ("done_points", "failed_points", "done_blocks", "n_blocks",
                    "cancel_requested", "run_start_blocks"):
            if key in fields:
                fields[key] = check_count(key, fields[key])
        fields["updated"] = utc_now(self.clock)
        assignments = ", ".join(f"{k} = :{k}" for k in fields)
        with self._connection() as con:
            cur = con.execute(
                f"UPDATE sweeps SET {assignments} WHERE sweep_id = :_id",
                {**fields, "_id": sweep_id},
            )
        if cur.rowcount == 0:
            raise LookupError(f"Catalogue.update: no sweep with id {sweep_id!r}; register it first")
        return self.get(sweep_id)

    def get(self, sweep_id: str) -> dict:
        """The row of ``sweep_id`` (exact id), as a dict; ``LookupError`` if unknown."""
        for attempt in range(2):
            rows = self._query("SELECT * FROM sweeps WHERE sweep_id = ?", (sweep_id,))
            if rows:
                return rows[0]
            if attempt == 0 and not self.scan():
                break
        raise LookupError(f"no sweep with id {sweep_id!r} in {self.path}")

    def matches(self, key: str) -> list[dict]:
        """Every sweep a user may mean by ``key``, newest first: the sweep of that exact
        id, else every sweep of that name, else of that earlier name, else every sweep
        whose id starts with ``key`` (cubes without a row are adopted first when nothing
        matches).
        Deciding between several is the caller's (``sweeps.lookup``: only current ones)."""
        for attempt in range(2):
            rows = self._match(str(key))
            if rows or (attempt == 0 and not self.scan()):
                return rows
        return []

    def find(self, key: str) -> dict | None:
        """The one sweep ``key`` names, ``None`` when nothing matches.

        Raises ``LookupError`` listing the candidates when several match.
        """
        rows = self.matches(key)
        if len(rows) > 1:
            ids = ", ".join(r["sweep_id"] for r in rows)
            raise LookupError(f"{key!r} is ambiguous: it matches {ids}; pass a sweep id")
        return rows[0] if rows else None

    def _match(self, key: str) -> list[dict]:
        newest = " ORDER BY created DESC, sweep_id"
        return (self._query("SELECT * FROM sweeps WHERE sweep_id = ?", (key,))
                or self._query("SELECT * FROM sweeps WHERE name = ?" + newest, (key,))
                or self._query("SELECT * FROM sweeps WHERE instr(char(10) || aliases, "   # earlier
                               "char(10) || ? || char(10))" + newest, (key,))
                or self._query("SELECT * FROM sweeps WHERE substr(sweep_id, 1, ?) = ?" + newest,
                               (len(key), key)))

    def list(self) -> list[dict]:
        """Every sweep, oldest first (after adopting cubes that have no row)."""
        self.scan()
        return self._query("SELECT * FROM sweeps ORDER BY created, sweep_id")

    def scan(self) -> list[str]:
        """Add a row for every ``<store>/<id>/cube.nc`` (or older ``cube.h5``) that has none;
        returns the new ids."""
        known = {r["sweep_id"] for r in self._query("SELECT sweep_id FROM sweeps")}
        added = []
        cubes = {c.parent.name: c for name in (LEGACY_CUBE_NAME, CUBE_NAME)
                 for c in sorted(self.root.glob(f"*/{name}"))}
        for cube in cubes.values():
            if cube.parent.name in known:
                continue
            row = row_from_cube(cube)
            if row is not None:
                with self._connection() as con:
                    con.execute(ADOPT, row)
                added.append(row["sweep_id"])
        return added
