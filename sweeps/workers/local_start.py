"""How our LocalCluster's processes start and idle: workers forked from one server that
imported the engine once (:func:`start_method`), and dask's background work, which takes
its CPU from the workers when they share the submitter's cores, turned down (QUIET)."""
from __future__ import annotations

import os
import sys
import threading

# dask's periodic work, per second, that a local cluster on a workstation does not need.
# Idle, with dask's defaults, the submitter (scheduler, nannies) took 8 % of a core and
# each worker 5 % here (2-core AMD EPYC), on a machine whose 2 cores run the 2 workers;
# with these, 1.4 % and 0.6 %. Most of a worker's is its statistical profiler, sampling
# every 10 ms for the dashboard's profile page (kept when a dashboard is asked for).
QUIET = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.system-monitor.interval": "2s",      # 500 ms: psutil's CPU and memory
    "distributed.worker.memory.monitor-interval": "1s",    # 100 ms: the nanny's memory limit
    "distributed.admin.tick.interval": "500ms",            # 20 ms: blocked-event-loop warnings
}   # (work stealing stays: a task waiting behind a running one moves to a worker gone idle)

PRELOAD = "sweeps.workers.preload"   # what the fork server imports before it forks workers
# set by dask itself (its nanny's, the process title's), and the test runner's name of the
# running test: not part of what a worker is started with (start_method)
_VOLATILE = {"PYTEST_CURRENT_TEST", "PYTHONHASHSEED", "__DASK_PARENT_PID"}
_forked_from: tuple | None = None   # (environment, sys.path) the fork server started with
_DECIDING = threading.RLock()


def start_method() -> str:
    """How this process starts local workers: ``"forkserver"``, or ``"spawn"`` (dask's
    default) where the fork server would give a worker another environment than now.

    A spawned worker is a new interpreter that imports dask, numba and the engine and
    loads numba's registries before its first block: 2-5 s of CPU each, paid by every
    worker of every cluster (16 at once took 15 s to start on a 16-core machine). The fork
    server is one process, started with the first worker, that imports all of it once
    (:mod:`sweeps.workers.preload`); each worker is forked from it, ready. It lives until
    this process ends, so it keeps the environment and ``sys.path`` it started with: a
    later cluster whose process changed them (another ``DITHERLAB_CACHE_DIR``, a test's
    gate, a path in front) gets spawned workers, which start from the present ones, and so
    does a process whose fork server would import another engine (:func:`_server_imports_ours`). The
    server is started by the first worker's start, after dask's nanny has put its
    pre-spawn environment (``OMP_NUM_THREADS``, ``MALLOC_TRIM_THRESHOLD_``,
    ``PYTHONHASHSEED``) into this process's: started earlier, it would not pass that on
    (:func:`prestart` starts it earlier, with that environment put in first)."""
    global _forked_from
    import multiprocessing

    with _DECIDING:   # (prestart's thread and a cluster's start)
        if "forkserver" not in multiprocessing.get_all_start_methods() or \
                not _server_imports_ours():
            return "spawn"
        now = (_environment(), _import_path())
        if _forked_from is None:
            _forked_from = now
            multiprocessing.get_context("forkserver").set_forkserver_preload([PRELOAD])
        _claim_preload()
        return "forkserver" if now == _forked_from else "spawn"


PRESTART_MIN_WORKERS = 4   # from this many local workers `submit` starts the server first


def prestart() -> threading.Thread:
    """Start the fork server now, on a thread, so that it imports the engine (0.9 s of a
    core here) while this process loads the spec, plans and reads the store, instead of
    after (``ditherlab submit --workers N``, N >= PRESTART_MIN_WORKERS: the start of 4
    workers here began 0.8-1.0 s into the command). The environment dask's nanny gives the
    server when it starts it (its pre-spawn environment) is put into this process's first,
    as the nanny does at its first worker's start. Nothing if the workers would be spawned
    (:func:`start_method`); a sweep that runs on threads here leaves the server idle until
    the process ends."""
    def start() -> None:
        import multiprocessing.forkserver

        with _DECIDING:   # (the environment is read under it: _environment)
            if start_method() != "forkserver":
                return
            os.environ.update(_pre_spawn_environment())
        multiprocessing.forkserver.ensure_running()

    thread = threading.Thread(target=start, daemon=True, name="ditherlab-fork-server")
    thread.start()
    return thread


def usable_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:   # (not on every platform)
        return os.cpu_count() or 1


