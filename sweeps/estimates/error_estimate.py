"""The error estimate of every simulated cube, and the gate that makes it loud.

After a sweep, a sample of its points is integrated again 100x more accurately (the same
integrator at tolerances / 100, or 4x the steps of a fixed-step method; the next level up
where that is the same run or another integrator: :func:`finer_numerics`) and the observed
change per output is compared with what the sweep's level promises for that output
(:func:`sweeps.spec.accuracy.promise`: absolute for time fractions, relative otherwise;
explicit numerics are held to the ``standard`` promise). The result is stored in the cube's
``error_estimate`` attribute::

    {"compared_with": "reference", "sample_points": 12, "level": "standard",
     "change": {"F_mean": 3e-6, ...}, "promise": {"F_mean": 1e-4, ...},
     "warnings": ["slip_fraction: changed by 2.1e-02 at a finer level ..."]}

and every warning also in the ``accuracy_warnings`` attribute (one string, ``; ``-joined),
which ``ditherlab status``, ``query`` and ``map`` print.

The sample (:func:`sample_index`) is stratified: the corners of the swept (W, omega)
plane, the most expensive point (largest omega * W), and a Latin hypercube over the grid's
axes (seeded by the sweep id, so a rerun samples the same points) -- :data:`SAMPLE_SIZE`
points in all (every point of a smaller grid). The change is *observed*, not a bound:
where the level is converged it is close to the true error; where it is not, it says so.
"""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np

from engine import params as P
from engine import status as S

from ..spec.accuracy import FRACTION_OUTPUTS, Numerics, numerics, promise
from ..planning.plan import Plan

FINER = {"draft": "standard", "standard": "reference", "reference": None, "explicit": None}
SAMPLE_SIZE = 12
# a relative change is measured against max(|value|, REL_FLOOR * the sample's largest |value|)
# (a quenched v_slow_p2p of 1e-7 has no meaningful relative error)
REL_FLOOR = 1e-3


def finer_numerics(plan: Plan) -> Numerics:
    """The numerics the error sample is re-run at: the sweep's own integrator at tolerances
    / 100 (4x the steps of a fixed-step method), labelled ``<level>/100``, or the next level
    up where it is 10x to 100x tighter (standard -> reference on DP5, the stiff method's
    levels) or runs another integrator (an independent method). On the CPU whatever the
    sweep's device: a dozen points, each on one GPU thread 10-24x slower than on a core
    (docs/GPU.md, an H200), would be a GPU sweep's tail.

    A run 100x more accurate measures the level's error to about 1 %, 10x to about 10 %.
    The next level, whatever it was, was at times no check at all, at others a needless
    price: a static law's draft runs at its standard's tolerances
    (sweeps.spec.accuracy.STATIC_RTOL_PER_BAND), so its estimate compared two identical
    runs and always said 0; an elasto-plastic sweep's reference is DP5 at rtol 1e-12, 10^4 x
    standard's, and its 12 re-runs took 4.5 % of Fig. 14's workers' time where rtol 1e-10
    took 2.1x less and changed the estimate by at most 1.2 % of itself (docs/ACCURACY.md
    5.5)."""
    s, integrator = plan.numerics.settings, plan.numerics.integrator
    level = FINER.get(plan.numerics.label)
    if level is not None:
        nxt = numerics(plan.spec, float(plan.params[P.SIGMA0]), level)
        if nxt.integrator != integrator or _tighter_10_to_100(integrator, s, nxt.settings):
            return replace(nxt, settings=replace(nxt.settings, device="cpu"))
    finer = replace(s, rtol=s.rtol / 100, atol=s.atol / 100, device="cpu",
                    steps_per_period=s.steps_per_period * 4, h=s.h / 4)
    return Numerics(integrator, finer, f"{plan.numerics.label}/100")


def _tighter_10_to_100(integrator: str, own, nxt) -> bool:
    """The next level's adaptive tolerances are 10x to 100x tighter than the level's (100x:
    the same run as tolerances / 100, under the next level's name): good enough to measure
    its error (to about 10 %) and cheaper than tolerances / 100. The stiff method's
    standard (rtol 1e-9) against its reference (1e-10): 12 stiff points took 6.1 s against
    13.3 s at rtol 1e-11, and the estimates agreed within 6 %."""
    from engine.integrators import METHODS

    if not METHODS[integrator].ADAPTIVE or not nxt.rtol > 0:
        return False
    ratio = own.rtol / nxt.rtol   # (1e-8 / 1e-10 is not 100 in binary)
    return 10 * (1 - 1e-9) <= ratio <= 100 * (1 + 1e-9)


