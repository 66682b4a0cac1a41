#!/usr/bin/env python
"""Regenerate docs/PERFORMANCE.md: run the benchmark scripts and write their tables.

    .venv/bin/python scripts/performance_page.py            # the whole page (tens of minutes)
    .venv/bin/python scripts/performance_page.py --quick    # a subset, small options (a check)

Each benchmark runs as its own process (``scripts/bench_*.py``; the engine's is timed
against the C anchor in ``../shared/anchors``) and its output goes onto the page verbatim,
under the command that made it, with the CPU, the date and the load average around it. The
page is written only when every benchmark succeeded; a failure is one line and exit 1, the
old page kept. Measured numbers live on that page only: the README and the other pages link
it instead of quoting them.
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "PERFORMANCE.md"


@dataclass(frozen=True)
class Bench:
    title: str
    script: str
    full: tuple[str, ...]          # options for the whole page
    quick: tuple[str, ...] | None  # options for --quick; None: left out of --quick
    prose: str                     # what the numbers mean


BENCHES = (
    Bench("The engine against C", "bench_engine.py",
          ("--methods", "rk4,dopri5", "--repeats", "7", "--scipy-cap", "60",
           "--no-effects", "--no-stiff"),
          ("--methods", "rk4,dopri5", "--repeats", "3", "--no-scipy", "--no-effects",
           "--no-stiff"),
          """\
The engine's speed as a **ratio to plain C** (`gcc -O3 -march=native`, the anchor
`../shared/anchors/anchor.c`) running the same algorithm on the same scene in the same
process, the two timed in alternation (thread CPU time, median of the repeats). Scenes: `fig10`
(the LuGre slider of Fig. 10, square-velocity dither W = 0.4 at omega = 1000, tau in [0, 100])
and `nodither` (the same with W = 0). For each accuracy (1e-4, 1e-7: the largest error over
five quantities of interest, in units of their natural scales) each method runs at its
cheapest setting that reaches it. `ratio` is engine / C, each at its own cheapest setting;
`same` is the ratio at the engine's setting (equal steps: the cost of the implementation);
a ratio below 1 means the engine is faster. `dopri5` stops exactly at every switch of the
square wave and also lands on the |u| = 0 kinks of the friction law, which C's DP5 does not:
at tight tolerances that saves it steps. `dopri5 dense` runs without stops and samples its
dense output, as C's `dp5dense`. The second table compares the engine's cheapest 1e-4 run with
scipy's `solve_ivp` (a run capped in time gives a lower bound `>=`). The effects table and the
stiff crossover are in [ACCURACY.md](ACCURACY.md) §7-8."""),
    Bench("Maps: the full grid against adaptive refinement", "bench_maps.py",
          ("--sizes", "31"), ("--sizes",),
          """\
