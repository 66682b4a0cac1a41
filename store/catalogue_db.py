"""The catalogue's SQLite side: the ``state`` values, the schema (with the columns added
since the first catalogues, which old files gain on open), the statements that write a
row, opening a damaged or read-only file (one-line errors; an in-memory snapshot), and the
row a cube without one is adopted with (store.catalogue)."""
from __future__ import annotations

import sqlite3
import warnings
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from . import attrs as A
from .errors import NoSpaceError, StoreError
from .flags import FAILED, NON_FINITE, NOT_COMPUTED

STATES = ("queued", "running", "done", "partial", "failed", "cancelled")
FINAL = ("done", "partial", "failed", "cancelled")   # nobody works on the sweep
SCHEMA = """
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
# columns added after the first catalogues were written, per table: old ones gain them on open
ADDED_COLUMNS = {"sweeps": (
    ("owner", "TEXT NOT NULL DEFAULT ''"),           # host:pid of the lease holder
    ("heartbeat", "REAL NOT NULL DEFAULT 0"),        # its last sign of life (epoch s)
    ("cancel_requested", "INTEGER NOT NULL DEFAULT 0"),
    ("run_started", "REAL NOT NULL DEFAULT 0"),      # when blocks began to flow (ETA)
    ("run_start_blocks", "INTEGER NOT NULL DEFAULT 0"),   # done_blocks at that instant
    ("queued_at", "TEXT NOT NULL DEFAULT ''"),       # serve runs the oldest first
    ("engine_fingerprint", "TEXT NOT NULL DEFAULT ''"),   # engine that computes it ('' unknown)
    ("aliases", "TEXT NOT NULL DEFAULT ''"),         # earlier names, each ended by a newline
), "servers": (
    ("device", "TEXT NOT NULL DEFAULT 'cpu'"),       # cuda: it runs the GPU's sweeps too
)}
SERVERS = """
CREATE TABLE IF NOT EXISTS servers (
    owner     TEXT PRIMARY KEY,
    started   TEXT NOT NULL,
    heartbeat REAL NOT NULL,
    sweep_id  TEXT NOT NULL DEFAULT '',
    cluster   TEXT NOT NULL DEFAULT ''
)"""
UPSERT = """
INSERT INTO sweeps (sweep_id, name, state, spec_json, n_points, n_blocks, done_points,
                    failed_points, done_blocks, path, created, updated, queued_at,
                    engine_fingerprint)
VALUES (:sweep_id, :name, :state, :spec_json, :n_points, :n_blocks, :done_points,
        :failed_points, :done_blocks, :path, :created, :updated, :created, :engine_fingerprint)
ON CONFLICT(sweep_id) DO UPDATE SET name = excluded.name, spec_json = excluded.spec_json,
    aliases = CASE WHEN sweeps.name = excluded.name
                     OR instr(char(10) || sweeps.aliases, char(10) || sweeps.name || char(10))
                   THEN sweeps.aliases ELSE sweeps.aliases || sweeps.name || char(10) END,
    n_points = excluded.n_points, n_blocks = excluded.n_blocks, path = excluded.path,
    updated = excluded.updated, engine_fingerprint = excluded.engine_fingerprint"""
ADOPT = """
INSERT INTO sweeps (sweep_id, name, state, spec_json, n_points, n_blocks, done_points,
                    failed_points, done_blocks, path, message, created, updated,
                    engine_fingerprint)
VALUES (:sweep_id, :name, :state, :spec_json, :n_points, :n_blocks, :done_points,
        :failed_points, :done_blocks, :path, :message, :created, :updated, :engine_fingerprint)
ON CONFLICT(sweep_id) DO NOTHING"""


def utc_now(clock=None) -> str:
    """Now as the catalogue writes times: ISO 8601 with milliseconds, UTC. ``clock``: a
    callable returning a timezone-aware ``datetime`` (the catalogue's, tests inject one);
    default the wall clock."""
    return (clock() if clock else datetime.now(timezone.utc)).isoformat(timespec="milliseconds")


def check_readable(con: sqlite3.Connection, path: Path) -> None:
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


def snapshot(path: Path) -> sqlite3.Connection:
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
            check_readable(src, path)   # raises the one-line "damaged" error
        finally:
            if src is not None:
                src.close()
    raise StoreError(f"cannot read the catalogue {path} of a read-only store")


def check_count(name: str, value) -> int:
    if int(value) != value or value < 0:
        raise ValueError(f"Catalogue: {name} must be a non-negative integer, got {value!r}")
    return int(value)


def row_from_cube(cube: Path) -> dict | None:
    """A catalogue row rebuilt from a cube's attributes and status counts."""
    import xarray as xr  # only when a cube without a row is adopted

    try:
        with xr.open_dataset(cube, engine="h5netcdf", decode_timedelta=False) as ds:
            attrs = dict(ds.attrs)
            status = ds["status"].values
    except Exception as err:  # a broken file must not break `ditherlab status`
        warnings.warn(f"catalogue: cannot read {cube} ({err}); skipped")
        return None
    failed = int(np.count_nonzero((status == FAILED) | (status == NON_FINITE)))
    pending = int(np.count_nonzero(status == NOT_COMPUTED))
    # the cube's last publish, not this command's time ("finished" in `ditherlab status`)
    published = datetime.fromtimestamp(cube.stat().st_mtime, timezone.utc).isoformat(
        timespec="milliseconds")
    created = attrs.get(A.CREATED) or published
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
        updated=published,
        engine_fingerprint=str(attrs.get(A.FINGERPRINT, "")),
    )
