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
:func:`decay` (the same expression, so the same bits), without the run-time test.
"""
from __future__ import annotations

import numpy as np

from .. import params as P
from ..jit import njit


@njit(cache=True, error_model="numpy")
def decay(x, delta):
    """exp(-|x|**delta), with the common delta = 2 and 1 without pow."""
    if delta == 2.0:
        return np.exp(-x * x)
    if delta == 1.0:
        return np.exp(-abs(x))
    return np.exp(-abs(x) ** delta)


@njit(cache=True, error_model="numpy")
def g(u, p):
    """Stribeck curve g(u) (force units), Eq. 2.4."""
    return p[P.FC] + (p[P.FS] - p[P.FC]) * decay(u / p[P.VS], p[P.DELTA])


@njit(cache=True, error_model="numpy")
def sigma1(u, p):
    """Bristle damping sigma1(u), Eq. 2.5."""
    return p[P.SIGMA1] * decay(u / p[P.VD], p[P.DELTA_D])


@njit(cache=True, error_model="numpy")
def _coulomb_level(u, p):
    return p[P.FC]


@njit(cache=True, error_model="numpy")
def _no_damping(u, p):
    return 0.0


def make_decay(delta: float | None):
    """njit ``decay(x, delta)`` with the exponent folded in when it is 1 or 2 (the
    run-time ``delta`` argument is then ignored); None: :func:`decay` itself."""
    if delta == 2.0:
        @njit(inline="always", error_model="numpy")
        def square(x, delta):
            return np.exp(-x * x)
        return square
    if delta == 1.0:
        @njit(inline="always", error_model="numpy")
        def linear(x, delta):
            return np.exp(-abs(x))
        return linear
    return decay


def make_g(stribeck: bool, delta: float | None = None):
    """``g(u, p)``, or the constant ``fc`` when the scene has no Stribeck effect;
    ``delta``: the exponent fixed at compile time (``Scene.delta``) or None."""
    if not stribeck:
        return _coulomb_level
    if delta is None:
        return g
    dec = make_decay(delta)

    @njit(inline="always", error_model="numpy")
    def g_fixed(u, p):
        return p[P.FC] + (p[P.FS] - p[P.FC]) * dec(u / p[P.VS], 0.0)
    return g_fixed


def make_sigma1(bristle_damping: bool, delta_d: float | None = None):
    """``sigma1(u, p)``, or 0 when the scene has no bristle damping; ``delta_d``: the
    exponent fixed at compile time (``Scene.delta_d``) or None."""
    if not bristle_damping:
        return _no_damping
    if delta_d is None:
        return sigma1
    dec = make_decay(delta_d)

    @njit(inline="always", error_model="numpy")
    def sigma1_fixed(u, p):
        return p[P.SIGMA1] * dec(u / p[P.VD], 0.0)
    return sigma1_fixed
