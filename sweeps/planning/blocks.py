"""How a sweep's points are cut into blocks (sweeps.planning.plan.make_plan, and a refined
sweep's levels: sweeps.run.refined)."""
from __future__ import annotations

import numpy as np

# The blocks a sweep's dispatch takes last are smaller (balanced_blocks): the work of its
# last TAIL_BLOCKS blocks in halves and quarters, so that 16-32 workers end together
TAIL_BLOCKS = 32


def interleaved_blocks(n_points: int, n_blocks: int) -> list[np.ndarray]:
    """Block b holds flat indices b, b + n_blocks, ...: cost that varies smoothly across
    the grid (e.g. with omega) is spread evenly over the blocks, so no core idles."""
    return [np.arange(b, n_points, n_blocks) for b in range(n_blocks)]


def balanced_blocks(cost: np.ndarray, n_blocks: int, size: int | None = None
                    ) -> list[np.ndarray]:
    """Points into ``n_blocks`` blocks of nearly equal total ``cost`` (largest first onto
    the emptiest block so far; with ``size``, the spec's ``block_size``, onto the emptiest
    of those with fewer than ``size`` points), each block's indices sorted; the costliest
    blocks come first, so the dispatch starts the long work early and the workers finish
    together. Without ``size`` and with TAIL_BLOCKS x 3 blocks or more, the work of the last
    TAIL_BLOCKS goes into blocks of half and a quarter of the size (:func:`block_shares`),
    which the dispatch takes last: a worker done before the others waits for the last block
    of all, and a small last block is a short wait. Fig. 14's measured point costs
    list-scheduled on 16 workers (scripts/schedule_projection.py): 0.953 of the ideal in 173
    equal blocks, 0.989 in 237 with this tail.
    (The greedy loop is Python's, but it keeps one block number per point in an int32
    array: at 10^6 points 4 MB, where lists of Python ints took 40 MB; 1.1 s, was 1.9.)"""
    import heapq

    share = (block_shares(n_blocks) if size is None else np.ones(n_blocks)).tolist()
    heap = [(0.0, b) for b in range(len(share))]
    totals, counts = [0.0] * len(share), [0] * len(share)
    room = cost.size if size is None else size
    order = np.argsort(-cost, kind="stable")
    owner = np.empty(cost.size, np.int32)
    for start in range(0, cost.size, 1 << 16):   # Python numbers for a slice at a time
        part = order[start:start + (1 << 16)]
        for i, c in zip(part.tolist(), cost[part].tolist()):
            _, b = heapq.heappop(heap)
            owner[i] = b
            totals[b] += c
            counts[b] += 1
            if counts[b] < room:   # (a full block takes no more)
                heapq.heappush(heap, (totals[b] / share[b], b))   # the emptiest for its share
    members = np.argsort(owner, kind="stable")     # block by block, indices ascending
    bounds = np.cumsum(np.bincount(owner, minlength=len(share)))
    blocks = np.split(members.astype(np.int64), bounds[:-1])
    return [blocks[b] for b in sorted(range(len(share)), key=lambda b: -totals[b])
            if blocks[b].size]


def block_shares(n_blocks: int) -> np.ndarray:
    """Each block's share of the work, in units of an even ``1 / n_blocks`` share: all 1,
    or with TAIL_BLOCKS x 3 blocks or more the last TAIL_BLOCKS units each cut in a half and two
    quarters (more blocks in all)."""
    if n_blocks < 3 * TAIL_BLOCKS:
        return np.ones(n_blocks)
    return np.concatenate([np.ones(n_blocks - TAIL_BLOCKS), np.full(TAIL_BLOCKS, 0.5),
                           np.full(2 * TAIL_BLOCKS, 0.25)])
