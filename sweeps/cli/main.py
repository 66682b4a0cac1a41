"""The ``ditherlab`` command line (DESIGN.md §5): the parser, and the promise that every
fault ends in one line.

    ditherlab submit SPEC.toml [--store DIR] [--scheduler ADDR | --workers N
                               | --cluster slurm|pbs|sge [--jobs N]] [--dashboard ADDR] [--detach]
    ditherlab serve [--store DIR] [--scheduler ADDR | --workers N | --cluster KIND [--jobs N]]
                    [--dashboard ADDR]
    ditherlab status [SWEEP] [--format table|json]
    ditherlab cancel SWEEP [--wait]
    ditherlab query SWEEP [--var NAME] [--sel AXIS=VALUE ...] [--format table|csv|json]
    ditherlab map SWEEP --kind stick-slip|stability|friction|hunting [--sel AXIS=VALUE ...] -o F
    ditherlab plan SPEC.toml [--record];  ditherlab --version;  -v / -q on every command
    ditherlab web [--bind HOST:PORT] [--token-file F];  serve --web HOST:PORT

Exit status: 0 success, 1 a run or lookup failed, 2 the input (spec, arguments, a brought
model's fault) was refused, 130 interrupted (143 SIGTERM to submit). Imports stay inside the
commands: ``--help`` and ``status`` start in a fraction of a second (no dask, numba, xarray).
"""
from __future__ import annotations

import argparse
import os
import sys
from contextlib import contextmanager

from engine.contract import ModelError

from ..errors import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_REFUSED, Interrupted, SpecError, UserError
from ..exports import MAPS, QUERY_FORMATS
from ..workers.batch import BATCH_KINDS
from .gallery_commands import add_commands as add_gallery_commands
from .web_commands import add_commands as add_web_commands
from .reading import cmd_map, cmd_query, cmd_status
from .running import cmd_cancel, cmd_plan, cmd_serve, cmd_submit

DEFAULT_MAX_POINTS = 250_000   # sweeps.spec.DEFAULT_MAX_POINTS (a test checks they agree)


class _OneLineParser(argparse.ArgumentParser):
    """argparse, but a refused argument is one line (the promise of every fault), with where
    to look instead of the usage block: ``ditherlab query: error: ... (ditherlab query -h)``."""

    def error(self, message):
        self.exit(EXIT_REFUSED, f"{self.prog}: error: {message} (see {self.prog} -h)\n")


def build_parser() -> argparse.ArgumentParser:
    ap = _OneLineParser(prog="ditherlab", description="Parameter sweeps of friction "
                        "dynamics under dither: submit, inspect, query, draw.")
    ap.add_argument("--version", action="version", version=f"ditherlab {_version()}")
    common = _OneLineParser(add_help=False)
    common.add_argument("--store", help="store folder (default $DITHERLAB_STORE or "
                        "./ditherlab-store)")
    talk = common.add_mutually_exclusive_group()
    talk.add_argument("-v", "--verbose", action="store_true",
                      help="also say what happens inside (timings, cluster, blocks)")
    talk.add_argument("-q", "--quiet", action="store_true",
                      help="only results, warnings and errors (no progress bar)")
    sub = ap.add_subparsers(dest="command", required=True)

    p = sub.add_parser("submit", parents=[common], help="run a sweep spec (resumes a partial one)")
    p.add_argument("spec", nargs="?", help="spec file (.toml or .json); or --scene NAME")
    _cluster_options(p)
    p.add_argument("--max-points", type=int, default=DEFAULT_MAX_POINTS, help="point budget")
    p.add_argument("--detach", action="store_true",
                   help="queue the sweep for `ditherlab serve` and return its id at once")
    _device_option(p)
    p.set_defaults(func=cmd_submit)

    p = sub.add_parser("serve", parents=[common],
                       help="run queued sweeps, oldest first, until SIGTERM or Ctrl-C")
    _cluster_options(p)
    p.add_argument("--device", choices=("cpu", "cuda"), default="cpu", help="cuda: also run "
                   "the sweeps queued for the GPU (default: leave them to a serve with one)")
    p.set_defaults(func=cmd_serve)

    p = sub.add_parser("cancel", parents=[common],
                       help="cancel a queued sweep, or stop a running one after its blocks "
                       "in flight (the journal is kept; submitting again resumes)")
    p.add_argument("sweep")
    p.add_argument("--wait", action="store_true", help="return once the run has stopped")
    p.set_defaults(func=cmd_cancel)

    p = sub.add_parser("status", parents=[common], help="list sweeps, or show one")
    p.add_argument("sweep", nargs="?")
    p.add_argument("--format", choices=("table", "json"), default="table",
                   help="json: the data the web view shows (docs/WEB.md)")
    p.set_defaults(func=cmd_status)

    p = sub.add_parser("query", parents=[common], help="print a cube's values")
    p.add_argument("sweep")
    p.add_argument("--var", help="variable (default: all outputs)")
    p.add_argument("--sel", action="append", metavar="AXIS=VALUE", help="nearest-point selection")
    p.add_argument("--format", choices=QUERY_FORMATS, default="table")
    p.set_defaults(func=cmd_query)

    p = sub.add_parser("map", parents=[common], help="draw a map from a cube (png, pdf, svg)")
    p.add_argument("sweep", nargs="?", help="sweep id, id prefix or name; or --scene NAME")
    p.add_argument("--kind", required=True, choices=tuple(MAPS))
    p.add_argument("--sel", action="append", metavar="AXIS=VALUE")
    p.add_argument("-o", "--output", required=True,
                   help="file to write: .png, .pdf or .svg, in an existing folder")
    p.set_defaults(func=cmd_map)

    p = sub.add_parser("plan", parents=[common],
                       help="what a spec will run, and its cost per accuracy level")
    p.add_argument("spec", nargs="?", help="spec file (.toml or .json); or --scene NAME")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=2)
    where.add_argument("--cluster", choices=tuple(BATCH_KINDS),
                       help="estimate for batch jobs (their start-up counted)")
    p.add_argument("--jobs", type=int, default=4, metavar="N", help="with --cluster")
    p.add_argument("--max-points", type=int, default=DEFAULT_MAX_POINTS)
    p.add_argument("--record", action="store_true",
                   help="remember the estimates in the store, so that the next plan says how "
                   "far off they were (plan writes nothing otherwise)")
    _device_option(p)
    p.set_defaults(func=cmd_plan)
    add_gallery_commands(sub, common)   # scenes, gallery, --scene (cli.gallery_commands)
    add_web_commands(sub, common)     # web, serve --web (cli.web_commands)
    return ap


