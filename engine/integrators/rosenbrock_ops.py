"""njit building blocks of the Rosenbrock steppers (engine.integrators.rodas4).

- :func:`invert`: explicit inverse of the small matrix ``I / (h gamma) - J``;
- :func:`make_fd_jacobian`, :func:`make_time_derivative`: ``df/dy`` and ``df/dt`` by finite
  differences of the problem's right-hand side (the method protocol gives no Jacobian);
  :func:`make_time_probe` tells whether ``df/dt`` is needed at all;
- :func:`step_divisor`, :func:`accept_divisor`: the step-size controller of Hairer's
  ``rodas.f`` (``h_new = h / fac``, ``fac`` in ``[1/6, 5]``, safety 0.9, Gustafsson's
  predictive correction after accepted steps; error exponent 1/4 for the order-3 estimate).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from .events import sign_change

SAFETY, FAC_LO, FAC_HI = 0.9, 1.0 / 6.0, 5.0   # h_new = h / fac, fac in [FAC_LO, FAC_HI]


@njit(error_model="numpy", refcount=False)
def invert(M, Minv):
    """``Minv = M^-1`` by Gauss-Jordan elimination with partial pivoting (``M`` is destroyed).

    For the small dense matrices of a Rosenbrock step (n <= 5) one explicit inverse per
    attempt makes each of the ``s`` stage solves a matrix-vector product without a
    dependency chain (measured 3x faster than LU forward/back substitution for n = 3).
    Returns False when ``M`` is singular (a zero pivot).
    """
    n = M.shape[0]
    for i in range(n):
        for j in range(n):
            Minv[i, j] = 1.0 if i == j else 0.0
    for k in range(n):
        pk, big = k, abs(M[k, k])
        for i in range(k + 1, n):
            if abs(M[i, k]) > big:
                pk, big = i, abs(M[i, k])
        if big == 0.0:
            return False
        if pk != k:
            for j in range(n):
                M[k, j], M[pk, j] = M[pk, j], M[k, j]
                Minv[k, j], Minv[pk, j] = Minv[pk, j], Minv[k, j]
        d = 1.0 / M[k, k]
        for j in range(n):
            M[k, j] *= d
            Minv[k, j] *= d
        for i in range(n):
            f = M[i, k]
            if i != k and f != 0.0:
                for j in range(n):
                    M[i, j] -= f * M[k, j]
                    Minv[i, j] -= f * Minv[k, j]
    return True


SQRT_EPS = float(np.sqrt(np.finfo(float).eps))


def make_fd_jacobian(n, n_err, rhs, n_events, events):
    """njit ``jac(t, y, f0, p, sq, J, yt, ft, atol, rtol, g0, g1)``: one-sided differences
    ``J = df/dy``.

    Columns ``j < n_err`` with increment ``sqrt(eps) (|y_j| + atol_j / rtol)`` (the
    magnitude below which ``y_j`` is negligible; 1 when rtol is 0); the other columns (quadrature
    states, which nothing depends on) are zero. ``f0 = f(t, y)``; ``n_err`` evaluations.
    The increment goes *away* from a kink or discontinuity of ``f`` (a sign change of an
    event function, ``g0``/``g1`` scratch): a difference across the Karnopp band edge is
    ``jump / increment ~ 1e12`` and was measured to freeze the slider in a wrong stick, with
    a small error estimate, since both embedded solutions share the Jacobian.
    """
    @njit(error_model="numpy", refcount=False)
    def jac(t, y, f0, p, sq, J, yt, ft, atol, rtol, g0, g1):
        for k in range(n):
            yt[k] = y[k]
        if n_events:
            events(t, y, p, sq, g0)
        for j in range(n_err):
            yj = y[j]
            step = SQRT_EPS * (abs(yj) + (atol[j] / rtol if rtol > 0.0 else 1.0))
            yt[j] = yj + step
            if n_events:
                events(t, yt, p, sq, g1)
                if sign_change(g0, g1, n_events):
                    yt[j] = yj - step
            delta = yt[j] - yj
            rhs(t, yt, p, sq, ft)
            for i in range(n):
                J[i, j] = (ft[i] - f0[i]) / delta
            yt[j] = yj
        for j in range(n_err, n):
            for i in range(n):
                J[i, j] = 0.0
    return jac


def make_time_derivative(n, rhs, n_events, events):
    """njit ``dfdt(t, y, f0, p, sq, hh, ft, yt, g0, g1)``: ``df/dt`` by differences.

    Central, increment ``delta = max(eps**(1/3) hh, 64 eps |t|)``: tied to the step, which
    resolves the explicit time dependence (so the O(delta^2) truncation error is ~1e-11
    relative), yet well above the rounding of ``t``. A forward difference with
    ``sqrt(eps) hh`` was measured to stall the step control at rtol 1e-9 (its rounding
    error, ``~ sqrt(eps) / hh``, grows as the step shrinks). When ``t +- delta`` straddles a
    kink (an event changes sign, e.g. the breakaway ``|hold| = f_break`` driven by the slow
    force) it falls back to the one-sided difference on the clean side (``f0 = f(t, y)``).
    Two evaluations; ``yt``, ``g0``, ``g1`` are scratch.
    """
    eps = float(np.finfo(float).eps)
    cbrt_eps = eps ** (1.0 / 3.0)

    @njit(error_model="numpy", refcount=False)
    def dfdt(t, y, f0, p, sq, hh, ft, yt, g0, g1):
        d = max(cbrt_eps * hh, 64.0 * eps * abs(t))
        t_hi, t_lo = t + d, t - d
        rhs(t_hi, y, p, sq, ft)
        rhs(t_lo, y, p, sq, yt)
        hi_ok = lo_ok = True
        if n_events:
            events(t, y, p, sq, g0)
            events(t_hi, y, p, sq, g1)
            hi_ok = not sign_change(g0, g1, n_events)
            events(t_lo, y, p, sq, g1)
            lo_ok = not sign_change(g0, g1, n_events)
        if hi_ok and lo_ok:
            inv = 1.0 / (t_hi - t_lo)
            for i in range(n):
                ft[i] = (ft[i] - yt[i]) * inv
        elif hi_ok:
            inv = 1.0 / (t_hi - t)
            for i in range(n):
                ft[i] = (ft[i] - f0[i]) * inv
        else:
            inv = 1.0 / (t - t_lo)
            for i in range(n):
                ft[i] = (f0[i] - yt[i]) * inv
    return dfdt


def make_time_probe(n, n_err, rhs):
    """njit ``depends_on_t(t, y, p, sq, fa, fb, yt) -> bool``: does ``f`` depend on ``t``?

    Compares ``f(t, .)`` with ``f(t + 0.1234567, .)`` at ``y`` *and* at a far-off state
    ``y + 0.1 (1 + |y|)`` (error-controlled components): a single state can be blind, e.g.
    a Karnopp stick band at rest, where the friction cancels the slow force exactly
    (measured: a wrong answer at rtol 1e-8 when only ``y`` was probed). Four evaluations,
    once per point; a non-finite probe counts as dependent. ``fa``, ``fb``, ``yt``: scratch.
    """
    @njit(error_model="numpy", refcount=False)
    def depends_on_t(t, y, p, sq, fa, fb, yt):
        for k in range(n):
            yt[k] = y[k]
        for probe in range(2):
            if probe == 1:
                for k in range(n_err):
                    yt[k] = y[k] + 0.1 * (1.0 + abs(y[k]))
            rhs(t, yt, p, sq, fa)
            rhs(t + 0.1234567, yt, p, sq, fb)
            for k in range(n):
                if fa[k] != fb[k]:      # also true for NaN
                    return True
        return False
    return depends_on_t


@njit(error_model="numpy", refcount=False)
def step_divisor(err):
    """Step divisor for error ``err`` (non-finite -> the largest cut)."""
    if not math.isfinite(err):
        return FAC_HI
    return min(FAC_HI, max(FAC_LO, err ** 0.25 / SAFETY))


@njit(error_model="numpy", refcount=False)
def accept_divisor(err, hh, h_old, err_old, rejected):
    """Gustafsson's predictive divisor after an accepted step of size ``hh`` with error
    ``err``, given the previous accepted step ``h_old`` (0: none) and its ``err_old``;
    no growth right after a rejection (Hairer & Wanner II, IV.8, Eq. 8.21)."""
    fac = step_divisor(err)
    if h_old > 0.0:
        pred = (h_old / hh) * (err * err / err_old) ** 0.25 / SAFETY
        fac = max(fac, min(FAC_HI, max(FAC_LO, pred)))
    if rejected:
        fac = max(fac, 1.0)
    return fac
