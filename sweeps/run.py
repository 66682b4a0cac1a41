"""Running a plan: blocks of points as dask tasks, a journal of finished blocks, and a
cube rebuilt from the journal and published atomically (DESIGN.md §4).

The submitting process is the only writer. Workers compute and return arrays; they
never touch files. Each finished block is journaled at once (temporary name, fsync,
rename), so a submitter killed at any instant loses at most the blocks in flight; the
cube is republished every few blocks and at the end. A resubmitted spec computes only
the blocks missing from the journal.
"""
from __future__ import annotations

import json
import logging
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import store
from engine import params as P
from engine import provenance
from engine import status as S

from . import errors, history
from .outputs import output_attrs
from .plan import Plan
from .version import __version__

PUBLISH_EVERY_S = 5.0     # republish the cube at most this often while running
ESTIMATE_FILE = "error_estimate.json"   # the sweep's error estimate (sweeps.errors)
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


# --- the task (runs on a worker) ------------------------------------------------------

def compute_block(scene, points: np.ndarray, p: np.ndarray, settings) -> dict:
    """Integrate one block; never raises (a crash of the engine marks the block FAILED)."""
    from engine.batch import run_block

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


def warm_up(scene, p: np.ndarray, settings) -> float:
    """Compile the block kernel in this process (once per worker); returns seconds."""
    t0 = time.perf_counter()
    q = p.copy()
    q[P.T_END] = min(q[P.T_END], 1e-3)
    q[P.T_TRANSIENT] = 0.0
    compute_block(scene, np.array([[0.1, 1000.0, 0.1, 0.1]]), q, settings)
    return time.perf_counter() - t0


# --- clusters --------------------------------------------------------------------------

@contextmanager
def dask_client(scheduler: str | None = None, workers: int = 2):
    """A client on an existing cluster (``scheduler`` address) or on a LocalCluster of
    ``workers`` single-threaded processes."""
    from distributed import Client, LocalCluster

    if scheduler:
        client = Client(scheduler, timeout="20s")
        try:
            yield client
        finally:
            client.close()
        return
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as client:
        yield client


# --- the cube --------------------------------------------------------------------------

def cube_attrs(plan: Plan) -> dict:
    return {
        "name": plan.spec.name,
        "sweep_id": plan.sweep_id,
        "spec": plan.spec.to_json(),
        "spec_hash": plan.sweep_id,
        "ditherlab_version": __version__,
        "engine_fingerprint": provenance.fingerprint(),   # also in the sweep id
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "path": plan.path,
        "system": plan.spec.system, "friction": plan.spec.friction,
        "dither": plan.spec.dither,
        "engine_settings": plan.numerics.as_dict() if plan.path == "simulate" else {},
        "engine_scene": {k: (list(v) if isinstance(v, tuple) else v)
                         for k, v in vars(plan.scene).items()},
        "engine_params": P.unpack(plan.params),
        "Conventions": "CF-1.8",
    }


def empty_cube(plan: Plan):
    """A cube with every point NOT_COMPUTED, the coordinates, variables and attributes of
    ``plan``."""
    variables = {name: output_attrs(plan.path, name) for name in plan.outputs}
    units = {"omega": "rad/s", "W": "m/s", "v_ref": "m/s", "v_d": "m/s"} \
        if plan.spec.system == "contact" else None
    return store.empty_cube(plan.coords, variables, cube_attrs(plan), axis_units=units)


# --- submit ----------------------------------------------------------------------------

def blocks_to_run(plan: Plan, cube) -> list[int]:
    """Blocks with a point whose status is not OK: never computed, or failed before
    (DESIGN.md §4: a resubmitted spec computes only the points whose status is not 0)."""
    status = cube["status"].values.ravel()
    return [b for b, index in enumerate(plan.blocks) if np.any(status[index] != S.OK)]


def submit(plan: Plan, store_root: str | Path, *, scheduler: str | None = None,
           workers: int = 2, progress: bool = True, max_blocks: int | None = None
           ) -> SubmitResult:
    """Run every block of ``plan`` not yet finished OK; publish the cube.

    ``max_blocks`` stops after that many new blocks (for tests of partial sweeps).
    """
    t0 = time.perf_counter()
    sweep = store.SweepDir(store_root, plan.sweep_id)
    journal = store.Journal(sweep.journal)
    cube = store.rebuild(empty_cube(plan), journal)  # what earlier runs finished
    attach_saved_estimate(sweep, cube)
    todo = blocks_to_run(plan, cube)
    catalogue = store.Catalogue(store_root)
    if not todo and sweep.cube.exists():
        return _result(plan, sweep, catalogue, cube, blocks_run=0, t0=t0, timings={})
    sweep.root.mkdir(parents=True, exist_ok=True)
    sweep.write_spec(plan.spec.to_json())
    catalogue.register(plan.sweep_id, plan.spec.name, plan.spec.to_json(), plan.n_points,
                       len(plan.blocks), sweep.root, provenance.fingerprint())
    catalogue.update(plan.sweep_id, state="running", owner=store.catalogue.owner_tag())
    store.publish(cube, sweep.cube)  # a valid cube exists from the first instant
    todo = todo[:max_blocks] if max_blocks is not None else todo
    sink = BlockSink(plan, cube, journal, sweep, catalogue)
    timings: dict = {}
    run = _run_blocks_local if plan.path != "simulate" and scheduler is None else _run_blocks
    run(plan, todo, sink, scheduler=scheduler, workers=workers, progress=progress,
        timings=timings)
    store.publish(cube, sweep.cube)
    if "compute_s" in timings and max_blocks is None:
        history.record_actual(Path(store_root), plan.sweep_id, plan.numerics.label,
                              timings["compute_s"])
    return _result(plan, sweep, catalogue, cube, blocks_run=len(todo), t0=t0, timings=timings)


