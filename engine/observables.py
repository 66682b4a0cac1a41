"""Observables reduced while integrating (O(1) memory), DESIGN.md §4 "simulate" outputs.

Only the observables in ``scene.outputs`` are compiled in. The accumulator is one float64
array ``obs`` (layout: the ``O_*`` constants of :mod:`engine.phase_book`, which also books
each step's phases). The observation window is ``[t_transient, t_end]``; the driver stops exactly at ``t_transient`` and calls ``start``.

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
  about ``gap * z_ss``: the accuracy levels tighten the tolerance for it (sweeps.spec.accuracy).
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
from .friction.stribeck import make_g
from .jit import njit
from .outputs import SIMULATE, VECTOR
from .systems import with_system_outputs
from .phase_book import (
    N_HIST,
    O_HIST,
    O_LONG,
    O_MAX,
    O_ON,
    O_Q0,
    O_R_EDGE,
    O_R_NEAR,
    O_R_SLIP,
    O_R_STICK,
    O_RUN,
    O_SIZE,
    O_T0,
    O_T_NEAR,
    O_T_STICK,
    O_TPREV,
    O_VMAX,
    O_VMIN,
    O_X0,
    O_XPREV,
    add_band,
    add_elasto,
    add_phase,
    close_run,
    quad_coeffs,
    rho_of_alpha,
)

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


def check_outputs(outputs, own=()) -> None:
    """Raise ValueError naming any output the simulate path does not know (``own``: the
    system's own observables)."""
    bad = [o for o in outputs if o not in SIMULATE and o not in own]
    if bad:
        raise ValueError(f"outputs: unknown simulate observable(s) {bad}; "
                         f"known: {tuple(SIMULATE) + tuple(own)}")


def make_observer(scene, system) -> Observer:
    """Compile the hooks for ``scene.outputs`` on ``system`` (engine.systems.System)."""
    outs = tuple(scene.outputs)
    so = system.outputs
    check_outputs(outs, so.names if so is not None else ())
    own = so.names if so is not None else ()
    names = tuple(o for o in outs if o not in VECTOR and o not in own)
    phases = any(o in PHASE_OUTPUTS for o in outs)
    hist = "alpha_hist" in outs
    undithered = CODE[scene.dither] == NONE
    p2p = "v_slow_p2p" in outs
    period_stops = p2p and not undithered
    elasto = system.phases == "elasto"
    hooks = _make_hooks(system, phases, hist, p2p and undithered, period_stops, elasto,
                        system.phases == "band", make_g(scene.stribeck, scene.delta))
    finish = _make_finish(system, names, hist)
    needs_mid = phases or (p2p and undithered)
    size = O_SIZE
    if so is not None:   # the system's own observables: slots after the engine's
        hooks, finish = with_system_outputs(hooks, finish, so, len(names), hist)
        names, needs_mid, size = names + own, True, O_SIZE + so.size
        period_stops = period_stops or (so.period_stops and not undithered)
    return Observer(size, names, hist, needs_mid, period_stops, *hooks, finish)


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
                add_elasto(obs, t0, t1, rho(t0, y0, p, sq, su), rho(tm, ymid, p, sq, su),
                            rho(t1, y1, p, sq, su), p[P.LONG_STICK], hist)
            elif band_law:
                u0, _, _ = interface(t0, y0, p, sq)
                u1, _, _ = interface(t1, y1, p, sq)
                add_band(obs, t0, t1, u0, um, u1, p[P.STICK_BAND], p[P.LONG_STICK], hist)
            else:
                add_phase(obs, t0, t1, am, p[P.LONG_STICK], hist)
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
    a, b = quad_coeffs(v0, vm, v1)
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


def _make_finish(system, names, hist):
    codes = np.array([SCALARS.index(nm) for nm in names], dtype=np.int64)
    position, qf = system.position, system.qf
    k = len(names)

    @njit(inline="always", error_model="numpy")
    def finish(t, y, p, obs, out):
        if not math.isnan(obs[O_RUN]):
            close_run(obs, t, p[P.LONG_STICK])
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
