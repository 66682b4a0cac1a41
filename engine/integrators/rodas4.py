"""RODAS: stiffly accurate, L-stable Rosenbrock method of order 4(3), for stiff contacts.

Hairer & Wanner, *Solving ODEs II* (2nd ed., 1996), Sec. IV.7, Table 7.2 ("RODAS"):
the coefficients of their code ``rodas.f`` (METH = 1) with its third-order dense output.
Six stages and one inverse of the small matrix ``I / (h gamma) - J`` per attempt, no Newton
iteration. Why it suits ditherlab: for frozen ``u`` the bristle equation
``dz = u - (sigma0 |u| / g(u)) z`` is linear in ``z`` with rates up to
``sigma0 |u| / g ~ 1e6`` per unit tau; a linearly implicit step is stable at any ``h`` for
it, L-stability (``R(-inf) = 0``) damps the relaxation after each square-wave switch
instead of ringing, so the step follows accuracy, not stability (explicit DP5 needs
``h < 3.3 g / (sigma0 |u|)``).

- Jacobian: one-sided differences of ``problem.rhs`` over the ``n_err`` state columns
  (quadrature states never feed back: zero columns), increment
  ``sqrt(eps) (|y_j| + atol_j / rtol)``, directed away from kinks (event sign changes).
  ``df/dt`` by central differences, only when ``f`` depends on ``t`` (probed once per
  point at two states; a square wave is constant on a segment). Per step: ``n_err + 1``
  evaluations (+2 for ``df/dt``) and 5 for the stages.
- Error: ``U_6 = y1 - y1_hat``, ``err = rms_i(U_6i / (atol_i + rtol max(|y_i|, |y1_i|)))`` over
  the ``n_err`` leading components; accept when ``err <= 1``.
- Step control: Gustafsson's predictive controller as in ``rodas.f``
  (:mod:`engine.integrators.rosenbrock_ops`).
- Stops, kinks, counters and status: as :mod:`engine.integrators.dopri5` (segments end
  exactly on ``t1``; a sign change of an event function inside an accepted step is located
  on the dense output and the step retaken to end on it; the event is muted for the next
  step once reached or passed and found again if the landing fell short, at most
  ``MAX_SHORT`` times in a row). ``FAILED`` past ``cfg[CFG_MAX_STEPS]`` or on step-size
  underflow, ``NON_FINITE`` when it underflows because the state blew up.
- After a square-wave switch the bristle state relaxes on the time scale
  ``g / (sigma0 |u|)``: the step restarts there from the initial-step heuristic (one
  evaluation) rather than being cut down by rejections from the previous half-period's.
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
from .rosenbrock import RosenbrockTableau
from .rosenbrock_ops import (
    accept_divisor,
    invert,
    make_fd_jacobian,
    make_time_derivative,
    make_time_probe,
    step_divisor,
)
from .stepsize import make_initial_step

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
STRETCH = 1.01       # take the rest of a segment when it is within 1 % of h
EVENT_MARGIN = 1e-12  # roots closer than this (in theta) to a step end are not landed on
MAX_SHORT = 2        # landings in a row that fall short of the same kink before it is passed
# scalar slots of the work state
W_H, W_REJ, W_HOLD, W_ERROLD, W_TDEP, W_SHORT, W_K = 0, 1, 2, 3, 4, 5, 6  # W_K: next sample


def _check_layout(tab):
    """The unrolled stages assume RODAS's layout: stiffly accurate (the solution is the
    sixth stage's argument plus U6, the embedded one the sixth argument), c5 = c6 = 1,
    no time-derivative term in stages 5 and 6."""
    a, m, m_hat, c, d = tab.a, tab.m, tab.m_hat, tab.c, tab.d
    ok = (tab.stages == 6 and np.array_equal(a[5, :4], a[4, :4]) and a[5, 4] == 1.0
          and np.array_equal(m[:5], a[5, :5]) and m[5] == 1.0
          and np.array_equal(m_hat[:5], a[5, :5]) and m_hat[5] == 0.0
          and c[4] == c[5] == 1.0 and d[4] == d[5] == 0.0)
    if not ok:
        raise ValueError(f"{tab.name}: the unrolled kernel needs RODAS's stiffly accurate layout")


def _make_attempt(tab, n, n_err, rhs):
    """njit ``attempt(t, hh, y, f0, ft, tdep, Minv, p, sq, U, yt, r, yn, rtol, atol) -> err``.

    Stages of one step from ``(t, y)`` with ``f0 = f(t, y)`` and ``Minv`` the inverse of
    ``I / (hh gamma) - J``; writes ``U`` (stages) and ``yn`` (the order-4 solution);
    ``yt``, ``r`` are scratch. Unrolled with the coefficients as compile-time constants
    (measured 1.5x faster than loops over the tableau arrays).
    """
    _check_layout(tab)
    a, C, c, d = tab.a, tab.C, tab.c, tab.d
    a21 = a[1, 0]
    a31, a32 = a[2, 0], a[2, 1]
    a41, a42, a43 = a[3, 0], a[3, 1], a[3, 2]
    a51, a52, a53, a54 = a[4, 0], a[4, 1], a[4, 2], a[4, 3]
    c21 = C[1, 0]
    c31, c32 = C[2, 0], C[2, 1]
    c41, c42, c43 = C[3, 0], C[3, 1], C[3, 2]
    c51, c52, c53, c54 = C[4, 0], C[4, 1], C[4, 2], C[4, 3]
    c61, c62, c63, c64, c65 = C[5, 0], C[5, 1], C[5, 2], C[5, 3], C[5, 4]
    t2, t3, t4 = c[1], c[2], c[3]
    d1, d2, d3, d4 = d[0], d[1], d[2], d[3]

    @njit(error_model="numpy", refcount=False)
    def solve(Minv, r, Ui):
        for k in range(n):
            acc = 0.0
            for j in range(n):
                acc += Minv[k, j] * r[j]
            Ui[k] = acc

    @njit(error_model="numpy", refcount=False)
    def attempt(t, hh, y, f0, ft, tdep, Minv, p, sq, U, yt, r, yn, rtol, atol):
        ih = 1.0 / hh
        dh = hh if tdep else 0.0
        U1, U2, U3, U4, U5, U6 = U[0], U[1], U[2], U[3], U[4], U[5]
        for k in range(n):
            r[k] = f0[k] + (d1 * dh * ft[k] if tdep else 0.0)
        solve(Minv, r, U1)
        for k in range(n):
            yt[k] = y[k] + a21 * U1[k]
        rhs(t + t2 * hh, yt, p, sq, r)
        for k in range(n):
            r[k] += ih * c21 * U1[k] + (d2 * dh * ft[k] if tdep else 0.0)
        solve(Minv, r, U2)
        for k in range(n):
            yt[k] = y[k] + a31 * U1[k] + a32 * U2[k]
        rhs(t + t3 * hh, yt, p, sq, r)
        for k in range(n):
            r[k] += ih * (c31 * U1[k] + c32 * U2[k]) + (d3 * dh * ft[k] if tdep else 0.0)
        solve(Minv, r, U3)
        for k in range(n):
            yt[k] = y[k] + a41 * U1[k] + a42 * U2[k] + a43 * U3[k]
        rhs(t + t4 * hh, yt, p, sq, r)
        for k in range(n):
            r[k] += (ih * (c41 * U1[k] + c42 * U2[k] + c43 * U3[k])
                     + (d4 * dh * ft[k] if tdep else 0.0))
        solve(Minv, r, U4)
        for k in range(n):
            yt[k] = y[k] + a51 * U1[k] + a52 * U2[k] + a53 * U3[k] + a54 * U4[k]
        rhs(t + hh, yt, p, sq, r)
        for k in range(n):
            r[k] += ih * (c51 * U1[k] + c52 * U2[k] + c53 * U3[k] + c54 * U4[k])
        solve(Minv, r, U5)
        for k in range(n):
            yt[k] += U5[k]                      # the sixth argument = embedded solution
        rhs(t + hh, yt, p, sq, r)
        for k in range(n):
            r[k] += ih * (c61 * U1[k] + c62 * U2[k] + c63 * U3[k] + c64 * U4[k]
                          + c65 * U5[k])
        solve(Minv, r, U6)
        err = 0.0
        for k in range(n):
            yn[k] = yt[k] + U6[k]
            if k < n_err:
                sc = atol[k] + rtol * max(abs(y[k]), abs(yn[k]))
                err += (U6[k] / sc) ** 2
        return math.sqrt(err / n_err)

    return attempt


def _make_dense(tab, n):
    """njit ``coeffs(y, yn, U, Q)`` and ``dense_eval(y, hh, Q, th, out)`` (rodas.f form:
    ``y + th (y1 - y) + th (1 - th) (Q1 + th Q2)``)."""
    D = tab.dense.copy()
    s = tab.stages

    @njit(error_model="numpy", refcount=False)
    def coeffs(y, yn, U, Q):
        for k in range(n):
            q1 = q2 = 0.0
            for i in range(s):
                q1 += D[0, i] * U[i, k]
                q2 += D[1, i] * U[i, k]
            Q[0, k], Q[1, k], Q[2, k] = yn[k] - y[k], q1, q2

    @njit(error_model="numpy", refcount=False)
    def dense_eval(y, hh, Q, th, out):
        for k in range(n):
            out[k] = y[k] + th * (Q[0, k] + (1.0 - th) * (Q[1, k] + th * Q[2, k]))

    return coeffs, dense_eval


def make_stepper(problem) -> Stepper:
    """Kernel factory (protocol in engine.integrators)."""
    n, n_err, rhs, observe = problem.n, problem.n_err, problem.rhs, problem.observe
    n_ev, events = problem.n_events, problem.events
    record, needs_mid = problem.record, problem.needs_mid
    s = TABLEAU.stages
    gamma = TABLEAU.gamma
    attempt = _make_attempt(TABLEAU, n, n_err, rhs)
    coeffs, dense_eval = _make_dense(TABLEAU, n)
    initial_step = make_initial_step(n, n_err, rhs, ORDER + 1)
    jac = make_fd_jacobian(n, n_err, rhs, n_ev, events)
    dfdt = make_time_derivative(n, rhs, n_ev, events)
    depends_on_t = make_time_probe(n, n_err, rhs)
    locate = make_locator(events, n_ev, dense_eval)
    graze, probe = problem.graze and n_ev > 0, make_grazing_probe(events, n_ev, dense_eval)
    sampling = problem.sampling
    first_sample, emit = make_sampler(problem, dense_eval)
    n_g = max(n_ev, 1)

    @njit(error_model="numpy")
    def alloc():
        # U: stages; Y: yt, yn, ym, ytmp, f0, ft, r; Q: dense coefficients; G: event values
        # at step start / end / scratch x2 / grazing probe; J, M, Minv: Jacobian, scratch,
        # inverse of I / (h gamma) - J; state: W_* slots
        return (np.zeros((s, n)), np.zeros((7, n)), np.zeros((3, n)), np.zeros((5, n_g)),
                np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)), np.zeros(7))

    @njit(error_model="numpy", refcount=False)
    def factor(J, M, Minv, hh):
        for i in range(n):
            for j in range(n):
                M[i, j] = -J[i, j]
            M[i, i] += 1.0 / (hh * gamma)
        return invert(M, Minv)

    @njit(error_model="numpy", refcount=False)
    def restart(t0, t1, y, p, sq, fresh, work, rtol, atol):
        """Events at t0; at the first segment of a point or after a switch a new h."""
        Y, G, state = work[1], work[3], work[7]
        if n_ev:
            events(t0, y, p, sq, G[0])
        if fresh == FRESH_START:
            state[W_TDEP] = 1.0 if depends_on_t(t0, y, p, sq, Y[4], Y[5], Y[0]) else 0.0
        rhs(t0, y, p, sq, Y[4])
        state[W_H] = initial_step(t0, y, Y[4], p, sq, Y[0], Y[5], rtol, atol, t1 - t0)
        state[W_REJ] = 0.0
        state[W_HOLD] = 0.0
        state[W_SHORT] = 0.0
        return 6 if fresh == FRESH_START else 2

    @njit(error_model="numpy", refcount=False)
    def try_step(t, hh, y, p, sq, work, rtol, atol, ctr):
        """Factor and attempt one step of size hh from (t, y); err (inf if singular)."""
        U, Y, J, M, Minv, state = work[0], work[1], work[4], work[5], work[6], work[7]
        ctr[CTR_EVALS] += s - 1
        if not factor(J, M, Minv, hh):
            return np.inf
        return attempt(t, hh, y, Y[4], Y[5], state[W_TDEP] != 0.0, Minv, p, sq, U, Y[0],
                       Y[6], Y[1], rtol, atol)

    @njit(error_model="numpy", refcount=False)
    def land(t, hh, err, y, p, sq, work, rtol, atol, ctr):
        """After an accepted trial of size hh: if an event changed sign, retake the step so
        that it ends on the earliest root (the trial counts as rejected), as dopri5 does.
        Returns (hh, err, retaken)."""
        U, Y, Q, G, state = work[0], work[1], work[2], work[3], work[7]
        yn, ytmp = Y[1], Y[3]
        events(t + hh, yn, p, sq, G[1])
        if sign_change(G[0], G[1], n_ev):
            coeffs(y, yn, U, Q)
            th, idx = locate(t, hh, y, Q, p, sq, G[0], G[1], ytmp, G[2])
        elif graze:   # a dip through zero and back inside the step (G[3]: jac scratch)
            coeffs(y, yn, U, Q)
            th_b = probe(t, hh, y, Q, p, sq, G[0], G[1], ytmp, G[3], G[4])
            if not th_b < 1.0:
                return hh, err, False
            th, idx = locate(t, hh, y, Q, p, sq, G[0], G[3], ytmp, G[2], th_b)
        else:
            return hh, err, False
        if not EVENT_MARGIN < th < 1.0 - EVENT_MARGIN:
            return hh, err, False
        ctr[CTR_REJECTED] += 1
        hh = th * hh
        err = try_step(t, hh, y, p, sq, work, rtol, atol, ctr)
        if err <= 1.0:
            events(t + hh, yn, p, sq, G[1])
            state[W_SHORT] = 0.0 if G[1, idx] * G[0, idx] <= 0.0 else state[W_SHORT] + 1.0
            if state[W_SHORT] == 0.0:
                past_corner(G[0], G[1], idx)   # the locator aims at the far side
            elif state[W_SHORT] > MAX_SHORT:
                G[1, idx] = 0.0   # unreachable: mute it for the next step
                state[W_SHORT] = 0.0
            # else it fell short (the dense output is O(h^4) off across the corner): the
            # next step finds the root again, from the near side -- at most MAX_SHORT
            # times in a row: a grazing kink (u -> 0 with du/dt -> 0, e.g. W = v_ref) or
            # one that rounding cannot reach (u = v - W stuck one ulp short) is passed
        return hh, err, True

    @njit(error_model="numpy", refcount=False)
    def segment(work, y, t0, t1, p, sq, fresh, cfg, obs, ctr, rec):
        U, Y, Q, G, J, state = work[0], work[1], work[2], work[3], work[4], work[7]
        yn, ym, f0, ft = Y[1], Y[2], Y[4], Y[5]
        rtol, atol = cfg[CFG_RTOL], cfg[CFG_ATOL_I:CFG_ATOL_I + n_err]   # atol per component
        if fresh != FRESH_NONE:
            ctr[CTR_EVALS] += restart(t0, t1, y, p, sq, fresh, work, rtol, atol)
            if sampling and fresh == FRESH_START:
                state[W_K] = first_sample(t0, y, p, sq, cfg, obs, ctr, rec)
        h = state[W_H]
        t = t0
        while t < t1:
            # Jacobian (and df/dt) at (t, y), kept through rejections of this step
            rhs(t, y, p, sq, f0)
            jac(t, y, f0, p, sq, J, Y[0], ft, atol, rtol, G[2], G[3])
            ctr[CTR_EVALS] += 1 + n_err
            if state[W_TDEP] != 0.0:
                dfdt(t, y, f0, p, sq, min(h, t1 - t), ft, Y[0], G[2], G[3])
                ctr[CTR_EVALS] += 2
            while True:
                rem = t1 - t
                last = STRETCH * h >= rem
                hh = rem if last else h
                err = try_step(t, hh, y, p, sq, work, rtol, atol, ctr)
                if ctr[CTR_STEPS] + ctr[CTR_REJECTED] >= cfg[CFG_MAX_STEPS]:
                    state[W_H] = h
                    return S.FAILED
                if err <= 1.0 and n_ev:
                    hh, err, retaken = land(t, hh, err, y, p, sq, work, rtol, atol, ctr)
                    last = last and not retaken
                if err <= 1.0:
                    break
                ctr[CTR_REJECTED] += 1
                h = hh / step_divisor(err)
                state[W_REJ] = 1.0
                if h < 1e-14 * max(1.0, abs(t)):
                    state[W_H] = h
                    return S.FAILED if math.isfinite(err) else S.NON_FINITE
            h_next = hh / accept_divisor(err, hh, state[W_HOLD], state[W_ERROLD],
                                         state[W_REJ] != 0.0)
            state[W_HOLD], state[W_ERROLD] = hh, max(1e-2, err)
            if needs_mid:
                coeffs(y, yn, U, Q)
                dense_eval(y, hh, Q, 0.5, ym)
            t_new = t1 if last else t + hh
            observe(t, y, t_new, yn, ym, p, sq, obs)
            if sampling and sample_due(state[W_K], cfg, t_new):
                if not needs_mid:   # else Q holds this step's coefficients already
                    coeffs(y, yn, U, Q)
                state[W_K] = emit(t, hh, t_new, y, yn, Q, p, sq, cfg, obs, ctr, rec,
                                  state[W_K], Y[3])
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
