"""The one adaptive step loop: step control, exact stops, kink landing, grazing probe,
sampling, recording and counters, for any method reduced to its parts (:class:`Method`).

In the spirit of scipy's ``_ivp`` (``OdeSolver.step`` around a method's ``_step_impl``) and
diffrax (a stepping loop around a solver's ``step`` and a controller's ``adapt_step_size``),
a method says only how to attempt one step, how to interpolate it and how to choose the
next step size; this driver does everything else, identically for every method.

- Segments end exactly on ``t1`` (assigned); the step is stretched to it when within 1 % of
  ``h``. The step size carries over between segments (``fresh`` restarts it, see
  :mod:`engine.integrators`).
- Kinks: after an accepted trial the problem's event functions are evaluated at its end; if
  one changed sign (or, with ``problem.graze``, dipped through zero and back inside the
  step), its root theta* is found on the dense output (:mod:`engine.integrators.events`)
  and the step is retaken from ``t`` with ``theta* h`` so that it ends on the kink (the
  discarded trial counts as rejected). An error estimate is blind to a corner inside a step
  (measured on Fig. 10 with DP5: error stuck near 1e-4 whatever rtol); landing on it
  restores the tolerance-proportional error.
- A landing that reached its root moves the end value to the far side (``past_corner``),
  so the next step sees a crossing back as a sign change. One that fell short (the dense
  output is only O(h^p) exact across the corner) is found again by the next step, from the
  near side, at most ``MAX_SHORT`` times in a row before the kink is muted for one
  step: a grazing kink (``u -> 0`` with ``du/dt -> 0``, e.g. W = v_ref) or one that rounding
  cannot reach (``u = v - W`` one ulp short) is passed. A landing shorter than
  ``LANDING_FLOOR * max(1, |t|)`` crosses the corner instead of landing on it
  (a corner hovering within round-off of ``t`` would otherwise repeat zero-length steps).
  One policy for every method (measured against an exact-sticking automaton: docs/ACCURACY.md).
- Under a sine dither, a scene whose switches mark jumps or change modes (``period_cap``)
  steps at most a quarter of the dither period: within it the dither has at most one
  extremum, so a reversal of ``u`` and back inside one step is the one dip the grazing probe
  looks for (a heuristic, not a bound; without it a GMS slider stepped over reversals:
  ``gms-3-reversals``, docs/ACCURACY.md 5.4).
- Discrete modes (engine.contract: stick/slip of a GMS element): after each accepted step the
  law's ``update_modes`` gets the step-end state and the index of the switch the step landed
  on (-1: none; a landing may stop a hair short of its root, so the index, not the sign of
  the switching function there, says that it was reached); when a mode changed, the
  switching functions are evaluated anew and cached stages refreshed as after a dither
  switch. (At a square-wave switch the driver updates them, engine.integrators.driver.) A
  switch whose root lies too close to a step's start to land on (``th_min``; GMS elements
  that reach their shares a hair apart) was reached at the start: its mode changes there
  and the step is retaken (``at_start``, once per step). Crossed instead, an element slipped
  a tolerance-dependent step late (``gms-3-servo-square``, docs/ACCURACY.md 5.6).
- ``FAILED`` once accepted plus rejected steps reach ``cfg.max_steps`` or the step
  underflows (``h < 1e-14 max(1, |t|)``); ``NON_FINITE`` when it underflows because the
  error is not finite (the state blew up).

Work storage of one point, allocated once per block: ``(mw, Q, Y, G, st)`` with ``mw`` the
method's own scratch (its ``alloc()``), ``Q`` the dense-output coefficients, ``Y`` the rows
``yn`` (end of the step), ``ym`` (midpoint, for observers) and ``ytmp``, ``G`` the event
values at step start / end / locator scratch / grazing probe x2, and ``st`` the scalar state:
the slots ``W_*`` below, then the method's own from ``W_METHOD`` on.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from .. import params as P
from .. import status as S
from ..jit import njit
from .events import (make_dip_before, make_grazing_probe, make_locator, make_start_switch,
                     past_corner, sign_change)
from .problem import (
    CTR_EVALS,
    CTR_REJECTED,
    CTR_STEPS,
    FRESH_NONE,
    FRESH_START,
    FRESH_SWITCH,
    Stepper,
    make_sampler,
    no_modes,
    record_step,
    sample_due,
)

STRETCH = 1.01        # take the rest of a segment when it is within 1 % of h
EVENT_MARGIN = 1e-12  # roots closer than this (in theta) to a step end are not landed on
LANDING_FLOOR = 1e-12  # landings shorter than this times max(1, |t|) cross the corner instead
MAX_SHORT = 2         # landings in a row that may fall short of a kink before it is passed
UNDERFLOW = 1e-14     # a step below this times max(1, |t|) fails
# scalar work state: step size, reject flag, next sampling index, short landings in a row
W_H, W_REJ, W_K, W_SHORT = 0, 1, 2, 3
W_METHOD = 4          # the method's own slots start here
RETAKE = -2           # land(): a switch at the step's start changed the modes there


class Method(NamedTuple):
    """An adaptive method's parts for one problem (njit functions, compile-time constants).

    ``mw`` is the method's scratch (``alloc()``), ``st`` the driver's scalar state (the
    method may keep its own slots from ``W_METHOD`` on and may read ``st[W_REJ]``, 1.0 when
    the previous attempt of this step was rejected).
    """

    alloc: Callable        # alloc() -> mw
    n_state: int           # the method's scalar slots in st
    n_dense: int           # rows of the dense-output coefficients Q
    attempt_evals: int     # rhs evaluations per attempt
    restart: Callable      # restart(t0, t1, y, p, sq, fresh, mw, rtol, atol, st) -> evals:
    #                        a new start (FRESH_START) or a switch of the dither sign: refresh
    #                        cached stages, and choose a step size st[W_H] where needed
    prepare: Callable      # prepare(t, y, h, t1, p, sq, mw, G, rtol, atol, st) -> evals:
    #                        once per step, before its attempts (e.g. a Jacobian)
    attempt: Callable      # attempt(t, hh, y, yn, p, sq, mw, rtol, atol, st) -> err:
    #                        the step of size hh from (t, y) into yn; err <= 1 accepts
    coeffs: Callable       # coeffs(y, yn, mw, Q): the attempted step's dense output
    dense_eval: Callable   # dense_eval(y, hh, Q, theta, out): the state at t + theta hh
    advance: Callable      # advance(mw): after an accepted step (e.g. FSAL)
    on_reject: Callable    # on_reject(err, hh, st) -> h: the retry after a rejection
    on_accept: Callable    # on_accept(err_trial, hh_trial, err, hh, st) -> h_next, after an
    #                        accepted step (hh, err), which may be the landing on a kink
    #                        retaken from the trial (hh_trial, err_trial)
    shapes: tuple | None = None  # alloc()'s array shapes (engine.integrators.Stepper.shapes)


def make_stepper(problem, method: Method) -> Stepper:
    """The kernel (protocol in :mod:`engine.integrators`) of ``method`` on ``problem``."""
    n, n_err, observe = problem.n, problem.n_err, problem.observe
    n_ev, events = problem.n_events, problem.events
    record, needs_mid, sampling = problem.record, problem.needs_mid, problem.sampling
    m_alloc, restart, prepare, attempt = method.alloc, method.restart, method.prepare, method.attempt
    coeffs, dense_eval, advance = method.coeffs, method.dense_eval, method.advance
    on_reject, on_accept = method.on_reject, method.on_accept
    attempt_evals, n_dense = method.attempt_evals, method.n_dense
    locate = make_locator(events, n_ev, dense_eval)
    graze, probe = problem.graze and n_ev > 0, make_grazing_probe(events, n_ev, dense_eval)
    period_cap = problem.period_cap if n_ev > 0 else 0.0
    before = make_dip_before(events, n_ev, dense_eval, locate)
    dips = graze and problem.update_modes is not None   # (the static laws: no need measured)
    first_sample, emit = make_sampler(problem, dense_eval)
    n_g, n_st = max(n_ev, 1), W_METHOD + method.n_state
    modal = problem.update_modes is not None
    update_modes = problem.update_modes if modal else no_modes
    at_start = make_start_switch(events, n_ev, dense_eval, update_modes)

    @njit(error_model="numpy", entry=True)   # (engine.api calls it)
    def alloc():
        return (m_alloc(), np.zeros((n_dense, n)), np.zeros((3, n)), np.zeros((5, n_g)),
                np.zeros(n_st))

    # inlined (numba IR), as are the method's small parts: a call per step, with the work
    # tuple passed by value, cost DP5 15 % on the anchor scenes (1.23x -> 1.42x of C)
    @njit(inline="always", error_model="numpy", refcount=False)
    def land(t, hh, err, y, p, sq, work, rtol, atol, ctr, may_retake):
        """After an accepted trial of size hh: if an event changed sign inside it, retake
        the step so that it ends on the earliest root. Returns (hh, err, landed): the index
        of the event the retaken step ends on, -1 when it was not retaken, RETAKE when a
        law's switch too close to the start to land on changed its modes at the start
        (the caller then retakes the step from there)."""
        mw, Q, Y, G, st = work
        yn, ytmp = Y[0], Y[2]
        events(t + hh, yn, p, sq, G[1])
        # roots closer than this to the start are crossed, not landed on (module docstring)
        th_min = max(EVENT_MARGIN, LANDING_FLOOR * max(1.0, abs(t)) / hh)
        th, idx = 2.0, -1
        crossed = sign_change(G[0], G[1], n_ev)
        if crossed or graze:
            coeffs(y, yn, mw, Q)
        if modal and crossed and may_retake and at_start(t, hh, y, p, sq, Q, G, ytmp, th_min):
            return hh, err, RETAKE
        if crossed:
            th, idx = locate(t, hh, y, Q, p, sq, G[0], G[1], ytmp, G[2], 1.0, th_min)
            if dips and idx >= 0:   # another event's dip before that root
                th, idx = before(t, hh, y, Q, p, sq, G[0], G[3], ytmp, G[2], th, idx, th_min)
        if graze and idx < 0:   # a dip through zero and back inside the step (the probe
            #                     skips events whose ends differ: one crossed at the start)
            th_b = probe(t, hh, y, Q, p, sq, G[0], G[1], ytmp, G[3], G[4])
            if th_b < 1.0:
                th, idx = locate(t, hh, y, Q, p, sq, G[0], G[3], ytmp, G[2], th_b, th_min)
        if idx < 0:
            return hh, err, -1
        if not (EVENT_MARGIN < th < 1.0 - EVENT_MARGIN
                and th * hh > LANDING_FLOOR * max(1.0, abs(t))):
            return hh, err, -1
        ctr[CTR_REJECTED] += 1
        hh = th * hh
        ctr[CTR_EVALS] += attempt_evals
        err = attempt(t, hh, y, yn, p, sq, mw, rtol, atol, st)
        if err <= 1.0:
            events(t + hh, yn, p, sq, G[1])
            if G[1, idx] * G[0, idx] <= 0.0:   # reached or passed
                st[W_SHORT] = 0.0
                past_corner(G[0], G[1], idx)   # the locator aims at the far side
            else:
                st[W_SHORT] += 1.0
                if st[W_SHORT] > MAX_SHORT:
                    G[1, idx] = 0.0   # unreachable: mute it for the next step
                    st[W_SHORT] = 0.0
        return hh, err, idx

    # inlined into the driver's loop over stops (engine.integrators.driver): on the anchor
    # scenes every half-period is one step, and the call per segment (work tuple, config
    # record and arrays passed by value) cost DP5 ~12 % (1.25x -> 1.10x of C, no kinks)
    @njit(inline="always", error_model="numpy", refcount=False)
    def segment(work, y, t0, t1, p, sq, fresh, cfg, obs, ctr, rec):
        mw, Q, Y, G, st = work
        yn, ym = Y[0], Y[1]
        rtol, atol = cfg.rtol, cfg.atol_i[:n_err]   # atol per component
        if fresh != FRESH_NONE:
            if n_ev:
                events(t0, y, p, sq, G[0])
            ctr[CTR_EVALS] += restart(t0, t1, y, p, sq, fresh, mw, rtol, atol, st)
            st[W_SHORT] = 0.0
            if sampling and fresh == FRESH_START:
                st[W_K] = first_sample(t0, y, p, sq, cfg, obs, ctr, rec)
        h = st[W_H]
        h_cap = math.inf
        if (period_cap > 0.0 and p[P.W] != 0.0 and p[P.OMEGA] > 0.0
                and math.isfinite(p[P.OMEGA])):
            h_cap = period_cap * (2.0 * math.pi / p[P.OMEGA])
        t = t0
        may_retake = True
        while t < t1:
            h = min(h, h_cap)
            ctr[CTR_EVALS] += prepare(t, y, h, t1, p, sq, mw, G, rtol, atol, st)
            while True:
                rem = t1 - t
                last = rem <= min(STRETCH * h, h_cap)
                hh = rem if last else h
                ctr[CTR_EVALS] += attempt_evals
                err = attempt(t, hh, y, yn, p, sq, mw, rtol, atol, st)
                if ctr[CTR_STEPS] + ctr[CTR_REJECTED] >= cfg.max_steps:
                    st[W_H] = h
                    return S.FAILED
                hh_trial, err_trial = hh, err
                landed = -1
                if err <= 1.0 and n_ev:
                    hh, err, landed = land(t, hh, err, y, p, sq, work, rtol, atol, ctr,
                                           may_retake)
                    last = last and landed < 0
                if err <= 1.0 or landed == RETAKE:
                    break
                ctr[CTR_REJECTED] += 1
                h = on_reject(err, hh, st)
                st[W_REJ] = 1.0
                if h < UNDERFLOW * max(1.0, abs(t)):
                    st[W_H] = h
                    return S.FAILED if math.isfinite(err) else S.NON_FINITE
            if landed == RETAKE:   # the modes changed at t: the step again, with them
                may_retake = False
                ctr[CTR_REJECTED] += 1
                ctr[CTR_EVALS] += restart(t, t1, y, p, sq, FRESH_SWITCH, mw, rtol, atol, st)
                continue
            may_retake = True
            h_next = on_accept(err_trial, hh_trial, err, hh, st)
            if needs_mid:
                coeffs(y, yn, mw, Q)
                dense_eval(y, hh, Q, 0.5, ym)
            t_new = t1 if last else t + hh
            observe(t, y, t_new, yn, ym, p, sq, obs)
            if sampling and sample_due(st[W_K], cfg, t_new):
                if not needs_mid:   # else Q holds this step's coefficients already
                    coeffs(y, yn, mw, Q)
                st[W_K] = emit(t, hh, t_new, y, yn, Q, p, sq, cfg, obs, ctr, rec, st[W_K],
                               Y[2])
            for i in range(n):
                y[i] = yn[i]
            advance(mw)
            for i in range(n_ev):
                G[0, i] = G[1, i]
            if modal and update_modes(t_new, y, p, sq, landed):
                # a mode changed (an element stuck or slipped, on the switch just landed
                # on): the right-hand side and the switching functions changed with it
                if n_ev:
                    events(t_new, y, p, sq, G[0])
                ctr[CTR_EVALS] += restart(t_new, t1, y, p, sq, FRESH_SWITCH, mw, rtol, atol,
                                          st)
            ctr[CTR_STEPS] += 1
            if record and rec.shape[0] > 0:   # the check here, not in the call: ~10 %
                record_step(rec, ctr, cfg, t_new, y)
            st[W_REJ] = 0.0
            h = max(h, h_next) if (last or hh < h) else h_next
            t = t_new
        st[W_H] = h
        return S.OK

    shapes = None if method.shapes is None else (
        method.shapes, (n_dense, n), (3, n), (5, n_g), (n_st,))
    return Stepper(alloc, segment, shapes)
