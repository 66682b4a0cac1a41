#!/usr/bin/env python
"""How evenly a sweep's blocks would keep N workers busy: a projection from a cube's
measured point costs (its ``cost_s``), for machines this one cannot try (issue 37: 16
workers).

Method: the plan's blocks (sweeps.planning.plan.make_plan of the cube's own spec, with
the code on ``sys.path``) are taken in the dispatch's order, longest expected first
(``work_s``), one block a task, each onto the worker that frees first (list scheduling),
each lasting the sum of its points' measured ``cost_s``. Printed: the points phase's
makespan against its ideal (summed cost / N) and their ratio, the points-phase
efficiency. Left out, so the figure is an upper bound: the dispatch's latency per task
(10-25 ms), the error estimate's re-runs (they run among the blocks), the cluster's start
and the publish; and the costs were measured on this machine, whose cores may differ.

Usage: ``python scripts/schedule_projection.py STORE/SWEEP_ID/cube.nc [--workers 2,16,32]``.
With ``--baseline DIR`` (a checkout of other code, e.g. a git worktree) its plan's blocks
are projected too, in a child process with that checkout first on ``sys.path``.
"""
from __future__ import annotations

import argparse
import heapq
import json
import os
import subprocess
import sys
from pathlib import Path


def project(cube: str, workers: list[int]) -> list[dict]:
    import numpy as np
    import xarray as xr

    from sweeps.planning.plan import make_plan, work_s
    from sweeps.spec import parse_spec

    with xr.open_dataset(cube, engine="h5netcdf") as ds:
        cost = ds["cost_s"].values.reshape(-1)
        spec = parse_spec(json.loads(ds.attrs["spec"]))
    plan = make_plan(spec)
    expected = [work_s(plan, b) for b in plan.blocks]
    order = sorted(range(len(plan.blocks)), key=lambda b: -expected[b])
    lasts = [float(cost[plan.blocks[b]].sum()) for b in order]
    rows = []
    for n in workers:
        free = [0.0] * n
        for last in lasts:
            heapq.heappush(free, heapq.heappop(free) + last)
        makespan, ideal = max(free), float(cost.sum()) / n
        rows.append({"blocks": len(lasts), "mean_s": float(np.mean(lasts)),
                     "max_s": max(lasts), "workers": n, "makespan_s": makespan,
                     "ideal_s": ideal, "efficiency": ideal / makespan})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cube")
    ap.add_argument("--workers", default="2,4,8,16,32")
    ap.add_argument("--baseline", help="a checkout of other code: its blocks projected too")
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)   # (the child)
    args = ap.parse_args()
    workers = [int(w) for w in args.workers.split(",")]
    if args.json:
        print(json.dumps(project(args.cube, workers)))
        return
    from machine import cores, cpu_model   # scripts/machine.py

    print(f"CPU here: {cpu_model()}, {cores()} cores; the point costs are the cube's, "
          f"measured where it was computed")
    print(f"cube: {args.cube}")
    runs = [("this code", project(args.cube, workers))]
    if args.baseline:
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [str(Path(args.baseline).resolve()), os.environ.get("PYTHONPATH", "")])}
        out = subprocess.run([sys.executable, __file__, args.cube, "--workers", args.workers,
                              "--json"], env=env, capture_output=True, text=True, check=True,
                             cwd=args.baseline)
        runs.insert(0, (f"baseline {args.baseline}", json.loads(out.stdout)))
    print(f"{'code':28s} {'blocks':>6s} {'mean':>6s} {'max':>6s} {'workers':>7s} "
          f"{'makespan':>9s} {'ideal':>8s} {'efficiency':>10s}")
    for name, rows in runs:
        for r in rows:
            print(f"{name:28s} {r['blocks']:6d} {r['mean_s']:6.2f} {r['max_s']:6.2f} "
                  f"{r['workers']:7d} {r['makespan_s']:9.2f} {r['ideal_s']:8.2f} "
                  f"{r['efficiency']:10.3f}")


if __name__ == "__main__":
    main()