def sample_index(shape: tuple[int, ...], coords: list[np.ndarray], seed: str,
                 size: int = SAMPLE_SIZE) -> np.ndarray:
    """Sorted flat indices (C order over ``shape``) of the stratified error sample."""
    n = int(np.prod(shape))
    if n <= size:
        return np.arange(n)
    picks: set[int] = set()
    # corners of the (W, omega) plane at the middle of the other axes
    mid = [s // 2 for s in shape]
    for i in (0, shape[0] - 1):
        for j in (0, shape[1] - 1):
            picks.add(int(np.ravel_multi_index((i, j, *mid[2:]), shape)))
    # the costliest point: largest omega * W (most dither periods at the largest amplitude)
    W, omega = coords[0], coords[1]
    cost = np.add.outer(np.abs(W) + 1e-12, 0 * omega) * np.abs(omega)[None, :]
    i, j = np.unravel_index(int(np.argmax(cost)), cost.shape)
    picks.add(int(np.ravel_multi_index((i, j, *mid[2:]), shape)))
    # a Latin hypercube over every axis for the rest
    rng = np.random.default_rng(int(seed[:12], 16) if seed else 0)
    k = max(size - len(picks), 1)
    cols = [np.floor((rng.permutation(k) + rng.random(k)) / k * s).astype(int) for s in shape]
    for row in zip(*cols):
        if len(picks) >= size:
            break
        picks.add(int(np.ravel_multi_index(row, shape)))
    return np.array(sorted(picks), dtype=np.int64)


def sample(plan: Plan) -> tuple[np.ndarray, np.ndarray]:
    """(flat indices, points ``(k, 4)``) of the error sample of ``plan``."""
    coords = [np.asarray(v) for v in plan.coords.values()]
    index = sample_index(tuple(len(v) for v in coords), coords, plan.sweep_id)
    if plan.refinement is not None:   # a refined sweep: the nearest first-level points,
        index = plan.refinement.on_first_lattice(index)   # computed before any other
    return index, plan.points_at(index)


def compare(plan: Plan, cube, index: np.ndarray, finer, label: str) -> dict:
    """The observed change between the cube's values and the finer re-run, per output,
    against the promise of the sweep's level; warnings where a change exceeds it."""
    level = plan.numerics.label if plan.numerics.label in FINER else "standard"
    level = "standard" if level == "explicit" else level
    status = cube["status"].values.reshape(-1)[index]
    ok = (status == S.OK) & (finer.status == S.OK)
    change, promised, warnings = {}, {}, []
    for name in plan.outputs:
        values = cube[name].values
        coarse = values.reshape((-1,) + values.shape[4:])[index][ok]
        fine = finer.outputs[name][ok]
        if coarse.size == 0:
            continue
        worst = output_change(name, coarse, fine, float(plan.params[P.LONG_STICK]))
        change[name], promised[name] = worst, promise(level, name, plan.spec.friction)
        if not worst <= promised[name]:
            warnings.append(_warning(name, worst, promised[name], plan.numerics.label, label))
    dropped = int((~ok).sum())
    if dropped:
        warnings.append(f"{dropped} of {ok.size} sample points failed at the finer level "
                        f"({label}): their error is unknown")
    return {"compared_with": label, "level": plan.numerics.label,
            "sample_points": int(ok.sum()), "sample_index": [int(i) for i in index],
            "change": change, "promise": promised, "warnings": warnings}


def output_change(name: str, coarse: np.ndarray, fine: np.ndarray, long_stick: float) -> float:
    """The largest change of output ``name`` between values at a level (``coarse``) and
    finer values of the same points, as promises are stated: absolute for fractions,
    else relative to ``max(|fine|, REL_FLOOR x max |fine|)`` (``max_stick``: also at least
    ``long_stick``); infinite where only one side is NaN."""
    diff = np.abs(coarse - fine)
    if name in FRACTION_OUTPUTS:
        err = diff
    else:
        floor = REL_FLOOR * float(np.nanmax(np.abs(fine))) if np.isfinite(fine).any() else 0
        if name == "max_stick":   # a run matters against the long-stick threshold
            floor = max(floor, long_stick)
        err = diff / np.maximum(np.maximum(np.abs(fine), floor), 1e-300)
    if np.isnan(coarse).any() != np.isnan(fine).any():
        return float("inf")
    return float(np.nanmax(err)) if np.isfinite(err).any() else float("inf")


def _warning(name: str, change: float, promised: float, level: str, finer: str) -> str:
    kind = "" if name in FRACTION_OUTPUTS else " (relative)"
    advice = ("submit at a finer accuracy (e.g. accuracy = \"reference\")"
              if level in ("draft", "standard", "explicit") else
              "this output is not converged even at the reference level; see docs/ACCURACY.md")
    return (f"{name}: changed by {change:.1e}{kind} at the finer level {finer}, more than "
            f"the {level} level promises ({promised:.0e}); {advice}")


def attach(cube, estimate: dict) -> None:
    """Record ``estimate`` (from :func:`compare`) in the cube's attributes."""
    cube.attrs["error_estimate"] = json.dumps(estimate)
    cube.attrs["accuracy_warnings"] = "; ".join(estimate["warnings"])
