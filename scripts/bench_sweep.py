#!/usr/bin/env python
"""Benchmark of the sweep service's scheduling (issue 'sweep service', Speed).

Prints, for one 1000-point simulated sweep (LuGre slider, square-velocity dither):

- T_serial: the same blocks run one after another in this process, without dask;
- T_dask2: the compute phase of the sweep on LocalCluster(2 workers x 1 thread), its error
  estimate's re-runs included (they run among the blocks; T_serial runs them too), cluster
  start-up and the one-off per-worker numba compilation printed apart;
- dask overhead = T_dask2 / (T_serial / 2) - 1            (target <= 5 %);
- T_dask1: the same on one worker, and the 2-core speed-up T_dask1 / T_dask2 (target >= 1.9).

All three runs happen in this one process run, so the ratios compare like with like on a
shared, noisy machine. Usage: ``python scripts/bench_sweep.py [--t-end 100]`` (run it on an otherwise idle machine).
"""
from __future__ import annotations

import argparse
import tempfile
import time

from sweeps.estimates.error_reruns import SampleRuns
from sweeps.planning.plan import make_plan
from sweeps.run.submit import submit
from sweeps.workers.compute import Compute
from sweeps.spec import parse_spec
from sweeps.workers.task import compute_block, warm_up


def bench_spec(n_w: int, n_omega: int, n_vref: int, t_end: float, block_size=None) -> dict:
    return {
        "name": "bench-sweep", "block_size": block_size, "friction": "lugre", "dither": "square-velocity",
        "method": "simulate", "accuracy": "draft",
        "outputs": ["v_mean", "v_slow_p2p", "F_mean"],
        "time": {"t_end": t_end, "t_transient": t_end / 2},
        "grid": {"W": {"start": 0.0, "stop": 0.6, "num": n_w},
                 "omega": {"start": 100.0, "stop": 1000.0, "num": n_omega, "scale": "log"},
                 "v_ref": {"start": 0.1, "stop": 0.5, "num": n_vref}, "v_d": [0.1]},
    }


def serial(plan) -> float:
    """The blocks and the error estimate's re-runs one after another, no dask."""
    runs = SampleRuns(plan)
    warm_up(plan.scene, plan.params, plan.numerics.settings)
    warm_up(runs.scene, plan.params, runs.finer.settings)
    t0 = time.perf_counter()
    for b in range(len(plan.blocks)):
        compute_block(plan.scene, plan.block_points(b), plan.params, plan.numerics.settings)
    for i in range(len(runs.index)):
        compute_block(runs.scene, runs.points[i:i + 1], plan.params, runs.finer.settings)
    return time.perf_counter() - t0


def work(timings: dict) -> float:
    """A run's points and error estimate (its re-runs run among the blocks, or after)."""
    return timings["compute_s"] + timings.get("error_estimate_s", 0.0)


def on_dask(plan, workers: int) -> dict:
    with tempfile.TemporaryDirectory() as store:
        res = submit(plan, store, Compute(workers), progress=False)
    assert res.state == "done", res
    return res.timings


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--t-end", type=float, default=100.0)
    ap.add_argument("--block-size", type=int, default=None, help="points per block "
                    "(default: the planner's choice)")
    args = ap.parse_args()
    spec = parse_spec(bench_spec(10, 10, 10, args.t_end, args.block_size))
    plan = make_plan(spec)
    print(f"sweep: {plan.n_points} points in {len(plan.blocks)} blocks, "
          f"{plan.numerics.integrator} ({plan.numerics.label}), t_end = {args.t_end}")
    t_serial = serial(plan)
    d2 = on_dask(plan, 2)
    d1 = on_dask(plan, 1)
    overhead = work(d2) / (t_serial / 2) - 1
    speedup = work(d1) / work(d2)
    print(f"T_serial (no dask, 1 core)      {t_serial:8.2f} s   "
          f"({t_serial / plan.n_points * 1e3:.2f} ms per point, the estimate's re-runs included)")
    print(f"T_dask2 compute (2 workers)     {work(d2):8.2f} s   "
          f"[cluster start {d2['cluster_s']:.2f} s, per-worker compile "
          f"{d2.get('warm_up_s', 0.0):.2f} s]")
    print(f"T_dask1 compute (1 worker)      {work(d1):8.2f} s")
    print(f"dask overhead  T_dask2 / (T_serial/2) - 1 = {overhead * 100:+.1f} %   (target <= 5 %)")
    print(f"2-core speed-up T_dask1 / T_dask2          = {speedup:.2f}x    (target >= 1.9x)")
    print(f"whole sweep incl. start-up (2 workers)     = "
          f"{sum(d2.values()):.2f} s")


if __name__ == "__main__":
    main()
