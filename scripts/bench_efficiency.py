#!/usr/bin/env python
"""Efficiency and the fixed costs around a sweep's points (issue 37).

For each sweep (``cheap``: 1,000 draft LuGre points without dither, ~0.6 s of point cost
in all; ``fig14``: specs/fig14.toml, 961 standard points) and each worker count (1, 2 and
all cores by default), one ``submit`` into a fresh store, in a fresh process (imports
counted, as a user's ``ditherlab submit``), prints:

- wall: the process, from its start to its exit (imports, plan, run, cluster stop), and
  ``submit``'s own call;
- point cost: the cube's summed ``cost_s`` (every point's share of its block's wall time);
- efficiency = point cost / (submit's wall x workers);
- the fixed costs the run timed: cluster start (``cluster_s``, 0 on threads), compile
  (``warm_up_s``: loading or compiling the kernel), points (``compute_s``), the estimate's
  tail after the last point (``error_estimate_s``), publish (``publish_s``), cluster stop
  (``stop_s``); and where the run went (threads of the submitter or a local cluster);
- still: the longest time the progress display went without a redraw (from the call to
  its end; issue 38 asks for at most 10 s while work is done).

``--cold`` gives each process an empty kernel cache ($DITHERLAB_CACHE_DIR in a temporary
folder: the first run on a new machine, or after any engine edit). The machine's CPU model,
its cores and the load average before and after are printed: on a shared machine compare
ratios taken in one run. Usage::

    python scripts/bench_efficiency.py [--sweeps cheap,fig14,fig14-100] [--workers 1,2,16]
        [--cold] [--repeats 1] [--baseline ../earlier-checkout]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine import cores, cpu_model

ROOT = Path(__file__).resolve().parents[1]

CHEAP = {"name": "cheap", "friction": "lugre", "dither": "none", "method": "simulate",
         "outputs": ["v_mean", "F_mean"], "accuracy": "draft",
         "time": {"t_end": 100.0, "t_transient": 50.0},
         "grid": {"v_ref": {"start": 0.05, "stop": 1.0, "num": 100},
                  "v_d": {"start": 0.01, "stop": 0.5, "num": 10}}}


def fig14(**changes) -> dict:
    """specs/fig14.toml as a dict, with ``changes`` (``grid`` merged)."""
    import tomllib

    spec = tomllib.loads((ROOT / "specs" / "fig14.toml").read_text())
    grid = {**spec["grid"], **changes.pop("grid", {})}
    return {**spec, **changes, "grid": grid}


SWEEPS = {"cheap": CHEAP, "fig14": fig14(),
          # issue 38's case: a 100-point draft Fig. 14, its estimate's tail sat 10.2 s still
          "fig14-100": fig14(name="fig14-100", accuracy="draft",
                             grid={"W": {"start": 0.0, "stop": 3.0, "num": 10},
                                   "omega": {"start": 10.0, "stop": 1000.0, "num": 10,
                                             "scale": "log"}})}

CHILD = """
import json, sys, time
t0 = time.perf_counter()
import numpy as np
from sweeps.spec.load import load_spec
from sweeps.planning.plan import make_plan
from sweeps.run.submit import submit
import store

try:   # a display handed in, where the runner of the checkout takes one (issue 38)
    from sweeps.run.phases import shown as display
    progress = display(True)
except ImportError:
    progress = True
try:   # where the blocks run: a Compute, where the checkout has one (issue 38)
    from sweeps.workers.compute import Compute
    where = {"compute": Compute(int(sys.argv[3]))}
except ImportError:
    where = {"workers": int(sys.argv[3])}


class Stamped:   # the progress display's redraws, timed (tqdm writes to sys.stderr)
    def __init__(self):
        self.times = []

    def write(self, text):
        if text.strip():
            self.times.append(time.perf_counter())
        return len(text)

    def flush(self):
        pass


