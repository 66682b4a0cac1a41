"""A system as a user brings it (engine.contract, docs/MODELS.md): a contact driven along a
prescribed displacement path with reversals, to draw a friction law's hysteresis loops
(``system = "mylab.rigs:Stroke"``; tests/engine/test_models_reference.py,
scripts/models_figures.py).

The path visits the corners ``path[0], path[1], ...`` in turn; each leg takes
``|dx| / speed`` and follows a half-cosine, ``x = x_a + (x_b - x_a) (1 - cos(pi s)) / 2``, so
the velocity ``u`` passes through zero smoothly at every corner (a reversal).
"""
from __future__ import annotations

import math

import numpy as np

from engine import registry
from engine.contract import MechanicalSystem, Param, SystemKernels


class Stroke(MechanicalSystem):
    name = "stroke"
    group = "stroke"
    state_names = ()
    dithers = ("none",)
    params = {
        "path": Param((0.0, 1.0), "1", "displacement corners", vector=True),
        "speed": Param(1e-3, "1", "mean speed of a leg", lo=0.0, lo_open=True),
    }

    def build(self, b):
        n = b.size["path"]
        ip, isp = b.ix["path"], b.ix["speed"]

        @b.jit(inline="always", error_model="numpy")
        def leg(t, p):
            """(x_a, x_b, s, T) of the leg holding time t (the last leg extended)."""
            t0 = 0.0
            for j in range(n - 1):
                xa, xb = p[ip + j], p[ip + j + 1]
                T = abs(xb - xa) / p[isp]
                if t < t0 + T or j == n - 2:
                    return xa, xb, (t - t0) / T, T
                t0 += T
            return 0.0, 0.0, 0.0, 1.0

        @b.jit(inline="always", error_model="numpy")
        def drive(t, y, p, sq):
            xa, xb, s, T = leg(t, p)
            return (xb - xa) * math.pi / (2.0 * T) * math.sin(math.pi * s), 0.0, 0.0

        @b.jit(inline="always", error_model="numpy")
        def dynamics(t, y, p, sq, u, f, F, dy):
            pass

        @b.jit(inline="always", error_model="numpy")
        def position(t, y, p):
            xa, xb, s, T = leg(t, p)
            return xa + (xb - xa) * (1.0 - math.cos(math.pi * s)) / 2.0

        @b.jit(inline="always", error_model="numpy")
        def velocity(t, y, p, sq):
            u, _, _ = drive(t, y, p, sq)
            return u

        @b.jit(inline="always", error_model="numpy")
        def nothing(p, y):
            pass

        return SystemKernels(drive, dynamics, position, velocity, nothing, nothing)


def stroke_run(k, alpha, C, path, settings=None, samples_per_leg=200, friction="gms"):
    """(x, F, marks): displacement and friction force sampled along the path, and the
    sample index of each corner."""
    from engine import Scene, Settings, simulate

    speed = 1e-3
    legs = [abs(b - a) / speed for a, b in zip(path[:-1], path[1:])]
    dt = min(legs) / samples_per_leg
    # corners on the sampling grid: legs are multiples of dt when path steps are multiples
    t_end = sum(legs)
    own = {"k": list(k), "alpha": list(alpha), "C": C, "path": list(path), "speed": speed}
    system = "mylab.rigs:Stroke"
    p = registry.pack(friction, system, own, fs=1.5, fc=1.0, vs=0.1, sigma2=0.0,
                      t_end=t_end, t_transient=0.0)
    scene = Scene(system=system, friction=friction, dither="none", viscous=False,
                  bristle_damping=False, outputs=("F_mean",),
                  sizes=registry.sizes_of(friction, system, own))
    r = simulate(scene, p, settings or Settings(rtol=1e-10, atol=1e-13), record_dt=dt)
    assert r.status == 0
    n = len(k)
    F = r.y[:, :n] @ np.asarray(k)
    t = r.t
    corners = np.cumsum([0.0, *legs])
    x = np.interp(t, corners, path)
    # the exact displacement (half-cosine legs)
    for j, (a, b) in enumerate(zip(path[:-1], path[1:])):
        inside = (t >= corners[j]) & (t <= corners[j + 1])
        s = (t[inside] - corners[j]) / legs[j]
        x[inside] = a + (b - a) * (1 - np.cos(np.pi * s)) / 2
    marks = [int(np.argmin(abs(t - c))) for c in corners]
    return x, F, marks
