"""Can the engine run a spec as asked? Spec-time checks of the numerics (issue 10).

Called by :func:`sweeps.spec.parse_spec` once the spec is well-typed and its grid is
within the point budget, so that ``ditherlab plan`` and ``submit`` refuse, with one line
each, what would otherwise fail point by point at run time, or worse, finish with status
ok and wrong numbers.

1. **Options the integrator ignores** (explicit ``accuracy``): ``rk4`` with dither
   divides each dither (half-)period into ``steps_per_period`` steps and ignores ``step``;
   without dither (``dither = "none"`` or ``W = 0`` everywhere) it takes ``step`` and
   ignores ``steps_per_period``. (rtol/atol for rk4, step/steps_per_period for adaptive
   methods are refused by :class:`sweeps.spec.models.ExplicitAccuracy` itself.)

2. **Stability of a fixed step.** On the linear test equation ``y' = lambda y`` a
   Runge-Kutta step multiplies ``y`` by ``R(h lambda)``, ``R(z) = 1 + z b^T (I - z A)^-1 1``
   from the method's Butcher tableau; the step is stable while ``|R(h lambda)| <= 1``
   (Hairer & Wanner, *Solving ODEs II*, Sec. IV.2). For classical RK4, ``R(z) = 1 + z + z^2/2
   + z^3/6 + z^4/24``: the region reaches -2.785 on the negative real axis and
   ``2 sqrt 2 = 2.828`` on the imaginary axis (HW II, Fig. IV.2.1). :func:`reach` computes
   how far it reaches along any direction from the engine's own tableau. The eigenvalues
   of a scene, estimated over the whole grid (:func:`rates`):

   - the bristle relaxation of LuGre and elasto-plastic friction (Eq. 2.3 linearised in z
     for frozen u, engine.friction.lugre.dz): ``lambda = -sigma0 |u| / g(u)``, ``g >= fc``,
     ``|u| <= u_max``; slider ``u_max = 2 max|v_ref| + max W + |A|`` (the estimate of
     :func:`sweeps.spec.accuracy.rk4_fits` plus the slow force of amplitude ``A``, which on the
     unit spring-mass drives the slider up to about ``A``: max|v| = 1.50 measured on the
     Sec. 7 scene, v_ref = 0.1, A = 1.7, no dither), contact ``u_max = max|v_ref| + max W``
     (prescribed). Measured on the Sec. 7 scene (W = 3, omega = 10, sine, t_end = 100):
     RK4 blows up (status non-finite) at N = 32 per period (this estimate 9.6) for both
     laws, LuGre also at N = 64 (4.8) where the elasto-plastic result is 27 % off with
     status ok; fine from N = 80 (3.8). Without dither (A = 1.7): NaN at h = 0.03 (5.7),
     fine at 0.02 (3.8). The estimate is conservative by about 1.4x;
   - the stuck bristle as a spring-damper (slider with a bristle law, ``u ~ 0``):
     ``lambda^2 + (sigma1 + sigma2) lambda + sigma0 + 1 = 0``;
   - a sine dither: ``W sin(omega t)`` is the output of an oscillator with eigenvalues
     ``+-i omega`` that the step must resolve; with ``N`` steps per period
     ``h omega = 2 pi / N``, so RK4 needs ``N >= 3`` (the Sec. 7 scene at W = 1,
     omega = 3000: N = 1 gives F_mean 0.094 and v_slow_p2p 2.19 with status ok, DP5
     0.158 and 1.53). A square wave is constant between the switches the steps land on
     and adds nothing;
   - the slow force, ``+-i slow_omega``, likewise.

   The step is ``2 pi / (omega N)`` for a sine dither, ``pi / (omega N)`` for a square
   wave (engine.integrators.driver), largest at the smallest omega; ``step`` without dither.
   A step whose ``|h lambda|`` is under the reach is allowed, however close.

3. **The step budget.** A point stops as failed after ``Settings.max_steps`` steps. Some
   counts are certain before anything runs: a square wave is a stop at every switch
   (``omega t_end / pi``, a step each at least); a sine dither must be resolved, a step per
   period at least (``omega t_end / 2 pi``); a slow force likewise; fixed steps are exactly
   ``N`` per (half-)period or ``t_end / step``. Over the budget at the grid's largest omega
   the spec is refused. An adaptive method under a sine dither takes several steps per
   period (DP5 on the Sec. 7 scene, W = 0.1-3, omega = 1e3-3e4: 4.5-16 at draft, 15-53 at
   standard); past :data:`WARN_STEPS_PER_PERIOD` x periods the spec is accepted with a
   warning.

Check 2 (the stability region, the scene's rates) is :mod:`sweeps.spec.fixed_step`; this module
holds checks 1 and 3 and :func:`check`, which runs them all.
"""
from __future__ import annotations

import math

from engine import params as P

from .accuracy import numerics
from .fixed_step import dither_periods, stability_faults
from .grid import GridFacts, base_params
from .models import ExplicitAccuracy, is_adaptive

