"""``ditherlab web`` and ``ditherlab serve --web``: the read-only pages of a store
(docs/WEB.md).

    ditherlab web [--store DIR] [--bind HOST:PORT] [--token-file F] [--gallery DIR]
    ditherlab serve ... --web HOST:PORT [--token-file F]

Loopback (127.0.0.1:8700) by default; any other address needs a token (``--token-file``,
or one generated and printed once). This module is light: tornado is imported by the
commands, so ``ditherlab --help`` stays fast.
"""
from __future__ import annotations

import sys

from ..lookup import store_root
from ..web.security import DEFAULT_BIND, parse_bind, server_token


def add_commands(sub, common) -> None:
    """The ``web`` command, and ``--web``/``--token-file`` on ``serve``."""
    p = sub.add_parser("web", parents=[common],
                       help="read-only web pages of the store (catalogue, sweeps, maps, "
                       "downloads, explorer); default 127.0.0.1:8700")
    p.add_argument("--bind", default=DEFAULT_BIND, metavar="HOST:PORT",
                   help=f"address to listen on (default {DEFAULT_BIND}; an address beyond "
                   "loopback needs a token)")
    _token_option(p)
    p.add_argument("--gallery", metavar="DIR",
                   help="serve this gallery folder (default STORE/gallery when built there)")
    p.set_defaults(func=cmd_web)
    serve = sub.choices["serve"]
    serve.add_argument("--web", metavar="HOST:PORT",
                       help="also serve the read-only web pages at HOST:PORT from this process")
    _token_option(serve)
    serve.set_defaults(func=_serve_with_web(serve.get_default("func")))


def _token_option(p) -> None:
    p.add_argument("--token-file", metavar="F",
                   help="file holding the token requests must show (else one is generated "
                   "and printed once when the address is beyond loopback)")


def _prepare(root, bind: str, token_file: str | None, option: str):
    """Check the address and token before anything listens; returns ``(ctx, host, port,
    the line to print)``."""
    from ..web.app import ServerState

    host, port = parse_bind(bind, option)
    token, generated = server_token(host, token_file)
    ctx = ServerState(root, token=token)
    shown = f"[{host}]" if ":" in host else host
    link = f"http://{shown}:{{port}}/"
    if generated:
        link += f"?token={token}   (the token: printed once, never logged)"
    elif token:
        link += "   (token from --token-file)"
    return ctx, host, port, link


def cmd_web(args) -> int:
    import asyncio

    from ..web.app import server_port, start

    ctx, host, port, link = _prepare(store_root(args.store), args.bind, args.token_file,
                                     "--bind")
    if args.gallery:
        from pathlib import Path

        ctx.gallery = Path(args.gallery)

    async def main():
        server = start(ctx, host, port)
        ctx.explorer.warm_up()
        ctx.maps.draw.start()
        print(f"ditherlab web: store {ctx.root}, read-only, at "
              + link.format(port=server_port(server)), file=sys.stderr, flush=True)
        await asyncio.Event().wait()

    try:
        asyncio.run(main())
    except OSError as exc:
        from ..errors import UserError

        raise UserError(f"web: cannot listen on {host}:{port}: {exc.strerror or exc}") from None
    return 0


def _serve_with_web(serve_cmd):
    def run(args) -> int:
        if not args.web:
            if args.token_file:
                from ..errors import RefusedError

                raise RefusedError("--token-file applies with --web only")
            return serve_cmd(args)
        from ..web.app import start_in_thread
        from ..web.first_imports import ready

        ctx, host, port, link = _prepare(store_root(args.store), args.web, args.token_file,
                                         "--web")
        # made here, before the pages' threads start: serve's own imports (dask, numba)
        # would otherwise run beside theirs (sweeps.web.first_imports)
        ready()
        try:
            bound, stop = start_in_thread(ctx, host, port)
        except OSError as exc:
            from ..errors import UserError

            raise UserError(f"--web: cannot listen on {host}:{port}: "
                            f"{exc.strerror or exc}") from None
        ctx.explorer.warm_up()
        ctx.maps.draw.start()
        print(f"ditherlab serve: web pages at {link.format(port=bound)}", file=sys.stderr,
              flush=True)
        try:
            return serve_cmd(args)
        finally:
            stop()
    return run
