"""Verdicts computed from numbers: a figure's claim is split into checks, each a measured
quantity against a threshold stated here, and the verdict follows from the checks.

- ``holds``: every check passes; ``does not hold``: none passes (or a check marked
  ``decisive`` fails); ``holds in part``: the rest.
- A check may belong to a *reading* (``reading="vd = 0.1"``): a value the paper does not
  give, read one way. Each reading is judged on the common checks plus its own; the figure
  holds if every reading holds, does not hold if none holds in any part, and holds in part
  otherwise, its reason naming the readings under which it holds.
- A threshold that is a convention (not the paper's number) says so: ``convention=``.
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
    reading: str = ""        # the reading of an unstated value this check belongs to
    convention: str = ""     # why the threshold is what it is, when the paper gives none

    @property
    def rule_text(self) -> str:
        return self.rule + (f" [convention: {self.convention}]" if self.convention else "")

    def line(self) -> str:
        mark = "ok" if self.ok else "NO"
        where = f"({self.reading}) " if self.reading else ""
        return f"[{mark}] {where}{self.claim}: {self.measured} (rule: {self.rule_text})"


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
    computed: str = ""                # which points were computed (a refined sweep)
    loose: list[str] = field(default_factory=list)   # where the paper is loose or wrong

    @property
    def readings(self) -> dict[str, str]:
        """Reading -> its verdict (common checks plus its own); empty without readings."""
        names = list(dict.fromkeys(c.reading for c in self.checks if c.reading))
        common = [c for c in self.checks if not c.reading]
        return {n: verdict(common + [c for c in self.checks if c.reading == n])
                for n in names}

    @property
    def verdict(self) -> str:
        if self.error:
            return NOT_COMPUTED
        per = self.readings
        if not per:
            return verdict(self.checks)
        if all(v == HOLDS for v in per.values()):
            return HOLDS
        return FAILS if all(v == FAILS for v in per.values()) else PARTLY

    @property
    def reason(self) -> str:
        bad = [c for c in self.checks if not c.ok]
        pick = bad if bad and len(bad) < len(self.checks) else self.checks
        text = "; ".join(f"{c.claim}: {c.measured}" for c in pick)
        per = self.readings
        if per:
            text = ("; ".join(f"{v} under {n}" for n, v in per.items()) + ". " + text)
        return text


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
    xs, ys = list(xs), list(ys)
    steps = [b - a for a, b in zip(ys, ys[1:])]
    bad = [k for k, s in enumerate(steps) if (s < -tol if increasing else s > tol)]
    ok = not bad
    if len(xs) <= 8:
        pairs = ", ".join(f"{x:g}: {y:{fmt}}" for x, y in zip(xs, ys))
    else:   # a long series: its ends and where it first turns
        pairs = (f"{len(xs)} values, {xs[0]:g}: {ys[0]:{fmt}} ... {xs[-1]:g}: {ys[-1]:{fmt}}"
                 + (f"; turns between {xs[bad[0]]:g} and {xs[bad[0] + 1]:g}, "
                    f"{len(bad)} of {len(steps)} steps" if bad else ""))
    word = "non-decreasing" if increasing else "non-increasing"
    return Check(claim, f"{name} ({pairs})", f"{word} within {tol:g}", bool(ok), **kw)
