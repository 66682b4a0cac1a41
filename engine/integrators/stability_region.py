"""The stability region of an explicit Runge-Kutta step: the ``z = h lambda`` for which the
step applied to ``y' = lambda y`` does not grow, ``|R(z)| <= 1`` (Hairer & Wanner II,
Sec. IV.2). :func:`stability_polynomial` is ``R`` from a Butcher tableau; :func:`reach` how
far the region extends from 0 along a ray. A fixed-step method is safe on a scene when
every ``h lambda`` of the scene's eigenvalues lies inside (the spec-time check of an explicit
fixed step, sweeps.spec.fixed_step). Plain numpy, no compilation.
"""
from __future__ import annotations

import cmath
import math
from functools import lru_cache

import numpy as np


def stability_polynomial(tableau) -> np.ndarray:
    """Coefficients (lowest power first) of ``R(z) = 1 + z b^T (I - z A)^-1 1`` of an
    explicit Runge-Kutta tableau: ``R(z) = sum_k z^k b^T A^(k-1) 1`` (a polynomial, A being
    nilpotent). RK4: 1, 1, 1/2, 1/6, 1/24."""
    a = np.asarray(tableau.a, dtype=float)
    b = np.asarray(tableau.b, dtype=float)
    coeffs, v = [1.0], np.ones(len(b))
    for _ in range(len(b)):
        coeffs.append(float(b @ v))
        v = a @ v
    return np.array(coeffs)


def direction(z: complex) -> float:
    """The angle of ``z``, snapped onto the real and imaginary axes (where RK4's region
    has its boundary on the axis itself, so a rounding error must not leave it)."""
    if abs(z.imag) <= 1e-9 * abs(z):
        return math.pi if z.real < 0 else 0.0
    if abs(z.real) <= 1e-9 * abs(z):
        return math.pi / 2
    return cmath.phase(complex(z.real, abs(z.imag)))   # the region is symmetric in Im


@lru_cache(maxsize=256)
def reach(integrator: str, angle: float) -> float:
    """How far the stability region of ``integrator`` (a name of
    ``engine.integrators.METHODS`` with a Butcher tableau) reaches from 0 along the ray
    ``t e^{i angle}``: the first ``t`` with ``|R| > 1``. RK4: 2.785 at ``angle = pi``
    (negative real axis), ``2 sqrt 2 = 2.828`` at ``pi / 2`` (imaginary axis)."""
    from . import METHODS

    poly = stability_polynomial(METHODS[integrator].TABLEAU)
    ray = cmath.exp(1j * angle)

    def inside(t):
        return np.abs(np.polynomial.polynomial.polyval(t * ray, poly)) <= 1.0 + 1e-9

    t = np.linspace(0.0, 20.0, 20_001)[1:]
    out = np.flatnonzero(~inside(t))
    if out.size == 0:
        return math.inf
    lo, hi = (t[out[0] - 1] if out[0] else 0.0), t[out[0]]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if inside(mid) else (lo, mid)
    return float(lo)
