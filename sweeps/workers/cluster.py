"""Dask clusters for a run: a client on an existing scheduler or a LocalCluster, with its
workers ignoring Ctrl-C (the submitter stops them cleanly; sweeps.run.submit)."""
from __future__ import annotations

import atexit
import logging
import signal
import threading
import time
from contextlib import contextmanager

log = logging.getLogger("ditherlab")

NOTICE_AFTER_S = 3.0   # a warm-up longer than this is a first compilation: say so
LOOPBACK_HTTP = "127.0.0.1:0"   # the scheduler's HTTP server (health checks) when no dashboard


class ClusterStartError(RuntimeError):
    """The LocalCluster's workers did not start."""


@contextmanager
def dask_client(scheduler: str | None = None, workers: int = 2, dashboard: str | None = None):
    """A client on an existing cluster (``scheduler`` address) or on a LocalCluster of
    ``workers`` single-threaded processes (batch jobs: sweeps.workers.batch.batch_client; a
    run's choice among them is its :class:`sweeps.workers.compute.Compute`). Its tasks
    reach only the workers that run this engine (a
    :class:`sweeps.workers.matching.MatchedClient`).

    ``dashboard`` is the address of the LocalCluster's dask dashboard (e.g. ``":8787"``,
    needs bokeh: ``pip install 'ditherlab[dashboard]'``); its link is logged when it
    starts. Without it there is no dashboard, and the scheduler's small HTTP server (health
    checks) takes a free port: no "Port 8787 is already in use" warning when another
    cluster runs on this machine.

    Not made dask's default scheduler: tasks are submitted to it explicitly, and as the
    default it would make xarray take a *distributed* lock for every netCDF write of the
    cube (which fails for an in-memory image: "Semaphore or Lock ... not known")."""
    from distributed import Client, LocalCluster

    from .local_start import local_settings
    from .matching import LOCAL_WORKERS_BACK_S, matched

    if scheduler:
        client = Client(scheduler, timeout="20s", set_as_default=False)
        try:
            yield matched(client)
        finally:
            client.close()
        return
    # every socket on loopback (scheduler, its HTTP server, nannies, workers) unless the
    # user names the dashboard's address
    http = {} if dashboard else {"scheduler_kwargs": {"dashboard_address": LOOPBACK_HTTP}}
    # workers are born ignoring Ctrl-C (their submitter stops them), forked where they can be
    with _sigint_ignored(), local_settings(dashboard):
        try:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   host="127.0.0.1", dashboard_address=dashboard,
                                   silence_logs=logging.CRITICAL, **http)
        except Exception as exc:  # noqa: BLE001 -- one line for dask's nested traceback
            raise ClusterStartError(
                f"the local dask workers did not start ({exc}); their own message is above. "
                f"A script that calls run_sweep must do so under 'if __name__ == "
                f"\"__main__\":' (each worker imports the script again)") from None
    with cluster, Client(cluster, set_as_default=False) as client:
        if dashboard:
            log.info("dask dashboard: %s", client.dashboard_link)
        client.register_plugin(_ignore_sigint_plugin())   # ... and workers restarted later
        client = matched(client)
        client.check.back_within_s = LOCAL_WORKERS_BACK_S   # our nannies restart the dead,
        client.check.revive = lambda: cluster.scale(workers)   # or we start new ones
        yield client


