"""What a method's kernel factory receives (:class:`Problem`) and returns (:class:`Stepper`),
the run-time settings record ``cfg`` (:data:`CONFIG`) and the index constants of the
counters ``ctr``.

See the protocol in :mod:`engine.integrators`.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ..jit import njit

N_ATOL = 72  # room for the per-component absolute tolerances (n_err <= N_ATOL): a system's
#              states and up to engine.registry.MAX_STATES states of a friction law

#: The run-time settings of the kernels, one numpy record (``cfg``; no recompilation when
#: they change); the njit code reads them by name, ``cfg.rtol``. Built from
#: :class:`engine.settings.Settings` by :func:`engine.kernels.make_config`.
CONFIG = np.dtype([
    ("rtol", "f8"),              # relative tolerance (adaptive methods)
    ("atol", "f8"),              # Settings.atol: absolute, or in natural units
    ("atol_natural", "?"),       # atol in natural units (engine.settings): scaled per point
    ("atol_i", "f8", (N_ATOL,)), # per-component absolute tolerances of the n_err
    #                              controlled components, filled per point (kernels.run_point)
    ("max_steps", "i8"),         # budget of accepted + rejected steps
    ("steps_per_period", "i8"),  # Settings.steps_per_period (the driver sets h from it)
    ("h_free", "f8"),            # Settings.h, the fixed step without dither
    ("h", "f8"),                 # nominal fixed step (fixed-step methods), set per point
    ("record_every", "i8"),      # API recording: keep every m-th accepted step
    ("sample_dt", "f8"),         # spacing of the sampling instants k * dt (<= 0: none)
    ("sample_t0", "f8"),         # no sampling instant before this time
], align=True)

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
    period_cap: float = 0.0  # > 0: no adaptive step spans more than this share of a sine
    #                        dither's period (W != 0; engine.integrators.adaptive)
    sampling: bool = False # call sample at the instants k * cfg.sample_dt (dense output)
    sample: Callable | None = None  # sample(t, y, p, sq, obs, ctr, rec)
    update_modes: Callable | None = None  # update_modes(t, y, p, sq, landed) -> bool: after
    #                        each accepted step, the law's discrete modes from the step-end
    #                        state and the switch landed on (-1: none; engine.contract); True
    #                        when one changed (the right-hand side did)


class Stepper(NamedTuple):
    """A method's two njit entry points (see the protocol in engine.integrators)."""

    alloc: Callable        # alloc() -> work
    segment: Callable      # segment(work, y, t0, t1, p, sq, fresh, cfg, obs, ctr, rec) -> status
    shapes: tuple | None = None  # the shapes of alloc()'s arrays, nested as its tuple (all
    #                        float64, zeroed): how a GPU thread allocates the same work in
    #                        its local memory (engine.gpu); None: the method runs on the CPU only


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
    for every ``cfg.record_every``-th accepted step; call after counting the step.
    A zero-capacity ``rec`` (the batch path) records nothing at the cost of one branch;
    silently stops when ``rec`` is full (the API reports truncation)."""
    if rec.shape[0] == 0 or ctr[CTR_STEPS] % max(1, cfg.record_every) != 0:
        return
    record_sample(t, y, ctr, rec)


@njit(inline="always", error_model="numpy", refcount=False)
def no_modes(t, y, p, sq, landed):
    """The ``update_modes`` hook of a law without modes (never called)."""
    return False


@njit(error_model="numpy", refcount=False)
def no_sample(t, y, p, sq, obs, ctr, rec):
    """The ``sample`` hook of a problem without sampling (never called)."""


ROUNDOFF = 4e-16   # relative: an instant k * dt this close past a step end falls on it


@njit(inline="always", error_model="numpy")
def sample_due(k, cfg, t_new):
    """True when the sampling instant ``k * dt`` falls in a step ending at ``t_new``."""
    return k * cfg.sample_dt <= t_new + ROUNDOFF * abs(t_new)


def make_sampler(problem, dense_eval):
    """Sampling at requested instants from a method's dense output, without stopping there.

    ``problem.sample`` is the hook (:func:`no_sample` when ``problem.sampling`` is off: the
    method then never calls ``first``/``emit``, whose compilation stays trivial).

    The instants are ``t_k = k * dt`` (``dt = cfg.sample_dt``, computed from ``k``,
    never accumulated) with ``t_k >= cfg.sample_t0``. A method keeps the next ``k``
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
        dt = cfg.sample_dt
        if not dt > 0.0:
            return math.inf
        k = math.ceil(max(t0, cfg.sample_t0) / dt)
        if k * dt == t0:
            sample(t0, y, p, sq, obs, ctr, rec)
            k += 1
        return float(k)

    @njit(error_model="numpy", refcount=False)
    def emit(t, hh, t_new, y, yn, Q, p, sq, cfg, obs, ctr, rec, k, ytmp):
        dt = cfg.sample_dt
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
