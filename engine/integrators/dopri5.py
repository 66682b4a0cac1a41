"""Dormand-Prince 5(4) with an I-controller, exact stops and kink events.

Dormand & Prince (1980), "A family of embedded Runge-Kutta formulae"; continuous extension
of order 4 by Shampine (1986) as in Hairer-Norsett-Wanner I, II.6 and scipy's ``RK45``.

- Error: ``err = rms_i(h sum_j e_j k_ji / (atol_i + rtol max(|y_i|, |y1_i|)))`` over the
  ``problem.n_err`` leading components; accept when ``err <= 1``.
- Step control (I-controller): ``h_new = h * min(10, max(0.2, 0.9 err**(-1/5)))``, no growth
  right after a rejection; a non-finite ``err`` is a rejection with factor 0.2.
- FSAL: the last stage is the next first stage, re-evaluated after a square-wave switch.
- Stops, kinks, landing, counters and status: the shared driver,
  :mod:`engine.integrators.adaptive`; this module is the tableau, the attempt, the dense
  output and the controller.
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from . import adaptive
from .adaptive import W_REJ, Method
from .problem import FRESH_START, Stepper
from .stepsize import make_initial_step
from .tableau import ButcherTableau

NAME = "dopri5"
ORDER = 5
ADAPTIVE = True
_A = np.zeros((7, 7))
_A[1, :1] = [1 / 5]
_A[2, :2] = [3 / 40, 9 / 40]
_A[3, :3] = [44 / 45, -56 / 15, 32 / 9]
_A[4, :4] = [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729]
_A[5, :5] = [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]
_A[6, :6] = [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]
TABLEAU = ButcherTableau(
    name=NAME,
    c=[0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1, 1],
    a=_A,
    b=[35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0],
    order=5,
    b_hat=[5179 / 57600, 0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40],
    error_order=4,
    dense=[  # Shampine's 4th-order extension (scipy.integrate RK45.P)
        [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
        [0, 0, 0, 0],
        [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
        [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
        [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
        [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
        [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
    ],
)
SAFETY, FAC_MIN, FAC_MAX = 0.9, 0.2, 10.0

def _make_attempt(tab, n, n_err, rhs):
    """njit ``attempt(t, hh, y, yn, p, sq, mw, rtol, atol, st) -> err``: stages 2..7 (k1
    given), the solution into ``yn``; ``mw = (K, T)``: the stages, and a scratch row.

    Compiled with floating-point contraction (fused multiply-add in the stage sums), as
    gcc does by default for the C reference (``-ffp-contract=fast``): ~1.5 % per step.

    ``forceinline``: LLVM inlines it into the driver's step loop (``alwaysinline``; the
    ``contract`` flags stay on its own instructions, so the bits do not change). numba's IR
    inlining (``inline="always"``) would compile it with the caller's strict flags instead.
    As a real call, its ten arguments (arrays as 7-word structs) cost ~90 stores and loads
    per attempt: fig10/nodither at rtol 1e-3 without kinks went 1.09-1.13x -> 1.06-1.07x of C."""
    a, c, e = tab.a, tab.c, tab.b_err
    a21 = a[1, 0]
    a31, a32 = a[2, 0], a[2, 1]
    a41, a42, a43 = a[3, 0], a[3, 1], a[3, 2]
    a51, a52, a53, a54 = a[4, 0], a[4, 1], a[4, 2], a[4, 3]
    a61, a62, a63, a64, a65 = a[5, 0], a[5, 1], a[5, 2], a[5, 3], a[5, 4]
    b1, b3, b4, b5, b6 = a[6, 0], a[6, 2], a[6, 3], a[6, 4], a[6, 5]
    c2, c3, c4, c5 = c[1], c[2], c[3], c[4]
    e1, e3, e4, e5, e6, e7 = e[0], e[2], e[3], e[4], e[5], e[6]

    @njit(error_model="numpy", refcount=False, fastmath={"contract"}, forceinline=True)
    def attempt(t, hh, y, yn, p, sq, mw, rtol, atol, st):
        K, T = mw
        k1, k2, k3, k4, k5, k6, k7 = K[0], K[1], K[2], K[3], K[4], K[5], K[6]
        yt = T[0]
        for i in range(n):
            yt[i] = y[i] + hh * a21 * k1[i]
        rhs(t + c2 * hh, yt, p, sq, k2)
        for i in range(n):
            yt[i] = y[i] + hh * (a31 * k1[i] + a32 * k2[i])
        rhs(t + c3 * hh, yt, p, sq, k3)
        for i in range(n):
            yt[i] = y[i] + hh * (a41 * k1[i] + a42 * k2[i] + a43 * k3[i])
        rhs(t + c4 * hh, yt, p, sq, k4)
        for i in range(n):
            yt[i] = y[i] + hh * (a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i])
        rhs(t + c5 * hh, yt, p, sq, k5)
        for i in range(n):
            yt[i] = y[i] + hh * (a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i]
                                 + a65 * k5[i])
        rhs(t + hh, yt, p, sq, k6)
        for i in range(n):
            yn[i] = y[i] + hh * (b1 * k1[i] + b3 * k3[i] + b4 * k4[i] + b5 * k5[i] + b6 * k6[i])
        rhs(t + hh, yn, p, sq, k7)
        err = 0.0
        for i in range(n_err):
            ei = hh * (e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i]
                       + e7 * k7[i])
            sc = atol[i] + rtol * max(abs(y[i]), abs(yn[i]))
            err += (ei / sc) ** 2
        return math.sqrt(err / n_err)

    return attempt


def _make_dense(tab, n):
    """njit ``coeffs(y, yn, K, Q)`` (dense polynomial per component) and
    ``dense_eval(y, hh, Q, th, out)``."""
    P = tab.dense
    rows = tuple(tuple(float(x) for x in P[:, j]) for j in range(P.shape[1]))
    d0, d1, d2, d3 = rows

    @njit(error_model="numpy", refcount=False)
    def coeffs(y, yn, mw, Q):
        K = mw[0]
        for i in range(n):
            Q[0, i] = (d0[0] * K[0, i] + d0[2] * K[2, i] + d0[3] * K[3, i] + d0[4] * K[4, i]
                       + d0[5] * K[5, i] + d0[6] * K[6, i])
            Q[1, i] = (d1[0] * K[0, i] + d1[2] * K[2, i] + d1[3] * K[3, i] + d1[4] * K[4, i]
                       + d1[5] * K[5, i] + d1[6] * K[6, i])
            Q[2, i] = (d2[0] * K[0, i] + d2[2] * K[2, i] + d2[3] * K[3, i] + d2[4] * K[4, i]
                       + d2[5] * K[5, i] + d2[6] * K[6, i])
            Q[3, i] = (d3[0] * K[0, i] + d3[2] * K[2, i] + d3[3] * K[3, i] + d3[4] * K[4, i]
                       + d3[5] * K[5, i] + d3[6] * K[6, i])

    @njit(error_model="numpy", refcount=False)
    def dense_eval(y, hh, Q, th, out):
        for i in range(n):
            out[i] = y[i] + hh * th * (Q[0, i] + th * (Q[1, i] + th * (Q[2, i] + th * Q[3, i])))

    return coeffs, dense_eval


@njit(error_model="numpy", refcount=False)
def _factor(err, reject_prev):
    """I-controller step factor for error ``err`` (non-finite -> FAC_MIN)."""
    if not math.isfinite(err):
        return FAC_MIN
    fac = FAC_MAX if err == 0.0 else min(FAC_MAX, max(FAC_MIN, SAFETY * err ** -0.2))
    if reject_prev and fac > 1.0:
        fac = 1.0
    return fac


def make_method(problem) -> Method:
    """DP5's parts for the shared driver (:mod:`engine.integrators.adaptive`)."""
    n, n_err, rhs = problem.n, problem.n_err, problem.rhs
    attempt = _make_attempt(TABLEAU, n, n_err, rhs)
    coeffs, dense_eval = _make_dense(TABLEAU, n)
    initial_step = make_initial_step(n, n_err, rhs, ORDER)

    @njit(inline="always", error_model="numpy")
    def alloc():
        return np.zeros((7, n)), np.zeros((1, n))   # stages k1..k7; scratch

    @njit(inline="always", error_model="numpy", refcount=False)
    def restart(t0, t1, y, p, sq, fresh, mw, rtol, atol, st):
        """k1 at t0 (the FSAL stage is stale after a switch); at a start also h."""
        K, T = mw
        rhs(t0, y, p, sq, K[0])
        if fresh != FRESH_START:
            return 1
        st[adaptive.W_H] = initial_step(t0, y, K[0], p, sq, T[0], K[1], rtol, atol, t1 - t0)
        st[W_REJ] = 0.0
        return 2

    @njit(inline="always", error_model="numpy", refcount=False)
    def prepare(t, y, h, t1, p, sq, mw, G, rtol, atol, st):
        return 0

    @njit(inline="always", error_model="numpy", refcount=False)
    def advance(mw):
        K = mw[0]
        for i in range(n):
            K[0, i] = K[6, i]   # FSAL

    @njit(inline="always", error_model="numpy", refcount=False)
    def on_reject(err, hh, st):
        return hh * _factor(err, False)

    @njit(inline="always", error_model="numpy", refcount=False)
    def on_accept(err_trial, hh_trial, err, hh, st):
        # from the trial: a landing on a kink says nothing about the smooth step size
        return hh_trial * _factor(err_trial, st[W_REJ] != 0.0)

    return Method(alloc, 0, 4, 6, restart, prepare, attempt, coeffs, dense_eval, advance,
                  on_reject, on_accept, ((7, n), (1, n)))


def make_stepper(problem) -> Stepper:
    """Kernel factory (protocol in engine.integrators)."""
    return adaptive.make_stepper(problem, make_method(problem))
