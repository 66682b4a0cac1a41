"""Stability of the averaged velocity-tracking system, Sec. 6 (Eqs. 6.4-6.7).

State ``x = (Z, e, v)`` (the paper's order); with the phase averages ``A, B, C`` of
engine.analysis.quadrature at the slow velocity ``v``::

    f1 = v - sigma0 A(v) Z                                          (Eq. 6.4)
    f2 = v_ref - v                                                  (Eq. 6.5)
    f3 = e - sigma0 Z - sigma2 v - B(v) + sigma0 C(v) Z             (Eq. 6.6)

(for the square wave ``B = <sigma1(u) u>`` and ``C`` use ``sigma1(v - W)`` in the second
bracket -- DESIGN.md corrects the paper's ``v + W``). Equilibrium (Eq. 6.7):
``v0 = v_ref``, ``Z0 = v_ref / (sigma0 A(v_ref))``, ``e0 = <F>(v_ref)`` (the paper's
``e0 = sigma0 Z0`` drops ``B``, ``C`` and ``sigma2`` terms; the Jacobian does not
involve ``e0``). Analytic Jacobian at the equilibrium::

    [[-sigma0 A,        0, 1 - sigma0 Z0 A'              ],
     [ 0,               0, -1                            ],
     [-sigma0 (1 - C),  1, -sigma2 - B' + sigma0 Z0 C'   ]]

Its characteristic polynomial is ``l**3 - (a + d) l**2 + (1 + a d - b c) l - a`` with
``a = J00, b = J02, c = J20, d = J22`` (also used by the Routh-Hurwitz cross-check in the
tests). Stable when every eigenvalue has a negative real part. The largest real part
``lam`` comes from that polynomial, in the kernel pass that makes the Jacobians (:func:`jacobian_max_real_eig`, engine.analysis.cubic: closed form,
Newton, stable deflation): as accurate as LAPACK's eigenvalues and ten times faster than
``np.linalg.eigvals`` (tests/analysis/test_analysis_cubic.py).

The square-wave field has a kink at ``W = |v_ref|`` (a point at ``u = 0``); there the
Jacobian is one-sided: ``side = +1`` (default) is the right derivative in ``v``
(``v -> v_ref+``), ``side = -1`` the left one. The sine rule is smooth there.

The averaged model is the ``omega -> infinity`` limit: omega does not enter.
"""
from __future__ import annotations

import math

import numpy as np

from .. import params as P
from ..jit import njit
from .cubic import MAX_NEWTON, max_root, plus_det2
from .effective import LUGRE, force_and_slope
from .quadrature import DA, DB, DC, N_AVG, N_QUAD, A, B, C, point_averages


@njit(cache=True, error_model="numpy")
def _entries(avg, v, sigma0, sigma2):
    """``(a, b, c, d) = (J00, J02, J20, J22)``, the entries that vary."""
    Z0 = v / (sigma0 * avg[A])
    return (-sigma0 * avg[A], 1.0 - sigma0 * Z0 * avg[DA],
            -sigma0 * (1.0 - avg[C]), -sigma2 - avg[DB] + sigma0 * Z0 * avg[DC])


@njit(cache=True, error_model="numpy")
def _fill_jacobian(J, a, b, c, d):
    J[0, 0], J[0, 1], J[0, 2] = a, 0.0, b
    J[1, 0], J[1, 1], J[1, 2] = 0.0, 0.0, -1.0
    J[2, 0], J[2, 1], J[2, 2] = c, 1.0, d


#: Entries up to 2**_BIG: products, Veltkamp's split (plus_det2) and the determinant
#: ``~lam**3`` (_det_polish) stay finite.
_BIG = 256


@njit(cache=True, error_model="numpy")
def _det_polish(lam, a, bc, d, one):
    """Newton on ``det(lam I - J) = (lam - a)(lam (lam - d) + 1) - b c lam`` while it
    falls (``one``: that 1 in the units of a scaled ``J``).

    Evaluated in this form the determinant keeps the accuracy a nearly triangular ``J``
    (``b c`` small) gives its real eigenvalues, which the expanded polynomial loses when
    ``a ~ d`` (a near-double root of the polynomial, not of the matrix).
    """
    f = (lam - a) * (lam * (lam - d) + one) - bc * lam
    for _ in range(MAX_NEWTON):
        df = (lam * (lam - d) + one) + (lam - a) * (2.0 * lam - d) - bc
        if f == 0.0 or df == 0.0:
            break
        y = lam - f / df
        g = (y - a) * (y * (y - d) + one) - bc * y
        if not abs(g) < abs(f):
            break
        lam, f = y, g
    return lam


