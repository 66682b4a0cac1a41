"""A Ctrl-C that is never lost.

Python raises KeyboardInterrupt wherever the main thread happens to be when SIGINT
arrives. When that is inside a weakref callback or a ``__del__`` (dask's futures and
clients run many), the exception is printed as "Exception ignored in ..." and dropped,
and a submitter runs on as if nobody had pressed Ctrl-C (seen under load in
tests/e2e/test_service.py's Ctrl-C test). :func:`remembered` installs a SIGINT handler
that notes the signal before raising; the dispatch loop calls :func:`check` every tick,
which raises it again if it was swallowed. Python reports a swallowed exception through
``sys.unraisablehook`` as "Exception ignored in ... Traceback ... KeyboardInterrupt" on
stderr, which the user would read as a crash beside the one line the interrupt ends with
(seen under load in tests/e2e/test_faults.py's Ctrl-C test): while inside, such a
KeyboardInterrupt is not printed (:func:`check` raises it); any other unraisable exception
is reported as before. Installed only over Python's default handler (``serve`` has its
own: the first SIGINT stops gracefully, sweeps.service).
"""
from __future__ import annotations

import signal
import sys
import threading
from contextlib import contextmanager

_pressed = threading.Event()
_terminated = threading.Event()   # ... and the signal was SIGTERM (terminated_as_interrupt)


def _note_and_raise(signum, frame):
    _pressed.set()
    raise KeyboardInterrupt


@contextmanager
def remembered():
    """While inside, a SIGINT that something swallowed is raised again by :func:`check`."""
    main = threading.current_thread() is threading.main_thread()
    if not main or signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield
        return
    _pressed.clear()
    previous = signal.signal(signal.SIGINT, _note_and_raise)
    report = sys.unraisablehook

    def unraisable(info) -> None:
        if not (issubclass(info.exc_type, KeyboardInterrupt) and _pressed.is_set()):
            report(info)

    sys.unraisablehook = unraisable
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        sys.unraisablehook = report
        _pressed.clear()


def check() -> None:
    """Raise KeyboardInterrupt if a SIGINT arrived (and was swallowed) since the last check."""
    if _pressed.is_set():
        _pressed.clear()
        if _terminated.is_set():
            from ..errors import Terminated
            raise Terminated
        raise KeyboardInterrupt


@contextmanager
def terminated_as_interrupt():
    """While inside (the main thread of ``ditherlab submit``), SIGTERM raises
    :class:`sweeps.errors.Terminated`, a KeyboardInterrupt: the run stops as at a Ctrl-C,
    and one that something swallowed is raised again by :func:`check` (inside
    :func:`remembered`, whose hook keeps it unprinted)."""
    from ..errors import Terminated

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminate(signum, frame):   # noted as a Ctrl-C is: check() raises it again
        _terminated.set()
        _pressed.set()
        raise Terminated

    _terminated.clear()
    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
        _terminated.clear()
