"""Observables reduced while integrating (O(1) memory), DESIGN.md §4 "simulate" outputs.

Only the observables in ``scene.outputs`` are compiled in. The accumulator is one float64
array ``obs`` (layout: the ``O_*`` constants). The observation window is
``[t_transient, t_end]``; the driver stops exactly at ``t_transient`` and calls ``start``.

Definitions (``T = t_end - t_transient``):

- ``v_mean``: ``(x(t_end) - x(t_transient)) / T`` with ``x`` the displacement
  (slider: ``v_ref t - e``; contact: the integral of ``u``) -- exact, no quadrature error.
- ``v_slow_p2p``: peak-to-peak over the window of the *dither-period average* of the body
  velocity, ``(x(t_{j+1}) - x(t_j)) / (t_{j+1} - t_j)`` over consecutive period
  boundaries ``t_j = j 2 pi / omega`` (the driver stops on them; square wave: every second
  switch). Without dither: peak-to-peak of the velocity, each step's extreme taken from the
  quadratic through its start, midpoint (dense output) and end. NaN when the
  window holds fewer than two period boundaries.
- ``F_mean``: ``(Q(t_end) - Q(t_transient)) / T`` with ``Q`` the quadrature state ``dQ = F``.
- ``stick_fraction`` / ``presliding_fraction`` / ``slip_fraction``: time shares of the
  elasto-plastic phases ``alpha == 0``, ``0 < alpha < 1``, ``alpha == 1`` (Eq. 2.7).
  **Sliding** is ``|z| >= (1 - p[SLIP_GAP]) z_ss`` with ``sgn z = sgn u``: a sliding bristle
  relaxes onto ``z_ss`` exponentially (rate ``sigma0 |u| / g``), so exact ``alpha == 1``
  holds there only to round-off and its share would change with every tolerance (measured:
  slip 0.081 / 0.096 / 0.350 at rtol 1e-5 / 1e-8 / 1e-10 when judged by ``alpha == 1.0`` at
  step midpoints). The gap makes the share a well-posed functional of the trajectory; the
  default 1e-9 is where ``alpha`` rounds to 1.0 in double precision (lam = 0.8), so it agrees
  with that reading on an exact trajectory (DESIGN.md §1 reference shares). The share still
  depends on the gap (about 0.003 per decade on the Sec. 7 slider: sliding ends where
  ``z_ss`` starts to rise, by an exponentially small amount), so it needs the state to
  about ``gap * z_ss``: the accuracy levels tighten the tolerance for it (sweeps.accuracy).
  **Bookkeeping**: the phases depend on the state only through the signed ratio
  ``rho = sgn(u) z / z_ss(u)`` (stick: ``rho <= lam``; sliding: ``rho >= 1 - gap``), which
  is smooth inside a step when the step does not cross ``u = 0`` (adaptive methods land on
  every kink, so it never does; ``sgn(u)`` is taken at the midpoint). ``rho`` is interpolated
  by the quadratic through the step's start, midpoint (dense output) and end, and each phase
  gets the measure of the part of the step where the quadratic lies in its band. Phase
  boundaries inside a step are thus located to O(h^3), not rounded to a whole step. Laws
  without alpha: stick is ``|u| < p[STICK_BAND]`` (lugre: located by the quadratic of ``u``
  in the same way; the static laws step onto their Karnopp band edges and breakaway, so
  their midpoint phase holds for the whole step), slip otherwise, pre-sliding 0.
- ``near_slip_fraction``: the share of time with ``alpha >= p[ALPHA_NEAR]`` (default 0.9), from
  the same quadratic; ``alpha`` crosses 0.9 transversally, so unlike ``slip_fraction`` it is
  well conditioned at any tolerance. Laws without alpha: the slip share.
- ``long_stick_fraction`` / ``max_stick``: a *sticking run* is an uninterrupted stretch of
  time in the stick phase, its ends at the interpolated crossings (clipped to the window); the paper's
  "long-duration stick" (Sec. 7, never defined there) is a run longer than ``p[LONG_STICK]``.
  ``long_stick_fraction`` = total time in long runs / T, ``max_stick`` = the longest run.
- ``alpha_hist``: the time shares of alpha in :data:`N_HIST` equal bins of [0, 1] (the paper's
  Figs. 12 and 17 histograms; stick counts in the first bin), a vector output (cube
  dimension ``alpha_bin``).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from . import params as P
from .dither import CODE, NONE
from .friction.elastoplastic import STICK, phase
from .friction.stribeck import make_g
from .jit import njit
from .outputs import SIMULATE, VECTOR

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
SCALARS = tuple(nm for nm in SIMULATE if nm not in VECTOR)
PHASE_OUTPUTS = ("stick_fraction", "presliding_fraction", "slip_fraction",
                 "long_stick_fraction", "max_stick", "near_slip_fraction", "alpha_hist")


class Observer(NamedTuple):
    """njit hooks of a scene's observables (see module docstring)."""

    size: int              # len(obs)
    names: tuple           # scalar outputs written by finish, in order
    hist: bool             # finish appends the N_HIST alpha_hist shares after the scalars
    needs_mid: bool        # observe uses ymid
    period_stops: bool     # the driver must stop on dither period boundaries
    init: Callable         # init(obs)
    start: Callable        # start(t, y, p, sq, obs)
    observe: Callable      # observe(t0, y0, t1, y1, ymid, p, sq, obs)
    stop: Callable         # stop(t, y, p, is_period, obs)
    finish: Callable       # finish(t, y, p, obs, out)


