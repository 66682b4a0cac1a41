"""Time integrators: one method per module, picked by name from :data:`METHODS`.

Protocol (how to add a method, e.g. a stiff Rosenbrock or exponential scheme)
-----------------------------------------------------------------------------
A method is *data + a kernel factory* in its own module ``engine/integrators/<name>.py``:

``NAME: str``
    literature name, the key in :data:`METHODS` (``"rk4"``, ``"dopri5"``, ...).
``ORDER: int``
    order of the propagated solution (the convergence tests check the log2-slope).
``ADAPTIVE: bool``
    True: the method reads ``cfg.rtol`` and the per-component absolute tolerances
    ``cfg.atol_i[i]``, ``i < n_err`` (``Settings.atol``, times the system's natural
    scales with ``atol_units="natural"``; filled per point); False: it takes fixed
    steps of nominal size ``cfg.h`` (the driver computes it from
    ``Settings.steps_per_period`` so that it divides the dither (half-)period).
``TABLEAU``
    frozen coefficients (:class:`engine.integrators.tableau.ButcherTableau`, which checks
    its own sum rules when built), or ``None``.
``make_stepper(problem: Problem) -> Stepper``
    the kernel factory. ``problem`` (:class:`engine.integrators.problem.Problem`) carries the
    scene's njit pieces as compile-time constants:

    - ``n`` state size, ``n_err`` the leading components under error control (the rest are
      quadrature states such as the running integral of F, never used for step control);
    - ``rhs(t, y, p, sq, dy)`` the right-hand side (engine.systems), ``jac`` is *not* given:
      a stiff method builds its own (finite differences of ``rhs`` or its own analytic form);
    - ``n_events`` and ``events(t, y, p, sq, g)``: kink functions; a sign change of ``g[i]``
      marks a corner of the right-hand side (``|u| = 0``, elasto-plastic alpha boundaries,
      Karnopp band edges). Adaptive methods should step exactly onto them (see dopri5);
    - ``observe(t0, y0, t1, y1, ymid, p, sq, obs)``: call after every accepted step
      (``ymid`` = state at ``(t0 + t1) / 2`` from the method's dense output; it is an
      empty function when no observable needs per-step data);
    - ``record``: when True call ``record_step`` after each accepted step (it is a run-time
      no-op for the empty ``rec`` of the batch path);
    - ``needs_mid``: False when ``observe`` ignores ``ymid`` (skip the dense evaluation);
    - ``sampling`` and ``sample(t, y, p, sq, obs, ctr, rec)``: when True, call ``sample``
      at every instant ``k * cfg.sample_dt >= cfg.sample_t0`` with the state
      from the method's continuous extension, *without* shortening any step to reach it
      (:func:`engine.integrators.problem.make_sampler` does the bookkeeping; the method
      keeps the next ``k`` in its work state and sets it on ``FRESH_START``). This is how
      a scene without stops is observed at given instants (``simulate(record_dt=...)``).

    It returns ``Stepper(alloc, segment)``, two njit functions:

    ``work = alloc()``
        all scratch storage of one point (any numba-typable object, e.g. a tuple of arrays),
        allocated once per block and reused by every segment of every point: no allocation
        in the step loop. Anything carried between segments (step size, FSAL stage) must be
        re-initialised on ``FRESH_START``.
    ``status = segment(work, y, t0, t1, p, sq, fresh, cfg, obs, ctr, rec)``
        integrate ``y`` (float64 ``(n,)``, updated in place) from ``t0`` to *exactly* ``t1``:
        the last step ends at ``t = t1`` assigned, never accumulated. The dither sign ``sq``
        (+-1, square wave) is constant on the segment. ``fresh`` is ``FRESH_START`` on the
        first segment of a point (select an initial step), ``FRESH_SWITCH`` after a
        square-wave switch (``sq`` changed: re-evaluate any FSAL/cached stage) and
        ``FRESH_NONE`` at other stops (caches stay valid). Step-size state carried between
        segments lives in ``work``. Counters go to ``ctr[CTR_STEPS]``, ``ctr[CTR_REJECTED]``,
        ``ctr[CTR_EVALS]``; with ``problem.record`` call
        ``engine.integrators.problem.record_step(rec, ctr, cfg, t, y)`` after each
        accepted step (``rec`` is ``(capacity, 1 + n)``: time, then state). Returns an
        ``engine.status`` code: ``OK``, ``FAILED`` (``ctr[CTR_STEPS] + ctr[CTR_REJECTED]``
        exceeded ``cfg.max_steps`` or the step underflowed) or ``NON_FINITE``.

An adaptive method does not write this loop: it gives its parts -- attempt, dense output,
controller, restart -- as an :class:`engine.integrators.adaptive.Method` from
``make_method(problem)``, and ``make_stepper`` is
``adaptive.make_stepper(problem, make_method(problem))``, the one adaptive step loop (step
control, exact stops, kink landing, grazing probe, sampling, recording, counters).

The shared driver (:mod:`engine.integrators.driver`) owns everything that is not the
method: the stop grid (square-wave switches ``k * (pi / omega)``, ``t_transient``,
``t_end``, and period boundaries when an observable needs them), the sign ``sq`` per
segment, the observer's stop hook, and the status. Register a new method by importing
its module below and adding it to :data:`METHODS`; ``engine.kernels`` then builds
``Scene(integrator=NAME)`` kernels with it and every batch/API path works unchanged.
"""
from __future__ import annotations

from . import dopri5, rk4, rodas4
from .problem import (
    CONFIG,
    CTR_EVALS,
    CTR_NREC,
    CTR_REJECTED,
    CTR_SIZE,
    CTR_STEPS,
    FRESH_NONE,
    FRESH_START,
    FRESH_SWITCH,
    Problem,
    Stepper,
)

#: name -> method module (see the protocol above)
METHODS = {m.NAME: m for m in (rk4, dopri5, rodas4)}
METHODS["rosenbrock"] = rodas4  # alias: sweeps.spec.accuracy.STIFF_METHOD

__all__ = [
    "CONFIG", "CTR_EVALS", "CTR_NREC",
    "CTR_REJECTED", "CTR_SIZE", "CTR_STEPS", "FRESH_NONE", "FRESH_START", "FRESH_SWITCH",
    "METHODS", "Problem", "Stepper",
]
