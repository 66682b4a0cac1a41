"""LuGre friction (Eq. 2.3 with alpha = 1).

    dz/dt = u - sigma0 |u| z / g(u)
    F     = sigma0 z + sigma1(u) dz/dt + sigma2 u

For frozen ``u`` the z equation is linear, ``dz = u - k z`` with rate
``k = sigma0 |u| / g(u)``, relaxing to ``z_ss(u) = g(u) sgn(u) / sigma0``:
``z(t) = z_ss + (z0 - z_ss) exp(-k t)`` (used by tests and stiff updates).
"""
from __future__ import annotations

import numpy as np

from ..jit import njit
from .stribeck import g


@njit(cache=True)
def rate(u, gu, sigma0):
    """Relaxation rate k = sigma0 |u| / g(u) of the bristle state (1/time)."""
    return sigma0 * abs(u) / gu


@njit(cache=True)
def dz(u, z, gu, sigma0):
    """LuGre bristle rate dz/dt for interface velocity u, given g(u)."""
    return u - sigma0 * abs(u) * z / gu


@njit(cache=True)
def force(z, dz_, u, sigma0, sigma1_u, sigma2):
    """Friction force F = sigma0 z + sigma1(u) dz + sigma2 u."""
    return sigma0 * z + sigma1_u * dz_ + sigma2 * u


@njit(cache=True)
def steady_state(u, fc, fs, vs, delta, sigma0):
    """Steady bristle deflection z_ss(u) = g(u) sgn(u) / sigma0."""
    return g(u, fc, fs, vs, delta) * np.sign(u) / sigma0


@njit(cache=True)
def relax(z0, u, t, fc, fs, vs, delta, sigma0):
    """Closed-form z(t) at constant velocity u from z(0) = z0."""
    gu = g(u, fc, fs, vs, delta)
    zss = gu * np.sign(u) / sigma0
    return zss + (z0 - zss) * np.exp(-rate(u, gu, sigma0) * t)
