"""Generalized Maxwell-slip friction (Al-Bender, Lampaert and Swevers, IEEE TAC 50(11), 2005),
N elements, through the model contract; the form of issue 35.

Element i has stiffness ``k_i``, weight ``alpha_i`` (the weights sum to 1), deflection ``z_i``
(a state) and force ``F_i = k_i z_i``; its mode ``m_i`` is 0 (stuck) or ``+-1`` (slipping in
that direction), a discrete mode of the contract. With the Stribeck curve
``s(u) = fc + (fs - fc) exp(-|u / vs|**delta)`` (Eq. 2.4):

    stuck:     dz_i/dt = u                                until |F_i| reaches alpha_i s(u)
    slipping:  dz_i/dt = (C / k_i) (m_i alpha_i - F_i / s(u))      until u reverses
                                              (reaches the band |u| < stick_band, a reading)
    F = sum_i F_i + sigma2 u                             (sigma2 u only with the viscous effect)

A stuck element whose force grows to its share of the Stribeck curve starts slipping in the
direction of u (``m_i = sgn u``), its force then attracted to ``m_i alpha_i s(u)`` at the rate
``C / s(u)``; when u reverses every slipping element sticks again. The model has hysteresis
with non-local memory: a minor loop closes where it began (tests/engine/test_models_reference.py).

Switches: ``u`` (reversal) and, per stuck element, ``alpha_i s(u) - sgn(u) F_i`` (+1 while it
slips, or inside the band ``|u| < stick_band``); the modes change on them, after the
integrator landed there (engine.contract).
Phases (``alpha`` of the observables): the weight of the slipping elements,
``sum_i alpha_i [m_i != 0]``: 0 all stuck (stick), 1 all slipping (slip), between pre-sliding.
Steady state at constant ``u``: ``F_ss = s(u) sgn(u) + sigma2 u`` (weights summing to 1).

Spec: ``friction = "gms"``, ``[params] gms = { k = [...], alpha = [...], C = ... }`` (N = len(k)).
"""
from __future__ import annotations

from .. import params as P
from ..contract import FrictionLaw, LawKernels, ModelError, Param
from .stribeck import make_g

# relative: a stuck element at |F_i| >= (1 - SLIP_EDGE) alpha_i s(u) slips. A landing on the
# switch may stop a hair short of it (the locator's theta is exact to 1e-13 of the step; seen:
# alpha_i s - |F_i| = 6e-13 of 0.2 left over), and the next step would then find the root at
# its very start, too close to land on, and switch a whole step late (an overshoot of |F_i| of
# 6 % on the dithered slider, 1e-3 in v_mean): the edge must cover what a landing leaves.
# The same for a reversal: a landing on u = 0 may leave u a hair on the old side, so a
# slipping element sticks once |u| < stick_band (and a stuck one slips only outside it).
SLIP_EDGE = 1e-9