@njit(cache=True, error_model="numpy")
def jacobian_max_real_eig(a, b, c, d):
    """Largest real part of the eigenvalues of ``[[a, 0, b], [0, 0, -1], [c, 1, d]]``.

    The roots of its characteristic polynomial (module docstring) by
    :func:`engine.analysis.cubic.max_root`, with ``1 + a d - b c`` in twice the working
    precision; a real largest root then gets Newton steps on the determinant
    (:func:`_det_polish`). Entries above ``2**256`` are balanced (``b``, ``c``) and scaled
    to it by powers of two (exact: ``b c`` and the eigenvalues over the scale unchanged),
    so no product overflows and any finite entries give a finite answer. NaN or inf in
    -> NaN.
    """
    if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(c) and math.isfinite(d)):
        return np.nan
    k, one = 0, 1.0
    if max(abs(a), abs(b), abs(c), abs(d)) > 2.0 ** _BIG:
        j = (math.frexp(c)[1] - math.frexp(b)[1]) // 2
        m = max(abs(a), abs(d), math.sqrt(abs(b)) * math.sqrt(abs(c)))
        k = max(math.frexp(m)[1] - _BIG, 0)
        a, d = math.ldexp(a, -k), math.ldexp(d, -k)
        b, c = math.ldexp(b, j - k), math.ldexp(c, -j - k)
        one = math.ldexp(1.0, -2 * k)  # the 1 of the minor [[0, -1], [1, d]], scaled
    lam, real = max_root(-(a + d), plus_det2(one, a, b, c, d), -one * a)
    if real:
        lam = _det_polish(lam, a, b * c, d, one)
    return math.ldexp(lam, k)


@njit(cache=True, error_model="numpy", entry=True)
def _linearise(avg, v, sigma0, sigma2, J, F, lam):
    for i in range(v.size):
        a, b, c, d = _entries(avg[i], v[i], sigma0, sigma2)
        _fill_jacobian(J[i], a, b, c, d)
        F[i] = force_and_slope(avg[i], v[i], sigma2, LUGRE)[0]
        lam[i] = jacobian_max_real_eig(a, b, c, d)


@njit(cache=True, error_model="numpy", entry=True)
def _structured_max_real_eig(a, b, c, d, out):
    for i in range(out.size):
        out[i] = jacobian_max_real_eig(a[i], b[i], c[i], d[i])


def linearisation(v_ref, W, p, *, dither="square-velocity", vd=None, n_quad=N_QUAD, side=1.0):
    """Jacobian, effective friction and largest real eigenvalue part in one kernel pass.

    Parameters and the first two results as :func:`jacobian`; the third, ``lam`` (shape
    ``s``), is ``max_real_eig(J)`` (:func:`jacobian_max_real_eig`, NaN where J is not
    finite).
    """
    shape, v, avg = point_averages(v_ref, W, p, dither=dither, vd=vd, n_quad=n_quad,
                                   side=side)
    J, F, lam = np.empty((v.size, 3, 3)), np.empty(v.size), np.empty(v.size)
    _linearise(avg, v, float(p[P.SIGMA0]), float(p[P.SIGMA2]), J, F, lam)
    return J.reshape(shape + (3, 3)), F.reshape(shape), lam.reshape(shape)


def jacobian(v_ref, W, p, *, dither="square-velocity", vd=None, n_quad=N_QUAD, side=1.0):
    """Analytic Jacobian of Eqs. 6.4-6.6 at the equilibrium Eq. 6.7, vectorised.

    Parameters
    ----------
    v_ref, W, vd : array_like
        Drive velocity, dither velocity amplitude, bristle-damping velocity (default
        ``p[VD]``); broadcast together to a shape ``s``.
    p : (N_PARAMS,) ndarray
        Parameter vector (engine.params).
    dither, n_quad, side
        As in :func:`engine.analysis.effective.effective_friction`.

    Returns
    -------
    J : (*s, 3, 3) ndarray
        d(f1, f2, f3)/d(Z, e, v).
    F_eff : s ndarray
        Effective friction ``<F>(v_ref)`` (Eq. 5.9), which is also ``e0``.
    """
    return linearisation(v_ref, W, p, dither=dither, vd=vd, n_quad=n_quad, side=side)[:2]


