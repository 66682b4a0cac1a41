"""Planning: which path answers a spec, which effects the kernel needs, the step policy,
and how the grid is cut into blocks.

"Simulate only the effects a scene calls for": the averaged and harmonic-balance
paths integrate nothing; a simulated scene is compiled without every effect whose
parameters make it vanish over the whole grid (Stribeck when fs == fc, bristle damping
when sigma1 == 0, the viscous term when sigma2 == 0, the slow force when its amplitude
is 0, the dither when W == 0 everywhere) and without every observable not requested.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace

import numpy as np

from engine import params as P
from engine import registry
from engine.scene import Scene
from engine.user_code import hook

from ..spec.accuracy import Numerics, numerics
from ..spec.grid import GridFacts, base_params
from ..spec.methods import resolve_outputs
from ..spec.models import Spec
from .blocks import balanced_blocks, interleaved_blocks

# Points per block when the spec does not say: about MIN_BLOCKS blocks, clamped to
# [lo, hi] points. Each block costs ~7 ms of scheduling and journaling beside its compute
# (scripts/bench_sweep.py: 1000 points at 6 ms in 125 blocks lose 29 % to it, in 8 blocks
# 4 %), so blocks are made as large as load balance and resume granularity allow; the
# interleaved layout gives the blocks equal cost, so 4 per worker keep both cores busy.
BLOCK_POINTS = {"simulate": (4, 256), "averaged": (4096, 65536), "hbm": (8, 64)}
# A simulated point costs ~ its number of dither periods, omega * t_end, on top of the slow
# dynamics (about OMEGA_FLOOR rad per unit tau of steps): blocks are balanced by that, and
# sized to take about BLOCK_SECONDS each (SECONDS_PER_RADIAN: a rough price of one radian
# of dither at standard accuracy, fitted to Fig. 14's 3.2 min on 2 cores), so progress
# moves every second or two whatever the grid, and cheap sweeps keep few blocks (each
# block costs ~7 ms of bookkeeping).
OMEGA_FLOOR = 50.0
SECONDS_PER_RADIAN = 1e-5
STANDARD_RTOL = 1e-8       # the standard level's DP5 tolerance, SECONDS_PER_RADIAN's level
ANALYSIS_POINT_S = 2e-6    # an averaged or harmonic-balance point (bench_analysis: 1-5 us)
# A dithered point's price grows with the dither's amplitude and saturates: (W + a) / (W + b).
# Fig. 14's elasto-plastic slider at draft, omega = 1000: W = 0, 0.5, 1.5, 3 cost 0.03, 0.6,
# 0.82, 1 of the W = 3 point (0.14, 0.71, 0.92, 1 here); at omega = 100 0.01, 0.36, 0.7, 1
W_SHARE = (0.02, 0.3)
BLOCK_SECONDS = 1.0
MIN_BLOCKS = 8
# Tasks per second one submitting process hands out and takes back: dask's scheduler and
# client, the journal and the cube cost it 4.9 ms of CPU a task with 65 in flight, 9.3 ms
# with 1000 workers in every task's restriction (scripts/bench_scale.py, docs/BATCH.md),
# so 100 tasks/s keep about one core busy. Workers that would ask for more (threads /
# block seconds) get several blocks a task instead (blocks_per_task); the journal keeps
# blocks, so a resume with any number of workers finds them.
SUBMITTER_TASKS_PER_S = 100.0
# A task's shortest worthwhile length: each costs the submitter 10-25 ms of CPU (its dask
# scheduler, client and nannies, the journal), taken from the workers when they share its
# cores (a local cluster). scripts/bench_sweep.py (1,000 draft LuGre points, 2 workers,
# here): tasks of one 0.09 s block lost 39-57 % against half the serial time, of 0.3 s
# 17-23 %, of 0.6 s 12-20 % (1.0 s no better), the rest dask's per-task work.
MIN_TASK_S = 0.6
MIN_TASK_ENV = "DITHERLAB_MIN_TASK_S"   # another MIN_TASK_S (min_task_s)
# Points per block on a GPU (spec device = "cuda"): one thread a point, and a GPU fills with
# ~10^5 threads (../shared/recipes/gpu.md: 16,384 points ran at 40 % of an H200's rate)
GPU_BLOCK_POINTS = 131072


@dataclass
class Plan:
    spec: Spec
    sweep_id: str
    path: str
    scene: Scene
    params: np.ndarray
    numerics: Numerics
    outputs: tuple[str, ...]
    grid: GridFacts = field(repr=False)      # the spec's grid, resolved once
    blocks: list[np.ndarray] = field(repr=False)
    refinement: object = field(default=None, repr=False)   # sweeps.planning.refine (refined sweeps)
    sources: np.ndarray | None = field(default=None, repr=False)   # inferred -> computed
    device_note: str = ""   # why a spec's device = "cuda" runs on the CPU (else empty)

    @property
    def coords(self) -> dict[str, np.ndarray]:
        """The values of each axis, in the cube's axis order."""
        return self.grid.coords

    @property
    def shape(self) -> tuple[int, ...]:
        return self.grid.shape

    @property
    def n_points(self) -> int:
        return math.prod(self.shape)

    def effects(self) -> dict[str, bool]:
        """Effects compiled into the kernel (True) or left out (False). A brought law's
        Stribeck curve and bristle damping are its own to name (its ``effects()``): the
        plan listed the scene's flags, which such a law need not read, as compiled in."""
        s = self.scene
        eff = {} if registry.is_import_path(s.friction) else {
            "stribeck": s.stribeck, "bristle damping": s.bristle_damping}
        eff.update({"viscous term": s.viscous, "slow force": s.slow_force,
                    "dither": s.dither != "none"})
        eff.update(hook(s.friction, "effects", registry.law(s.friction).effects, s))
        return eff

    @property
    def points(self) -> np.ndarray:
        """Every grid point, ``(n, 4)`` (columns W, omega, v_ref, vd), built once and kept
        with the spec (the run itself uses :meth:`points_at`)."""
        return self.grid.points

    def points_at(self, index: np.ndarray) -> np.ndarray:
        """The ``(k, 4)`` grid points at flat indices ``index``, from the axes (the whole
        grid is never built: at 10^6 points it would be 32 MB held by the submitter)."""
        at = np.unravel_index(np.asarray(index, dtype=np.int64), self.shape)
        return np.stack([axis[i] for axis, i in zip(self.coords.values(), at)], axis=1)

    def costs_at(self, index: np.ndarray) -> np.ndarray:
        """The relative costs (point_costs) of the points at flat indices ``index``, from
        the axes (not kept per point: 8 MB at 10^6 points)."""
        return point_costs(self.spec, self.coords, index)

    def block_points(self, b: int) -> np.ndarray:
        """The ``(k, 4)`` grid points of block ``b`` (columns W, omega, v_ref, vd)."""
        return self.points_at(self.blocks[b])