class GMS(FrictionLaw):
    name = "gms"
    group = "gms"
    params = {
        "k": Param((100.0,), "1", "element stiffnesses k_i (force per deflection)", lo=0.0,
                   lo_open=True, vector=True),
        "alpha": Param((1.0,), "1", "element weights alpha_i (summing to 1)", lo=0.0, hi=1.0,
                       lo_open=True, vector=True),
        "C": Param(20.0, "1", "attraction rate of a slipping element's force (force/time)",
                   lo=0.0, lo_open=True),
    }
    phases = "alpha"
    # a mode change is a jump of the right-hand side: a reversal there and back inside one
    # step (u grazing zero) must be found too (the integrators' grazing probe); without it,
    # rtol 1e-5 missed one on the dithered slider and F_mean came out 15 % off
    switch_jumps = True

    def effects(self, scene):
        return {"bristle damping": False, "stick/slip modes": True}   # no sigma1 in GMS

    def n_states(self, size):
        return int(size.get("k", 1))

    def n_modes(self, size):
        return int(size.get("k", 1))

    def check(self, values):
        k, a = values["k"], values["alpha"]
        if len(k) != len(a):
            raise ModelError(f"params.gms: k has {len(k)} elements and alpha {len(a)}; give "
                             "one weight per stiffness")
        if abs(sum(a) - 1.0) > 1e-9:
            raise ModelError(f"params.gms: the weights alpha must sum to 1, got {sum(a)!r}")

    def build(self, b):
        n, Z, M = self.n_states(b.size), b.z0, b.m0
        ik, ia, iC = b.ix["k"], b.ix["alpha"], b.ix["C"]
        viscous = b.scene.viscous
        s = make_g(b.scene.stribeck, b.scene.delta)

        @b.jit(inline="always", error_model="numpy")
        def total(u, y, p):
            F = 0.0
            for i in range(n):
                F += p[ik + i] * y[Z + i]
            if viscous:
                F += p[P.SIGMA2] * u
            return F

        @b.jit(inline="always", error_model="numpy")
        def rates(u, y, dy, hold, p):
            su = s(u, p)
            for i in range(n):
                m = y[M + i]
                if m == 0.0:
                    dy[Z + i] = u
                else:
                    dy[Z + i] = p[iC] / p[ik + i] * (m * p[ia + i] - p[ik + i] * y[Z + i] / su)
            return total(u, y, p)

        @b.jit(inline="always", error_model="numpy")
        def force(u, y, hold, p):
            share = 0.0
            for i in range(n):
                if y[M + i] != 0.0:
                    share += p[ia + i]
            return total(u, y, p), min(share, 1.0)

        @b.jit(inline="always", error_model="numpy")
        def switches(u, y, hold, p, g):
            g[0] = u
            su = s(u, p)
            band = p[P.STICK_BAND]
            d = 1.0 if u > 0.0 else -1.0
            for i in range(n):
                # a stuck element slips when its force *in the direction of u* reaches its
                # share: signed, so that an element just stuck by a reversal (its force at
                # minus its share) starts far from the switch, not a hair either side of it
                if y[M + i] == 0.0 and abs(u) >= band:
                    g[1 + i] = p[ia + i] * su - d * p[ik + i] * y[Z + i]
                else:
                    g[1 + i] = 1.0

        @b.jit(inline="always", error_model="numpy")
        def update_modes(u, y, hold, p, landed):
            """``landed``: the switch an adaptive step just landed on (0 the reversal, 1 + i
            element i's share), -1 for none; the state-based tests catch a switch crossed
            without a landing (fixed steps)."""
            changed = False
            su = s(u, p)
            band = p[P.STICK_BAND]
            for i in range(n):
                m = y[M + i]
                Fi = p[ik + i] * y[Z + i]
                if m == 0.0:
                    if abs(u) >= band and (landed == 1 + i or (
                            Fi * u > 0.0 and abs(Fi) >= (1.0 - SLIP_EDGE) * p[ia + i] * su)):
                        y[M + i] = 1.0 if u > 0.0 else -1.0
                        changed = True
                elif landed == 0 or m * u < 0.0 or abs(u) < band:
                    y[M + i] = 0.0
                    changed = True
            return changed

        @b.jit(inline="always", error_model="numpy")
        def init(p, y):
            for i in range(n):
                y[Z + i] = 0.0
                y[M + i] = 0.0

        @b.jit(inline="always", error_model="numpy")
        def scales(p, out):
            fc = abs(p[P.FC])
            for i in range(n):
                out[Z + i] = p[ia + i] * (fc if fc > 0.0 else 1.0) / p[ik + i]

        return LawKernels(rates, force, 1 + n, switches, init, scales, update_modes)

    def build_steady(self, b):
        n, ia, viscous = self.n_states(b.size), b.ix["alpha"], b.scene.viscous
        s = make_g(b.scene.stribeck, b.scene.delta)

        @b.jit(error_model="numpy")
        def steady(u, p):
            w = 0.0
            for i in range(n):
                w += p[ia + i]
            F = w * s(u, p) * (1.0 if u > 0.0 else (-1.0 if u < 0.0 else 0.0))
            if viscous:
                F += p[P.SIGMA2] * u
            return F
        return steady
