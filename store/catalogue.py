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
"""

from __future__ import annotations

import os
import socket
import sqlite3
import threading
import time
import warnings
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from . import attrs as A
from .layout import (CATALOGUE_NAME, CUBE_NAME, LEGACY_CUBE_NAME, NoSpaceError, StoreError,
                     check_store, writable)
from .status import FAILED, NON_FINITE, NOT_COMPUTED

STATES = ("queued", "running", "done", "partial", "failed", "cancelled")
FINAL = ("done", "partial", "failed", "cancelled")   # nobody works on the sweep
UPDATABLE = ("state", "done_points", "failed_points", "done_blocks", "n_blocks", "message", "path",
             "owner", "heartbeat", "cancel_requested", "run_started", "run_start_blocks")
STALLED = "stalled"   # derived, never stored: running, but its submitter is gone
HEARTBEAT_S = 5.0     # a lease holder (and serve) beats this often
STALE_S = float(os.environ.get("DITHERLAB_STALE_S") or 60.0)   # silent longer: gone
_SCHEMA = """
CREATE TABLE IF NOT EXISTS sweeps (
    sweep_id      TEXT PRIMARY KEY,
    name          TEXT NOT NULL,
    state         TEXT NOT NULL,
    spec_json     TEXT NOT NULL,
    n_points      INTEGER NOT NULL,
    n_blocks      INTEGER NOT NULL,
    done_points   INTEGER NOT NULL DEFAULT 0,
    failed_points INTEGER NOT NULL DEFAULT 0,
    done_blocks   INTEGER NOT NULL DEFAULT 0,
    path          TEXT NOT NULL,
    message       TEXT NOT NULL DEFAULT '',
    created       TEXT NOT NULL,
    updated       TEXT NOT NULL,
    owner         TEXT NOT NULL DEFAULT ''
)"""
# columns added after the first catalogues were written: old ones gain them on open
_ADDED_COLUMNS = (
    ("owner", "TEXT NOT NULL DEFAULT ''"),           # host:pid of the lease holder
    ("heartbeat", "REAL NOT NULL DEFAULT 0"),        # its last sign of life (epoch s)
    ("cancel_requested", "INTEGER NOT NULL DEFAULT 0"),
    ("run_started", "REAL NOT NULL DEFAULT 0"),      # when blocks began to flow (ETA)
    ("run_start_blocks", "INTEGER NOT NULL DEFAULT 0"),   # done_blocks at that instant
    ("queued_at", "TEXT NOT NULL DEFAULT ''"),       # serve runs the oldest first
    ("engine_fingerprint", "TEXT NOT NULL DEFAULT ''"),   # engine that computes it ('' unknown)
)
_SERVERS = """
CREATE TABLE IF NOT EXISTS servers (
    owner     TEXT PRIMARY KEY,
    started   TEXT NOT NULL,
    heartbeat REAL NOT NULL,
    sweep_id  TEXT NOT NULL DEFAULT '',
    cluster   TEXT NOT NULL DEFAULT ''
)"""
_UPSERT = """
INSERT INTO sweeps (sweep_id, name, state, spec_json, n_points, n_blocks, done_points,
                    failed_points, done_blocks, path, created, updated, queued_at,
                    engine_fingerprint)
VALUES (:sweep_id, :name, :state, :spec_json, :n_points, :n_blocks, :done_points,
        :failed_points, :done_blocks, :path, :created, :updated, :created, :engine_fingerprint)
ON CONFLICT(sweep_id) DO UPDATE SET name = excluded.name, spec_json = excluded.spec_json,
    n_points = excluded.n_points, n_blocks = excluded.n_blocks, path = excluded.path,
    updated = excluded.updated, engine_fingerprint = excluded.engine_fingerprint"""
_ADOPT = """
INSERT INTO sweeps (sweep_id, name, state, spec_json, n_points, n_blocks, done_points,
                    failed_points, done_blocks, path, message, created, updated,
                    engine_fingerprint)
VALUES (:sweep_id, :name, :state, :spec_json, :n_points, :n_blocks, :done_points,
        :failed_points, :done_blocks, :path, :message, :created, :updated, :engine_fingerprint)
