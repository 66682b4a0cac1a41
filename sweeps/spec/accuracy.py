"""Accuracy levels: what ``draft`` / ``standard`` / ``reference`` mean in numerics.

A level names an integrator and its tolerances or step, calibrated by the work-precision
study (``scripts/work_precision.py``, docs/ACCURACY.md): each level keeps the error of the
queried outputs (relative; absolute for time fractions) under :data:`TARGET_ERROR` on the
study's canonical scenes at the least measured cost. Every cube records the settings
actually used in its attributes.

Choice of integrator (:func:`numerics`):

1. ``sigma0 >= STIFF_SIGMA0``: the stiff method with :data:`STIFF_LEVELS`;
2. a (dither, level) pair of :data:`RK4_WHERE` whose fixed step is safely inside RK4's
   stability region on the whole grid (:func:`rk4_fits`): RK4 with :data:`FIXED_STEPS`
   steps per half-period (square wave) or the step :data:`FIXED_H` (no dither);
3. otherwise DP5 with :data:`LEVELS`.
"""
from __future__ import annotations

from dataclasses import dataclass

from engine.settings import Settings

from . import model_params
from .fixed_step import relaxation_factor
from .grid import system_defaults
from .methods import resolve_outputs
from .models import ExplicitAccuracy, Spec

# error each level promises in the queried outputs (relative; absolute for time fractions)
TARGET_ERROR = {"draft": 1e-2, "standard": 1e-4, "reference": 1e-7}

# sigma0 from which the stiff integrator (at STIFF_LEVELS) replaces DP5 (at LEVELS),
# measured on Fig. 10(d) (|u| <= 0.8, omega = 1000; docs/ACCURACY.md "stiff crossover"):
# DP5 1.3-3.6x cheaper at 1e5; at 3e5 RODAS 2.3x cheaper (draft), a tie (standard), DP5
# 1.5x cheaper (reference); RODAS 2-7x cheaper at 1e6
STIFF_SIGMA0 = 3e5
STIFF_METHOD = "rosenbrock"

