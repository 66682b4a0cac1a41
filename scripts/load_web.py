#!/usr/bin/env python3
"""A bounded load test of the web view on loopback (issue 28): 20 clients for 60 s over
the catalogue, its JSON, sweep pages, maps and downloads while a sweep runs; then

- 0 errors (every answer 200, every body whole: a cube.nc opens, a PNG decodes);
- p50 / p95 latency per kind of request, printed;
- the running sweep's cube identical (outputs and status; the wall-clock cost aside) to
  the same spec computed afterwards in a fresh store without load.

The server is ``ditherlab web`` and the sweep ``ditherlab submit``, each its own process.

    python scripts/load_web.py [--clients 20] [--seconds 60]
"""
from __future__ import annotations

import argparse
import io
import os
import random
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_web import get  # noqa: E402 -- one HTTP GET for both web scripts

BIN = Path(sys.executable).parent / "ditherlab"
RUNNING = """
name = "load-running"
friction = "elastoplastic"
dither = "sine-velocity"
method = "simulate"
outputs = ["stick_fraction", "long_stick_fraction", "max_stick", "F_mean"]
accuracy = "draft"
block_size = 1
[params]
lam = 0.8
slow_force = { amplitude = 1.7, omega = 0.3 }
[time]
t_end = 60.0
t_transient = 20.0
[grid]
W     = { start = 0.0, stop = 3.0, num = 6 }
omega = { start = 20.0, stop = 2000.0, num = 5, scale = "log" }
v_ref = [0.1]
v_d   = [0.1]
"""
SHOWN = {"friction": "lugre", "method": "averaged", "name": "load-chart",
         "grid": {"W": {"start": 0.0, "stop": 1.2, "num": 61},
                  "v_ref": {"start": 0.005, "stop": 1.2, "num": 60}, "v_d": [0.1, 0.01]}}


def whole(kind: str, body: bytes) -> bool:
    """A body is what it says: a netCDF cube opens, a PNG is a PNG, JSON parses."""
    if kind == "cube.nc":
        import h5py

        with h5py.File(io.BytesIO(body), "r") as f:
            return "status" in f
    if kind.startswith("map"):
        return body.startswith(b"\x89PNG") or body.startswith(b"<?xml")
    if kind == "api":
        import json

        json.loads(body)
    return len(body) > 0


def requests(avg: str, run: str) -> list[tuple[str, str]]:
    return [("catalogue", "/"), ("api", "/api/sweeps?after=0"),
            ("sweep page", f"/sweep/{avg}"), ("sweep page", f"/sweep/{run}"),
            ("map", f"/sweep/{avg}/map/stability.png?sel.v_d=0.1"),
            ("map", f"/sweep/{avg}/map/stability.png?sel.v_d=0.01"),
            ("map", f"/sweep/{avg}/map/friction.svg?sel.v_d=0.1&pick=4"),
            ("map running", f"/sweep/{run}/map/stick-slip.png"),
            ("query.csv", f"/sweep/{avg}/query.csv?sel.v_d=0.1"),
            ("query.json", f"/sweep/{run}/query.json"),
            ("cube.nc", f"/sweep/{avg}/cube.nc"), ("cube.nc", f"/sweep/{run}/cube.nc")]


def client(port, todo, until, seed, times, errors, lock):
    rng = random.Random(seed)
    while time.monotonic() < until:
        kind, path = rng.choice(todo)
        t = time.perf_counter()
        try:
            status, body = get(port, path)
            ok = status == 200 and whole(kind, body)
            why = f"{status} {body[:120]!r}"
        except Exception as exc:  # noqa: BLE001 -- every failure is counted and shown
            ok, why = False, f"{type(exc).__name__}: {exc}"
        with lock:
            times[kind].append(time.perf_counter() - t)
            if not ok:
                errors.append(f"{kind} {path}: {why}")


def results(path: Path):
    import xarray as xr

    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.drop_vars("cost_s").drop_attrs().load()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clients", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--port", type=int, default=8792)
    args = ap.parse_args()
    os.environ.setdefault("MPLBACKEND", "Agg")
    import sweeps
    from sweeps.spec import load_spec

    work = Path(tempfile.mkdtemp(prefix="load-web-"))
    root = work / "store"
    spec = work / "running.toml"
    spec.write_text(RUNNING)
    avg = sweeps.run_sweep(SHOWN, root, progress=False).sweep_id
    run_id = load_spec(spec).sweep_id
    submit = subprocess.Popen([str(BIN), "submit", str(spec), "--store", str(root), "-q"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    server = subprocess.Popen([str(BIN), "web", "--store", str(root), "--bind",
                               f"127.0.0.1:{args.port}"], stderr=subprocess.PIPE)
    server.stderr.readline()
    cube = root / run_id / "cube.nc"
    while not cube.exists():   # its first publish: from then on its pages have a cube
        if submit.poll() is not None:
            raise SystemExit(f"the sweep ended before its first publish: {submit.stderr.read()}")
        time.sleep(0.2)
    times, errors, lock = defaultdict(list), [], threading.Lock()
    until = time.monotonic() + args.seconds
    todo = requests(avg, run_id)
    load0 = os.getloadavg()[0]
    threads = [threading.Thread(target=client, args=(args.port, todo, until, i, times, errors,
                                                     lock)) for i in range(args.clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    running_after = submit.poll() is None
    server.terminate()
    server.wait()
    out, err = submit.communicate()
    n = sum(len(v) for v in times.values())
    print(f"{args.clients} clients, {args.seconds:.0f} s: {n} requests, {len(errors)} errors; "
          f"the sweep was {'still running' if running_after else 'finished'} at the end "
          f"({out.decode().strip().splitlines()[0] if out else err.decode()[:200]}); "
          f"load average {load0:.2f} -> {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    for kind, ts in sorted(times.items()):
        ms = np.array(ts) * 1000
        print(f"  {kind:<12} n={len(ms):>5}  p50 {np.percentile(ms, 50):8.1f} ms  "
              f"p95 {np.percentile(ms, 95):8.1f} ms  max {ms.max():8.1f} ms")
    for e in errors[:10]:
        print(f"  error: {e}")
    clean = work / "clean"
    subprocess.run([str(BIN), "submit", str(spec), "--store", str(clean), "-q"], check=True,
                   capture_output=True)
    same = results(cube).identical(results(clean / run_id / "cube.nc"))
    print(f"the loaded sweep's cube {'is identical to' if same else 'DIFFERS from'} the one "
          f"computed without load (outputs and status)")
    shutil.rmtree(work, ignore_errors=True)
    return 0 if same and not errors else 1


if __name__ == "__main__":
    sys.exit(main())
