"""Single-state elasto-plastic friction (Dupont et al.), Eqs. 2.3, 2.6, 2.7.

    dz/dt = u - alpha(z, u) sigma0 |u| z / g(u),     F as in LuGre (engine.friction.lugre)

with z_ss(u) = g(u) / sigma0, z_ba = lam * z_ss(u) and

    alpha = 0                         if sgn(u) != sgn(z) or |z| <= z_ba   (sticking)
    alpha = 1                         if |z| >= z_ss                       (sliding)
    alpha = 0.5 sin(pi (|z| - (z_ss + z_ba)/2) / (z_ss - z_ba)) + 0.5      (pre-sliding)

Eq. 2.7 is printed with z; it is read with |z| so that the law is odd (docs/MODEL.md).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import njit

STICK = 0
PRESLIDE = 1
SLIDE = 2


@njit(cache=True, error_model="numpy")
def alpha(z, u, gu, sigma0, lam):
    """Elasto-plastic function alpha(z, u) in [0, 1], given g(u)."""
    if u == 0.0 or z == 0.0 or (u > 0.0) != (z > 0.0):
        return 0.0
    zss = gu / sigma0
    zba = lam * zss
    az = abs(z)
    if az <= zba:
        return 0.0
    if az >= zss:
        return 1.0
    return 0.5 * math.sin(np.pi * (az - 0.5 * (zss + zba)) / (zss - zba)) + 0.5


@njit(cache=True, error_model="numpy")
def phase(a):
    """STICK (alpha == 0), PRESLIDE (0 < alpha < 1) or SLIDE (alpha == 1)."""
    if a == 0.0:
        return STICK
    if a == 1.0:
        return SLIDE
    return PRESLIDE
