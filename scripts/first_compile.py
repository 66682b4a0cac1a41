#!/usr/bin/env python
"""What a scene's first compile costs: numba compiling its block kernel into an empty cache.

Each run is a fresh process with its own empty ``$DITHERLAB_CACHE_DIR`` that calls
``engine.blocks.run_block`` on one point (the compile, timed as wall and CPU seconds), then
on 12 points (the kernel's run time, to see that a change to what is compiled costs no
speed). With ``--baseline DIR`` (a git worktree of another commit: ``git worktree add
/tmp/base <commit>``) the two trees are run alternately, ``--repeats`` times each, and the
12 points' outputs of the last two runs are compared bit for bit.

    .venv/bin/python scripts/first_compile.py [--scenes cheap,fig14] [--repeats 3]
                                              [--baseline /tmp/base]

Scenes: ``cheap`` (LuGre, no dither, v_mean and F_mean: bench_efficiency.py's cheap sweep)
and ``fig14`` (specs/fig14.toml's: elasto-plastic, sine dither, seven outputs), both DP5.
Compiling is single-threaded: run it on an otherwise idle machine (the CPU seconds show
when it was not: wall well above CPU).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

SCENES = {
    "cheap": {"friction": "lugre", "dither": "none", "outputs": ["v_mean", "F_mean"]},
    "fig14": {"friction": "elastoplastic", "dither": "sine-velocity",
              "outputs": ["stick_fraction", "near_slip_fraction", "long_stick_fraction",
                          "max_stick", "v_slow_p2p", "F_mean", "alpha_hist"]},
}

CHILD = """
import json, sys, time
import numpy as np
from engine import Scene, registry
from engine.blocks import run_block

kw = json.loads(sys.argv[1])
scene = Scene(**{**kw, "outputs": tuple(kw["outputs"])})
p = registry.pack(scene.friction, scene.system)
wall, cpu = time.perf_counter(), time.process_time()
run_block(scene, np.array([[1.0, 100.0, 0.1, 0.1]]), p)
wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
points = np.array([[w, om, 0.1, 0.1] for w in np.linspace(0.1, 3.0, 4) for om in (10.0, 100.0, 1000.0)])
run = time.perf_counter()
r = run_block(scene, points, p)
run = time.perf_counter() - run
np.save(sys.argv[2], np.column_stack([v.reshape(len(points), -1) for v in r.outputs.values()]))
print(json.dumps({"wall": wall, "cpu": cpu, "run": run}))
"""


def first_compile(tree: Path, scene: dict, out: Path) -> dict:
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "DITHERLAB_CACHE_DIR": cache, "PYTHONPATH": str(tree)}
        proc = subprocess.run([sys.executable, "-c", CHILD, json.dumps(scene), str(out)],
                              capture_output=True, text=True, cwd=tree, env=env, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="cheap,fig14")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--baseline", type=Path, help="a worktree of the commit to compare with")
    args = ap.parse_args(argv)
    trees = {"this": ROOT} | ({"baseline": args.baseline.resolve()} if args.baseline else {})
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo")
                if line.startswith("model name")), platform.processor())
    print(f"CPU: {cpu}, {os.cpu_count()} cores; load average {os.getloadavg()[0]:.2f}")
    print(f"{'scene':6s} {'tree':8s} {'compile wall':>13s} {'compile CPU':>12s} {'12 points':>10s}")
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenes.split(","):
            for i in range(args.repeats):
                for label, tree in (reversed(trees.items()) if i % 2 else trees.items()):
                    r = first_compile(tree, SCENES[name], Path(tmp) / f"{name}-{label}.npy")
                    print(f"{name:6s} {label:8s} {r['wall']:11.1f} s {r['cpu']:10.1f} s "
                          f"{r['run']:8.3f} s", flush=True)
            if args.baseline:
                a, b = (np.load(Path(tmp) / f"{name}-{label}.npy") for label in trees)
                same = a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=True))
                bad += not same
                print(f"{name}: outputs of the two trees {'bit-identical' if same else 'DIFFER'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
