"""Running a plan: blocks of points as dask tasks, a journal of finished blocks, and a
cube rebuilt from the journal and published atomically (DESIGN.md §4).

The submitting process is the only writer, and only while it holds the sweep's lease in
the catalogue (sweeps.service): a second submitter of a running sweep attaches to it
instead of computing. Workers compute and return arrays; they never touch files. Each
finished block is journaled at once (temporary name, fsync,
rename), so a submitter killed at any instant loses at most the blocks in flight; the
cube is republished every few blocks and at the end. A resubmitted spec computes only
the blocks missing from the journal.
"""
from __future__ import annotations

import json
import logging
import os
import signal
import sys
import threading
import time
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import store
from engine import params as P
from engine import status as S

from . import estimate as errest, history, service
from .outputs import output_attrs
from .plan import Plan
from .version import __version__, results_fingerprint

PUBLISH_EVERY_S = 5.0     # republish the cube at most this often while running
ESTIMATE_FILE = "error_estimate.json"   # the sweep's error estimate (sweeps.estimate)
COUNTERS = ("status", "cost_s", "steps", "evals")

log = logging.getLogger("ditherlab")


@dataclass
class SubmitResult:
    sweep_id: str
    cube_path: Path
    state: str
    n_points: int
    n_ok: int
    n_failed: int
    blocks_run: int
    blocks_total: int
    wall_s: float
    timings: dict = field(default_factory=dict)  # phase -> seconds (cluster, warm_up, compute)
    message: str = ""       # why the run stopped early, or what went wrong
    attached_to: str = ""   # the owner whose run this call waited for (it computed nothing)


# --- the task (runs on a worker) ------------------------------------------------------

BLOCK_LOG_ENV = "DITHERLAB_BLOCK_LOG"   # diagnostics: a file every computed block is noted in


def compute_block(scene, points: np.ndarray, p: np.ndarray, settings) -> dict:
    """Integrate one block; never raises (a crash of the engine marks the block FAILED).

    With ``$DITHERLAB_BLOCK_LOG`` set (inherited by local dask workers), appends one line
    per call to that file: pid and :func:`block_key` (how the tests count block
    computations across processes).
    """
    from engine.batch import run_block

    if os.environ.get(BLOCK_LOG_ENV):
        _note_block(os.environ[BLOCK_LOG_ENV], block_key(scene, points, settings))
    try:
        res = run_block(scene, points, p, settings)
    except Exception as exc:  # noqa: BLE001 -- one bad block must not end the sweep
        n = len(points)
        nan = np.full(n, np.nan)
        return {**{name: nan for name in scene.outputs},
                "status": np.full(n, S.FAILED, np.int8), "cost_s": np.zeros(n),
                "steps": np.zeros(n, np.int64), "evals": np.zeros(n, np.int64),
                "error": f"{type(exc).__name__}: {exc}"}
    return {**res.outputs, "status": res.status, "cost_s": res.cost_s,
            "steps": res.steps, "evals": res.evals}


def block_key(scene, points: np.ndarray, settings) -> str:
    """A short hash of one block computation: its points, scene and numerics (the key
    ``$DITHERLAB_BLOCK_LOG`` lines carry; the error estimate's finer re-runs differ)."""
    import hashlib

    h = hashlib.sha1(np.ascontiguousarray(points, np.float64).tobytes())
    h.update(repr((scene, settings)).encode())
    return h.hexdigest()[:16]


def _note_block(path: str, key: str) -> None:
    line = f"{os.getpid()} {key}\n".encode()
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, line)   # one short O_APPEND write: lines of processes never interleave
    finally:
        os.close(fd)


