"""Running the error estimate of a finished simulated run (sweeps.estimates.error_estimate):
the error sample re-run 100x more accurately (finer_numerics) on the dask client,
compared, attached to the cube and saved beside it as ``<sweep>/error_estimate.json``, so
that no cube goes unchecked."""
from __future__ import annotations

import json
import time

import numpy as np

from engine import status as S
from store.atomic import atomic_write
from store.record import BlockRecord

from . import error_estimate as errest
from ..workers import task
from ..workers.deaths import Deaths, crash_line, died_running, killed_worker
from ..workers.matching import WorkersGoneError
from ..planning.plan import Plan, work_s

ESTIMATE_FILE = "error_estimate.json"   # the sweep's error estimate (error_estimate.py)
GATHER_TICK_S = 0.05   # how often the re-runs still running are looked at
HARVEST_S = 1.0        # the longest harvest() waits for a finished re-run's result
RESCUE_S = 2.0         # how often gather() looks for re-runs whose workers have all gone


def estimate_into(plan: Plan, client, cube, sweep, timings: dict, started=None,
                  display=None) -> None:
    """The error estimate of a finished simulated sweep, into its ``cube`` (in memory) and
    ``<sweep>/error_estimate.json`` (``sweep``: its ``store.SweepDir``); a failure is
    recorded as a warning, never lost. ``started``: a :class:`SampleRuns` some of whose
    re-runs are already submitted; ``display(phase, total, unit)``: a progress bar that
    counts the re-runs as they finish (sweeps.run.phases.bar), or None."""
    t = time.perf_counter()
    try:
        estimate = _error_estimate(plan, client, cube, started, display)
    except WorkersGoneError:   # the run ends: nothing left to compute it with
        raise
    except Exception as exc:  # noqa: BLE001 -- say so in the cube, keep the results
        estimate = {"compared_with": None, "level": plan.numerics.label,
                    "sample_points": 0, "change": {}, "promise": {},
                    "warnings": [f"the error estimate could not be computed "
                                 f"({type(exc).__name__}: {exc}); submit again"]}
    errest.attach(cube, estimate)
    if estimate["compared_with"] is not None:
        atomic_write(sweep.root / ESTIMATE_FILE, json.dumps(estimate).encode())
    timings["error_estimate_s"] = time.perf_counter() - t


