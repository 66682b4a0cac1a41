#!/usr/bin/env python
"""What each test module cost, from a pytest JUnit XML report (``--junitxml``): the summed
time of its tests (setup and teardown included, as pytest's report counts them), costliest
first, and the total. ``.ci/run`` prints it after the tests (issue 38: say what each long
module costs). Usage: ``python scripts/test_costs.py REPORT.xml [--top 30]``."""
from __future__ import annotations

import argparse
import xml.etree.ElementTree as ET
from collections import defaultdict


def module_costs(report: str) -> dict[str, tuple[float, int]]:
    """module (``tests/e2e/test_faults.py``) -> (seconds, tests)."""
    costs: dict[str, list] = defaultdict(lambda: [0.0, 0])
    for case in ET.parse(report).getroot().iter("testcase"):
        module = case.get("classname", "").split("::")[0]
        parts = module.split(".")   # tests.e2e.test_faults[.Class]
        while parts and not parts[-1].startswith("test_"):
            parts.pop()
        name = "/".join(parts) + ".py" if parts else module
        costs[name][0] += float(case.get("time") or 0.0)
        costs[name][1] += 1
    return {k: (v[0], v[1]) for k, v in costs.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("report")
    ap.add_argument("--top", type=int, default=30)
    args = ap.parse_args(argv)
    costs = sorted(module_costs(args.report).items(), key=lambda kv: -kv[1][0])
    total = sum(s for s, _ in dict(costs).values())
    print(f"test time by module ({len(costs)} modules, {total:.0f} s in all, summed over "
          f"the workers; the {args.top} costliest):")
    for name, (seconds, n) in costs[:args.top]:
        print(f"  {seconds:7.1f} s  {n:4d} tests  {name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
