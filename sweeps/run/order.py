"""The order and the size of a run's tasks (sweeps.run.dispatch, sweeps.run.local): the
longest expected first (LPT), the error sample's re-runs among the blocks by the same
expected cost, groups of blocks that shrink towards the end, and how many tasks wait at
each worker."""
from __future__ import annotations

from ..planning.plan import min_task_s

TAIL_MIN_S = 0.1   # the shortest group of blocks the tail is split into (tail_cap_s)
DEPTH = 2   # tasks in flight per worker thread: one running and one waiting at it, so a
            # worker starts its next task without a round trip to the submitter (15-25 ms a
            # task here, most of a worker's idle time in scripts/bench_sweep.py). Not for a
            # brought model (one more in flight in all): dask blames a worker's death on
            # every task it held, and a block waiting behind one that crashes its process
            # would count deaths it did not cause (sweeps.workers.deaths). A stop waits
            # for both: cancelling the waiting one lost its block when it had just started
            # (computed again on resume; tests/e2e/test_service.py's cancel test saw it)


def reruns_left(sample) -> bool:
    """The error sample's re-runs (or None) still running or to submit: the dispatch
    waits for them with the blocks' ``as_completed``, which wakes it as each ends, where
    the estimate's gather (sweeps.estimates.error_reruns) looks every 50 ms. (The cheap
    sweep of scripts/bench_sweep.py ended 0.09-0.15 s after its last block, 4-6 % of its
    points' time.) Once one is given up the others are not waited for: the gather cancels
    them and says why."""
    return sample is not None and not sample.given_up and \
        (sample.running() > 0 or sample.next_cost() is not None)


def outstanding(*samples) -> int:
    """Tasks the error samples (:class:`sweeps.estimates.error_reruns.SampleRuns`, or None)
    still need: counted as blocks left when a batch cluster ends idle jobs. Without them,
    the jobs all ended when the last block was back while re-runs were still to run, and
    the estimate's gather waited for ever for a worker (seen in test_slurm: the submit hung
    with the cube published, both jobs cancelled 4 s after they started)."""
    return sum(s.outstanding() for s in samples if s is not None)


def longest_first(todo: list[int], cost_of: dict) -> list[int]:
    """``todo`` by expected cost, longest first (ties in their order): the work that would
    otherwise be a lone worker's tail starts early (LPT scheduling)."""
    return sorted(todo, key=lambda b: -cost_of[b])


def rerun_first(sample, queue: list[int], cost_of: dict) -> bool:
    """True when the next task should be the error sample's next re-run: one is left and
    it is expected to take at least as long as the next block (``queue[-1]``), or no block
    is left."""
    nxt = sample.next_cost() if sample is not None else None
    return nxt is not None and (not queue or nxt >= cost_of[queue[-1]])


def tail_cap_s(left_s: float, threads: int, cost: list) -> float:
    """The most expected seconds (sweeps.planning.plan.work_s) one task may take when
    ``left_s`` are left to submit to ``threads`` threads: half of each thread's share
    (``left_s / (2 x threads)``, "factoring"), so the tasks shrink towards the end and the
    threads finish together, instead of one of them running a last 0.6-second group while
    the other idles (seen in scripts/bench_sweep.py's task stream: one worker idle 0.39 s
    of a 2.56 s run); but not below TAIL_MIN_S at the price the blocks back so far
    measured (``cost``, as :func:`rerun_group_s`): each task costs the submitter, which
    shares the workers' cores, some CPU (halving every task down to one block doubled the
    tasks, 15 to 31, and the workers' kernels ran 5 % slower). A task's first block is
    taken whatever the cap."""
    floor = TAIL_MIN_S * cost[2] / cost[0] if cost[0] > 0 else 0.0
    return max(left_s / (2 * max(threads, 1)), floor)


def rerun_group_s(cost: list) -> float:
    """Expected seconds (sweeps.planning.plan.work_s) of the re-runs that share a task: as
    many as take :func:`sweeps.planning.plan.min_task_s` at the price the blocks back so
    far measured (``cost``: seconds computed, blocks back, their expected seconds; the
    price per radian is rough, its ratios less so); one re-run a task until a block is
    back. The 12 re-runs of 1,000 draft LuGre points (10 ms each), a task each, were the
    last 0.2 s of a 3.3 s run on 2 workers here."""
    return min_task_s() * cost[2] / cost[0] if cost[0] > 0 else 0.0
