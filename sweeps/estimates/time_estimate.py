"""Wall-time estimates from a calibration measured on this machine.

For each accuracy level, a few sample points spread over the grid (its corners and
centre, so the most expensive omega is included) are integrated here over a short
window; the per-point cost is scaled by ``t_end / window`` and by the number of points,
and divided by the number of workers. Compilation is excluded (a warm-up call first).
The analysis paths are timed on a sample block directly.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from engine import params as P

from ..planning.plan import Plan, make_plan
from ..spec.models import LEVELS, Spec
from ..workers.task import compute_block, warm_up

CAL_WINDOW = 5.0      # time units integrated per calibration point
MAX_SAMPLES = 5
TASK_OVERHEAD_S = 2e-3  # per dask task, measured ~1.6 ms here


@dataclass
class Estimate:
    level: str
    integrator: str
    per_point_s: float
    wall_s: float


def sample_points(plan: Plan) -> np.ndarray:
    """Up to MAX_SAMPLES grid points: the extreme corners and the centre of the grid."""
    pts = plan.points
    n = len(pts)
    picks = {0, n - 1, n // 2}
    # the point with the largest omega*W tends to cost most (most switches, largest |u|)
    picks.add(int(np.argmax(pts[:, 1] * (pts[:, 0] + 1e-12))))
    picks.add(int(np.argmax(pts[:, 1])))
    return pts[sorted(picks)[:MAX_SAMPLES]]


def _time_block(plan: Plan, pts: np.ndarray) -> float:
    p = plan.params.copy()
    scale = 1.0
    if plan.path == "simulate":
        window = min(p[P.T_END], CAL_WINDOW)
        scale = p[P.T_END] / window
        p[P.T_END], p[P.T_TRANSIENT] = window, 0.0
    t0 = time.perf_counter()
    compute_block(plan.scene, pts, p, plan.numerics.settings)
    return (time.perf_counter() - t0) / len(pts) * scale


def estimate(spec: Spec, level: str, workers: int = 2) -> Estimate:
    """Estimated wall time of ``spec`` at accuracy ``level`` on ``workers`` cores."""
    plan = make_plan(spec, level)
    warm_up(plan.scene, plan.params, plan.numerics.settings)
    pts = sample_points(plan)
    if plan.path != "simulate":
        pts = plan.points[: min(plan.n_points, 4096)]
        workers = 1  # the analysis paths run in the submitting process
    per_point = _time_block(plan, pts)
    n_tasks = len(plan.blocks)
    # a block is one worker's: ceil(blocks / workers) rounds of one block each (3 blocks on
    # 2 workers take 2 rounds, 1 block on 2 workers takes 1)
    rounds = -(-n_tasks // max(1, workers))
    wall = rounds * (plan.n_points / max(n_tasks, 1) * per_point + TASK_OVERHEAD_S)
    return Estimate(level, plan.numerics.integrator, per_point, wall)


def estimates(spec: Spec, workers: int = 2) -> list[Estimate]:
    """One estimate per accuracy level (the analysis paths have a single level)."""
    if spec.method != "simulate":
        return [estimate(spec, "standard", workers)]
    return [estimate(spec, level, workers) for level in LEVELS]


def format_seconds(s: float) -> str:
    if s < 1:
        return f"{s * 1e3:.0f} ms"
    if s < 120:
        return f"{s:.1f} s"
    if s < 7200:
        return f"{s / 60:.1f} min"
    return f"{s / 3600:.1f} h"

