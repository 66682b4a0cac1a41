"""Locating sign changes of kink functions inside an accepted step (dense output + Illinois).

A method hands over the dense-output polynomial of its step; the root ``theta`` in (0, 1)
of the earliest event is found by the Illinois variant of regula falsi (Dowell & Jarratt
1971), which keeps the bracket and converges superlinearly, using dense-output states only
(no right-hand-side evaluations). The root is taken on its far side (within 1e-13 in theta).

Events that mark *jumps* of the right-hand side (the static laws' Karnopp band) also get a
grazing probe (:func:`make_grazing_probe`): a dip through zero and back within one step,
and, for laws with modes, where another event's root was found in the step, a look for such a
dip before that root (:func:`make_dip_before`).
"""
from __future__ import annotations

import math

from ..jit import njit

THETA_TOL = 1e-13   # bracket width on theta at which the root is taken
MAX_ITER = 60
FAR_SIDE = 1e-300   # event value of a landing exactly on the corner, moved past it


@njit(error_model="numpy", refcount=False)
def sign_change(g0, g1, m):
    """True if any of the first m event functions changed sign (a zero is no change)."""
    for i in range(m):
        if g0[i] * g1[i] < 0.0:
            return True
    return False


@njit(error_model="numpy", refcount=False)
def past_corner(g0, g1, i):
    """After a landing on event ``i`` that reached its root: an end value of exactly zero
    is moved to the far side, so the next step starts beyond the corner and sees a crossing
    back (leaving a band it just entered) as a sign change."""
    if g1[i] == 0.0:
        g1[i] = -math.copysign(FAR_SIDE, g0[i])


