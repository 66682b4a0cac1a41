"""Phase average ``<.>`` over one dither period (Eq. 5.3 / 5.17).

For a velocity dither ``u = v + W s(theta)`` with ``theta`` uniform over a period:

* **square** (``s = sq``, Sec. 5.1): ``<f> = (f(v + W) + f(v - W)) / 2`` -- exact,
  two points (Eqs. 5.6b, 5.9);
* **sine** (``s = sin``, Sec. 7; also the sine *force* of Sec. 5.2, whose velocity
  fluctuation is ``phi1' = -a Omega cos(Omega tau)`` with ``a Omega = W``):
  ``<f> = (1/pi) int_0^pi f(v + W cos phi) dphi``. The integrands have a kink at
  ``u = 0`` (``|u|``), i.e. at ``phi0 = arccos(-v/W)`` when ``|v| < W``; the interval
  is split there and each smooth piece gets an ``n``-point Gauss-Legendre rule, so the
  error falls faster than any power of ``n`` (tests/analysis/test_analysis_quadrature.py,
  scripts/bench_analysis.py). The features of g and sigma1 (widths vs, vd) sit next to the
  kink, so the ``n`` needed grows like ``sqrt(W / min(vs, vd))``: measured max error of
  ``<F>`` with the default ``n`` = :data:`N_QUAD` = 64 is < 1e-12 for W <= 1, vd = 0.1;
  7e-9 for W = 1, vd = 0.01; 1.7e-6 for W = 3, vd = 0.01 (n = 128: 3e-10).

The kernel accumulates the averages of all integrands of
:func:`engine.analysis.integrands.abc` in one pass.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .. import params as P
from ..jit import njit
from .integrands import abc

SQUARE = 0
SINE = 1
#: Rule per dither kind. ``none`` is the square rule with W = 0 (both points at v).
RULES = {"none": SQUARE, "square-velocity": SQUARE, "sine-velocity": SINE, "sine-force": SINE}
#: Gauss-Legendre points per smooth piece of the sine rule (see the module docstring).
N_QUAD = 64
#: Number of averaged integrands returned by :func:`phase_average` (a, b, c, s and slopes).
N_AVG = 8
A, B, C, S, DA, DB, DC, DS = range(N_AVG)


def rule_code(dither: str) -> int:
    """Quadrature rule for a dither kind (engine.dither.KINDS)."""
    try:
        return RULES[dither]
    except KeyError:
        raise ValueError(f"dither must be one of {tuple(RULES)}, got {dither!r}") from None


@lru_cache(maxsize=16)
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [-1, 1] (``n >= 1`` points; cached, read-only)."""
    if n < 1:
        raise ValueError(f"n_quad must be >= 1, got {n}")
    x, w = np.polynomial.legendre.leggauss(int(n))
    x.flags.writeable = False
    w.flags.writeable = False
    return x, w


@njit(cache=True, error_model="numpy")
def _add(out, u, w, p, side):
    r = abc(u, p, side)
    for i in range(8):
        out[i] += w * r[i]


@njit(cache=True, error_model="numpy")
def _add_piece(out, v, W, lo, hi, x, wx, p, side):
    """Add (1/pi) int_lo^hi f(v + W cos phi) dphi by Gauss-Legendre."""
    half = 0.5 * (hi - lo)
    mid = 0.5 * (hi + lo)
    for k in range(x.size):
        _add(out, v + W * np.cos(mid + half * x[k]), half * wx[k] / np.pi, p, side)


@njit(cache=True, error_model="numpy")
def phase_average(out, v, W, rule, x, wx, p, side):
    """Write the phase averages of a, b, c, s, a', b', c', s' into ``out[:8]``.

    Parameters
    ----------
    out : (8,) float64
        Output, indexed by :data:`A`, :data:`B`, ... :data:`DS`.
    v, W : float
        Slow velocity and dither velocity amplitude (the sign of W is irrelevant).
    rule : int
        :data:`SQUARE` or :data:`SINE`.
    x, wx : (n,) float64
        Gauss-Legendre nodes/weights on [-1, 1] (sine rule only).
    p : (N_PARAMS,) float64
        The parameter vector (engine.params); the laws read fc, fs, vs, delta, sigma1,
        vd, delta_d from it.
    side : float
        sgn(0) for slopes at a kink, +1 or -1 (integrands module).
    """
    out[:] = 0.0
    Wa = abs(W)
    if rule == SQUARE:
        _add(out, v + Wa, 0.5, p, side)
        _add(out, v - Wa, 0.5, p, side)
    elif Wa > abs(v):
        phi0 = np.arccos(-v / Wa)  # u(phi0) = 0: the kink of |u|
        _add_piece(out, v, Wa, 0.0, phi0, x, wx, p, side)
        _add_piece(out, v, Wa, phi0, np.pi, x, wx, p, side)
    else:
        _add_piece(out, v, Wa, 0.0, np.pi, x, wx, p, side)


@njit(cache=True, error_model="numpy", entry=True)
def _averages_kernel(v, W, vd, p, rule, x, wx, side, out):
    pv = p.copy()   # the point's parameters: vd varies along the grid
    for i in range(v.size):
        pv[P.VD] = vd[i]
        phase_average(out[i], v[i], W[i], rule, x, wx, pv, side)


def point_averages(v, W, p, *, dither="square-velocity", vd=None, n_quad=N_QUAD, side=1.0):
    """The phase averages at every point of ``(v, W, vd)`` broadcast together (``vd``
    default ``p[VD]``): ``(shape, v, avg)`` with ``v`` the flat slow velocities and ``avg``
    their ``(n, 8)`` averages, indexed by :data:`A` ... :data:`DS`. The one loop over points
    of the averaged path (effective friction, Jacobians, averages)."""
    b = np.broadcast_arrays(*[np.asarray(a, float)
                              for a in (v, W, p[P.VD] if vd is None else vd)])
    v, w, d = (np.ascontiguousarray(a).ravel() for a in b)
    x, wx = gauss_legendre(n_quad)
    avg = np.empty((v.size, N_AVG))
    _averages_kernel(v, w, d, np.array(p, dtype=np.float64), rule_code(dither), x, wx,
                     float(side), avg)
    return b[0].shape, v, avg
