"""Dormand-Prince 5(4) with an I-controller, exact stops and kink events.

Dormand & Prince (1980), "A family of embedded Runge-Kutta formulae"; continuous extension
of order 4 by Shampine (1986) as in Hairer-Norsett-Wanner I, II.6 and scipy's ``RK45``.

- Error: ``err = rms_i(h sum_j e_j k_ji / (atol_i + rtol max(|y_i|, |y1_i|)))`` over the
  ``problem.n_err`` leading components; accept when ``err <= 1``.
- Step control (I-controller): ``h_new = h * min(10, max(0.2, 0.9 err**(-1/5)))``, no growth
  right after a rejection; a non-finite ``err`` is a rejection with factor 0.2.
- Stops: a segment ends exactly on ``t1`` (assigned; the step is stretched to it when
  within 1 % of ``h``). FSAL: the last stage is the next first stage, re-evaluated
  after a square-wave switch (``fresh``). The step size carries over between segments.
- Kinks: after an accepted trial step, the problem's event functions are evaluated at its
  end; if one changed sign, its root theta* is found on the dense output
  (:mod:`engine.integrators.events`) and the step is retaken from ``t`` with ``theta* h``,
  so that it ends on the kink (the discarded trial counts as rejected). An event reached or
  passed is muted for the next step; one fallen short is found again by the next step,
  whose dense output no longer straddles the corner. The DP5 error estimate is blind to a corner inside a step
  (measured on Fig. 10: error stuck near 1e-4 whatever rtol); landing on it restores the
  tolerance-proportional error.
"""
from __future__ import annotations

import math

import numpy as np

from .. import status as S
from ..jit import njit
from .events import make_grazing_probe, make_locator, past_corner, sign_change
from .problem import (
    CFG_ATOL_I,
    CFG_MAX_STEPS,
    CFG_RTOL,
    CTR_EVALS,
    CTR_REJECTED,
    CTR_STEPS,
    FRESH_NONE,
    FRESH_START,
    Stepper,
    make_sampler,
    record_step,
    sample_due,
)
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
STRETCH = 1.01      # take the rest of a segment when it is within 1 % of h
EVENT_MARGIN = 1e-12  # roots closer than this (in theta) to a step end are not landed on
LANDING_FLOOR = 1e-12  # landings shorter than this times max(1, |t|) cross the corner instead
W_H, W_REJ, W_K = 0, 1, 2   # work state: step size, reject flag, next sampling index


def _make_attempt(tab, n, n_err, rhs):
    """njit ``attempt(t, hh, y, p, sq, K, Y, rtol, atol) -> err``: stages 2..7 (k1 given).

    Compiled with floating-point contraction (fused multiply-add in the stage sums), as
    gcc does by default for the C reference (``-ffp-contract=fast``): ~1.5 % per step."""
    a, c, e = tab.a, tab.c, tab.b_err
    a21 = a[1, 0]
    a31, a32 = a[2, 0], a[2, 1]
    a41, a42, a43 = a[3, 0], a[3, 1], a[3, 2]
    a51, a52, a53, a54 = a[4, 0], a[4, 1], a[4, 2], a[4, 3]
    a61, a62, a63, a64, a65 = a[5, 0], a[5, 1], a[5, 2], a[5, 3], a[5, 4]
    b1, b3, b4, b5, b6 = a[6, 0], a[6, 2], a[6, 3], a[6, 4], a[6, 5]
    c2, c3, c4, c5 = c[1], c[2], c[3], c[4]
    e1, e3, e4, e5, e6, e7 = e[0], e[2], e[3], e[4], e[5], e[6]

    @njit(error_model="numpy", refcount=False, fastmath={"contract"})
    def attempt(t, hh, y, p, sq, K, Y, rtol, atol):
        k1, k2, k3, k4, k5, k6, k7 = K[0], K[1], K[2], K[3], K[4], K[5], K[6]
        yt, yn = Y[0], Y[1]
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
    """njit ``coeffs(K, Q)`` (dense polynomial per component) and ``dense_eval(y, hh, Q, th, out)``."""
    P = tab.dense
    rows = tuple(tuple(float(x) for x in P[:, j]) for j in range(P.shape[1]))
    d0, d1, d2, d3 = rows

    @njit(error_model="numpy", refcount=False)
    def coeffs(K, Q):
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


