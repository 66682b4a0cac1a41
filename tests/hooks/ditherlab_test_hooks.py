"""The tests' hooks inside a worker's task: the gates that hold blocks back. Not a module of
ditherlab: ``sweeps.workers.task`` looks this module up by name once per process
(``sweeps.workers.task.HOOKS_MODULE``) and finds it only where a test put this folder on
``PYTHONPATH`` (``tests.helpers.gated``): in the processes the test starts and their dask
workers (local processes or batch jobs inherit the environment). The task calls
:func:`before_block` with the kind of computation alone and uses nothing it returns, so no
hook can change a number; this source is off the computing path (sweeps.version), and the
gates can change without re-iding a sweep.

With ``$DITHERLAB_BLOCK_GATE`` naming a FIFO (``os.mkfifo``), every block computation
(:func:`sweeps.workers.task.compute_block`, in whichever process runs it) takes one byte from it
before it starts, and waits while there is none: the test holding the FIFO's write end lets
exactly as many blocks through as it writes bytes, and closing it opens the gate for good.
So a test can stop a sweep, or start a second submitter, while blocks are certainly still
to run, instead of hoping that the machine is slow enough (no timing luck).

With ``$DITHERLAB_BLOCK_GATE`` naming a folder instead (the batch-system tests, whose workers
are jobs the test does not start), a block takes a ticket (a file ``ticket*``, removed) or
passes once ``open`` exists, and a waiting process shows as ``waiting-<pid>`` there, so the
test knows a worker is up and held.
"""
from __future__ import annotations

import os
import select
import time

GATE_ENV = "DITHERLAB_BLOCK_GATE"
# The error estimate's re-runs (sweeps.estimates.error_reruns) are not blocks: they pass
# $DITHERLAB_BLOCK_GATE freely (they run among the blocks, often first: a test that lets
# three blocks through gets three blocks), and a gate of their own, the same kinds of file,
# when $DITHERLAB_RERUN_GATE names one.
RERUN_GATE_ENV = "DITHERLAB_RERUN_GATE"


def before_block(kind: str) -> None:
    """Called by the task before each computation: ``kind`` ``"block"`` (a block of the
    plan) passes ``$DITHERLAB_BLOCK_GATE``, ``"rerun"`` (an error-estimate re-run)
    ``$DITHERLAB_RERUN_GATE``, each when set."""
    path = os.environ.get(RERUN_GATE_ENV if kind == "rerun" else GATE_ENV)
    if path:
        pass_gate(path)


def pass_gate(path: str) -> None:
    """Pass the gate at ``path``: a folder of tickets, or a FIFO (module docstring)."""
    if os.path.isdir(path):
        _take_ticket(path)
    else:
        _take_byte(path)


def _take_ticket(folder: str) -> None:
    """Wait for a ticket in ``folder`` (taken by removing it) or for ``folder/open``."""
    waiting = os.path.join(folder, f"waiting-{os.getpid()}")
    while not os.path.exists(os.path.join(folder, "open")):
        if not os.path.exists(waiting):
            open(waiting, "w").close()
        for name in sorted(os.listdir(folder)):
            if name.startswith("ticket"):
                try:
                    os.unlink(os.path.join(folder, name))
                    return
                except FileNotFoundError:   # another worker took it
                    continue
        time.sleep(0.05)   # a poll, not a wait for luck: the test decides when tickets exist


def _take_byte(path: str) -> None:
    """Take one byte from the FIFO at ``path``; wait while it is empty and held open."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)   # never waits for a writer to appear
    try:
        while True:
            try:
                os.read(fd, 1)   # one byte: through; b"" (no writer left): the gate is open
                return
            except BlockingIOError:   # empty and held: wait (another worker may win the byte)
                select.select([fd], [], [])
    finally:
        os.close(fd)
