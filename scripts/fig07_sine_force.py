"""Fig. 7: effective friction under sine-force dither (Sec. 5.2), Eq. 5.20 corrected.

    .venv/bin/python scripts/fig07_sine_force.py      -> out/fig07_sine_force.png

Solid: Eq. 5.20 (no Stribeck, no bristle damping) with DESIGN.md's corrections (1/pi in
Eq. 5.19a; outer branch fc sgn(v)); dashed: the printed outer branch fs sgn(v), which
jumps at |v| = a Omega; dotted: the full LuGre slow manifold (Stribeck + bristle damping,
vd = 0.1) by the sine quadrature, i.e. what the paper's simulations (Fig. 8) contain.
Prints the low-velocity slopes against Eq. 5.21 and the jump of the printed form.
"""
from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from engine import params as P
from engine.analysis import effective_friction, sine_force_simplified

A_OMEGA = (0.5, 0.75)
FC, FS, S2 = 1.0, 1.5, 0.004
OUT = os.path.join(os.path.dirname(__file__), "..", "out")


def main():
    v = np.linspace(-1.5, 1.5, 3001)
    simple = P.pack(fs=FC, sigma1=0.0)
    fig, ax = plt.subplots(figsize=(7, 5))
    print(f"{'a Omega':>8s} {'Eq.5.21':>9s} {'5.20 FD':>9s} {'quad FD':>9s} {'LuGre vd=.1':>12s} {'LuGre vd=.01':>13s} {'printed jump':>13s}")
    for k, W in enumerate(A_OMEGA):
        F = sine_force_simplified(v, W, FC, S2)
        printed = np.where(np.abs(v) > W, FS * np.sign(v) + S2 * v, F)
        ax.plot(v, F, c=f"C{k}", label=f"Eq. 5.20, a Omega = {W}")
        ax.plot(v, printed, "--", c=f"C{k}", lw=0.8, label="printed fs branch" if k == 0 else None)
        ax.plot(v, effective_friction(v, W, P.pack(vd=0.1), dither="sine-force"), ":", c=f"C{k}",
                label="full LuGre, vd = 0.1" if k == 0 else None)
        h = 1e-6
        fd = (sine_force_simplified(h, W, FC, S2) - sine_force_simplified(-h, W, FC, S2)) / (2 * h)
        quad = effective_friction(0.0, W, simple, dither="sine-force", slope=True)[1]
        full = [effective_friction(0.0, W, P.pack(vd=vd), dither="sine-force", slope=True)[1] for vd in (0.1, 0.01)]
        jump = (FS + S2 * W) - sine_force_simplified(W, W, FC, S2)   # printed form at |v| = W+
        print(f"{W:8.2f} {np.pi * FC / (2 * W) + S2:9.5f} {fd:9.5f} {quad:9.5f} {full[0]:12.5f} {full[1]:13.5f} {jump:13.3f}")
    ax.set_xlabel("slow velocity v")
    ax.set_ylabel("<F>")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, "fig07_sine_force.png")
    fig.savefig(path, dpi=120)
    print(f"wrote {os.path.normpath(path)}")


if __name__ == "__main__":
    main()
