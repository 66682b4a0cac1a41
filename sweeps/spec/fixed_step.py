"""The stability of an explicit fixed step (check 2 of :mod:`sweeps.spec.feasibility`): the
stability region of a Runge-Kutta method from its Butcher tableau (:func:`reach`), the
scene's eigenvalue estimates over the grid (:func:`rates`), and the few facts of the grid
every feasibility check needs (:class:`Grid`: extremes, the effective dither, parameters;
:func:`dither_periods`). The equations and the measurements behind them are in the docstring of
:mod:`sweeps.spec.feasibility`.
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from engine import params as P

from . import grid
from .models import ExplicitAccuracy, is_adaptive

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


def grid_summary(spec) -> Grid:
    """The :class:`Grid` of ``spec`` (its axes are built: call after the point budget)."""
    W = grid.axis_values(spec, "W")
    omega = grid.axis_values(spec, "omega")
    v_ref = grid.axis_values(spec, "v_ref")
    dither = spec.dither if spec.dither != "none" and W.any() else "none"
    return Grid(dither, float(np.abs(W).max()), float(np.abs(v_ref).max()),
                float(omega.min()), float(omega.max()), grid.base_params(spec))


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
        if need * dither_periods(g, spec.time.t_end) > s.max_steps:
            fix = "the steps it needs exceed the step budget: use"
    return [f"{field}: {head}; {fix} or an adaptive integrator ('dopri5')"]


def _floor3(x: float) -> float:
    """``x`` rounded down to 3 significant digits."""
    if x <= 0 or not math.isfinite(x):
        return x
    scale = 10.0 ** (math.floor(math.log10(x)) - 2)
    return math.floor(x / scale) * scale


def dither_periods(g: Grid, t_end: float) -> float:
    """Dither (half-)periods of the grid's fastest point: square-wave switches, or sine
    periods; 0 without dither."""
    if g.dither == "square-velocity":
        return g.omega_max * t_end / math.pi
    if g.dither in SINES:
        return g.omega_max * t_end / (2.0 * math.pi)
    return 0.0