# DP5 (atol = 1e-3 rtol: states range from z ~ fc/sigma0 = 1e-2 to e ~ 1)
LEVELS = {
    "draft": {"rtol": 1e-5, "atol": 1e-8},
    "standard": {"rtol": 1e-8, "atol": 1e-11},
    "reference": {"rtol": 1e-10, "atol": 1e-13},
}
# the stiff method (RODAS): loose tolerances leave the (tiny) quenched v_slow_p2p wrong at
# sigma0 = 1e6 (docs/ACCURACY.md): draft needs 1e-7, standard 1e-9 there
STIFF_LEVELS = {
    "draft": {"rtol": 1e-7, "atol": 1e-10},
    "standard": {"rtol": 1e-9, "atol": 1e-12},
    "reference": {"rtol": 1e-10, "atol": 1e-13},
}
# DP5 when an elasto-plastic scene asks for slip_fraction or presliding_fraction: sliding is
# |z| >= (1 - slip_gap) z_ss with slip_gap = 1e-9 (engine.observables), so the bristle state
# must be right to ~1e-10 relative. Measured on the Sec. 7 slider without dither (slip
# 0.3498): rtol 1e-9 is 0.014 off, 1e-10 4e-5, 1e-12 1e-5 (docs/ACCURACY.md "phase shares");
# with sine dither the share is ill-conditioned at the 1e-4 level whatever the tolerance
# (near-tangent touches of the gap): hence PROMISE below
PHASE_OUTPUTS = ("slip_fraction", "presliding_fraction")
PHASE_LEVELS = {
    "draft": {"rtol": 1e-10, "atol": 1e-13},
    "standard": {"rtol": 1e-10, "atol": 1e-13},
    "reference": {"rtol": 1e-12, "atol": 1e-15},
}
# The elasto-plastic slider at reference, whatever it is asked: the alpha-booked shares
# (stick_fraction: alpha = 0, near_slip_fraction: alpha >= 0.9, alpha_hist) locate each
# crossing inside a step by the quadratic of rho through its start, midpoint and end, O(h^3)
# per crossing. At reference's DP5 rtol 1e-10 they were 7.6e-7 to 9.6e-7 off (against rtol
# 1e-14, on the error samples of specs/demo-stick-slip.toml and the small fig14 scenes),
# where reference promises 1e-7 (scripts/promise_check.py warned); at 1e-11 1.1e-7 to 1.8e-7,
# at 1e-12 1.9e-8 to 4.5e-8, for 1.5-2.1x the reference cost (docs/ACCURACY.md 5.2)
ELASTOPLASTIC_LEVELS = {"reference": {"rtol": 1e-12, "atol": 1e-15}}
# The static laws (coulomb, stribeck) stick inside the Karnopp band |u| < stick_band (default
# 1e-6), entered only when a landing on its edge ends inside it: DP5's velocity error per step
# must be well below the band. At draft's rtol 1e-5 it crosses the band instead (and chatters
# across it: 10x the steps): on the square-wave slider (v_ref 0.4, omega 300, W 0.2 / 0.4 /
# 0.8, tau in [1, 3]) stick_fraction came out 0.0013 / 0.0002 / 0 where an exact-sticking
# automaton (tests/engine/reference.py) gives 0.3413 / 0.2068 / 0.0017. At rtol 1e-7
# Stribeck still chattered at W = 0.8 (5e-3 off, 13x the steps); from rtol 1e-8 on both laws
# are within 4e-6 in the fewest steps (6 500-8 900 for the three points, 90 000-320 000 at
# rtol 1e-6). Their rtol is therefore at most STATIC_RTOL_PER_BAND * stick_band
# (tests/accuracy/test_static_levels.py)
STATIC_LAWS = ("coulomb", "stribeck")
STATIC_RTOL_PER_BAND = 0.01
# what each level promises per output (relative error; absolute for time fractions): the
# level's TARGET_ERROR, except the two shares that hinge on the sliding gap and the two
# outputs made of sticking runs. A run ends where the trajectory leaves the stick region,
# and near a grazing exit (a near-tangent touch of the stick boundary) whether a long run is
# split in two depends on the integration error: on Fig. 14 (121 points, every 3rd W and
# omega of specs/fig14.toml) against DP5 at rtol 1e-11 (confirmed by RK4 with 256 steps per
# dither period to 1e-6), long_stick_fraction was 2.1e-2 / 2.0e-4 / 6.1e-8 off at draft /
# standard / reference and max_stick 1.3e-1 / 1.7e-3 / 9.6e-6 (relative to max(value,
# long_stick)), where TARGET_ERROR promised 1e-2 / 1e-4 / 1e-7; the zone classes
# (long_stick_fraction > 0) agreed at every level (tests/accuracy/test_run_lengths.py)
PROMISE_OVERRIDES = {
    "slip_fraction": {"draft": 1e-2, "standard": 1e-3, "reference": 1e-4},
    "presliding_fraction": {"draft": 1e-2, "standard": 1e-3, "reference": 1e-4},
    "long_stick_fraction": {"draft": 5e-2, "standard": 1e-3, "reference": 1e-6},
    "max_stick": {"draft": 3e-1, "standard": 1e-2, "reference": 1e-4},
}
FRACTION_OUTPUTS = ("stick_fraction", "presliding_fraction", "slip_fraction",
                    "long_stick_fraction", "near_slip_fraction", "alpha_hist", "stable")