def _scene(spec: Spec, p: np.ndarray, integrator: str, outputs) -> Scene:
    # the simulate path compiles the dither in effect (none when W = 0 everywhere)
    dither = spec.grid_facts.dither if spec.method == "simulate" else spec.dither
    return Scene.from_params(p, system=spec.system, friction=spec.friction, dither=dither,
                             path=spec.method, integrator=integrator, outputs=outputs,
                             sizes=spec.model_sizes)


def point_costs(spec: Spec, coords: dict[str, np.ndarray],
                index: np.ndarray | None = None) -> np.ndarray:
    """Relative cost per grid point (C order; at the flat indices ``index`` only, if
    given): for a dithered simulation ``max(omega, OMEGA_FLOOR)`` (the time span is the
    same for every point), and where the grid's dither is in effect (some W != 0) times
    its amplitude's share ``(|W| + a) / (|W| + b)`` (W_SHARE: W = 0 is hardly dithered);
    1 elsewhere. The blocks are balanced by it and :func:`work_s` prices by it."""
    shape = tuple(len(v) for v in coords.values())
    index = np.arange(math.prod(shape)) if index is None else np.asarray(index, np.int64)
    if spec.method != "simulate" or spec.dither == "none":
        return np.ones(index.size)
    at = np.unravel_index(index, shape)
    cost = np.maximum(np.abs(coords["omega"]), OMEGA_FLOOR)[at[1]]
    if spec.grid_facts.dither != "none":   # (the scene's dither: engine.scene)
        w = np.abs(coords["W"])[at[0]]
        cost = cost * (w + W_SHARE[0]) / (w + W_SHARE[1])
    return cost


def level_price(num: Numerics) -> float:
    """A level's price relative to ``standard`` (SECONDS_PER_RADIAN): an adaptive method's
    steps grow about as rtol^(-1/10) here (measured on this machine's 2-core AMD EPYC: a
    draft point cost 0.45-0.55x a standard one, LuGre with and without dither); a
    fixed step is priced as standard."""
    rtol = getattr(num.settings, "rtol", 0.0)
    if num.integrator == "rk4" or not rtol > 0:
        return 1.0
    return (rtol / STANDARD_RTOL) ** -0.1


def work_s(plan: Plan, index: np.ndarray, num: Numerics | None = None) -> float:
    """Rough serial seconds of the points at flat indices ``index`` at ``num`` (the plan's
    own numerics by default): their relative costs x t_end x SECONDS_PER_RADIAN x the
    level's price (the dither's amplitude included: :func:`point_costs`). Fitted to Fig. 14
    (standard); it over-prices dithered LuGre points by 20-45x and prices undithered ones
    about right (1 ms a draft point of 100 tau), so it errs towards a cluster. The
    analysis paths are priced at ANALYSIS_POINT_S a point."""
    index = np.asarray(index, np.int64)
    if plan.path != "simulate":
        return ANALYSIS_POINT_S * index.size
    num = num or plan.numerics
    cost = plan.costs_at(index)
    t_end = float(plan.params[P.T_END])
    return float(cost.sum()) * t_end * SECONDS_PER_RADIAN * level_price(num)


