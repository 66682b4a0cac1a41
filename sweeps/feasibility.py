"""Can the engine run a spec as asked? Spec-time checks of the numerics (issue 10).

Called by :func:`sweeps.spec.parse_spec` once the spec is well-typed and its grid is
within the point budget, so that ``ditherlab plan`` and ``submit`` refuse, with one line
each, what would otherwise fail point by point at run time, or worse, finish with status
ok and wrong numbers.

1. **Options the integrator ignores** (explicit ``accuracy``): ``rk4`` with dither
   divides each dither (half-)period into ``steps_per_period`` steps and ignores ``step``;
   without dither (``dither = "none"`` or ``W = 0`` everywhere) it takes ``step`` and
   ignores ``steps_per_period``. (rtol/atol for rk4, step/steps_per_period for adaptive
   methods are refused by :class:`sweeps.spec.ExplicitAccuracy` itself.)

2. **Stability of a fixed step.** On the linear test equation ``y' = lambda y`` a
   Runge-Kutta step multiplies ``y`` by ``R(h lambda)``, ``R(z) = 1 + z b^T (I - z A)^-1 1``
   from the method's Butcher tableau; the step is stable while ``|R(h lambda)| <= 1``
   (Hairer & Wanner, *Solving ODEs II*, Sec. IV.2). For classical RK4, ``R(z) = 1 + z + z^2/2
   + z^3/6 + z^4/24``: the region reaches -2.785 on the negative real axis and
   ``2 sqrt 2 = 2.828`` on the imaginary axis (HW II, Fig. IV.2.1). :func:`reach` computes
   how far it reaches along any direction from the engine's own tableau. The eigenvalues
   of a scene, estimated over the whole grid (:func:`rates`):

   - the bristle relaxation of LuGre and elasto-plastic friction (Eq. 2.3 linearised in z
     for frozen u; engine.friction.lugre.rate): ``lambda = -sigma0 |u| / g(u)``, ``g >= fc``,
     ``|u| <= u_max``; slider ``u_max = 2 max|v_ref| + max W + |A|`` (the estimate of
     :func:`sweeps.accuracy.rk4_fits` plus the slow force of amplitude ``A``, which on the
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
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from engine import params as P

# an adaptive method takes about this many steps per sine period at least (DP5, Sec. 7
# scene, W = 0.1-3, omega = 1e3-3e4: 4.5-16 at draft, 15-53 at standard): past the budget
# with it, warn
WARN_STEPS_PER_PERIOD = 4
SINES = ("sine-velocity", "sine-force")
BRISTLE_LAWS = ("lugre", "elastoplastic")


# --- the stability region of a fixed-step method -----------------------------------------

def stability_polynomial(tableau) -> np.ndarray:
    """Coefficients (lowest power first) of ``R(z) = 1 + z b^T (I - z A)^-1 1`` of an
    explicit Runge-Kutta tableau: ``R(z) = sum_k z^k b^T A^(k-1) 1`` (a polynomial, A being
    nilpotent). RK4: 1, 1, 1/2, 1/6, 1/24."""
    a = np.asarray(tableau.a, dtype=float)
    b = np.asarray(tableau.b, dtype=float)
    coeffs, v = [1.0], np.ones(len(b))
    for _ in range(len(b)):
        coeffs.append(float(b @ v))
        v = a @ v
    return np.array(coeffs)


def _direction(z: complex) -> float:
    """The angle of ``z``, snapped onto the real and imaginary axes (where RK4's region
    has its boundary on the axis itself, so a rounding error must not leave it)."""
    if abs(z.imag) <= 1e-9 * abs(z):
        return math.pi if z.real < 0 else 0.0
    if abs(z.real) <= 1e-9 * abs(z):
        return math.pi / 2
    return cmath.phase(complex(z.real, abs(z.imag)))   # the region is symmetric in Im


@lru_cache(maxsize=256)
def reach(integrator: str, angle: float) -> float:
    """How far the stability region of ``integrator`` reaches from 0 along the ray
    ``t e^{i angle}``: the first ``t`` with ``|R| > 1`` (HW II, Sec. IV.2). RK4: 2.785 at
    ``angle = pi`` (negative real axis), ``2 sqrt 2 = 2.828`` at ``pi / 2`` (imaginary
    axis)."""
    from engine.integrators import METHODS

    poly = stability_polynomial(METHODS[integrator].TABLEAU)
    ray = cmath.exp(1j * angle)

    def inside(t):
        return np.abs(np.polynomial.polynomial.polyval(t * ray, poly)) <= 1.0 + 1e-9

    t = np.linspace(0.0, 20.0, 20_001)[1:]
    out = np.flatnonzero(~inside(t))
    if out.size == 0:
        return math.inf
    lo, hi = (t[out[0] - 1] if out[0] else 0.0), t[out[0]]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if inside(mid) else (lo, mid)
    return float(lo)


# --- the scene's rates --------------------------------------------------------------------

@dataclass(frozen=True)
class Rate:
    """One eigenvalue (estimate) of the scene. ``per_step`` means ``h lambda`` does not
    depend on omega (the dither itself: ``2 pi i / N``)."""

    what: str
    lam: complex
    per_step: bool = False


@dataclass(frozen=True)
class Grid:
    """What the checks need of the grid: extremes, the effective dither, parameters."""

    dither: str          # "none" when the spec has no dither or W = 0 everywhere
    W_max: float
    v_max: float
    omega_min: float
    omega_max: float
    p: np.ndarray


def _grid(spec) -> Grid:
    from . import grid
    from .plan import base_params

    W = grid.axis_values(spec, "W")
    omega = grid.axis_values(spec, "omega")
    v_ref = grid.axis_values(spec, "v_ref")
    dither = spec.dither if spec.dither != "none" and W.any() else "none"
    return Grid(dither, float(np.abs(W).max()), float(np.abs(v_ref).max()),
                float(omega.min()), float(omega.max()), base_params(spec))


def rates(spec, g: Grid) -> list[Rate]:
    """The scene's eigenvalue estimates (module docstring, 2)."""
    p = g.p
    out = []
    slider = spec.system == "slider"
    slow_a, slow_omega = abs(p[P.SLOW_A]), p[P.SLOW_OMEGA]
    if spec.friction in BRISTLE_LAWS:
        sigma0, fc = p[P.SIGMA0], min(p[P.FC], p[P.FS])
        if slider:
            u_max = 2.0 * g.v_max + g.W_max + slow_a
            out.append(Rate(f"bristle relaxation sigma0 u_max / fc (u_max = 2 v_ref + W + "
                            f"|slow force| = {u_max:.3g})", -sigma0 * u_max / fc))
            c, k = p[P.SIGMA1] + p[P.SIGMA2], sigma0 + 1.0
            root = cmath.sqrt(c * c / 4.0 - k)
            out.append(Rate("stuck bristle as a spring-damper", -c / 2.0 - root))
        else:
            u_max = g.v_max + g.W_max
            out.append(Rate(f"bristle relaxation sigma0 u_max / fc (u_max = v_ref + W = "
                            f"{u_max:.3g})",
                            -sigma0 * u_max / fc))
    if g.dither in SINES:
        out.append(Rate("sine dither (h omega)", 1j, per_step=True))
    if slider and slow_a != 0.0 and slow_omega > 0.0:
        out.append(Rate("slow force (h slow_omega)", 1j * slow_omega))
    return out


