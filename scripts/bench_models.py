"""A law a user brings is as fast as the same law built in (issue 35): the GMS of
docs/examples/mylab/laws.py (``mylab.laws:MaxwellSlip``) against the built-in ``gms`` on the
same block of points, and Dahl against LuGre in its special case, as ratios measured in one
run (paired, interleaved, median of repeats; thread CPU time). Prints the CPU model.

    .venv/bin/python scripts/bench_models.py [--repeats 7] [--points 16]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "docs" / "examples")]

from engine import Scene, Settings, registry  # noqa: E402
from engine.blocks import run_block  # noqa: E402
from machine import cpu_model  # noqa: E402  (/proc/cpuinfo's model name)

GMS = {"k": [40.0, 100.0, 250.0], "alpha": [0.2, 0.3, 0.5], "C": 20.0}


def case(ref, own, points, **shared):
    p = registry.pack(ref, "slider", own, **shared)
    scene = Scene.from_params(p, friction=ref, dither="sine-velocity",
                              outputs=("v_mean", "F_mean", "stick_fraction"),
                              sizes=registry.sizes_of(ref, "slider", own))
    settings = Settings(rtol=1e-8, atol=1e-11)
    run_block(scene, points[:1], p, settings)          # compile
    return lambda: run_block(scene, points, p, settings)


def timed(fn) -> float:
    t0 = time.thread_time()
    fn()
    return time.thread_time() - t0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--points", type=int, default=16)
    a = ap.parse_args()
    W = np.linspace(0.0, 0.5, a.points)
    points = np.stack([W, np.full_like(W, 50.0), np.full_like(W, 0.1), np.full_like(W, 0.1)], 1)
    window = dict(t_end=20.0, t_transient=5.0)
    pairs = {
        "GMS (3 elements): user / built-in": (
            case("mylab.laws:MaxwellSlip", GMS, points, **window),
            case("gms", GMS, points, **window)),
        "Dahl (alpha = 1) / LuGre (g = fc, sigma1 = 0)": (
            case("dahl", {"dahl_alpha": 1.0}, points, sigma1=0.0, fs=1.0, **window),
            case("lugre", {}, points, sigma1=0.0, fs=1.0, **window)),
    }
    print(f"CPU: {cpu_model()}; {a.points} points a block, median of {a.repeats}")
    print(f"{'pair':48s} {'A s':>9s} {'B s':>9s} {'A/B':>6s}")
    for name, (fa, fb) in pairs.items():
        ta, tb = [], []
        for _ in range(a.repeats):      # interleaved: the machine's load falls on both alike
            ta.append(timed(fa))
            tb.append(timed(fb))
        ma, mb = float(np.median(ta)), float(np.median(tb))
        print(f"{name:48s} {ma:9.4f} {mb:9.4f} {ma / mb:6.3f}")


if __name__ == "__main__":
    main()
