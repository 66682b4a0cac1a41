"""Stribeck curve and velocity-dependent bristle damping.

    g(u)      = fc + (fs - fc) * exp(-|u / vs|**delta)        (Eq. 2.4)
    sigma1(u) = sigma1_hat * exp(-|u / vd|**delta_d)          (Eq. 2.5)

and the static (kinetic) friction model of Eq. 2.2 while sliding,
``F = g(u) sgn(u) + sigma2 u``. ``delta = 2`` (Sec. 4) takes a pow-free path.
"""
from __future__ import annotations

import numpy as np

from ..jit import njit


@njit(cache=True)
def _decay(x, delta):
    """exp(-|x|**delta), with the common delta = 2 and 1 without pow."""
    if delta == 2.0:
        return np.exp(-x * x)
    if delta == 1.0:
        return np.exp(-abs(x))
    return np.exp(-abs(x) ** delta)


@njit(cache=True)
def g(u, fc, fs, vs, delta):
    """Stribeck curve g(u) (force units), Eq. 2.4."""
    return fc + (fs - fc) * _decay(u / vs, delta)


@njit(cache=True)
def sigma1(u, sigma1_hat, vd, delta_d):
    """Bristle damping sigma1(u), Eq. 2.5."""
    return sigma1_hat * _decay(u / vd, delta_d)


@njit(cache=True)
def static_force(u, fc, fs, vs, delta, sigma2):
    """Sliding branch of the static model, Eq. 2.2: g(u) sgn(u) + sigma2 u."""
    return g(u, fc, fs, vs, delta) * np.sign(u) + sigma2 * u
