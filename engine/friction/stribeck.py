"""Stribeck curve and velocity-dependent bristle damping, on the parameter vector ``p``.

    g(u)      = fc + (fs - fc) * exp(-|u / vs|**delta)        (Eq. 2.4)
    sigma1(u) = sigma1_hat * exp(-|u / vd|**delta_d)          (Eq. 2.5)

One parameter convention for every path: ``p`` is the vector of :mod:`engine.params`
(``p[P.FC]``, ``p[P.VD]``, ...); the simulate kernels, the averaged integrands and the
harmonic balance all call these. ``delta = 2`` (Sec. 4) takes a pow-free path.

A scene without the Stribeck effect (``fs == fc``) or without bristle damping
(``sigma1_hat == 0``) compiles :func:`make_g` / :func:`make_sigma1`'s constant instead,
so an effect the scene does not call for costs no ``exp``.
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


def make_g(stribeck: bool):
    """``g(u, p)``, or the constant ``fc`` when the scene has no Stribeck effect."""
    return g if stribeck else _coulomb_level


def make_sigma1(bristle_damping: bool):
    """``sigma1(u, p)``, or 0 when the scene has no bristle damping."""
    return sigma1 if bristle_damping else _no_damping