def _device_option(p) -> None:
    p.add_argument("--device", choices=("cpu", "cuda"),
                   help="where the points are integrated (default: the spec's device, cpu): "
                   "cuda = this machine's NVIDIA GPU, one thread a point (docs/GPU.md); "
                   "another sweep id than the CPU's")


def _cluster_options(p) -> None:
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", help="address of an existing dask scheduler, tcp://HOST:PORT")
    where.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    where.add_argument("--cluster", choices=tuple(BATCH_KINDS),
                       help="workers as batch jobs through dask-jobqueue, configured the dask "
                       "way (jobqueue.KIND.* : docs/BATCH.md)")
    p.add_argument("--jobs", type=int, default=4, metavar="N",
                   help="with --cluster: at most N batch jobs, one single-threaded worker each "
                   "(never more than blocks to compute; default 4)")
    p.add_argument("--dashboard", metavar="ADDR",
                   help="start the local cluster's dask dashboard at ADDR (e.g. :8787; needs "
                   "bokeh) and print its link; default: no dashboard")


def _version() -> str:
    from ..version import __version__

    return __version__



def entry() -> int:
    """The ``ditherlab`` program: :func:`main`, then a quick exit. At interpreter shutdown
    Python's last garbage collections walk every object the run left, and numba's and
    llvmlite's number in the hundreds of thousands: 0.3-0.4 s of a 2 s command, measured
    on the averaged Fig. 9 chart. ``gc.freeze()`` hides them from the collector once the
    command is done (its work is on disk). Tests call :func:`main` directly."""
    import gc

    try:
        return main()
    finally:
        gc.freeze()


def main(argv: list[str] | None = None) -> int:
    """Run one command; every fault ends in one line on stderr and the exit status of the
    README (0 ok, 1 failed, 2 refused, 130 interrupted), never a traceback
    (``DITHERLAB_DEBUG=1`` shows the traceback of an unexpected error)."""
    args = build_parser().parse_args(argv)
    for option in ("workers", "jobs"):
        if getattr(args, option, 1) is not None and getattr(args, option, 1) < 1:
            print(f"ditherlab: --{option} must be >= 1", file=sys.stderr)
            return EXIT_REFUSED
    verbosity = -1 if getattr(args, "quiet", False) else int(getattr(args, "verbose", False))
    with _one_line_warnings(verbosity):
        try:
            return args.func(args)
        except (SpecError, ModelError) as exc:   # (a brought model's fault: a crash in plan)
            return _fail(exc, EXIT_REFUSED)
        except (UserError, Interrupted) as exc:
            if isinstance(exc, Interrupted):   # (Ctrl-C or SIGTERM)
                _quiet_finalizers()
            return _fail(exc, exc.exit_status)
        except KeyboardInterrupt:
            _quiet_finalizers()
            return _fail("interrupted", EXIT_INTERRUPTED)
        except BrokenPipeError as exc:
            if not _stdout_closed():      # a pipe of the run's own (dask): a fault
                return _fail_unexpected(exc)
            # `ditherlab status | head`: the reader has what it wanted. A command that only
            # prints (status, query, scenes, plan) succeeded, as when its output fitted the
            # pipe before head closed it (pipefail-safe); a run cut short by it has not
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 0 if args.command in ("status", "query", "scenes", "plan") else EXIT_FAILED
        except Exception as exc:  # noqa: BLE001 -- the one-line promise (README)
            return _fail_unexpected(exc)