ON CONFLICT(sweep_id) DO NOTHING"""


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


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


class Catalogue:
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
        A damaged catalogue raises ``store.layout.StoreError`` saying what to do.
    """

    def __init__(self, store_root, timeout_s: float = 30.0, readonly: bool | None = None):
        self.root = Path(store_root)
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
            con.execute(_SCHEMA)
            con.execute(_SERVERS)
            columns = {row["name"] for row in con.execute("PRAGMA table_info(sweeps)")}
            for name, decl in _ADDED_COLUMNS:   # a catalogue written before they existed
                if name in columns:
                    continue
                try:
                    con.execute(f"ALTER TABLE sweeps ADD COLUMN {name} {decl}")
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
            con = _snapshot(self.path)
        else:
            con = sqlite3.connect(
                self.path, timeout=self.timeout_s, isolation_level=None, check_same_thread=False
            )
            _check_readable(con, self.path)
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
        sizes, path and fingerprint are overwritten. Returns the row.
        """
        now = _now()
        row = dict(
            sweep_id=str(sweep_id),
            name=str(name),
            state="queued",
            spec_json=str(spec_json),
            n_points=_count("n_points", n_points),
            n_blocks=_count("n_blocks", n_blocks),
            done_points=0,
            failed_points=0,
            done_blocks=0,
            path=str(path),
            created=now,
            updated=now,
            engine_fingerprint=str(engine_fingerprint),
        )
        with self._connection() as con:
            con.execute(_UPSERT, row)
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
                fields[key] = _count(key, fields[key])
        fields["updated"] = _now()
        assignments = ", ".join(f"{k} = :{k}" for k in fields)
        with self._connection() as con:
            cur = con.execute(
                f"UPDATE sweeps SET {assignments} WHERE sweep_id = :_id",
                {**fields, "_id": sweep_id},
            )
        if cur.rowcount == 0:
            raise LookupError(f"Catalogue.update: no sweep with id {sweep_id!r}; register it first")
        return self.get(sweep_id)

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
            con.execute("BEGIN IMMEDIATE")
            try:
                yield con
            except BaseException:
                con.execute("ROLLBACK")
                raise
            con.execute("COMMIT")

    @staticmethod
    def _row(con, sweep_id: str) -> dict:
        row = con.execute("SELECT * FROM sweeps WHERE sweep_id = ?", (sweep_id,)).fetchone()
        if row is None:
            raise LookupError(f"no sweep with id {sweep_id!r}; register it first")
        return dict(row)

    @staticmethod
    def _set(con, sweep_id: str, **fields) -> None:
        fields["updated"] = _now()
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

    def claim_next(self, owner: str | None = None) -> dict | None:
        """For ``serve``: the oldest ``queued`` sweep, now ``running`` under ``owner``;
        ``None`` when the queue is empty. Two servers never claim the same sweep."""
        owner = owner or owner_tag()
        with self._transaction() as con:
            row = con.execute("SELECT * FROM sweeps WHERE state = 'queued' "
                              "ORDER BY queued_at, created, sweep_id LIMIT 1").fetchone()
            return None if row is None else self._take(con, row["sweep_id"], owner, dict(row))

    def beat(self, sweep_id: str, owner: str | None = None, **counts) -> bool:
        """The lease holder's heartbeat, with progress counts if given (``done_points``,
        ``failed_points``, ``done_blocks``, ``run_started``, ``run_start_blocks``).
        False when ``owner`` no longer holds the lease: it must stop computing."""
        unknown = sorted(set(counts) - {"done_points", "failed_points", "done_blocks",
                                        "run_started", "run_start_blocks"})
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
        counts = {k: _count(k, v) for k, v in counts.items()
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
                          cancel_requested=0, queued_at=_now())
            return self._row(con, sweep_id)

    def requeue(self, sweep_id: str, owner: str, message: str = "", **counts) -> bool:
        """A lease holder puts its sweep back in the queue (``serve`` stopping)."""
        with self._transaction() as con:
            row = self._row(con, sweep_id)
            if row["state"] != "running" or row["owner"] != owner:
                return False
            counts = {k: _count(k, v) for k, v in counts.items()
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

    def server_beat(self, owner: str | None = None, sweep_id: str = "", cluster: str = "") -> None:
        """Register or refresh a ``serve`` process (and the sweep it is running)."""
        with self._connection() as con:
            con.execute(
                "INSERT INTO servers (owner, started, heartbeat, sweep_id, cluster) "
                "VALUES (?, ?, ?, ?, ?) ON CONFLICT(owner) DO UPDATE SET "
                "heartbeat = excluded.heartbeat, sweep_id = excluded.sweep_id, "
                "cluster = excluded.cluster",
                (owner or owner_tag(), _now(), time.time(), sweep_id, cluster))

    def server_gone(self, owner: str | None = None) -> None:
        with self._connection() as con:
            con.execute("DELETE FROM servers WHERE owner = ?", (owner or owner_tag(),))

    def servers(self) -> list[dict]:
        """The ``serve`` processes that are alive (dead ones are left in the table)."""
        rows = self._query("SELECT * FROM servers ORDER BY started")
        return [r for r in rows if self.alive(r)]

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
        id, else every sweep of that name, else every sweep whose id starts with ``key``
        (cubes without a row are adopted first when nothing matches). Deciding between
        several is the caller's (``sweeps.lookup``: only current sweeps count)."""
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
            row = _row_from_cube(cube)
            if row is not None:
                with self._connection() as con:
                    con.execute(_ADOPT, row)
                added.append(row["sweep_id"])
        return added