def warm_up(scene, p: np.ndarray, settings) -> float:
    """Compile the block kernel in this process (once per worker); returns seconds.
    Calls the engine directly, not compute_block: no ``$DITHERLAB_BLOCK_LOG`` line."""
    from engine.batch import run_block

    t0 = time.perf_counter()
    q = p.copy()
    q[P.T_END] = min(q[P.T_END], 1e-3)
    q[P.T_TRANSIENT] = 0.0
    try:
        run_block(scene, np.array([[0.1, 1000.0, 0.1, 0.1]]), q, settings)
    except Exception as exc:  # noqa: BLE001 -- the sweep's own blocks report it (compute_block)
        log.debug("warm-up failed: %s", exc)
    return time.perf_counter() - t0


# --- clusters --------------------------------------------------------------------------

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
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=dashboard, silence_logs=logging.ERROR, **http)
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


# --- the cube --------------------------------------------------------------------------

def cube_attrs(plan: Plan) -> dict:
    return {
        "name": plan.spec.name,
        "sweep_id": plan.sweep_id,
        "spec": plan.spec.to_json(),
        "spec_hash": plan.sweep_id,
        "ditherlab_version": __version__,
        "engine_fingerprint": results_fingerprint(),   # also in the sweep id
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "path": plan.path,
        "system": plan.spec.system, "friction": plan.spec.friction,
        "dither": plan.spec.dither,
        "engine_settings": plan.numerics.as_dict() if plan.path == "simulate" else {},
        "engine_scene": {k: (list(v) if isinstance(v, tuple) else v)
                         for k, v in vars(plan.scene).items()},
        "engine_params": {k: v for k, v in P.unpack(plan.params).items()
                          if k not in AXIS_PARAMS},   # the axes are the cube's coordinates
        "Conventions": "CF-1.8",
        **software_versions(),
    }


AXIS_PARAMS = ("W", "omega", "v_ref", "vd")


def software_versions() -> dict[str, str]:
    """``<package>_version`` of what computed the cube (the engine's own is its fingerprint)."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"python_version": sys.version.split()[0]}
    for pkg in ("numpy", "numba", "scipy", "dask", "xarray", "h5netcdf"):
        try:
            out[f"{pkg}_version"] = version(pkg)
        except PackageNotFoundError:
            out[f"{pkg}_version"] = "not installed"
    return out


def empty_cube(plan: Plan):
    """A cube with every point NOT_COMPUTED, the coordinates, variables and attributes of
    ``plan``."""
    variables = {name: output_attrs(plan.path, name) for name in plan.outputs}
    units = {"omega": "rad/s", "W": "m/s", "v_ref": "m/s", "v_d": "m/s"} \
        if plan.spec.system == "contact" else None
    names = {"omega": "dither angular frequency: inf, the averaged theory is the limit "
                      "omega -> infinity"} if plan.path == "averaged" else None
    cube = store.empty_cube(plan.coords, variables, cube_attrs(plan), axis_units=units,
                            axis_long_names=names)
    if plan.spec.refine:
        store.cube.add_provenance(cube)
    return cube


# --- submit ----------------------------------------------------------------------------

def blocks_to_run(plan: Plan, cube) -> list[int]:
    """Blocks with a point whose status is not OK: never computed, or failed before
    (DESIGN.md §4: a resubmitted spec computes only the points whose status is not 0).
    A refined sweep's blocks are known level by level: sweeps.run_refined.replay."""
    if plan.spec.refine:
        from .run_refined import replay

        return replay(plan, cube)
    status = cube["status"].values.ravel()
    return [b for b, index in enumerate(plan.blocks) if np.any(status[index] != S.OK)]


