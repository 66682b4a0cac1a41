"""Phase bookkeeping of the observables: the accumulator layout and the measure of each step
in each phase (stick, pre-sliding, sliding, near-slip, the alpha histogram), from the
quadratic through the step's start, midpoint and end (engine.observables has the
definitions). Sticking runs open and close at the interpolated crossing instants.
"""
from __future__ import annotations

import math

import numpy as np

from .friction.elastoplastic import STICK, phase
from .jit import njit
from .outputs import VECTOR

# the accumulator obs: float64 slots
O_ON, O_T0, O_X0, O_Q0 = 0, 1, 2, 3
O_T_STICK, O_T_PRE, O_T_SLIP = 4, 5, 6
O_RUN, O_LONG, O_MAX = 7, 8, 9
O_VMIN, O_VMAX, O_XPREV, O_TPREV = 10, 11, 12, 13
O_T_NEAR = 14
O_R_STICK, O_R_SLIP, O_R_NEAR = 15, 16, 17   # rho at the stick edge (lam), at sliding
                                              # (1 - gap) and at alpha_near
O_R_EDGE = 18                   # rho at the inner alpha bin edges 1/N_HIST ... (N_HIST-1)/N_HIST
N_HIST = VECTOR["alpha_hist"][1]
O_HIST = O_R_EDGE + N_HIST - 1
O_SIZE = O_HIST + N_HIST


@njit(error_model="numpy")
def rho_of_alpha(a, lam):
    """The ratio ``rho = |z| / z_ss`` at which Eq. 2.7 gives ``alpha = a`` (0 < a < 1)."""
    return 0.5 * (1.0 + lam) + (1.0 - lam) / np.pi * math.asin(2.0 * a - 1.0)


@njit(inline="always", error_model="numpy")
def quad_coeffs(r0, rm, r1):
    """``(a, b)`` of the quadratic ``q(s) = a s^2 + b s + r0`` through ``(0, r0)``,
    ``(1/2, rm)``, ``(1, r1)``."""
    return 2.0 * (r0 + r1) - 4.0 * rm, 4.0 * rm - 3.0 * r0 - r1


@njit(error_model="numpy")
def quad_roots(a, b, c):
    """The roots of ``a s^2 + b s + c`` inside (0, 1), ascending; 2.0 marks 'none'."""
    s1, s2 = 2.0, 2.0
    if abs(a) <= 1e-12 * (abs(b) + abs(c)):
        if b != 0.0:
            s1 = -c / b
    else:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            qq = -0.5 * (b + math.copysign(math.sqrt(disc), b))
            x1 = qq / a
            x2 = c / qq if qq != 0.0 else x1
            s1, s2 = min(x1, x2), max(x1, x2)
    if not 0.0 < s1 < 1.0:
        s1, s2 = s2, 2.0
    if not 0.0 < s1 < 1.0:
        s1 = 2.0
    if not 0.0 < s2 < 1.0:
        s2 = 2.0
    return s1, s2


@njit(error_model="numpy")
def share_above(r0, rm, r1, thr):
    """Measure of ``{s in [0, 1]: q(s) >= thr}`` for the quadratic ``q`` through
    ``(0, r0)``, ``(1/2, rm)``, ``(1, r1)``."""
    if min(r0, rm, r1) >= thr and max(r0, rm, r1) == min(r0, rm, r1):
        return 1.0
    a, b = quad_coeffs(r0, rm, r1)
    c = r0 - thr
    s1, s2 = quad_roots(a, b, c)
    total, left = 0.0, 0.0
    for right in (s1, s2, 1.0):
        if right > 1.0:
            continue
        mid = 0.5 * (left + right)
        if (a * mid + b) * mid + c >= 0.0:
            total += right - left
        left = right
    return total


