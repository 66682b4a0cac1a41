"""Accuracy levels: what ``draft`` / ``standard`` / ``reference`` mean in numerics.

A level names an integrator and its tolerances or step. The provisional table below is
to be calibrated from the work-precision study (``scripts/work_precision.py``); every
cube records the settings actually used in its attributes.
"""
from __future__ import annotations

from dataclasses import dataclass

from engine.settings import Settings

from .spec import ExplicitAccuracy, Spec

# sigma0 from which the stiff integrator replaces explicit DP5 (bristle time scale
# g / (sigma0 |u|) below ~1e-4 tau makes explicit steps stability-bound, not accuracy-bound)
STIFF_SIGMA0 = 1e4
STIFF_METHOD = "rosenbrock"

LEVELS = {
    "draft": dict(rtol=1e-4, atol=1e-7),
    "standard": dict(rtol=1e-6, atol=1e-9),
    "reference": dict(rtol=1e-9, atol=1e-12),
}
FIXED_STEPS = {"draft": 2, "standard": 4, "reference": 16}


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


def numerics(spec: Spec, sigma0: float, level: str | None = None) -> Numerics:
    """Integrator and Settings for ``spec`` at its own accuracy or at ``level``."""
    acc = level or spec.accuracy
    if isinstance(acc, ExplicitAccuracy):
        base = Settings()
        settings = Settings(
            rtol=acc.rtol or base.rtol, atol=acc.atol or (acc.rtol or base.rtol) * 1e-3,
            steps_per_period=acc.steps_per_period or base.steps_per_period,
            h=acc.step or base.h)
        return Numerics(acc.integrator, settings, "explicit")
    integrator = default_integrator(sigma0)
    tol = LEVELS[acc]
    settings = Settings(rtol=tol["rtol"], atol=tol["atol"], steps_per_period=FIXED_STEPS[acc])
    return Numerics(integrator, settings, acc)
