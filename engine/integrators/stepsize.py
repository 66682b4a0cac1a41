"""Starting step size shared by the adaptive methods (Hairer, Norsett & Wanner I, II.4).

One extra right-hand-side evaluation: ``h0`` from the sizes of ``y`` and ``f(t, y)``, an
explicit Euler probe for the second derivative, then
``h1 = (0.01 / max(d1, d2)) ** (1 / k)`` with ``k`` the order of the local error the
controller sees (5 for DP5's local error of a 4th-order estimate in Hairer's dopri5.f, 5
for RODAS's order-4 method), capped at the segment length.
"""
from __future__ import annotations

import math

from ..jit import njit


def make_initial_step(n, n_err, rhs, error_order):
    """njit ``h0(t, y, f0, p, sq, y1, f1, rtol, atol, t_span) -> h``.

    ``n_err`` leading components are under error control (``atol[i]`` per component);
    ``y1``, ``f1`` are scratch rows.
    """
    @njit(error_model="numpy", refcount=False)
    def initial_step(t, y, f0, p, sq, y1, f1, rtol, atol, t_span):
        d0 = d1 = 0.0
        for i in range(n_err):
            sc = atol[i] + rtol * abs(y[i])
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
            d2 += ((f1[i] - f0[i]) / (atol[i] + rtol * abs(y[i]))) ** 2
        d2 = math.sqrt(d2 / n_err) / h0
        if max(d1, d2) <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / error_order)
        return min(100.0 * h0, h1, t_span)
    return initial_step