def make_locator(events, n_events, dense_eval):
    """njit ``locate(t, hh, y, Q, p, sq, g0, g1, ytmp, gtmp, th_b=1.0, th_min=0.0) ->
    (theta, index)``: the earliest root beyond ``th_min``.

    ``g0``/``g1``: event values at theta = 0 / ``th_b`` (the end of the bracket, 1 unless
    a grazing probe found a sign change earlier); ``dense_eval(y, hh, Q, theta, out)``
    writes the dense state at theta. Returns ``(2.0, -1)`` when no event changes sign
    beyond ``th_min``. A root at or before ``th_min`` (too close to the step's start to land
    on: the caller crosses it) does not hide a later one: a GMS slider landed on a reversal
    a hair short, the next step found that root at its very start, crossed it, and with it
    the three elements' switches later in the same step (each element stuck 0.6 % past its
    share, ``F_mean`` 1 % off at rtol 1e-6).
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
        # the root lies in [a, b]; b is on the far side, a on the near side. Land on the
        # far side: the next step then starts past the corner, and a crossing back within
        # it (leaving the Karnopp band it just entered) is a sign change it sees. (Not
        # converged within MAX_ITER: the end closer to the root.)
        if b - a < THETA_TOL:
            return b
        return a if abs(fa) < abs(fb) else b

    @njit(error_model="numpy", refcount=False)
    def locate(t, hh, y, Q, p, sq, g0, g1, ytmp, gtmp, th_b=1.0, th_min=0.0):
        best, idx = 2.0, -1
        for i in range(n_events):
            if g0[i] * g1[i] < 0.0:
                th = _illinois(i, t, hh, y, Q, p, sq, th_b, g0[i], g1[i], ytmp, gtmp)
                if th_min < th < best:
                    best, idx = th, i
        return best, idx

    return locate


GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)
GRAZE_ITER = 48     # golden-section steps: the bracket shrinks to 0.618**48 ~ 1e-10


def make_grazing_probe(events, n_events, dense_eval):
    """njit ``probe(t, hh, y, Q, p, sq, g0, g1, ytmp, gb, ga) -> theta_b`` for steps whose
    ends show no sign change: an event function that dips through zero and back *inside* one
    step (a grazing crossing) is invisible at the ends. Where that skips a jump of the
    right-hand side -- the Karnopp band of a static law, which a prescribed velocity can
    touch for a few milliseconds per period -- a whole stick phase is lost (measured: F_mean
    of a sine-dithered Stribeck contact 0.75 % off, tests/engine/test_engine_grazing.py).

    An event is a candidate when it moves toward zero at the step start and away from it at
    the end (slopes by one-sided differences on the dense output). Its extremum on the dense
    output is then searched by golden section, stopping as soon as a point on the other side
    of zero turns up: that ``theta`` is returned (``gb`` = the events there), so
    ``[0, theta]`` brackets the first root. Otherwise 2.0. Two event evaluations per step,
    and a search (at most GRAZE_ITER dense evaluations) per candidate event -- a few per
    minimum of ``|u|`` near the band; compiled in only for scenes whose events mark jumps
    (``Problem.graze``).
    """
    eps = 1e-6

    @njit(error_model="numpy", refcount=False)
    def side(t, hh, y, Q, p, sq, i, th, ytmp, gb):
        dense_eval(y, hh, Q, th, ytmp)
        events(t + th * hh, ytmp, p, sq, gb)
        return gb[i]

    @njit(error_model="numpy", refcount=False)
    def probe(t, hh, y, Q, p, sq, g0, g1, ytmp, gb, ga):
        dense_eval(y, hh, Q, eps, ytmp)
        events(t + eps * hh, ytmp, p, sq, ga)
        dense_eval(y, hh, Q, 1.0 - eps, ytmp)
        events(t + (1.0 - eps) * hh, ytmp, p, sq, gb)
        for i in range(n_events):    # ga[i] <- 1.0 for the candidates (gb is reused below)
            a, b = g0[i], g1[i]
            heading = (ga[i] - a) * a < 0.0 and (b - gb[i]) * b > 0.0
            ga[i] = 1.0 if (a * b > 0.0 and heading) else 0.0
        best = 2.0
        for i in range(n_events):
            if ga[i] == 0.0:
                continue                          # a crossing, muted, or no dip
            s = 1.0 if g0[i] > 0.0 else -1.0      # minimise s g on [0, 1]
            lo, hi = 0.0, 1.0
            x1, x2 = hi - GOLDEN, lo + GOLDEN
            f1 = s * side(t, hh, y, Q, p, sq, i, x1, ytmp, gb)
            f2 = s * side(t, hh, y, Q, p, sq, i, x2, ytmp, gb)
            for _ in range(GRAZE_ITER):
                if f1 < 0.0 or f2 < 0.0:
                    best = min(best, x1 if f1 < 0.0 else x2)
                    break
                if f1 < f2:
                    hi, x2, f2 = x2, x1, f1
                    x1 = hi - GOLDEN * (hi - lo)
                    f1 = s * side(t, hh, y, Q, p, sq, i, x1, ytmp, gb)
                else:
                    lo, x1, f1 = x1, x2, f2
                    x2 = lo + GOLDEN * (hi - lo)
                    f2 = s * side(t, hh, y, Q, p, sq, i, x2, ytmp, gb)
        if best < 1.0:
            dense_eval(y, hh, Q, best, ytmp)
            events(t + best * hh, ytmp, p, sq, gb)
            return best
        return 2.0

    return probe


DIP_SAMPLES = 3     # interior points of [0, root] read by make_dip_before's check
NEAR = 1e-9         # and one this far short of the root (relative)


def make_dip_before(events, n_events, dense_eval, locate):
    """njit ``before(t, hh, y, Q, p, sq, g0, gs, ytmp, gtmp, th, idx, th_min) -> (theta,
    index)`` for steps in which event ``idx`` was located at ``th``: whether another event crossed
    zero *earlier* and came back by ``th`` (or was masked there), which the ends of the step
    cannot show. GMS: a stuck element's force passes its share of the Stribeck curve while
    ``|u|`` falls, the share grows faster near ``u = 0`` and is above the force again at the
    reversal, and there, inside the band, the switch is not read at all. The grazing probe
    runs only on steps without a sign change, so the landing on the reversal lost the slip
    (rtol 1e-5 on the dithered slider: tests/engine/test_models_reference.py,
    ``gms-3-reversals``). Or a share crossed before another element's, not back above the
    force by that root: the update at the landing slipped it late (0.17 % past its share;
    stick_fraction 9e-4 off at rtol 1e-8, omega 1000). The events are read at
    ``DIP_SAMPLES`` evenly spaced points inside ``(0, th)`` and just short of ``th``; at
    the first that shows a sign change, the earliest root on ``[0, that point]`` beyond
    ``th_min`` replaces ``(th, idx)``. ``gs``, ``gtmp``: scratch. A few
    dense evaluations per landing, for scenes whose switches mark jumps and change modes
    (``Problem.graze`` and ``update_modes``). Not for the static laws: on a sine-dithered
    Stribeck slider it changed no output by more than its noise, for 7 % more time at rtol
    1e-8."""
    @njit(error_model="numpy", refcount=False)
    def before(t, hh, y, Q, p, sq, g0, gs, ytmp, gtmp, th, idx, th_min):
        for k in range(1, DIP_SAMPLES + 2):
            # evenly inside (0, th), then just short of th (crossed and not back by then)
            ths = th * k / (DIP_SAMPLES + 1) if k <= DIP_SAMPLES else th * (1.0 - NEAR)
            if not ths > th_min:
                continue
            dense_eval(y, hh, Q, ths, ytmp)
            events(t + ths * hh, ytmp, p, sq, gs)
            if sign_change(g0, gs, n_events):
                th2, idx2 = locate(t, hh, y, Q, p, sq, g0, gs, ytmp, gtmp, ths, th_min)
                if idx2 >= 0:   # (th2 <= ths < th)
                    return th2, idx2
                # only a root too close to the start, crossed: read on
        return th, idx

    return before


def make_start_switch(events, n_events, dense_eval, update_modes):
    """njit ``at_start(t, hh, y, p, sq, Q, G, ytmp, th_min) -> changed`` for laws with modes:
    the switches whose root lies too close to the step's start to land on (at or before
    ``th_min``, where the locator does not look) were reached at the start, so their modes
    change there (``update_modes`` with each one's index; ``G[0]`` re-read when one did).
    GMS elements whose deflections moved together while stuck reach their shares a hair
    apart: after the landing on the first, the next one's root was crossed and its element
    slipped at the step's end, a tolerance-dependent step late (docs/ACCURACY.md 5.6)."""
    @njit(inline="always", error_model="numpy", refcount=False)
    def at_start(t, hh, y, p, sq, Q, G, ytmp, th_min):
        dense_eval(y, hh, Q, th_min, ytmp)
        events(t + th_min * hh, ytmp, p, sq, G[2])
        changed = False
        for j in range(n_events):
            if G[0, j] != 0.0 and G[0, j] * G[2, j] <= 0.0 and G[0, j] * G[1, j] < 0.0:
                if update_modes(t, y, p, sq, j):
                    changed = True
        if changed:
            events(t, y, p, sq, G[0])
        return changed

    return at_start
