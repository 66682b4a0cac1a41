"""Fixtures of the tests that run sweeps (here and in tests/e2e, whose conftest shares
them): a spec file, the environment of the processes a test starts, the block gate. The
specs, the gate's class and the wait loop are tests/helpers.py's (imported here too for
the modules that take them from this conftest)."""
import os
from pathlib import Path

import pytest

from ..helpers import (AVERAGED_SPEC, SIMULATE_SPEC, BlockGate, as_a_terminal_job,  # noqa: F401
                       gated)


@pytest.fixture
def spec_file(tmp_path):
    def write(text: str, name: str = "spec.toml") -> Path:
        path = tmp_path / name
        path.write_text(text)
        return path
    return write


@pytest.fixture
def env(tmp_path):
    """The environment of the CLI processes a test starts: blocks counted in
    ``blocks.log`` (sweeps.workers.task, ``$DITHERLAB_BLOCK_LOG``)."""
    return {**os.environ, "MPLBACKEND": "Agg", "DITHERLAB_BLOCK_LOG": str(tmp_path / "blocks.log")}


@pytest.fixture
def gate(tmp_path, env):
    """A shut :class:`BlockGate` in ``env`` (the test's ``env`` fixture): the processes
    started with ``env`` hold every block until the test lets it through."""
    held = BlockGate(tmp_path / "block-gate")
    gated(env, held.path)
    yield held
    held.open()