# LuGre has no stick phase: its "stick" is |u| < stick_band (1e-6), a sliver around each
# zero crossing of u located inside a step by a quadratic (O(h^3)); at the reference level
# that is 2e-7 off on Fig. 10(d) (docs/ACCURACY.md 5.1). The static laws stick at
# |u| = stick_band, not 0: their stick times are O(band) off exact sticking (measured 1e-6)
_BAND_FRACTIONS = ("stick_fraction", "slip_fraction", "near_slip_fraction", "alpha_hist")
LAW_PROMISE_OVERRIDES = {
    law: {o: {"reference": 1e-6} for o in _BAND_FRACTIONS} for law in ("lugre", *STATIC_LAWS)
}
# The elasto-plastic slider's mean friction at draft: each stick-slip event's timing moves
# F_mean, as it moves the run lengths above. On specs/demo-stick-slip.toml (49 points, sine
# dither up to omega = 2000) draft (DP5 rtol 1e-5) against standard was 3.4e-2 off at most
# (W = 2, omega = 2000; 9 of 49 points above 1e-2), which the error estimate reported as the
# demo's first output line (issue 30; scripts/promise_check.py, docs/ACCURACY.md 5.2). Its
# near_slip_fraction (alpha >= 0.9) moves with the same events: on the whole demo grid
# draft against standard was 1.06e-2 off at one point of 49 (0.83e-2 at most on the small
# Fig. 14 scene), which the 12-point error sample reports or not as the sweep's id draws it
# (scripts/promise_check.py's grid comparison, docs/ACCURACY.md 5.3)
LAW_PROMISE_OVERRIDES["elastoplastic"] = {"F_mean": {"draft": 5e-2},
                                          "near_slip_fraction": {"draft": 2e-2}}
# GMS at draft: each element's slip and stick moves the trajectory, as the elasto-plastic
# events do. On a 50-point sine-dithered slider (three elements, W 0..0.8, omega 10..300,
# v_ref 0.1 and 0.4, tau 30..60) draft (DP5 rtol 1e-5) against standard was at most 1.6e-2
# off in v_mean, 1.2e-2 in F_mean, 1.3e-2 in stick_fraction and 1.4e-2 in slip_fraction, all
# at one point (W 0.4, omega 300, v_ref 0.4), the other 49 within 1e-2; standard against
# reference within 2e-6 (scripts/promise_check.py --spec, docs/ACCURACY.md 5.4)
LAW_PROMISE_OVERRIDES["gms"] = {o: {"draft": 5e-2} for o in (
    "v_mean", "F_mean", "stick_fraction", "slip_fraction", "presliding_fraction")}


def promise(level: str, output: str, friction: str | None = None) -> float:
    """The error ``level`` promises for ``output`` (absolute for fractions; relative
    otherwise, ``max_stick`` relative to ``max(value, long_stick)``) under ``friction``."""
    law = LAW_PROMISE_OVERRIDES.get(friction or "", {}).get(output, {})
    return law.get(level, PROMISE_OVERRIDES.get(output, {}).get(level, TARGET_ERROR[level]))


def needs_phase_accuracy(spec: Spec) -> bool:
    """True when the spec asks for a share that hinges on the sliding gap (PHASE_LEVELS)."""
    return (spec.method == "simulate" and spec.friction == "elastoplastic"
            and any(o in PHASE_OUTPUTS
                    for o in resolve_outputs(spec.method, spec.outputs, spec.system)))


# RK4: steps per square-wave half-period (per period for a sine), and the step without
# dither; errors on Fig. 10(d): N = 1: 1.3e-4, 4: 1.1e-5, 64: 2.4e-8; Fig. 10(a):
# h = 1e-2: 2.9e-6, 5e-3: 5.9e-7, 1e-3: 2.8e-8
FIXED_STEPS = {"draft": 1, "standard": 4, "reference": 64}
FIXED_H = {"draft": 1e-2, "standard": 5e-3, "reference": 1e-3}
# where RK4 beats DP5: square wave at draft (1.8x fewer evaluations on Fig. 10(d)). (No
# dither at reference was RK4 h = 1e-3 while v_slow_p2p sampled the velocity peaks at the
# step ends only; with each step's peak taken from its quadratic, DP5 at rtol 1e-10 is
# 1.6e-8 off in 5.6 ms where RK4 was 1.3e-7 in 24 ms, Fig. 10(a), engine.observables)
RK4_WHERE = {"square-velocity": ("draft",)}
# RK4 only while h * sigma0 * u_max / fc <= this (the bristle relaxation rate, Eq. 2.3
# linearised; u_max = 2 max|v_ref| + max W); Fig. 10(d) at N = 1 sits at 0.38
RK4_MAX_H_LAMBDA = 0.5


