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
- Stops, kinks, landing, counters and status: the shared driver,
  :mod:`engine.integrators.adaptive`; this module is the tableau, the attempt (with its
  Jacobian), the dense output and the controller.
- After a square-wave switch the bristle state relaxes on the time scale
  ``g / (sigma0 |u|)``: the step restarts there from the initial-step heuristic (one
  evaluation) rather than being cut down by rejections from the previous half-period's.
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from . import adaptive
from .adaptive import W_H, W_METHOD, W_REJ, Method
from .problem import FRESH_START, Stepper
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
# the method's scalar slots in the driver's state: the last accepted step and its error
# (for the predictive controller), and whether f depends on t
W_HOLD, W_ERROLD, W_TDEP = W_METHOD, W_METHOD + 1, W_METHOD + 2
# rows of the vector scratch R
R_YT, R_F0, R_FT, R_R = 0, 1, 2, 3

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
    """njit ``coeffs(y, yn, mw, Q)`` and ``dense_eval(y, hh, Q, th, out)`` (rodas.f form:
    ``y + th (y1 - y) + th (1 - th) (Q1 + th Q2)``)."""
    D = tab.dense.copy()
    s = tab.stages

    @njit(error_model="numpy", refcount=False)
    def coeffs(y, yn, mw, Q):
        U = mw[0]
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


def make_method(problem) -> Method:
    """RODAS's parts for the shared driver (:mod:`engine.integrators.adaptive`)."""
    n, n_err, rhs = problem.n, problem.n_err, problem.rhs
    n_ev, events = problem.n_events, problem.events
    s, gamma = TABLEAU.stages, TABLEAU.gamma
    stages = _make_attempt(TABLEAU, n, n_err, rhs)
    coeffs, dense_eval = _make_dense(TABLEAU, n)
    initial_step = make_initial_step(n, n_err, rhs, ORDER + 1)
    jac = make_fd_jacobian(n, n_err, rhs, n_ev, events)
    dfdt = make_time_derivative(n, rhs, n_ev, events)
    depends_on_t = make_time_probe(n, n_err, rhs)

    @njit(error_model="numpy")
    def alloc():
        # U: stages; R: rows R_*; J, M, Minv: Jacobian, scratch, inverse of I / (h gamma) - J
        return (np.zeros((s, n)), np.zeros((4, n)), np.zeros((n, n)), np.zeros((n, n)),
                np.zeros((n, n)))

    @njit(error_model="numpy", refcount=False)
    def factor(J, M, Minv, hh):
        for i in range(n):
            for j in range(n):
                M[i, j] = -J[i, j]
            M[i, i] += 1.0 / (hh * gamma)
        return invert(M, Minv)

    @njit(inline="always", error_model="numpy", refcount=False)
    def restart(t0, t1, y, p, sq, fresh, mw, rtol, atol, st):
        """At the first segment of a point or after a switch, a new h."""
        R = mw[1]
        if fresh == FRESH_START:
            st[W_TDEP] = 1.0 if depends_on_t(t0, y, p, sq, R[R_F0], R[R_FT], R[R_YT]) else 0.0
        rhs(t0, y, p, sq, R[R_F0])
        st[W_H] = initial_step(t0, y, R[R_F0], p, sq, R[R_YT], R[R_FT], rtol, atol, t1 - t0)
        st[W_REJ] = 0.0
        st[W_HOLD] = 0.0
        return 6 if fresh == FRESH_START else 2

    @njit(inline="always", error_model="numpy", refcount=False)
    def prepare(t, y, h, t1, p, sq, mw, G, rtol, atol, st):
        """Jacobian (and df/dt) at (t, y), kept through the rejections of this step."""
        R, J = mw[1], mw[2]
        rhs(t, y, p, sq, R[R_F0])
        jac(t, y, R[R_F0], p, sq, J, R[R_YT], R[R_FT], atol, rtol, G[2], G[3])
        if st[W_TDEP] == 0.0:
            return 1 + n_err
        dfdt(t, y, R[R_F0], p, sq, min(h, t1 - t), R[R_FT], R[R_YT], G[2], G[3])
        return 3 + n_err

    @njit(error_model="numpy", refcount=False)
    def attempt(t, hh, y, yn, p, sq, mw, rtol, atol, st):
        """Factor and attempt one step of size hh from (t, y); err (inf if singular)."""
        U, R, J, M, Minv = mw
        if not factor(J, M, Minv, hh):
            return np.inf
        return stages(t, hh, y, R[R_F0], R[R_FT], st[W_TDEP] != 0.0, Minv, p, sq, U,
                      R[R_YT], R[R_R], yn, rtol, atol)

    @njit(inline="always", error_model="numpy", refcount=False)
    def advance(mw):
        pass

    @njit(inline="always", error_model="numpy", refcount=False)
    def on_reject(err, hh, st):
        return hh / step_divisor(err)

    @njit(inline="always", error_model="numpy", refcount=False)
    def on_accept(err_trial, hh_trial, err, hh, st):
        h_next = hh / accept_divisor(err, hh, st[W_HOLD], st[W_ERROLD], st[W_REJ] != 0.0)
        st[W_HOLD], st[W_ERROLD] = hh, max(1e-2, err)
        return h_next

    return Method(alloc, 3, 3, s - 1, restart, prepare, attempt, coeffs, dense_eval, advance,
                  on_reject, on_accept)


def make_stepper(problem) -> Stepper:
    """Kernel factory (protocol in engine.integrators)."""
    return adaptive.make_stepper(problem, make_method(problem))