Wall time of `ditherlab submit` as a fresh process (imports, the local 2-worker cluster's
start, compiling or loading kernels, computing, publishing), for the full grid and for the same
spec with `refine = true` ([SPEC.md](SPEC.md#adaptive-refinement)). `computed` and `share`:
the points the refined run computed (the rest are inferred); `agree`: the share of cells whose
class (the stick-slip zone, or the stable / PU / SU label) equals the full grid's; `still s`:
the longest time the progress display sat still while points were computed. Fig. 14 is the
elasto-plastic zone map at standard accuracy; Fig. 9 the averaged stability chart, computed in
the submitting process without a cluster, so its time is mostly start-up."""),
    Bench("Sweeps on dask: overhead and speed-up", "bench_sweep.py",
          ("--t-end", "100"), ("--t-end", "20"),
          """\
One 1000-point simulated sweep (LuGre slider, square-velocity dither, draft accuracy) three
ways in one process: its blocks one after another without dask (`T_serial`), on a
LocalCluster of 2 single-threaded workers (`T_dask2`) and of 1 (`T_dask1`). The compute
phase is compared; the cluster's start and the one-off per-worker compile are printed apart.
`dask overhead` is what 2 workers lose against half the serial time (0 % is perfect); the
`speed-up` of 2 workers over 1 is at most 2. On a machine shared with other jobs both read
worse than on an idle one."""),
    Bench("The averaged theory and harmonic balance", "bench_analysis.py", (), (),
          """\
The analysis paths that answer without time integration (engine/analysis). Each time is the
best of several runs and also given as a multiple of a fixed numpy workload timed in the same
run (`x ref`, 1e6 `exp` + 1e6 `sqrt`), which makes numbers comparable across loads; `budget`
is the target each path was built to, `ratio` the time over it. The first calls compile or
load numba's cached kernels. The quadrature table shows how fast the sine-dither average
converges with the number of nodes n (the engine uses n = 64), and the last lines time the
harmonic balance of the contact system of Fig. 1."""),
    Bench("How far one submitting process scales", "bench_scale.py", (), ("--quick",),
          """What the submitting process does per block, piece by piece ([BATCH.md](BATCH.md#how-many-workers-one-submitter-feeds)):
blocks/s the journal, cube and catalogue accept (`sink`, handed over one by one and in
groups), a cube's publish against its size with and without `alpha_hist`, the submitter's
peak memory against the cube, dask's tasks/s through the run's own dispatch with tasks that
compute nothing (`dask`), and the submitter's side of 1,000 workers at 1-s blocks (`fed`).
Noise values everywhere, the worst case for compression. The last table: how many
single-threaded workers one submitter keeps busy for a point cost, and the blocks a task
the dispatch gives 1,000 workers."""),
    Bench("The web view", "bench_web.py", (), ("--sweeps", "100", "--repeat", "8"),
          """`ditherlab web` in its own process, timed from a client ([WEB.md](WEB.md)): the catalogue
page with 1,000 sweeps, a map drawn the first time and from the cache, and the explorer's
200 x 200 stability chart from click to image; each against its target."""),
)


def commit() -> str:
    """The checkout's commit, ``+changes`` when files differ from it."""
    def git(*args):
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True,
                              text=True).stdout.strip()
    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + ("+changes" if git("status", "--porcelain", "--untracked-files=no") else "")


def load() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.1f} (1 min), {five:.1f} (5 min)"


def run(bench: Bench, options: tuple[str, ...]) -> tuple[str, str, float]:
    """(command, stdout, seconds) of one benchmark; its output is echoed as it comes."""
    cmd = [sys.executable, f"scripts/{bench.script}", *options]
    shown = " ".join([".venv/bin/python", *cmd[1:]])
    print(f"$ {shown}", flush=True)
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, text=True,
                            env={**os.environ, "MPLBACKEND": "Agg"})
    lines = []
    for line in proc.stdout:
        print(line, end="", flush=True)
        lines.append(line)
    if proc.wait() != 0:
        raise SystemExit(f"performance_page: {shown} failed (exit {proc.returncode}); "
                         f"{PAGE.relative_to(ROOT)} left as it was")
    return shown, "".join(lines).rstrip("\n"), time.monotonic() - t0


def section(bench: Bench, command: str, output: str, seconds: float, before: str) -> str:
    return (f"## {bench.title}\n\n{bench.prose}\n\n"
            f"`{command}` ({seconds:.0f} s; load average {before} at its start):\n\n"
            f"```text\n{output}\n```\n")


def header(args, started: datetime.datetime, code: str, load_start: str, load_end: str) -> str:
    import numba
    import numpy

    sys.path.insert(0, str(ROOT / "scripts"))
    from bench_maps import cpu_model   # /proc/cpuinfo's model name

    made_by = ".venv/bin/python scripts/performance_page.py" + (" --quick" if args.quick else "")
    subset = ("\n**This is the `--quick` subset** (small options, fewer tables): run the "
              "command without `--quick` for the whole page.\n" if args.quick else "")
    return f"""\
# Performance, measured

Generated by `{made_by}` on {started:%Y-%m-%d %H:%M} UTC: every table below is the
verbatim output of the command above it. Do not edit the numbers by hand; run the script
again. Back to the [README](../README.md).
{subset}
- **Code**: commit {code}.
- **CPU**: {cpu_model()}, {len(os.sched_getaffinity(0))} cores usable; Python
  {platform.python_version()}, numpy {numpy.__version__}, numba {numba.__version__}.
- **Load average**: {load_start} at the start, {load_end} at the end. {args.busy_note} The
  engine-to-C ratios are timed in alternation in one process and suffer least from other
  load, and the analysis times are also given relative to a workload timed in the same run.

How accurate each level is, and what accuracy costs per integrator, is the work-precision
study in [ACCURACY.md](ACCURACY.md); the model is in [MODEL.md](MODEL.md).

"""


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="a subset with small options (a check that the page can be made)")
    ap.add_argument("-o", "--output", type=Path, default=PAGE, help=f"default {PAGE}")
    ap.add_argument("--busy-note", default="This machine is shared: other jobs ran while "
                    "these numbers were taken, so absolute times are longer than on an idle "
                    "machine.", help="a sentence on the page about the machine's load")
    args = ap.parse_args(argv)
    started, code, load_start = datetime.datetime.now(datetime.timezone.utc), commit(), load()
    parts = []
    for bench in BENCHES:
        options = bench.quick if args.quick else bench.full
        if options is None:
            continue
        before = load()
        parts.append(section(bench, *run(bench, options), before))
    args.output.write_text(header(args, started, code, load_start, load()) + "\n".join(parts))
    print(f"performance_page: wrote {args.output}")


if __name__ == "__main__":
    main()
