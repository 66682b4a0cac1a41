"""What the dispatch does with a task whose worker processes died running it
(sweeps.workers.deaths), and how long a run waits for its own local cluster's workers to
come back (sweeps.workers.matching.WorkerCheck). The whole path, with a law that crashes its
worker, is tests/e2e/test_crashing_model.py."""
from __future__ import annotations

import time
from types import SimpleNamespace

import pytest

from sweeps.workers import deaths as D
from sweeps.workers import matching


def test_a_task_of_several_blocks_that_killed_a_worker_is_split_and_nobody_is_blamed():
    d = D.Deaths()
    again, lost = d.requeue([3, 4, 5], died=2)
    assert (again, lost) == ([3, 4, 5], [])
    assert d.alone == {3, 4, 5} and d.of_block == {}


def test_a_block_is_given_up_once_its_tasks_killed_more_workers_than_dask_allows():
    d = D.Deaths()
    assert d.allowed == 3   # distributed.scheduler.allowed-failures, dask's default
    assert d.requeue([7], died=0) == ([7], [])   # its workers were retired: no death
    assert d.requeue([7], died=2) == ([7], [])   # both workers of a local cluster died
    assert d.requeue([7], died=1) == ([7], [])   # 3: still allowed
    assert d.requeue([7], died=1) == ([], [7])   # 4 > 3: given up
    assert 7 in d.alone and d.of_block[7] == 4
    assert D.crash_line(4).startswith("4 worker processes died computing it")


def test_an_unknown_count_charges_one_death_to_a_block_that_ran_alone():
    """A scheduler that cannot be asked (distributed.scheduler.pickle off): the blocks go
    alone, and each orphaning alone counts 1, so a crasher is still given up in the end
    (before this, an unknown count on a block not yet alone stayed 0 for ever)."""
    d = D.Deaths()
    assert d.requeue([1, 2], died=None) == ([1, 2], []) and d.of_block == {}  # not alone yet
    assert d.alone == {1, 2}
    for _ in range(3):
        assert d.requeue([1], died=None) == ([1], [])
    assert d.requeue([1], died=None) == ([], [1]) and d.of_block == {1: 4}


def test_the_engines_own_models_are_never_given_up():
    """Only a brought model's run counts deaths: a worker that left for another reason (a
    batch job's walltime, a preemption) is an unexpected removal to dask too."""
    d = D.Deaths(counting=False)
    for _ in range(10):
        assert d.requeue([7], died=4) == ([7], [])
    assert d.of_block == {} and d.alone == set()


def _clock(monkeypatch, monotonic) -> None:
    """``matching``'s own clock (its module-level ``time``), not the process's: a thread left
    by an earlier test (a dask or asyncio loop) reads ``time.monotonic`` too."""
    monkeypatch.setattr(matching, "time", SimpleNamespace(monotonic=monotonic,
                                                          sleep=time.sleep))


class _NoWorkers:
    def nthreads(self):
        return {}


def test_a_local_cluster_without_workers_ends_the_run_after_its_bound(monkeypatch):
    clock = iter([100.0, 130.0, 161.0])
    _clock(monkeypatch, lambda: next(clock))
    check = matching.WorkerCheck(_NoWorkers())
    check.back_within_s = 60.0
    assert check.matching() == {}   # t = 100: none since now
    assert check.matching() == {}   # t = 130: 30 s
    with pytest.raises(matching.WorkersGoneError, match="none has started again for 60 s"):
        check.matching()            # t = 161: 61 s


def test_a_local_cluster_without_workers_is_scaled_again_once_before_it_gives_up(monkeypatch):
    """dask's LocalCluster drops a nanny now and then when its worker keeps crashing (with
    plain dask: no worker and no nanny left after 18-24 segfaulting tasks); after REVIVE_S
    without a worker the cluster is asked for its workers again, once per such gap."""
    clock = iter([0.0, 5.0, 11.0, 30.0, 31.0, 50.0])
    _clock(monkeypatch, lambda: next(clock))
    asked = []
    check = matching.WorkerCheck(_NoWorkers())
    check.back_within_s, check.revive = 60.0, lambda: asked.append(1)
    for _ in range(4):
        check.matching()            # t = 0, 5: waiting; 11: revived; 30: not again
    assert asked == [1]
    check._check_gone(True)         # a worker came back: the next gap may revive again
    check.matching()                # t = 31: none since now
    check.matching()                # t = 50: 19 s, over REVIVE_S
    assert asked == [1, 1]


def test_other_clusters_wait_for_their_workers_at_will(monkeypatch):
    _clock(monkeypatch, lambda: pytest.fail("no clock needed"))
    check = matching.WorkerCheck(_NoWorkers())   # a batch or external cluster: no bound
    assert check.matching() == {} and check.matching() == {}
