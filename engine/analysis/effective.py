"""Effective (dither-averaged) friction ``<F>(v)`` of the slider, Sec. 5.

With the phase averages ``A = <|u|/g>``, ``B = <sigma1(u) u>``, ``C = <sigma1(u)|u|/g>``,
``S = <g(u) sgn(u)>`` over ``u = v + W s(theta)`` (engine.analysis.quadrature):

* ``lugre``: the LuGre slow manifold ``Y = sigma0 Z_s = v / A`` (Eq. 5.10) in
  ``<F> = Y (1 - C) + B + sigma2 v`` (Eq. 5.9);
* ``no-damping``: bristle damping dropped, ``<F> = Y + sigma2 v`` (Eq. 5.12);
* ``static``: the kinetic model of Eq. 2.2, ``<F> = S + sigma2 v`` (Eq. 5.14).

For the square wave the averages are the paper's two-point expressions; for a sine
(sine velocity, or the sine force of Sec. 5.2 whose velocity fluctuation has amplitude
``a Omega = W``) they come from the converged quadrature. The slope ``d<F>/dv`` is exact
(averages of the integrands' derivatives), e.g. ``Y' = (A - v A') / A**2``.

The slow manifold does not depend on sigma0 (it is the sigma0 -> infinity limit,
Eq. 5.7b with epsilon = 0). ``<F>`` is undefined (NaN) at ``v = W = 0``.

The closed form of the simplified sine-force model (no Stribeck, no bristle damping),
Eq. 5.20 with DESIGN.md's corrections, is :func:`sine_force_simplified`.
"""
from __future__ import annotations

import numpy as np

from .. import params as P
from ..jit import njit
from .quadrature import DA, DB, DC, DS, N_QUAD, A, B, C, S, point_averages

LUGRE, NO_DAMPING, STATIC = 0, 1, 2
MODELS = {"lugre": LUGRE, "no-damping": NO_DAMPING, "static": STATIC}


def model_code(model: str) -> int:
    """Integer code of an effective-friction model name."""
    try:
        return MODELS[model]
    except KeyError:
        raise ValueError(f"model must be one of {tuple(MODELS)}, got {model!r}") from None


@njit(cache=True, error_model="numpy")
def force_and_slope(avg, v, sigma2, model):
    """``<F>`` and ``d<F>/dv`` at slow velocity ``v`` from the phase averages ``avg``."""
    if model == STATIC:
        return avg[S] + sigma2 * v, avg[DS] + sigma2
    Y = v / avg[A]                                   # Eq. 5.10, generalised
    dY = (avg[A] - v * avg[DA]) / (avg[A] * avg[A])
    if model == NO_DAMPING:
        return Y + sigma2 * v, dY + sigma2           # Eq. 5.12
    F = Y * (1.0 - avg[C]) + avg[B] + sigma2 * v    # Eq. 5.9
    return F, dY * (1.0 - avg[C]) - Y * avg[DC] + avg[DB] + sigma2


@njit(cache=True, error_model="numpy", entry=True)
def _forces(avg, v, sigma2, model, F, dF):
    for i in range(v.size):
        F[i], dF[i] = force_and_slope(avg[i], v[i], sigma2, model)


def effective_friction(v, W, p, *, dither="square-velocity", model="lugre", vd=None,
                       n_quad=N_QUAD, side=1.0, slope=False):
    """Effective friction ``<F>(v)`` (Eqs. 5.9-5.10, 5.12, 5.14), vectorised.

    Parameters
    ----------
    v, W : array_like
        Slow sliding velocity and dither velocity amplitude (non-dimensional);
        broadcast against each other (and ``vd``).
    p : (N_PARAMS,) ndarray
        Parameter vector (engine.params); ``p[W]``, ``p[V_REF]`` are not used.
    dither : str
        ``square-velocity`` (exact 2-point average), ``sine-velocity`` or
        ``sine-force`` (Gauss-Legendre quadrature, ``n_quad`` points per smooth piece).
        ``none`` is the square rule with W = 0.
    model : str
        ``lugre`` (Eq. 5.9), ``no-damping`` (Eq. 5.12) or ``static`` (Eq. 5.14).
    vd : array_like, optional
        Bristle-damping velocity, default ``p[VD]``.
    side : float
        sgn(0) in slopes at a kink (``+1`` right, ``-1`` left derivative).
    slope : bool
        Also return ``d<F>/dv``.

    Returns
    -------
    F : ndarray, broadcast shape of (v, W, vd); ``(F, dFdv)`` if ``slope``.
    """
    code = model_code(model)
    shape, v, avg = point_averages(v, W, p, dither=dither, vd=vd, n_quad=n_quad, side=side)
    F, dF = np.empty(v.size), np.empty(v.size)
    _forces(avg, v, float(p[P.SIGMA2]), code, F, dF)
    F, dF = F.reshape(shape), dF.reshape(shape)
    return (F, dF) if slope else F


def sine_force_simplified(v, W, fc, sigma2):
    """Eq. 5.20 (corrected): sine-force dither, no Stribeck, no bristle damping.

    ``<F> = pi fc v / (2 W sin(theta1) + v (pi - 2 theta1)) + sigma2 v`` with
    ``theta1 = arccos(v / W)`` for ``|v| <= W`` (Eq. 5.19a with its missing ``1/pi``
    restored), and ``fc sgn(v) + sigma2 v`` for ``|v| > W`` (the printed ``fs`` would
    jump by ``fs - fc`` at ``|v| = W``). ``W = a Omega`` is the velocity amplitude.
    """
    v, W = np.broadcast_arrays(np.asarray(v, float), np.asarray(W, float))
    inner = np.abs(v) <= W
    th = np.arccos(np.clip(v / np.where(W > 0, W, 1.0), -1.0, 1.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        Y = np.where(inner, np.pi * fc * v / (2 * W * np.sin(th) + v * (np.pi - 2 * th)),
                     fc * np.sign(v))
    return Y + sigma2 * v


def negative_slope_zones(v, dFdv):
    """Maximal intervals of the grid ``v`` (ascending) on which ``dFdv < 0``.

    Returns a list of ``(v_first, v_last)`` grid values; the true edges lie within one
    grid step outside them.
    """
    neg = np.asarray(dFdv) < 0
    edges = np.flatnonzero(np.diff(np.r_[0, neg.astype(np.int8), 0]))
    return [(float(v[i]), float(v[j - 1])) for i, j in zip(edges[::2], edges[1::2])]