def _check_readable(con: sqlite3.Connection, path: Path) -> None:
    """Read the schema once, so that a damaged or unopenable file fails here, as one line."""
    try:
        con.execute("SELECT count(*) FROM sqlite_master").fetchone()
    except sqlite3.DatabaseError as err:
        con.close()
        if "full" in str(err):
            raise NoSpaceError(path) from None
        if isinstance(err, sqlite3.OperationalError):   # locked, a folder, no permission
            raise StoreError(f"cannot open the catalogue {path}: {err}") from None
        raise StoreError(
            f"the catalogue {path} is damaged ({err}); move it aside (mv {path} "
            f"{path}.damaged) and run the command again: it is rebuilt from the cubes "
            "(queued sweeps must be submitted again)") from None


def _snapshot(path: Path) -> sqlite3.Connection:
    """The catalogue of a read-only store, copied into memory: reads see it as on disk,
    writes (adopting cubes, migrations) stay in memory, nothing touches the store."""
    mem = sqlite3.connect(":memory:", isolation_level=None, check_same_thread=False)
    if not path.exists():
        return mem
    uri = path.absolute().as_uri()
    for mode in ("mode=ro", "immutable=1"):   # immutable: when no -shm can be made beside it
        src = None
        try:
            src = sqlite3.connect(f"{uri}?{mode}", uri=True)
            src.execute("SELECT count(*) FROM sqlite_master").fetchone()
            src.backup(mem)
            return mem
        except sqlite3.OperationalError:
            continue
        except sqlite3.DatabaseError:
            _check_readable(src, path)   # raises the one-line "damaged" error
        finally:
            if src is not None:
                src.close()
    raise StoreError(f"cannot read the catalogue {path} of a read-only store")


def _count(name: str, value) -> int:
    if int(value) != value or value < 0:
        raise ValueError(f"Catalogue: {name} must be a non-negative integer, got {value!r}")
    return int(value)


def _row_from_cube(cube: Path) -> dict | None:
    """A catalogue row rebuilt from a cube's attributes and status counts."""
    import xarray as xr   # only when a cube without a row is adopted

    try:
        with xr.open_dataset(cube, engine="h5netcdf", decode_timedelta=False) as ds:
            attrs = dict(ds.attrs)
            status = ds["status"].values
    except Exception as err:  # a broken file must not break `ditherlab status`
        warnings.warn(f"catalogue: cannot read {cube} ({err}); skipped")
        return None
    failed = int(np.count_nonzero((status == FAILED) | (status == NON_FINITE)))
    pending = int(np.count_nonzero(status == NOT_COMPUTED))
    created = (
        attrs.get(A.CREATED)
        or datetime.fromtimestamp(cube.stat().st_mtime, timezone.utc).isoformat()
    )
    spec = attrs.get(A.SPEC, "{}")
    if pending:
        state, message = "cancelled", (f"found as a cube with {pending} points not computed; "
                                       "submit the spec again to resume")
    else:
        state, message = ("partial" if failed else "done"), ""
    return dict(
        sweep_id=cube.parent.name,
        name=str(attrs.get(A.NAME, cube.parent.name)),
        state=state,
        message=message,
        spec_json=spec if isinstance(spec, str) else A.canonical_json(spec),
        n_points=int(status.size),
        n_blocks=0,
        done_points=int(status.size) - pending,
        failed_points=failed,
        done_blocks=0,
        path=str(cube.parent),
        created=str(created),
        updated=_now(),
        engine_fingerprint=str(attrs.get(A.FINGERPRINT, "")),
    )