class BlockSink:
    """Receives finished blocks in the submitting process: journal first (durable), then
    the in-memory cube, republished atomically every PUBLISH_EVERY_S seconds."""

    def __init__(self, plan: Plan, cube, journal, sweep, catalogue):
        self.plan, self.cube, self.journal = plan, cube, journal
        self.sweep, self.catalogue = sweep, catalogue
        self.last_publish = time.monotonic()

    def __call__(self, b: int, result: dict) -> None:
        if "error" in result:
            log.warning("block %d failed: %s", b, result["error"])
        payload = {"index": self.plan.blocks[b],
                   **{k: v for k, v in result.items() if k != "error"}}
        self.journal.write(b, payload)
        store.fill_block(self.cube, payload)
        if time.monotonic() - self.last_publish > PUBLISH_EVERY_S:
            store.publish(self.cube, self.sweep.cube)
            self.catalogue.update(self.plan.sweep_id, **_counts(self.cube))
            self.last_publish = time.monotonic()


def _run_blocks(plan: Plan, todo: list[int], sink: BlockSink, *, scheduler, workers,
                progress, timings) -> None:
    from distributed import as_completed

    bar = _progress_bar(plan, len(todo), progress)
    t = time.perf_counter()
    with dask_client(scheduler, workers) as client:
        timings["cluster_s"] = time.perf_counter() - t
        t = time.perf_counter()
        client.run(warm_up, plan.scene, plan.params, plan.numerics.settings)
        timings["warm_up_s"] = time.perf_counter() - t
        t = time.perf_counter()
        futures = {client.submit(compute_block, plan.scene, plan.block_points(b), plan.params,
                                 plan.numerics.settings, pure=False): b for b in todo}
        for future in as_completed(futures):
            sink(futures[future], future.result())
            bar.update(1)
        timings["compute_s"] = time.perf_counter() - t
        complete = not (sink.cube["status"].values == S.NOT_COMPUTED).any()
        if todo and plan.path == "simulate" and complete:
            t = time.perf_counter()
            estimate = _error_estimate(plan, client, sink.cube)
            errors.attach(sink.cube, estimate)
            _write_json(sink.sweep.root / ESTIMATE_FILE, estimate)
            timings["error_estimate_s"] = time.perf_counter() - t
    bar.close()


def _error_estimate(plan: Plan, client, cube) -> dict:
    """Re-run the error sample one accuracy level finer on the cluster, one task per
    point (sweeps.errors), and compare."""
    finer = errors.finer_numerics(plan)
    index, pts = errors.sample(plan)
    scene = plan.scene.with_(method=finer.integrator)
    futures = [client.submit(compute_block, scene, pts[i:i + 1], plan.params, finer.settings,
                             pure=False) for i in range(len(pts))]
    parts = client.gather(futures)
    result = {k: np.concatenate([part[k] for part in parts]) for k in parts[0]
              if k != "error"}
    return errors.compare(plan, cube, index, result, finer.label)


def _write_json(path: Path, data: dict) -> None:
    """Write ``data`` as JSON atomically (temporary name, fsync, rename)."""
    import os

    tmp = path.with_name(path.name + f".tmp{os.getpid()}")
    with open(tmp, "w") as f:
        json.dump(data, f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def attach_saved_estimate(sweep, cube) -> bool:
    """Put the sweep's saved error estimate (if any) into ``cube``; True when there was one."""
    path = sweep.root / ESTIMATE_FILE
    try:
        errors.attach(cube, json.loads(path.read_text()))
    except (OSError, ValueError, KeyError):
        return False
    return True


def _run_blocks_local(plan: Plan, todo: list[int], sink: BlockSink, *, scheduler, workers,
                      progress, timings) -> None:
    """The analysis paths cost microseconds per point: starting a cluster would cost
    more than the whole sweep, so they run in this process."""
    bar = _progress_bar(plan, len(todo), progress)
    t = time.perf_counter()
    for b in todo:
        sink(b, compute_block(plan.scene, plan.block_points(b), plan.params,
                              plan.numerics.settings))
        bar.update(1)
    timings["compute_s"] = time.perf_counter() - t
    bar.close()


def _progress_bar(plan: Plan, n: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=n, unit="block", desc=f"{plan.spec.name} [{plan.sweep_id}]",
                disable=not enabled, mininterval=0.5)


def _counts(cube) -> dict:
    status = cube["status"].values
    n_ok = int((status == S.OK).sum())
    n_missing = int((status == S.NOT_COMPUTED).sum())
    n_failed = int(status.size - n_ok - n_missing)
    return {"done_points": n_ok + n_failed, "failed_points": n_failed}


def _result(plan, sweep, catalogue, cube, *, blocks_run, t0, timings) -> SubmitResult:
    counts = _counts(cube)
    n = cube["status"].size
    if counts["done_points"] < n:
        state = "partial"
    else:
        state = "failed" if counts["failed_points"] else "done"
    catalogue.update(plan.sweep_id, state=state, owner="", **counts)
    n_ok = counts["done_points"] - counts["failed_points"]
    return SubmitResult(plan.sweep_id, sweep.cube, state, n, n_ok, counts["failed_points"],
                        blocks_run, len(plan.blocks), time.perf_counter() - t0, timings)