spec, root, workers = json.loads(sys.argv[1]), sys.argv[2], int(sys.argv[3])
plan = make_plan(load_spec(spec))
shown = Stamped()
sys.stderr = shown
t1 = time.perf_counter()
res = submit(plan, root, progress=progress, **where)
t2 = time.perf_counter()
sys.stderr = sys.__stderr__
cube = store.read_cube(res.cube_path)
times = [t1, *shown.times]
print(json.dumps({"state": res.state, "timings": res.timings, "submit_s": t2 - t1,
                  "before_submit_s": t1 - t0, "points": plan.n_points,
                  "blocks": len(plan.blocks), "still_s": max(np.diff(times), default=0.0),
                  "point_cost_s": float(np.nansum(cube["cost_s"].values))}))
"""


def one(spec, workers: int, cold: bool, tree: Path = ROOT) -> dict:
    """One submit in a fresh process and a fresh store, with the code of ``tree``; its
    numbers."""
    with tempfile.TemporaryDirectory() as tmp:
        path = [str(tree), *filter(None, [os.environ.get("PYTHONPATH")])]
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(path)}   # (keeps carried packages)
        if cold:
            env["DITHERLAB_CACHE_DIR"] = str(Path(tmp) / "kernel-cache")
        t = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", CHILD, json.dumps(spec),
                               str(Path(tmp) / "store"), str(workers)],
                              capture_output=True, text=True, env=env, timeout=3600,
                              cwd=tmp)   # (python -c puts its folder first on sys.path)
        wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(f"bench_efficiency: the submit failed: "
                         f"{(proc.stderr.strip().splitlines() or ['?'])[-1]}")
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    out["process_s"] = wall
    return out


def row(name: str, workers: int, r: dict) -> str:
    t = r["timings"]
    eff = r["point_cost_s"] / (r["submit_s"] * workers)
    where = "cluster" if "cluster_s" in t else "threads"

    def f(key: str) -> str:
        return f"{t[key]:6.2f}" if key in t else "     -"

    return (f"{name:6s} {workers:3d} {where:8s} {r['process_s']:7.2f} {r['submit_s']:7.2f} "
            f"{r['point_cost_s']:8.2f} {eff:5.2f}  {f('cluster_s')} {f('warm_up_s')} "
            f"{f('compute_s')} {f('error_estimate_s')} {f('publish_s')} {f('stop_s')} "
            f"{r['still_s']:6.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sweeps", default="cheap,fig14")
    ap.add_argument("--workers", default=None, help="comma-separated (default 1,2,all)")
    ap.add_argument("--cold", action="store_true", help="an empty kernel cache each run")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--baseline", type=Path, default=None, help="a checkout of other code "
                    "(e.g. git worktree of an earlier commit): each run is taken with it "
                    "first, then with this one, rows 'before' and 'after'")
    args = ap.parse_args()
    trees = [("before", args.baseline.resolve()), ("after", ROOT)] if args.baseline else \
        [("", ROOT)]
    n = cores()
    counts = [int(w) for w in args.workers.split(",")] if args.workers else \
        sorted({1, min(2, n), n})
    print(f"CPU: {cpu_model()}, {n} cores; kernel cache {'empty' if args.cold else 'warm'}; "
          f"load average before {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if not args.cold:   # fill the kernel cache (and the OS's file cache) first
        for name in args.sweeps.split(","):
            spec = SWEEPS[name]
            if name.startswith("fig14"):   # a corner of it: the same kernels, in seconds
                spec = {**spec, "grid": {**spec["grid"], "W": [0.5], "omega": [100.0]}}
            for _, tree in trees:
                one(spec, 1, cold=False, tree=tree)
    print("sweep  wrk where    process  submit  pt-cost   eff  start compile points "
          "est-tail publish  stop  still  (seconds)")
    for name in args.sweeps.split(","):
        for w in counts:
            for _ in range(args.repeats):
                for label, tree in trees:
                    print(row(name, w, one(SWEEPS[name], w, args.cold, tree)), label,
                          flush=True)
    print(f"load average after {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
