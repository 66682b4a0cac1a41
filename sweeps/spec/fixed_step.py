"""Whether an explicit fixed step is stable on the scene (check 2 of
:mod:`sweeps.spec.feasibility`): the scene's eigenvalue estimates over the grid
(:func:`rates`) against the method's stability region (engine.integrators.stability_region),
at the largest step the grid gives (:meth:`sweeps.spec.grid.GridFacts.largest_step`); and
the dither (half-)periods a point must step through (:func:`dither_periods`). The equations
and the measurements behind them are in the docstring of :mod:`sweeps.spec.feasibility`.
"""
from __future__ import annotations

import cmath
import math
import numbers
from dataclasses import dataclass

from engine import params as P

from .grid import GridFacts
from .models import ExplicitAccuracy, is_adaptive

SINES = ("sine-velocity", "sine-force")
BRISTLE_LAWS = ("lugre", "elastoplastic", "dahl")   # a bristle of stiffness sigma0


# --- the scene's rates --------------------------------------------------------------------

@dataclass(frozen=True)
class Rate:
    """One eigenvalue (estimate) of the scene. ``per_step`` means ``h lambda`` does not
    depend on omega (the dither itself: ``2 pi i / N``)."""

    what: str
    lam: complex
    per_step: bool = False


def relaxation_factor(spec) -> float:
    """The spec's law's ``relaxation_factor`` (engine.contract.FrictionLaw) for its own
    parameter values: 1 for LuGre and the elasto-plastic law, ``a 2**(a - 1)`` for Dahl.
    A brought law's hook that fails, or answers no positive number, is one ModelError line."""
    from engine import registry
    from engine.contract import ModelError
    from engine.user_code import hook, short

    law = registry.law(spec.friction)
    values = registry.check_values(spec.friction, spec.system, spec.model_values)
    mine = {name: values[name] for name in registry.own_params(law)}
    f = hook(spec.friction, "relaxation_factor", law.relaxation_factor, mine)
    try:   # (float(10**400) overflows)
        ok = not isinstance(f, bool) and isinstance(f, numbers.Real) and 0.0 < float(f) < math.inf
    except OverflowError:
        ok = False
    if not ok:
        raise ModelError(f"{spec.friction!r}: relaxation_factor must return a positive "
                         f"number, got {short(f)}")
    return float(f)


def bristle_like(spec) -> bool:
    """Whether the spec's law has a bristle whose relaxation the explicit step must resolve:
    LuGre, elasto-plastic, Dahl, and a brought law that declares its ``relaxation_factor``
    (one that inherits the contract's default says nothing about its states: GMS's do not
    relax at ``sigma0``)."""
    from engine import registry
    from engine.contract import FrictionLaw

    if spec.friction in BRISTLE_LAWS:
        return True
    own = type(registry.law(spec.friction)).relaxation_factor
    return registry.is_import_path(spec.friction) and own is not FrictionLaw.relaxation_factor


def rates(spec, g: GridFacts, p) -> list[Rate]:
    """The scene's eigenvalue estimates (sweeps.spec.feasibility docstring, 2); ``p`` the
    spec's parameter vector (sweeps.spec.grid.base_params)."""
    out = []
    slider = spec.system == "slider"
    slow_a, slow_omega = abs(p[P.SLOW_A]), p[P.SLOW_OMEGA]
    if bristle_like(spec):
        sigma0, fc = p[P.SIGMA0], min(p[P.FC], p[P.FS])
        rate = sigma0 * relaxation_factor(spec) / fc    # x u_max
        if slider:
            u_max = 2.0 * g.v_max + g.W_max + slow_a
            out.append(Rate(f"bristle relaxation sigma0 u_max / fc (u_max = 2 v_ref + W + "
                            f"|slow force| = {u_max:.3g})", -rate * u_max))
            # sigma1 is LuGre's and elasto-plastic's (|lambda|^2 = k whatever the damping)
            damping = p[P.SIGMA1] if spec.friction in ("lugre", "elastoplastic") else 0.0
            c, k = damping + p[P.SIGMA2], sigma0 + 1.0
            root = cmath.sqrt(c * c / 4.0 - k)
            out.append(Rate("stuck bristle as a spring-damper", -c / 2.0 - root))
        else:
            u_max = g.v_max + g.W_max
            out.append(Rate(f"bristle relaxation sigma0 u_max / fc (u_max = v_ref + W = "
                            f"{u_max:.3g})", -rate * u_max))
    if g.dither in SINES:
        out.append(Rate("sine dither (h omega)", 1j, per_step=True))
    if slider and slow_a != 0.0 and slow_omega > 0.0:
        out.append(Rate("slow force (h slow_omega)", 1j * slow_omega))
    return out


def stability_faults(spec, g: GridFacts, p, numerics) -> list[str]:
    """One line when the explicit fixed step is outside its method's stability region."""
    acc = spec.accuracy
    if not isinstance(acc, ExplicitAccuracy) or is_adaptive(numerics.integrator):
        return []
    from engine.integrators import METHODS
    from engine.integrators.stability_region import direction, reach

    if METHODS[numerics.integrator].TABLEAU is None:   # no tableau, no known region
        return []
    s, name = numerics.settings, numerics.integrator
    h = g.largest_step(s.steps_per_period, s.h)
    worst, ratio, zbest = None, 0.0, 0j
    for rate in rates(spec, g, p):
        z = (2j * math.pi / s.steps_per_period) if rate.per_step else h * rate.lam
        if z == 0:
            continue
        r = abs(z) / reach(name, direction(z))
        if r > ratio:
            worst, ratio, zbest = rate, r, z
    if worst is None or ratio <= 1.0:
        return []
    bound = reach(name, direction(zbest))
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
        if need * dither_periods(g, spec.time.t_end) > s.max_steps:
            fix = "the steps it needs exceed the step budget: use"
    return [f"{field}: {head}; {fix} or an adaptive integrator ('dopri5')"]


def _floor3(x: float) -> float:
    """``x`` rounded down to 3 significant digits."""
    if x <= 0 or not math.isfinite(x):
        return x
    scale = 10.0 ** (math.floor(math.log10(x)) - 2)
    return math.floor(x / scale) * scale


def dither_periods(g: GridFacts, t_end: float) -> float:
    """Dither (half-)periods of the grid's fastest point: square-wave switches, or sine
    periods; 0 without dither."""
    if g.dither == "square-velocity":
        return g.omega_max * t_end / math.pi
    if g.dither in SINES:
        return g.omega_max * t_end / (2.0 * math.pi)
    return 0.0
