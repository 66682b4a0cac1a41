#!/usr/bin/env python3
"""Benchmark of the web view (issue 28's targets, on a quiet 2-core machine):

- catalogue page with 1,000 sweeps: p95 <= 200 ms;
- a cached map: <= 50 ms;
- the first map of a Fig. 14 31 x 31 cube: <= 1 s;
- an explorer chart of 200 x 200 points: <= 0.5 s from click to image (the page, then
  both images fetched at once, as the browser does after the click).

The store is built here: one small averaged sweep computed, copied into 1,000 catalogue rows
(each with its cube); a Fig. 14 31 x 31 cube laid out by the fig14 plan with the zone of
long sticks filled in by a formula (a map's cost depends on the grid, not on the values).
The server is ``ditherlab web`` in its own process; this one only asks and times.

    python scripts/bench_web.py [--sweeps 1000] [--repeat 40]
"""
from __future__ import annotations

import argparse
import http.client
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

BIN = Path(sys.executable).parent / "ditherlab"
TINY = {"name": "bench-tiny", "friction": "lugre", "method": "averaged",
        "grid": {"W": [0.0, 0.5, 1.0], "v_ref": [0.1, 0.5, 0.9], "v_d": [0.1]}}


def build_store(root: Path, n: int) -> str:
    """``n`` done sweeps (copies of one small averaged cube) and a Fig. 14 31 x 31 cube;
    returns the Fig. 14 sweep's id."""
    import store
    import sweeps
    from store.lease import owner_tag
    from sweeps.run.new_cube import empty_cube
    from sweeps.gallery.scenes import get_scene
    from sweeps.planning.plan import make_plan
    from sweeps.spec.load import load_spec
    from sweeps.version import results_fingerprint

    res = sweeps.run_sweep(TINY, root, progress=False)
    cube = Path(res.cube_path)
    cat = store.Catalogue(root)
    spec_json = json.dumps(TINY)
    for i in range(n - 1):
        sid = f"{i:012x}"
        folder = root / sid
        folder.mkdir()
        shutil.copy(cube, folder / "cube.nc")
        cat.register(sid, f"bench-{i:04d}", spec_json, 9, 1, folder,
                     engine_fingerprint=results_fingerprint())
        cat.acquire(sid)
        cat.finish(sid, "done", owner=owner_tag(), done_points=9, done_blocks=1)
    plan = make_plan(load_spec(get_scene("fig14").spec("full")))
    fig14 = empty_cube(plan)
    W, omega = np.meshgrid(plan.coords["W"], plan.coords["omega"], indexing="ij")
    zone = 0.3 * (W < 0.2 * np.log10(omega) ** 2)   # a zone shaped like Fig. 14's
    for name in plan.outputs:
        values = fig14[name].values
        values[...] = zone.reshape(zone.shape + (1,) * (values.ndim - 2))
    fig14["status"].values[...] = 0
    sweep = store.SweepDir(root, plan.sweep_id)
    sweep.root.mkdir(parents=True, exist_ok=True)
    store.publish(fig14, sweep.cube)
    cat.register(plan.sweep_id, "fig14-31x31", plan.spec.to_json(), plan.n_points,
                 len(plan.blocks), sweep.root, engine_fingerprint=results_fingerprint())
    cat.acquire(plan.sweep_id)
    cat.finish(plan.sweep_id, "done", owner=owner_tag(), done_points=plan.n_points, done_blocks=len(plan.blocks))
    return plan.sweep_id


def get(port: int, path: str) -> tuple[int, bytes]:
    con = http.client.HTTPConnection("127.0.0.1", port, timeout=300)
    try:
        con.request("GET", path)
        r = con.getresponse()
        return r.status, r.read()
    finally:
        con.close()


def timed(port: int, path: str) -> float:
    t = time.perf_counter()
    status, body = get(port, path)
    if status != 200:
        raise SystemExit(f"GET {path}: {status} {body[:200]!r}")
    return time.perf_counter() - t


