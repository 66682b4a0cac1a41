"""What a method's kernel factory receives (:class:`Problem`) and returns (:class:`Stepper`),
and the index constants of the small run-time arrays ``cfg`` and ``ctr``.

See the protocol in :mod:`engine.integrators`.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

from ..jit import njit

# cfg: float64 run-time settings of one point (no recompilation when they change)
CFG_RTOL = 0        # relative tolerance (adaptive methods)
CFG_ATOL = 1        # absolute tolerance (adaptive methods)
CFG_H = 2           # nominal fixed step (fixed-step methods), set per point by the driver
CFG_MAX_STEPS = 3   # budget of accepted + rejected steps
CFG_STEPS_PER_PERIOD = 4   # Settings.steps_per_period (read by the driver to set CFG_H)
CFG_H_FREE = 5      # Settings.h, the fixed step without dither (read by the driver)
CFG_RECORD_EVERY = 6       # API recording: keep every m-th accepted step
CFG_SAMPLE_DT = 7   # spacing of the sampling instants k * dt (problem.sampling; <= 0: none)
CFG_SAMPLE_T0 = 8   # no sampling instant before this time
CFG_ATOL_NATURAL = 9  # 1.0: Settings.atol in natural units (engine.settings), 0.0: absolute
CFG_ATOL_I = 10     # per-component absolute tolerances of the n_err controlled components,
N_ATOL = 4          # filled per point (kernels.run_point): cfg[CFG_ATOL_I + i], i < N_ATOL
CFG_SIZE = CFG_ATOL_I + N_ATOL

# ctr: int64 counters of one point
CTR_STEPS = 0       # accepted steps
CTR_REJECTED = 1    # rejected steps (error test failed, or retaken to land on an event)
CTR_EVALS = 2       # right-hand-side evaluations
CTR_NREC = 3        # number of step times written to rec (API recording)
CTR_SIZE = 4

# segment(..., fresh, ...) values
FRESH_NONE = 0      # continue: caches (FSAL stage, step size) are valid
FRESH_SWITCH = 1    # the dither sign changed: re-evaluate cached stages
FRESH_START = 2     # first segment of a point: also choose an initial step


class Problem(NamedTuple):
    """The scene's compiled pieces, handed to ``make_stepper`` (compile-time constants)."""

    n: int                 # state size, quadrature states included
    n_err: int             # leading components under error control
    rhs: Callable          # rhs(t, y, p, sq, dy)
    n_events: int          # number of kink functions (0: none)
    events: Callable       # events(t, y, p, sq, g): g[:n_events]
    observe: Callable      # observe(t0, y0, t1, y1, ymid, p, sq, obs)
    record: bool = True    # call record_step (a run-time no-op for an empty rec)
    needs_mid: bool = True # observe reads ymid (else methods may pass any array)
    graze: bool = False    # events mark jumps of rhs: probe steps for grazing crossings
    sampling: bool = False # call sample at the instants k * cfg[CFG_SAMPLE_DT] (dense output)
    sample: Callable | None = None  # sample(t, y, p, sq, obs, ctr, rec)


class Stepper(NamedTuple):
    """A method's two njit entry points (see the protocol in engine.integrators)."""

    alloc: Callable        # alloc() -> work
    segment: Callable      # segment(work, y, t0, t1, p, sq, fresh, cfg, obs, ctr, rec) -> status
    extra: Any = None      # method-specific helpers (e.g. dense output), optional


@njit(error_model="numpy", refcount=False)
def record_sample(t, y, ctr, rec):
    """Append ``(t, y)`` as row ``ctr[CTR_NREC]`` of ``rec``; silently stops when full."""
    i = ctr[CTR_NREC]
    if i < rec.shape[0]:
        rec[i, 0] = t
        for j in range(y.size):
            rec[i, 1 + j] = y[j]
        ctr[CTR_NREC] = i + 1


@njit(error_model="numpy", refcount=False)
def record_step(rec, ctr, cfg, t, y):
    """Append ``(t, y)`` as row ``ctr[CTR_NREC]`` of ``rec`` (shape ``(capacity, 1 + n)``)
    for every ``cfg[CFG_RECORD_EVERY]``-th accepted step; call after counting the step.
    A zero-capacity ``rec`` (the batch path) records nothing at the cost of one branch;
    silently stops when ``rec`` is full (the API reports truncation)."""
    if rec.shape[0] == 0 or ctr[CTR_STEPS] % max(1, int(cfg[CFG_RECORD_EVERY])) != 0:
        return
    record_sample(t, y, ctr, rec)


@njit(error_model="numpy", refcount=False)
def no_sample(t, y, p, sq, obs, ctr, rec):
    """The ``sample`` hook of a problem without sampling (never called)."""


ROUNDOFF = 4e-16   # relative: an instant k * dt this close past a step end falls on it


@njit(inline="always", error_model="numpy")
def sample_due(k, cfg, t_new):
    """True when the sampling instant ``k * dt`` falls in a step ending at ``t_new``."""
    return k * cfg[CFG_SAMPLE_DT] <= t_new + ROUNDOFF * abs(t_new)


def make_sampler(problem, dense_eval):
    """Sampling at requested instants from a method's dense output, without stopping there.

    ``problem.sample`` is the hook (:func:`no_sample` when ``problem.sampling`` is off: the
    method then never calls ``first``/``emit``, whose compilation stays trivial).

    The instants are ``t_k = k * dt`` (``dt = cfg[CFG_SAMPLE_DT]``, computed from ``k``,
    never accumulated) with ``t_k >= cfg[CFG_SAMPLE_T0]``. A method keeps the next ``k``
    (a float) in its work state and, after each accepted step ``(t, t_new]`` that holds an
    instant, calls ``emit``; ``dense_eval(y, hh, Q, theta, out)`` is its continuous
    extension on that step (``Q`` its coefficients, valid for the accepted step).

    Returns njit ``first(t0, y, p, sq, cfg, obs, ctr, rec) -> k`` (the first index at or
    after ``t0``, sampling ``t0`` itself when it is an instant; ``inf`` when ``dt <= 0``) and
    ``emit(t, hh, t_new, y, yn, Q, p, sq, cfg, obs, ctr, rec, k, ytmp) -> k``. An instant
    equal to ``t_new`` (or past it by the round-off of ``k * dt``, e.g. ``3 * 0.1 > 0.3``)
    takes the step-end state ``yn`` (no interpolation error).
    """
    sample = problem.sample if problem.sampling else no_sample

    @njit(error_model="numpy", refcount=False)
    def first(t0, y, p, sq, cfg, obs, ctr, rec):
        dt = cfg[CFG_SAMPLE_DT]
        if not dt > 0.0:
            return math.inf
        k = math.ceil(max(t0, cfg[CFG_SAMPLE_T0]) / dt)
        if k * dt == t0:
            sample(t0, y, p, sq, obs, ctr, rec)
            k += 1
        return float(k)

    @njit(error_model="numpy", refcount=False)
    def emit(t, hh, t_new, y, yn, Q, p, sq, cfg, obs, ctr, rec, k, ytmp):
        dt = cfg[CFG_SAMPLE_DT]
        if not dt > 0.0:
            return k
        ts = k * dt
        end = t_new + ROUNDOFF * abs(t_new)
        while ts <= end:
            if ts >= t_new:        # on the step end, or past it by round-off of k * dt
                sample(ts, yn, p, sq, obs, ctr, rec)
            else:
                dense_eval(y, hh, Q, (ts - t) / hh, ytmp)
                sample(ts, ytmp, p, sq, obs, ctr, rec)
            k += 1.0
            ts = k * dt
        return k

    return first, emit