class EarlyStart:
    """A cluster of our own started, and the run's kernel compiled on its workers, in a
    thread while the submitter still reads the store and prepares its cube (rebuild, lease,
    first publish): on a refined Fig. 14 map that preparation takes about a second, cluster
    start and warm-up two (:meth:`sweeps.workers.compute.Compute.start_early`).

    Made on the main thread. SIGINT is ignored until the workers are up and the submitter
    asks for the client, so they are born ignoring it (as with :func:`dask_client`); a
    Ctrl-C in those one or two seconds is dropped. ``connect`` is the context manager that
    makes the cluster (it yields a matched client), ``warm`` is ``(fn, *args)``, run on
    every worker once they are up (sweeps.workers.task.warm_up)."""

    def __init__(self, connect, warm: tuple):
        # an earlier run's cluster still stopping (close_later) stops first: two local
        # clusters overlapping also undo each other's silenced dask logs
        wait_for_stops()
        self._cm = connect
        self._client = None
        self._error: BaseException | None = None
        self._up = threading.Event()          # the cluster is started, or failed to
        self._closing = False
        self._ignoring = threading.current_thread() is threading.main_thread()
        if self._ignoring:
            self._previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        self._thread = threading.Thread(target=self._start, args=(warm,), daemon=True,
                                        name="ditherlab-cluster-start")
        self._thread.start()

    def _start(self, warm: tuple) -> None:
        try:
            self._client = self._cm.__enter__()
        except BaseException as exc:  # noqa: BLE001 -- handed to the main thread
            self._error = exc
            return
        finally:
            self._up.set()
        try:
            self._client.run(*warm)
        except BaseException as exc:  # noqa: BLE001 -- handed to the main thread
            if not self._closing:
                self._error = exc

    def _wait(self, done, should_stop, notice, after: float = NOTICE_AFTER_S) -> bool:
        t0 = time.monotonic()
        while not done():
            if should_stop():
                return False
            if notice is not None and time.monotonic() - t0 > after:
                notice()
            time.sleep(0.05)
        return True

    def _restore_sigint(self) -> None:
        if self._ignoring:   # None: a handler not set from Python; the default then
            signal.signal(signal.SIGINT, self._previous if self._previous is not None
                          else signal.default_int_handler)
            self._ignoring = False

    def client(self, should_stop=lambda: False, notice=None, starting=None):
        """The client once its workers are warm; None if ``should_stop()`` turned true
        while waiting (a first compilation can take a minute on a busy machine). Calls
        ``starting()`` every 50 ms while the workers start, and ``notice()`` every 50 ms
        once their warm-up takes longer than NOTICE_AFTER_S (displays that say so and stay
        alive). Raises what the start raised (ClusterStartError)."""
        if not self._wait(self._up.is_set, should_stop, starting, after=0.0):
            return None
        self._restore_sigint()
        if not self._wait(lambda: not self._thread.is_alive(), should_stop, notice):
            return None
        if self._error is not None:
            raise self._error
        return self._client

    def ready(self) -> bool:
        """The cluster is up and its workers warm, or its start failed (:meth:`client`
        says which), without waiting. Once the workers are up, Ctrl-C is given back here
        too, as :meth:`client` does (sweeps.run.head_start asks this while the workers
        warm up, which a first compile makes a minute)."""
        if self._up.is_set() and threading.current_thread() is threading.main_thread():
            self._restore_sigint()
        return self._up.is_set() and not self._thread.is_alive()

    def close_later(self) -> None:
        """Close the cluster on a thread, so the caller reports its result first; the
        process waits for it at its exit, ignoring Ctrl-C meanwhile (:func:`_wait_for_stops`:
        the workers are stopping anyway, and a traceback would be the last thing shown)."""
        self._restore_sigint()   # on this (main) thread: the closing thread cannot
        thread = threading.Thread(target=self.close, daemon=True, name="ditherlab-cluster-stop")
        thread.start()
        with _STOPPING_LOCK:
            if not _STOPPING:
                atexit.register(_wait_for_stops)
            _STOPPING.append(thread)

    def close(self) -> None:
        """Close the cluster (a warm-up still running ends with it)."""
        self._up.wait()
        self._restore_sigint()
        if self._client is not None:
            self._closing = True
            self._cm.__exit__(None, None, None)
        self._thread.join()


_STOPPING: list[threading.Thread] = []   # clusters closing in the background (close_later)
_STOPPING_LOCK = threading.Lock()


def wait_for_stops() -> None:
    """Wait until every cluster handed to :meth:`EarlyStart.close_later` is closed."""
    with _STOPPING_LOCK:
        threads = list(_STOPPING)
    for thread in threads:
        thread.join()
    with _STOPPING_LOCK:
        _STOPPING[:] = [t for t in _STOPPING if t.is_alive()]


def _wait_for_stops() -> None:
    """At exit: the background stops end before the process does (their workers with
    them), with Ctrl-C ignored on the main thread meanwhile."""
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        wait_for_stops()
    finally:
        if main:
            signal.signal(signal.SIGINT, previous if previous is not None else signal.SIG_DFL)


@contextmanager
def _sigint_ignored():
    """SIGINT ignored while local workers are spawned (they inherit it), so a Ctrl-C in the
    terminal, which reaches the whole process group, stops the submitter cleanly instead
    of printing a traceback from every worker. A Ctrl-C in these seconds is dropped.
    Off the main thread it does nothing (:class:`EarlyStart` ignores SIGINT itself)."""
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