def show(what: str, seconds: list[float], target_s: float) -> None:
    ms = np.array(seconds) * 1000
    p50, p95 = np.percentile(ms, 50), np.percentile(ms, 95)
    verdict = "meets" if p95 <= target_s * 1000 else "MISSES"
    print(f"{what:<44} n={len(ms):>3}  p50 {p50:7.1f} ms  p95 {p95:7.1f} ms  max {ms.max():7.1f}"
          f" ms   target {target_s * 1000:.0f} ms: {verdict}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sweeps", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=40)
    ap.add_argument("--port", type=int, default=8791)
    args = ap.parse_args()
    os.environ.setdefault("MPLBACKEND", "Agg")
    work = Path(tempfile.mkdtemp(prefix="bench-web-"))
    try:
        t = time.perf_counter()
        fig14 = build_store(work / "store", args.sweeps)
        print(f"store: {args.sweeps} sweeps built in {time.perf_counter() - t:.0f} s; "
              f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
        server = subprocess.Popen([str(BIN), "web", "--store", str(work / "store"), "--bind",
                                   f"127.0.0.1:{args.port}"], stderr=subprocess.PIPE)
        server.stderr.readline()   # "ditherlab web: ... at http://..." once it listens
        try:
            run(args, fig14, work / "store" / fig14 / "cube.nc")
        finally:
            server.terminate()
            server.wait()
        cpu_costs(work / "store" / fig14 / "cube.nc")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    return 0


def cpu_costs(cube: Path, n: int = 3) -> None:
    """The CPU seconds of the same work in this process: what the wall time would be on a
    quiet machine (the wall-clock figures above include waiting for a busy CPU)."""
    from sweeps.web.explorer import compute, spec_from_query
    from sweeps.web.renders import render
    from sweeps.web.snapshot import CubeSnapshot

    data = cube.read_bytes()
    render(CubeSnapshot(None, data).ds, "stick-slip", {}, None, "png")   # imports, fonts
    compute(spec_from_query({"W_num": "3", "v_ref_num": "3"}))   # kernels loaded
    rows = {"first map, Fig. 14 31x31 (read + draw)": [], "explorer 200x200 compute": [],
            "explorer stability chart draw": [], "explorer curves draw": []}
    for i in range(n):
        t = time.process_time()
        render(CubeSnapshot(None, data).ds, "stick-slip", {}, None, "png")
        rows["first map, Fig. 14 31x31 (read + draw)"].append(time.process_time() - t)
        t = time.process_time()
        ds = compute(spec_from_query({"W_num": "200", "v_ref_num": "200",
                                      "v_d": str(0.2 + 0.001 * i)}))
        rows["explorer 200x200 compute"].append(time.process_time() - t)
        t = time.process_time()
        render(ds, "stability", {}, None, "png")
        rows["explorer stability chart draw"].append(time.process_time() - t)
        t = time.process_time()
        render(ds, "friction", {}, 5, "png")
        rows["explorer curves draw"].append(time.process_time() - t)
    print("CPU time of the same work (this process; a quiet machine's wall time):")
    for what, ts in rows.items():
        print(f"  {what:<42} median {1000 * float(np.median(ts)):7.1f} ms CPU")


def run(args, fig14: str, cube: Path) -> None:
    port, n = args.port, args.repeat
    timed(port, "/")   # the first read of 1,000 cube headers (cached afterwards)
    show(f"catalogue page, {args.sweeps} sweeps", [timed(port, "/") for _ in range(n)], 0.2)
    show("catalogue JSON after=0 (every sweep)",
         [timed(port, "/api/sweeps?after=0") for _ in range(n)], 0.2)
    firsts = []
    for i in range(max(3, n // 10)):   # a new publish key each time: a first draw
        os.utime(cube, ns=(time.time_ns(), time.time_ns() + i))
        firsts.append(timed(port, f"/sweep/{fig14}/map/stick-slip.png"))
    show("first map of a Fig. 14 31x31 cube", firsts, 1.0)
    show("cached map (same cube, same map)",
         [timed(port, f"/sweep/{fig14}/map/stick-slip.png") for _ in range(n)], 0.05)
    timed(port, "/explorer/stability.png?W_num=5&v_ref_num=5")   # after the warm-up
    chart, both = [], []
    with ThreadPoolExecutor(2) as pool:
        for i in range(max(3, n // 10)):
            q = f"W_num=200&v_ref_num=200&v_d={0.1 + 0.001 * i}"
            t = time.perf_counter()
            timed(port, f"/explorer?{q}")
            done = pool.map(lambda k: (timed(port, f"/explorer/{k}.png?{q}"),
                                       time.perf_counter()), ("stability", "friction"))
            (_, t_chart), (_, t_both) = done
            chart.append(t_chart - t)
            both.append(max(t_chart, t_both) - t)
    show("explorer 200x200: page + stability chart", chart, 0.5)
    show("explorer 200x200: page + chart + curves", both, 0.5)


if __name__ == "__main__":
    sys.exit(main())
