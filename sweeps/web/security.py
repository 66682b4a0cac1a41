"""Who may read the pages: the bind address (loopback by default) and the token any other
address needs.

A server bound to a loopback address answers anyone on this machine, as Jupyter and the
dask dashboard do behind ``ssh -L``. Any other address needs a token: read from
``--token-file`` or generated and printed once at start. A request shows it as
``Authorization: Bearer TOKEN``, as the ``ditherlab_token`` cookie, or once as
``?token=TOKEN`` (the page then sets the cookie and redirects to the address without it).
Tokens are compared in constant time (``hmac.compare_digest``) and never logged: the
access log writes the path without its query.
"""
from __future__ import annotations

import hmac
import ipaddress
import secrets
from pathlib import Path

from ..errors import RefusedError

DEFAULT_BIND = "127.0.0.1:8700"
COOKIE = "ditherlab_token"


def parse_bind(text: str, option: str = "--bind") -> tuple[str, int]:
    """``HOST:PORT`` (``[::1]:8700`` for IPv6; ``:PORT`` means loopback) -> (host, port)."""
    host, sep, port = str(text).rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise RefusedError(f"{option}: expected HOST:PORT (e.g. {DEFAULT_BIND}), got {text!r}")
    host = host.strip("[]") or "127.0.0.1"
    return host, int(port)


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and the loopback addresses (127.0.0.0/8, ::1)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:   # a host name: only reachable beyond loopback if it resolves there
        return False


def server_token(host: str, token_file: str | None) -> tuple[str | None, bool]:
    """The token requests must show, and whether it was generated here (print it once).

    None on a loopback address without ``--token-file``; a ``--token-file`` is read
    (a missing or empty file is refused); any other address gets a fresh token."""
    if token_file:
        try:
            token = Path(token_file).read_text().strip()
        except OSError as exc:
            raise RefusedError(f"--token-file {token_file}: {exc.strerror or exc}") from None
        if len(token) < 16:
            raise RefusedError(f"--token-file {token_file}: the token must be at least 16 "
                               "characters (one line)")
        return token, False
    if is_loopback(host):
        return None, False
    return secrets.token_urlsafe(32), True


def token_matches(given: str | None, expected: str) -> bool:
    """Constant-time comparison (no early exit on the first differing character)."""
    return given is not None and hmac.compare_digest(given.encode(), expected.encode())


def bearer(header: str | None) -> str | None:
    """The token of an ``Authorization: Bearer TOKEN`` header, or None."""
    kind, _, value = (header or "").partition(" ")
    return value.strip() if kind.lower() == "bearer" and value.strip() else None


CSP = ("default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self'; "
       "connect-src 'self'; form-action 'self'; base-uri 'none'; frame-ancestors 'none'")
# the gallery's static page carries its own <style> (no scripts): its styles only
GALLERY_CSP = CSP.replace("style-src 'self'", "style-src 'self' 'unsafe-inline'")
HEADERS = {
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "X-Frame-Options": "DENY",
    "Cross-Origin-Resource-Policy": "same-origin",
}
