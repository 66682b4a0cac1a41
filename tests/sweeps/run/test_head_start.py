"""sweeps.run.head_start: blocks computed on threads of the submitter while its local
cluster starts (issue 37). Here the rules, with the real kernels and a cluster whose
readiness the test decides (no race to win or lose); a real submit with 4 workers:
tests/e2e/test_fixed_costs.py."""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

from sweeps.planning.plan import make_plan, work_s
from sweeps.run import head_start as hs
from sweeps.spec import parse_spec
from sweeps.workers import local_start, task
from sweeps.workers.compute import LOCAL

from .test_fixed_costs import SPEC as FIXED_COSTS_SPEC

EXAMPLES = Path(__file__).resolve().parents[3] / "docs" / "examples"
SPEC = {**FIXED_COSTS_SPEC, "name": "head-start"}   # 16 points in 8 blocks of 2


class _Compute:
    """A local cluster still starting until ``up`` is set."""

    kind, early = LOCAL, True

    def __init__(self, workers: int = 4):
        self.workers = workers
        self.up = threading.Event()

    def early_ready(self) -> bool:
        return self.up.is_set()


class _Sink:
    def __init__(self, up_after: int | None, compute: _Compute):
        self.got, self.timings = {}, {}
        self.up_after, self.compute = up_after, compute
        self.lock = threading.Lock()

    def __call__(self, b, record):
        with self.lock:
            self.got[b] = record
            if self.up_after is not None and len(self.got) >= self.up_after:
                self.compute.up.set()   # the cluster comes up now

    def should_stop(self):
        return False


@pytest.fixture(autouse=True)
def two_threads(monkeypatch):
    monkeypatch.setattr(local_start, "usable_cores", lambda: 3)   # 2 threads for 4 workers


def test_threads_leave_a_core_and_need_4_workers(monkeypatch):
    for workers, cores, threads in [(2, 2, 0), (3, 16, 0), (4, 2, 1), (4, 16, 3),
                                    (16, 16, 15), (16, 8, 7)]:
        monkeypatch.setattr(local_start, "usable_cores", lambda c=cores: c)
        assert hs.threads_for(_Compute(workers)) == threads, (workers, cores)


def test_the_smallest_blocks_run_here_until_the_cluster_is_up():
    plan = make_plan(parse_spec(SPEC))
    todo = list(range(len(plan.blocks)))
    compute = _Compute()
    sink = _Sink(up_after=3, compute=compute)
    left = hs.head_start(plan, todo, sink, compute)
    done = set(sink.got)
    # no block lost, none twice: the cluster gets exactly those not done here
    assert sorted(left) == [b for b in todo if b not in done] and 3 <= len(done) < len(todo)
    # the cheapest ones: none left for the cluster is cheaper than the dearest done here
    cost = {b: work_s(plan, plan.blocks[b]) for b in todo}
    assert max(cost[b] for b in done) <= min(cost[b] for b in left), (done, left)
    # each block's record is what a worker's task gives (the same kernel and task)
    for b in done:
        want = task.compute_block(plan.scene, plan.block_points(b), plan.params,
                                  plan.numerics.settings, plan.blocks[b])
        for name, value in want.outputs.items():
            np.testing.assert_array_equal(sink.got[b].outputs[name], value)
    assert sink.timings["head_start_s"] > 0


def test_nothing_here_when_the_cluster_is_up_first_or_the_run_is_not_for_it(monkeypatch):
    plan = make_plan(parse_spec(SPEC))
    todo = list(range(len(plan.blocks)))
    compute = _Compute()
    compute.up.set()   # up before this process could load its kernel
    sink = _Sink(up_after=None, compute=compute)
    assert hs.head_start(plan, todo, sink, compute) == todo and not sink.got
    monkeypatch.syspath_prepend(str(EXAMPLES))   # (docs/examples/mylab: a brought law)
    brought = {"name": "brought", "friction": "mylab.laws:MaxwellSlip", "dither": "none",
               "outputs": ["v_mean"], "accuracy": "draft",
               "time": {"t_end": 2.0, "t_transient": 1.0},
               "params": {"gms": {"k": [100.0], "alpha": [1.0], "C": 20.0}},
               "grid": {"v_ref": [0.1, 0.2, 0.3]}}
    for workers, spec in [(2, SPEC),                         # this machine's default
                          (4, {**SPEC, "refine": True, "outputs": ["long_stick_fraction"]}),   # by levels
                          (4, {**SPEC, "device": "cuda"}),   # launches on the GPU
                          (4, brought)]:                     # its crash would be ours
        plan = make_plan(parse_spec(spec))
        compute = _Compute(workers)
        sink = _Sink(up_after=None, compute=compute)
        todo = [0, 1]   # (a refined plan has its blocks level by level)
        assert hs.head_start(plan, todo, sink, compute) == todo and not sink.got, spec
