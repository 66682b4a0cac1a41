#!/usr/bin/env python
"""Numba compile time per test module and per kernel, from the log that
``scripts/compile_hook`` writes (its docstring says how to run the tests with it).

Usage: ``python scripts/compile_costs.py LOG [--top 30]``. Printed: the total, the modules
whose tests compiled most (the first test to need a scene pays for it; with several
pytest workers that depends on the order), and the engine kernels compiled more than once
(by two processes at once, or in fresh caches on purpose)."""
from __future__ import annotations

import argparse
import json
from collections import defaultdict


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log")
    ap.add_argument("--top", type=int, default=30)
    args = ap.parse_args(argv)
    with open(args.log) as fh:
        rows = [json.loads(line) for line in fh if line.strip()]
    by_module: dict[str, list] = defaultdict(lambda: [0.0, 0])
    by_kernel: dict[str, list] = defaultdict(list)
    for r in rows:
        module = r["test"].split("::")[0] or "(no test: " + r["argv"] + ")"
        by_module[module][0] += r["seconds"]
        by_module[module][1] += 1
        if r["function"].startswith("engine.kernels."):
            by_kernel[r["function"]].append(r["seconds"])
    total = sum(r["seconds"] for r in rows)
    kernels = sum(len(v) for v in by_kernel.values())
    print(f"{len(rows)} top-level compiles, {total:.0f} s; engine kernels: {len(by_kernel)} "
          f"distinct, {kernels} compiles, {sum(map(sum, by_kernel.values())):.0f} s")
    print(f"compile seconds by test module (the {args.top} costliest):")
    for module, (seconds, n) in sorted(by_module.items(), key=lambda kv: -kv[1][0])[:args.top]:
        print(f"  {seconds:7.1f} s  {n:4d} compiles  {module}")
    again = {k: v for k, v in by_kernel.items() if len(v) > 1}
    wasted = sum(sum(sorted(v)[:-1]) for v in again.values())
    print(f"kernels compiled more than once: {len(again)}, {wasted:.0f} s beyond the first")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
