"""Blocks computed on threads of the submitting process while its local cluster starts
(issue 37). A cluster of N workers takes a second or more to start and warm up, the fork
server's import most of it, and meanwhile N - 1 cores sit idle. With 4 workers or more
(sweeps.workers.local_start.PRESTART_MIN_WORKERS: a machine with cores to spare), the
submitter loads the scene's kernel itself and computes the run's smallest blocks, one
per thread, until the cluster is up and warm; the cluster then takes the rest. The same
task, journal and checks as the threads of a small sweep (sweeps.run.local), so the cube
is the same bit for bit; not for a brought model (its crash would take this process with
it: sweeps.workers.deaths), a refined sweep, or a GPU sweep.

The smallest blocks, because the cluster waits for the ones running when it comes up
(a fraction of a second: the planner's smallest are a quarter of BLOCK_SECONDS,
sweeps.planning.blocks), and because the longest must start first on the cluster."""
from __future__ import annotations

import logging
import threading
import time

from ..planning.plan import Plan, work_s
from ..workers.task import compute_block, warm_up
from ..workers.compute import LOCAL
from ..workers.local_start import PRESTART_MIN_WORKERS
from ..workers.threads import ThreadClient
from . import interrupt
from .dispatch import TICK_S
from .local import _collect

log = logging.getLogger("ditherlab")

HEAD_START_S = 2.0   # the work offered, per thread: about a local cluster's start and more


def threads_for(compute) -> int:
    """Threads of the head start: one fewer than the workers and the cores (the fork
    server, the scheduler and the workers' start need one), or 0: none."""
    from ..workers.local_start import usable_cores

    if compute.kind != LOCAL or compute.workers < PRESTART_MIN_WORKERS:
        return 0
    return max(0, min(compute.workers, usable_cores()) - 1)


def head_start(plan: Plan, todo: list[int], sink, compute, keep_alive=lambda: None
               ) -> list[int]:
    """Compute blocks of ``todo`` here until ``compute``'s early-started cluster is up
    and warm (:meth:`sweeps.workers.compute.Compute.early_ready`); returns the blocks left
    for it. Nothing when the run is not one for it (see the module), when the kernel is
    not loaded here before the cluster is up (a first compile: the cluster compiles), or
    when ``sink.should_stop()``. ``keep_alive`` is called while it runs (the display)."""
    threads = threads_for(compute)
    if not (todo and threads and compute.early and plan.path == "simulate"
            and not plan.scene.digests and not plan.spec.refine
            and plan.numerics.settings.device != "cuda"):
        return todo
    up = compute.early_ready
    t0 = time.perf_counter()
    if not _kernel_here(plan, lambda: up() or sink.should_stop(), keep_alive):
        return todo
    cost_of = {b: work_s(plan, plan.blocks[b]) for b in todo}
    offered, total = [], 0.0
    for b in sorted(todo, key=lambda b: cost_of[b]):   # the smallest first
        if total > threads * HEAD_START_S:
            break
        offered.append(b)
        total += cost_of[b]
    until = _Until(sink, up, keep_alive)
    with ThreadClient(threads, name="ditherlab-head") as pool:
        _smallest_first(pool, plan, offered, until)
    sink.timings["head_start_s"] = time.perf_counter() - t0
    log.debug("%d of %d blocks computed here while the cluster started (threads: %d)",
              len(until.got), len(todo), threads)
    return [b for b in todo if b not in until.got]


def _smallest_first(pool: ThreadClient, plan: Plan, queue: list[int], until) -> None:
    """``queue``'s blocks in its order, one per thread of ``pool`` (none waiting behind a
    running one: the cluster would wait for it), each journaled as it ends, until
    ``until.should_stop()``; then those running are waited for."""
    inflight: dict = {}   # future -> block
    queue = list(reversed(queue))   # popped from the end
    while True:
        interrupt.check()
        while queue and len(inflight) < pool.threads and not until.should_stop():
            b = queue.pop()
            inflight[pool.submit(compute_block, plan.scene, plan.block_points(b),
                                 plan.params, plan.numerics.settings, plan.blocks[b])] = b
        if not inflight:
            return
        failed = _collect(plan, pool.wait_any(inflight, TICK_S), inflight, until, until)
        if failed is not None:   # (as on the threads of a small sweep: sweeps.run.local)
            _collect(plan, list(inflight), inflight, until, until)
            raise failed
        until.keep_alive()


def _kernel_here(plan: Plan, give_up, keep_alive) -> bool:
    """Load (or compile) the block kernel in this process on a daemon thread; False if
    ``give_up()`` turns true first (it is left to finish behind)."""
    thread = threading.Thread(target=warm_up, daemon=True, name="ditherlab-head-warm",
                              args=(plan.scene, plan.params, plan.numerics.settings))
    thread.start()
    while thread.is_alive():
        if give_up():
            return False
        keep_alive()
        thread.join(0.02)
    return not give_up()


class _Until:
    """The run's sink, which says stop once the cluster is up too; and a silent progress
    bar (the display says the cluster is starting; the run's bar counts what is left)."""

    def __init__(self, sink, up, keep_alive):
        self.sink, self.up, self.keep_alive = sink, up, keep_alive
        self.got: set[int] = set()

    def __call__(self, b: int, record) -> None:
        self.sink(b, record)
        self.got.add(b)

    def should_stop(self) -> bool:
        return self.up() or self.sink.should_stop()

    def update(self, n: int) -> None:
        pass

    def set_postfix_str(self, text: str) -> None:
        pass