def check_outputs(outputs) -> None:
    """Raise ValueError naming any output the simulate path does not know."""
    bad = [o for o in outputs if o not in SIMULATE]
    if bad:
        raise ValueError(f"outputs: unknown simulate observable(s) {bad}; "
                         f"known: {tuple(SIMULATE)}")


def make_observer(scene, system) -> Observer:
    """Compile the hooks for ``scene.outputs`` on ``system`` (engine.systems.System)."""
    outs = tuple(scene.outputs)
    check_outputs(outs)
    names = tuple(o for o in outs if o not in VECTOR)
    phases = any(o in PHASE_OUTPUTS for o in outs)
    hist = "alpha_hist" in outs
    undithered = CODE[scene.dither] == NONE
    p2p = "v_slow_p2p" in outs
    period_stops = p2p and not undithered
    elasto = scene.friction == "elastoplastic"
    hooks = _make_hooks(system, phases, hist, p2p and undithered, period_stops, elasto,
                        scene.friction == "lugre", make_g(scene.stribeck))
    finish = _make_finish(system, names, hist)
    needs_mid = phases or (p2p and undithered)
    return Observer(O_SIZE, names, hist, needs_mid, period_stops, *hooks, finish)


@njit(error_model="numpy")
def rho_of_alpha(a, lam):
    """The ratio ``rho = |z| / z_ss`` at which Eq. 2.7 gives ``alpha = a`` (0 < a < 1)."""
    return 0.5 * (1.0 + lam) + (1.0 - lam) / np.pi * math.asin(2.0 * a - 1.0)


@njit(inline="always", error_model="numpy")
def _coeffs(r0, rm, r1):
    """``(a, b)`` of the quadratic ``q(s) = a s^2 + b s + r0`` through ``(0, r0)``,
    ``(1/2, rm)``, ``(1, r1)``."""
    return 2.0 * (r0 + r1) - 4.0 * rm, 4.0 * rm - 3.0 * r0 - r1


@njit(error_model="numpy")
def _roots(a, b, c):
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
    a, b = _coeffs(r0, rm, r1)
    c = r0 - thr
    s1, s2 = _roots(a, b, c)
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
def _stick_pass(obs, t0, h, r0, rm, r1, lo, hi, long_stick):
    """Book the sticking part ``{lo < q(s) <= hi}`` of the step ``[t0, t0 + h]`` (``q``
    the quadratic through ``r0, rm, r1``) and the sticking runs it opens, extends and
    closes, at the interpolated crossing instants. Returns the sticking share of the step."""
    a, b = _coeffs(r0, rm, r1)
    p1, p2 = _roots(a, b, r0 - lo) if lo > -np.inf else (2.0, 2.0)
    p3, p4 = _roots(a, b, r0 - hi) if hi < np.inf else (2.0, 2.0)
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
        _run_bookkeeping(obs, t0 + left * h, sticking, long_stick)
        left = right
    return stick


