"""The explorer (``/explorer``, its images and TOML), the gallery (``/gallery/``), and the
page scripts and styles (``/static/NAME``). No address becomes a path: static files are a
fixed table read at start, gallery files are looked up by name in the folder's listing."""
from __future__ import annotations

import asyncio
import hashlib
import json
import os
from urllib.parse import urlencode

from tornado.web import HTTPError

from ..errors import RefusedError
from .base import HERE, Base
from .explorer import DEFAULTS, DITHERS, FRICTIONS, MAX_AXIS, PARAMS, curves_wanted
from .explorer import spec_from_query
from .security import GALLERY_CSP
from .tomltext import spec_toml

STATIC = {p.name: p.read_bytes() for p in (HERE / "static").iterdir() if p.is_file()}
STATIC_TYPES = {".js": "text/javascript; charset=utf-8", ".css": "text/css; charset=utf-8"}
GALLERY_TYPES = {".png": "image/png", ".svg": "image/svg+xml", ".pdf": "application/pdf",
                 ".html": "text/html; charset=utf-8", ".md": "text/plain; charset=utf-8"}


class Static(Base):
    public = True   # the scripts and styles hold nothing private

    def get(self, name):
        if name not in STATIC:
            raise HTTPError(404)
        self.set_header("Content-Type", STATIC_TYPES[os.path.splitext(name)[1]])
        self.set_header("Cache-Control", "max-age=300")
        self.finish(STATIC[name])


class NoIcon(Base):
    public = True

    def get(self):
        self.set_status(204)   # no icon: an empty answer, not a 404 in the console
        self.finish()


def _fields(handler) -> dict:
    known = ("friction", "dither", "v_d", "curves", *PARAMS,
             *(f"{a}_{p}" for a in ("W", "v_ref") for p in ("start", "stop", "num")))
    given = {k: handler.get_query_argument(k, "") for k in known}
    return {k: v for k, v in given.items() if v != ""}


class ExplorerPage(Base):
    def get(self):
        fields = _fields(self)
        values = {**DEFAULTS, **fields}
        toml = error = None
        if fields:
            try:
                spec = spec_from_query(fields)
                curves_wanted(fields)
                toml = spec_toml({**spec, "name": "explorer-chart"})
            except RefusedError as exc:
                error = str(exc)
        self.page("explorer.html", values=values, frictions=FRICTIONS, dithers=DITHERS,
                  params=PARAMS, max_axis=MAX_AXIS, toml=toml, error=error,
                  query=urlencode(fields) if toml else "")


class ExplorerImage(Base):
    async def get(self, kind):
        fields = _fields(self)
        spec = spec_from_query(fields)
        curves = curves_wanted(fields)
        key = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()
        cube = await asyncio.wrap_future(self.ctx.explorer.cube(key, spec))
        maps = self.ctx.maps
        draw = {"stability": lambda: maps.draw(cube, "stability", {}, None, "png"),
                "friction": lambda: maps.draw(cube, "friction", {}, curves, "png")}[kind]
        fut = maps.get(("explorer", key, kind, curves), draw)
        data = await asyncio.wrap_future(fut)
        self.set_header("Content-Type", "image/png")
        self.finish(data)


class ExplorerToml(Base):
    def get(self):
        spec = spec_from_query(_fields(self))
        self.set_header("Content-Type", "text/plain; charset=utf-8")
        self.finish(spec_toml({**spec, "name": "explorer-chart"}))


class Gallery(Base):
    csp = GALLERY_CSP

    def get(self, name=None):
        folder = self.ctx.gallery_dir()
        if folder is None:
            raise HTTPError(404, "no gallery in this store (`ditherlab gallery -o "
                            "STORE/gallery` builds one, or start the server with "
                            "--gallery DIR)")
        files = {f: folder / f for f in os.listdir(folder)
                 if not f.startswith(".") and os.path.splitext(f)[1] in GALLERY_TYPES}
        if name is None:
            name = "index.html"
        if name not in files or not files[name].is_file() or files[name].is_symlink():
            raise HTTPError(404)
        self.set_header("Content-Type", GALLERY_TYPES[os.path.splitext(name)[1]])
        self.finish(files[name].read_bytes())
