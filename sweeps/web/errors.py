"""The web view's errors in one table: the status each kind of fault is answered with
(:data:`STATUS`), its one sentence the body (sweeps.web.base.Base.write_error). No tornado
here: the drawing processes import it too. A handler that knows the status itself raises
``tornado.web.HTTPError(status, sentence)``."""
from __future__ import annotations

from store.errors import StoreError

from ..errors import RefusedError, UserError


class Busy(Exception):
    """The server is at its bound of work of one kind (maps waiting to be drawn, an
    explorer computation running): 503, try again in a moment."""


# first match wins (a RefusedError is also a UserError)
STATUS = (
    (Busy, 503),            # too many maps waiting, an explorer computation running
    (OverflowError, 413),   # a cube over the size the web view serves
    (RefusedError, 400),    # a field, a selection or a spec refused
    (UserError, 409),       # the store disagrees (a cube of another sweep in its folder)
    (StoreError, 409),      # a cube that cannot be read (store.cube_io.CubeError)
)
SENTENCES = {404: "not found", 405: "this server only reads: GET and HEAD are answered"}


def status_of(exc: BaseException | None) -> int | None:
    """The status a fault is answered with, or None (a bug: 500, logged)."""
    return next((status for kind, status in STATUS if isinstance(exc, kind)), None)
