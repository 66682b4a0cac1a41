"""The averaged path for a friction law that declares its steady-state curve (engine.contract,
docs/MODELS.md rule 7): Dahl, GMS and the laws users bring.

With ``F_ss(u)`` the friction at constant sliding velocity ``u`` (``law.build_steady``), the
effective friction at slow velocity ``v`` under velocity dither of amplitude ``W`` is its
phase average (engine.analysis.quadrature's rules: two points for the square wave,
Gauss-Legendre on each smooth piece of ``(1/pi) int_0^pi F_ss(v + W cos phi) dphi`` for a sine,
split at the kink ``u = 0``), and the averaged slider is the memoryless ``(e, v)`` system of a
static law, stable when ``dF_eff/dv > 0`` (engine.analysis.stability.static_max_real_eig).
The slope is a central difference of ``F_eff`` (step ``1e-6 max(1, |v|)``).

This is the quasi-static reading: the law's internal states are taken at their steady value
for each instantaneous velocity, which the paper's LuGre analysis (Eqs. 6.4-6.7) refines by
keeping the bristle state; for a law with states, a fast dither (omega much above the states'
relaxation rates) is where it holds.
"""
from __future__ import annotations

from functools import cache

import numpy as np

from ..contract import ModelError
from ..jit import njit
from .quadrature import SQUARE, gauss_legendre, rule_code


def has_steady(law) -> bool:
    """True when the law declares a steady-state curve (overrides ``build_steady``)."""
    from ..contract import FrictionLaw

    return type(law).build_steady is not FrictionLaw.build_steady


@cache
def _kernel(scene):
    from .. import registry
    from ..systems import build_context

    law, _, b = build_context(scene.with_(path="simulate", integrator="dopri5"))
    steady = law.build_steady(b)
    if steady is None:
        raise ModelError(f"friction {registry.law(scene.friction).name!r}: no steady-state "
                         "curve (build_steady), so no averaged model; use a time integrator")

    @njit(error_model="numpy")
    def average(v, W, rule, x, wx, p):
        Wa = abs(W)
        if rule == SQUARE:
            return 0.5 * (steady(v + Wa, p) + steady(v - Wa, p))
        total = 0.0
        lo_hi = (0.0, np.pi)
        if Wa > abs(v):
            phi0 = np.arccos(-v / Wa)
            pieces = ((0.0, phi0), (phi0, np.pi))
        else:
            pieces = (lo_hi, lo_hi)
        for j in range(2 if Wa > abs(v) else 1):
            lo, hi = pieces[j]
            half, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
            for k in range(x.size):
                total += half * wx[k] / np.pi * steady(v + Wa * np.cos(mid + half * x[k]), p)
        return total

    @njit(error_model="numpy", entry=True)
    def run(v, W, rule, x, wx, p, F, dF):
        for i in range(v.size):
            F[i] = average(v[i], W[i], rule, x, wx, p)
            h = 1e-6 * max(1.0, abs(v[i]))
            dF[i] = (average(v[i] + h, W[i], rule, x, wx, p)
                     - average(v[i] - h, W[i], rule, x, wx, p)) / (2.0 * h)
    return run


def steady_effective(scene, v, W, p, n_quad: int):
    """``(F_eff, dF_eff/dv)`` at each point (module docstring)."""
    x, wx = gauss_legendre(n_quad)
    v = np.ascontiguousarray(v, dtype=np.float64)
    W = np.ascontiguousarray(W, dtype=np.float64)
    F, dF = np.empty(v.size), np.empty(v.size)
    dither = "none" if scene.dither == "none" else scene.dither
    _kernel(scene)(v, W, rule_code(dither), x, wx, np.ascontiguousarray(p), F, dF)
    return F, dF