def make_plan(spec: Spec, level: str | None = None) -> Plan:
    """Plan ``spec`` (at its own accuracy, or at ``level`` for estimates)."""
    p = base_params(spec)
    num = numerics(spec, float(p[P.SIGMA0]), level)
    outputs = resolve_outputs(spec.method, spec.outputs, spec.system)
    scene = _scene(spec, p, num.integrator, outputs)
    device_note = gpu_refusal(spec, scene)
    if device_note:   # the CPU's sweep (its id, its cube's spec): not a GPU result
        spec = spec.model_copy(update={"device": "cpu"})
    elif spec.device == "cuda":
        num = replace(num, settings=replace(num.settings, device="cuda"))
    g = spec.grid_facts
    costs = point_costs(spec, g.coords)
    n = math.prod(g.shape)
    lo, hi = BLOCK_POINTS[spec.method]
    per_block = spec.block_size or min(hi, max(lo, math.ceil(n / MIN_BLOCKS)))
    n_blocks = min(n, max(math.ceil(n / per_block), MIN_BLOCKS))
    if num.settings.device == "cuda" and not spec.block_size:
        n_blocks = math.ceil(n / GPU_BLOCK_POINTS)   # one launch fills the GPU
    elif spec.method == "simulate" and not spec.block_size:
        # about BLOCK_SECONDS a block, but never fewer than lo points: the price per radian
        # is Fig. 14's at standard, ~70x a draft LuGre point's. A dask task costs 10-25 ms
        # here, but cheap blocks go several to a task (blocks_per_task): 1,000 draft LuGre
        # points lost 5.3-6.1 % to dask in 195 blocks, 5.0-6.5 % in 63 (scripts/
        # bench_sweep.py, 2026-11-30), where one block a task had lost 150 % in 409 blocks.
        # At least 16 points made Fig. 14 61 blocks: too few for 16 workers (blocks.py)
        seconds = costs.sum() * spec.time.t_end * SECONDS_PER_RADIAN
        n_blocks = min(n, max(n_blocks, min(math.ceil(seconds / BLOCK_SECONDS),
                                            math.ceil(n / lo))))
    if spec.refine:
        blocks = []   # known level by level (sweeps.run.refined)
    elif spec.method == "simulate":
        blocks = balanced_blocks(costs, n_blocks, spec.block_size)
    else:
        blocks = interleaved_blocks(n, n_blocks)
    return Plan(spec=spec, sweep_id=spec.sweep_id, path=spec.method, scene=scene, params=p,
                numerics=num, outputs=outputs, grid=g, blocks=blocks, device_note=device_note)


def gpu_refusal(spec: Spec, scene: Scene) -> str:
    """Why a spec asking for ``device = "cuda"`` runs on the CPU all the same (the
    Rosenbrock solver, the analysis paths: engine.gpu.unsupported), else ``""``."""
    if spec.device != "cuda":
        return ""
    from engine import gpu   # compiles nothing: reads the scene's method

    why = gpu.unsupported(scene)
    return f"device cuda: {why}: this sweep runs on the CPU" if why else ""


def min_task_s() -> float:
    """MIN_TASK_S, or ``$DITHERLAB_MIN_TASK_S`` seconds: 0 gives one block a task (the
    finest progress and resume, for a scheduler and workers that do not share the
    submitter's cores; the tests' block gates, which let blocks through one by one). A
    bad value is refused (exit 2) when a :class:`sweeps.workers.compute.Compute` is made,
    before anything runs."""
    text = os.environ.get(MIN_TASK_ENV, "").strip()
    if not text:
        return MIN_TASK_S
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value >= 0 or math.isinf(value):
        from ..errors import RefusedError

        raise RefusedError(f"${MIN_TASK_ENV} = {text!r}: give a number of seconds >= 0 "
                           f"(default {MIN_TASK_S})")
    return value


def blocks_per_task(threads: int, block_s: float, blocks_left: int,
                    ceiling: float | None = None) -> int:
    """Blocks one dask task computes so that ``threads`` workers busy with blocks of
    ``block_s`` seconds ask the submitter for at most ``ceiling`` (SUBMITTER_TASKS_PER_S)
    tasks a second, and no task is shorter than :func:`min_task_s`: 1 for blocks of that
    up to ``ceiling x block_s`` threads, more beyond, but never so many that a thread
    would be left without a task among the ``blocks_left``."""
    ceiling = SUBMITTER_TASKS_PER_S if ceiling is None else ceiling
    if threads < 1 or not block_s > 0:
        return 1
    k = max(math.ceil(threads / (ceiling * block_s)), math.ceil(min_task_s() / block_s))
    return max(1, min(k, blocks_left // threads))
