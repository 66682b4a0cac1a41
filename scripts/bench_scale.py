"""How far one submitting process scales (docs/BATCH.md "How many workers one submitter
feeds"): what the submitter does per block, measured piece by piece, and the table of
workers it keeps busy that follows. Every figure is wall time and this process's CPU time
(the machine may be shared: the load average is printed).

    .venv/bin/python scripts/bench_scale.py [--quick] [--only sink|publish|memory|dask|fed]

1. sink: blocks/s that the journal and the catalogue (progress under the lease) accept,
   through ``sweeps.run.sink.BlockSink`` itself, with the cube filled and republished as
   in a run, the blocks handed over one by one and in groups (as the dispatch finds them);
2. publish: a cube of 10^3 .. 10^6 points, without and with ``alpha_hist`` (10 values per
   point), every value noise (the worst case for compression);
3. memory: the submitter's peak resident memory against cube size (a fresh process per
   size: plan, empty cube, every block through the sink with noise values, publish);
4. dask: the dispatch (``sweeps.run.dispatch``) and sink with a worker task that computes
   nothing: tasks/s and CPU per task, 1 thread per worker (3 tasks in flight: the latency
   of one task), 32 (65 in flight: the throughput of many workers), and 32 with 1000
   more worker addresses in every task's restriction (as 1000 matching workers give);
5. fed: the submitter's side of 1,000 single-threaded workers at 1-s blocks (64 threads
   whose blocks claim 0.064 s and return at once: 1,000 blocks/s asked of the dispatch,
   which gives each task 10 blocks, as for 1,000 workers), blocks/s journaled;
6. the table: for a point cost, the plan's block, and the workers one submitter keeps
   busy with one block a task, and with the blocks per task the dispatch chooses beyond
   the ceiling (sweeps.planning.plan.blocks_per_task).
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def spec_of(n_points: int, block: int = 16, hist: bool = False) -> dict:
    """A simulated elasto-plastic spec of ``n_points`` (W x omega), blocks of ``block``."""
    w = 1000 if n_points >= 10_000 else 10
    outputs = ["stick_fraction", "slip_fraction", "v_mean", "F_mean"] + \
        (["alpha_hist"] if hist else [])
    return {"name": f"scale-{n_points}", "friction": "elastoplastic", "dither": "sine-velocity",
            "outputs": outputs, "block_size": block, "accuracy": "draft",
            "grid": {"W": {"start": 0.0, "stop": 3.0, "num": w},
                     "omega": {"start": 10.0, "stop": 1000.0, "num": n_points // w}}}


def _plan(spec: dict):
    from sweeps.planning.plan import make_plan
    from sweeps.spec.load import load_spec

    return make_plan(load_spec(spec, max_points=2_000_000))


def instant_block(scene, points, p, settings, index=None, sizes=None, point_s=None):
    """``sweeps.workers.task.compute_block`` computing nothing: what a worker returns for
    ``points`` (a store.BlockRecord), at once, every value noise; each point claims to
    have cost ``point_s`` seconds (default: noise in [0, 1))."""
    from store.record import BlockRecord
    from sweeps.version import results_fingerprint

    n, rng = len(points), np.random.default_rng(len(points))
    out = {k: rng.random((n, 10) if k == "alpha_hist" else n) for k in scene.outputs}
    cost = rng.random(n) if point_s is None else np.full(n, point_s)
    return BlockRecord(np.arange(n) if index is None else index, np.zeros(n), cost,
                       rng.integers(1, 10**6, n), rng.integers(1, 10**6, n), out,
                       fingerprint=results_fingerprint())


def _sweep(plan, root: Path):
    """A registered sweep under a real lease: (sweep folder, lease, cube, BlockSink)."""
    import store
    from sweeps.run.lease_holder import Lease
    from sweeps.run.new_cube import empty_cube
    from sweeps.run.sink import BlockSink
    from sweeps.version import results_fingerprint

    sweep = store.SweepDir(root, plan.sweep_id)
    sweep.root.mkdir(parents=True, exist_ok=True)
    catalogue = store.Catalogue(root)
    catalogue.register(plan.sweep_id, plan.spec.name, plan.spec.to_json(), plan.n_points,
                       len(plan.blocks), sweep.root, results_fingerprint())
    lease, _ = Lease.take(catalogue, plan.sweep_id, None, None)
    cube = empty_cube(plan)
    store.publish(cube, sweep.cube)   # as a run's first publish (h5netcdf imported)
    return sweep, lease, cube, BlockSink(plan, cube, store.Journal(sweep.journal), sweep, lease)


def sink_run(plan, root: Path, group: int = 1) -> tuple[float, float, int]:
    """Every block (noise results) through a BlockSink, ``group`` at a time, then the
    last publish; returns (seconds, CPU seconds, blocks) of the blocks alone."""
    import store

    sweep, lease, cube, sink = _sweep(plan, root)
    n = len(plan.blocks)
    noise = {len(index): instant_block(plan.scene, plan.block_points(b), None, None)
             for b, index in enumerate(plan.blocks)}   # values made once per block size
    t, c = time.perf_counter(), time.process_time()
    for i in range(0, n, group):   # (a record per block, as the dispatch hands them over)
        sink.many([(b, replace(noise[len(plan.blocks[b])], index=plan.blocks[b]))
                   for b in range(i, min(n, i + group))])
    seconds, cpu = time.perf_counter() - t, time.process_time() - c
    store.publish(cube, sweep.cube)
    lease.end("done")
    return seconds, cpu, n


def bench_sink(tmp: Path, n_blocks: int) -> dict[int, tuple[float, float]]:
    """Blocks/s (and CPU ms a block) one by one, in groups of 20 (what the dispatch finds
    ready in one 20-ms tick at 1,000 blocks/s) and of 100."""
    plan, rates = _plan(spec_of(16 * n_blocks, block=16)), {}
    for group in (1, 20, 100):
        seconds, cpu, n = sink_run(plan, tmp / f"sink-{group}", group)
        rates[group] = (n / seconds, 1e3 * cpu / n)
        print(f"sink      {n} blocks of 16 points, {group:>3} at a time (journal + cube + "
              f"catalogue + publish): {rates[group][0]:7,.0f} blocks/s, "
              f"{1e3 * cpu / n:.2f} ms CPU a block")
    return rates


def bench_publish(tmp: Path, sizes: list[int]) -> None:
    import store
    from sweeps.run.new_cube import empty_cube

    for hist in (False, True):
        for n in sizes:
            cube = empty_cube(_plan(spec_of(n, block=256, hist=hist)))
            for v in cube.data_vars.values():
                v.data[...] = np.random.default_rng(1).random(v.shape).astype(v.data.dtype)
            path, best = tmp / f"pub-{n}-{hist}.nc", (1e9, 1e9)
            for _ in range(3 if n < 1_000_000 else 1):
                t, c = time.perf_counter(), time.process_time()
                store.publish(cube, path)
                best = min(best, (time.perf_counter() - t, time.process_time() - c))
            print(f"publish   {n:>9,} points{' + alpha_hist' if hist else '':<13} "
                  f"{best[0]:6.3f} s, CPU {best[1]:6.3f} s  ({path.stat().st_size / 1e6:6.1f} MB)")


MEMORY_CHILD = """
import sys
sys.path.insert(0, {root!r})
from pathlib import Path
sys.argv = ['x']
import scripts.bench_scale as b
import store, sweeps.run.sink, sweeps.run.new_cube, sweeps.run.lease_holder, sweeps.planning.plan, sweeps.spec.load
import h5netcdf  # (imported by a run's first publish)
base = int(open('/proc/self/statm').read().split()[1]) * 4096 / 1e6
plan = b._plan(b.spec_of({n}, block=256, hist=True))
b.sink_run(plan, Path({tmp!r}), 20)
cube = sweeps.run.new_cube.empty_cube(plan)
nbytes = sum(v.data.nbytes for v in cube.variables.values())
hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1]
print(base, int(hwm) / 1e3, nbytes / 1e6)
"""


def bench_memory(tmp: Path, sizes: list[int]) -> None:
    before = None
    for n in sizes:
        code = MEMORY_CHILD.format(root=str(ROOT), n=n, tmp=str(tmp / f"mem-{n}"))
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True, cwd=tmp)
        base, peak, cube_mb = map(float, out.stdout.split()[-3:])
        grew = "" if before is None else \
            f"; {(peak - base - before[0]) / (cube_mb - before[1]):4.2f} MB per MB of cube since"
        print(f"memory    {n:>9,} points + alpha_hist: cube {cube_mb:7.1f} MB, submitter's "
              f"peak {peak - base:7.1f} MB above its imports ({(peak - base) / cube_mb:5.2f} x "
              f"the cube{grew})")
        before = (peak - base, cube_mb)


def bench_dask(tmp: Path, n_tasks: int) -> dict[str, tuple[float, float]]:
    """Tasks/s through the run's own dispatch and sink (a LocalCluster of 2 workers; the
    scheduler in this process, as with --cluster), every task one 16-point block."""
    from distributed import Client, LocalCluster

    from sweeps.run import dispatch
    from sweeps.workers import task
    from sweeps.workers.matching import matched

    task.compute_block = instant_block   # (pickled by reference: scripts.bench_scale)
    plan, rates = _plan(spec_of(16 * n_tasks, block=16)), {}
    for threads, more in ((1, 0), (32, 0), (32, 1000)):
        with LocalCluster(n_workers=2, threads_per_worker=threads, host="127.0.0.1",
                          dashboard_address=None, silence_logs=logging.CRITICAL,
                          scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}) as cluster, \
                Client(cluster) as client:
            sweep, lease, cube, sink = _sweep(plan, tmp / f"dask-{threads}-{more}")
            client.run(task.identity)
            mc = matched(client)
            if more:   # addresses nobody listens at, in every task's restriction
                matching, fake = mc.check.matching, {f"tcp://127.0.0.2:{20000 + i}": 1
                                                     for i in range(more)}
                mc.check.matching = lambda: {**matching(), **fake}
            t, c = time.perf_counter(), time.process_time()
            dispatch._dispatch(mc, plan, list(range(n_tasks)), sink, _NoBar())
            seconds, cpu = time.perf_counter() - t, time.process_time() - c
            lease.end("done")
        key = f"{threads}" + (f"+{more}" if more else "")
        rates[key] = (n_tasks / seconds, 1e3 * cpu / n_tasks)
        print(f"dask      {n_tasks} tasks of 16 points, 2 workers x {threads:>2} threads"
              f"{f' (+{more} addresses)' if more else '':<17}: {rates[key][0]:5,.0f} tasks/s, "
              f"{1e3 * cpu / n_tasks:.2f} ms CPU a task (dispatch + sink + scheduler)")
    return rates


def bench_fed(tmp: Path, n_blocks: int) -> tuple[float, float, float]:
    """The submitter's side of 1,000 single-threaded workers at 1-s blocks: 64 worker
    threads (2 workers x 32) whose tasks return at once, every block claiming 0.064 s,
    so that the dispatch is asked for 64 / 0.064 = 1,000 blocks a second and groups
    blocks_per_task = 10 blocks a task, as it would for 1,000 workers at 1 s. Returns
    (blocks/s, tasks/s, CPU ms a block) through the run's own dispatch and sink."""
    import functools

    from distributed import Client, LocalCluster

    import store
    from sweeps.run import dispatch
    from sweeps.workers import task
    from sweeps.workers.matching import matched

    task.compute_block = functools.partial(instant_block, point_s=0.064 / 16)
    plan = _plan(spec_of(16 * n_blocks, block=16))
    tasks = []
    submit = dispatch.blocks_per_task
    dispatch.blocks_per_task = lambda *a, **k: tasks.append(submit(*a, **k)) or tasks[-1]
    with LocalCluster(n_workers=2, threads_per_worker=32, host="127.0.0.1",
                      dashboard_address=None, silence_logs=logging.CRITICAL,
                      scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}) as cluster, \
            Client(cluster) as client:
        sweep, lease, cube, sink = _sweep(plan, tmp / "fed")
        client.run(task.identity)
        mc = matched(client)
        t, c = time.perf_counter(), time.process_time()
        dispatch._dispatch(mc, plan, list(range(n_blocks)), sink, _NoBar())
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
        lease.end("done")
    dispatch.blocks_per_task = submit
    n_tasks = len(tasks)
    done = len(store.Journal(sweep.journal).done())
    print(f"fed       {n_blocks} blocks of 16 points claiming 0.064 s each, 2 workers x 32 "
          f"threads: {n_blocks / seconds:6,.0f} blocks/s in {n_tasks} tasks "
          f"({n_tasks / seconds:,.0f} tasks/s; blocks a task: the first {tasks[0]}, then "
          f"{max(tasks)}), {1e3 * cpu / n_blocks:.2f} ms CPU a block; {done} blocks journaled")
    return n_blocks / seconds, n_tasks / seconds, 1e3 * cpu / n_blocks