@dataclass(frozen=True)
class Numerics:
    integrator: str
    settings: Settings
    label: str

    def as_dict(self) -> dict:
        return {"integrator": self.integrator, "label": self.label, **self.settings.as_dict()}


def default_integrator(sigma0: float) -> str:
    from engine.integrators import METHODS

    if sigma0 >= STIFF_SIGMA0 and STIFF_METHOD in METHODS:
        return STIFF_METHOD
    return "dopri5"


def rk4_fits(spec: Spec, sigma0: float, level: str) -> bool:
    """True when RK4 at ``level`` is the calibrated choice for ``spec`` (module docstring)."""
    g = spec.grid_facts
    if level not in RK4_WHERE.get(g.dither, ()) or spec.method != "simulate":
        return False
    if needs_phase_accuracy(spec) or spec.friction in STATIC_LAWS:
        return False                 # RK4 lands neither on alpha's kinks nor on the band
    if g.dither != "none" and not g.omega_min > 0:
        return False
    h = g.largest_step(FIXED_STEPS[level], FIXED_H[level])
    fc = spec.params.fc or system_defaults(spec.system)["fc"]
    rate = sigma0 * relaxation_factor(spec) * (2.0 * g.v_max + g.W_max) / fc
    return h * rate <= RK4_MAX_H_LAMBDA


def numerics(spec: Spec, sigma0: float, level: str | None = None) -> Numerics:
    """Integrator and Settings for ``spec`` at its own accuracy or at ``level``."""
    acc = level or spec.accuracy
    if isinstance(acc, ExplicitAccuracy):
        base = Settings()
        settings = Settings(
            rtol=acc.rtol or base.rtol, atol=acc.atol or (acc.rtol or base.rtol) * 1e-3,
            atol_units=acc.atol_units or model_params.atol_units(spec),
            steps_per_period=acc.steps_per_period or base.steps_per_period,
            h=acc.step or base.h)
        return Numerics(acc.integrator, settings, "explicit")
    integrator = default_integrator(sigma0)
    if integrator == "dopri5" and rk4_fits(spec, sigma0, acc):
        integrator = "rk4"
    if integrator == STIFF_METHOD:
        tol = STIFF_LEVELS[acc]
    else:
        tol = PHASE_LEVELS[acc] if needs_phase_accuracy(spec) else LEVELS[acc]
        if spec.friction == "elastoplastic" and spec.method == "simulate":
            tol = ELASTOPLASTIC_LEVELS.get(acc, tol)
    if spec.friction in STATIC_LAWS:
        tol = _static_tol(spec, tol)
    settings = Settings(rtol=tol["rtol"], atol=tol["atol"], steps_per_period=FIXED_STEPS[acc],
                        h=FIXED_H[acc], atol_units=model_params.atol_units(spec))
    return Numerics(integrator, settings, acc)


def _static_tol(spec: Spec, tol: dict) -> dict:
    """``tol`` tightened until the step's velocity error fits well inside the Karnopp band
    (``STATIC_RTOL_PER_BAND``); atol keeps the levels' ratio 1e-3 to rtol."""
    band = spec.params.stick_band or system_defaults(spec.system)["stick_band"]
    rtol = min(tol["rtol"], STATIC_RTOL_PER_BAND * band)
    return {"rtol": rtol, "atol": min(tol["atol"], 1e-3 * rtol)}
