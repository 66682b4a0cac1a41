"""Workers as batch jobs (Slurm, PBS, SGE) through dask-jobqueue (docs/BATCH.md).

Everything a site decides (queue, account, walltime, memory, job script prologue, the
network interface) is dask configuration: ``jobqueue.<kind>.*`` in ``~/.config/dask/*.yaml``
or ``DASK_JOBQUEUE__<KIND>__<KEY>`` in the environment. ditherlab sets only what it must:

- one thread per worker (``processes = cores``: the kernels are single-threaded);
- ``DITHERLAB_CACHE_DIR`` in the job script (before the site's prologue, which may
  override it), so that jobs share the submitter's kernel cache folder, and
  ``PYTHONSAFEPATH=1`` (the job's folder is not put first on ``sys.path``);
- no dashboard unless asked (``--dashboard``): the scheduler's HTTP server on loopback,
  ``--no-dashboard`` for the workers;
- the loopback interface (``lo``) unless an interface or scheduler host is configured:
  nothing listens beyond loopback unless the user names an address. Workers on other
  nodes need it named (``jobqueue.slurm.interface: ib0``); the submitter says so.

The number of jobs follows the work: at most one per block left (:class:`BatchWorkers`),
and jobs whose worker idles once fewer blocks are left than workers end
(:class:`JobScaler`, driven by the run's sweeps.workers.compute.Compute: the dispatch
shrinks it), so no allocation is held idle.
"""
from __future__ import annotations

import logging
import shlex
import signal
import sys
import threading
from contextlib import contextmanager
from dataclasses import dataclass, replace

from ..errors import RefusedError

log = logging.getLogger("ditherlab")

BATCH_KINDS = {"slurm": "SLURMCluster", "pbs": "PBSCluster", "sge": "SGECluster"}
JOB_START_S = 8.0   # sbatch to a joined worker on an idle queue: 8.3 s measured on the
                    # single-node test Slurm with the 2 cores shared (docs/BATCH.md); a
                    # busy queue adds its wait


@dataclass(frozen=True)
class BatchWorkers:
    """Where a run's workers come from: ``jobs`` batch jobs of ``kind`` (one worker each,
    unless the site's ``cores`` per job is larger)."""
    kind: str
    jobs: int = 4

    def __post_init__(self):
        if self.kind not in BATCH_KINDS:
            raise RefusedError(f"--cluster {self.kind}: choose one of {', '.join(BATCH_KINDS)}")
        jobqueue()   # refused now if missing; imported on the main thread (see there)

    def for_blocks(self, n_blocks: int) -> BatchWorkers:
        """No more jobs than blocks to compute."""
        return replace(self, jobs=max(1, min(self.jobs, n_blocks)))

    def client(self, dashboard: str | None = None):
        """:func:`batch_client` on these jobs: sweeps.workers.compute calls it on the value
        the command line built, without importing this module (off the computing path)."""
        return batch_client(self, dashboard)


def job_options(kind: str, dashboard: str | None = None) -> dict:
    """The keyword arguments ditherlab gives the dask-jobqueue cluster of ``kind``
    (the rest comes from the dask configuration)."""
    import dask

    def cfg(key):
        return dask.config.get(f"jobqueue.{kind}.{key}", None)

    if cfg("memory") is None:
        raise RefusedError(
            f"a {kind} job needs its memory set the dask way: jobqueue.{kind}.memory in "
            f"~/.config/dask/jobqueue.yaml, or DASK_JOBQUEUE__{kind.upper()}__MEMORY=2GB "
            "in the environment (docs/BATCH.md)")
    cores = int(cfg("cores") or 1)
    scheduler = dict(cfg("scheduler-options") or {})
    if dashboard:
        scheduler["dashboard_address"] = dashboard
    scheduler.setdefault("dashboard_address", "127.0.0.1:0")
    options = {"cores": cores, "processes": cores, "scheduler_options": scheduler}
    if not (cfg("interface") or "host" in scheduler or "interface" in scheduler):
        options["interface"] = "lo"
    extra = list(cfg("worker-extra-args") or [])
    if not any(a.startswith("--dashboard") or a == "--no-dashboard" for a in extra):
        extra.append("--no-dashboard")
    options["worker_extra_args"] = extra
    from engine.provenance import cache_root   # hashlib and pathlib only

    cache = cache_root()
    # PYTHONSAFEPATH: a job starts in the submitter's folder, and `python -m` would put it
    # first on sys.path, where a store named `store` hides the package (Python >= 3.11)
    options["job_script_prologue"] = [f"export DITHERLAB_CACHE_DIR={shlex.quote(str(cache))}",
                                      "export PYTHONSAFEPATH=1",
                                      *(cfg("job-script-prologue") or [])]
    return options