def make_stepper(problem) -> Stepper:
    """Kernel factory (protocol in engine.integrators)."""
    n, n_err, rhs, observe = problem.n, problem.n_err, problem.rhs, problem.observe
    n_ev, events = problem.n_events, problem.events
    record, needs_mid, sampling = problem.record, problem.needs_mid, problem.sampling
    attempt = _make_attempt(TABLEAU, n, n_err, rhs)
    coeffs, dense_eval = _make_dense(TABLEAU, n)
    initial_step = make_initial_step(n, n_err, rhs, ORDER)
    locate = make_locator(events, n_ev, dense_eval)
    graze, probe = problem.graze and n_ev > 0, make_grazing_probe(events, n_ev, dense_eval)
    first_sample, emit = make_sampler(problem, dense_eval)
    n_g = max(n_ev, 1)

    @njit(inline="always", error_model="numpy")
    def alloc():
        # K: stages k1..k7; Y: yt, yn, ymid, ytmp; Q: dense coefficients;
        # G: event values at step start / end / scratch / grazing probe x2; state: W_* slots
        return (np.zeros((7, n)), np.zeros((4, n)), np.zeros((4, n)), np.zeros((5, n_g)),
                np.zeros(3))

    @njit(error_model="numpy", refcount=False)
    def segment(work, y, t0, t1, p, sq, fresh, cfg, obs, ctr, rec):
        K, Y, Q, G, state = work
        rtol, atol = cfg[CFG_RTOL], cfg[CFG_ATOL_I:CFG_ATOL_I + n_err]   # atol per component
        if fresh != FRESH_NONE:
            rhs(t0, y, p, sq, K[0])
            ctr[CTR_EVALS] += 1
            if n_ev:
                events(t0, y, p, sq, G[0])
            if fresh == FRESH_START:
                state[W_H] = initial_step(t0, y, K[0], p, sq, Y[0], K[1], rtol, atol, t1 - t0)
                state[W_REJ] = 0.0
                ctr[CTR_EVALS] += 1
                if sampling:
                    state[W_K] = first_sample(t0, y, p, sq, cfg, obs, ctr, rec)
        h = state[W_H]
        t = t0
        while t < t1:
            rem = t1 - t
            last = STRETCH * h >= rem
            hh = rem if last else h
            err = attempt(t, hh, y, p, sq, K, Y, rtol, atol)
            ctr[CTR_EVALS] += 6
            if ctr[CTR_STEPS] + ctr[CTR_REJECTED] >= cfg[CFG_MAX_STEPS]:
                return S.FAILED
            if not err <= 1.0:
                ctr[CTR_REJECTED] += 1
                h = hh * _factor(err, False)
                state[W_REJ] = 1.0
                if h < 1e-14 * max(1.0, abs(t)):
                    return S.FAILED if math.isfinite(err) else S.NON_FINITE
                continue
            h_next = hh * _factor(err, state[W_REJ] != 0.0)
            if n_ev:
                events(t + hh, Y[1], p, sq, G[1])
                th, idx = 2.0, -1
                if sign_change(G[0], G[1], n_ev):
                    coeffs(K, Q)
                    th, idx = locate(t, hh, y, Q, p, sq, G[0], G[1], Y[3], G[2])
                elif graze:   # a dip through zero and back inside the step
                    coeffs(K, Q)
                    th_b = probe(t, hh, y, Q, p, sq, G[0], G[1], Y[3], G[3], G[4])
                    if th_b < 1.0:
                        th, idx = locate(t, hh, y, Q, p, sq, G[0], G[3], Y[3], G[2], th_b)
                # a corner within round-off of t is crossed, not landed on: a landing
                # shorter than LANDING_FLOOR (relative) that falls short would otherwise
                # repeat forever with zero-length steps (u = v + W sin hovering at 1e-13)
                if EVENT_MARGIN < th < 1.0 - EVENT_MARGIN and \
                        th * hh > LANDING_FLOOR * max(1.0, abs(t)):
                    # retake the step so that it ends on the kink
                    ctr[CTR_REJECTED] += 1
                    hh = th * hh
                    last = False
                    err = attempt(t, hh, y, p, sq, K, Y, rtol, atol)
                    ctr[CTR_EVALS] += 6
                    if not err <= 1.0:
                        ctr[CTR_REJECTED] += 1
                        h = hh * _factor(err, False)
                        state[W_REJ] = 1.0
                        continue
                    events(t + hh, Y[1], p, sq, G[1])
                    past_corner(G[0], G[1], idx)   # the locator aims at the far side
                    # fell short (dense output across the corner is only O(h^3) exact):
                    # the next step finds the root again, from the near side
            if needs_mid:
                coeffs(K, Q)
                dense_eval(y, hh, Q, 0.5, Y[2])
            t_new = t1 if last else t + hh
            observe(t, y, t_new, Y[1], Y[2], p, sq, obs)
            if sampling and sample_due(state[W_K], cfg, t_new):
                if not needs_mid:   # else Q holds this step's coefficients already
                    coeffs(K, Q)
                state[W_K] = emit(t, hh, t_new, y, Y[1], Q, p, sq, cfg, obs, ctr, rec,
                                  state[W_K], Y[3])
            for i in range(n):
                y[i] = Y[1, i]
                K[0, i] = K[6, i]
            if n_ev:
                for i in range(n_ev):
                    G[0, i] = G[1, i]
            ctr[CTR_STEPS] += 1
            if record and rec.shape[0] > 0:   # the check here, not in the call: ~10 %
                record_step(rec, ctr, cfg, t_new, y)
            state[W_REJ] = 0.0
            h = max(h, h_next) if (last or hh < h) else h_next
            t = t_new
        state[W_H] = h
        return S.OK

    return Stepper(alloc, segment, (coeffs, dense_eval))
