#!/usr/bin/env python
"""The walk of a spec through the rooms (issue 38): the functions of ours that the
submitting process enters while ``sweeps.run_sweep`` runs a spec, room by room, and how
many times each (docs/ARCHITECTURE.md, "The walk of a spec").

A room is a sub-package of sweeps/ (``run``, ``workers``, ...; ``sweeps`` for its top-level
modules), ``store`` or ``engine``. Functions entered by the dask workers (other processes)
are not seen; threads of this process are. Per-block functions (the sink, the journal, the
progress bar) are entered once per block or tick: ``--all`` lists them too. Usage::

    python scripts/walk_spec.py [--sweep cluster|threads] [--all] [--store DIR]
"""
from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SWEEPS = {
    # 100 draft Fig. 14 points: priced above a cluster's start, a LocalCluster of 2
    "cluster": {"name": "walk-cluster", "friction": "lugre", "dither": "square-velocity",
                "outputs": ["long_stick_fraction", "v_mean"], "accuracy": "draft",
                "time": {"t_end": 60.0, "t_transient": 30.0},
                "grid": {"W": {"start": 0.0, "stop": 3.0, "num": 10},
                         "omega": {"start": 10.0, "stop": 1000.0, "num": 10, "scale": "log"},
                         "v_ref": [0.4]}},
    # 30 undithered draft points: below a cluster's start, on threads of the submitter
    "threads": {"name": "walk-threads", "friction": "lugre", "dither": "none",
                "outputs": ["v_mean"], "accuracy": "draft",
                "time": {"t_end": 20.0, "t_transient": 5.0},
                "grid": {"v_ref": {"start": 0.1, "stop": 1.0, "num": 30}}},
}


def room_of(path: str) -> str | None:
    try:
        rel = Path(path).resolve().relative_to(ROOT)
    except ValueError:
        return None
    parts = rel.parts
    if parts[0] not in ("sweeps", "store", "engine"):
        return None
    if parts[0] == "sweeps" and len(parts) > 2:
        return f"sweeps/{parts[1]}"
    return parts[0]


def walk(spec: dict, store: str) -> dict:
    """``room -> Counter(module.function -> calls)`` of one run_sweep in this process."""
    import sweeps

    seen: dict = collections.defaultdict(collections.Counter)
    rooms: dict = {}

    def profile(frame, event, arg):
        if event != "call":
            return
        code = frame.f_code
        room = rooms.get(code.co_filename, ...)
        if room is ...:
            room = rooms[code.co_filename] = room_of(code.co_filename)
        if room is not None and not code.co_name.startswith("<"):
            module = Path(code.co_filename).stem
            seen[room][f"{module}.{code.co_qualname}"] += 1

    threading.setprofile(profile)
    sys.setprofile(profile)
    try:
        sweeps.run_sweep(spec, store, progress=False)
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    return seen


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sweep", choices=SWEEPS, default="cluster")
    ap.add_argument("--all", action="store_true", help="also the functions entered per "
                    "block or per tick (entered more than 8 times)")
    ap.add_argument("--store", default=None)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        seen = walk(SWEEPS[args.sweep], args.store or tmp)
    order = ["sweeps", "sweeps/cli", "sweeps/spec", "sweeps/planning", "sweeps/run",
             "sweeps/workers", "sweeps/estimates", "store", "engine"]
    for room in sorted(seen, key=lambda r: order.index(r) if r in order else len(order)):
        calls = seen[room]
        shown = [(f, n) for f, n in calls.items() if args.all or n <= 8]
        many = sorted(f for f, n in shown if n > 1)
        print(f"{room}: {len(calls)} functions entered, {len(many)} of them more than once "
              f"(at most 8 times){'' if args.all else f'; {len(calls) - len(shown)} per block or tick'}")
        print("  once: " + ", ".join(sorted(f for f, n in shown if n == 1)))
        if many:
            print("  more than once: " + ", ".join(f"{f} x{calls[f]}" for f in many))


if __name__ == "__main__":
    main()
