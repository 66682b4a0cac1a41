"""Beyond the submitter's ceiling the dispatch gives each task several blocks
(sweeps.planning.plan.blocks_per_task): the workers then ask for fewer tasks a second, and
the journal still receives every block, each with its own points' results.

Here the dispatch on an in-process dask cluster; the rule alone:
tests/sweeps/planning/test_blocks_per_task.py."""
from __future__ import annotations

import threading
from contextlib import contextmanager

import numpy as np
import pytest

from store.record import BlockRecord
from sweeps.planning import plan as planning
from sweeps.planning.plan import make_plan
from sweeps.run import dispatch
from sweeps.spec import parse_spec
from sweeps.version import results_fingerprint
from sweeps.workers import task
from tests.helpers import LOOPBACK_CLUSTER

pytestmark = pytest.mark.cluster   # what it starts (tests/conftest.py)


TASK_POINTS: list[int] = []   # points of each task computed (the workers are threads here)


def _instant(scene, points, p, settings, index, sizes=None):
    """compute_block at once: every output is the point's omega (so a block's values tell
    which points it was given)."""
    TASK_POINTS.append(len(points))
    n = len(points)
    return BlockRecord(index, np.zeros(n), np.full(n, 0.25), np.ones(n), np.ones(n),
                       {k: points[:, 1].copy() for k in scene.outputs},
                       fingerprint=results_fingerprint())


class _Sink:
    def __init__(self):
        self.got: dict[int, dict] = {}

    def should_stop(self) -> bool:
        return False

    def many(self, items) -> None:
        for b, result in items:
            assert b not in self.got
            self.got[b] = result


class _Bar:
    def update(self, n) -> None:
        pass

    def keep_alive(self) -> None:   # (sweeps.run.phases: redrawn while the dispatch waits)
        pass

    def set_postfix_str(self, text) -> None:   # (the re-runs finished: dispatch.show_reruns)
        pass


@contextmanager
def _threads(n: int):
    """A matched client of an in-process dask cluster: one worker of ``n`` threads (the
    monkeypatched compute_block runs there)."""
    from distributed import Client, LocalCluster

    from sweeps.workers.matching import matched

    with LocalCluster(n_workers=1, threads_per_worker=n, processes=False,
                      **LOOPBACK_CLUSTER) as cluster, Client(cluster) as client:
        yield matched(client)


def _plan(name: str, grid: dict):
    """A plan of draft LuGre blocks of 4 points under sine dither over ``grid``."""
    return make_plan(parse_spec({"name": name, "friction": "lugre", "dither": "sine-velocity",
                                 "outputs": ["F_mean"], "accuracy": "draft", "block_size": 4,
                                 "grid": grid}))


def _every(plan) -> list[int]:
    return list(range(len(plan.blocks)))


@pytest.mark.timeout(300)
def test_the_dispatch_groups_blocks_beyond_the_ceiling(monkeypatch):
    plan = _plan("group", {"W": [0.0, 1.0], "omega": {"start": 10.0, "stop": 1000.0,
                                                      "num": 60}})
    # blocks of 4 points that say they took 0.25 s each: 1 s
    monkeypatch.setattr(planning, "SUBMITTER_TASKS_PER_S", 1.0)   # 3 threads: 3 blocks a task
    monkeypatch.setattr(task, "compute_block", _instant)
    monkeypatch.setattr(dispatch, "tail_cap_s", lambda *a: float("inf"))   # (the tail's
    # smaller tasks: test_the_last_tasks_shrink)
    TASK_POINTS.clear()   # (this test's tasks alone, whatever ran before it)
    sink = _Sink()
    with _threads(3) as client:
        dispatch._dispatch(client, plan, _every(plan), sink, _Bar())
    assert sorted(sink.got) == list(range(len(plan.blocks)))
    points = plan.points
    for b, record in sink.got.items():   # each block has its own points' values
        np.testing.assert_array_equal(record.index, plan.blocks[b])
        np.testing.assert_array_equal(record.outputs["F_mean"], points[plan.blocks[b], 1])
    assert max(TASK_POINTS) == 3 * 4 and sum(TASK_POINTS) == plan.n_points   # 3 blocks a task


@pytest.mark.timeout(300)
def test_the_last_tasks_shrink(monkeypatch):
    """Towards the end a task takes at most half of each thread's share of what is left
    (sweeps.run.order.tail_cap_s): groups of 3 blocks while much is left, and single
    blocks once fewer blocks are left than tasks fit in flight (3 threads x DEPTH 2),
    so that no thread runs a last group while the others idle. (30 blocks of one expected
    cost c: with k left the cap is k c / 6, below 2 c once k < 12.)"""
    plan = _plan("tail", {"W": [0.5], "omega": [100.0],   # blocks of equal cost
                          "v_ref": {"start": 0.1, "stop": 0.5, "num": 120}})
    monkeypatch.setattr(planning, "SUBMITTER_TASKS_PER_S", 1.0)   # 3 blocks a task
    monkeypatch.setattr(task, "compute_block", _instant)
    TASK_POINTS.clear()
    sink = _Sink()
    with _threads(3) as client:
        dispatch._dispatch(client, plan, _every(plan), sink, _Bar())
    assert sorted(sink.got) == list(range(len(plan.blocks)))
    assert sum(TASK_POINTS) == plan.n_points and max(TASK_POINTS) == 3 * 4, TASK_POINTS
    assert TASK_POINTS[-6:] == [4] * 6, TASK_POINTS   # the last tasks: a block each