def _step(g: Grid, settings) -> float:
    """The largest fixed step of the grid (at the smallest omega), as the driver sets it."""
    n = settings.steps_per_period
    if g.dither == "square-velocity":
        return math.pi / g.omega_min / n
    if g.dither in SINES:
        return 2.0 * math.pi / g.omega_min / n
    return settings.h


def stability_faults(spec, g: Grid, numerics) -> list[str]:
    """One line when the explicit fixed step is outside its method's stability region."""
    from .spec_models import ExplicitAccuracy, is_adaptive

    acc = spec.accuracy
    if not isinstance(acc, ExplicitAccuracy) or is_adaptive(numerics.integrator):
        return []
    from engine.integrators import METHODS

    if METHODS[numerics.integrator].TABLEAU is None:   # no tableau, no known region
        return []
    s, name = numerics.settings, numerics.integrator
    h = _step(g, s)
    worst, ratio, zbest = None, 0.0, 0j
    for rate in rates(spec, g):
        z = (2j * math.pi / s.steps_per_period) if rate.per_step else h * rate.lam
        if z == 0:
            continue
        r = abs(z) / reach(name, _direction(z))
        if r > ratio:
            worst, ratio, zbest = rate, r, z
    if worst is None or ratio <= 1.0:
        return []
    bound = reach(name, _direction(zbest))
    axis = ("real axis" if abs(zbest.imag) < 1e-12 * abs(zbest) else
            "imaginary axis" if abs(zbest.real) < 1e-12 * abs(zbest) else "that direction")
    where = "" if worst.per_step or g.dither == "none" else f" at omega = {g.omega_min:g}"
    head = (f"{name} unstable, |h lambda| = {abs(zbest):.3g} > {bound:.4g} (its stability "
            f"bound on the {axis}) for the {worst.what}{where}")
    if g.dither == "none":
        field = "accuracy.step" if acc.step is not None else "accuracy"
        fix = f"use step <= {_floor3(h / ratio):g}"
    else:
        field = "accuracy.steps_per_period" if acc.steps_per_period is not None else "accuracy"
        need = math.ceil(s.steps_per_period * ratio * (1.0 + 1e-9))
        fix = f"use steps_per_period >= {need}"
        if need * _periods(g, spec.time.t_end) > s.max_steps:
            fix = "the steps it needs exceed the step budget: use"
    return [f"{field}: {head}; {fix} or an adaptive integrator ('dopri5')"]


