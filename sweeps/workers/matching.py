"""Workers that must match: a block is computed only by a worker that runs the submitter's
engine (DESIGN.md §5).

Each worker is asked once, as it is first seen, what it runs (``sweeps.workers.task.identity``:
its results fingerprint and ditherlab version, computed from the modules *it* imports,
through ``client.run`` pinned to that worker). A worker with another fingerprint, or one
that cannot run the check at all (no ditherlab, an older one), gets no block: every task
of the run is restricted to the matching workers (``workers=``,
``allow_other_workers=False``), and the submitter says in one line which worker, which
fingerprint, and what to do. With only foreign workers nothing is computed and the run
ends with that line (:class:`ForeignWorkersError`, exit 1). The sink checks each block's
own fingerprint again before journaling it (sweeps.run.sink), the last line of defence.

:class:`MatchedClient` is the run's client with these restrictions applied to ``submit``,
``map`` and ``run``; everything else is the dask client's.

A sweep on the GPU (spec ``device = "cuda"``) on a dask cluster goes to GPU workers: workers
started with a ``GPU`` resource (``dask worker ADDRESS --resources GPU=1``, dask's own
resource mechanism). Its tasks are restricted to the matching workers that have one and ask
for one each (``resources={"GPU": 1}``: one block at a time per GPU); with none connected
the run ends in one line (:class:`NoGPUWorkersError`).
"""
from __future__ import annotations

import logging
import time

from . import task
from ..errors import UserError

log = logging.getLogger("ditherlab")

WAIT_TICK_S = 0.25   # how often a run waiting for a matching worker looks again
SHOWN = 3            # foreign workers named in one line (the rest counted)
# A local cluster's nannies start a dead worker again within seconds (2-3 s here, with the
# kernel in the cache); one that cannot start again (its environment changed under it, e.g.
# a folder named like one of our packages appeared on its path) leaves the run without
# workers: past this, the run ends in one line instead of waiting for ever.
LOCAL_WORKERS_BACK_S = 60.0
# dask's LocalCluster drops a nanny from its workers now and then when its worker keeps
# crashing (reproduced with plain dask: after 18-24 tasks that segfault their worker, no
# worker and no nanny left, its spec still listing both); scaling it to its size again
# brings them back. Done once our local cluster has had no worker for this long.
REVIVE_S = 10.0


class ForeignWorkersError(UserError):
    """Workers are connected, and none runs this submitter's engine."""


class WorkersGoneError(UserError):
    """Every worker of our own local cluster died and none came back."""


class NoGPUWorkersError(UserError):
    """A GPU sweep on a cluster whose matching workers have no GPU resource."""


GPU = "GPU"   # the dask worker resource a GPU worker declares


def _gpus(dask_worker) -> float:
    """The GPU resource a worker declares (run on the worker by ``client.run``)."""
    return float(dask_worker.state.total_resources.get(GPU, 0))


