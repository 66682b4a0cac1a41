"""The fixed costs around a sweep's points (issue 37): the error estimate's re-runs among the
blocks, longest expected first; a small sweep on threads of the submitting process, writing
the cube a cluster writes; one compilation of a scene per machine; a kill while the
re-runs run among the blocks leaves a resumable sweep.

Here the order of the tasks and the pricing of a small sweep; what needs a cluster or
processes: tests/e2e/test_fixed_costs.py."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from sweeps.estimates.error_reruns import SampleRuns
from sweeps.planning.plan import make_plan, work_s
from sweeps.run import local
from sweeps.run.submit import small
from sweeps.spec import parse_spec
from sweeps.workers import task
from sweeps.workers.threads import ThreadClient


# 16 points, 4 omegas: blocks of one omega each cost alike, and the re-runs (one level
# finer, 11 of the 16 points) cost more or less than a block
SPEC = {"name": "fixed-costs", "friction": "lugre", "dither": "square-velocity",
        "method": "simulate", "outputs": ["v_mean", "F_mean"], "accuracy": "draft",
        "block_size": 2, "time": {"t_end": 6.0, "t_transient": 2.0},
        "grid": {"W": [0.1, 0.3, 0.5, 0.7], "omega": [100.0, 300.0, 1000.0, 3000.0],
                 "v_ref": [0.4], "v_d": [0.1]}}


class _Sink:
    """What the local dispatch needs of a BlockSink: journal nothing, never stop."""

    def __init__(self):
        self.blocks = []

    def __call__(self, b, record):
        self.blocks.append(b)

    def should_stop(self):
        return False


class _Bar:
    def update(self, n):
        pass

    def set_postfix_str(self, text):
        pass

    def keep_alive(self):
        pass


def test_reruns_and_blocks_start_longest_expected_first(monkeypatch):
    """One thread: the tasks start in the order of their expected cost, the re-runs (one
    level finer) merged with the blocks, not after them."""
    plan = make_plan(parse_spec(SPEC))
    sample = SampleRuns(plan)
    started = []
    lock = threading.Lock()

    def record(scene, points, p, settings, index=None, sizes=None, kind=None):
        with lock:
            started.append(("rerun" if settings == sample.finer.settings else "block",
                            tuple(np.asarray(index).tolist())))
        return None

    monkeypatch.setattr(task, "compute_block", record)
    todo = list(range(len(plan.blocks)))[::-1]   # any order in: longest first out
    with ThreadClient(1) as pool:
        local._dispatch_local(pool, plan, todo, _Sink(), _Bar(), sample)
        while sample.submit_next(pool):   # those left after the last block: the estimate's
            pass
        pool.gather(list(sample.futures.values()))
    cost = {("block", tuple(plan.blocks[b].tolist())): work_s(plan, plan.blocks[b])
            for b in todo}
    cost.update({("rerun", (int(i),)): c for i, c in
                 zip(sample.index[sample.order], sample.costs)})
    assert sorted(started) == sorted(cost), started
    costs = [cost[t] for t in started]
    assert costs == sorted(costs, reverse=True), list(zip(started, costs))
    kinds = [k for k, _ in started]   # the costliest re-runs first, the cheapest last
    assert kinds[0] == kinds[-1] == "rerun" and "block" in kinds, kinds


def test_a_gpu_sweeps_reruns_run_beside_its_launches_not_behind_them(monkeypatch):
    """On a GPU sweep each launch holds a thread of the pool until the device is done, and
    the re-runs (CPU work, finer_numerics) waited behind them: on an H200 a 1,000 x 1,000
    map's 12 re-runs had not started 125 s into its launches. They now run on threads of
    their own (local._rerun_pool), all submitted before the first launch: here every
    launch waits until every re-run is back, which only they can be, and the re-runs run
    on the re-run threads. (The old dispatch sent only the re-runs costlier than a launch
    first and then filled its window with launches: the rest waited behind the held
    launches for ever; the finally below releases them if the dispatch fails so.)"""
    plan = make_plan(parse_spec({**SPEC, "device": "cuda"}))
    assert plan.numerics.settings.device == "cuda"
    sample = SampleRuns(plan)
    reruns_back = threading.Event()
    lock, back, launches, where = threading.Lock(), [], [], set()

    def compute(scene, points, p, settings, index=None, sizes=None, kind=None):
        if kind == "rerun":
            with lock:
                back.append(int(np.asarray(index)[0]))
                where.add(threading.current_thread().name.rsplit("_", 1)[0])
                if len(back) == len(sample.order):
                    reruns_back.set()
        else:   # a launch: its thread held until the device is done
            reruns_back.wait()
            with lock:
                launches.append(kind)
        return None

    monkeypatch.setattr(task, "compute_block", compute)
    todo = list(range(len(plan.blocks)))
    assert len(todo) > local.GPU_LAUNCHES + 1   # more launches than the pool's window
    with ThreadClient(local.GPU_LAUNCHES) as pool, \
            local._rerun_pool(pool, 2, gpu=True) as reruns_on:
        assert reruns_on is not pool
        try:
            local._dispatch_local(pool, plan, todo, _Sink(), _Bar(), sample, reruns_on)
        finally:
            reruns_back.set()   # (a failed dispatch leaves no launch held: the pool closes)
    assert sorted(back) == sorted(int(i) for i in sample.index)
    assert where == {"ditherlab-rerun"}, where
    assert len(launches) == len(todo)
    with ThreadClient(2) as pool, local._rerun_pool(pool, 2, gpu=False) as reruns_on:
        assert reruns_on is pool   # on the CPU the re-runs go among the blocks, as before


def test_cheap_reruns_share_a_task_and_come_back_in_sample_order(tmp_path, monkeypatch):
    """Re-runs cheaper than a task's worth share one task (issue 37: a task each cost the
    submitter more than the re-run); gathered, they are the record one task each gives,
    in sample order; the progress counts re-runs, not tasks, and so do the tests' hooks
    and the block log (a line per re-run)."""
    log = tmp_path / "blocks.log"
    monkeypatch.setenv(task.BLOCK_LOG_ENV, str(log))
    plan = make_plan(parse_spec(SPEC))
    one_each, grouped = SampleRuns(plan), SampleRuns(plan)
    with ThreadClient(1) as pool:
        alone = one_each.gather(pool)
        n = len(one_each.order)
        assert len(one_each.groups) == n > 5
        assert grouped.submit_next(pool, at_most_s=sum(grouped.costs[:5]))
        assert [len(g) for _, g in grouped.groups] == [5]
        together = grouped.gather(pool)   # the rest one a task
    assert [len(g) for _, g in grouped.groups] == [5] + [1] * (n - 5)
    assert grouped.finished() == n and grouped.running() == 0
    np.testing.assert_array_equal(together.index, alone.index)
    np.testing.assert_array_equal(together.index, grouped.index)
    for k in alone.outputs:
        np.testing.assert_array_equal(together.outputs[k], alone.outputs[k])
    assert len(log.read_text().splitlines()) == 2 * n


def test_reruns_group_to_a_task_of_measured_seconds(monkeypatch):
    """A re-run group's expected seconds: MIN_TASK_S at the price the blocks back so far
    measured (2 s measured for 20 s expected: 10x cheaper than priced); one re-run a task
    until a block is back."""
    from sweeps.planning.plan import MIN_TASK_ENV, MIN_TASK_S
    from sweeps.run.order import rerun_group_s

    monkeypatch.delenv(MIN_TASK_ENV, raising=False)   # (the default floor)
    assert rerun_group_s([0.0, 0, 0.0]) == 0.0
    assert rerun_group_s([2.0, 10, 20.0]) == pytest.approx(10 * MIN_TASK_S)


def test_a_sweep_priced_below_a_cluster_start_is_small():
    assert small(make_plan(parse_spec(SPEC)), list(range(8)), 2)
    big = {**SPEC, "time": {"t_end": 3000.0, "t_transient": 4.0}, "accuracy": "standard"}
    plan = make_plan(parse_spec(big))
    assert not small(plan, list(range(len(plan.blocks))), 2)




class _Stop(Exception):
    pass


def _early_starts(plan, store, monkeypatch) -> list:
    """What a submit of ``plan`` does before it reads the store: ``[("start", n_blocks)]``
    for each cluster start asked for, then ``"read"`` (the run is stopped there). The plan
    is priced as needing a cluster; nothing is started."""
    from sweeps.run import submit as submitting
    from sweeps.workers.compute import Compute

    seen = []
    monkeypatch.setattr(submitting, "small", lambda *a: False)
    monkeypatch.setattr(Compute, "start_early", lambda self, n, warm: seen.append(("start", n)))

    def read(self):
        seen.append("read")
        raise _Stop

    monkeypatch.setattr(submitting.Submission, "read", read)
    with pytest.raises(_Stop):
        submitting.submit(plan, store)
    return seen


def test_the_cluster_starts_before_the_store_is_read_for_a_new_and_a_resumed_sweep(
        tmp_path, monkeypatch):
    """Issue 37: the start overlaps reading the journal, also when a run resumes: for the
    blocks without a journal file; a sweep whose blocks are all journaled reads first
    (whether it needs a cluster, for failed points or the error estimate, is known then)."""
    from sweeps.run.submit import submit
    from sweeps.workers.compute import Compute

    plan = make_plan(parse_spec(SPEC))
    store = tmp_path / "store"
    n = len(plan.blocks)
    with monkeypatch.context() as m:
        assert _early_starts(plan, store, m) == [("start", n), "read"]
    submit(plan, store, Compute(workers=1), max_blocks=3)   # small: on a thread here
    with monkeypatch.context() as m:
        assert _early_starts(plan, store, m) == [("start", n - 3), "read"]
    submit(plan, store, Compute(workers=1))
    with monkeypatch.context() as m:
        assert _early_starts(plan, store, m) == ["read"]


def test_a_submitter_that_will_attach_starts_no_cluster(tmp_path, monkeypatch):
    """A sweep another live process runs: a second submit attaches to it and computes
    nothing, so it starts no workers on the cores that run is using (it started two and
    stopped them unused). Once the holder is gone, the start overlaps the read again."""
    import os

    import store as store_module
    from store.lease import owner_tag
    from sweeps.run.submit import submit
    from sweeps.workers.compute import Compute

    plan = make_plan(parse_spec(SPEC))
    store = tmp_path / "store"
    submit(plan, store, Compute(workers=1), max_blocks=3)   # small: on a thread here
    catalogue, host = store_module.Catalogue(store), owner_tag().rpartition(":")[0]
    got, _ = catalogue.acquire(plan.sweep_id, f"{host}:{os.getppid()}")   # a live process
    assert got
    with monkeypatch.context() as m:
        assert _early_starts(plan, store, m) == ["read"]
    catalogue.update(plan.sweep_id, owner=f"{host}:999999999")   # no such process: stalled
    with monkeypatch.context() as m:
        assert _early_starts(plan, store, m) == [("start", len(plan.blocks) - 3), "read"]


class _Finished:
    """A finished task as the dispatch sees one: its status and its exception."""

    def __init__(self, exc=None):
        self.status, self._exc = ("error" if exc else "finished"), exc

    def done(self) -> bool:
        return True

    def exception(self):
        return self._exc

    def result(self, timeout=None):   # (held by SampleRuns.take; the test ends before use)
        return None


def test_a_rerun_dask_gave_up_itself_is_ditherlabs_line_not_killed_workers_text():
    """A brought model's re-run whose workers kept dying: when dask gives the task up
    (KilledWorker, its allowed-failures) before rescue() does, gather says so in the line a
    block gets (sweeps.workers.deaths.crash_line). Before, the estimate's warning carried
    dask's own text: seen in the crashing-law test with allowed-failures = 1 under load."""
    from distributed import KilledWorker

    runs = SampleRuns(make_plan(parse_spec(SPEC)))
    runs.deaths.counting = True   # (a brought model's run)
    for k, i in enumerate(runs.order):
        f = _Finished(KilledWorker("compute_block-x", None, 1) if k == 0 else None)
        runs.futures[int(i)] = f
        runs.groups.append((f, [int(i)]))

    class Client:
        cancelled: list = []

        def cancel(self, futures):
            self.cancelled.append(futures)

        def gather(self, futures):
            raise AssertionError("a given-up re-run is not gathered")

    client = Client()
    with pytest.raises(RuntimeError, match=r"^a re-run was given up: \d+ worker processes died "
                       r"computing it \(a crash in compiled code"):
        runs.gather(client)
    assert client.cancelled   # the other re-runs are cancelled, not left running


def test_a_brought_models_reruns_on_threads_are_gathered():
    """A brought model's re-runs on threads (a GPU sweep's estimate): counting deaths, the
    check for a task dask gave up must pass a thread's future by (it has no ``status``:
    an AttributeError ended the estimate in f878fd9)."""
    runs = SampleRuns(make_plan(parse_spec(SPEC)))
    runs.deaths.counting = True   # (a brought model's run)
    with ThreadClient(2) as client:
        record = runs.gather(client)
    assert len(record.status) == len(runs.order) and (record.status == 0).all()
