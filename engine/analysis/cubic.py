"""Largest real part of the roots of a real cubic, scalar and jitted (the averaged
stability's eigenvalue step, engine.analysis.stability).

For the monic cubic ``P(l) = l**3 + c2 l**2 + c1 l + c0`` -- the characteristic
polynomial of a real 3x3 matrix ``J`` has ``c2 = -trace J``, ``c1`` = the sum of the
principal 2x2 minors, ``c0 = -det J`` -- :func:`max_real_root` returns
``max Re l`` over the three roots:

1. **scale**: a root scale ``m = max(|c2|, |c1|**(1/2), |c0|**(1/3))`` outside
   ``2**(+-256)`` is brought to that edge by a power of two (exact), so that no
   intermediate (at most ``~m**3``) overflows or underflows whatever the input's scale,
   while roots far below the largest keep their exponent range;
2. **one real root** ``x`` in closed form, on the depressed cubic ``t**3 + p t + q`` at
   ``l = t - c2/3``: trigonometric when all three roots are real (the one with ``t`` of
   the sign of ``-c2``, so ``t - c2/3`` cannot cancel: a root of the polynomial's scale);
   otherwise Cardano's ``u + v`` for ``p < 0`` (``u``, ``v`` of one sign) and the
   hyperbolic ``sinh`` form for ``p > 0`` (where ``u + v`` would cancel); ``t = -q**(1/3)``
   when ``|p|`` is negligible. No form has cancellation of its own;
3. **Newton steps on the cubic itself**, kept while ``|P(x)|`` falls: the shift ``c2/3``
   and the rounding of ``p``, ``q`` are undone, a simple root ends at the accuracy the
   coefficients allow;
4. **deflation** to ``l**2 + e1 l + e0``: ``e0 = -c0/x`` (no cancellation) and ``e1`` by the
   more accurate of ``c2 + x`` and ``(e0 - c1)/x`` by their error bounds (forward for a
   small root, backward for a dominant one), as in Flocke, ACM TOMS 41 (2015), Alg. 954;
5. the **quadratic** by the stable formulas: a complex pair's real part ``-e1/2``; real
   roots ``-e1/2 + sqrt(disc)`` for ``e1 <= 0``, else ``e0 / (-e1/2 - sqrt(disc))``.

A simple root comes out to a few ulps of the scale of the polynomial, the conditioning of
the roots on the coefficients; near a double (triple) root that conditioning is
``eps**(1/2)`` (``eps**(1/3)``), for LAPACK as well. Non-finite coefficients give NaN;
``c0 = 0`` gives the zero root exactly. Roots below the largest by more than ~1e-230 lose
their own accuracy (the quadratic underflows), not the ``eps m`` of the scale.

:func:`plus_det2` is ``s + a d - b c`` in twice the working precision (Dekker's exact
products, Knuth's exact sums; Ogita, Rump, Oishi, SIAM J. Sci. Comput. 26 (2005), Dot2):
a coefficient made of cancelling products keeps its relative accuracy.
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import njit

EPS = 2.0 ** -52
#: Veltkamp's splitter 2**27 + 1 for Dekker's exact product.
_SPLIT = 134217729.0
#: Root scales within 2**(+-_RANGE) are solved as given (every intermediate <= m**3 is a
#: normal number); others are scaled to that edge, not to 1, so that the smaller
#: coefficients keep as much of the exponent range as possible.
_RANGE = 256
_HUGE, _TINY = 2.0 ** _RANGE, 2.0 ** -_RANGE
#: Newton steps on the cubic at most (each kept only while |P| falls; 1-2 are used).
MAX_NEWTON = 4


@njit(cache=True, error_model="numpy")
def _two_sum(a, b):
    s = a + b
    z = s - a
    return s, (a - (s - z)) + (b - z)


@njit(cache=True, error_model="numpy")
def _two_prod(a, b):
    p = a * b
    t = _SPLIT * a
    ah = t - (t - a)
    t = _SPLIT * b
    bh = t - (t - b)
    al, bl = a - ah, b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


@njit(cache=True, error_model="numpy")
def plus_det2(s, a, b, c, d):
    """``s + det [[a, b], [c, d]] = s + a d - b c`` as if computed in twice the working
    precision, then rounded (entries below ~1e150: Veltkamp's split must not overflow)."""
    p1, e1 = _two_prod(a, d)
    p2, e2 = _two_prod(b, c)
    q, t = _two_sum(p1, -p2)
    u, w = _two_sum(s, q)
    return u + (w + (t + (e1 - e2)))


@njit(cache=True, error_model="numpy")
def _real_root(c2, c1, c0):
    """A real root of the cubic (root scale within ``2**(+-256)``); when all three are
    real, one of magnitude ``>= max(|c2|/3, (|p|/3)**(1/2))``: a root of the polynomial's
    scale, computed without cancellation, the one to deflate with."""
    h = c2 / 3.0
    p = c1 - c2 * h                    # P'(-h)
    q = c0 + h * (2.0 * h * h - c1)    # P(-h)
    r = abs(p) / 3.0
    sr = math.sqrt(r)
    den = r * sr                       # (|p|/3)**1.5
    if not 0.5 * abs(q) < 1e100 * den:   # p negligible beside q (or both zero)
        return -np.cbrt(q) - h
    x = 0.5 * q / den
    if p > 0.0:
        t = -2.0 * sr * math.sinh(math.asinh(x) / 3.0)
    elif abs(x) <= 1.0:                # three real roots: the largest t for h < 0, the
        phi = math.acos(-x) / 3.0      # smallest for h >= 0, so that t - h cannot cancel
        t = 2.0 * sr * math.cos(phi if h < 0.0 else phi + 2.0 * math.pi / 3.0)
    else:                              # one real root: Cardano, u and v of one sign
        ax = abs(x)
        w = np.cbrt(ax + math.sqrt((ax - 1.0) * (ax + 1.0)))
        t = -math.copysign(sr * (w + 1.0 / w), q)
    return t - h


@njit(cache=True, error_model="numpy")
def _polish(x, c2, c1, c0):
    """Newton on P while |P| falls: near a multiple root it stops at the noise level."""
    f = ((x + c2) * x + c1) * x + c0
    for _ in range(MAX_NEWTON):
        df = (3.0 * x + 2.0 * c2) * x + c1
        if f == 0.0 or df == 0.0:
            break
        y = x - f / df
        g = ((y + c2) * y + c1) * y + c0
        if not abs(g) < abs(f):
            break
        x, f = y, g
    return x


@njit(cache=True, error_model="numpy")
def _deflate(x, c2, c1, c0):
    """``(e1, e0)`` of ``P(l) = (l - x)(l**2 + e1 l + e0)``, the better of two ``e1``."""
    e1 = c2 + x
    if x == 0.0:
        return e1, c1
    e0 = -c0 / x
    ax = abs(x)
    # forward error of x: Horner's rounding of P over |P'(x)|
    size = ((ax + abs(c2)) * ax + abs(c1)) * ax + abs(c0)
    dx = 4.0 * EPS * size / abs((3.0 * x + 2.0 * c2) * x + c1)
    e1b = (e0 - c1) / x
    err_a = EPS * (abs(c2) + ax) + dx
    err_b = (2.0 * EPS * (abs(e0) + abs(c1)) + dx * (abs(e0) / ax + abs(e1b))) / ax
    return (e1b if err_b < err_a else e1), e0


@njit(cache=True, error_model="numpy")
def _max_quadratic(e1, e0):
    """Largest real part of the roots of ``l**2 + e1 l + e0``, no cancellation, and
    whether the roots are real."""
    m = -0.5 * e1
    disc = m * m - e0
    if disc < 0.0:
        return m, False
    s = math.sqrt(disc)
    if m >= 0.0:
        return m + s, True
    return e0 / (m - s), True


@njit(cache=True, error_model="numpy")
def _max_root(c2, c1, c0):
    x = _polish(_real_root(c2, c1, c0), c2, c1, c0)
    e1, e0 = _deflate(x, c2, c1, c0)
    y, real = _max_quadratic(e1, e0)
    return (x, True) if x >= y else (y, real)


@njit(cache=True, error_model="numpy")
def max_root(c2, c1, c0):
    """Largest real part of the roots of ``l**3 + c2 l**2 + c1 l + c0`` (module docstring).

    Parameters
    ----------
    c2, c1, c0 : float
        Coefficients of the monic cubic; for a 3x3 matrix ``-trace``, the sum of the
        principal 2x2 minors and ``-det``.

    Returns
    -------
    re : float
        ``max Re l``; NaN if a coefficient is not finite.
    real : bool
        The root of largest real part is real (False: a complex pair ``re +- i w``).
    """
    if not (math.isfinite(c2) and math.isfinite(c1) and math.isfinite(c0)):
        return np.nan, False
    a2, a1, a0 = abs(c2), abs(c1), abs(c0)
    # the root scale m = max(|c2|, |c1|**(1/2), |c0|**(1/3)) within 2**(+-256): m**3 and
    # every intermediate are normal numbers, scaling (exact) would change nothing
    if (a2 <= _HUGE and a1 <= _HUGE ** 2 and a0 <= _HUGE ** 3
            and (a2 >= _TINY or a1 >= _TINY ** 2 or a0 >= _TINY ** 3)):
        return _max_root(c2, c1, c0)
    m = max(a2, math.sqrt(a1), np.cbrt(a0))
    if m == 0.0:
        return 0.0, True
    e = math.frexp(m)[1]
    k = e - _RANGE if m > 1.0 else e + _RANGE      # m / 2**k just inside 2**(+-256)
    x, real = _max_root(math.ldexp(c2, -k), math.ldexp(c1, -2 * k), math.ldexp(c0, -3 * k))
    return math.ldexp(x, k), real


@njit(cache=True, error_model="numpy")
def max_real_root(c2, c1, c0):
    """``max Re l`` over the roots of ``l**3 + c2 l**2 + c1 l + c0``: :func:`max_root`'s."""
    return max_root(c2, c1, c0)[0]
