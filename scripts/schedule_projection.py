#!/usr/bin/env python
"""How evenly a sweep's blocks would keep N workers busy: a projection from a cube's
measured point costs (its ``cost_s``), for machines this one cannot try (issue 37: 16
workers).

Method: the plan's blocks (sweeps.planning.plan.make_plan of the cube's own spec, with
the code on ``sys.path``) are taken in the dispatch's order, longest expected first
(``work_s``), one block a task, each onto the worker that frees first (list scheduling),
each lasting the sum of its points' measured ``cost_s``. With ``--reruns`` the error
sample's re-runs (sweeps.estimates.error_reruns.SampleRuns) are timed here, one after
another in this process (the kernel loaded first), and merged into that order as the
dispatch merges them (sweeps.run.order.rerun_first). Printed: the makespan against its
ideal (summed cost / N) and their ratio, the points phase's efficiency. Left out, so the
figure is an upper bound: the dispatch's latency per task (10-25 ms), the cluster's start
and the publish; and the costs were measured where the cube was computed, on cores that
may differ from the N projected (the re-runs here: compute the cube here too).

Usage: ``python scripts/schedule_projection.py STORE/SWEEP_ID/cube.nc [--workers 2,16,32]
[--reruns]``. With ``--baseline DIR`` (a checkout of other code, e.g. a git worktree) its
plan's blocks are projected too, in a child process with that checkout first on
``sys.path`` (the re-runs' times measured once, here, and handed to it).
"""
from __future__ import annotations

import argparse
import heapq
import json
import os
import subprocess
import sys
from pathlib import Path


def project(cube: str, workers: list[int], reruns: list[float] | None = None) -> list[dict]:
    """One row per worker count; ``reruns``: the re-runs' measured seconds, in the
    sample's submission order (:func:`time_reruns`)."""
    import numpy as np
    import xarray as xr

    from sweeps.estimates.error_reruns import SampleRuns
    from sweeps.planning.plan import make_plan, work_s
    from sweeps.run.order import longest_first, rerun_first
    from sweeps.spec import parse_spec

    with xr.open_dataset(cube, engine="h5netcdf") as ds:
        cost = ds["cost_s"].values.reshape(-1)
        spec = parse_spec(json.loads(ds.attrs["spec"]))
    plan = make_plan(spec)
    todo = list(range(len(plan.blocks)))
    cost_of = {b: work_s(plan, plan.blocks[b]) for b in todo}
    queue = list(reversed(longest_first(todo, cost_of)))   # popped from the end
    sample = _Sample(SampleRuns(plan).costs if reruns is not None else [])
    lasts = []   # the tasks' measured seconds, in the dispatch's order
    while queue or sample.next_cost() is not None:
        if rerun_first(sample, queue, cost_of):
            lasts.append(reruns[sample.taken])
            sample.taken += 1
        else:
            lasts.append(float(cost[plan.blocks[queue.pop()]].sum()))
    total = float(cost.sum()) + sum(reruns or [])
    rows = []
    for n in workers:
        free = [0.0] * n
        for last in lasts:
            heapq.heappush(free, heapq.heappop(free) + last)
        makespan, ideal = max(free), total / n
        rows.append({"blocks": len(plan.blocks), "reruns": len(reruns or []),
                     "mean_s": float(np.mean(lasts)), "max_s": max(lasts), "workers": n,
                     "makespan_s": makespan, "ideal_s": ideal, "efficiency": ideal / makespan})
    return rows


class _Sample:
    """What :func:`sweeps.run.order.rerun_first` asks of the error sample."""

    def __init__(self, costs: list[float]):
        self.costs, self.taken = costs, 0

    def next_cost(self):
        return self.costs[self.taken] if self.taken < len(self.costs) else None


def time_reruns(cube: str) -> list[float]:
    """The error sample's re-runs of the cube's sweep, each timed here (compute_block at
    the finer level, one at a time), in the sample's submission order."""
    import time

    import xarray as xr

    from sweeps.estimates.error_reruns import SampleRuns
    from sweeps.planning.plan import make_plan
    from sweeps.spec import parse_spec
    from sweeps.workers.task import compute_block, warm_up

    with xr.open_dataset(cube, engine="h5netcdf") as ds:
        plan = make_plan(parse_spec(json.loads(ds.attrs["spec"])))
    sample = SampleRuns(plan)
    warm_up(sample.scene, plan.params, sample.finer.settings)
    seconds = []
    for i in sample.order:
        t = time.perf_counter()
        compute_block(sample.scene, sample.points[i:i + 1], plan.params,
                      sample.finer.settings, sample.index[i:i + 1])
        seconds.append(time.perf_counter() - t)
    return seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cube")
    ap.add_argument("--workers", default="2,4,8,16,32")
    ap.add_argument("--reruns", action="store_true",
                    help="time the error sample's re-runs here and schedule them too")
    ap.add_argument("--baseline", help="a checkout of other code: its blocks projected too")
    ap.add_argument("--rerun-seconds", help=argparse.SUPPRESS)   # (the child: JSON)
    args = ap.parse_args()
    args.cube = str(Path(args.cube).resolve())   # (the baseline's child runs elsewhere)
    workers = [int(w) for w in args.workers.split(",")]
    if args.rerun_seconds is not None:   # the baseline's child
        print(json.dumps(project(args.cube, workers, json.loads(args.rerun_seconds))))
        return
    from machine import cores, cpu_model   # scripts/machine.py

    print(f"CPU here: {cpu_model()}, {cores()} cores; the point costs are the cube's, "
          f"measured where it was computed")
    print(f"cube: {args.cube}")
    reruns = time_reruns(args.cube) if args.reruns else None
    if reruns:
        print("re-runs timed here (s): " + ", ".join(f"{t:.2f}" for t in reruns))
    runs = [("this code", project(args.cube, workers, reruns))]
    if args.baseline:
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [str(Path(args.baseline).resolve()), os.environ.get("PYTHONPATH", "")])}
        out = subprocess.run([sys.executable, str(Path(__file__).resolve()), args.cube,
                              "--workers", args.workers, "--rerun-seconds",
                              json.dumps(reruns)], env=env, capture_output=True, text=True,
                             check=True, cwd=args.baseline)
        runs.insert(0, (f"baseline {args.baseline}", json.loads(out.stdout)))
    print(f"{'code':28s} {'blocks':>6s} {'reruns':>6s} {'mean':>6s} {'max':>6s} {'workers':>7s} "
          f"{'makespan':>9s} {'ideal':>8s} {'efficiency':>10s}")
    for name, rows in runs:
        for r in rows:
            print(f"{name:28s} {r['blocks']:6d} {r['reruns']:6d} {r['mean_s']:6.2f} {r['max_s']:6.2f} "
                  f"{r['workers']:7d} {r['makespan_s']:9.2f} {r['ideal_s']:8.2f} "
                  f"{r['efficiency']:10.3f}")


if __name__ == "__main__":
    main()
