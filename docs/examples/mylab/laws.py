"""Generalized Maxwell-slip friction as a user writes it for ditherlab (docs/MODELS.md).

Al-Bender, Lampaert and Swevers, IEEE TAC 50(11), 2005: N elements, each a spring k_i that
sticks to the surface until its force reaches its share alpha_i of the Stribeck curve s(u),
then slips with its force drawn toward that share at the rate C / s(u) until the velocity
reverses. Use it from a spec with

    friction = "mylab.laws:MaxwellSlip"
    [params]
    gms = { k = [40.0, 100.0, 250.0], alpha = [0.2, 0.3, 0.5], C = 20.0 }

(run ditherlab from the folder that holds mylab/, or put it on PYTHONPATH).
"""
import math

from engine.contract import FrictionLaw, LawKernels, ModelError, Param


class MaxwellSlip(FrictionLaw):
    name = "maxwell_slip"
    group = "gms"                      # its parameters: [params] gms = { ... }
    params = {
        "k": Param((100.0,), "1", "element stiffnesses", lo=0.0, lo_open=True, vector=True),
        "alpha": Param((1.0,), "1", "element weights, summing to 1", lo=0.0, hi=1.0,
                       lo_open=True, vector=True),
        "C": Param(20.0, "1", "attraction rate of a slipping element", lo=0.0, lo_open=True),
    }
    phases = "alpha"                   # alpha = the weight of the slipping elements
    switch_jumps = True                # a mode change is a jump: probe for grazing switches

    def n_states(self, size):
        return size["k"]               # one deflection per element ...

    def n_modes(self, size):
        return size["k"]               # ... and one stick/slip mode per element

    def check(self, values):
        if len(values["k"]) != len(values["alpha"]):
            raise ModelError("params.gms: give one weight alpha per stiffness k")
        if abs(sum(values["alpha"]) - 1.0) > 1e-9:
            raise ModelError("params.gms: the weights alpha must sum to 1")

    def build(self, b):
        n, Z, M = b.size["k"], b.z0, b.m0          # sizes and offsets: compile-time constants
        ik, ia, iC = b.ix["k"], b.ix["alpha"], b.ix["C"]
        fc, fs, vs, delta, sigma2 = (b.ix[k] for k in ("fc", "fs", "vs", "delta", "sigma2"))
        stick_band = b.ix["stick_band"]

        square = b.scene.delta == 2.0              # delta = 2 known at compile time: no pow

        @b.jit(inline="always")
        def s(u, p):                               # the Stribeck curve
            x = u / p[vs]
            return p[fc] + (p[fs] - p[fc]) * math.exp(-(x * x if square else abs(x) ** p[delta]))

        @b.jit(inline="always")
        def force_of(u, y, p):
            F = p[sigma2] * u
            for i in range(n):
                F += p[ik + i] * y[Z + i]
            return F

        @b.jit(inline="always")
        def rates(u, y, dy, hold, p):
            su = s(u, p)
            for i in range(n):
                if y[M + i] == 0.0:                 # stuck: the spring follows the surface
                    dy[Z + i] = u
                else:                               # slipping toward its share of s(u)
                    dy[Z + i] = p[iC] / p[ik + i] * (y[M + i] * p[ia + i]
                                                      - p[ik + i] * y[Z + i] / su)
            return force_of(u, y, p)

        @b.jit(inline="always")
        def force(u, y, hold, p):
            slipping = 0.0
            for i in range(n):
                if y[M + i] != 0.0:
                    slipping += p[ia + i]
            return force_of(u, y, p), min(slipping, 1.0)

        @b.jit(inline="always")
        def switches(u, y, hold, p, g):            # where the modes change
            g[0] = u                               # a reversal
            su = s(u, p)
            d = 1.0 if u > 0.0 else -1.0
            for i in range(n):                     # a stuck element reaching its share
                stuck = y[M + i] == 0.0 and abs(u) >= p[stick_band]   # in the direction of u
                g[1 + i] = p[ia + i] * su - d * p[ik + i] * y[Z + i] if stuck else 1.0

        @b.jit(inline="always")
        def update_modes(u, y, hold, p, landed):   # landed: the switch just landed on, or -1
            changed = False
            su = s(u, p)
            band = p[stick_band]
            for i in range(n):
                Fi = p[ik + i] * y[Z + i]
                if y[M + i] == 0.0 and abs(u) >= band and (
                        landed == 1 + i or (Fi * u > 0.0 and abs(Fi) >= p[ia + i] * su)):
                    y[M + i] = 1.0 if u > 0.0 else -1.0
                    changed = True
                elif y[M + i] != 0.0 and (landed == 0 or y[M + i] * u < 0.0 or abs(u) < band):
                    y[M + i] = 0.0
                    changed = True
            return changed

        @b.jit(inline="always")
        def init(p, y):
            for i in range(n):
                y[Z + i] = 0.0
                y[M + i] = 0.0

        @b.jit(inline="always")
        def scales(p, out):
            for i in range(n):
                out[Z + i] = p[ia + i] * p[fc] / p[ik + i]

        return LawKernels(rates, force, 1 + n, switches, init, scales, update_modes)

    def build_steady(self, b):
        fc, fs, vs, delta, sigma2 = (b.ix[k] for k in ("fc", "fs", "vs", "delta", "sigma2"))

        @b.jit
        def steady(u, p):
            s = p[fc] + (p[fs] - p[fc]) * math.exp(-abs(u / p[vs]) ** p[delta])
            return math.copysign(s, u) * (u != 0.0) + p[sigma2] * u
        return steady
