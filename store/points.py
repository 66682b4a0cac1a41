"""Points of a cube by flat index (C order over ``AXES``; store.cube): checking an
index, the parameter rows of points, status counts, and :func:`fill`, which writes the
results of some points into a cube in memory."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .cube import AXES, output_names, shape_of
from .status import OK, STATUS_MEANINGS


def check_index(ds, flat_index) -> np.ndarray:
    """``flat_index`` as a 1-D int64 array, after checking it addresses points of ``ds``."""
    idx = np.asarray(flat_index)
    size = int(np.prod(shape_of(ds)))
    if idx.ndim != 1 or (idx.size and not np.issubdtype(idx.dtype, np.integer)):
        raise ValueError(
            f"flat_index must be a 1-D integer array, got dtype {idx.dtype} shape {idx.shape}"
        )
    if idx.size and (idx.min() < 0 or idx.max() >= size):
        raise ValueError(
            f"flat_index must lie in [0, {size}) for a cube of shape {shape_of(ds)}, "
            f"got range [{idx.min()}, {idx.max()}]"
        )
    return idx.astype(np.int64)


def grid_points(ds, flat_index=None) -> np.ndarray:
    """Parameter rows ``(n, 4)`` float64 of the points ``flat_index`` (all by default).

    Columns follow ``AXES`` (the engine's ``POINT_AXES`` order: W, omega, v_ref, vd).
    """
    size = int(np.prod(shape_of(ds)))
    idx = np.arange(size) if flat_index is None else check_index(ds, flat_index)
    multi = np.unravel_index(idx, shape_of(ds))
    return np.column_stack([ds[a].values[m] for a, m in zip(AXES, multi)]).astype(np.float64)


def pending_index(ds) -> np.ndarray:
    """Flat indices of the points whose status is not ok (to resume a sweep)."""
    return np.flatnonzero(ds["status"].values.reshape(-1) != OK)


def status_counts(ds) -> dict[str, int]:
    """Number of points per status meaning, e.g. ``{"ok": 90, "not_yet_computed": 10, ...}``."""
    counts = np.bincount(
        ds["status"].values.reshape(-1).astype(np.int64), minlength=len(STATUS_MEANINGS)
    )
    return {m: int(c) for m, c in zip(STATUS_MEANINGS, counts)}


def _columns(ds, n, values, status, cost_s, steps, evals) -> dict[str, np.ndarray]:
    outputs = output_names(ds)
    missing, extra = sorted(set(outputs) - set(values)), sorted(set(values) - set(outputs))
    if missing or extra:
        raise ValueError(
            f"fill: values must have exactly the cube's outputs {outputs}; missing {missing}, unknown {extra}"
        )
    columns = {**values, "status": status, "cost_s": cost_s, "steps": steps, "evals": evals}
    columns = {k: np.asarray(v) for k, v in columns.items()}
    for name, col in columns.items():
        expected = (n,) + tuple(ds[name].shape[len(AXES):])
        if col.shape != expected:
            raise ValueError(f"fill: {name} has shape {col.shape}, expected {expected} "
                             "like flat_index")
    bad = ~np.isin(columns["status"], np.arange(len(STATUS_MEANINGS)))
    if bad.any():
        raise ValueError(
            f"fill: status codes must be in 0..{len(STATUS_MEANINGS) - 1}, got {np.unique(columns['status'][bad]).tolist()}"
        )
    return columns


def fill(
    ds, flat_index, values: Mapping[str, np.ndarray], status, cost_s, steps, evals
) -> None:
    """Write the results of some points into ``ds`` in place.

    Parameters
    ----------
    ds
        A cube from ``empty_cube`` or ``rebuild`` (a ``store.cubedata.Cube``, in memory).
    flat_index
        ``(n,)`` int, C-order flat indices over ``AXES``.
    values
        Output name -> ``(n,)`` float; exactly the cube's outputs.
    status
        ``(n,)`` int codes 0..3; ``cost_s`` ``(n,)`` seconds; ``steps``, ``evals`` ``(n,)`` int.

    Everything is checked before anything is written, so a refused call leaves ``ds``
    unchanged.
    """
    idx = check_index(ds, flat_index)
    columns = _columns(ds, idx.size, values, status, cost_s, steps, evals)
    for name, col in columns.items():
        var = ds[name]
        flat = var.data.reshape((-1,) + var.shape[len(AXES):])   # a view: points first
        flat[idx] = col