def make_cluster(kind: str, dashboard: str | None = None):
    """A dask-jobqueue cluster of ``kind`` (no job submitted yet)."""
    cluster = getattr(jobqueue(), BATCH_KINDS[kind])(**job_options(kind, dashboard))
    address = cluster.scheduler_address
    if "127.0.0.1" in address or "localhost" in address:
        log.info("%s jobs report to %s (loopback: workers on other nodes need the interface "
                 "named, jobqueue.%s.interface, docs/BATCH.md)", kind, address, kind)
    return cluster


def jobqueue():
    """The dask_jobqueue module, imported with this process's Ctrl-C handler kept: its
    ``runner`` module sets SIGINT to ``sys.exit`` at import (0.9), which would turn a
    Ctrl-C into a bare exit, and fails off the main thread."""
    if "dask_jobqueue" in sys.modules:
        return sys.modules["dask_jobqueue"]
    main = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGINT) if main else None
    try:
        import dask_jobqueue
    except ImportError:
        raise RefusedError("--cluster needs dask-jobqueue: pip install 'ditherlab[hpc]'") \
            from None
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)
    return dask_jobqueue


@contextmanager
def batch_client(workers: BatchWorkers, dashboard: str | None = None):
    """``(client, scaler)``: a matched client (sweeps.workers.matching) on ``workers.jobs``
    batch jobs, cancelled at the end (also on failure), and the :class:`JobScaler` of its
    jobs (sweeps.workers.compute.Compute scales them)."""
    from distributed import Client

    from .matching import matched

    cluster = make_cluster(workers.kind, dashboard)
    with cluster, Client(cluster, set_as_default=False) as client:
        cluster.scale(jobs=workers.jobs)
        log.debug("%d %s jobs submitted", workers.jobs, workers.kind)
        yield matched(client), JobScaler(cluster, client)


class JobScaler:
    """Ends jobs the work no longer needs: once fewer blocks are left than jobs, jobs not
    started yet are withdrawn first, then workers holding no block are retired (their
    jobs end). Grows the cluster only when a run starts (:meth:`start`); a cluster kept
    between runs (``ditherlab serve``) holds no job while it waits (:meth:`release`)."""

    def __init__(self, cluster, client):
        self.cluster, self.client = cluster, client

    def start(self, jobs: int) -> None:
        """A run begins that wants ``jobs`` jobs (BatchWorkers.for_blocks)."""
        if len(self.cluster.worker_spec) != jobs:
            log.debug("%d %s jobs for this run", jobs, type(self.cluster).__name__)
            self.cluster.scale(jobs=jobs)

    def release(self) -> None:
        """The run is over: every job ends (the next run's :meth:`start` submits again)."""
        if self.cluster.worker_spec:
            self.cluster.scale(0)

    def tick(self, blocks_left: int) -> None:
        requested = len(self.cluster.worker_spec)
        if blocks_left >= requested:
            return
        info = self.client.scheduler_info(n_workers=-1)["workers"]
        joined = len(info)
        if requested > max(blocks_left, joined):   # withdraws jobs not yet started first
            self.cluster.scale(max(blocks_left, joined))
        if blocks_left >= joined:
            return
        busy = self.client.processing()
        idle = [w["name"] for a, w in info.items() if not busy.get(a)][:joined - blocks_left]
        if idle:
            log.debug("ending %d idle batch jobs (%d blocks left)", len(idle), blocks_left)
            self.client.retire_workers(names=idle, close_workers=True)
            self.cluster.sync(self.cluster.scale_down, idle)