def _floor3(x: float) -> float:
    """``x`` rounded down to 3 significant digits."""
    if x <= 0 or not math.isfinite(x):
        return x
    scale = 10.0 ** (math.floor(math.log10(x)) - 2)
    return math.floor(x / scale) * scale


def _periods(g: Grid, t_end: float) -> float:
    """Dither (half-)periods of the grid's fastest point: square-wave switches, or sine
    periods; 0 without dither."""
    if g.dither == "square-velocity":
        return g.omega_max * t_end / math.pi
    if g.dither in SINES:
        return g.omega_max * t_end / (2.0 * math.pi)
    return 0.0


# --- options the integrator ignores ---------------------------------------------------

def option_faults(spec, g: Grid) -> list[str]:
    """rk4's ``steps_per_period`` without dither, ``step`` with dither (module docstring, 1)."""
    from .spec_models import ExplicitAccuracy, is_adaptive

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

def budget_faults(spec, g: Grid, numerics) -> tuple[list[str], list[str]]:
    """(refusals, warnings) of the step budget (module docstring, 3)."""
    from .spec_models import ExplicitAccuracy, is_adaptive

    s, name, t_end = numerics.settings, numerics.integrator, spec.time.t_end
    fixed = not is_adaptive(name)
    budget = s.max_steps
    where = ("explicit numerics" if isinstance(spec.accuracy, ExplicitAccuracy)
             else f"the {numerics.label} level")
    problems, notes = [], []
    periods = _periods(g, t_end)
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
    p = g.p
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
    from .accuracy import numerics

    if spec.method != "simulate":
        return [], []
    g = _grid(spec)
    problems = option_faults(spec, g)
    if problems:
        return problems, []
    num = numerics(spec, float(g.p[P.SIGMA0]))
    problems = stability_faults(spec, g, num)
    found, notes = budget_faults(spec, g, num)
    return problems + found, notes