def max_real_eig(J):
    """Largest real part of the eigenvalues of each 3x3 matrix in ``J``, shape ``(..., 3, 3)``.

    A matrix with the averaged Jacobian's fixed entries (``J01 = J10 = J11 = 0``,
    ``J12 = -1``, ``J21 = 1``) goes through :func:`jacobian_max_real_eig`, the numbers of
    the averaged path, any other through LAPACK (``np.linalg.eigvals``): for a general
    matrix the characteristic polynomial can be worse conditioned than its eigenvalues.
    A matrix with a NaN or inf entry gives NaN.
    """
    J = np.asarray(J, dtype=np.float64)
    flat = J.reshape(-1, 3, 3)
    out = np.full(flat.shape[0], np.nan)
    fixed = ((flat[:, 0, 1] == 0) & (flat[:, 1, 0] == 0) & (flat[:, 1, 1] == 0)
             & (flat[:, 1, 2] == -1) & (flat[:, 2, 1] == 1))
    if fixed.any():
        a, b, c, d = (np.ascontiguousarray(flat[fixed, i, j])
                      for i, j in ((0, 0), (0, 2), (2, 0), (2, 2)))
        lam = np.empty(a.size)
        _structured_max_real_eig(a, b, c, d, lam)
        out[fixed] = lam
    other = ~fixed & np.isfinite(flat).all(axis=(1, 2))
    if other.any():
        out[other] = np.linalg.eigvals(flat[other]).real.max(axis=-1)
    return out.reshape(J.shape[:-2])


def equilibrium(v_ref, W, p, *, dither="square-velocity", vd=None, n_quad=N_QUAD):
    """Equilibrium ``(Z0, e0, v0)`` of Eqs. 6.4-6.6 (Eq. 6.7 with the full ``e0``)."""
    from .effective import effective_friction
    v_ref = np.asarray(v_ref, float)
    A_ = averages(v_ref, W, p, dither=dither, vd=vd, n_quad=n_quad)[..., A]
    Z0 = v_ref / (p[P.SIGMA0] * A_)
    e0 = effective_friction(v_ref, W, p, dither=dither, vd=vd, n_quad=n_quad)
    return Z0, e0, np.broadcast_to(v_ref, np.shape(Z0)).copy()


def averages(v, W, p, *, dither="square-velocity", vd=None, n_quad=N_QUAD, side=1.0):
    """Phase averages ``(A, B, C, S, A', B', C', S')`` at ``(v, W)``, shape ``(*s, 8)``."""
    shape, _, avg = point_averages(v, W, p, dither=dither, vd=vd, n_quad=n_quad, side=side)
    return avg.reshape(shape + (N_AVG,))


def averaged_rhs(x, v_ref, W, p, *, dither="square-velocity", vd=None, n_quad=N_QUAD):
    """Right-hand side ``(f1, f2, f3)`` of Eqs. 6.4-6.6 at one state ``x = (Z, e, v)``."""
    Z, e, v = (float(c) for c in x)
    a = averages(v, W, p, dither=dither, vd=vd, n_quad=n_quad)
    s0, s2 = p[P.SIGMA0], p[P.SIGMA2]
    return np.array([v - s0 * a[A] * Z, v_ref - v,
                     e - s0 * Z - s2 * v - a[B] + s0 * a[C] * Z])


def static_max_real_eig(slope):
    """Largest real eigenvalue part of the averaged tracking system with a static law.

    With a memoryless effective friction (Eq. 5.14) the state is ``(e, v)`` and
    ``J = [[0, -1], [1, -F']]``: the roots of ``l**2 + F' l + 1``.
    """
    s = np.asarray(slope, float)
    disc = s * s - 4.0
    root = np.sqrt(np.where(disc > 0, disc, 0.0))
    return np.where(disc > 0, 0.5 * (-s + root), -0.5 * s)
