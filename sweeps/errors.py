"""An error estimate for every simulated cube.

After a sweep, a small sample of its points (the grid's corners, centre and most
expensive point, as for calibration) is integrated again one accuracy level finer
(draft -> standard -> reference -> reference with tolerances / 100) and the observed
change per output is stored in the cube's ``error_estimate`` attribute:

    {"compared_with": "reference", "sample_points": 5,
     "max_abs_change": {"F_mean": 3e-6, ...}, "max_rel_change": {...}}

It is an *observed* change, not a bound: where the sweep's level is converged it is
close to the true error; where it is not, it says so.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from engine import status as S

from .accuracy import Numerics, numerics
from .calibrate import sample_points
from .plan import Plan

FINER = {"draft": "standard", "standard": "reference", "reference": None, "explicit": None}


def finer_numerics(plan: Plan) -> Numerics:
    """The next level up, or the same integrator at tolerances / 100 at the top."""
    from engine import params as P

    level = FINER.get(plan.numerics.label)
    if level is not None:
        return numerics(plan.spec, float(plan.params[P.SIGMA0]), level)
    s = plan.numerics.settings
    finer = replace(s, rtol=s.rtol / 100, atol=s.atol / 100,
                    steps_per_period=s.steps_per_period * 4, h=s.h / 4)
    return Numerics(plan.numerics.integrator, finer, f"{plan.numerics.label}/100")


def sample(plan: Plan) -> tuple[np.ndarray, np.ndarray]:
    """(flat indices, points) of the error sample."""
    pts = sample_points(plan.spec)
    from . import grid

    all_pts = grid.points(plan.spec)
    index = np.array([int(np.flatnonzero((all_pts == row).all(axis=1))[0]) for row in pts])
    return index, pts


def compare(plan: Plan, cube, index: np.ndarray, finer: dict, label: str) -> dict:
    """The observed change between the cube's values and the finer re-run."""
    status = cube["status"].values.ravel()[index]
    ok = (status == S.OK) & (np.asarray(finer["status"]) == S.OK)
    abs_change, rel_change = {}, {}
    for name in plan.outputs:
        coarse = cube[name].values.ravel()[index][ok]
        fine = np.asarray(finer[name])[ok]
        if coarse.size == 0:
            continue
        diff = np.abs(coarse - fine)
        abs_change[name] = float(diff.max())
        scale = np.maximum(np.abs(fine), 1e-12)
        rel_change[name] = float((diff / scale).max())
    return {"compared_with": label, "sample_points": int(ok.sum()),
            "max_abs_change": abs_change, "max_rel_change": rel_change}
