"""Adaptive refinement of a map's boundary (issue 11): compute a coarse lattice, then only the
cells whose corners disagree, level by level down to the spec's grid; infer the rest.

A map's information is on its class boundary (stick-slip zone: ``long_stick_fraction > 0``;
stability chart: ``stable``). On a 2-D plane of the cube (``PLANES``: (W, omega) for the
simulate path, (W, v_ref) for the averaged one; every other axis value is a separate plane)
the refinement

1. computes the lattice of stride ``s`` = the coarse stride (a power of two; the last index of
   each axis always belongs to the lattice, so edge cells may be narrower);
2. looks at each cell of the lattice (two consecutive lattice values per axis): a cell whose
   four corners carry the same class is *settled*; a cell whose corners disagree is split at
   stride ``s/2``, and the new lattice points inside it (edges included) are computed next;
3. repeats until the split cells are single grid steps.

On a zone map (the simulate path, where a point costs up to a second) a split cell's new
point on one of its edges whose two ends agree is not computed either: it takes the class
and values of the nearer end (ties: the lower), as a point of a settled cell does. Only the
points on edges the boundary crosses, and the cells' centres, are computed. On Fig. 14
(31x31, both lam) that computes 137 and 146 points instead of 205 and 221 (34 % less
compute) with every cell still equal to the full grid. A stability chart, whose points
cost microseconds, refines its cells whole (its labels must equal the full grid's).

Every point never computed lies in a settled cell or on an agreeing edge and is *inferred*:
its class is the corners' class and its values are those of the nearest corner (ties: the
lowest corner).
The decisions depend only on computed values, so a resumed run replays them exactly and
ends in the same cube (the journal holds every computed point). A feature smaller than the
coarse lattice that touches no corner can be missed: ``scripts/bench_maps.py`` measures the
share of cells that agree with the full grid.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..spec.grid import AXES
from ..spec.methods import CLASS_OUTPUT, PLANES  # noqa: F401  (CLASS_OUTPUT: re-exported)
from .lattice import lattice, split

# a continuous quantity whose sign is the class: a cell whose corners agree is still split
# when the quantity varies across it by more than its least distance from 0 (a sign change,
# e.g. a small unstable island, may hide inside)
MARGIN_OUTPUT = {"averaged": "max_real_eig"}
# lattice steps per map axis of the first level: a zone map's regions are large, while a
# stability chart has thin secondary bands (and its points cost microseconds)
FIRST_STEPS = {"simulate": 4, "averaged": 8}
# ... and small islands: its first stride is at most 16 grid steps. On Fig. 9 at 400x400
# (v_d = 0.1) stride 64 missed an SU island of about 10 x 16 cells (86 cells wrong);
# stride 16 finds it, computing 17.9 % of the points instead of 17.3 %
MAX_FIRST_STRIDE = {"simulate": None, "averaged": 16}
# paths whose split cells infer the new points on agreeing edges (module docstring)
EDGE_INFERENCE = {"simulate": True, "averaged": False}


def default_stride(n: int, target: int = 4) -> int:
    """The coarse stride for an axis of ``n`` points: the power of two that leaves about
    ``target`` lattice steps (1 for a short axis). Four steps for zone maps: the lattice only
    has to catch every region once, and finer first lattices cost more than they save (on a
    straight boundary over 61x61, strides 4 / 8 / 16 compute 16 / 13 / 12 % of the points).
    """
    if n <= target + 1:
        return 1
    return 2 ** math.ceil(math.log2((n - 1) / target))


def classify(path: str, values: np.ndarray) -> np.ndarray:
    """The class of each point from its class output (NaN stays NaN: not computed)."""
    out = np.where(values > 0, 1.0, 0.0) if path == "simulate" else np.round(values)
    return np.where(np.isnan(values), np.nan, out)


@dataclass
class Plane:
    """The refinement of one 2-D plane of ``shape`` (na, nb), driven level by level."""

    shape: tuple[int, int]
    stride: int
    cells: np.ndarray                     # open cells, (k, 4) rows a0, a1, b0, b1
    # settled cells, in the order they settled: (k, 5) rows a0, a1, b0, b1, class
    settled: list[np.ndarray] = field(default_factory=list)
    infer_edges: bool = False
    # a point inferred on an agreeing edge -> the computed point whose class and values it takes
    on_edges: dict[tuple[int, int], tuple[int, int]] = field(default_factory=dict)

    @classmethod
    def start(cls, shape: tuple[int, int], stride: int,
              infer_edges: bool = False) -> tuple[Plane, np.ndarray]:
        """The plane and its first (coarse) points as an ``(k, 2)`` index array."""
        ia, ib = (lattice(0, n - 1, stride) for n in shape)
        cells = np.array([(a0, a1, b0, b1) for a0, a1 in zip(ia, ia[1:])
                          for b0, b1 in zip(ib, ib[1:])], dtype=np.int64).reshape(-1, 4)
        plane = cls(shape, stride, cells, infer_edges=infer_edges)
        return plane, np.array([(a, b) for a in ia for b in ib], dtype=np.int64)

    def step(self, classes: np.ndarray, margin: np.ndarray | None = None) -> np.ndarray:
        """Given the classes of every point computed so far (``shape``, NaN elsewhere),
        and optionally their margin (``MARGIN_OUTPUT``), settle or split the open cells;
        the ``(k, 2)`` points to compute next (may repeat computed ones: the caller skips
        those). Empty when the plane is done."""
        half = max(self.stride // 2, 1)
        classes = classes.copy()
        for (a, b), (sa, sb) in self.on_edges.items():
            classes[a, b] = classes[sa, sb]
        settle = self._settling(classes, margin)
        done = self.cells[settle]
        self.settled.append(np.column_stack([done, classes[done[:, 0], done[:, 2]]]))
        # a disagreeing cell of neighbours is a resolved boundary; the others split
        cells = self.cells[~settle]
        cells = cells[(cells[:, 1] - cells[:, 0] > 1) | (cells[:, 3] - cells[:, 2] > 1)]
        if self.infer_edges:
            self.cells, points = self._split_inferring_edges(cells, half, classes)
        else:
            self.cells, points = split(cells, half)
        self.stride = half
        if not len(points):
            return np.empty((0, 2), dtype=np.int64)
        return np.unique(np.array(points, dtype=np.int64), axis=0)

    def _split_inferring_edges(self, cells: np.ndarray, half: int, classes: np.ndarray):
        """:func:`_split`, cell by cell, leaving out the new points on agreeing edges
        (recorded in ``on_edges``; the order matters: a point is recorded by the first
        cell that finds it on an agreeing edge)."""
        cls = classes.tolist()
        new_cells, points = [], []
        for a0, a1, b0, b1 in cells.tolist():
            ia, ib = lattice(a0, a1, half), lattice(b0, b1, half)
            new_cells += [(x0, x1, y0, y1) for x0, x1 in zip(ia, ia[1:])
                          for y0, y1 in zip(ib, ib[1:])]
            points += [(a, b) for a in ia for b in ib
                       if (a, b) not in self.on_edges
                       and not self._on_agreeing_edge(cls, a, b, (a0, a1, b0, b1))]
        return np.array(new_cells, dtype=np.int64).reshape(-1, 4), points

    def _settling(self, classes: np.ndarray, margin: np.ndarray | None) -> np.ndarray:
        """Which open cells settle: their four corners have one class (NaN, not computed,
        never agrees) and, with a margin, the margin at the corners is finite and varies
        across the cell by less than its least distance from 0 (else a sign change may
        hide inside). Decided for all cells at once: a 400x400 chart has 28 800 cells over
        its levels, and a loop over them cost 0.3 s of its 2 s."""
        corner = (self.cells[:, [0, 0, 1, 1]], self.cells[:, [2, 3, 2, 3]])
        c = classes[corner]
        settle = (c == c[:, :1]).all(axis=1)
        if margin is not None:
            m = margin[corner]
            with np.errstate(invalid="ignore"):
                sure = np.isfinite(m).all(axis=1) & \
                    ~(np.abs(m).min(axis=1) < m.max(axis=1) - m.min(axis=1))
            settle &= sure
        return settle

    def _on_agreeing_edge(self, classes, a, b, cell) -> bool:
        """True (and the point recorded in ``on_edges``) when ``(a, b)`` lies inside an
        edge of ``cell`` whose two ends have the same class."""
        a0, a1, b0, b1 = cell
        if (a in (a0, a1)) == (b in (b0, b1)):
            return False                       # a corner, or inside the cell
        ends = [(a, b0), (a, b1)] if a in (a0, a1) else [(a0, b), (a1, b)]
        if classes[ends[0][0]][ends[0][1]] != classes[ends[1][0]][ends[1][1]]:
            return False
        near = ends[0] if abs(a - ends[0][0]) + abs(b - ends[0][1]) <= \
            abs(a - ends[1][0]) + abs(b - ends[1][1]) else ends[1]
        self.on_edges[(a, b)] = self.on_edges.get(near, near)   # a computed point
        return True

    def sources(self, computed: np.ndarray) -> np.ndarray:
        """For every point of the plane, the flat plane index of the computed point whose
        values it takes: itself when computed, the nearest corner of its settled cell when
        inferred, -1 when in no settled cell (only possible before the plane is done)."""
        na, nb = self.shape
        src = np.where(computed.ravel(), np.arange(na * nb), -1).reshape(self.shape)
        for (a, b), (sa, sb) in self.on_edges.items():
            src[a, b] = sa * nb + sb
        settled = np.concatenate(self.settled) if self.settled else np.empty((0, 5))
        if not len(settled):
            return src
        # every (point, cell) pair of the settled cells, in the order they settled: a point
        # on the border of several takes the first one's nearest corner
        a0, a1, b0, b1 = settled[:, :4].astype(np.int64).T
        na, nbs = a1 - a0 + 1, b1 - b0 + 1
        cell = np.repeat(np.arange(a0.size), na * nbs)
        j = np.arange(cell.size) - np.repeat(np.cumsum(na * nbs) - na * nbs, na * nbs)
        a, b = a0[cell] + j // nbs[cell], b0[cell] + j % nbs[cell]
        ca = np.where(a - a0[cell] <= a1[cell] - a, a0[cell], a1[cell])
        cb = np.where(b - b0[cell] <= b1[cell] - b, b0[cell], b1[cell])
        flat, first = np.unique(a * nb + b, return_index=True)
        fill = src.ravel()[ca[first] * nb + cb[first]]   # corners: computed or on an edge
        out = src.ravel()
        empty = out[flat] < 0
        out[flat[empty]] = fill[empty]
        return out.reshape(self.shape)


class Refinement:
    """Every plane of a cube of ``shape`` refined together, level by level.

    Level ``k`` asks for the flat cube indices :meth:`next_points` returns (only points not
    asked for before, sorted: the caller cuts them into blocks in this order, so a replay
    gives the same blocks); :attr:`asked` marks every point asked for so far.
    """

    def __init__(self, path: str, shape: tuple[int, ...], coarse: int | None = None):
        self.path, self.shape = path, tuple(shape)
        self.axes = tuple(AXES.index(a) for a in PLANES[path])
        plane_shape = tuple(self.shape[i] for i in self.axes)
        stride = max(default_stride(n, FIRST_STEPS[path]) for n in plane_shape)
        self.stride = coarse or min(stride, MAX_FIRST_STRIDE[path] or stride)
        others = [range(n) if i not in self.axes else [0] for i, n in enumerate(self.shape)]
        self._origins = np.stack(np.meshgrid(*others, indexing="ij"), -1).reshape(-1, 4)
        self.planes: list[Plane] = []
        self.asked = np.zeros(int(np.prod(self.shape)), dtype=bool)
        self.level = -1

    def _flat(self, origin: np.ndarray, pts: np.ndarray) -> np.ndarray:
        multi = np.repeat(origin[None, :], len(pts), axis=0)
        multi[:, self.axes[0]], multi[:, self.axes[1]] = pts[:, 0], pts[:, 1]
        return np.ravel_multi_index(tuple(multi.T), self.shape)

    def _plane_values(self, values: np.ndarray, origin: np.ndarray) -> np.ndarray:
        index = [slice(None) if i in self.axes else int(o) for i, o in enumerate(origin)]
        return values.reshape(self.shape)[tuple(index)]

    def next_points(self, class_values: np.ndarray | None = None,
                    margin_values: np.ndarray | None = None) -> np.ndarray:
        """The flat indices to compute at the next level (empty: refinement done).

        ``class_values`` is the cube's class output (``CLASS_OUTPUT``) over ``shape`` with
        every point asked for so far computed; ignored at the first level."""
        self.level += 1
        batches = []
        if self.level == 0:
            for origin in self._origins:
                plane, pts = Plane.start(tuple(self.shape[i] for i in self.axes), self.stride,
                                         EDGE_INFERENCE[self.path])
                self.planes.append(plane)
                batches.append(self._flat(origin, pts))
        else:
            for plane, origin in zip(self.planes, self._origins):
                classes = classify(self.path, self._plane_values(class_values, origin))
                margin = None if margin_values is None else \
                    self._plane_values(margin_values, origin)
                pts = plane.step(classes, margin)
                if len(pts):
                    batches.append(self._flat(origin, pts))
        flat = np.unique(np.concatenate(batches)) if batches else np.empty(0, np.int64)
        flat = flat[~self.asked[flat]]
        self.asked[flat] = True
        return flat

    def on_first_lattice(self, flat: np.ndarray) -> np.ndarray:
        """The nearest first-level lattice point of each flat index (sorted, unique): points
        computed before any other level, known as soon as the refinement starts."""
        multi = np.array(np.unravel_index(np.asarray(flat), self.shape))
        for ax in self.axes:
            grid = np.array(lattice(0, self.shape[ax] - 1, self.stride))
            multi[ax] = grid[np.abs(multi[ax][:, None] - grid[None, :]).argmin(axis=1)]
        return np.unique(np.ravel_multi_index(tuple(multi), self.shape))

    def sources(self) -> np.ndarray:
        """For every flat index, the computed point whose values it holds (itself when
        computed); call when :meth:`next_points` has returned nothing."""
        src = np.arange(self.asked.size)
        for plane, origin in zip(self.planes, self._origins):
            computed = self._plane_values(self.asked, origin)
            local = plane.sources(computed).ravel()
            nb = plane.shape[1]
            pts = np.stack([local // nb, local % nb], axis=1)
            all_pts = np.stack(np.unravel_index(np.arange(local.size), plane.shape), axis=1)
            src[self._flat(origin, all_pts)] = self._flat(origin, pts)
        return src
