"""Points of a cube by flat index (C order over ``AXES``; store.cube): checking an
index, status counts, and :func:`fill`, which writes a
block's results (a :class:`store.record.BlockRecord`) into a cube in memory."""

from __future__ import annotations

import numpy as np

from .cube import AXES, output_names, shape_of
from .record import BlockRecord
from .flags import OK, STATUS_MEANINGS


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


def status_counts(ds) -> dict[str, int]:
    """Number of points per status meaning, e.g. ``{"ok": 90, "not_yet_computed": 10, ...}``."""
    counts = np.bincount(
        ds["status"].values.reshape(-1).astype(np.int64), minlength=len(STATUS_MEANINGS)
    )
    return {m: int(c) for m, c in zip(STATUS_MEANINGS, counts)}


def _columns(ds, record: BlockRecord) -> dict[str, np.ndarray]:
    outputs = output_names(ds)
    values = record.outputs
    missing, extra = sorted(set(outputs) - set(values)), sorted(set(values) - set(outputs))
    if missing or extra:
        raise ValueError(f"fill: the record must have exactly the cube's outputs {outputs}; "
                         f"missing {missing}, unknown {extra}")
    columns = {k: v for k, v in record.arrays().items() if k != "index"}
    for name, col in columns.items():
        expected = (len(record),) + tuple(ds[name].shape[len(AXES):])
        if col.shape != expected:
            raise ValueError(f"fill: {name} has shape {col.shape}, expected {expected} "
                             "like index")
    bad = ~np.isin(record.status, np.arange(len(STATUS_MEANINGS)))
    if bad.any():
        raise ValueError(f"fill: status codes must be in 0..{len(STATUS_MEANINGS) - 1}, got "
                         f"{np.unique(record.status[bad]).tolist()}")
    return columns


def fill(ds, record: BlockRecord) -> None:
    """Write a block's results into ``ds`` in place: ``ds`` a cube from ``empty_cube`` or
    ``rebuild`` (a ``store.cubedata.Cube``, in memory), ``record`` the results at its flat
    indices, with exactly the cube's outputs.

    Everything is checked before anything is written, so a refused call leaves ``ds``
    unchanged.
    """
    idx = check_index(ds, record.index)
    for name, col in _columns(ds, record).items():
        var = ds[name]
        flat = var.data.reshape((-1,) + var.shape[len(AXES):])   # a view: points first
        flat[idx] = col
