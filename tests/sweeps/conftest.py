"""Specs and fixtures of the end-to-end tests through the real command line (the command
itself and the wait loop: tests/helpers.py)."""
import os
import signal
from pathlib import Path

import pytest


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


@pytest.fixture
def spec_file(tmp_path):
    def write(text: str, name: str = "spec.toml") -> Path:
        path = tmp_path / name
        path.write_text(text)
        return path
    return write


class BlockGate:
    """The test's end of ``$DITHERLAB_BLOCK_GATE`` (sweeps.workers.block_gate): a FIFO every block
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


@pytest.fixture
def env(tmp_path):
    """The environment of the CLI processes a test starts: blocks counted in
    ``blocks.log`` (sweeps.workers.task, ``$DITHERLAB_BLOCK_LOG``)."""
    return {**os.environ, "MPLBACKEND": "Agg", "DITHERLAB_BLOCK_LOG": str(tmp_path / "blocks.log")}


@pytest.fixture
def gate(tmp_path, env):
    """A shut :class:`BlockGate` in ``env`` (the test's ``env`` fixture): the processes
    started with ``env`` hold every block until the test lets it through."""
    from sweeps.workers.block_gate import GATE_ENV

    held = BlockGate(tmp_path / "block-gate")
    env[GATE_ENV] = str(held.path)
    yield held
    held.open()