@njit(error_model="numpy")
def stick_pass(obs, t0, h, r0, rm, r1, lo, hi, long_stick):
    """Book the sticking part ``{lo < q(s) <= hi}`` of the step ``[t0, t0 + h]`` (``q``
    the quadratic through ``r0, rm, r1``) and the sticking runs it opens, extends and
    closes, at the interpolated crossing instants. Returns the sticking share of the step."""
    a, b = quad_coeffs(r0, rm, r1)
    p1, p2 = quad_roots(a, b, r0 - lo) if lo > -np.inf else (2.0, 2.0)
    p3, p4 = quad_roots(a, b, r0 - hi) if hi < np.inf else (2.0, 2.0)
    # the (at most four) breakpoints in ascending order: a small sorting network
    if p1 > p3:
        p1, p3 = p3, p1
    if p2 > p4:
        p2, p4 = p4, p2
    if p1 > p2:
        p1, p2 = p2, p1
    if p3 > p4:
        p3, p4 = p4, p3
    if p2 > p3:
        p2, p3 = p3, p2
    stick, left = 0.0, 0.0
    for right in (p1, p2, p3, p4, 1.0):
        if right > 1.0 or right <= left:
            continue
        mid = 0.5 * (left + right)
        q = (a * mid + b) * mid + r0
        sticking = lo < q <= hi
        if sticking:
            stick += right - left
        run_bookkeeping(obs, t0 + left * h, sticking, long_stick)
        left = right
    return stick


@njit(error_model="numpy")
def add_elasto(obs, t0, t1, r0, rm, r1, long_stick, hist):
    """Book the step ``[t0, t1]`` by the quadratic of ``rho`` (module docstring): stick at
    or below ``lam``, sliding above ``1 - gap``; sticking runs at the crossing instants."""
    h = t1 - t0
    stick = stick_pass(obs, t0, h, r0, rm, r1, -np.inf, obs[O_R_STICK], long_stick)
    slip = share_above(r0, rm, r1, obs[O_R_SLIP])
    obs[O_T_STICK] += h * stick
    obs[O_T_SLIP] += h * slip
    obs[O_T_PRE] += h * max(1.0 - stick - slip, 0.0)
    obs[O_T_NEAR] += h * share_above(r0, rm, r1, obs[O_R_NEAR])
    if hist:
        prev = 1.0
        for k in range(N_HIST):
            above = share_above(r0, rm, r1, obs[O_R_EDGE + k]) if k < N_HIST - 1 else 0.0
            obs[O_HIST + k] += h * max(prev - above, 0.0)
            prev = above


@njit(error_model="numpy")
def add_band(obs, t0, t1, u0, um, u1, band, long_stick, hist):
    """Book the step of a law without alpha (lugre): stick while ``|u| < band`` (the
    quadratic of ``u``), slip otherwise."""
    h = t1 - t0
    stick = stick_pass(obs, t0, h, u0, um, u1, -band, band, long_stick)
    obs[O_T_STICK] += h * stick
    obs[O_T_SLIP] += h * (1.0 - stick)
    obs[O_T_NEAR] += h * (1.0 - stick)
    if hist:
        obs[O_HIST] += h * stick
        obs[O_HIST + N_HIST - 1] += h * (1.0 - stick)


@njit(error_model="numpy")
def add_phase(obs, t0, t1, a, long_stick, hist):
    """Book the step [t0, t1] to the phase of its midpoint alpha ``a`` (sticking steps of
    every law; every step of the laws without alpha) and update sticking runs."""
    h = t1 - t0
    ph = phase(a)
    obs[O_T_STICK + ph] += h
    if a >= 1.0:
        obs[O_T_NEAR] += h
    run_bookkeeping(obs, t0, ph == STICK, long_stick)
    if hist:   # (a brought law's alpha outside [0, 1] or NaN: an end bin, not another slot)
        obs[O_HIST + min(int(a * N_HIST) if a > 0.0 else 0, N_HIST - 1)] += h


@njit(error_model="numpy")
def run_bookkeeping(obs, t0, sticking, long_stick):
    if sticking:
        if math.isnan(obs[O_RUN]):
            obs[O_RUN] = t0
    elif not math.isnan(obs[O_RUN]):
        close_run(obs, t0, long_stick)


@njit(error_model="numpy")
def close_run(obs, t, long_stick):
    run = t - obs[O_RUN]
    if run > long_stick:
        obs[O_LONG] += run
    obs[O_MAX] = max(obs[O_MAX], run)
    obs[O_RUN] = np.nan
