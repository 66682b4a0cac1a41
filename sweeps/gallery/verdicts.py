"""Verdicts computed from numbers: a figure's claim is split into checks, each a measured
quantity against a threshold stated here, and the verdict follows from the checks.

- ``holds``: every check passes; ``does not hold``: none passes (or a check marked
  ``decisive`` fails); ``holds in part``: the rest.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

HOLDS, PARTLY, FAILS = "holds", "holds in part", "does not hold"
#: a figure whose computation raised: no verdict on the paper's claim at all
NOT_COMPUTED = "not computed"


@dataclass
class Check:
    """One sub-claim: what the paper says, what was measured, the rule, the outcome."""

    claim: str
    measured: str
    rule: str
    ok: bool
    decisive: bool = False   # a failure of this check alone makes the claim fail

    def line(self) -> str:
        mark = "ok" if self.ok else "NO"
        return f"[{mark}] {self.claim}: {self.measured} (rule: {self.rule})"


@dataclass
class FigureResult:
    """A gallery figure: what the paper claims, the numbers, the verdict and the readings.

    ``numbers`` holds the claim's quantities by name (the tests pin them); ``choices`` every
    place where the paper is ambiguous, silent or wrong and the reading taken here.
    """

    key: str
    title: str
    ref: str
    claim: str
    png: Path
    checks: list[Check]
    numbers: dict[str, float] = field(default_factory=dict)
    choices: list[str] = field(default_factory=list)
    wall: float = 0.0
    error: str | None = None          # why the figure could not be computed

    @property
    def verdict(self) -> str:
        return NOT_COMPUTED if self.error else verdict(self.checks)

    @property
    def reason(self) -> str:
        bad = [c for c in self.checks if not c.ok]
        pick = bad if bad and len(bad) < len(self.checks) else self.checks
        return "; ".join(f"{c.claim}: {c.measured}" for c in pick)


def verdict(checks: list[Check]) -> str:
    if not checks:
        raise ValueError("a verdict needs at least one check")
    passed = [c.ok for c in checks]
    if all(passed):
        return HOLDS
    if not any(passed) or any(c.decisive and not c.ok for c in checks):
        return FAILS
    return PARTLY


def below(claim: str, name: str, value: float, limit: float, fmt: str = ".3g", **kw) -> Check:
    """``value < limit``."""
    return Check(claim, f"{name} = {value:{fmt}}", f"< {limit:{fmt}}",
                 bool(value < limit), **kw)


def above(claim: str, name: str, value: float, limit: float, fmt: str = ".3g", **kw) -> Check:
    """``value > limit``."""
    return Check(claim, f"{name} = {value:{fmt}}", f"> {limit:{fmt}}",
                 bool(value > limit), **kw)


def monotone(claim: str, name: str, xs, ys, *, increasing: bool, tol: float = 0.0,
             fmt: str = ".3g", **kw) -> Check:
    """``ys`` non-decreasing (``increasing``) or non-increasing along ``xs``, up to ``tol``."""
    pairs = ", ".join(f"{x:g}: {y:{fmt}}" for x, y in zip(xs, ys))
    steps = [b - a for a, b in zip(ys, ys[1:])]
    ok = all(s >= -tol for s in steps) if increasing else all(s <= tol for s in steps)
    word = "non-decreasing" if increasing else "non-increasing"
    return Check(claim, f"{name} ({pairs})", f"{word} within {tol:g}", bool(ok), **kw)