def submit(plan: Plan, store_root: str | Path, *, scheduler: str | None = None,
           workers: int = 2, progress: bool = True, max_blocks: int | None = None,
           client=None, owner: str | None = None, stop=None,
           dashboard: str | None = None) -> SubmitResult:
    """Run every block of ``plan`` not yet finished OK; publish the cube.

    Blocks are computed only under the sweep's lease (sweeps.service): when another live
    process holds it, this call attaches, computes nothing, and returns that run's result
    (taking the lease over if the holder dies first).

    ``max_blocks`` stops after that many new blocks (for tests of partial sweeps).
    ``client`` is a dask client to use instead of starting a cluster (``dashboard``: the
    address of a started LocalCluster's dashboard, see :func:`dask_client`); ``owner`` the lease
    owner tag (default this process's ``host:pid``); ``stop`` a ``threading.Event`` that,
    once set, ends the run after its in-flight blocks and re-queues the sweep (serve).
    """
    t0 = time.perf_counter()
    store.layout.check_store(store_root, write=True)   # read-only, a file: one line, now
    sweep = store.SweepDir(store_root, plan.sweep_id)
    journal = store.Journal(sweep.journal)
    # what earlier runs finished; bad blocks are only skipped until this process holds
    # the sweep (their writer may be replacing them right now)
    cube = store.rebuild(empty_cube(plan), journal, _checked_blocks(plan), repair=False)
    attach_saved_estimate(sweep, cube)
    todo = blocks_to_run(plan, cube)
    catalogue = store.Catalogue(store_root)
    if not todo and store.cube.disagreement(sweep.cube, cube) is None \
            and not _needs_estimate(plan, sweep, cube):
        return _result(plan, sweep, catalogue, cube, blocks_run=0, t0=t0, timings={},
                       owner=owner)
    _check_space(plan, sweep, cube, todo)
    sweep.root.mkdir(parents=True, exist_ok=True)
    sweep.write_spec(plan.spec.to_json())
    catalogue.register(plan.sweep_id, plan.spec.name, plan.spec.to_json(), plan.n_points,
                       len(plan.blocks), sweep.root, results_fingerprint())
    lease, attached = _take_lease(plan, catalogue, owner, stop, progress)
    if lease is None:
        return _attached_result(plan, sweep, attached, t0)
    sink, timings = None, {}
    try:
        # this process alone writes from here on; the journal may have grown since the
        # rebuild above (another writer finished or died in between): read it again
        cube = store.rebuild(empty_cube(plan), journal, _checked_blocks(plan))
        attach_saved_estimate(sweep, cube)
        todo = blocks_to_run(plan, cube)
        _republish(plan, sweep, cube)  # a valid cube, equal to the journal, from the start
        todo = todo[:max_blocks] if max_blocks is not None else todo
        sink = BlockSink(plan, cube, journal, sweep, lease)
        run = _run_blocks_local if plan.path != "simulate" and scheduler is None \
            else _run_blocks
        if plan.spec.refine:
            from .run_refined import run
        if todo or _needs_estimate(plan, sweep, cube):
            run(plan, todo, sink, scheduler=scheduler, workers=workers, progress=progress,
                timings=timings, client=client, dashboard=dashboard)
        if sink.stopped != service.LEASE_LOST:   # else the new holder publishes
            store.publish(cube, sweep.cube)
    except BaseException as exc:
        _abort(plan, sink, lease, exc, serving=stop is not None)
        raise
    if "compute_s" in timings and max_blocks is None and sink.stopped is None:
        history.record_actual(Path(store_root), plan.sweep_id, plan.numerics.label,
                              timings["compute_s"])
    log.debug("sweep %s timings: %s", plan.sweep_id,
              ", ".join(f"{k} {v:.2f} s" for k, v in timings.items()) or "-")
    return _result(plan, sweep, catalogue, cube, blocks_run=sink.blocks_run, t0=t0,
                   timings=timings, lease=lease, stopped=sink.stopped,
                   max_blocks=max_blocks)


def _checked_blocks(plan: Plan):
    """The blocks the journal is checked against: a refined sweep's are not known before
    its replay (sweeps.run_refined), so only checksums and index ranges are checked."""
    return None if plan.spec.refine else plan.blocks