class WorkerCheck:
    """The identity of every worker seen (asked once per worker address) and which match."""

    def __init__(self, client):
        self.client = client
        self.models: tuple = ()
        self.own = task.identity()
        self.seen: dict[str, dict | str] = {}   # address -> identity, or why the check failed
        self.told: set[str] = set()
        self.gpu = False                        # the run's blocks need a GPU worker
        self.gpus: dict[str, float] = {}        # address -> its GPU resource, once asked
        self.back_within_s: float | None = None  # our local cluster: LOCAL_WORKERS_BACK_S
        self.none_since: float | None = None     # when the last worker left (none since)
        self.revive = None                       # our local cluster: start its workers again
        self.revived = False                     # (once per time without workers)

    def expect(self, models, gpu: bool = False) -> None:
        """The models this run brings by import path (engine.registry): a worker must also
        import the same source of each (its digest in the identity) to get a block; ``gpu``:
        and have a GPU resource (a sweep on the GPU)."""
        self.gpu = gpu
        models = tuple(sorted(models))
        if models != self.models:
            self.models = models
            self.own = task.identity(models)
            self.seen.clear()
            self.told.clear()

    def matching(self) -> dict[str, int]:
        """Address -> threads of every connected worker that runs this engine. Workers
        seen for the first time are asked now; a foreign one is named once (a warning).
        Raises :class:`ForeignWorkersError` when workers are connected and none matches."""
        nthreads = self.client.nthreads()
        self._check_gone(bool(nthreads))
        new = [a for a in nthreads if a not in self.seen]
        if new:
            self.seen.update(self._ask(new))
        for gone in set(self.seen) - set(nthreads):
            del self.seen[gone]
        foreign = [a for a in nthreads if a in self.seen and self.seen[a] != self.own]
        good = {a: n for a, n in nthreads.items() if self.seen.get(a) == self.own}
        if foreign and not good:
            raise ForeignWorkersError(self.line(foreign, alone=True))
        fresh = [a for a in foreign if a not in self.told]
        if fresh:
            self.told.update(fresh)
            log.warning("%s", self.line(fresh, alone=False))
        return self._with_gpu(good) if self.gpu else good

    def _check_gone(self, any_worker: bool) -> None:
        """WorkersGoneError when our local cluster has had no worker for longer than
        ``back_within_s`` (a batch or external cluster may wait for its workers at will)."""
        if any_worker or self.back_within_s is None:
            self.none_since, self.revived = None, False
            return
        now = time.monotonic()
        self.none_since = self.none_since or now
        if now - self.none_since > REVIVE_S and self.revive is not None and not self.revived:
            log.debug("no local worker for %.0f s: starting them again", REVIVE_S)
            self.revived = True
            self.revive()
        if now - self.none_since > self.back_within_s:
            raise WorkersGoneError(
                f"every local dask worker died and none has started again for "
                f"{self.back_within_s:.0f} s (a worker that cannot start prints why above); "
                "the journal keeps every finished block: fix that and submit again")

    def _with_gpu(self, good: dict[str, int]) -> dict[str, int]:
        """The workers of ``good`` with a GPU resource; :class:`NoGPUWorkersError` when
        there are workers and none has one."""
        new = [a for a in good if a not in self.gpus]
        if new:
            try:
                self.gpus.update(self.client.run(_gpus, workers=new, on_error="return"))
            except Exception as exc:  # noqa: BLE001 -- a worker left meanwhile: ask next time
                log.debug("GPU resource check failed (%s); asking again", exc)
        with_gpu = {a: n for a, n in good.items()
                    if isinstance(self.gpus.get(a), float) and self.gpus[a] >= 1}
        if good and not with_gpu and all(a in self.gpus for a in good):
            raise NoGPUWorkersError(
                f"device cuda: none of the {len(good)} workers of this cluster has a GPU "
                f"resource, nothing was computed; start GPU workers with `dask worker "
                f"ADDRESS --resources {GPU}=1` on machines with an NVIDIA GPU and numba-cuda "
                "(docs/GPU.md), or submit without --device cuda (the journal keeps every "
                "finished block)")
        return with_gpu

    def wait(self, should_stop=lambda: False) -> dict[str, int]:
        """:meth:`matching` once it is not empty (batch jobs may still be starting); an
        empty dict if ``should_stop()`` turned true first."""
        while True:
            good = self.matching()
            if good or should_stop():
                return good
            time.sleep(WAIT_TICK_S)

    def _ask(self, addresses: list[str]) -> dict[str, dict | str]:
        try:
            got = self.client.run(task.identity, self.models, workers=addresses,
                                  on_error="return")
        except Exception as exc:  # noqa: BLE001 -- a worker left meanwhile: ask next time
            log.debug("worker check failed (%s); asking again", exc)
            return {}
        return {a: r if isinstance(r, dict) else f"cannot run ditherlab's check "
                f"({type(r).__name__}: {r})".replace("\n", " ") for a, r in got.items()}

    def line(self, foreign: list[str], alone: bool) -> str:
        """One line: which workers, which fingerprint, and what to do."""
        own = self.own
        shown = "; ".join(f"{a} {self._what(a)}" for a in foreign[:SHOWN])
        more = f" and {len(foreign) - SHOWN} more" if len(foreign) > SHOWN else ""
        fix = (f"start the workers from this installation (ditherlab {own['version']}, "
               f"results fingerprint {own['fingerprint']}), or run on this machine's workers")
        if alone:
            return (f"no worker runs this engine, nothing was computed: {shown}{more}; {fix} "
                    "and submit again (the journal keeps every finished block)")
        return f"worker {shown}{more}: another engine, it gets no block of this sweep; {fix}"

    def _what(self, address: str) -> str:
        got = self.seen[address]
        if isinstance(got, str):
            return got
        mine, theirs = self.own.get("models", {}), got.get("models", {})
        for ref in mine:
            if got["fingerprint"] == self.own["fingerprint"] and theirs.get(ref) != mine[ref]:
                where = (f"source {theirs[ref]}" if theirs.get(ref) else "no copy")
                return (f"has another copy of {ref} ({where}; this submitter's source is "
                        f"{mine[ref]})")
        return f"runs results fingerprint {got['fingerprint']} (ditherlab {got['version']})"


class MatchedClient:
    """A dask client whose ``submit``, ``map`` and ``run`` reach only the matching workers (waiting
    for one if none is connected yet); ``check`` is the :class:`WorkerCheck`."""

    def __init__(self, client):
        self.client, self.check = client, WorkerCheck(client)

    def __getattr__(self, name):
        return getattr(self.client, name)

    def _needs(self) -> dict:
        return {"resources": {GPU: 1}} if self.check.gpu else {}

    def submit(self, *args, workers=None, **kwargs):
        workers = list(workers or self.check.wait())
        return self.client.submit(*args, workers=workers, allow_other_workers=False,
                                  **self._needs(), **kwargs)

    def map(self, *args, workers=None, **kwargs):
        workers = list(workers or self.check.wait())
        return self.client.map(*args, workers=workers, allow_other_workers=False,
                               **self._needs(), **kwargs)

    def run(self, *args, workers=None, **kwargs):
        return self.client.run(*args, workers=list(workers or self.check.wait()), **kwargs)


def matched(client, models=(), gpu: bool = False):
    """``client`` as a :class:`MatchedClient` (itself if it is one already; None stays None),
    expecting ``models``: the import paths of the run's brought models, and ``gpu`` workers
    for a sweep on the GPU (WorkerCheck.expect)."""
    if client is None:
        return client
    if not isinstance(client, MatchedClient):
        client = MatchedClient(client)
    client.check.expect(models, gpu)
    return client
