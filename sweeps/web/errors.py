"""The web view's own refusals, raised by the code behind the pages (no tornado here: the
drawing processes import it too); sweeps.web.base answers each with its status."""
from __future__ import annotations


class Busy(Exception):
    """The server is at its bound of work of one kind (maps waiting to be drawn, an
    explorer computation running): 503, try again in a moment."""