def _check_space(plan: Plan, sweep, cube, todo: list[int]) -> None:
    """Refuse to start (``store.layout.NoSpaceError``) unless the journal blocks still to
    write and one more copy of the cube fit on the store's disk, counted generously."""
    per_point = sum(v.size for v in cube.data_vars.values()) // cube["status"].size + 1
    need = sum(store.journal.block_bytes(len(plan.blocks[b]), per_point) for b in todo)
    store.layout.ensure_space(sweep.root, need + store.cube.cube_bytes(cube))


def _republish(plan: Plan, sweep, cube) -> None:
    """Publish ``cube`` (rebuilt from the journal), saying so when the published cube
    was missing, unreadable or different (a run killed before its last publish, a
    damaged file)."""
    why = store.cube.disagreement(sweep.cube, cube) if sweep.cube.exists() else None
    store.publish(cube, sweep.cube)
    if why:
        log.warning("sweep %s: %s; republished it from the journal", plan.sweep_id, why)


def _take_lease(plan: Plan, catalogue, owner, stop, progress):
    """``(Lease, None)`` once this process holds the sweep, or ``(None, row)`` with the
    final row of the run it attached to."""
    while True:
        lease, row = service.Lease.take(catalogue, plan.sweep_id, owner, stop)
        if lease is not None:
            return lease, None
        row = service.attach(catalogue, plan.sweep_id, progress=progress)
        if row["state"] in service.FINAL:
            return None, row
        # queued again (a serve stopped) or stalled (the holder died): take it over
        if progress:
            print(f"sweep {plan.sweep_id}: {row['owner'] or 'its runner'} stopped "
                  f"({catalogue.live_state(row)}); taking it over", file=sys.stderr, flush=True)


class BlockSink:
    """Receives finished blocks in the submitting process: journal first (durable), then
    the in-memory cube, republished atomically every PUBLISH_EVERY_S seconds; progress
    (journaled blocks, points) goes to the catalogue under the lease. Between blocks the
    dispatch loop asks :meth:`should_stop` (cancel, serve shutdown, lease lost)."""

    def __init__(self, plan: Plan, cube, journal, sweep, lease):
        self.plan, self.cube, self.journal = plan, cube, journal
        self.sweep, self.lease = sweep, lease
        self.last_publish = time.monotonic()
        self.done = set(_done_blocks(plan, cube))   # blocks with every point computed
        self.blocks_run = 0
        self.stopped: str | None = None              # service.CANCELLED / SHUTDOWN / ...
        self._report(force=True)

    def __call__(self, b: int, result: dict) -> None:
        if "error" in result:
            log.warning("block %d failed: %s", b, result["error"])
        payload = {"index": self.plan.blocks[b],
                   **{k: v for k, v in result.items() if k != "error"}}
        self.journal.write(b, payload)
        store.fill_block(self.cube, payload)
        self.done.add(b)
        self.blocks_run += 1
        if time.monotonic() - self.last_publish > PUBLISH_EVERY_S and \
                self.stopped != service.LEASE_LOST:
            store.publish(self.cube, self.sweep.cube)
            self.last_publish = time.monotonic()
        self._report()

    def _report(self, force: bool = False, **extra) -> None:
        if force or self.lease.due():
            self.lease.progress(force=True, done_blocks=len(self.done), **_counts(self.cube),
                                **extra)

    def started(self) -> None:
        """Blocks begin to flow now (cluster up, kernels warm): the origin of the ETA."""
        self._report(force=True, run_started=time.time(), run_start_blocks=len(self.done))

    def should_stop(self) -> bool:
        """True when no further block should be submitted (the reason in ``stopped``)."""
        if self.stopped is None:
            self.stopped = self.lease.stop_reason()
            if self.stopped is not None:
                log.warning("sweep %s: stopping after the blocks in flight (%s)",
                            self.plan.sweep_id, self.stopped)
        return self.stopped is not None


def _done_blocks(plan: Plan, cube) -> list[int]:
    status = cube["status"].values.ravel()
    return [b for b, index in enumerate(plan.blocks) if np.all(status[index] != S.NOT_COMPUTED)]