# an adaptive method takes about this many steps per sine period at least (DP5, Sec. 7
# scene, W = 0.1-3, omega = 1e3-3e4: 4.5-16 at draft, 15-53 at standard): past the budget
# with it, warn
WARN_STEPS_PER_PERIOD = 4


# --- options the integrator ignores ---------------------------------------------------

def option_faults(spec, g: GridFacts) -> list[str]:
    """rk4's ``steps_per_period`` without dither, ``step`` with dither (module docstring, 1)."""
    acc = spec.accuracy
    if not isinstance(acc, ExplicitAccuracy) or is_adaptive(acc.integrator):
        return []
    if g.dither == "none" and acc.steps_per_period is not None:
        why = "dither = 'none'" if spec.dither == "none" else "W = 0 everywhere"
        return [f"accuracy.steps_per_period: ignored without dither ({why}): "
                f"{acc.integrator!r} then takes the fixed step accuracy.step; set step instead"]
    if g.dither != "none" and acc.step is not None:
        return [f"accuracy.step: ignored with dither: {acc.integrator!r} divides each dither "
                "period (half-period for a square wave) into steps_per_period steps; set "
                "steps_per_period instead"]
    return []


# --- the step budget ------------------------------------------------------------------

def budget_faults(spec, g: GridFacts, p, numerics) -> tuple[list[str], list[str]]:
    """(refusals, warnings) of the step budget (module docstring, 3); ``p`` the spec's
    parameter vector."""
    s, name, t_end = numerics.settings, numerics.integrator, spec.time.t_end
    fixed = not is_adaptive(name)
    budget = s.max_steps
    where = ("explicit numerics" if isinstance(spec.accuracy, ExplicitAccuracy)
             else f"the {numerics.label} level")
    problems, notes = [], []
    periods = dither_periods(g, t_end)
    if g.dither != "none":
        square = g.dither == "square-velocity"
        unit = ("square-wave switches (omega t_end / pi)" if square
                else "dither periods (omega t_end / 2 pi)")
        if periods > budget:
            each = "a stop and a step at each" if square else "at least a step each to resolve"
            problems.append(f"grid.omega: at omega = {g.omega_max:g} a point has {periods:.3g} "
                            f"{unit}, {each}: over the engine's budget of {budget:.3g} steps "
                            "per point; lower omega or t_end")
        elif fixed and periods * s.steps_per_period > budget:
            field = ("accuracy.steps_per_period" if isinstance(spec.accuracy, ExplicitAccuracy)
                     else "grid.omega")
            problems.append(f"{field}: {name} ({where}) takes {s.steps_per_period} steps x "
                            f"{periods:.3g} {unit} = {periods * s.steps_per_period:.3g} steps "
                            f"at omega = {g.omega_max:g}, over the engine's budget of "
                            f"{budget:.3g} per point; lower omega or t_end, or use fewer "
                            "steps per period (within stability)")
        elif not fixed and not square and periods * WARN_STEPS_PER_PERIOD > budget:
            notes.append(f"grid.omega: at omega = {g.omega_max:g} a point has {periods:.3g} "
                         f"dither periods; at the {WARN_STEPS_PER_PERIOD} or more steps per "
                         f"period {name} takes it may exhaust the budget of {budget:.3g} steps "
                         "per point (status failed); lower omega or t_end if it does")
    elif fixed and t_end / s.h > budget:
        field = "accuracy.step" if isinstance(spec.accuracy, ExplicitAccuracy) else "time.t_end"
        problems.append(f"{field}: {name} ({where}) with step {s.h:g} takes t_end / step = "
                        f"{t_end / s.h:.3g} steps per point, over the engine's budget of "
                        f"{budget:.3g}; shorten t_end, or use a larger step or an adaptive "
                        "integrator")
    if spec.system == "slider" and p[P.SLOW_A] != 0.0 and p[P.SLOW_OMEGA] > 0.0:
        slow = p[P.SLOW_OMEGA] * t_end / (2.0 * math.pi)
        if slow > budget:
            problems.append(f"params.slow_force.omega: {slow:.3g} slow-force periods "
                            "(omega t_end / 2 pi), at least a step each to resolve: over the "
                            f"engine's budget of {budget:.3g} steps per point; lower "
                            "slow_force.omega or t_end")
    return problems, notes


# --- all of it -----------------------------------------------------------------------------

def check(spec) -> tuple[list[str], list[str]]:
    """(refusals, warnings) for a well-typed spec whose grid is within the point budget."""
    if spec.method != "simulate":
        return [], []
    g, p = spec.grid_facts, base_params(spec)
    problems = option_faults(spec, g)
    if problems:
        return problems, []
    num = numerics(spec, float(p[P.SIGMA0]))
    problems = stability_faults(spec, g, p, num)
    found, notes = budget_faults(spec, g, p, num)
    return problems + found, notes
