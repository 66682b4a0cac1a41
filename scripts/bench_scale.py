"""How far one submitting process scales (docs/BATCH.md "How many workers one submitter
feeds"): what the submitter does per block, measured piece by piece, and the table of
workers it keeps busy that follows.

    .venv/bin/python scripts/bench_scale.py [--quick]

1. sink: blocks/s that the journal (one fsynced file per block) and the catalogue
   (progress under the lease) accept, through ``sweeps.run.sink.BlockSink`` itself, with
   the cube filled and republished every 5 s as in a run (one by one, and in groups as
   the dispatch hands them over);
2. publish: seconds to publish a cube of 10^3 .. 10^6 points, without and with
   ``alpha_hist`` (10 values per point);
3. memory: the submitter's resident memory against cube size (a fresh process per size:
   plan, empty cube, every block through the sink);
4. dask: scheduler overhead per task at the plan's block sizes (16 and 256 points; a task
   that computes nothing, one in flight per worker thread plus one, as sweeps.dispatch);
5. the table: for a point cost, the plan's block (about 1 s, 16..256 points), its time,
   and the workers one submitter keeps busy: min(sink, dask) blocks/s x block seconds.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
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


def fake_result(plan, b: int, fingerprint: str):
    """What a worker returns for block ``b`` (a store.BlockRecord; values arbitrary,
    shapes exact)."""
    from store.record import BlockRecord

    n = len(plan.blocks[b])
    out = {name: np.full((n, 10), 0.1) if name == "alpha_hist" else np.full(n, 0.5)
           for name in plan.outputs}
    return BlockRecord(plan.blocks[b], np.zeros(n), np.full(n, 0.01), np.ones(n),
                       np.ones(n), out, fingerprint=fingerprint)


def sink_run(plan, root: Path, group: int = 1) -> tuple[float, int]:
    """Feed every block (fake results) through a BlockSink under a real lease, ``group``
    at a time (as the dispatch hands over the blocks it finds ready), then publish;
    returns (seconds, blocks)."""
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
    sink = BlockSink(plan, cube, store.Journal(sweep.journal), sweep, lease)
    store.publish(cube, sweep.cube)   # as a run's first publish (h5netcdf imported)
    fp, n = results_fingerprint(), len(plan.blocks)
    t = time.perf_counter()   # (results made group by group: as they arrive, then dropped)
    for i in range(0, n, group):
        sink.many([(b, fake_result(plan, b, fp)) for b in range(i, min(n, i + group))])
    seconds = time.perf_counter() - t   # (the run's last publish: bench_publish)
    store.publish(cube, sweep.cube)
    lease.end("done")
    return seconds, n


def bench_sink(tmp: Path, n_blocks: int) -> float:
    """Blocks/s one by one, and in groups of 20 (what the dispatch finds ready in one
    20-ms tick at 1,000 blocks/s)."""
    plan = _plan(spec_of(16 * n_blocks, block=16))
    for group in (1, 20):
        seconds, n = sink_run(plan, tmp / f"sink-{group}", group)
        rate = n / seconds
        print(f"sink      {n} blocks of 16 points, {group:>2} at a time (journal + cube + "
              f"catalogue + publish every 5 s): {seconds:.2f} s, {rate:,.0f} blocks/s")
    return rate


def bench_publish(tmp: Path, sizes: list[int]) -> None:
    import store
    from sweeps.run.new_cube import empty_cube

    for hist in (False, True):
        for n in sizes:
            cube = empty_cube(_plan(spec_of(n, block=256, hist=hist)))
            for v in cube.data_vars.values():
                v.data[...] = np.random.default_rng(1).random(v.shape).astype(v.data.dtype)
            path = tmp / f"pub-{n}-{hist}.nc"
            times = []
            for _ in range(3 if n < 1_000_000 else 1):
                t = time.perf_counter()
                store.publish(cube, path)
                times.append(time.perf_counter() - t)
            print(f"publish   {n:>9,} points{' + alpha_hist' if hist else '':<13} "
                  f"best {min(times):6.3f} s  ({path.stat().st_size / 1e6:6.1f} MB)")


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
    for n in sizes:
        code = MEMORY_CHILD.format(root=str(ROOT), n=n, tmp=str(tmp / f"mem-{n}"))
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True, cwd=tmp)
        base, peak, cube_mb = map(float, out.stdout.split()[-3:])
        print(f"memory    {n:>9,} points + alpha_hist: cube {cube_mb:7.1f} MB, submitter's "
              f"peak {peak - base:7.1f} MB above its imports ({(peak - base) / cube_mb:5.2f} x "
              f"the cube)")


def noop_block(n: int):
    """A worker's result of ``n`` points, computed instantly (a record as compute_block's)."""
    from store.record import BlockRecord

    return BlockRecord(np.arange(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n),
                       {"F_mean": np.zeros(n)}, fingerprint="0" * 12)


def bench_dask(sizes: list[int], n_tasks: int) -> dict[int, float]:
    """Tasks/s through a LocalCluster of 2 single-threaded workers, as sweeps.dispatch
    submits them (restricted to the matching workers, window threads + 1)."""
    import logging

    from distributed import Client, LocalCluster, as_completed

    rates = {}
    with LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1",
                      dashboard_address=None, silence_logs=logging.CRITICAL,
                      scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}) as cluster, \
            Client(cluster) as client:
        workers = list(client.nthreads())
        for size in sizes:
            client.submit(noop_block, size, pure=False).result()
            t, left = time.perf_counter(), n_tasks
            done = as_completed()
            for _ in range(min(left, 3)):
                done.add(client.submit(noop_block, size, pure=False, workers=workers))
                left -= 1
            for future in done:
                future.result()
                if left:
                    done.add(client.submit(noop_block, size, pure=False, workers=workers))
                    left -= 1
            rates[size] = n_tasks / (time.perf_counter() - t)
            print(f"dask      {n_tasks} tasks of {size:>3} points, 2 workers: "
                  f"{1e3 / rates[size]:.2f} ms per task, {rates[size]:,.0f} tasks/s")
    return rates


def table(sink_rate: float, dask_rates: dict[int, float]) -> None:
    """Workers one submitter keeps busy, for a point cost (the plan's ~1 s blocks)."""
    from sweeps.planning.plan import BLOCK_POINTS, BLOCK_SECONDS

    lo, hi = BLOCK_POINTS["simulate"]
    print("\npoint cost   block (points)   block time   submitter blocks/s   workers kept busy")
    for cost in (1e-4, 1e-3, 1e-2, 1e-1, 1.0):
        points = int(min(hi, max(lo, round(BLOCK_SECONDS / cost))))
        seconds = points * cost
        rate = min(sink_rate, dask_rates[16 if points < 128 else 256])
        print(f"{cost * 1e3:8.1f} ms   {points:>14}   {seconds:8.3f} s   {rate:18,.0f}   "
              f"{rate * seconds:17,.0f}")


def cpu_model() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller sizes (a smoke run)")
    args = ap.parse_args()
    sizes = [1_000, 10_000, 100_000] + ([] if args.quick else [1_000_000])
    print(f"CPU: {cpu_model()}, {os.cpu_count()} cores; python {platform.python_version()}")
    with tempfile.TemporaryDirectory(prefix="bench-scale-") as d:
        tmp = Path(d)
        sink_rate = bench_sink(tmp, 500 if args.quick else 3000)
        bench_publish(tmp, sizes)
        bench_memory(tmp, sizes[1:])
        dask_rates = bench_dask([16, 256], 200 if args.quick else 1000)
    table(sink_rate, dask_rates)
    print(json.dumps({"sink_blocks_per_s": round(sink_rate),
                      "dask_tasks_per_s": {k: round(v) for k, v in dask_rates.items()}}))


if __name__ == "__main__":
    main()
