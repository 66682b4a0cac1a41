"""LuGre friction (Eq. 2.3; alpha = 1) and the bristle law it shares with elasto-plastic.

    dz/dt = u - alpha sigma0 |u| z / g(u)
    F     = sigma0 z + sigma1(u) dz/dt + sigma2 u

LuGre is ``alpha = 1``; :mod:`engine.friction.elastoplastic` supplies ``alpha(z, u)``.
For frozen ``u`` the LuGre z equation is linear, ``dz = u - k z`` with rate
``k = sigma0 |u| / g(u)`` (:func:`rate`), relaxing to ``z_ss(u) = g(u) sgn(u) / sigma0``.
"""
from __future__ import annotations

from .. import params as P
from ..jit import njit


@njit(cache=True, error_model="numpy")
def dz(u, z, gu, sigma0, alpha):
    """Bristle rate dz/dt (Eq. 2.3) for interface velocity u, given g(u) and alpha."""
    return u - alpha * sigma0 * abs(u) * z / gu


def make_force(bristle_damping: bool, viscous: bool):
    """njit ``force(z, dz, u, s1, p)``: F = sigma0 z [+ sigma1(u) dz] [+ sigma2 u], the
    bracketed terms compiled only when the scene has them (``s1`` = sigma1(u))."""
    @njit(inline="always", error_model="numpy")
    def force(z, dz_, u, s1, p):
        F = p[P.SIGMA0] * z
        if bristle_damping:
            F += s1 * dz_
        if viscous:
            F += p[P.SIGMA2] * u
        return F
    return force