def _make_observe(interface, velocity, z_index, g, phases, hist, p2p_steps, elasto, band_law):
    """The per-step hook: phase bookkeeping and/or step-end velocity extremes.

    ``band_law``: stick is ``|u| < stick_band`` (lugre), located inside the step by the
    quadratic of ``u``; the static laws stop on their band edges and breakaway instead, so
    their midpoint phase holds for the whole step."""
    if not (phases or p2p_steps):
        # nothing is reduced per step: an empty hook the compiler removes (~6 % of a step)
        @njit(inline="always", error_model="numpy")
        def nothing(t0, y0, t1, y1, ymid, p, sq, obs):
            pass
        return nothing

    @njit(inline="always", error_model="numpy")
    def rho(t, y, p, sq, su):
        u, _, _ = interface(t, y, p, sq)
        return su * y[z_index] * p[P.SIGMA0] / g(u, p)

    @njit(inline="always", error_model="numpy")
    def observe(t0, y0, t1, y1, ymid, p, sq, obs):
        if obs[O_ON] == 0.0:
            return
        if phases:
            tm = 0.5 * (t0 + t1)
            um, _, am = interface(tm, ymid, p, sq)
            if elasto and um != 0.0:
                su = 1.0 if um > 0.0 else -1.0
                _add_elasto(obs, t0, t1, rho(t0, y0, p, sq, su), rho(tm, ymid, p, sq, su),
                            rho(t1, y1, p, sq, su), p[P.LONG_STICK], hist)
            elif band_law:
                u0, _, _ = interface(t0, y0, p, sq)
                u1, _, _ = interface(t1, y1, p, sq)
                _add_band(obs, t0, t1, u0, um, u1, p[P.STICK_BAND], p[P.LONG_STICK], hist)
            else:
                _add_phase(obs, t0, t1, am, p[P.LONG_STICK], hist)
        if p2p_steps:
            v1 = velocity(t1, y1, p, sq)
            lo, hi = _quadratic_extremes(velocity(t0, y0, p, sq),
                                         velocity(0.5 * (t0 + t1), ymid, p, sq), v1)
            obs[O_VMIN] = min(obs[O_VMIN], lo)
            obs[O_VMAX] = max(obs[O_VMAX], hi)
    return observe


@njit(inline="always", error_model="numpy")
def _quadratic_extremes(v0, vm, v1):
    """(min, max) over the step of the quadratic through the velocity at its start, midpoint
    and end: a peak between step ends is caught to O(h^3), not sampled at the ends."""
    lo, hi = min(v0, v1), max(v0, v1)
    a, b = _coeffs(v0, vm, v1)
    if a != 0.0:
        s = -b / (2.0 * a)
        if 0.0 < s < 1.0:
            v = (a * s + b) * s + v0
            lo, hi = min(lo, v), max(hi, v)
    return lo, hi


def _make_hooks(system, phases, hist, p2p_steps, p2p_periods, elasto, band_law, g):
    interface, position, velocity, qf = (system.interface, system.position,
                                         system.velocity, system.qf)

    @njit(inline="always", error_model="numpy")
    def init(obs):
        obs[:] = 0.0
        obs[O_RUN] = np.nan
        obs[O_TPREV] = np.nan
        obs[O_VMIN] = np.inf
        obs[O_VMAX] = -np.inf

    @njit(inline="always", error_model="numpy")
    def start(t, y, p, sq, obs):
        obs[O_ON] = 1.0
        obs[O_T0] = t
        obs[O_X0] = position(t, y, p)
        if qf >= 0:
            obs[O_Q0] = y[qf]
        if p2p_steps:
            v = velocity(t, y, p, sq)
            obs[O_VMIN] = v
            obs[O_VMAX] = v
        if phases and elasto:
            lam = p[P.LAM]
            obs[O_R_STICK] = lam
            obs[O_R_SLIP] = 1.0 - p[P.SLIP_GAP]
            obs[O_R_NEAR] = rho_of_alpha(min(max(p[P.ALPHA_NEAR], 0.0), 1.0), lam)
            for k in range(1, N_HIST):
                obs[O_R_EDGE + k - 1] = rho_of_alpha(k / N_HIST, lam)

    observe = _make_observe(interface, velocity, system.z_index, g, phases, hist, p2p_steps,
                            elasto, band_law)

    @njit(inline="always", error_model="numpy")
    def stop(t, y, p, is_period, obs):
        if not p2p_periods or not is_period or obs[O_ON] == 0.0:
            return
        x = position(t, y, p)
        if not math.isnan(obs[O_TPREV]):
            vbar = (x - obs[O_XPREV]) / (t - obs[O_TPREV])
            obs[O_VMIN] = min(obs[O_VMIN], vbar)
            obs[O_VMAX] = max(obs[O_VMAX], vbar)
        obs[O_XPREV] = x
        obs[O_TPREV] = t

    return init, start, observe, stop


