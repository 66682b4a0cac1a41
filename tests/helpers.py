"""What tests of every folder share: the specs of the end-to-end tests, the block gate
(:class:`BlockGate`), a Ctrl-C'able child (:func:`as_a_terminal_job`), cubes' results
compared (:func:`results`, :func:`assert_same_results`), the ``ditherlab`` command
(:data:`BIN`, :func:`ditherlab`), the command line run in this process
(:func:`in_process`), the one wait loop
(:func:`wait_for`): a condition polled until it holds, a deadline that fails the test with
what was awaited, and the process the test depends on checked alive on every poll; and a
clock that ticks (:func:`ticking_clock`) for code that takes one, instead of sleeps; and
the CPU seconds of a block of code (:func:`cpu_seconds`), for bounds no machine load moves."""
from __future__ import annotations

import contextlib
import gc
import io
import os
import signal
import subprocess
import sys
import time
import tomllib
from datetime import datetime, timedelta, timezone
from pathlib import Path

from .hooks.ditherlab_test_hooks import GATE_ENV, RERUN_GATE_ENV  # noqa: F401 (tests import them here)

BIN = Path(sys.executable).parent / "ditherlab"
HOOKS = Path(__file__).resolve().parent / "hooks"   # the tests' hooks in a worker's task
TIMING = ("cost_s",)   # wall-clock seconds differ between runs; everything else must not
# a test's own LocalCluster: no dashboard, and the scheduler's HTTP server (health checks)
# on loopback at a free port, as sweeps.workers.cluster starts ours. dashboard_address=None
# alone put that server at 127.0.0.1:8787, a fixed port: with another cluster on the machine
# (the other pytest worker's) dask warned "Port 8787 is already in use" (ss -ltnp checked)
LOOPBACK_CLUSTER = {"dashboard_address": None,
                    "scheduler_kwargs": {"dashboard_address": "127.0.0.1:0"}}


def as_a_terminal_job() -> None:
    """``preexec_fn`` for a submitter that a test Ctrl-C's: SIGINT back to its default, as in
    a terminal's foreground job. A test run started in the background of a script (``.ci/run
    &``, nohup in a non-interactive shell) inherits SIGINT ignored, and Python keeps it
    ignored, so the child would never see the test's Ctrl-C and run to the end."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


SIMULATE_SPEC = """
name = "e2e-sim"
friction = "lugre"
dither = "square-velocity"
method = "simulate"
outputs = ["v_mean", "v_slow_p2p", "F_mean", "stick_fraction", "max_stick"]
accuracy = "draft"
block_size = 2
[time]
t_end = 12.0
t_transient = 4.0
[grid]
W = [0.0, 0.2, 0.4, 0.6]
omega = [300.0, 1000.0]
v_ref = [0.4]
v_d = [0.1]
"""

# its scene's outputs: tests that need a simulated scene take this one, so that one
# compilation serves them all (docs/ARCHITECTURE.md, where the suite's time goes)
SIMULATE_OUTPUTS = tuple(tomllib.loads(SIMULATE_SPEC)["outputs"])

AVERAGED_SPEC = """
name = "e2e-avg"
friction = "lugre"
dither = "square-velocity"
method = "averaged"
[grid]
W = { start = 0.0, stop = 1.0, num = 21 }
v_ref = { start = 0.02, stop = 1.0, num = 25 }
v_d = [0.1]
"""


def gated(env: dict, path, var: str = GATE_ENV) -> dict:
    """``env`` (changed, returned) with the gate at ``path`` (a :class:`BlockGate`'s FIFO or
    a folder of tickets) in ``var`` (``$DITHERLAB_BLOCK_GATE``, or ``RERUN_GATE_ENV`` for the
    error estimate's re-runs), and the tests' hooks (tests/hooks/ditherlab_test_hooks.py) on
    the ``PYTHONPATH`` of the processes started with it and their dask workers: the task
    finds the gates there (sweeps.workers.task.HOOKS_MODULE). One block a task
    (``$DITHERLAB_MIN_TASK_S`` = 0): a task of several blocks is journaled when its last
    block is through, so N blocks let through would not always make N journaled."""
    from sweeps.planning.plan import MIN_TASK_ENV

    paths = [str(HOOKS)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]
    env.update({var: str(path), "PYTHONPATH": os.pathsep.join(dict.fromkeys(paths)),
                MIN_TASK_ENV: "0"})
    return env


class BlockGate:
    """The test's end of ``$DITHERLAB_BLOCK_GATE`` (tests/hooks, :func:`gated`): a FIFO every block
    computation takes a byte from before it starts. ``let(n)`` lets n more blocks start;
    ``open()`` lets every block start from now on. Held shut from creation."""

    def __init__(self, path: Path):
        os.mkfifo(path)
        self.path = path
        self._fd: int | None = os.open(path, os.O_RDWR)   # a writer held: readers wait

    def let(self, n: int) -> None:
        os.write(self._fd, b"x" * n)

    def open(self) -> None:
        if self._fd is not None:
            os.close(self._fd)   # no writer left: every read, now and later, passes
            self._fd = None


def results(cube):
    """A cube's results (``xarray.Dataset``, loaded), all but the wall-clock ``cost_s``."""
    import xarray as xr

    with xr.open_dataset(cube, engine="h5netcdf") as ds:
        return ds.drop_vars(TIMING).load()


def assert_same_results(a, b):
    """Two cubes' :func:`results` identical, values and variables' attributes (the global
    attributes carry times and the run's own facts)."""
    import xarray as xr

    xr.testing.assert_identical(a.drop_attrs(), b.drop_attrs())


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


@contextlib.contextmanager
def cpu_seconds():
    """Measure the CPU seconds of the code in the block, read as ``spent()`` after it:
    the calling thread's alone (``time.thread_time``), with the garbage collector held off.
    Neither a busy machine, nor another thread of the test process, nor a full collection
    of a long-lived worker's heap inflates them. (``process_time``, which counts every
    thread, once read 1.9 s in CI for a parse its neighbouring cases did in 5 ms; which of
    the two it was is not known. No collection before the block either: in a worker that
    had run for 20 minutes, one per fuzzed spec made tests/sweeps/spec/test_spec_fuzz.py
    take 119 s instead of 4.)"""
    was_enabled = gc.isenabled()
    gc.disable()
    t0 = time.thread_time()
    spent = [None]
    try:
        yield lambda: spent[0]
    finally:
        spent[0] = time.thread_time() - t0
        if was_enabled:
            gc.enable()