class _NoBar:
    def update(self, n) -> None:
        pass


def table(sink: dict[int, tuple[float, float]], dask: dict[str, tuple[float, float]]) -> None:
    """Workers one submitter keeps busy, for a point cost (the plan's ~1 s blocks): tasks/s
    as measured here (wall), and as one free core gives (1 / CPU a task); blocks a task as
    the dispatch chooses for 1000 workers (sweeps.planning.plan.blocks_per_task)."""
    from sweeps.planning.plan import BLOCK_POINTS, BLOCK_SECONDS, blocks_per_task

    lo, hi = BLOCK_POINTS["simulate"]
    wall = min(dask["32"][0], sink[20][0])
    core = 1e3 / (dask["32+1000"][1] + sink[20][1])
    print(f"\nsubmitter: {wall:,.0f} tasks/s of one block measured here (dask at 65 in flight,"
          f" sink in groups of 20); one free core: {core:,.0f} tasks/s (CPU of a task with "
          f"1000 addresses + the sink's)")
    print("point cost   block (points)   block time   workers busy: here / one core   "
          "1000 workers: blocks a task, tasks/s")
    for cost in (1e-4, 1e-3, 1e-2, 1e-1, 1.0):
        points = int(min(hi, max(lo, round(BLOCK_SECONDS / cost))))
        seconds = points * cost
        k = blocks_per_task(1000, seconds, 10**6)
        print(f"{cost * 1e3:8.1f} ms   {points:>14}   {seconds:8.3f} s   "
              f"{wall * seconds:13,.0f} / {core * seconds:9,.0f}   {k:21} {1000 / (k * seconds):8,.0f}")


