"""Figs. 6 and 8: effective friction by simulation against the averaged theory.

    .venv/bin/python scripts/fig06_fig08_simulated_friction.py  -> out/fig06_fig08_simulated_friction.png

As in the paper (Secs. 5.1, 5.2): slider with v_ref = 0, LuGre (Sec. 5.1 parameters),
slow force 1.7 sin(0.5 tau), and either the square-velocity dither W = 0.5, omega = 1000
(Fig. 6) or the sine force 1500 sin(2000 tau), i.e. W = a Omega = 0.75, omega = 2000
(Fig. 8), for vd = 0.1 and 0.01. One trajectory each through the engine's own API
(engine.api.simulate, method rk4 with a fixed step that divides the dither (half-)period:
32 steps per half-period / 128 per period), 3 slow periods, the first discarded.

Friction F(u, z) and the slider velocity v are low-passed by an 8th-order Butterworth
filter with edge 500 rad per unit tau (the paper: "order 8, lower band edge frequency 500";
its frequency unit is read as rad per unit tau, DESIGN.md §1), applied forward-backward
(scipy.signal.sosfiltfilt, zero phase; the paper's analog filter adds a delay of order
1e-2 tau, small against the slow period 12.6). The filtered cloud (F_f against v_f) is
compared with the averaged curve <F>(v): RMS and max deviation of F_f - <F>(v_f), for the
full LuGre slow manifold (Eq. 5.9, square rule / sine quadrature) and, for the sine force,
the simplified Eq. 5.20.
"""
from __future__ import annotations

import os
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numba import njit
from scipy.signal import butter, sosfiltfilt

from engine import params as P
from engine.analysis import effective_friction, sine_force_simplified
from engine.api import simulate
from engine.scene import Scene
from engine.settings import Settings
from engine.systems import slider

OUT = os.path.join(os.path.dirname(__file__), "..", "out")
CASES = {"fig06 square W=0.5, omega=1000": ("square-velocity", 0.5, 1000.0, 32),
         "fig08 sine force 1500 sin(2000 tau)": ("sine-force", 0.75, 2000.0, 128)}
T_SLOW = 2 * np.pi / 0.5


def friction_samples(scene, p, t, y, dither, omega):
    """F(u, z) at the recorded states via the slider's own interface function."""
    interface = slider.make_interface(scene)

    @njit
    def loop(t, y, p, sq, F):
        for i in range(t.size):
            F[i] = interface(t[i], y[i], p, sq[i])[1]

    # left limit at a switch: the sign of the half-period that ends at t
    k = np.ceil(t * omega / np.pi - 1e-9) - 1
    sq = np.where(k % 2 == 0, 1.0, -1.0) if dither == "square-velocity" else np.ones_like(t)
    F = np.empty(t.size)
    loop(t, np.ascontiguousarray(y), p, sq, F)
    return F


def run(dither, W, omega, spp, vd):
    p = P.pack(vd=vd, W=W, omega=omega, slow_a=1.7, slow_omega=0.5, v_ref=0.0, t_end=3 * T_SLOW)
    scene = Scene.from_params(p, system="slider", friction="lugre", dither=dither, integrator="rk4")
    t0 = time.perf_counter()
    sim = simulate(scene, p, Settings(steps_per_period=spp), record=True, max_records=2_000_000)
    h = (np.pi if dither == "square-velocity" else 2 * np.pi) / omega / spp
    on_grid = np.abs(sim.t / h - np.round(sim.t / h)) < 1e-6       # drop extra stops
    t, y = sim.t[on_grid], sim.y[on_grid]
    F = friction_samples(scene, p, t, y, dither, omega)
    sos = butter(8, 500.0, fs=2 * np.pi / h, output="sos")
    keep = t >= T_SLOW
    vf, Ff = sosfiltfilt(sos, y[:, slider.V])[keep], sosfiltfilt(sos, F)[keep]
    return sim, vf, Ff, time.perf_counter() - t0


def main():
    fig, ax = plt.subplots(2, 2, figsize=(11, 8))
    for row, (name, (dither, W, omega, spp)) in enumerate(CASES.items()):
        for col, vd in enumerate((0.1, 0.01)):
            sim, vf, Ff, wall = run(dither, W, omega, spp, vd)
            theory = effective_friction(vf, W, P.pack(vd=vd), dither=dither)
            dev = Ff - theory
            line = (f"{name}, vd={vd}: status {sim.status}, {sim.steps} steps, {wall:.1f} s; "
                    f"v_f in [{vf.min():.3f}, {vf.max():.3f}]; F_f - <F>(v_f): "
                    f"RMS {np.sqrt(np.mean(dev ** 2)):.4f}, max {np.abs(dev).max():.4f}")
            if dither == "sine-force":
                d2 = Ff - sine_force_simplified(vf, W, 1.0, 0.004)
                line += f"; vs Eq. 5.20: RMS {np.sqrt(np.mean(d2 ** 2)):.4f}, max {np.abs(d2).max():.4f}"
            print(line)
            a = ax[row, col]
            a.plot(vf[::20], Ff[::20], ".", ms=1.5, c="C0", label="simulation, filtered")
            vv = np.linspace(vf.min(), vf.max(), 400)
            a.plot(vv, effective_friction(vv, W, P.pack(vd=vd), dither=dither), "k-", lw=1,
                   label="averaged LuGre")
            if dither == "sine-force":
                a.plot(vv, sine_force_simplified(vv, W, 1.0, 0.004), "r--", lw=1, label="Eq. 5.20")
            a.set(title=f"{name}, vd = {vd}", xlabel="filtered v", ylabel="filtered F")
            a.grid(alpha=0.3)
            a.legend(fontsize=8)
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, "fig06_fig08_simulated_friction.png")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {os.path.normpath(path)}")


if __name__ == "__main__":
    main()
