"""Where a run's blocks are computed: :class:`Compute`, the one value the command line
(``--workers``, ``--cluster``/``--jobs``, ``--scheduler``, ``--dashboard``),
:func:`sweeps.api.run_sweep` and ``serve`` build from the user's choice and hand to
:func:`sweeps.run.submit.submit`.

It owns the dask client: made when a run needs one (:meth:`Compute.open`, or in the
background while the submitter reads the store: :meth:`Compute.start_early`), closed by
whoever opened it (:meth:`Compute.close`, :meth:`Compute.close_later`); a client the caller
gave stays open. And it scales batch jobs to the work (:meth:`start` for a run's blocks,
:meth:`shrink` as they run out, :meth:`release` between runs); for the other kinds these
do nothing. A run small enough for threads of the submitter
(sweeps.run.local.run_blocks_local) opens nothing and takes :attr:`threads` from it.
"""
from __future__ import annotations

from contextlib import contextmanager

from .cluster import EarlyStart, dask_client
from .matching import matched

LOCAL, BATCH, SCHEDULER, CLIENT = "local", "batch", "scheduler", "client"


class Compute:
    """One of: ``workers`` local single-threaded worker processes (a LocalCluster, the
    default), ``batch`` jobs (:class:`sweeps.workers.batch.BatchWorkers`), the dask cluster
    at ``scheduler`` (an address), or an existing ``client`` (left open); ``dashboard`` the
    address of the dask dashboard of a cluster made here (none by default)."""

    def __init__(self, workers: int = 2, *, batch=None,
                 scheduler: str | None = None, client=None, dashboard: str | None = None):
        if sum(x is not None for x in (batch, scheduler, client)) > 1:
            raise ValueError("compute on batch jobs, a scheduler or a client: one of them")
        from ..planning.plan import min_task_s

        min_task_s()   # a bad $DITHERLAB_MIN_TASK_S: one line (exit 2) before anything runs
        _block_timeout_s()   # and a bad $DITHERLAB_BLOCK_TIMEOUT_S likewise
        self.workers, self.batch, self.scheduler = workers, batch, scheduler
        self.dashboard = dashboard
        self._given = client
        self._client = matched(client)   # a caller's client is open from the start
        self._scaler = None              # a batch cluster's JobScaler, once open
        self._connected = None           # the context manager of a client made here
        self._early: EarlyStart | None = None

    @classmethod
    def chosen(cls, *, workers: int = 2, batch=None, scheduler: str | None = None,
               client=None, dashboard: str | None = None) -> Compute:
        """From the user's options, the first given of: an existing ``client``, a
        ``scheduler`` address, ``batch`` jobs (a :class:`sweeps.workers.batch.BatchWorkers`,
        built by the command line from ``--cluster KIND --jobs N``: this module never
        imports the batch system's options, which cannot change a number and so stay off
        the computing path, sweeps.version); else ``workers`` local workers."""
        if client is not None:
            return cls(workers, client=client, dashboard=dashboard)
        if scheduler:
            return cls(workers, scheduler=scheduler, dashboard=dashboard)
        return cls(workers, batch=batch, dashboard=dashboard)

    @property
    def kind(self) -> str:
        return (CLIENT if self._given is not None else SCHEDULER if self.scheduler
                else BATCH if self.batch is not None else LOCAL)

    @property
    def where(self) -> str:
        """What computes, in words (serve's line, the progress display)."""
        kind = self.kind
        if kind == BATCH:
            return f"up to {self.batch.jobs} {self.batch.kind} batch jobs"
        return {LOCAL: f"local cluster of {self.workers} workers", SCHEDULER: self.scheduler,
                CLIENT: "the caller's dask client"}[kind]

    def check_gpu(self) -> None:
        """A sweep on the GPU (spec ``device = "cuda"``) runs its blocks on this machine's
        GPU from the submitting process (local workers), or on a dask cluster's GPU workers
        (a scheduler or a client: sweeps.workers.matching, checked once connected). One line
        (exit 2) when this machine has no GPU, or for batch jobs."""
        from engine.gpu import NoGPU, check_device

        from ..errors import RefusedError

        if self.kind == BATCH:
            raise RefusedError(f"device cuda: a sweep on the GPU runs on this machine's GPU "
                               f"or a dask cluster's GPU workers, not on {self.where} (batch "
                               "jobs with GPUs are not supported yet); submit it without "
                               "--cluster, or start GPU workers with `dask worker ADDRESS "
                               "--resources GPU=1` and give --scheduler ADDRESS")
        if self.kind != LOCAL:
            return
        try:
            check_device()
        except NoGPU as exc:
            raise RefusedError(str(exc)) from None

    @property
    def threads(self) -> int:
        """Threads of the submitter for a run that starts no cluster: as many as the
        local workers asked for (2 for the other kinds)."""
        return max(1, self.workers) if self.kind == LOCAL else 2

    @property
    def starts_cluster(self) -> bool:
        """A cluster of our own (local workers, batch jobs) is started for a run: the run
        may rather go on threads (sweeps.run.submit.small), and the start overlaps the
        submitter's preparation (:meth:`start_early`)."""
        return self.kind in (LOCAL, BATCH)

    @property
    def client(self):
        """The matched dask client while open (None before :meth:`open`, or while an
        early start is still under way)."""
        return self._client

    @property
    def is_open(self) -> bool:
        return self._client is not None or self._early is not None

    # --- opening and closing -------------------------------------------------------------

    def open(self, n_blocks: int | None = None):
        """The client, made now if it is not open (batch jobs: no more than ``n_blocks``);
        an early start is waited for."""
        if self._client is None and self._early is not None:
            return self.wait()
        if self._client is None:
            self._connected = self._connect(n_blocks)
            self._client = self._connected.__enter__()
        return self._client

    def start_early(self, n_blocks: int | None, warm: tuple) -> None:
        """Start the cluster (no more than ``n_blocks`` batch jobs) on a thread and run
        ``warm`` (``(fn, *args)``) on its workers: :class:`sweeps.workers.cluster.EarlyStart`.
        :meth:`wait` hands the client over."""
        self._early = EarlyStart(self._connect(n_blocks), warm)

    def wait(self, should_stop=lambda: False, notice=None, starting=None):
        """The client of an early start once its workers are warm, or None if
        ``should_stop()`` turned true first (EarlyStart.client)."""
        self._client = self._early.client(should_stop, notice, starting)
        return self._client

    def early_ready(self) -> bool:
        """An early start's cluster is up and warm (or failed): :meth:`wait` returns at once."""
        return self._early is not None and self._early.ready()

    @property
    def early(self) -> bool:
        """The cluster was started by :meth:`start_early` (its workers are warm)."""
        return self._early is not None

    def close(self) -> None:
        """Close the cluster made here (nothing for a caller's client); :meth:`open` makes
        a fresh one after it."""
        if self._early is not None:
            self._early.close()
        elif self._connected is not None:
            self._connected.__exit__(None, None, None)
        self._forget()

    def close_later(self) -> None:
        """:meth:`close`, for an early-started cluster on a thread (the caller reports its
        result first: EarlyStart.close_later)."""
        if self._early is not None:
            self._early.close_later()
            self._forget()
        else:
            self.close()

    def _forget(self) -> None:
        self._client, self._scaler = matched(self._given), None
        self._connected = self._early = None

    @contextmanager
    def _connect(self, n_blocks: int | None):
        """The context manager that makes a matched client of this kind."""
        if self.kind == BATCH:
            jobs = self.batch if n_blocks is None else self.batch.for_blocks(n_blocks)
            with jobs.client(self.dashboard) as (client, scaler):
                self._scaler = scaler
                yield client
        else:
            with dask_client(self.scheduler, self.workers, self.dashboard) as client:
                yield client

    # --- batch jobs follow the work (nothing for the other kinds) --------------------------

    def start(self, n_blocks: int) -> None:
        """A run begins with ``n_blocks`` blocks: that many batch jobs at most."""
        if self._scaler is not None:
            self._scaler.start(self.batch.for_blocks(n_blocks).jobs)

    def shrink(self, blocks_left: int) -> None:
        """End the batch jobs the ``blocks_left`` no longer need (JobScaler.tick)."""
        if self._scaler is not None:
            self._scaler.tick(blocks_left)

    def release(self) -> None:
        """The run is over: every batch job ends (serve waits holding none)."""
        if self._scaler is not None:
            self._scaler.release()


def _block_timeout_s() -> float:
    """``$DITHERLAB_BLOCK_TIMEOUT_S`` (sweeps.workers.task.watched), checked by the submitter:
    a bad value is refused (exit 2), not a failed block on every worker."""
    from engine.user_code import ModelError, block_timeout_s

    from ..errors import RefusedError

    try:
        return block_timeout_s()
    except ModelError as exc:
        raise RefusedError(str(exc)) from None