class SampleRuns:
    """The error sample's re-runs, 100x more accurately (error_estimate.finer_numerics),
    costliest first, a task at a time: one re-run a task, or several cheap ones together
    (:meth:`submit_next`). The sample is drawn from the sweep id, so it is known when the
    plan is made: an exhaustive sweep's dispatch runs the re-runs among its blocks,
    longest expected first (:meth:`next_cost`), and a refined sweep hands them to the
    dispatch as filler for the workers idling at the tail of each level.

    ``client`` is a dask client or a :class:`sweeps.workers.threads.ThreadClient`."""

    def __init__(self, plan: Plan):
        self.plan, self.finer = plan, errest.finer_numerics(plan)
        self.index, self.points = errest.sample(plan)
        self.scene = plan.scene.with_(integrator=self.finer.integrator)
        # expected seconds of each re-run (sweeps.planning.plan.work_s), costliest first
        cost = np.array([work_s(plan, self.index[i:i + 1], self.finer)
                         for i in range(len(self.index))])
        self.order = np.argsort(-cost, kind="stable")
        self.costs = [float(cost[i]) for i in self.order]   # in submission order
        self.futures: dict[int, object] = {}   # re-run -> its task (shared by a group)
        self.groups: list[tuple[object, list[int]]] = []   # (task, its re-runs), in order
        self.allowed: dict[object, frozenset] = {}   # task -> the workers it may run on
        self.deaths = Deaths(counting=bool(plan.scene.digests))   # per group of re-runs
        self.given_up = ""                   # why a re-run was given up (gather raises it)
        self.shown = -1   # re-runs finished as last shown beside the points (show_reruns)

    def pending(self) -> list:
        """The tasks not finished."""
        return [f for f, _ in self.groups if not f.done()]

    @property
    def last_task(self):
        """The task :meth:`submit_next` submitted last."""
        return self.groups[-1][0]

    def running(self) -> int:
        return len(self.pending())

    def outstanding(self) -> int:
        """Tasks still to come: those running, and a task for each re-run not submitted
        yet (the most it may take). A batch cluster keeps a job for each
        (sweeps.run.dispatch): gather() waits for them after the last block."""
        return self.running() + len(self.order) - len(self.futures)

    def finished(self) -> int:
        """Re-runs finished."""
        return sum(f.done() for f in self.futures.values())

    def next_cost(self) -> float | None:
        """Expected seconds of the next re-run to submit; None when all are submitted (or
        one was given up: no more are)."""
        k = len(self.futures)
        return self.costs[k] if k < len(self.order) and not self.given_up else None

    def left_s(self) -> float:
        """Expected seconds of the re-runs not submitted yet."""
        return 0.0 if self.given_up else float(sum(self.costs[len(self.futures):]))

    def submit_next(self, client, at_most_s: float = 0.0) -> bool:
        """Submit the next re-run as one task, with those after it while their summed
        expected seconds (:meth:`next_cost`) stay within ``at_most_s``: cheap re-runs
        share a task, as blocks do (sweeps.planning.plan.blocks_per_task), instead of
        costing the submitter a task each. False when all are submitted."""
        k = len(self.futures)
        if k == len(self.order) or self.given_up:
            return False
        n, total = 1, self.costs[k]
        while k + n < len(self.order) and total + self.costs[k + n] <= at_most_s:
            total += self.costs[k + n]
            n += 1
        group = [int(i) for i in self.order[k:k + n]]
        future = self._submit(client, group)
        self.futures.update((i, future) for i in group)
        self.groups.append((future, group))
        return True

    def _submit(self, client, group: list[int], workers: list | None = None):
        """One task of the re-runs ``group`` (on the matching workers of a dask cluster,
        ``workers`` or those there now: the task remembers which, for :meth:`rescue`)."""
        check = getattr(client, "check", None)   # (a MatchedClient; not ThreadClient)
        if check is not None and workers is None:
            workers = list(check.wait())
        extra = {"workers": workers} if workers is not None else {}
        future = client.submit(task.compute_block, self.scene, self.points[group],
                               self.plan.params, self.finer.settings, self.index[group],
                               [1] * len(group), kind="rerun", pure=False,   # (the hooks:
                               **extra)                                      # a re-run each)
        if workers is not None:
            self.allowed[future] = frozenset(workers)
        return future

    def rescue(self, client, good: dict) -> list:
        """Submit again the re-run tasks whose allowed workers have all gone (batch jobs
        ended, or workers that died running them: sweeps.workers.deaths), on the workers
        in ``good`` now (none: they wait); returns the new tasks. For a brought model, a
        group whose tasks killed more workers than dask allows is given up (``given_up``:
        :meth:`gather` raises it, and the estimate says so in its warning); deaths are not
        counted for the engine's own models (sweeps.workers.deaths.Deaths)."""
        if not good:
            return []
        orphans = [(g, f) for g, (f, _) in enumerate(self.groups)
                   if f in self.allowed and not f.done() and not self.allowed[f] & good.keys()]
        died = died_running(client, [f for _, f in orphans]) if self.deaths.counting else {}
        new = []
        for g, future in orphans:
            client.cancel(future)
            _, lost = self.deaths.requeue([g], None if died is None else died.get(future.key, 0))
            if lost:   # (the same rule as a block's: sweeps.workers.deaths.Deaths)
                self.given_up = f"a re-run was given up: {crash_line(self.deaths.of_block[g])}"
                continue
            group = self.groups[g][1]
            new.append(self._submit(client, group, list(good)))
            self.groups[g] = (new[-1], group)
            self.futures.update((i, new[-1]) for i in group)
        return new

    def gather(self, client, tick=None, idle=None) -> BlockRecord:
        """Every re-run's result, in sample order, as one record (the rest submitted
        now); ``tick()`` once per re-run as it finishes, ``idle()`` every GATHER_TICK_S
        between (a progress bar's keep-alive)."""
        while self.submit_next(client):
            pass
        seen, looked = 0, time.monotonic()
        while seen < len(self.order):   # dask's and concurrent.futures' alike
            if self.allowed and time.monotonic() - looked > RESCUE_S:
                self.rescue(client, client.check.matching())
                looked = time.monotonic()
            if self.given_up:
                self.cancel(client)
                raise RuntimeError(self.given_up)
            self.harvest()
            done = sum(f.done() for f in (self.futures[i] for i in range(len(self.order))))
            for _ in range(done - seen):
                if tick is not None:
                    tick()
            seen = max(seen, done)   # (a finished task whose worker died is not done again)
            if seen < len(self.order):
                if idle is not None:
                    idle()
                time.sleep(GATHER_TICK_S)
        if self.deaths.counting and any(killed_worker(f) for f, _ in self.groups):
            # dask gave a re-run up itself (its allowed-failures) before rescue() did: the
            # same line as rescue's, not KilledWorker's text (as the dispatch does a block)
            self.cancel(client)
            raise RuntimeError(f"a re-run was given up: {crash_line(self.deaths.allowed + 1)}")
        self.harvest()
        records = [f.result() for f, _ in self.groups]   # (an erred task raises here)
        of_rerun = {}
        for (_, group), record in zip(self.groups, records):
            of_rerun.update(zip(group, record.split([1] * len(group))))
        return BlockRecord.concatenate([of_rerun[i] for i in range(len(self.order))])

    def take(self, future, record) -> bool:
        """Hold the result of a re-run task that finished (the dispatch's ``as_completed``
        fetched it) and let the task go: a worker that left (a brought model that hung:
        sweeps.workers.task) took the results still wanted of it, to be computed again,
        and one that hung again ended the next worker. False: not one of this sample's."""
        for g, (task_, group) in enumerate(self.groups):
            if task_ is future:
                if _succeeded(future):
                    self.allowed.pop(future, None)
                    self.groups[g] = (_Taken(record), group)
                    self.futures.update((i, self.groups[g][0]) for i in group)
                return True
        return False

    def harvest(self) -> None:
        """:meth:`take` every re-run task that finished, fetching its result (at most
        HARVEST_S each: one whose worker left meanwhile is computed again)."""
        for future, _ in list(self.groups):
            if not isinstance(future, _Taken) and _succeeded(future):
                try:
                    self.take(future, future.result(timeout=HARVEST_S))
                except TimeoutError:
                    continue

    def cancel(self, client) -> None:
        client.cancel([f for f, _ in self.groups if not isinstance(f, _Taken)])


