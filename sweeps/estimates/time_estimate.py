"""Wall-time estimates from a calibration measured on this machine.

For each accuracy level, a few sample points spread over the grid (its corners and
centre, so the most expensive omega is included) are integrated here over a short
window; the per-point cost is scaled by ``t_end / window`` and by the number of points,
and divided by the number of workers. Compilation is excluded (a warm-up call first).
The analysis paths are timed on a sample block directly.

On the GPU (spec ``device = "cuda"``) a block is one kernel launch, one thread a point, and a
launch lasts at least as long as its slowest thread: one GPU thread is ~40x slower than a
CPU core (Fig. 14's costliest point, W = 3 and omega = 1000, takes 1.2 s on a core and ~45 s
on an H200 thread; docs/GPU.md). So the GPU is calibrated by two launches over the same
short window: the sample points alone (the latency: their slowest thread) and the samples
repeated to a full block (the throughput at that fill); a block of ``m`` points is then
``max(latency, m / throughput)``, and blocks run one after another on the one GPU.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from engine import params as P

from ..errors import RefusedError
from ..planning.plan import Plan, make_plan
from ..spec.models import LEVELS, Spec
from ..workers.task import compute_block, warm_up

CAL_WINDOW = 5.0      # time units integrated per calibration point
MAX_SAMPLES = 5
TASK_OVERHEAD_S = 2e-3  # per dask task, measured ~1.6 ms here
GPU_SIM_POINTS = 8      # the throughput launch under numba's CUDA simulator (Python-slow)


@dataclass
class Estimate:
    level: str
    integrator: str
    per_point_s: float
    wall_s: float
    slowest_s: float = 0.0   # on the GPU: the latency a launch cannot beat (its slowest point)


def sample_points(plan: Plan) -> np.ndarray:
    """Up to MAX_SAMPLES grid points: the extreme corners and the centre of the grid."""
    pts = plan.points
    n = len(pts)
    picks = {0, n - 1, n // 2}
    # the point with the largest omega*W tends to cost most (most switches, largest |u|)
    picks.add(int(np.argmax(pts[:, 1] * (pts[:, 0] + 1e-12))))
    picks.add(int(np.argmax(pts[:, 1])))
    return pts[sorted(picks)[:MAX_SAMPLES]]


def _window(plan: Plan) -> tuple[np.ndarray, float]:
    """The plan's parameters over the calibration window, and the factor back to t_end."""
    p = plan.params.copy()
    if plan.path != "simulate":
        return p, 1.0
    window = min(p[P.T_END], CAL_WINDOW)
    scale = p[P.T_END] / window
    p[P.T_END], p[P.T_TRANSIENT] = window, 0.0
    return p, scale


def _time_block(plan: Plan, pts: np.ndarray) -> float:
    p, scale = _window(plan)
    t0 = time.perf_counter()
    compute_block(plan.scene, pts, p, plan.numerics.settings)
    return (time.perf_counter() - t0) / len(pts) * scale


def _gpu_estimate(plan: Plan, level: str) -> Estimate:
    """The GPU's calibration (module docstring): raises :class:`engine.gpu.NoGPU` without
    a GPU, and what a failed launch raises (never a made-up number)."""
    from engine import gpu
    from engine.blocks import run_block

    p, scale = _window(plan)
    settings, pts = plan.numerics.settings, sample_points(plan)

    def launch(points) -> float:
        t0 = time.perf_counter()
        run_block(plan.scene, points, p, settings)
        return (time.perf_counter() - t0) * scale

    try:
        launch(pts[:1])   # compiles the kernel (its time is not the sweep's)
    except ValueError as exc:   # engine.gpu.run: a kernel numba.cuda cannot compile (a
        if not str(exc).startswith("device cuda:"):   # brought law's np.exp): its one
            raise                                       # line, not an internal error
        raise RefusedError(str(exc)) from None
    latency = launch(pts)
    full = max(len(b) for b in plan.blocks)
    tiled = np.resize(pts, (min(full, GPU_SIM_POINTS if gpu.simulated() else full), 4))
    rate = len(tiled) / max(launch(tiled), 1e-9)
    wall = gpu_wall([len(b) for b in plan.blocks], latency, rate)
    return Estimate(level, plan.numerics.integrator, 1.0 / rate, wall, latency)


def gpu_wall(block_points: list[int], latency_s: float, points_per_s: float) -> float:
    """Blocks of ``block_points`` points launched one after another on one GPU: each lasts
    its slowest thread (``latency_s``) or its points at the GPU's throughput, whichever is
    longer (module docstring)."""
    return sum(max(latency_s, m / points_per_s) + TASK_OVERHEAD_S for m in block_points)


def estimate(spec: Spec, level: str, workers: int = 2) -> Estimate:
    """Estimated wall time of ``spec`` at accuracy ``level`` on ``workers`` cores."""
    plan = make_plan(spec, level)
    if plan.numerics.settings.device == "cuda":
        return _gpu_estimate(plan, level)
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
    """One estimate per accuracy level (the analysis paths have a single level). A spec
    that brings a model is calibrated in a child process: its code may crash the process
    that runs it (engine.user_code.isolated: one ModelError line)."""
    from engine import registry

    brought = [r for r in (spec.friction, spec.system) if registry.is_import_path(r)]
    if brought:
        from engine.user_code import isolated

        return isolated(f"{' and '.join(brought)} (the time estimate's sample points)",
                        _estimates, spec, workers)
    return _estimates(spec, workers)


def _estimates(spec: Spec, workers: int) -> list[Estimate]:
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

