"""Fig. 5: effective friction under square-velocity dither (Sec. 5.1), and its slopes.

    .venv/bin/python scripts/fig05_effective_friction.py      -> out/fig05_effective_friction.png

Panels: (a) LuGre slow manifold Eqs. 5.9-5.10, vd = 0.1; (b) vd = 0.01 with Eq. 5.12
(no bristle damping) as markers; (c) static model Eq. 5.14; (d) no dither (LuGre).
The paper does not state the W values of Fig. 5; W = 0.25, 0.5, 1.0 are drawn (0.5 is
the amplitude of its simulations, Fig. 6). Prints the negative-slope zones (analytic
slope on a grid of step 1e-5; edges accurate to one step) and the low-velocity slopes
against Eq. 5.13 and the exact g(W)/W + sigma2 of Eq. 5.12.
"""
from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from engine import params as P
from engine.analysis import effective_friction, negative_slope_zones
from engine.friction.stribeck import g

PAPER = P.pack()

WS = (0.25, 0.5, 1.0)
OUT = os.path.join(os.path.dirname(__file__), "..", "out")


def report_zones():
    v = np.linspace(0.0, 2.0, 200001)
    for vd in (0.1, 0.01):
        for W in (0.0,) + WS:
            _F, dF = effective_friction(v, W, P.pack(vd=vd), slope=True)
            zones = negative_slope_zones(v, dF)
            txt = ", ".join(f"[{a:.5f}, {b:.5f}] (min slope {dF[(v >= a) & (v <= b)].min():.3f})"
                            for a, b in zones)
            print(f"vd={vd:<5} W={W:<5} negative slope on v in {txt}")


def report_slopes():
    p = P.pack()
    print("\nlow-velocity slope d<F>/dv at v = 0 (sigma2 = 0.004)")
    print(f"{'W':>5s} {'Eq.5.13':>10s} {'5.12 exact':>11s} {'LuGre vd=.1':>12s} {'LuGre vd=.01':>13s} {'static':>9s}")
    for W in (0.1, 0.15, 0.2) + WS:
        row = [(1 + W * 0.004) / W, g(W, PAPER) / W + 0.004]
        row += [effective_friction(0.0, W, P.pack(vd=vd), slope=True)[1] for vd in (0.1, 0.01)]
        row += [effective_friction(0.0, W, p, model="static", slope=True)[1]]
        print(f"{W:5.2f} " + " ".join(f"{x:10.5f} " for x in row))


def plot():
    v = np.linspace(-1.5, 1.5, 3001)
    fig, ax = plt.subplots(2, 2, figsize=(10, 8), sharex=True)
    for k, (title, kw) in enumerate([("(a) LuGre, vd = 0.1", {"vd": 0.1}),
                                     ("(b) LuGre, vd = 0.01; o Eq. 5.12", {"vd": 0.01}),
                                     ("(c) static model, Eq. 5.14", {"model": "static"})]):
        a = ax.flat[k]
        for W in WS:
            a.plot(v, effective_friction(v, W, P.pack(), **kw), label=f"W = {W}")
            if k == 1:
                vm = v[::75]
                a.plot(vm, effective_friction(vm, W, P.pack(), model="no-damping"), "o", mfc="none", ms=4, c="k")
        a.set_title(title)
    vv = v[v != 0]
    ax[1, 1].plot(vv, effective_friction(vv, 0.0, P.pack()), c="k")
    ax[1, 1].set_title("(d) without dither (LuGre)")
    for a in ax.flat:
        a.set_xlabel("slow velocity v")
        a.set_ylabel("<F>")
        a.grid(alpha=0.3)
    ax[0, 0].legend()
    fig.tight_layout()
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, "fig05_effective_friction.png")
    fig.savefig(path, dpi=120)
    print(f"\nwrote {os.path.normpath(path)}")


if __name__ == "__main__":
    report_zones()
    report_slopes()
    plot()
