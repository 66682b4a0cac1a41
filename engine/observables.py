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
  switch). Without dither: peak-to-peak of the velocity at the step ends. NaN when the
  window holds fewer than two period boundaries.
- ``F_mean``: ``(Q(t_end) - Q(t_transient)) / T`` with ``Q`` the quadrature state ``dQ = F``.
- ``stick_fraction`` / ``presliding_fraction`` / ``slip_fraction``: time shares of the
  elasto-plastic phases ``alpha == 0``, ``0 < alpha < 1``, ``alpha == 1`` (Eq. 2.7). For laws
  without alpha, stick means ``|u| < p[STICK_BAND]`` (the Karnopp band of the static laws),
  slip otherwise, pre-sliding is 0. The phase of a step is the phase at its midpoint (dense
  output): exact when every phase change falls on a step end, which adaptive methods ensure
  by stepping onto the kink events; a fixed-step method errs by at most one step per change.
- ``long_stick_fraction`` / ``max_stick``: a *sticking run* is an uninterrupted stretch of
  steps in the stick phase (clipped to the window); the paper's "long-duration stick"
  (Sec. 7, never defined there) is a run longer than ``p[LONG_STICK]``.
  ``long_stick_fraction`` = total time in long runs / T, ``max_stick`` = the longest run.
- ``alpha_hist`` (API only, not a cube variable): time-weighted histogram of alpha over
  :data:`N_HIST` equal bins of [0, 1] (the paper's Fig. 12 histograms of uniform samples).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from . import params as P
from .dither import CODE, NONE
from .friction.elastoplastic import PRESLIDE, SLIDE, STICK
from .jit import njit
from .outputs import SIMULATE

O_ON, O_T0, O_X0, O_Q0 = 0, 1, 2, 3
O_T_STICK, O_T_PRE, O_T_SLIP = 4, 5, 6
O_RUN, O_LONG, O_MAX = 7, 8, 9
O_VMIN, O_VMAX, O_XPREV, O_TPREV = 10, 11, 12, 13
O_HIST = 14
N_HIST = 20
API_ONLY = ("alpha_hist",)
PHASE_OUTPUTS = ("stick_fraction", "presliding_fraction", "slip_fraction",
                 "long_stick_fraction", "max_stick", "alpha_hist")


class Observer(NamedTuple):
    """njit hooks of a scene's observables (see module docstring)."""

    size: int              # len(obs)
    names: tuple           # scalar outputs written by finish, in order
    needs_mid: bool        # observe uses ymid
    period_stops: bool     # the driver must stop on dither period boundaries
    init: Callable         # init(obs)
    start: Callable        # start(t, y, p, sq, obs)
    observe: Callable      # observe(t0, y0, t1, y1, ymid, p, sq, obs)
    stop: Callable         # stop(t, y, p, is_period, obs)
    finish: Callable       # finish(t, y, p, obs, out)


def check_outputs(outputs) -> None:
    """Raise ValueError naming any output the simulate path does not know."""
    known = tuple(SIMULATE) + API_ONLY
    bad = [o for o in outputs if o not in known]
    if bad:
        raise ValueError(f"outputs: unknown simulate observable(s) {bad}; known: {known}")


@njit(inline="always", error_model="numpy")
def _phase(a):
    if a == 0.0:
        return STICK
    if a == 1.0:
        return SLIDE
    return PRESLIDE


def make_observer(scene, system) -> Observer:
    """Compile the hooks for ``scene.outputs`` on ``system`` (engine.systems.System)."""
    outs = tuple(scene.outputs)
    check_outputs(outs)
    names = tuple(o for o in outs if o not in API_ONLY)
    phases = any(o in PHASE_OUTPUTS for o in outs)
    hist = "alpha_hist" in outs
    undithered = CODE[scene.dither] == NONE
    p2p = "v_slow_p2p" in outs
    period_stops = p2p and not undithered
    size = O_HIST + (N_HIST if hist else 0)
    hooks = _make_hooks(system, phases, hist, p2p and undithered, period_stops)
    finish = _make_finish(system, names)
    return Observer(size, names, phases, period_stops, hooks[0], hooks[1], hooks[2],
                    hooks[3], finish)


def _make_observe(interface, velocity, phases, hist, p2p_steps):
    """The per-step hook: phase bookkeeping and/or step-end velocity extremes."""
    if not (phases or p2p_steps):
        # nothing is reduced per step: an empty hook the compiler removes (~6 % of a step)
        @njit(inline="always", error_model="numpy")
        def nothing(t0, y0, t1, y1, ymid, p, sq, obs):
            pass
        return nothing

    @njit(inline="always", error_model="numpy")
    def observe(t0, y0, t1, y1, ymid, p, sq, obs):
        if obs[O_ON] == 0.0:
            return
        if phases:
            _, _, a = interface(0.5 * (t0 + t1), ymid, p, sq)
            _add_phase(obs, t0, t1, a, p[P.LONG_STICK], hist)
        if p2p_steps:
            v = velocity(t1, y1, p, sq)
            obs[O_VMIN] = min(obs[O_VMIN], v)
            obs[O_VMAX] = max(obs[O_VMAX], v)
    return observe


def _make_hooks(system, phases, hist, p2p_steps, p2p_periods):
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

    observe = _make_observe(interface, velocity, phases, hist, p2p_steps)

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
def _add_phase(obs, t0, t1, a, long_stick, hist):
    """Book the step [t0, t1] to the phase of alpha ``a`` and update sticking runs."""
    h = t1 - t0
    ph = _phase(a)
    obs[O_T_STICK + ph] += h
    if ph == STICK:
        if math.isnan(obs[O_RUN]):
            obs[O_RUN] = t0
    elif not math.isnan(obs[O_RUN]):
        _close_run(obs, t0, long_stick)
    if hist:
        obs[O_HIST + min(int(a * N_HIST), N_HIST - 1)] += h


@njit(error_model="numpy")
def _close_run(obs, t, long_stick):
    run = t - obs[O_RUN]
    if run > long_stick:
        obs[O_LONG] += run
    obs[O_MAX] = max(obs[O_MAX], run)
    obs[O_RUN] = np.nan


def _make_finish(system, names):
    codes = np.array([tuple(SIMULATE).index(nm) for nm in names], dtype=np.int64)
    position, qf = system.position, system.qf

    @njit(inline="always", error_model="numpy")
    def finish(t, y, p, obs, out):
        if not math.isnan(obs[O_RUN]):
            _close_run(obs, t, p[P.LONG_STICK])
        span = t - obs[O_T0]
        for j in range(codes.size):
            out[j] = _value(codes[j], t, y, p, obs, span, position(t, y, p), qf)
    return finish


@njit(error_model="numpy")
def _value(code, t, y, p, obs, span, x, qf):
    # code = index in engine.outputs.SIMULATE
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
    return obs[O_MAX]


def alpha_histogram(obs: np.ndarray) -> np.ndarray:
    """Time shares of alpha in :data:`N_HIST` equal bins of [0, 1] (sums to 1)."""
    h = np.asarray(obs[O_HIST:O_HIST + N_HIST], dtype=float)
    total = h.sum()
    return h / total if total > 0 else h
