"""What every page shares: GET and HEAD only (405 otherwise), the token check, the security
headers, one-sentence errors, templates (jinja2, every value escaped), and the parsing of
selections from the query string (``sel.AXIS=VALUE``)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import jinja2
import tornado.web

from ..errors import RefusedError, UserError
from .security import COOKIE, CSP, HEADERS, bearer, token_matches

HERE = Path(__file__).parent
TEMPLATES = jinja2.Environment(loader=jinja2.FileSystemLoader(HERE / "templates"),
                               autoescape=True, undefined=jinja2.StrictUndefined)
AXES = ("W", "omega", "v_ref", "v_d")


class Refused(Exception):
    """A request answered with ``status`` and one sentence."""

    def __init__(self, status: int, sentence: str):
        super().__init__(sentence)
        self.status, self.sentence = status, sentence


class Base(tornado.web.RequestHandler):
    SUPPORTED_METHODS = ("GET", "HEAD")
    csp = CSP

    def initialize(self, ctx):
        self.ctx = ctx

    def set_default_headers(self):
        self.set_header("Content-Security-Policy", self.csp)
        for name, value in HEADERS.items():
            self.set_header(name, value)
        self.set_header("Cache-Control", "no-store")

    def prepare(self):
        token = self.ctx.token
        if token is None:
            return
        given = self.get_query_argument("token", None)
        if given is not None and token_matches(given, token):
            # once in the address (a link printed at start): a cookie from then on, and the
            # address without the token (it stays out of history and of the logs)
            self.set_cookie(COOKIE, token, httponly=True, samesite="Strict",
                            path="/")
            self.redirect(self.request.path)
            return
        shown = bearer(self.request.headers.get("Authorization")) or self.get_cookie(COOKIE)
        if not token_matches(shown, token):
            raise Refused(401, "this server needs its token: open the address printed at its "
                               "start (…?token=…) or send 'Authorization: Bearer TOKEN'")

    def head(self, *args):
        return self.get(*args)

    def write_error(self, status_code, **kwargs):
        exc = kwargs.get("exc_info", (None, None))[1]
        if isinstance(exc, tornado.web.HTTPError) and status_code == 405:
            sentence = "this server only reads: GET and HEAD are answered"
        elif status_code == 404:
            sentence = "not found"
        else:
            sentence = f"{self._reason}"
        self.set_header("Content-Type", "text/plain; charset=utf-8")
        self.finish(sentence + "\n")

    def _handle_request_exception(self, e):
        if isinstance(e, Refused):
            self._reply(e.status, e.sentence)
        elif isinstance(e, (RefusedError,)):
            self._reply(400, str(e))
        elif isinstance(e, UserError):
            self._reply(409, self.ctx.shown(str(e)))
        else:
            super()._handle_request_exception(e)

    def _reply(self, status: int, sentence: str):
        if self._finished:
            return
        self.clear()
        self.set_status(status)
        self.set_header("Content-Type", "text/plain; charset=utf-8")
        self.finish(sentence.replace("\n", " ") + "\n")

    def page(self, template: str, **values):
        self.set_header("Content-Type", "text/html; charset=utf-8")
        self.finish(TEMPLATES.get_template(template).render(**values))

    def json(self, data):
        self.set_header("Content-Type", "application/json")
        self.finish(json.dumps(data, allow_nan=False, default=str))

    def sweep_or_404(self, sweep_id: str) -> dict:
        row = self.ctx.live.find(sweep_id)
        if row is None:
            raise Refused(404, f"no sweep {sweep_id} in this store")
        return row

    def selection(self) -> dict[str, float]:
        """``sel.AXIS=VALUE`` query arguments as a selection (numbers, one per axis)."""
        sel = {}
        for axis in AXES:
            values = [x for x in self.get_query_arguments(f"sel.{axis}") if x.strip()]
            if not values:
                continue
            if len(set(values)) > 1:
                raise Refused(400, f"sel.{axis}: given twice; a selection takes one value "
                                   "per axis")
            try:
                x = float(values[0])
            except ValueError:
                raise Refused(400, f"sel.{axis}: expected a number, got {values[0][:40]!r}")
            if math.isnan(x):
                raise Refused(400, f"sel.{axis}: expected a number, got NaN")
            sel[axis] = x
        unknown = [k for k in self.request.query_arguments
                   if k.startswith("sel.") and k[4:] not in AXES]
        if unknown:
            raise Refused(400, f"{unknown[0][:40]}: unknown axis; the axes are "
                               f"{', '.join(AXES)}")
        return sel


class NotFound(Base):
    """Every address no route knows: 404 for GET/HEAD, 405 for any other method."""

    def prepare(self):   # no token needed to learn that nothing is here
        pass

    def get(self, *args):
        raise Refused(404, "not found")