class _Taken:
    """A finished re-run task whose result the submitter holds (:meth:`SampleRuns.take`)."""
    status = "finished"

    def __init__(self, record: BlockRecord):
        self.record = record

    def done(self) -> bool:
        return True

    def result(self) -> BlockRecord:
        return self.record


def _succeeded(future) -> bool:
    """A dask future or a thread's ``concurrent.futures.Future`` that has its result (not
    running, lost with its worker, erred or cancelled)."""
    if not future.done():
        return False
    status = getattr(future, "status", None)
    if status is not None:
        return status == "finished"
    return not future.cancelled() and future.exception() is None


def _error_estimate(plan: Plan, client, cube, started: SampleRuns | None = None,
                    display=None) -> dict:
    """Gather the finer re-runs of the error sample (all submitted now unless some were
    ``started``) and compare."""
    runs = started or SampleRuns(plan)
    index, finer = runs.index, runs.finer
    # counted from what the points' bar last showed: a re-run that finished after that
    # and before this line got no bar and the display stopped at k-1/N (a race
    # tests/e2e/test_progress_phases.py could lose)
    done, total = (runs.finished() if runs.shown < 0 else runs.shown), len(runs.order)
    if display is None or done == total:   # (re-runs among the blocks: all finished)
        result = runs.gather(client)
    else:   # the re-runs still running after the last point, counted from those done
        with display("error estimate", total, "re-run", initial=done) as bar:
            ticks = iter(range(total))

            def tick() -> None:   # as_completed yields the finished ones too: skip them
                if next(ticks) >= done:
                    bar.update()

            result = runs.gather(client, tick=tick, idle=getattr(bar, "keep_alive", None))
    return errest.compare(plan, cube, index, result, finer.label)


def complete(cube) -> bool:
    return not (cube["status"].values == S.NOT_COMPUTED).any()


def needs_estimate(plan: Plan, sweep, cube) -> bool:
    """A finished simulated sweep without a saved error estimate (its run was killed
    between the last block and the estimate): it is computed before the sweep is done,
    so that no cube goes unchecked."""
    return (plan.path == "simulate" and complete(cube)
            and not (sweep.root / ESTIMATE_FILE).exists())


def attach_saved_estimate(sweep, cube) -> bool:
    """Put the sweep's saved error estimate (if any) into ``cube``; True when there was one."""
    path = sweep.root / ESTIMATE_FILE
    try:
        errest.attach(cube, json.loads(path.read_text()))
    except (OSError, ValueError, KeyError):
        return False
    return True
