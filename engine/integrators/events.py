"""Locating sign changes of kink functions inside an accepted step (dense output + Illinois).

A method hands over the dense-output polynomial of its step; the root ``theta`` in (0, 1)
of the earliest event is found by the Illinois variant of regula falsi (Dowell & Jarratt
1971), which keeps the bracket and converges superlinearly, using dense-output states only
(no right-hand-side evaluations).
"""
from __future__ import annotations

from ..jit import njit

THETA_TOL = 1e-13   # bracket width on theta at which the root is taken
MAX_ITER = 60


def make_locator(events, n_events, dense_eval):
    """njit ``locate(t, hh, y, Q, p, sq, g0, g1, ytmp, gtmp) -> (theta, index)``.

    ``g0``/``g1``: event values at theta = 0 / 1; ``dense_eval(y, hh, Q, theta, out)`` writes
    the dense state at theta. Returns ``(2.0, -1)`` when no event changes sign.
    """
    @njit(error_model="numpy", refcount=False)
    def _illinois(i, t, hh, y, Q, p, sq, fa, fb, ytmp, gtmp):
        a, b = 0.0, 1.0
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
    def locate(t, hh, y, Q, p, sq, g0, g1, ytmp, gtmp):
        best, idx = 2.0, -1
        for i in range(n_events):
            if g0[i] * g1[i] < 0.0:
                th = _illinois(i, t, hh, y, Q, p, sq, g0[i], g1[i], ytmp, gtmp)
                if th < best:
                    best, idx = th, i
        return best, idx

    return locate
