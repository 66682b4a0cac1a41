"""Crash-safe journal of finished blocks (DESIGN.md §4).

The submitting process is the only writer. Each finished block of points goes to
its own small ``.npz`` file ``<sweep>/journal/block-000042.npz``, written under a
temporary name, fsynced and renamed, so a file with a final name is always
complete. The cube is rebuilt from the journal (``rebuild``) and published every
few blocks and at the end; a resumed sweep submits only the blocks missing from
``Journal.done()``.

A block's payload is a flat dict of 1-D arrays of one length ``n``:

=========  =======  ==========================================
key        dtype    meaning
=========  =======  ==========================================
index      int64    C-order flat indices of the points (store.cube)
status     int8     status codes 0..3
cost_s     float64  seconds per point
steps      int64    accepted steps per point
evals      int64    right-hand-side evaluations per point
<output>   float64  one array per cube output, e.g. ``F_mean``
=========  =======  ==========================================

``block_payload`` builds it from the same arguments as ``store.cube.fill``.
"""

from __future__ import annotations

import re
import warnings
import zipfile
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np
import xarray as xr

from .cube import fill
from .layout import atomic_write, remove_stale_temps

FIELDS = {
    "index": np.int64,
    "status": np.int8,
    "cost_s": np.float64,
    "steps": np.int64,
    "evals": np.int64,
}
_NAME = re.compile(r"^block-(\d+)\.npz$")


def block_payload(
    flat_index, values: Mapping[str, np.ndarray], status, cost_s, steps, evals
) -> dict[str, np.ndarray]:
    """A journal payload from the arguments of ``store.cube.fill`` (see module doc)."""
    payload = {
        "index": flat_index,
        "status": status,
        "cost_s": cost_s,
        "steps": steps,
        "evals": evals,
    }
    clash = sorted(set(values) & set(payload))
    if clash:
        raise ValueError(
            f"block_payload: output names {clash} clash with the journal's own fields {sorted(FIELDS)}"
        )
    payload.update(values)
    return _checked(payload)


def _checked(payload: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    missing = [k for k in FIELDS if k not in payload]
    if missing:
        raise ValueError(
            f"journal payload lacks {missing}; build it with store.journal.block_payload"
        )
    out = {k: np.asarray(v, dtype=FIELDS.get(k, np.float64)) for k, v in payload.items()}
    n = out["index"].shape
    # one row per point; an output may carry one extra trailing axis (alpha_hist)
    bad = {k: v.shape for k, v in out.items()
           if v.shape[:1] != n or v.ndim > (1 if k in FIELDS else 2)}
    if bad:
        raise ValueError(f"journal payload arrays must have index's length {n[0]} first "
                         f"(1-D, or 2-D for a vector output); got {bad}")
    return out


class Journal:
    """The journal folder of one sweep: ``Journal(SweepDir(store_root, id).journal)``.

    Parameters
    ----------
    folder
        The journal folder; created on the first ``write``.
    """

    def __init__(self, folder):
        self.folder = Path(folder)

    def __repr__(self) -> str:
        return f"Journal({str(self.folder)!r})"

    def path(self, block_id: int) -> Path:
        """The final file name of block ``block_id``."""
        if int(block_id) != block_id or block_id < 0:
            raise ValueError(f"block_id must be a non-negative integer, got {block_id!r}")
        return self.folder / f"block-{int(block_id):06d}.npz"

    def write(self, block_id: int, payload: Mapping[str, np.ndarray]) -> Path:
        """Record a finished block atomically (temporary name, fsync, rename).

        Writing a block again replaces it. Returns the file's path.
        """
        arrays = _checked(payload)

        def save(tmp: Path) -> None:
            with open(tmp, "wb") as f:  # a file object: np.savez must not append ".npz"
                np.savez(f, **arrays)

        return atomic_write(self.path(block_id), save)

    def _complete(self) -> dict[int, Path]:
        blocks = {}
        if not self.folder.is_dir():
            return blocks
        for path in sorted(self.folder.iterdir()):
            match = _NAME.match(path.name)
            if match and _readable(path):
                blocks[int(match.group(1))] = path
        return blocks

    def done(self) -> set[int]:
        """Ids of the blocks with a complete file; temporary leftovers are ignored
        (and removed when their writer is dead)."""
        if self.folder.is_dir():
            remove_stale_temps(self.folder)
        return set(self._complete())

    def read(self) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """Yield ``(block_id, payload)`` for every complete block, in id order."""
        for block_id, path in self._complete().items():
            with np.load(path, allow_pickle=False) as npz:
                yield block_id, {k: npz[k] for k in npz.files}


def _readable(path: Path) -> bool:
    """True if ``path`` opens as an npz with the journal's fields; warns if not.

    Renamed files are complete by construction; this guards against a disk that
    lied about fsync or a file someone truncated, so such a block is recomputed.
    """
    try:
        with zipfile.ZipFile(path) as z:
            names = {n.removesuffix(".npy") for n in z.namelist()}
    except (OSError, zipfile.BadZipFile) as err:
        warnings.warn(
            f"journal: ignoring unreadable block file {path} ({err}); it will be recomputed"
        )
        return False
    if not set(FIELDS) <= names:
        warnings.warn(f"journal: ignoring {path}: fields {sorted(set(FIELDS) - names)} are missing")
        return False
    return True


def fill_block(ds: xr.Dataset, payload: Mapping[str, np.ndarray]) -> None:
    """``store.cube.fill`` from a journal payload."""
    values = {k: v for k, v in payload.items() if k not in FIELDS}
    fill(
        ds,
        payload["index"],
        values,
        payload["status"],
        payload["cost_s"],
        payload["steps"],
        payload["evals"],
    )


def rebuild(ds_empty: xr.Dataset, journal: Journal) -> xr.Dataset:
    """A new cube: a deep copy of ``ds_empty`` with every journalled block filled in.

    Blocks are applied in id order, so a point journalled twice keeps the later
    block's result. ``ds_empty`` itself is not modified.
    """
    ds = ds_empty.copy(deep=True)
    for _, payload in journal.read():
        fill_block(ds, payload)
    return ds