def _distributed_defaults() -> None:
    """distributed's configuration defaults (its ``distributed.yaml``: the nanny's
    pre-spawn environment among them) in dask's configuration, as ``import distributed``
    puts them there, without that import (0.4 s, not on prestart's thread). Without them
    prestart saw no pre-spawn environment: it did not set it, and where this process had
    inherited some of it (a parent that had run a cluster) it took that for the workers'
    own environment, and the cluster's start, with the defaults, then spawned its workers
    instead of forking them (a CI run)."""
    import importlib.util

    import dask
    import yaml

    if "distributed.config" in sys.modules or _LOADED:
        return
    spec = importlib.util.find_spec("distributed")
    if spec is None or not spec.submodule_search_locations:
        return
    path = os.path.join(list(spec.submodule_search_locations)[0], "distributed.yaml")
    with open(path) as f:
        dask.config.update_defaults(yaml.safe_load(f))   # (what distributed.config does)
    _LOADED.append(path)


_LOADED: list[str] = []   # distributed.yaml once loaded by _distributed_defaults


def _pre_spawn_environment() -> dict[str, str]:
    """What dask's nanny puts into this process's environment before it starts a worker:
    ``distributed.nanny.pre-spawn-environ``, a value already set here winning, and
    PYTHONHASHSEED 6640 unless that lists another (distributed.nanny.Nanny.__init__)."""
    import dask

    _distributed_defaults()
    env = {k: os.environ.get(k, str(v))
           for k, v in (dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {}).items()
           if v is not None}
    if env.get("PYTHONHASHSEED") in (None, "0"):
        env["PYTHONHASHSEED"] = "6640"
    return env


_OURS = ("engine", "sweeps", "store")   # the packages a worker must import from where we do
_ours_where: tuple | None = None   # (cwd, environment) -> whether the server imports ours


def _server_imports_ours() -> bool:
    """Whether a fork server started now would import the engine and sweeps from where this
    process did. Python 3.11's fork server takes no ``sys.path`` from its starter (it gets
    one and drops it): it is ``python -c`` in this folder, so a folder of the current
    directory or of ``$PYTHONPATH`` named ``engine`` or ``sweeps`` (another checkout, a
    worktree of an older commit) comes before the installed package, and its workers would
    run that engine (each refused by the fingerprint check: "no worker runs this engine").
    Asked of such a process once per directory and environment (about 40 ms); spawned
    workers take this process's ``sys.path``."""
    global _ours_where
    import importlib.util
    import subprocess

    key = (os.getcwd(), _environment())
    if _ours_where is not None and _ours_where[0] == key:
        return _ours_where[1]
    # (the same question here: a package this process has not imported yet counts too)
    ask = f"import importlib.util as u; print(*[getattr(u.find_spec(n), 'origin', None) " \
          f"for n in {_OURS!r}], sep='\\n')"
    here = [str(getattr(importlib.util.find_spec(n), "origin", None)) for n in _OURS]
    try:
        got = subprocess.run([sys.executable, "-c", ask], capture_output=True, text=True,
                             timeout=60).stdout.split("\n")[:len(_OURS)]
    except (OSError, subprocess.SubprocessError):
        got = []
    _ours_where = (key, got == here)
    return _ours_where[1]


def local_settings(dashboard: str | None = None):
    """dask's settings for our LocalCluster, made inside, set for it alone (a
    ``dask.config.set`` context): the workers' start method (:func:`start_method`) and
    QUIET, without the profiler where a ``dashboard`` would show it. A LocalCluster the
    caller makes later in this process starts as dask would, its workers with the
    environment of then (not forked from our server, whose environment may be older); a
    worker our nanny restarts later is spawned, with these settings (the nanny keeps them)."""
    import dask

    quiet = dict(QUIET)
    if dashboard:
        del quiet["distributed.worker.profile.enabled"]
    return dask.config.set({"distributed.worker.multiprocessing-method": start_method(),
                            **quiet})


def _import_path() -> tuple:
    """``sys.path`` as the workers need it, less the current directory: the fork server
    (``python -c`` here) imports from it first whatever this process's path says, and the
    spec load appends it for a brought model found there (engine.user_code): counted, it
    made a prestarted server's workers spawned ones (a review found it)."""
    here = os.getcwd()
    return tuple(p for p in sys.path if os.path.abspath(p or ".") != here)


def _environment() -> tuple:
    """The environment a worker would start with, less what dask's nanny sets itself."""
    import dask

    _distributed_defaults()

    nanny_sets = set(dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {})
    return tuple(sorted((k, v) for k, v in os.environ.items()
                        if k not in _VOLATILE and k not in nanny_sets))


def _claim_preload() -> None:
    """The fork server imports :data:`PRELOAD` (set by :func:`start_method`), not dask's own
    list, which dask sets at its first worker's start unless told it is set (a private
    flag): without it dask would also import pandas and lz4 into this process, and set its
    list for a server not yet started (its workers then import the engine themselves, as
    spawned ones do). Told once distributed is imported (a cluster's start; prestart's
    thread does not import it)."""
    utils = sys.modules.get("distributed.utils")
    if utils is not None and hasattr(utils, "_forkserver_preload_set"):
        utils._forkserver_preload_set = True