def cpu_model() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller sizes (a smoke run)")
    ap.add_argument("--only", choices=("sink", "publish", "memory", "dask", "fed"),
                    help="one measure alone (no table)")
    args = ap.parse_args()
    sizes = [1_000, 10_000, 100_000] + ([] if args.quick else [1_000_000])
    print(f"CPU: {cpu_model()}, {os.cpu_count()} cores; python {platform.python_version()}; "
          f"load average {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    with tempfile.TemporaryDirectory(prefix="bench-scale-") as d:
        tmp = Path(d)
        run = (lambda what: args.only in (None, what))
        sink_rates = bench_sink(tmp, 500 if args.quick else 3000) if run("sink") else {}
        if run("publish"):
            bench_publish(tmp, sizes)
        if run("memory"):
            bench_memory(tmp, sizes[1:])
        dask_rates = bench_dask(tmp, 200 if args.quick else 1000) if run("dask") else {}
        fed = bench_fed(tmp, 2000 if args.quick else 20000) if run("fed") else None
    print(f"load average {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    if args.only is None:
        table(sink_rates, dask_rates)
        print(json.dumps({"sink_blocks_per_s": {k: round(v[0]) for k, v in sink_rates.items()},
                          "dask_tasks_per_s": {k: round(v[0]) for k, v in dask_rates.items()}}))


if __name__ == "__main__":
    main()
