"""Beyond the submitter's ceiling the dispatch gives each task several blocks
(sweeps.planning.plan.blocks_per_task): the workers then ask for fewer tasks a second, and
the journal still receives every block, each with its own points' results.

Here the rule; the dispatch on a dask cluster: tests/e2e/test_blocks_per_task.py."""
from __future__ import annotations

import pytest

from sweeps.planning.plan import blocks_per_task


def test_one_block_a_task_below_the_ceiling_more_beyond():
    assert blocks_per_task(2, 1.0, 1000, ceiling=200) == 1          # a workstation
    assert blocks_per_task(200, 1.0, 10**5, ceiling=200) == 1       # at the ceiling
    assert blocks_per_task(1000, 1.0, 10**5, ceiling=200) == 5      # 1000 / 5 s = 200/s
    assert blocks_per_task(1000, 0.01, 10**6, ceiling=200) == 500   # cheap blocks
    assert blocks_per_task(1000, 1.0, 2500, ceiling=200) == 2       # every thread gets one
    assert blocks_per_task(1000, 1.0, 10, ceiling=200) == 1
    assert blocks_per_task(0, 1.0, 10) == blocks_per_task(4, 0.0, 10) == 1


def test_no_task_shorter_than_min_task_s(monkeypatch):
    """Cheap blocks go several to a task on a workstation too (issue 37): each task costs
    the submitter, on the workers' cores, 10-25 ms of CPU. ``$DITHERLAB_MIN_TASK_S`` sets
    another floor (0: one block a task); a bad value is one clear error, when the run's
    Compute is made."""
    from sweeps.errors import RefusedError
    from sweeps.planning.plan import MIN_TASK_ENV, MIN_TASK_S
    from sweeps.workers.compute import Compute

    monkeypatch.delenv(MIN_TASK_ENV, raising=False)
    assert blocks_per_task(2, MIN_TASK_S / 6, 1000, ceiling=200) == 6
    assert blocks_per_task(2, MIN_TASK_S / 6, 8, ceiling=200) == 4      # both threads get one
    assert blocks_per_task(2, MIN_TASK_S, 1000, ceiling=200) == 1
    monkeypatch.setenv(MIN_TASK_ENV, "0")
    assert blocks_per_task(2, MIN_TASK_S / 6, 1000, ceiling=200) == 1
    monkeypatch.setenv(MIN_TASK_ENV, "1.2")
    assert blocks_per_task(2, MIN_TASK_S / 6, 1000, ceiling=200) == 12
    for bad in ("fast", "-1", "nan", "inf"):
        monkeypatch.setenv(MIN_TASK_ENV, bad)
        with pytest.raises(RefusedError, match=f"{MIN_TASK_ENV} = '{bad}': give a number"):
            blocks_per_task(2, 0.1, 1000)
        with pytest.raises(RefusedError, match=f"{MIN_TASK_ENV} = '{bad}': give a number"):
            Compute(2)   # refused before anything runs (it made no cluster yet)


TASK_POINTS: list[int] = []   # points of each task computed (the workers are threads here)


