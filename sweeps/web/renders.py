"""Maps for the pages, drawn by :func:`sweeps.exports.draw_map` (the function behind
``ditherlab map``) and cached per cube publish.

Renders are queued on ``RENDER_THREADS`` threads, each handing its map to one of as many
drawing processes (matplotlib's Agg canvas, no pyplot): at most that many draw at once, however many
pages ask, and a drawing never holds the server's interpreter lock (pages and progress stay
quick while a map is drawn). A map already being drawn is waited for,
not drawn twice; more than ``MAX_WAITING`` maps waiting is refused (:class:`Busy`, 503)
rather than queued without bound. Finished images are kept (``CACHE_BYTES`` in all) under
the cube's publish key, so an unchanged cube's map is drawn once.
"""
from __future__ import annotations

import tempfile
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

from .errors import Busy
from .first_imports import after_imports
from .lru import LRU

RENDER_THREADS = 2   # the explorer's chart and curves are drawn side by side on 2 cores
MAX_WAITING = 32
CACHE_BYTES = 128 << 20
MEDIA = {"png": "image/png", "svg": "image/svg+xml", "pdf": "application/pdf"}


def render(ds, kind: str, sel: dict, pick: int | None, fmt: str) -> bytes:
    """One map of ``ds`` as bytes (``fmt`` png, svg or pdf), drawn into a temporary folder
    outside the store. ``ds``: the ``xarray.Dataset`` the server already read (pickled to
    the drawing process: a few ms, where opening the cube's bytes again took 250 ms)."""
    from ..exports import draw_map, pick_w

    if kind == "friction" and pick:
        ds = ds.sel(W=pick_w(ds, pick))
    with tempfile.TemporaryDirectory(prefix="ditherlab-web-") as tmp:
        path = Path(tmp) / f"map.{fmt}"
        draw_map(ds, kind, sel, path)
        return path.read_bytes()


def _warm() -> None:
    """matplotlib and xarray loaded, fonts and mathtext read, before the first map."""
    import store.maps

    store.maps.warm()


def _follow_parent(parent: int) -> None:
    """The drawing process ends with the server (pid ``parent``), however the server ends
    (SIGKILL too, and also before this process finished starting): a thread watches for the
    parent to change (an orphan is adopted by another process)."""
    import os
    import time

    def watch():
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(0)

    threading.Thread(target=watch, daemon=True, name="ditherlab-follow-parent").start()


class Drawer:
    """``processes`` drawing processes (spawned, so they share no threads or locks with the
    server), started again if one dies."""

    def __init__(self, processes: int = RENDER_THREADS):
        self.processes = processes
        self._pool = None
        self._lock = threading.Lock()

    def _get(self):
        import multiprocessing
        import os
        from concurrent.futures import ProcessPoolExecutor

        with self._lock:
            if self._pool is None:
                self._pool = ProcessPoolExecutor(
                    self.processes, mp_context=multiprocessing.get_context("spawn"),
                    initializer=_follow_parent, initargs=(os.getpid(),))
                for _ in range(self.processes):   # each one started and warmed now
                    self._pool.submit(_warm)
            return self._pool

    def __call__(self, *args) -> bytes:
        from concurrent.futures.process import BrokenProcessPool

        pool = self._get()
        try:
            return pool.submit(render, *args).result()
        except BrokenProcessPool:   # killed (out of memory?): a fresh one, once
            with self._lock:
                self._pool = None
            return self._get().submit(render, *args).result()

    def start(self) -> None:
        self._get()

    def stop(self) -> None:
        with self._lock:
            if self._pool is not None:
                self._pool.shutdown(wait=False, cancel_futures=True)
                self._pool = None


class MapCache:
    def __init__(self, threads: int = RENDER_THREADS, max_waiting: int = MAX_WAITING,
                 cache_bytes: int = CACHE_BYTES):
        self.pool = ThreadPoolExecutor(threads, thread_name_prefix="ditherlab-map")
        self.max_waiting = max_waiting
        self._done = LRU(cache_bytes, weight=len)   # images by key, CACHE_BYTES in all
        self._pending: dict[tuple, Future] = {}
        self._lock = threading.Lock()
        self.drawn = 0          # maps drawn (the tests count them)
        self.draw = Drawer(threads)    # render(...) in a drawing process

    def get(self, key: tuple, draw) -> Future:
        """A future of the bytes for ``key``; ``draw()`` makes them if nobody has."""
        with self._lock:
            data = self._done.get(key)
            if data is not None:
                done: Future = Future()
                done.set_result(data)
                return done
            if key in self._pending:
                return self._pending[key]
            if len(self._pending) >= self.max_waiting:
                raise Busy(f"{len(self._pending)} maps are being drawn; try again in a moment")
            fut = self.pool.submit(after_imports, self._draw, key, draw)
            self._pending[key] = fut
            return fut

    def _draw(self, key: tuple, draw) -> bytes:
        try:
            data = draw()
        except BaseException:
            with self._lock:
                self._pending.pop(key, None)
            raise
        with self._lock:   # cached before it stops pending: never drawn twice
            self._pending.pop(key, None)
            self.drawn += 1
            self._done.put(key, data)
        return data