def _run_blocks(plan: Plan, todo: list[int], sink: BlockSink, *, scheduler, workers,
                progress, timings, client=None, dashboard=None) -> None:
    bar = _progress_bar(plan, todo, progress)
    t = time.perf_counter()
    with (nullcontext(client) if client is not None
          else dask_client(scheduler, workers, dashboard)) as cluster_client:
        client = cluster_client
        timings["cluster_s"] = time.perf_counter() - t
        t = time.perf_counter()
        warm = _warm_up_workers(client, plan, sink)
        timings["warm_up_s"] = time.perf_counter() - t
        t = time.perf_counter()
        if warm:
            sink.started()
            _dispatch(client, plan, todo, sink, bar)
        timings["compute_s"] = time.perf_counter() - t
        if _needs_estimate(plan, sink.sweep, sink.cube) or \
                (todo and plan.path == "simulate" and _complete(sink.cube)):
            estimate_into(plan, client, sink, timings)
    bar.close()


def estimate_into(plan: Plan, client, sink: BlockSink, timings: dict) -> None:
    """The error estimate (sweeps.estimate) of a finished simulated sweep, into its cube
    and ``<sweep>/error_estimate.json``; a failure is recorded as a warning, never lost."""
    t = time.perf_counter()
    try:
        estimate = _error_estimate(plan, client, sink.cube)
    except Exception as exc:  # noqa: BLE001 -- say so in the cube, keep the results
        estimate = {"compared_with": None, "level": plan.numerics.label,
                    "sample_points": 0, "change": {}, "promise": {},
                    "warnings": [f"the error estimate could not be computed "
                                 f"({type(exc).__name__}: {exc}); submit again"]}
    errest.attach(sink.cube, estimate)
    if estimate["compared_with"] is not None:
        _write_json(sink.sweep.root / ESTIMATE_FILE, estimate)
    timings["error_estimate_s"] = time.perf_counter() - t


def _error_estimate(plan: Plan, client, cube) -> dict:
    """Re-run the error sample one accuracy level finer on the cluster, one task per
    point (sweeps.estimate), and compare."""
    finer = errest.finer_numerics(plan)
    index, pts = errest.sample(plan)
    scene = plan.scene.with_(integrator=finer.integrator)
    futures = [client.submit(compute_block, scene, pts[i:i + 1], plan.params, finer.settings,
                             pure=False) for i in range(len(pts))]
    parts = client.gather(futures)
    result = {k: np.concatenate([part[k] for part in parts]) for k in parts[0]
              if k != "error"}
    return errest.compare(plan, cube, index, result, finer.label)


