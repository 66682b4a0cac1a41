"""RODAS: stiffly accurate, L-stable Rosenbrock method of order 4(3), for stiff contacts.

Hairer & Wanner, *Solving ODEs II* (2nd ed., 1996), Sec. IV.7, Table 7.2 ("RODAS"),
coefficients of their code ``rodas.f`` (METH = 1) with its third-order dense output.
Six stages, one inversion of the small matrix ``I / (h gamma) - J`` per attempt, no Newton
iteration. Why this method for ditherlab: the bristle equation for frozen ``u`` is
linear in ``z``, ``dz = u - (sigma0 |u| / g(u)) z``, so the stiffness (rates up to
``sigma0 |u| / g ~ 1e6`` per unit tau) is exactly what a linearly implicit method treats
exactly; L-stability (``R(-inf) = 0``) damps the bristle transient after each square-wave
switch instead of ringing, and the step is set by accuracy, not stability.

- Jacobian: forward differences of ``problem.rhs`` over the ``n_err`` state columns
  (quadrature states never feed back: their columns are zero), increment
  ``sqrt(eps) (|y_j| + atol / rtol)``; ``df/dt`` likewise, but only when the right-hand side
  depends on ``t`` (tested once per point: a square wave is constant on a segment, so a
  scene without slow force or sine dither skips it). Cost per step: ``n_err + 1`` (+1)
  evaluations for ``J`` and 5 for the stages.
- Error: ``U_6`` (= ``y1 - y1_hat``), ``err = rms_i(U_6i / (atol + rtol max(|y_i|, |y1_i|)))``
  over the ``n_err`` leading components; accept when ``err <= 1``.
- Step control: Gustafsson's predictive controller as in ``rodas.f``
  (``h_new = h / fac``, ``fac`` in ``[1/6, 5]``, safety 0.9, no growth after a rejection).
- Stops, kinks, counters and status: as :mod:`engine.integrators.dopri5` (segments end
  exactly on ``t1``; a sign change of an event function inside an accepted step is located
  on the dense output and the step retaken to end on it; ``FAILED`` past
  ``cfg[CFG_MAX_STEPS]`` or on step-size underflow, ``NON_FINITE`` when it underflows
  because the state blew up).
- After a square-wave switch the bristle state relaxes on the time scale
  ``g / (sigma0 |u|)``; the step size is restarted there from the initial-step heuristic
  (one evaluation) rather than cut down from the previous half-period's step by rejections.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .. import status as S
from .events import make_locator
from .problem import (CFG_ATOL, CFG_MAX_STEPS, CFG_RTOL, CTR_EVALS, CTR_REJECTED, CTR_STEPS,
                      FRESH_NONE, FRESH_START, Stepper, record_step)
from .rosenbrock import (RosenbrockTableau, invert, make_fd_jacobian,
                         make_time_derivative)

NAME = "rodas4"
ORDER = 4
ADAPTIVE = True

_A5 = [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950]
TABLEAU = RosenbrockTableau(
    name=NAME,
    gamma=0.25,
    a=[[0, 0, 0, 0, 0, 0],
       [1.544, 0, 0, 0, 0, 0],
       [0.9466785280815826, 0.2557011698983284, 0, 0, 0, 0],
       [3.314825187068521, 2.896124015972201, 0.9986419139977817, 0, 0, 0],
       _A5 + [0, 0],
       _A5 + [1.0, 0]],
    C=[[0, 0, 0, 0, 0, 0],
       [-5.6688, 0, 0, 0, 0, 0],
       [-2.430093356833875, -0.2063599157091915, 0, 0, 0, 0],
       [-0.1073529058151375, -9.594562251023355, -20.47028614809616, 0, 0, 0],
       [7.496443313967647, -10.24680431464352, -33.99990352819905, 11.70890893206160, 0, 0],
       [8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136,
        -6.058818238834054, 0]],
    c=[0.0, 0.386, 0.21, 0.63, 1.0, 1.0],
    d=[0.25, -0.1043, 0.1035, -0.0362, 0.0, 0.0],
    m=_A5 + [1.0, 1.0],
    m_hat=_A5 + [1.0, 0.0],
    order=4,
    error_order=3,
    dense=[[10.12623508344586, -7.487995877610167, -34.80091861555747, -7.992771707568823,
            1.025137723295662, 0.0],
           [-0.6762803392801253, 6.087714651680015, 16.43084320892478, 24.76722511418386,
            -6.594389125716872, 0.0]],
)
SAFETY, FAC_LO, FAC_HI = 0.9, 1.0 / 6.0, 5.0   # h_new = h / fac, fac in [FAC_LO, FAC_HI]
STRETCH = 1.01       # take the rest of a segment when it is within 1 % of h
EVENT_MARGIN = 1e-9  # roots closer than this (in theta) to a step end are not landed on
# scalar slots of the work state
W_H, W_REJ, W_HOLD, W_ERROLD, W_TDEP = 0, 1, 2, 3, 4


def _make_attempt(tab, n, n_err, rhs):
    """njit ``attempt(t, hh, y, f0, ft, tdep, Minv, p, sq, U, yt, r, yn, rtol, atol) -> err``.

    Stages of one step from ``(t, y)`` with ``f0 = f(t, y)`` and ``Minv`` the inverse of
    ``I / (hh gamma) - J``; writes ``U`` (stages) and ``yn`` (the order-4 solution);
    ``yt``, ``r`` are scratch.
    """
    s = tab.stages
    A, C, c, d = tab.a.copy(), tab.C.copy(), tab.c.copy(), tab.d.copy()
    m, me = tab.m.copy(), tab.m_err.copy()

    @njit(error_model="numpy")
    def attempt(t, hh, y, f0, ft, tdep, Minv, p, sq, U, yt, r, yn, rtol, atol):
        inv_h = 1.0 / hh
        for i in range(s):
            if i == 0:
                r[:] = f0
            else:
                for k in range(n):
                    acc = y[k]
                    for j in range(i):
                        acc += A[i, j] * U[j, k]
                    yt[k] = acc
                rhs(t + c[i] * hh, yt, p, sq, r)
            for k in range(n):
                acc = r[k]
                for j in range(i):
                    acc += C[i, j] * inv_h * U[j, k]
                if tdep:
                    acc += d[i] * hh * ft[k]
                r[k] = acc
            for k in range(n):
                acc = 0.0
                for j in range(n):
                    acc += Minv[k, j] * r[j]
                U[i, k] = acc
        err = 0.0
        for k in range(n):
            acc, e = y[k], 0.0
            for i in range(s):
                acc += m[i] * U[i, k]
                e += me[i] * U[i, k]
            yn[k] = acc
            if k < n_err:
                sc = atol + rtol * max(abs(y[k]), abs(acc))
                err += (e / sc) ** 2
        return math.sqrt(err / n_err)

    return attempt


def _make_dense(tab, n):
    """njit ``coeffs(y, yn, U, Q)`` and ``dense_eval(y, hh, Q, th, out)`` (rodas.f form:
    ``y + th (y1 - y) + th (1 - th) (Q1 + th Q2)``)."""
    D = tab.dense.copy()
    s = tab.stages

    @njit(error_model="numpy")
    def coeffs(y, yn, U, Q):
        for k in range(n):
            q1 = q2 = 0.0
            for i in range(s):
                q1 += D[0, i] * U[i, k]
                q2 += D[1, i] * U[i, k]
            Q[0, k], Q[1, k], Q[2, k] = yn[k] - y[k], q1, q2

    @njit(error_model="numpy")
    def dense_eval(y, hh, Q, th, out):
        for k in range(n):
            out[k] = y[k] + th * (Q[0, k] + (1.0 - th) * (Q[1, k] + th * Q[2, k]))

    return coeffs, dense_eval


@njit(error_model="numpy")
def _fac(err):
    """Step divisor for error ``err`` (non-finite -> the largest cut)."""
    if not math.isfinite(err):
        return FAC_HI
    return min(FAC_HI, max(FAC_LO, err ** 0.25 / SAFETY))


@njit(error_model="numpy")
def _accept_fac(err, hh, state):
    """Gustafsson predictive divisor after an accepted step (updates the controller memory)."""
    fac = _fac(err)
    if state[W_HOLD] > 0.0:
        pred = (state[W_HOLD] / hh) * (err * err / state[W_ERROLD]) ** 0.25 / SAFETY
        fac = max(fac, min(FAC_HI, max(FAC_LO, pred)))
    state[W_HOLD] = hh
    state[W_ERROLD] = max(1e-2, err)
    if state[W_REJ] != 0.0:
        fac = max(fac, 1.0)
    return fac


def _make_initial_step(n, n_err, rhs, order):
    """njit ``h0(t, y, f0, p, sq, y1, f1, rtol, atol, t_span) -> h`` (Hairer-Norsett-Wanner I,
    II.4 "starting step size"; one evaluation)."""
    @njit(error_model="numpy")
    def initial_step(t, y, f0, p, sq, y1, f1, rtol, atol, t_span):
        d0 = d1 = 0.0
        for i in range(n_err):
            sc = atol + rtol * abs(y[i])
            d0 += (y[i] / sc) ** 2
            d1 += (f0[i] / sc) ** 2
        d0, d1 = math.sqrt(d0 / n_err), math.sqrt(d1 / n_err)
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, t_span)
        for i in range(n):
            y1[i] = y[i] + h0 * f0[i]
        rhs(t + h0, y1, p, sq, f1)
        d2 = 0.0
        for i in range(n_err):
            d2 += ((f1[i] - f0[i]) / (atol + rtol * abs(y[i]))) ** 2
        d2 = math.sqrt(d2 / n_err) / h0
        if max(d1, d2) <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
        return min(100.0 * h0, h1, t_span)
    return initial_step


def make_stepper(problem) -> Stepper:
    """Kernel factory (protocol in engine.integrators)."""
    n, n_err, rhs, observe = problem.n, problem.n_err, problem.rhs, problem.observe
    n_ev, events = problem.n_events, problem.events
    record, needs_mid = problem.record, problem.needs_mid
    s = TABLEAU.stages
    gamma = TABLEAU.gamma
    attempt = _make_attempt(TABLEAU, n, n_err, rhs)
    coeffs, dense_eval = _make_dense(TABLEAU, n)
    initial_step = _make_initial_step(n, n_err, rhs, ORDER)
    jac = make_fd_jacobian(n, n_err, rhs)
    dfdt = make_time_derivative(n, rhs)
    locate = make_locator(events, n_ev, dense_eval)
    n_g = max(n_ev, 1)

    @njit(error_model="numpy")
    def alloc():
        # U: stages; Y: yt, yn, ym, ytmp, f0, ft, r; Q: dense coefficients; G: event values
        # at step start / end / scratch; J, M, Minv: Jacobian, scratch, inverse of
        # I / (h gamma) - J; state: W_* slots
        return (np.zeros((s, n)), np.zeros((7, n)), np.zeros((3, n)), np.zeros((3, n_g)),
                np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)), np.zeros(5))

    @njit(error_model="numpy")
    def factor(J, M, Minv, hh):
        for i in range(n):
            for j in range(n):
                M[i, j] = -J[i, j]
            M[i, i] += 1.0 / (hh * gamma)
        return invert(M, Minv)

    @njit(error_model="numpy")
    def restart(t0, t1, y, p, sq, fresh, work, rtol, atol):
        """Events at t0; at the first segment of a point or after a switch a new h."""
        U, Y, Q, G, J, M, Minv, state = work
        if n_ev:
            events(t0, y, p, sq, G[0])
        rhs(t0, y, p, sq, Y[4])
        if fresh == FRESH_START:
            rhs(t0 + 0.1234567, y, p, sq, Y[5])
            state[W_TDEP] = 0.0
            for i in range(n):
                if Y[5, i] != Y[4, i]:
                    state[W_TDEP] = 1.0
        state[W_H] = initial_step(t0, y, Y[4], p, sq, Y[0], Y[5], rtol, atol, t1 - t0)
        state[W_REJ] = 0.0
        state[W_HOLD] = 0.0
        return 3 if fresh == FRESH_START else 2

    @njit(error_model="numpy")
    def try_step(t, hh, y, p, sq, work, rtol, atol, ctr):
        """Factor and attempt one step of size hh from (t, y); err (inf if singular)."""
        U, Y, Q, G, J, M, Minv, state = work
        ctr[CTR_EVALS] += s - 1
        if not factor(J, M, Minv, hh):
            return np.inf
        return attempt(t, hh, y, Y[4], Y[5], state[W_TDEP] != 0.0, Minv, p, sq, U, Y[0],
                       Y[6], Y[1], rtol, atol)

    @njit(error_model="numpy")
    def segment(work, y, t0, t1, p, sq, fresh, cfg, obs, ctr, rec):
        U, Y, Q, G, J, M, Minv, state = work
        yn, ym, ytmp, f0, ft = Y[1], Y[2], Y[3], Y[4], Y[5]
        rtol, atol = cfg[CFG_RTOL], cfg[CFG_ATOL]
        floor = atol / rtol if rtol > 0.0 else 1.0
        if fresh != FRESH_NONE:
            ctr[CTR_EVALS] += restart(t0, t1, y, p, sq, fresh, work, rtol, atol)
        h = state[W_H]
        t = t0
        while t < t1:
            # Jacobian (and df/dt) at (t, y), kept through rejections of this step
            rhs(t, y, p, sq, f0)
            jac(t, y, f0, p, sq, J, Y[0], ft, floor)
            ctr[CTR_EVALS] += 1 + n_err
            if state[W_TDEP] != 0.0:
                dfdt(t, y, f0, p, sq, min(h, t1 - t), ft, Y[0])
                ctr[CTR_EVALS] += 1
            while True:
                rem = t1 - t
                last = STRETCH * h >= rem
                hh = rem if last else h
                err = try_step(t, hh, y, p, sq, work, rtol, atol, ctr)
                if ctr[CTR_STEPS] + ctr[CTR_REJECTED] >= cfg[CFG_MAX_STEPS]:
                    state[W_H] = h
                    return S.FAILED
                if err <= 1.0 and n_ev:
                    events(t + hh, yn, p, sq, G[1])
                    coeffs(y, yn, U, Q)
                    th, idx = locate(t, hh, y, Q, p, sq, G[0], G[1], ytmp, G[2])
                    if EVENT_MARGIN < th < 1.0 - EVENT_MARGIN:
                        # retake the step so that it ends on the kink
                        ctr[CTR_REJECTED] += 1
                        hh = th * hh
                        last = False
                        err = try_step(t, hh, y, p, sq, work, rtol, atol, ctr)
                        if err <= 1.0:
                            events(t + hh, yn, p, sq, G[1])
                            G[1, idx] = 0.0   # landed on it: mute it for the next step
                if err <= 1.0:
                    break
                ctr[CTR_REJECTED] += 1
                h = hh / _fac(err)
                state[W_REJ] = 1.0
                if h < 1e-14 * max(1.0, abs(t)):
                    state[W_H] = h
                    return S.FAILED if math.isfinite(err) else S.NON_FINITE
            h_next = hh / _accept_fac(err, hh, state)
            if needs_mid:
                coeffs(y, yn, U, Q)
                dense_eval(y, hh, Q, 0.5, ym)
            t_new = t1 if last else t + hh
            observe(t, y, t_new, yn, ym, p, sq, obs)
            for i in range(n):
                y[i] = yn[i]
            for i in range(n_ev):
                G[0, i] = G[1, i]
            ctr[CTR_STEPS] += 1
            if record:
                record_step(rec, ctr, cfg, t_new, y)
            state[W_REJ] = 0.0
            h = max(h, h_next) if (last or hh < h) else h_next
            t = t_new
        state[W_H] = h
        return S.OK

    return Stepper(alloc, segment, (coeffs, dense_eval))