@njit(error_model="numpy")
def _add_elasto(obs, t0, t1, r0, rm, r1, long_stick, hist):
    """Book the step ``[t0, t1]`` by the quadratic of ``rho`` (module docstring): stick at
    or below ``lam``, sliding above ``1 - gap``; sticking runs at the crossing instants."""
    h = t1 - t0
    stick = _stick_pass(obs, t0, h, r0, rm, r1, -np.inf, obs[O_R_STICK], long_stick)
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
def _add_band(obs, t0, t1, u0, um, u1, band, long_stick, hist):
    """Book the step of a law without alpha (lugre): stick while ``|u| < band`` (the
    quadratic of ``u``), slip otherwise."""
    h = t1 - t0
    stick = _stick_pass(obs, t0, h, u0, um, u1, -band, band, long_stick)
    obs[O_T_STICK] += h * stick
    obs[O_T_SLIP] += h * (1.0 - stick)
    obs[O_T_NEAR] += h * (1.0 - stick)
    if hist:
        obs[O_HIST] += h * stick
        obs[O_HIST + N_HIST - 1] += h * (1.0 - stick)


@njit(error_model="numpy")
def _add_phase(obs, t0, t1, a, long_stick, hist):
    """Book the step [t0, t1] to the phase of its midpoint alpha ``a`` (sticking steps of
    every law; every step of the laws without alpha) and update sticking runs."""
    h = t1 - t0
    ph = phase(a)
    obs[O_T_STICK + ph] += h
    if a >= 1.0:
        obs[O_T_NEAR] += h
    _run_bookkeeping(obs, t0, ph == STICK, long_stick)
    if hist:
        obs[O_HIST + min(int(a * N_HIST), N_HIST - 1)] += h


@njit(error_model="numpy")
def _run_bookkeeping(obs, t0, sticking, long_stick):
    if sticking:
        if math.isnan(obs[O_RUN]):
            obs[O_RUN] = t0
    elif not math.isnan(obs[O_RUN]):
        _close_run(obs, t0, long_stick)


@njit(error_model="numpy")
def _close_run(obs, t, long_stick):
    run = t - obs[O_RUN]
    if run > long_stick:
        obs[O_LONG] += run
    obs[O_MAX] = max(obs[O_MAX], run)
    obs[O_RUN] = np.nan


def _make_finish(system, names, hist):
    codes = np.array([SCALARS.index(nm) for nm in names], dtype=np.int64)
    position, qf = system.position, system.qf
    k = len(names)

    @njit(inline="always", error_model="numpy")
    def finish(t, y, p, obs, out):
        if not math.isnan(obs[O_RUN]):
            _close_run(obs, t, p[P.LONG_STICK])
        span = t - obs[O_T0]
        for j in range(codes.size):
            out[j] = _value(codes[j], t, y, p, obs, span, position(t, y, p), qf)
        if hist:
            for j in range(N_HIST):
                out[k + j] = obs[O_HIST + j] / span
    return finish


@njit(error_model="numpy")
def _value(code, t, y, p, obs, span, x, qf):
    # code = index in SCALARS (engine.outputs.SIMULATE without the vector outputs)
    if code == 0:
        return (x - obs[O_X0]) / span
    if code == 1:
        return obs[O_VMAX] - obs[O_VMIN] if obs[O_VMAX] >= obs[O_VMIN] else np.nan
    if code == 2:
        return (y[qf] - obs[O_Q0]) / span if qf >= 0 else np.nan
    if code <= 5:
        return obs[O_T_STICK + code - 3] / span
    if code == 6:
        return obs[O_LONG] / span
    if code == 7:
        return obs[O_MAX]
    return obs[O_T_NEAR] / span
