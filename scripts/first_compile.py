#!/usr/bin/env python
"""What a scene's first compile costs: numba compiling its block kernel into an empty cache.

Each run is a fresh process with its own empty ``$DITHERLAB_CACHE_DIR``. It plans a sweep
(``sweeps.planning.plan.make_plan``: the Scene and parameters a sweep compiles), runs
``engine.blocks.run_block`` on the plan's first point (the compile, timed as wall and CPU
seconds), then on the plan's first block (the kernel's run time, to see that a change to
what is compiled costs no speed). With ``--baseline DIR`` (a git worktree of another
commit: ``git worktree add /tmp/base <commit>``) the two trees are run alternately,
``--repeats`` times each, and the first block's statuses, counters and output bytes of
their last runs are compared.

    .venv/bin/python scripts/first_compile.py [--scenes cheap,fig14] [--repeats 3]
                                              [--baseline /tmp/base]

Scenes: ``cheap`` (scripts/bench_efficiency.py's cheap sweep: 1,000 draft LuGre points
without dither, v_mean and F_mean) and ``fig14`` (specs/fig14.toml: elasto-plastic, sine
dither, seven outputs, standard), both DP5. Compiling is single-threaded: run it on an
otherwise idle machine (the CPU seconds show when it was not: wall well above CPU).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
from bench_efficiency import CHEAP
from machine import cores, cpu_model

ROOT = Path(__file__).resolve().parents[1]
SPECS = {"cheap": CHEAP, "fig14": tomllib.loads((ROOT / "specs" / "fig14.toml").read_text())}

CHILD = """
import json, sys, time
import numpy as np
from engine.blocks import run_block
from sweeps.planning.plan import make_plan
from sweeps.spec import parse_spec

plan = make_plan(parse_spec(json.loads(sys.argv[1])))
block = plan.block_points(0)
settings = plan.numerics.settings
wall, cpu = time.perf_counter(), time.process_time()
run_block(plan.scene, block[:1], plan.params, settings)
wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
run = time.perf_counter()
r = run_block(plan.scene, block, plan.params, settings)
run = time.perf_counter() - run
np.savez(sys.argv[2], status=r.status, counters=np.column_stack([r.steps, r.rejected, r.evals]),
         outputs=np.column_stack([v.reshape(len(block), -1) for v in r.outputs.values()]))
print(json.dumps({"wall": wall, "cpu": cpu, "run": run, "points": len(block)}))
"""


def first_compile(tree: Path, spec: dict, out: Path) -> dict:
    """One fresh process of ``tree`` with an empty kernel cache."""
    with tempfile.TemporaryDirectory() as cache:
        path = os.pathsep.join([str(tree), os.environ.get("PYTHONPATH", "")])
        env = {**os.environ, "DITHERLAB_CACHE_DIR": cache, "PYTHONPATH": path}
        proc = subprocess.run([sys.executable, "-c", CHILD, json.dumps(spec), str(out)],
                              capture_output=True, text=True, cwd=tree, env=env, timeout=900)
    if proc.returncode != 0:
        sys.exit(f"first_compile: the run in {tree} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def same(a: Path, b: Path) -> bool:
    """Equal statuses, counters and output bytes (NaN payloads included)."""
    with np.load(a) as x, np.load(b) as y:
        return all(x[k].shape == y[k].shape and x[k].tobytes() == y[k].tobytes()
                   for k in ("status", "counters", "outputs"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="cheap,fig14", help=f"of {', '.join(SPECS)}")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--baseline", type=Path, help="a worktree of the commit to compare with")
    args = ap.parse_args(argv)
    names = args.scenes.split(",")
    unknown = [n for n in names if n not in SPECS]
    if unknown:
        ap.error(f"--scenes: unknown {', '.join(unknown)}; known: {', '.join(SPECS)}")
    trees = {"this": ROOT} | ({"baseline": args.baseline.resolve()} if args.baseline else {})
    print(f"CPU: {cpu_model()}, {cores()} cores; load average {os.getloadavg()[0]:.2f}")
    print(f"{'scene':6s} {'tree':8s} {'compile wall':>13s} {'compile CPU':>12s} "
          f"{'first block':>12s}")
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            for i in range(args.repeats):
                for label, tree in (reversed(trees.items()) if i % 2 else trees.items()):
                    r = first_compile(tree, SPECS[name], Path(tmp) / f"{name}-{label}.npz")
                    print(f"{name:6s} {label:8s} {r['wall']:11.1f} s {r['cpu']:10.1f} s "
                          f"{r['run']:8.3f} s ({r['points']} points)", flush=True)
            if args.baseline:
                ok = same(*(Path(tmp) / f"{name}-{label}.npz" for label in trees))
                bad += not ok
                print(f"{name}: the first block of the two trees "
                      f"{'bit-identical' if ok else 'DIFFERS'} (statuses, counters, outputs)")
    print(f"load average at the end {os.getloadavg()[0]:.2f}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
