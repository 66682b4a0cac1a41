"""Pointwise integrands of the phase averages of the LuGre slow manifold.

Averaging the LuGre slider over one dither period (Sec. 5.1, Eqs. 5.6-5.10 and
6.4-6.6) leaves phase averages ``<f(u)>`` over the interface velocity
``u = v + W s(theta)`` of four functions of ``u``::

    a(u) = |u| / g(u)                  relaxation (Eq. 5.6b, 5.10, 6.4)
    b(u) = sigma1(u) u                 bristle-damping force at z = 0 (Eq. 5.9)
    c(u) = sigma1(u) |u| / g(u)        bristle damping times relaxation (Eq. 5.9)
    s(u) = g(u) sgn(u)                 static (kinetic) model, Eq. 5.14

and, for the Jacobian of Eqs. 6.4-6.6, their derivatives in ``u`` (the average of a
derivative is the derivative of the average: ``d<f>/dv = <f'>``). ``g`` and
``sigma1`` are the laws of :mod:`engine.friction.stribeck` (Eqs. 2.4, 2.5) on the same
parameter vector ``p`` as the simulate path; only their logarithmic derivatives are new here.

``|u|`` and (for ``delta = 1``) ``g`` have a kink at ``u = 0``: the derivatives use
``sgn(0) = side`` (``+1`` the right derivative, ``-1`` the left one). This matters
only when a quadrature node sits exactly on ``u = 0`` -- the square wave at
``v = +-W`` (DESIGN.md §1: the averaged field is one-sided there).
"""
from __future__ import annotations

from .. import params as P
from ..friction.stribeck import g, sigma1
from ..jit import njit


@njit(cache=True, error_model="numpy")
def sgn(u, side):
    """Sign of ``u`` with ``sgn(0) = side`` (the one-sided choice at the kink)."""
    if u > 0.0:
        return 1.0
    if u < 0.0:
        return -1.0
    return side


@njit(cache=True, error_model="numpy")
def dlog_decay(u, scale, delta, side):
    """d/du log(exp(-|u/scale|**delta)) = -delta |u/scale|**(delta-1) sgn(u) / scale."""
    if delta == 2.0:
        return -2.0 * u / (scale * scale)
    s = sgn(u, side)
    if delta == 1.0:
        return -s / scale
    return -delta * abs(u / scale) ** (delta - 1.0) * s / scale


@njit(cache=True, error_model="numpy")
def dg(u, p, side):
    """Slope g'(u) of the Stribeck curve (Eq. 2.4), force per velocity."""
    return (g(u, p) - p[P.FC]) * dlog_decay(u, p[P.VS], p[P.DELTA], side)


@njit(cache=True, error_model="numpy")
def dsigma1(u, p, side):
    """Slope sigma1'(u) of the bristle damping (Eq. 2.5)."""
    return sigma1(u, p) * dlog_decay(u, p[P.VD], p[P.DELTA_D], side)


@njit(cache=True, error_model="numpy")
def abc(u, p, side):
    """The integrands a, b, c, s and slopes a', b', c', s' at one velocity ``u``.

    Returns
    -------
    tuple of 8 floats
        ``(a, b, c, s, da, db, dc, ds)`` as defined in the module docstring.
        ``ds = g'(u) sgn(u)`` omits the Dirac jump of ``s`` at ``u = 0``.
    """
    gu = g(u, p)
    dgu = dg(u, p, side)
    s1 = sigma1(u, p)
    ds1 = dsigma1(u, p, side)
    su = sgn(u, side)
    au = abs(u)
    a = au / gu
    da = su / gu - au * dgu / (gu * gu)
    # the value of s takes the middle of its jump, sgn(0) = 0 (Eq. 5.14's Sgn)
    return (a, s1 * u, s1 * a, gu * sgn(u, 0.0),
            da, s1 + ds1 * u, ds1 * a + s1 * da, dgu * su)