def _write_json(path: Path, data: dict) -> None:
    """Write ``data`` as JSON atomically (temporary name, fsync, rename)."""
    import os

    tmp = path.with_name(path.name + f".tmp{os.getpid()}")
    with open(tmp, "w") as f:
        json.dump(data, f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _complete(cube) -> bool:
    return not (cube["status"].values == S.NOT_COMPUTED).any()


def _needs_estimate(plan: Plan, sweep, cube) -> bool:
    """A finished simulated sweep without a saved error estimate (its run was killed
    between the last block and the estimate): it is computed before the sweep is done,
    so that no cube goes unchecked."""
    return (plan.path == "simulate" and _complete(cube)
            and not (sweep.root / ESTIMATE_FILE).exists())


def attach_saved_estimate(sweep, cube) -> bool:
    """Put the sweep's saved error estimate (if any) into ``cube``; True when there was one."""
    path = sweep.root / ESTIMATE_FILE
    try:
        errest.attach(cube, json.loads(path.read_text()))
    except (OSError, ValueError, KeyError):
        return False
    return True


def _warm_up_workers(client, plan: Plan, sink: BlockSink) -> bool:
    """Compile the kernel on every worker (``warm_up``), asking ``sink.should_stop()`` while
    it runs (a first compilation can take a minute on a busy machine). False if stopped."""
    outcome: dict = {}

    def run() -> None:
        try:
            client.run(warm_up, plan.scene, plan.params, plan.numerics.settings)
        except BaseException as exc:  # noqa: BLE001 -- handed to the calling thread
            outcome["error"] = exc

    thread = threading.Thread(target=run, daemon=True, name="ditherlab-warm-up")
    thread.start()
    while thread.is_alive():
        thread.join(0.25)
        if thread.is_alive() and sink.should_stop():
            return False
    if "error" in outcome:
        raise outcome["error"]
    return True


def _dispatch(client, plan: Plan, todo: list[int], sink: BlockSink, bar) -> None:
    """Keep one block per worker thread (plus one) in flight, the next submitted as one
    finishes; once ``sink.should_stop()``, submit no more and collect those in flight (a
    stop loses no finished work and waits for at most one block per worker)."""
    from distributed import as_completed

    queue = list(reversed(todo))
    inflight: dict = {}
    done = as_completed(loop=client.loop)
    window, window_at = 1, -1e9

    def fill() -> None:
        nonlocal window, window_at
        if time.monotonic() - window_at > 5.0:   # workers may join or leave
            window = max(1, sum(client.nthreads().values())) + 1
            window_at = time.monotonic()
        while queue and len(inflight) < window:
            b = queue.pop()
            future = client.submit(compute_block, plan.scene, plan.block_points(b),
                                   plan.params, plan.numerics.settings, pure=False)
            inflight[future] = b
            done.add(future)

    if not sink.should_stop():
        fill()
    for future in done:
        b = inflight.pop(future)
        sink(b, future.result())
        bar.update(len(plan.blocks[b]))
        if not sink.should_stop():
            fill()


def _run_blocks_local(plan: Plan, todo: list[int], sink: BlockSink, *, scheduler, workers,
                      progress, timings, client=None, dashboard=None) -> None:
    """The analysis paths cost microseconds per point: starting a cluster would cost
    more than the whole sweep, so they run in this process."""
    bar = _progress_bar(plan, todo, progress)
    t = time.perf_counter()
    sink.started()
    for b in todo:
        if sink.should_stop():
            break
        sink(b, compute_block(plan.scene, plan.block_points(b), plan.params,
                              plan.numerics.settings))
        bar.update(len(plan.blocks[b]))
    timings["compute_s"] = time.perf_counter() - t
    bar.close()


def _progress_bar(plan: Plan, todo: list[int], enabled: bool):
    """Progress in points (blocks are small and cost-balanced: sweeps.plan), with tqdm's
    rate and ETA."""
    from tqdm import tqdm

    return tqdm(total=sum(len(plan.blocks[b]) for b in todo), unit="point",
                desc=f"{plan.spec.name} [{plan.sweep_id}]", disable=not enabled,
                mininterval=0.5)


def _counts(cube) -> dict:
    status = cube["status"].values
    n_ok = int((status == S.OK).sum())
    n_missing = int((status == S.NOT_COMPUTED).sum())
    n_failed = int(status.size - n_ok - n_missing)
    return {"done_points": n_ok + n_failed, "failed_points": n_failed}


def _result(plan, sweep, catalogue, cube, *, blocks_run, t0, timings, owner=None, lease=None,
            stopped=None, max_blocks=None) -> SubmitResult:
    """The run's final state, recorded in the catalogue (giving the lease back):

    every point final -> ``done``, or ``partial`` when some failed or went non-finite;
    points left -> ``cancelled`` (cancel, ``max_blocks``) or ``queued`` (serve stopping).
    Without a lease (nothing was left to compute) the row is settled unless a live
    process holds it.
    """
    counts = _counts(cube)
    n = cube["status"].size
    n_done_blocks = len(_done_blocks(plan, cube))
    progress = f"{n_done_blocks}/{len(plan.blocks)} blocks"
    if counts["done_points"] == n:
        state = "partial" if counts["failed_points"] else "done"
        message = (f"{counts['failed_points']} of {n} points failed or went non-finite "
                   "(submit again to retry them)" if counts["failed_points"] else "")
    elif stopped == service.SHUTDOWN:
        state = "queued"
        message = (f"re-queued after {progress}: serve {lease.owner} stopped; the next "
                   "serve or submit resumes it")
    elif stopped == service.CANCELLED:
        state, message = "cancelled", f"cancelled after {progress}; submit again to resume"
    elif stopped == service.LEASE_LOST:
        state, message = "running", f"another process took the sweep over after {progress}"
    else:
        state = "cancelled"
        message = (f"stopped after {progress} (max_blocks={max_blocks}); submit again to "
                   "resume")
    fields = dict(message=message, done_blocks=n_done_blocks, **counts)
    if lease is not None:
        if stopped != service.LEASE_LOST:
            lease.end(state, **fields)
        else:
            lease.close()
    else:
        try:
            catalogue.get(plan.sweep_id)   # adopts a cube whose row was lost
        except LookupError:
            catalogue.register(plan.sweep_id, plan.spec.name, plan.spec.to_json(),
                               plan.n_points, len(plan.blocks), sweep.root)
        catalogue.finish(plan.sweep_id, state, owner=owner, **fields)
    n_ok = counts["done_points"] - counts["failed_points"]
    return SubmitResult(plan.sweep_id, sweep.cube, state, n, n_ok, counts["failed_points"],
                        blocks_run, len(plan.blocks), time.perf_counter() - t0, timings,
                        message=message)


def _attached_result(plan, sweep, row, t0) -> SubmitResult:
    """The result of the run this call attached to, read from its published cube."""
    n = plan.n_points
    n_failed, n_ok = row["failed_points"], row["done_points"] - row["failed_points"]
    if sweep.cube.exists():
        try:
            counts = _counts(store.open_cube(sweep.cube))
            n_failed = counts["failed_points"]
            n_ok = counts["done_points"] - n_failed
        except Exception as err:  # noqa: BLE001 -- the row's counts will do
            log.warning("cannot read %s: %s", sweep.cube, err)
    return SubmitResult(plan.sweep_id, sweep.cube, row["state"], n, n_ok, n_failed, 0,
                        len(plan.blocks), time.perf_counter() - t0, {},
                        message=row["message"],
                        attached_to=row.get("attached_to") or "another process")


def _abort(plan, sink, lease, exc: BaseException, *, serving: bool) -> None:
    """The run raised: keep what was finished (publish), and give the lease back as
    ``failed`` with the error, or -- interrupted (Ctrl-C, a second signal to serve) --
    as ``cancelled`` (``queued`` under serve), resumable."""
    counts, progress = {}, "starting"
    if sink is not None:
        try:
            store.publish(sink.cube, sink.sweep.cube)
        except store.layout.NoSpaceError:
            pass   # the previous cube stays whole; the error itself is reported
        except Exception as err:  # noqa: BLE001 -- the journal keeps the blocks anyway
            log.warning("could not publish the cube after the run stopped: %s", err)
        counts = dict(done_blocks=len(sink.done), **_counts(sink.cube))
        progress = f"{len(sink.done)}/{len(plan.blocks)} blocks"
    try:
        if isinstance(exc, Exception):
            text = f"{type(exc).__name__}: {exc}".strip().splitlines()[0][:500]
            lease.end("failed", message=f"the run crashed after {progress}: {text}", **counts)
        elif serving:
            lease.end("queued", message=f"interrupted after {progress}; re-queued", **counts)
        else:
            lease.end("cancelled", message=(f"interrupted after {progress}; submit again to "
                                            "resume"), **counts)
    except Exception as err:  # noqa: BLE001 -- do not hide the original error
        if not isinstance(exc, store.layout.NoSpaceError):   # SQLite is out of space too
            log.warning("could not record the stop of sweep %s: %s", plan.sweep_id, err)
        lease.close()