RELEASED = threading.Event()   # the re-runs' gate (the workers are threads of this process)


def _blocks_now_reruns_later(scene, points, p, settings, index, sizes=None, kind="block"):
    """compute_block: a block at once (:func:`_instant`), a re-run once RELEASED is set."""
    if kind == "rerun":
        RELEASED.wait()   # (set in the test's finally: no clock decides when they run)
    return _instant(scene, points, p, settings, index, sizes)


class _Jobs:
    """A batch cluster's Compute as the dispatch sees it: told, every look at the workers,
    how many tasks are left (compute.shrink), which it would end idle jobs below. Records
    each count with the error sample's re-runs still to come at that moment and whether
    every block was back; lets the re-runs go (RELEASED) at the first look after the last
    block."""

    def __init__(self, sample, sink, n_blocks: int):
        self.sample, self.sink, self.n_blocks, self.told = sample, sink, n_blocks, []

    def shrink(self, left: int) -> None:
        blocks_back = len(self.sink.got) == self.n_blocks
        self.told.append((left, self.sample.outstanding(), blocks_back))
        if blocks_back:
            RELEASED.set()


@pytest.mark.timeout(300)
def test_a_batch_cluster_keeps_a_job_for_each_rerun_still_to_come(monkeypatch):
    """The error sample's re-runs run among the blocks and may outlast them; the dispatch
    waits for them too. A batch cluster told "no tasks left" when the last block was back
    ended its idle jobs, and the gather waited for ever for a worker (test_slurm hung so,
    the cube published, both jobs cancelled 4 s after they started). Here the re-runs
    wait until the dispatch has looked at the workers with every block back, so that they
    are certainly still running then."""
    from sweeps.estimates.error_reruns import SampleRuns

    plan = _plan("jobs", {"W": [0.0, 1.0], "omega": {"start": 10.0, "stop": 1000.0,
                                                     "num": 20}})
    sample = SampleRuns(plan)
    sink = _Sink()
    jobs = _Jobs(sample, sink, len(plan.blocks))
    RELEASED.clear()   # (a second run of this test in one process gates its re-runs too)
    monkeypatch.setattr(task, "compute_block", _blocks_now_reruns_later)
    monkeypatch.setattr(dispatch, "REFRESH_S", -1.0)   # a look at the workers every turn,
    # whatever the clock's resolution
    # more threads than re-runs: the blocked re-runs leave threads to the blocks
    with _threads(len(sample.order) + 4) as client:
        try:
            dispatch._dispatch(client, plan, _every(plan), sink, _Bar(), sample=sample,
                               compute=jobs)
        finally:
            RELEASED.set()
        finished_at_return = sample.finished()
        sample.gather(client)
    assert sorted(sink.got) == list(range(len(plan.blocks)))
    assert any(back and left >= to_come > 0 for left, to_come, back in jobs.told), \
        jobs.told   # a look came with every block back and re-runs still running, and the
    # jobs were told of them (left counts nothing else then)
    assert finished_at_return == len(sample.order)   # the dispatch returned after them


HELD = threading.Event()   # the stop test's gate: its running tasks end once it is set


def _held(scene, points, p, settings, index, sizes=None, kind="block"):
    HELD.wait()   # (set by the sink once the dispatch has seen the stop and gone on)
    return _instant(scene, points, p, settings, index, sizes)


class _StoppingSink(_Sink):
    """Asked ``should_stop`` once per turn of the dispatch: no at the first (the first
    tasks are submitted), yes from the second on (a cancel); at the third, the stop has
    been seen, and the running tasks are let go."""

    def __init__(self):
        super().__init__()
        self.asked = 0

    def should_stop(self) -> bool:
        self.asked += 1
        if self.asked >= 3:
            HELD.set()
        return self.asked >= 2


@pytest.mark.timeout(300)
def test_a_stop_collects_every_task_in_flight_the_waiting_ones_too(monkeypatch):
    """Two tasks per thread are in flight (sweeps.run.order.DEPTH); on a stop (a cancel,
    serve's shutdown, a lost lease) the dispatch submits no more and collects them all,
    the ones waiting behind a running task too: none is cancelled, so a block that had
    just started is not lost and computed again on resume (a version that cancelled the
    waiting ones failed tests/e2e/test_service.py's cancel test once in four CI runs)."""
    plan = _plan("stop", {"W": [0.5], "omega": [100.0],
                          "v_ref": {"start": 0.1, "stop": 0.5, "num": 40}})
    HELD.clear()
    monkeypatch.setattr(task, "compute_block", _held)
    sink = _StoppingSink()
    with _threads(2) as client:
        try:
            dispatch._dispatch(client, plan, _every(plan), sink, _Bar())
        finally:
            HELD.set()
    assert sorted(sink.got) == [0, 1, 2, 3]   # 2 threads x DEPTH 2, submitted before the stop
