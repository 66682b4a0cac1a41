"""Running a refined sweep (``refine = true``; sweeps.planning.refine): level after level
through the same blocks, journal, lease and dask dispatch as an exhaustive sweep.

A refined plan starts with no blocks. :func:`replay` rebuilds the refinement from what the
cube (rebuilt from the journal) already holds: level by level it asks for the next points,
cuts the new ones into blocks appended to ``plan.blocks`` in a fixed order (so a resumed run
numbers its blocks exactly as the killed one did and the journal's blocks match), and stops
at the first level with points still to compute. :func:`run` computes those and goes on.
When no level asks for more, every other point is inferred (:func:`infer`): it takes the
values of its source point, and the ``provenance`` flag says computed or inferred.
"""
from __future__ import annotations

import math
import time
from contextlib import nullcontext

import numpy as np

import store
from store.flags import COMPUTED, INFERRED
from engine import status as S

from ..workers.threads import ThreadClient
from .dispatch import run_blocks
from ..planning.blocks import balanced_blocks
from ..planning.plan import Plan
from ..planning.refine import CLASS_OUTPUT, MARGIN_OUTPUT, Refinement
from ..estimates.error_reruns import ESTIMATE_FILE, SampleRuns, estimate_into, needs_estimate

BLOCK_POINTS = {"simulate": 8, "averaged": 4096}   # points per block of a level (at most)


def replay(plan: Plan, cube) -> list[int]:
    """Rebuild ``plan.refinement`` and ``plan.blocks`` from ``cube``; the blocks still to
    compute at the first unfinished level ([] when the refinement is complete, and then
    the cube's inferred points are filled in)."""
    coarse = plan.spec.refine.coarse if not isinstance(plan.spec.refine, bool) else None
    plan.refinement = Refinement(plan.path, plan.shape, coarse)
    plan.blocks = []
    return _advance(plan, cube)


def _advance(plan: Plan, cube) -> list[int]:
    """Ask for levels until one has points not yet OK in ``cube``; their blocks."""
    ref, status = plan.refinement, cube["status"].values.ravel()
    values = cube[CLASS_OUTPUT[plan.path]].values
    name = MARGIN_OUTPUT.get(plan.path)
    margin = cube[name].values if name in cube else None
    while True:
        new = ref.next_points(values, margin)
        if new.size == 0:
            infer(plan, cube)
            return []
        start = len(plan.blocks)
        plan.blocks += _cut(plan, new)
        todo = [b for b in range(start, len(plan.blocks))
                if np.any(status[plan.blocks[b]] != S.OK)]
        if todo:
            return todo


def _cut(plan: Plan, index: np.ndarray) -> list[np.ndarray]:
    """A level's points in blocks of balanced estimated cost (sweeps.planning.plan), at least two
    (both workers busy)."""
    n_blocks = max(math.ceil(index.size / BLOCK_POINTS[plan.path]), min(index.size, 2))
    cost = plan.costs_at(index)
    return [index[b] for b in balanced_blocks(cost, n_blocks)]


def infer(plan: Plan, cube) -> None:
    """Fill every point not computed from its source (sweeps.planning.refine) and set provenance."""
    src = plan.refinement.sources()
    asked = plan.refinement.asked
    plan.sources = src
    for name in store.cube.output_names(cube):
        var = cube[name]
        flat = var.data.reshape((asked.size,) + var.shape[4:])
        flat[~asked] = flat[src[~asked]]
    status = cube["status"].data.reshape(-1)
    status[~asked] = status[src[~asked]]
    for name in ("cost_s", "steps", "evals"):
        cube[name].data.reshape(-1)[~asked] = 0
    cube[store.cube.PROVENANCE].data[...] = np.where(
        asked, COMPUTED, INFERRED).reshape(plan.shape)


def run(plan: Plan, todo: list[int], sink, compute, *, blocks, progress,
        warm_up: bool = True) -> None:
    """Compute ``todo`` (the first unfinished level's blocks), then every further level,
    each with ``blocks`` (sweeps.run.dispatch.run_blocks on the open cluster of ``compute``,
    or sweeps.run.local.run_blocks_local on threads), infer the rest, and (simulate)
    estimate the error on computed points: its finer re-runs run where a worker would idle
    at a level's tail (sweeps.run.dispatch ``filler``)."""
    simulate, on_cluster = plan.path == "simulate", blocks is run_blocks
    pool = compute.client if on_cluster else None   # (threads: the estimate's own, below)
    # the error sample's finer re-runs fill a cluster's workers idling at each level's tail
    # (on threads, each level's pool closes with it: they run after the last level; passed
    # there, a GPU sweep, or a CPU one small enough for threads, ended in a TypeError)
    early = SampleRuns(plan) if simulate and on_cluster and todo and not \
        (sink.sweep.root / ESTIMATE_FILE).exists() else None
    extra = {"filler": early} if early is not None else {}
    extra = extra if warm_up else {**extra, "warm_up": False}
    t, level = time.perf_counter(), 0
    while todo:
        blocks(plan, todo, sink, compute, progress=progress, **extra)
        extra = {**extra, "warm_up": False} if blocks is run_blocks else extra
        if sink.stopped is not None:
            if early is not None:
                early.cancel(pool)
            return
        todo, level = _advance(plan, sink.cube), level + 1
    sink.timings["compute_s"] = time.perf_counter() - t
    if simulate and needs_estimate(plan, sink.sweep, sink.cube):
        with ThreadClient(compute.threads, name="ditherlab-rerun") if pool is None else \
                nullcontext(pool) as reruns_on:
            estimate_into(plan, reruns_on, sink.cube, sink.sweep, sink.timings, started=early,
                          display=progress.display(plan))
    elif early is not None:
        early.cancel(pool)
