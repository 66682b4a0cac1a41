"""Dask clusters for a run: a client on an existing scheduler or a LocalCluster, with its
workers ignoring Ctrl-C (the submitter stops them cleanly; sweeps.run)."""
from __future__ import annotations

import logging
import signal
import threading
from contextlib import contextmanager

log = logging.getLogger("ditherlab")


class ClusterStartError(RuntimeError):
    """The LocalCluster's workers did not start."""


@contextmanager
def dask_client(scheduler: str | None = None, workers: int = 2, dashboard: str | None = None):
    """A client on an existing cluster (``scheduler`` address) or on a LocalCluster of
    ``workers`` single-threaded processes.

    ``dashboard`` is the address of the LocalCluster's dask dashboard (e.g. ``":8787"``,
    needs bokeh: ``pip install 'ditherlab[dashboard]'``); its link is logged when it
    starts. Without it there is no dashboard, and the scheduler's small HTTP server (health
    checks) takes a free port: no "Port 8787 is already in use" warning when another
    cluster runs on this machine.

    Not made dask's default scheduler: tasks are submitted to it explicitly, and as the
    default it would make xarray take a *distributed* lock for every netCDF write of the
    cube (which fails for an in-memory image: "Semaphore or Lock ... not known")."""
    from distributed import Client, LocalCluster

    if scheduler:
        client = Client(scheduler, timeout="20s", set_as_default=False)
        try:
            yield client
        finally:
            client.close()
        return
    http = {} if dashboard else {"scheduler_kwargs": {"dashboard_address": ":0"}}
    with _sigint_ignored():   # workers are born ignoring Ctrl-C: their submitter stops them
        try:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=dashboard, silence_logs=logging.CRITICAL,
                                   **http)
        except Exception as exc:  # noqa: BLE001 -- one line for dask's nested traceback
            raise ClusterStartError(
                f"the local dask workers did not start ({exc}); their own message is above. "
                f"A script that calls run_sweep must do so under 'if __name__ == "
                f"\"__main__\":' (each worker imports the script again)") from None
    with cluster, Client(cluster, set_as_default=False) as client:
        if dashboard:
            log.info("dask dashboard: %s", client.dashboard_link)
        client.register_plugin(_ignore_sigint_plugin())   # ... and workers restarted later
        yield client


@contextmanager
def _sigint_ignored():
    """SIGINT ignored while local workers are spawned (they inherit it), so a Ctrl-C in the
    terminal, which reaches the whole process group, stops the submitter cleanly instead
    of printing a traceback from every worker. A Ctrl-C in these seconds is dropped."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _ignore_sigint_plugin():
    """A dask worker plugin: the worker ignores SIGINT (see ``_sigint_ignored``)."""
    from distributed import WorkerPlugin

    class IgnoreSigint(WorkerPlugin):
        name = "ditherlab-ignore-sigint"

        def setup(self, worker) -> None:
            import signal
            import threading

            if threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGINT, signal.SIG_IGN)

    return IgnoreSigint()
