"""The web view's application: its routes, the shared state of one server (:class:`ServerState`)
and starting it (:func:`start`, in the calling thread's event loop or a thread of its own).

Every route is a fixed pattern; a sweep id must be 12 hex digits and is then looked up in
the catalogue; any other address is 404 (405 for a method other than GET and HEAD).
"""
from __future__ import annotations

import logging
import threading
from pathlib import Path

import tornado.web

from ..exports import MAPS, QUERY_FORMATS
from . import downloads, extra_pages, pages
from .base import NotFound
from .explorer import Explorer
from .live import LiveCatalogue, inside_store
from .lru import LRU
from .renders import MEDIA, MapCache
from .snapshot import Cubes

ID = r"([0-9a-f]{12})"
MAP_KIND = f"({'|'.join(MAPS)})"
EXPLORER_KIND = "(stability|friction)"   # the explorer's averaged cube draws these two
IMAGE = f"({'|'.join(MEDIA)})"
QUERY = f"({'|'.join(f for f in QUERY_FORMATS if f != 'table')})"   # downloads: no table
PLANS = 256   # plan summaries kept (each a few hundred bytes)
log = logging.getLogger("ditherlab")


class ServerState:
    """What the handlers of one server share: the store, its live catalogue, cubes read,
    maps drawn, the explorer, the token (None on loopback without one), the gallery."""

    def __init__(self, root, token: str | None = None, gallery: str | None = None):
        self.root = Path(root)
        self.token = token
        self.gallery = Path(gallery) if gallery else None
        self.live = LiveCatalogue(self.root)
        self.cubes = Cubes()
        self.maps = MapCache()
        self.explorer = Explorer()
        self._plans = LRU(PLANS)   # plan summaries by sweep id

    def cube_path(self, sweep_id: str) -> Path:
        from store import SweepDir

        return SweepDir(self.root, sweep_id).cube

    def shown(self, text: str) -> str:
        """``text`` with the store's folder left out (:func:`.live.inside_store`)."""
        return inside_store(self.root, text)

    def plan(self, sweep_id: str, spec: dict):
        from .sweep_view import plan_cached

        return plan_cached(self._plans, sweep_id, spec)

    def gallery_dir(self) -> Path | None:
        """The gallery folder: ``--gallery DIR``, else ``<store>/gallery`` if it holds a
        built gallery (``index.html``)."""
        folder = self.gallery or self.root / "gallery"
        return folder if (folder / "index.html").is_file() else None


def _log_request(handler) -> None:
    """Access log without the query string (a ``?token=`` never reaches a log)."""
    req = handler.request
    log.debug("web: %s %s %d %.1f ms", req.method, req.path, handler.get_status(),
              1000 * req.request_time())


def make_app(ctx: ServerState) -> tornado.web.Application:
    c = {"ctx": ctx}
    routes = [
        (r"/", pages.Catalogue, c),
        (r"/api/sweeps", pages.ApiSweeps, c),
        (rf"/api/sweep/{ID}", pages.ApiSweep, c),
        (rf"/sweep/{ID}", pages.SweepPage, c),
        (rf"/sweep/{ID}/cube\.nc", downloads.CubeFile, c),
        (rf"/sweep/{ID}/query\.{QUERY}", downloads.Query, c),
        (rf"/sweep/{ID}/map/{MAP_KIND}\.{IMAGE}", downloads.MapImage, c),
        (r"/explorer", extra_pages.ExplorerPage, c),
        (rf"/explorer/{EXPLORER_KIND}\.png", extra_pages.ExplorerImage, c),
        (r"/explorer/spec\.toml", extra_pages.ExplorerToml, c),
        (r"/gallery", tornado.web.RedirectHandler, {"url": "/gallery/"}),
        (r"/gallery/", extra_pages.Gallery, c),
        (r"/gallery/([A-Za-z0-9_][A-Za-z0-9_.-]{0,100})", extra_pages.Gallery, c),
        (r"/static/([a-z]+\.(?:js|css))", extra_pages.Static, c),
        (r"/favicon\.ico", extra_pages.NoIcon, c),
    ]
    return tornado.web.Application(routes, default_handler_class=NotFound,
                                   default_handler_args=c, log_function=_log_request,
                                   xsrf_cookies=False, compress_response=False)


def start(ctx: ServerState, host: str, port: int):
    """Listen on ``host:port`` in the current event loop; returns the HTTP server (its
    bound port: ``server_port(server)``)."""
    from tornado.httpserver import HTTPServer

    # a request body is never read (GET and HEAD only); a small one still gets its 405
    server = HTTPServer(make_app(ctx), max_body_size=64 * 1024, max_header_size=16 * 1024,
                        idle_connection_timeout=60)
    server.listen(port, address=host)
    return server


def server_port(server) -> int:
    return next(iter(server._sockets.values())).getsockname()[1]


def start_in_thread(ctx: ServerState, host: str, port: int) -> tuple[int, callable]:
    """Run the server in a daemon thread with its own event loop (``serve --web``, tests):
    returns ``(bound port, stop)``."""
    import asyncio

    ready, box = threading.Event(), {}

    def run():
        loop = asyncio.new_event_loop()
        asyncio.set_event_loop(loop)
        try:
            box["server"] = start(ctx, host, port)
        except BaseException as exc:  # noqa: BLE001 -- handed to the starting thread
            box["error"] = exc
            ready.set()
            return
        box["loop"] = loop
        ready.set()
        loop.run_forever()

    threading.Thread(target=run, daemon=True, name="ditherlab-web").start()
    ready.wait()
    if "error" in box:
        raise box["error"]

    def stop():
        loop = box["loop"]
        loop.call_soon_threadsafe(box["server"].stop)
        loop.call_soon_threadsafe(loop.stop)
        ctx.maps.draw.stop()

    return server_port(box["server"]), stop

