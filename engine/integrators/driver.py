"""The shared driver: the stop grid of one point, around any method's ``segment``.

Stops (DESIGN.md §1: "an integrator must step exactly onto them, never across them"):

- square-velocity: every switch ``t_k = k * (pi / omega)`` (computed from k, never
  accumulated, :func:`engine.dither.switch_time`); the sign on ``(t_k, t_{k+1})`` is
  ``square_sign(k)``; ``sq`` changes there, so the segment after a switch gets
  ``FRESH_SWITCH``, and a law's modes follow u's jump there (``make_solve``). Period
  boundaries are the even k.
- sine dither: every period ``k * (2 pi / omega)`` only when an observable needs the
  period boundaries (``period_stops``); the sign stays +1 and caches stay valid.
- always ``t_transient`` (the observer starts there) and ``t_end``.

The fixed step of non-adaptive methods (``cfg.h``) is set here per point by
:func:`engine.dither.fixed_step`: ``(pi / omega) / steps_per_period`` for a square wave
(divides the half-period), ``(2 pi / omega) / steps_per_period`` for a sine (divides the
period), ``Settings.h`` without dither or without a finite positive omega (methods split
each segment into ``ceil(length / h)`` equal steps).
"""
from __future__ import annotations

import math

import numpy as np

from .. import params as P
from .. import status as S
from ..dither import CODE, NONE, SQUARE_VELOCITY, fixed_step, square_sign, switch_time
from ..jit import njit
from .problem import FRESH_NONE, FRESH_START, FRESH_SWITCH, no_modes


def make_solve(stepper, observer, dither: str, update_modes=None):
    """njit ``solve(work, y, p, cfg, obs, ctr, rec) -> status`` for one point.

    ``y`` holds the initial state and is advanced to ``t_end`` in place; ``obs`` must have
    been initialised (``observer.init``). ``update_modes``: the law's, when it has modes
    (engine.contract); at a square-wave switch u jumps, perhaps through zero (a reversal no
    step lands on), so the modes follow there, before the next segment (``landed = -1``).
    Without it a GMS element kept slipping the old way for that segment's first step:
    ``F_mean`` 20 % off at rtol 1e-12 (``gms-3-square``, docs/ACCURACY.md 5.6).
    """
    modal = update_modes is not None
    switch_modes = update_modes if modal else no_modes
    kind = CODE[dither]
    square = kind == SQUARE_VELOCITY
    grid = square or (kind != NONE and observer.period_stops)
    segment, start, stop = stepper.segment, observer.start, observer.stop

    @njit(error_model="numpy", refcount=False)
    def solve(work, y, p, cfg, obs, ctr, rec):
        t_end, t_tr, omega = p[P.T_END], p[P.T_TRANSIENT], p[P.OMEGA]
        cfg.h = fixed_step(kind, omega, cfg.steps_per_period, cfg.h_free)
        t = 0.0
        k = 1
        sq = 1.0
        fresh = FRESH_START
        started = False
        if t_tr <= 0.0:
            start(t, y, p, sq, obs)
            started = True
        while t < t_end:
            t_grid = np.inf
            if grid:
                t_grid = switch_time(k, omega) if square else switch_time(2 * k, omega)
            t_next = min(t_grid, t_end)
            if not started and t_tr < t_next:
                t_next = t_tr
            status = segment(work, y, t, t_next, p, sq, fresh, cfg, obs, ctr, rec)
            if status != S.OK:
                return status
            t = t_next
            fresh = FRESH_NONE
            if not started and t == t_tr:
                start(t, y, p, sq, obs)
                started = True
            if t == t_grid:
                stop(t, y, p, (k % 2 == 0) if square else True, obs)
                if square:
                    sq = square_sign(k)
                    fresh = FRESH_SWITCH
                    if modal:
                        switch_modes(t, y, p, sq, -1)
                k += 1
        for i in range(y.size):
            if not math.isfinite(y[i]):
                return S.NON_FINITE
        return S.OK
    return solve
