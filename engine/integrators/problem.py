"""What a method's kernel factory receives (:class:`Problem`) and returns (:class:`Stepper`),
and the index constants of the small run-time arrays ``cfg`` and ``ctr``.

See the protocol in :mod:`engine.integrators`.
"""
from __future__ import annotations

from typing import Any, Callable, NamedTuple

# cfg: float64 run-time settings of one point (no recompilation when they change)
CFG_RTOL = 0        # relative tolerance (adaptive methods)
CFG_ATOL = 1        # absolute tolerance (adaptive methods)
CFG_H = 2           # nominal fixed step (fixed-step methods), set per point by the driver
CFG_MAX_STEPS = 3   # budget of accepted + rejected steps
CFG_SIZE = 4

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
    record: bool = False   # append accepted step end times to rec


class Stepper(NamedTuple):
    """A method's two njit entry points (see the protocol in engine.integrators)."""

    alloc: Callable        # alloc() -> work
    segment: Callable      # segment(work, y, t0, t1, p, sq, fresh, cfg, obs, ctr, rec) -> status
    extra: Any = None      # method-specific helpers (e.g. dense output), optional
