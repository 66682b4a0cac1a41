"""One finished block's results on their way from the worker to the journal to the cube:
:class:`BlockRecord`, the flat cube indices of the block's points and one row per point of
every field and output. The worker fills it from the engine's results
(sweeps.workers.task), the journal writes and reads it (store.journal: one ``.npz`` array
per field and output, under these names), and :func:`store.points.fill` writes it into a
cube. Plain numpy: the store never knows how a number was computed.

=========  =======  ==========================================
field      dtype    meaning
=========  =======  ==========================================
index      int64    C-order flat indices of the points (store.cube)
status     int8     status codes 0..3
cost_s     float64  seconds per point
steps      int64    accepted steps per point
evals      int64    right-hand-side evaluations per point
outputs    float64  output name -> ``(n,)``, or ``(n, k)`` for a vector output such as
                    ``alpha_hist``
=========  =======  ==========================================

Two fields are not per point: ``error`` (why a whole block failed; logged, not journaled)
and ``fingerprint``, the results fingerprint of the process that computed the block
(sweeps.version): the submitter journals only blocks carrying its own (sweeps.run.sink),
and the journal keeps it in the block file (``_engine``).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

FIELDS = {
    "index": np.int64,
    "status": np.int8,
    "cost_s": np.float64,
    "steps": np.int64,
    "evals": np.int64,
}


@dataclass
class BlockRecord:
    """The results of one block of ``n`` points (module docstring). Arrays are converted
    to the field dtypes when made; ``error`` says why a whole block failed, ``fingerprint``
    which engine computed it (None: not recorded)."""

    index: np.ndarray
    status: np.ndarray
    cost_s: np.ndarray
    steps: np.ndarray
    evals: np.ndarray
    outputs: dict[str, np.ndarray] = field(default_factory=dict)
    error: str = ""
    fingerprint: str | None = None

    def __post_init__(self):
        index = np.asarray(self.index)
        if index.ndim != 1 or (index.size and not np.issubdtype(index.dtype, np.integer)):
            raise ValueError(f"flat_index must be a 1-D integer array, got dtype {index.dtype} "
                             f"shape {index.shape}")
        for name, dtype in FIELDS.items():
            setattr(self, name, np.asarray(getattr(self, name), dtype=dtype))
        self.outputs = {k: np.asarray(v, dtype=np.float64) for k, v in self.outputs.items()}
        clash = sorted(set(self.outputs) & set(FIELDS))
        if clash:
            raise ValueError(f"block record: output names {clash} clash with its fields "
                             f"{sorted(FIELDS)}")
        n = self.index.shape
        # one row per point; an output may carry one extra trailing axis (alpha_hist)
        bad = {k: v.shape for k, v in self.arrays().items()
               if v.shape[:1] != n or v.ndim > (1 if k in FIELDS else 2)}
        if bad:
            raise ValueError(f"block record arrays must have index's length {n[0]} first "
                             f"(1-D, or 2-D for a vector output); got {bad}")

    def __len__(self) -> int:
        return int(self.index.size)

    def arrays(self) -> dict[str, np.ndarray]:
        """Every field and output by name, as the journal stores them."""
        return {**{name: getattr(self, name) for name in FIELDS}, **self.outputs}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray], strict: bool = False) -> BlockRecord:
        """The record of :meth:`arrays`; ``strict``: every array must have its dtype already
        (a journal file), else they are converted."""
        missing = [k for k in FIELDS if k not in arrays]
        if missing:
            raise ValueError(f"block record lacks {missing}")
        if strict:
            wrong = {k: str(v.dtype) for k, v in arrays.items()
                     if v.dtype != FIELDS.get(k, np.float64)}
            if wrong:
                raise ValueError(f"block record has wrong dtypes {wrong}")
        return cls(**{k: arrays[k] for k in FIELDS},
                   outputs={k: v for k, v in arrays.items() if k not in FIELDS})

    @classmethod
    def failed(cls, index, outputs: Sequence[str] | Mapping[str, tuple], error: str,
               status: int, fingerprint: str | None = None) -> BlockRecord:
        """A block whose computation raised: every point ``status``, outputs NaN.
        ``outputs``: the names, or name -> per-point shape (``(10,)`` for alpha_hist: a
        vector output's NaN rows must have the cube's shape, or the block cannot be
        filled in and the run stops)."""
        n = len(index)
        shapes = outputs if isinstance(outputs, Mapping) else dict.fromkeys(outputs, ())
        return cls(index, np.full(n, status), np.zeros(n), np.zeros(n), np.zeros(n),
                   {name: np.full((n, *shape), np.nan) for name, shape in shapes.items()},
                   error=error, fingerprint=fingerprint)

    @classmethod
    def concatenate(cls, records: Sequence[BlockRecord]) -> BlockRecord:
        """One record of several blocks' points, in order (their fingerprint if they all
        carry the same one, else None)."""
        first = records[0]
        prints = {r.fingerprint for r in records}
        return cls(*(np.concatenate([getattr(r, k) for r in records]) for k in FIELDS),
                   outputs={k: np.concatenate([r.outputs[k] for r in records])
                            for k in first.outputs},
                   fingerprint=prints.pop() if len(prints) == 1 else None)

    def split(self, sizes: Sequence[int]) -> list[BlockRecord]:
        """The records of consecutive blocks of ``sizes`` points that make this one (the
        inverse of :meth:`concatenate`; ``error`` and ``fingerprint`` go to each)."""
        if sum(sizes) != len(self):
            raise ValueError(f"block record of {len(self)} points split into {list(sizes)}")
        cuts = np.cumsum(sizes)[:-1]
        parts = {k: np.split(v, cuts) for k, v in self.arrays().items()}
        return [BlockRecord(*(parts[k][i] for k in FIELDS),
                            outputs={k: p[i] for k, p in parts.items() if k not in FIELDS},
                            error=self.error, fingerprint=self.fingerprint)
                for i in range(len(sizes))]
