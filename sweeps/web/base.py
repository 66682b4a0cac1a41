"""What every page shares: GET and HEAD only (405 otherwise), the token check (but on
``public`` pages), the security headers, one-sentence errors (a fault's status from the
table of sweeps.web.errors, or a ``tornado.web.HTTPError``'s; its sentence the body),
templates (jinja2, every value escaped), and the parsing of selections from the query
string (``sel.AXIS=VALUE``)."""
from __future__ import annotations

import json
from pathlib import Path

import jinja2
import tornado.web

from tornado.httputil import responses
from tornado.ioloop import IOLoop
from tornado.web import HTTPError

from .errors import SENTENCES, status_of
from .first_imports import after_imports
from .security import COOKIE, CSP, HEADERS, bearer, token_matches

HERE = Path(__file__).parent
TEMPLATES = jinja2.Environment(loader=jinja2.FileSystemLoader(HERE / "templates"),
                               autoescape=True, undefined=jinja2.StrictUndefined)


def in_executor(fn, *args):
    """``fn(*args)`` on the loop's thread pool, awaited: blocking work off the event loop
    (after the server's first imports: sweeps.web.first_imports)."""
    return IOLoop.current().run_in_executor(None, after_imports, fn, *args)


class Base(tornado.web.RequestHandler):
    SUPPORTED_METHODS = ("GET", "HEAD")
    csp = CSP
    public = False   # True: answered without the token (nothing private in it)

    def initialize(self, ctx):
        self.ctx = ctx

    def set_default_headers(self):
        self.set_header("Content-Security-Policy", self.csp)
        for name, value in HEADERS.items():
            self.set_header(name, value)
        self.set_header("Cache-Control", "no-store")

    def prepare(self):
        token = self.ctx.token
        if token is None or self.public:
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
            raise HTTPError(401, "this server needs its token: open the address printed at "
                            "its start (…?token=…) or send 'Authorization: Bearer TOKEN'")

    def head(self, *args):
        return self.get(*args)

    def write_error(self, status_code, **kwargs):
        """The body of every error: one sentence. A fault of sweeps.web.errors' table is
        answered with its status and message; an ``HTTPError`` with its own."""
        exc = kwargs.get("exc_info", (None, None, None))[1]
        status = status_of(exc)
        if status is not None:
            self.set_status(status)
            sentence = str(exc)
        elif isinstance(exc, HTTPError) and exc.log_message:
            sentence = exc.log_message % exc.args   # tornado doubled a bare '%'; undone
        else:
            sentence = SENTENCES.get(status_code, responses.get(status_code, "error"))
        self.set_header("Content-Type", "text/plain; charset=utf-8")
        self.finish(self.ctx.shown(sentence).replace("\n", " ") + "\n")

    def log_exception(self, typ, value, tb):
        """A refusal is answered, not logged (the access log has its status); a bug is."""
        if isinstance(value, HTTPError) or status_of(value) is not None:
            return
        super().log_exception(typ, value, tb)

    def page(self, template: str, **values):
        self.set_header("Content-Type", "text/html; charset=utf-8")
        self.finish(TEMPLATES.get_template(template).render(**values))

    def json(self, data):
        self.set_header("Content-Type", "application/json")
        self.finish(json.dumps(data, allow_nan=False, default=str))

    async def sweep_or_404(self, sweep_id: str) -> dict:
        # off the event loop: a catalogue read may take long (before, on the loop, it stalled
        # every request while a queued brought model's spec was loaded and probed)
        row = await in_executor(self.ctx.live.find, sweep_id)
        if row is None:
            raise HTTPError(404, f"no sweep {sweep_id} in this store")
        return row

    def selection(self) -> dict[str, float]:
        """``sel.AXIS=VALUE`` query arguments as a selection, by the command line's rules
        (sweeps.exports.parse_selection); a field left empty in a form is not given."""
        from ..exports import parse_selection

        pairs = [(k[4:], v.decode(errors="replace")) for k, values in
                 self.request.query_arguments.items() if k.startswith("sel.")
                 for v in values if v.strip()]
        return parse_selection(pairs, "sel.{axis}")


class NotFound(Base):
    """Every address no route knows: 404 for GET/HEAD, 405 for any other method."""

    public = True   # no token needed to learn that nothing is here

    def get(self, *args):
        raise HTTPError(404)
