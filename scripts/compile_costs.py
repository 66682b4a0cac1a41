#!/usr/bin/env python
"""Numba compile time per test module and per kernel, from the log that
``scripts/compile_hook`` writes (its docstring says how to run the tests with it).

Usage: ``python scripts/compile_costs.py LOG [--top 30] [--scenes] [--junit REPORT.xml]``.
Printed: the total, the modules whose tests compiled most (the first test to need a scene
pays for it; with several pytest workers that depends on the order), and the engine kernels
compiled more than once (by two processes at once, or in fresh caches on purpose). With
``--junit`` (the same run's ``--junitxml`` report, scripts/test_costs.py): each module's
test time beside its compile time, and the rest (its own work: sweeps, processes, waits).
The compile seconds are wall time in the compiling process, so a module whose commands
compile in two processes at once can show more compile than test time."""
from __future__ import annotations

import argparse
import json
from collections import defaultdict


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log")
    ap.add_argument("--top", type=int, default=30)
    ap.add_argument("--scenes", action="store_true",
                    help="list each compiled scene with the test modules that compiled it "
                         "(a scene one module alone needs is a compilation to share)")
    ap.add_argument("--junit", metavar="REPORT",
                    help="the run's --junitxml report: test time, compile and the rest per module")
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
    if args.junit:
        print_split(by_module, args.junit, args.top)
    if args.scenes:
        print_scenes(rows)
    return 0


def print_split(by_module: dict, report: str, top: int) -> None:
    """Each module's test time (the JUnit report), its compile seconds and the rest."""
    from test_costs import module_costs

    costs = module_costs(report)
    total = sum(s for s, _ in costs.values())
    compiled = sum(by_module[m][0] for m in costs if m in by_module)
    print(f"test time {total:.0f} s summed over the workers, {compiled:.0f} s of it compiling "
          f"({compiled / total:.0%}); by module (the {top} costliest):")
    print(f"  {'tests':>7}  {'compile':>7}  {'rest':>7}")
    for name, (seconds, _) in sorted(costs.items(), key=lambda kv: -kv[1][0])[:top]:
        c = by_module[name][0] if name in by_module else 0.0
        print(f"  {seconds:7.1f}  {c:7.1f}  {seconds - c:7.1f}  {name}")


def print_scenes(rows: list[dict]) -> None:
    """Each scene's engine-kernel compile seconds and the modules whose tests compiled it
    (the hook's ``scene``: the Scene on the compiling call's stack)."""
    by_scene: dict[str, list] = defaultdict(list)
    for r in rows:
        if r["function"].startswith("engine.kernels."):
            module = r["test"].split("::")[0].rsplit("/", 1)[-1] or "(no test)"
            by_scene[r.get("scene") or "(scene not on the stack)"].append((module, r["seconds"]))
    print(f"scenes compiled: {len(by_scene)}")
    for scene, hits in sorted(by_scene.items(), key=lambda kv: -sum(s for _, s in kv[1])):
        modules = ", ".join(sorted({m for m, _ in hits}))
        print(f"  {sum(s for _, s in hits):6.1f} s  {modules}\n      {scene}")


if __name__ == "__main__":
    raise SystemExit(main())
