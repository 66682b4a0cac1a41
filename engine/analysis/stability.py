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
``a = J00, b = J02, c = J20, d = J22`` (used by the Routh-Hurwitz cross-check in the
tests). Stable when every eigenvalue has a negative real part.

The square-wave field has a kink at ``W = |v_ref|`` (a point at ``u = 0``); there the
Jacobian is one-sided: ``side = +1`` (default) is the right derivative in ``v``
(``v -> v_ref+``), ``side = -1`` the left one. The sine rule is smooth there.

The averaged model is the ``omega -> infinity`` limit: omega does not enter.
"""
from __future__ import annotations

import numpy as np

from .. import params as P
from ..jit import njit
from .effective import LUGRE, force_and_slope
from .quadrature import DA, DB, DC, N_AVG, N_QUAD, A, B, C, point_averages


@njit(cache=True, error_model="numpy")
def _fill_jacobian(J, avg, v, sigma0, sigma2):
    Z0 = v / (sigma0 * avg[A])
    J[0, 0] = -sigma0 * avg[A]
    J[0, 1] = 0.0
    J[0, 2] = 1.0 - sigma0 * Z0 * avg[DA]
    J[1, 0] = 0.0
    J[1, 1] = 0.0
    J[1, 2] = -1.0
    J[2, 0] = -sigma0 * (1.0 - avg[C])
    J[2, 1] = 1.0
    J[2, 2] = -sigma2 - avg[DB] + sigma0 * Z0 * avg[DC]


@njit(cache=True, error_model="numpy")
def _jacobians(avg, v, sigma0, sigma2, J, F):
    for i in range(v.size):
        _fill_jacobian(J[i], avg[i], v[i], sigma0, sigma2)
        F[i] = force_and_slope(avg[i], v[i], sigma2, LUGRE)[0]


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
    shape, v, avg = point_averages(v_ref, W, p, dither=dither, vd=vd, n_quad=n_quad,
                                   side=side)
    J, F = np.empty((v.size, 3, 3)), np.empty(v.size)
    _jacobians(avg, v, float(p[P.SIGMA0]), float(p[P.SIGMA2]), J, F)
    return J.reshape(shape + (3, 3)), F.reshape(shape)


def max_real_eig(J):
    """Largest real part of the eigenvalues of each 3x3 matrix in ``J`` (NaN rows -> NaN)."""
    J = np.asarray(J)
    flat = J.reshape(-1, 3, 3)
    out = np.full(flat.shape[0], np.nan)
    ok = np.isfinite(flat).all(axis=(1, 2))
    if ok.any():
        out[ok] = np.linalg.eigvals(flat[ok]).real.max(axis=-1)
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
