"""What tests of every folder share: the ``ditherlab`` command (:data:`BIN`, :func:`ditherlab`),
the command line run in this process (:func:`in_process`), the one wait loop
(:func:`wait_for`): a condition polled until it holds, a deadline that fails the test with
what was awaited, and the process the test depends on checked alive on every poll; and a
clock that ticks (:func:`ticking_clock`) for code that takes one, instead of sleeps."""
from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import time
from datetime import datetime, timedelta, timezone
from pathlib import Path

BIN = Path(sys.executable).parent / "ditherlab"


def ditherlab(*args, store=None, env=None, check=False, text=True,
              timeout=600) -> subprocess.CompletedProcess:
    """``ditherlab ARGS [--store STORE]`` as a process, output captured (``text=False``:
    bytes, to compare with a download); ``check``: fail the test on a non-zero exit."""
    cmd = [str(BIN), *map(str, args)] + (["--store", str(store)] if store is not None else [])
    proc = subprocess.run(cmd, capture_output=True, text=text, timeout=timeout,
                          env=env if env is not None else {**os.environ, "MPLBACKEND": "Agg"})
    if check and proc.returncode != 0:
        raise AssertionError(f"{cmd} -> {proc.returncode}\n{proc.stdout}\n{proc.stderr}")
    return proc


def in_process(*argv) -> tuple[int, str, str]:
    """``(exit status, stdout, stderr)`` of ``sweeps.cli.main(argv)`` run in this process
    (no start-up cost: for refusals and listings)."""
    from sweeps.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main([str(a) for a in argv])
    return status, out.getvalue(), err.getvalue()


def wait_for(condition, what: str, seconds: float = 600, poll: float = 0.2, process=None):
    """Poll ``condition()`` until it returns something true, and return that. Fails the
    test (AssertionError naming ``what``) after ``seconds``, or as soon as ``process`` (a
    ``subprocess.Popen`` the wait depends on) has exited, with its output."""
    t0 = time.monotonic()
    while True:
        value = condition()
        if value:
            return value
        if process is not None and process.poll() is not None:
            out, err = process.communicate()
            raise AssertionError(f"waiting for {what}: the process exited "
                                 f"({process.returncode}): {out!s:.500} {err!s:.2000}")
        if time.monotonic() - t0 > seconds:
            raise AssertionError(f"timed out after {seconds:.0f} s waiting for {what}")
        time.sleep(poll)


def ticking_clock(step=timedelta(milliseconds=1)):
    """A clock (a callable returning a UTC ``datetime``) that moves ``step`` forward at
    every reading: the times a catalogue writes are distinct and ordered as the calls."""
    now = [datetime(2026, 1, 1, tzinfo=timezone.utc)]

    def clock() -> datetime:
        now[0] += step
        return now[0]

    return clock
