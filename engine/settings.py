"""Run-time numerical settings of an integration (not compile-time: no recompilation)."""
from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class Settings:
    """Step and tolerance policy of one run.

    Attributes
    ----------
    rtol, atol
        Adaptive methods: relative and absolute local error tolerances.
    steps_per_period
        Fixed-step methods: steps per square-wave half-period, or per dither period
        for a sine, so that the step divides the waveform period exactly.
    h
        Fixed-step methods without dither: the step (time units).
    max_steps
        Budget of accepted + rejected steps per point; past it the point is FAILED.
    """

    rtol: float = 1e-6
    atol: float = 1e-8
    steps_per_period: int = 8
    h: float = 1e-3
    max_steps: int = 50_000_000

    def as_dict(self) -> dict:
        return asdict(self)
