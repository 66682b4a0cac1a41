"""The catalogue as the pages poll it: :func:`sweeps.overview.store_summary`, read again at
most every ``REFRESH_S`` seconds however many pages poll (and, while neither the catalogue
file, its write-ahead log nor the store folder changed, every ``IDLE_REFRESH_S``; with
``refresh_s = 0``: on every call), with a change cursor.

Every sweep carries ``seq``, the cursor value at which it last changed; ``after=N``
returns only the sweeps changed since cursor ``N`` (and the ids gone since), so an open
page polling once a second receives a few rows, not the whole catalogue.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path

from .lru import LRU

REFRESH_S = 0.25
PAGES = 64   # rendered pages kept (pages.py), forgotten at every catalogue change
IDLE_REFRESH_S = 2.0   # unchanged files: read again this often (a runner may have died)


def inside_store(root: Path, text: str) -> str:
    """``text`` (a store's message, a sweep's folder) with the store's folder left out: a
    page names paths inside the store, never the server's folders."""
    return text.replace(f"{root}/", "").replace(str(root), "the store")


def row_inside_store(root: Path, row: dict) -> dict:
    """A sweep's summary or detail (sweeps.overview) as the web shows it: ``row`` with its
    texts that may name a path (folder, message, warnings, stale note) inside the store."""
    for key in ("folder", "message", "stale_note"):
        if isinstance(row.get(key), str):
            row[key] = inside_store(root, row[key])
    row["warnings"] = [inside_store(root, w) for w in row.get("warnings", [])]
    return row


class LiveCatalogue:
    def __init__(self, root: Path, refresh_s: float = REFRESH_S):
        self.root, self.refresh_s = Path(root), refresh_s
        self.cursor = 0
        self._rows: dict[str, dict] = {}
        self._order: list[str] = []
        self._gone: dict[str, int] = {}
        self._read_at = -1e9
        self._files = None
        self.pages = LRU(PAGES)       # rendered pages by (cursor, arguments): pages.py
        self._servers: list = []
        self._warnings: dict = {}       # cube path -> (stat key, warnings): overview cache
        self._lock = threading.Lock()

    def _refresh(self) -> None:
        from ..overview import store_summary

        age = time.monotonic() - self._read_at
        if age < self.refresh_s:
            return
        files = self._signature()
        if files == self._files and age < IDLE_REFRESH_S and self.refresh_s > 0:
            return   # no write to the catalogue and no new sweep folder since the last read
        summary = store_summary(self.root, self._warnings)
        self._files = files
        self._read_at = time.monotonic()
        fresh = {r["sweep_id"]: row_inside_store(self.root, r) for r in summary["sweeps"]}
        changed = [i for i, r in fresh.items()
                   if {k: v for k, v in self._rows.get(i, {}).items() if k != "seq"} != r]
        gone = set(self._rows) - set(fresh)
        if changed or gone:
            self.cursor += 1
            self.pages.clear()
        for i in changed:
            fresh[i]["seq"] = self.cursor
        for i in fresh:
            fresh[i].setdefault("seq", self._rows[i]["seq"] if i in self._rows else 0)
        for i in gone:
            self._gone[i] = self.cursor
        self._rows, self._order = fresh, [r["sweep_id"] for r in summary["sweeps"]]
        self._servers = summary["servers"]

    def _signature(self) -> tuple:
        """What a change of the catalogue or of the store's folders changes: the size and
        mtime of the catalogue, its write-ahead log and the store folder."""
        out = []
        for path in (self.root / "catalogue.sqlite", self.root / "catalogue.sqlite-wal",
                     self.root):
            try:
                st = path.stat()
                out.append((st.st_size, st.st_mtime_ns))
            except OSError:
                out.append(None)
        return tuple(out)

    def snapshot(self) -> tuple[int, list[dict], list]:
        """``(cursor, every sweep in catalogue order, serve processes)``."""
        with self._lock:
            self._refresh()
            return self.cursor, [self._rows[i] for i in self._order], self._servers

    def changes(self, after: int) -> dict:
        """The JSON answer to ``/api/sweeps?after=N``."""
        with self._lock:
            self._refresh()
            rows = [self._rows[i] for i in self._order if self._rows[i]["seq"] > after]
            gone = [i for i, seq in self._gone.items() if seq > after]
            return {"cursor": self.cursor, "sweeps": rows, "removed": gone,
                    "servers": self._servers}

    def find(self, sweep_id: str) -> dict | None:
        """The sweep with exactly this id, or None (ids are looked up, never made paths)."""
        with self._lock:
            self._refresh()
            return self._rows.get(sweep_id)
