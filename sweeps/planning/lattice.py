"""Lattices of a refined map plane (sweeps.planning.refine): the points of an axis interval at a
step, and a level's split cells with their new points, vectorised over cells."""
from __future__ import annotations

import numpy as np


def lattice(lo: int, hi: int, stride: int) -> list[int]:
    """Indices lo, lo+stride, ... and hi itself."""
    out = list(range(lo, hi + 1, stride))
    return out if out[-1] == hi else out + [hi]


def split(cells: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray]:
    """Split ``cells`` ((k, 4) rows a0, a1, b0, b1) on the lattice of step ``half``
    (:func:`lattice` per axis): the new cells, in the order of their parents and then
    row-major, and every lattice point of the split cells ((m, 2), with repeats)."""
    (a, has_a), (b, has_b) = (lattices(cells[:, i], cells[:, i + 1], half) for i in (0, 2))
    sub = np.stack(np.broadcast_arrays(a[:, :-1, None], a[:, 1:, None],
                                       b[:, None, :-1], b[:, None, 1:]), axis=-1)
    keep = has_a[:, 1:, None] & has_b[:, None, 1:]
    points = np.stack(np.broadcast_arrays(a[:, :, None], b[:, None, :]), axis=-1)
    return sub[keep], points[has_a[:, :, None] & has_b[:, None, :]]


def lattices(lo: np.ndarray, hi: np.ndarray, step: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`lattice` of every ``(lo, hi)`` pair, as rows padded on the right: (the
    points, which of them exist)."""
    n = int(np.max((hi - lo + step - 1) // step, initial=0)) + 1
    pts = lo[:, None] + step * np.arange(n)[None, :]
    inside = pts < hi[:, None]
    ends = inside.sum(axis=1)                     # the first point at or beyond hi
    pts[np.arange(len(lo)), ends] = hi
    return pts, np.arange(n)[None, :] <= ends[:, None]
