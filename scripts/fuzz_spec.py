#!/usr/bin/env python
"""Fuzz the sweep-spec validator (issues 9 and 10): mutations of valid specs, written as
TOML or JSON files, each through ``sweeps.spec.load_spec`` and, when refused, through
``ditherlab plan`` (``sweeps.cli.main`` in-process) against an empty temporary store.

Every case must end in a refusal (``SpecError``: exit 2, one line per fault, each under
300 characters and naming the field, no numpy reprs, nothing written to the store) or in
an accepted spec that plans (``make_plan``) and builds its empty cube; never in another
exception, never over 1 s of CPU, never growing memory. Cases whose mutation is invalid by
construction (NaN, a string for a number, a repeated grid value, an unknown integrator,
...) must be refused; a few benign mutations must be accepted.

The mutations and the checks are the test suite's (tests/sweeps/spec/spec_mutations.py,
tests/sweeps/spec/spec_cases.py; tests/sweeps/spec/test_spec_fuzz.py runs a CI-sized sample of
them): this script runs many more, from a seed.

    .venv/bin/python scripts/fuzz_spec.py [--n 1000] [--seed 1] [--show 5]

Prints counts per category and outcome, then the first ``--show`` faults of each kind.
The process runs under a 4 GiB address-space limit, so a validator that builds a huge
grid fails with MemoryError (counted as a traceback) instead of taking the machine.
"""
from __future__ import annotations

import argparse
import random
import re
import resource
import signal
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.sweeps.spec.spec_cases import bases, check  # noqa: E402
from tests.sweeps.spec.spec_mutations import MUTATIONS  # noqa: E402


class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang("over 20 s")


def run_case(case, tmp: Path, index: int) -> dict:
    """:func:`spec_cases.check` under a 20 s alarm (a hang is a fault too)."""
    signal.alarm(20)
    try:
        return check(case, tmp, index)
    except Hang:
        return {"case": case, "outcome": "traceback", "error": "Hang: over 20 s",
                "cpu_s": 20.0, "faults": ["traceback: Hang: over 20 s"]}
    finally:
        signal.alarm(0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000, help="number of specs (default 1000)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--show", type=int, default=5, help="faults shown per kind")
    args = ap.parse_args(argv)
    limit = 4 * 2**30
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    signal.signal(signal.SIGALRM, _alarm)
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 1000))

    specs = bases()
    rng = random.Random(args.seed)
    results = []
    by_kind = defaultdict(list)
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="fuzz-spec-") as tmpdir:
        for i in range(args.n):
            mutate = MUTATIONS[i % len(MUTATIONS)]
            case = mutate(rng, rng.choice(specs))
            res = run_case(case, Path(tmpdir), i)
            results.append(res)
            for fault in res["faults"]:
                by_kind[re.sub(r"\d+", "N", fault.split(":")[0])].append((case, fault))
            (Path(tmpdir) / f"case{i}.{case.fmt}").unlink()
    table = Counter((r["case"].category, r["outcome"]) for r in results)
    cats = sorted({r["case"].category for r in results})
    print(f"{len(results)} specs in {time.perf_counter() - t_start:.1f} s "
          f"(seed {args.seed})\n")
    print(f"{'category':<12}{'accepted':>10}{'refused':>10}{'traceback':>11}{'faulty':>8}")
    for c in cats:
        faulty = sum(1 for r in results if r["case"].category == c and r["faults"])
        print(f"{c:<12}{table[(c, 'accepted')]:>10}{table[(c, 'refused')]:>10}"
              f"{table[(c, 'traceback')]:>11}{faulty:>8}")
    outcomes = Counter(r["outcome"] for r in results)
    print(f"{'total':<12}{outcomes['accepted']:>10}{outcomes['refused']:>10}"
          f"{outcomes['traceback']:>11}{sum(1 for r in results if r['faults']):>8}\n")
    slowest = max(results, key=lambda r: r["cpu_s"])
    print(f"slowest: {slowest['cpu_s']:.3f} s of CPU ({slowest['case'].category}: "
          f"{slowest['case'].label[:60]})")
    longest = max((len(line) for r in results for line in r.get("lines", ())), default=0)
    print(f"longest message line: {longest} chars")
    warned = [r for r in results if r.get("warnings")]
    print(f"accepted with a warning: {len(warned)}")
    kinds = Counter(r["error"].split(":")[0] for r in results if r["outcome"] == "traceback")
    if kinds:
        print("tracebacks: " + ", ".join(f"{k} {n}" for k, n in kinds.most_common()))
    print("\nfaults by kind:")
    for kind, items in sorted(by_kind.items(), key=lambda kv: -len(kv[1])):
        print(f"  {kind}: {len(items)}")
        for case, fault in items[:args.show]:
            print(f"      [{case.category}: {case.label[:60]}] {fault[:160]}")
    return 1 if any(r["faults"] for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
