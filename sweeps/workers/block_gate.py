"""A gate the tests hold blocks back with (diagnostics, like ``$DITHERLAB_BLOCK_LOG``).

With ``$DITHERLAB_BLOCK_GATE`` naming a FIFO (``os.mkfifo``), every block computation
(:func:`sweeps.workers.task.compute_block`, in whichever process runs it) takes one byte from it
before it starts, and waits while there is none: the test holding the FIFO's write end lets
exactly as many blocks through as it writes bytes, and closing it opens the gate for good.
So a test can stop a sweep, or start a second submitter, while blocks are certainly still
to run, instead of hoping that the machine is slow enough (no timing luck).
"""
from __future__ import annotations

import os
import select

GATE_ENV = "DITHERLAB_BLOCK_GATE"


def pass_gate(path: str) -> None:
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
