"""The order and size of a run's tasks (sweeps.run.order): the tail's cap, and when the
dispatch waits for the error sample's re-runs. The dispatch with these on a dask cluster:
tests/e2e/test_blocks_per_task.py."""
from __future__ import annotations

from sweeps.run import order


def test_the_tail_cap_is_half_a_threads_share_and_not_below_the_floor():
    assert order.tail_cap_s(12.0, 3, [0.0, 0, 0.0]) == 2.0   # no block back: no floor
    # blocks back at 2 expected seconds per measured one: the floor is TAIL_MIN_S of those
    floor = order.TAIL_MIN_S * 2.0
    assert order.tail_cap_s(0.0, 2, [5.0, 10, 10.0]) == floor
    assert order.tail_cap_s(100.0, 2, [5.0, 10, 10.0]) == 25.0


class _Sample:
    def __init__(self, running=0, next_cost=None, given_up=""):
        self._running, self._next, self.given_up = running, next_cost, given_up

    def running(self) -> int:
        return self._running

    def next_cost(self):
        return self._next


def test_the_dispatch_waits_for_reruns_running_or_to_come_unless_one_was_given_up():
    assert not order.reruns_left(None)
    assert not order.reruns_left(_Sample())
    assert order.reruns_left(_Sample(running=2))
    assert order.reruns_left(_Sample(next_cost=0.1))
    assert not order.reruns_left(_Sample(running=2, given_up="a re-run was given up: ..."))

