"""Where the gallery's time goes: CPU time (user + system) per figure, issue 30.

    python scripts/bench_gallery.py [--size full] [--only fig14 ...] [--workers 2]
                                    [--store DIR] [--out DIR] [--json OUT]

Builds the gallery as ``ditherlab gallery`` does (``sweeps.gallery.build``, a fresh temp
store and output folder unless given) and prints per figure its wall time and its CPU time:
this process's plus that of its children, live or ended (the dask worker processes are
children: ``psutil``), with the load average before and after. On a shared machine the CPU time is the comparable number; the wall time
depends on the load.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def cpu() -> float:
    """CPU seconds of this process, its reaped children and its live descendants (the
    gallery's shared LocalCluster keeps its workers alive from sweep to sweep)."""
    import psutil

    me = psutil.Process()
    t = me.cpu_times()
    total = t.user + t.system + t.children_user + t.children_system
    for child in me.children(recursive=True):
        try:
            c = child.cpu_times()
        except psutil.Error:   # ended in between: its time is in children_* next call
            continue
        total += c.user + c.system
    return total


def main(argv=None) -> int:
    from sweeps.gallery import build as B
    from sweeps.gallery.context import Context

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="full", choices=("small", "full"))
    ap.add_argument("--only", nargs="+", metavar="KEY")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--store", default=None)
    ap.add_argument("--out", default=None)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="bench-gallery-"))
    ctx = Context(size=args.size, outdir=args.out or work / "out",
                  store=args.store or work / "store", workers=args.workers)
    rows, draw_of = {}, dict(B.FIGURES)

    def timed(key, draw):
        def run(c):
            c0, w0 = cpu(), time.perf_counter()
            try:
                return draw(c)
            finally:
                rows[key] = {"cpu": cpu() - c0, "wall": time.perf_counter() - w0}
        return run

    load0, c0, w0 = os.getloadavg(), cpu(), time.perf_counter()
    B.FIGURES.update({k: timed(k, d) for k, d in draw_of.items()})
    try:
        results = B.build(ctx, only=args.only, log=lambda m: None)
    finally:
        B.FIGURES.update(draw_of)
    total = {"cpu": cpu() - c0, "wall": time.perf_counter() - w0}
    print(f"{'figure':<15}{'verdict':<15}{'CPU s':>8}{'wall s':>8}")
    for r in results:
        print(f"{r.key:<15}{r.verdict:<15}{rows[r.key]['cpu']:8.1f}{rows[r.key]['wall']:8.1f}")
    print(f"{'total (+page)':<30}{total['cpu']:8.1f}{total['wall']:8.1f}")
    load1 = os.getloadavg()
    print(f"load average {load0[0]:.1f} / {load0[1]:.1f} before, "
          f"{load1[0]:.1f} / {load1[1]:.1f} after (1 / 5 min); {os.cpu_count()} cores")
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"figures": rows, "total": total, "load": [load0, load1],
             "verdicts": {r.key: r.verdict for r in results}}, indent=1))
    return 1 if any(r.error for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
