"""Stribeck curve and velocity-dependent bristle damping, on the parameter vector ``p``.

    g(u)      = fc + (fs - fc) * exp(-|u / vs|**delta)        (Eq. 2.4)
    sigma1(u) = sigma1_hat * exp(-|u / vd|**delta_d)          (Eq. 2.5)

One parameter convention for every path: ``p`` is the vector of :mod:`engine.params`
(``p[P.FC]``, ``p[P.VD]``, ...); the simulate kernels, the averaged integrands and the
harmonic balance all call these. ``delta = 2`` (Sec. 4) and ``delta = 1`` (Sec. 3) take
pow-free paths.

A scene without the Stribeck effect (``fs == fc``) or without bristle damping
(``sigma1_hat == 0``) compiles :func:`make_g` / :func:`make_sigma1`'s constant instead,
so an effect the scene does not call for costs no ``exp``; a scene whose exponents are
known at compile time (``Scene.delta``, ``Scene.delta_d``) compiles only their branch of
:func:`decay`, without the run-time test (the same expression: RK4's bits are unchanged,
DP5's contracted stage sums may differ in the last bits, tests/engine/test_folded_exponents).
"""
from __future__ import annotations

import math

from .. import params as P
from ..jit import njit


@njit(inline="always", error_model="numpy")
def _square(x, delta):
    """exp(-x**2): delta = 2 (Sec. 4), without pow (``delta`` unused)."""
    return math.exp(-x * x)


@njit(inline="always", error_model="numpy")
def _linear(x, delta):
    """exp(-|x|): delta = 1 (Sec. 3), without pow (``delta`` unused)."""
    return math.exp(-abs(x))


@njit(cache=True, error_model="numpy")
def decay(x, delta):
    """exp(-|x|**delta), with the common delta = 2 and 1 without pow."""
    if delta == 2.0:
        return _square(x, delta)
    if delta == 1.0:
        return _linear(x, delta)
    return math.exp(-abs(x) ** delta)


def _curves(dec, **options):
    """``(g, sigma1)``, Eqs. 2.4 and 2.5, over the decay ``dec(x, delta)``."""
    @njit(error_model="numpy", **options)
    def stribeck_curve(u, p):
        """Stribeck curve g(u) (force units), Eq. 2.4."""
        return p[P.FC] + (p[P.FS] - p[P.FC]) * dec(u / p[P.VS], p[P.DELTA])

    @njit(error_model="numpy", **options)
    def bristle_damping(u, p):
        """Bristle damping sigma1(u), Eq. 2.5."""
        return p[P.SIGMA1] * dec(u / p[P.VD], p[P.DELTA_D])

    return stribeck_curve, bristle_damping


g, sigma1 = _curves(decay)                        # the exponents read from p at run time
_FOLDED = {2.0: _curves(_square, inline="always"),   # ... or fixed at compile time
           1.0: _curves(_linear, inline="always")}


@njit(cache=True, error_model="numpy")
def _coulomb_level(u, p):
    return p[P.FC]


@njit(cache=True, error_model="numpy")
def _no_damping(u, p):
    return 0.0


def make_g(stribeck: bool, delta: float | None = None):
    """``g(u, p)``, or the constant ``fc`` when the scene has no Stribeck effect;
    ``delta``: the exponent fixed at compile time (``Scene.delta``: 1 or 2) or None."""
    if not stribeck:
        return _coulomb_level
    return g if delta is None else _FOLDED[delta][0]


def make_sigma1(bristle_damping: bool, delta_d: float | None = None):
    """``sigma1(u, p)``, or 0 when the scene has no bristle damping; ``delta_d``: the
    exponent fixed at compile time (``Scene.delta_d``: 1 or 2) or None."""
    if not bristle_damping:
        return _no_damping
    return sigma1 if delta_d is None else _FOLDED[delta_d][1]