def _stdout_closed() -> bool:
    """True when the reader of our standard output has gone. Asked of the kernel, not by a
    second flush: the failed write has already dropped the buffer, so a flush would succeed
    and call the closed pipe a fault (`ditherlab scenes | head -1` printed "Broken pipe").
    On Linux a pipe or socket whose reader has closed polls as POLLERR (or POLLHUP)."""
    import select

    try:
        fd = sys.stdout.fileno()
        poller = select.poll()
    except (AttributeError, OSError, ValueError):   # no poll (Windows) or no real stdout
        try:
            if sys.stdout is not None:   # None: started with stdout closed (>&-)
                sys.stdout.flush()
        except BrokenPipeError:
            return True
        return False
    poller.register(fd, select.POLLOUT)
    return any(mask & (select.POLLERR | select.POLLHUP) for _, mask in poller.poll(0))


def _quiet_finalizers() -> None:
    """After a Ctrl-C, objects it cut short in their making (an h5netcdf file interrupted in
    its ``__init__``) fail in their finalizers at exit, which Python prints as "Exception
    ignored in ... Traceback" below the one line (tests/e2e/test_faults.py's Ctrl-C test
    under load). Those reports are dropped from here on (``DITHERLAB_DEBUG=1`` keeps them)."""
    if not os.environ.get("DITHERLAB_DEBUG"):
        sys.unraisablehook = lambda info: None


def _fail(message, status: int) -> int:
    if "sweeps.run.phases" in sys.modules:   # the progress bars end first: the line alone
        sys.modules["sweeps.run.phases"].close_bars()
    print(f"ditherlab: {message}", file=sys.stderr)
    return status


def _fail_unexpected(exc: Exception) -> int:
    """Store faults (disk full, read-only, damaged files), OS, SQLite errors, bugs: a line."""
    import sqlite3

    import store

    if os.environ.get("DITHERLAB_DEBUG"):
        raise exc
    if isinstance(exc, store.layout.StoreError):
        return _fail(exc, exc.exit_status)
    if isinstance(exc, OSError):
        where = f" ({exc.filename})" if exc.filename else ""
        return _fail(f"{exc.strerror or exc}{where}", EXIT_FAILED)
    if isinstance(exc, sqlite3.Error):
        if "full" in str(exc):   # SQLite's "database or disk is full"
            return _fail(f"no space left on device writing the catalogue ({exc}): free "
                         "some space and run the command again", EXIT_FAILED)
        return _fail(f"catalogue error: {exc}", EXIT_FAILED)
    text = f"{type(exc).__name__}: {exc}".replace("\n", " ")
    return _fail(f"internal error: {text[:300]} (DITHERLAB_DEBUG=1 shows the traceback)",
                 EXIT_FAILED)


class _OneLine:
    """``ditherlab: <message>`` for information, ``ditherlab: warning: <message>`` above."""

    def format(self, record) -> str:
        kind = "warning: " if record.levelno >= 30 else ""
        return f"ditherlab: {kind}{record.getMessage()}".replace("\n", " ")


@contextmanager
def _one_line_warnings(verbosity: int = 0):
    """Warnings (a journal block set aside) and log records of the ``ditherlab`` logger
    as one line each; ``verbosity`` -1 (``-q``) shows warnings only, 0 information too,
    1 (``-v``) everything (debug: timings)."""
    import logging
    import warnings

    def show(message, category, filename, lineno, file=None, line=None):
        text = str(message).replace("\n", " ")
        print(f"ditherlab: warning: {text}", file=file or sys.stderr)

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_OneLine())
    logger = logging.getLogger("ditherlab")
    level = logger.level
    logger.setLevel({-1: logging.WARNING, 0: logging.INFO, 1: logging.DEBUG}[verbosity])
    saved = warnings.showwarning
    warnings.showwarning = show
    logger.addHandler(handler)
    try:
        yield
    finally:
        warnings.showwarning = saved
        logger.removeHandler(handler)
        logger.setLevel(level)   # a command run in-process leaves the caller's logging as it was




if __name__ == "__main__":   # python -m sweeps.cli.main (python -m sweeps.cli works too)
    sys.exit(main())
