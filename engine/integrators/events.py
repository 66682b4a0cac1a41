"""Locating sign changes of kink functions inside an accepted step (dense output + Illinois).

A method hands over the dense-output polynomial of its step; the root ``theta`` in (0, 1)
of the earliest event is found by the Illinois variant of regula falsi (Dowell & Jarratt
1971), which keeps the bracket and converges superlinearly, using dense-output states only
(no right-hand-side evaluations).
"""
from __future__ import annotations

import math

from ..jit import njit

THETA_TOL = 1e-13   # bracket width on theta at which the root is taken
MAX_ITER = 60


def make_locator(events, n_events, dense_eval):
    """njit ``locate(t, hh, y, Q, p, sq, g0, g1, ytmp, gtmp, th_b=1.0) -> (theta, index)``.

    ``g0``/``g1``: event values at theta = 0 / ``th_b`` (the end of the bracket, 1 unless
    a grazing probe found a sign change earlier); ``dense_eval(y, hh, Q, theta, out)``
    writes the dense state at theta. Returns ``(2.0, -1)`` when no event changes sign.
    """
    @njit(error_model="numpy", refcount=False)
    def _illinois(i, t, hh, y, Q, p, sq, b, fa, fb, ytmp, gtmp):
        a = 0.0
        side = 0
        for _ in range(MAX_ITER):
            c = (a * fb - b * fa) / (fb - fa)
            if not (a < c < b):
                c = 0.5 * (a + b)
            dense_eval(y, hh, Q, c, ytmp)
            events(t + c * hh, ytmp, p, sq, gtmp)
            fc = gtmp[i]
            if fc == 0.0:
                return c
            if (fc > 0.0) == (fb > 0.0):
                b, fb = c, fc
                if side == -1:
                    fa *= 0.5
                side = -1
            else:
                a, fa = c, fc
                if side == 1:
                    fb *= 0.5
                side = 1
            if b - a < THETA_TOL:
                break
        # the root lies in [a, b]; b is on the far side, a on the near side
        return a if abs(fa) < abs(fb) else b

    @njit(error_model="numpy", refcount=False)
    def locate(t, hh, y, Q, p, sq, g0, g1, ytmp, gtmp, th_b=1.0):
        best, idx = 2.0, -1
        for i in range(n_events):
            if g0[i] * g1[i] < 0.0:
                th = _illinois(i, t, hh, y, Q, p, sq, th_b, g0[i], g1[i], ytmp, gtmp)
                if th < best:
                    best, idx = th, i
        return best, idx

    return locate



def make_grazing_probe(events, n_events, dense_eval):
    """njit ``probe(t, hh, y, Q, p, sq, g0, g1, ytmp, gb, ga) -> theta_b`` for steps whose
    ends show no sign change: an event function that dips through zero and back *inside* one
    step (a grazing crossing) is invisible at the ends. Where that skips a jump of the
    right-hand side -- the Karnopp band of a static law, which a prescribed velocity can
    touch for a few milliseconds per period -- a whole stick phase is lost (measured: F_mean
    of a sine-dithered Stribeck contact 0.75 % off, tests/engine/test_engine_grazing.py).

    For each event that moves toward zero at the step start and away from it at the end,
    the cubic Hermite interpolant of ``g(theta)`` (values at the ends, slopes by one-sided
    differences on the dense output) locates its extremum ``theta_m``; the events are
    evaluated there on the dense output (into ``gb``) and ``theta_m`` is returned when one
    has the opposite sign of ``g0`` -- the bracket ``[0, theta_m]`` then holds the first
    root. Otherwise 2.0. Two extra event evaluations per step, compiled in only for scenes
    whose events mark jumps (``Problem.graze``).
    """
    eps = 1e-6

    @njit(error_model="numpy", refcount=False)
    def probe(t, hh, y, Q, p, sq, g0, g1, ytmp, gb, ga):
        dense_eval(y, hh, Q, eps, ytmp)
        events(t + eps * hh, ytmp, p, sq, ga)
        dense_eval(y, hh, Q, 1.0 - eps, ytmp)
        events(t + (1.0 - eps) * hh, ytmp, p, sq, gb)
        best = 2.0
        for i in range(n_events):
            a, b = g0[i], g1[i]
            if not a * b > 0.0:
                continue                          # a crossing, or a muted event
            d0, d1 = (ga[i] - a) / eps, (b - gb[i]) / eps
            if not (d0 * a < 0.0 and d1 * b > 0.0):
                continue                          # not heading to zero and back
            # p(th) = a + d0 th + B th^2 + C th^3; p'(th) = d0 + 2 B th + 3 C th^2 = 0
            B = 3.0 * (b - a) - 2.0 * d0 - d1
            C = 2.0 * (a - b) + d0 + d1
            th = 2.0
            if abs(C) < 1e-12 * (abs(B) + abs(d0)):
                if B != 0.0:
                    th = -d0 / (2.0 * B)
            else:
                disc = B * B - 3.0 * C * d0
                if disc >= 0.0:
                    r = math.sqrt(disc)
                    for cand in ((-B - r) / (3.0 * C), (-B + r) / (3.0 * C)):
                        if 0.0 < cand < th:
                            th = cand
            if 0.0 < th < best:
                best = th
        if best < 1.0:
            dense_eval(y, hh, Q, best, ytmp)
            events(t + best * hh, ytmp, p, sq, gb)
            for i in range(n_events):
                if g0[i] * gb[i] < 0.0:
                    return best
        return 2.0

    return probe
