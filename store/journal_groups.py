"""Groups of journal blocks in one file (store.journal): the blocks a submitter finishes
together go to one ``group-<seq>.npz``, written atomically with one fsync, where a file
per block costs an fsync and a zip archive each (scripts/bench_scale.py, docs/BATCH.md).

A group file holds every field and output of its blocks concatenated (the blocks one after
another), ``_blocks`` (their ids) and ``_sizes`` (their points), any extra array of a block
file (``_engine``), and ``_sha256`` of all of them and of the group's number. Groups are
numbered in the order written; a block journaled again (a resumed sweep recomputing its
failed points) keeps the result of the last group that holds it, and block files (the one
file a block of journals written before groups) come before every group. A group that
fails its checks is set aside whole: all its blocks are computed again (or, where an
earlier group holds one, read from there from the next reading of the journal on).
"""
from __future__ import annotations

import hashlib
import io
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

NAME = re.compile(r"^group-(\d+)\.npz$")
BLOCKS, SIZES = "_blocks", "_sizes"


def file_name(seq: int) -> str:
    """The file name of group number ``seq``."""
    return f"group-{int(seq):08d}.npz"


def next_seq(folder: Path) -> int:
    """One more than the highest group number in ``folder`` (0 for none)."""
    seqs = [int(m.group(1)) for m in map(NAME.match, _names(folder)) if m]
    return max(seqs, default=-1) + 1


def digest(label: str, arrays: Mapping[str, np.ndarray]) -> np.ndarray:
    """SHA-256 (32 uint8) of ``label`` (``group 42``; ``block 42``: store.journal.checksum)
    and the arrays' names, dtypes, shapes and bytes."""
    h = hashlib.sha256(f"ditherlab journal {label}\n".encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name} {a.dtype.str} {a.shape}\n".encode())
        h.update(a.tobytes())
    return np.frombuffer(h.digest(), dtype=np.uint8)


def image(seq: int, items: Sequence[tuple[int, Mapping[str, np.ndarray]]],
          extra: Mapping[str, np.ndarray], checksum_key: str) -> memoryview:
    """The file of group ``seq``: ``items`` ``(block id, arrays)``, every block with the
    same array names (checked) and ``index`` among them, and ``extra`` arrays kept whole."""
    names = sorted(items[0][1])
    odd = [b for b, arrays in items if sorted(arrays) != names]
    if odd:
        raise ValueError(f"journal group: blocks {odd} have other arrays than block "
                         f"{items[0][0]} ({names})")
    arrays = {k: np.concatenate([a[k] for _, a in items]) for k in names}
    arrays[BLOCKS] = np.array([b for b, _ in items], dtype=np.int64)
    arrays[SIZES] = np.array([len(a["index"]) for _, a in items], dtype=np.int64)
    arrays.update(extra)
    buf = io.BytesIO()
    np.savez(buf, **arrays, **{checksum_key: digest(f"group {int(seq)}", arrays)})
    return buf.getbuffer()


def index(folder: Path) -> dict[int, Path]:
    """Block id -> the last group file that holds it, for every group file (unverified)."""
    found: dict[int, Path] = {}
    for name in sorted(n for n in _names(folder) if NAME.match(n)):
        path = Path(folder) / name
        try:
            with open(path, "rb") as f, np.load(f, allow_pickle=False) as npz:   # (np.load
                ids = npz[BLOCKS].tolist()          # left a damaged file's handle open)
        except Exception:  # noqa: BLE001 -- unreadable: reading it says why and sets it aside
            ids = [-1 - int(NAME.match(name).group(1))]   # (a key no block has)
        found.update((int(b), path) for b in ids)
    return found


def block(path: Path, block_id: int, checksum_key: str, memo: dict | None = None
          ) -> dict[str, np.ndarray]:
    """The arrays of one block of a verified group file, extra arrays included; a
    ValueError (or OSError) says why the group cannot be trusted. ``memo`` (a dict the
    caller keeps while it reads a journal) holds the last few groups read, so reading
    every block of a group reads the file once."""
    if memo is None or path not in memo:
        try:
            got: dict | Exception = _verified(path, checksum_key)
        except (OSError, ValueError) as err:
            got = err
        if memo is not None:
            if len(memo) >= MEMO:
                memo.pop(next(iter(memo)))
            memo[path] = got
    else:
        got = memo[path]
    if isinstance(got, Exception):
        raise got
    if block_id not in got:
        raise ValueError(f"group {path.name} holds no block {block_id}")
    return dict(got[block_id])


MEMO = 8   # groups a reader keeps decoded (blocks are read in id order; groups hold
           # blocks finished together, so nearby ids)


def _verified(path: Path, checksum_key: str) -> dict[int, dict]:
    with open(path, "rb") as f, np.load(f, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    stored = arrays.pop(checksum_key, None)
    seq = NAME.match(Path(path).name)
    if stored is None or seq is None:
        raise ValueError("no checksum (not a file ditherlab wrote)")
    if not np.array_equal(stored, digest(f"group {int(seq.group(1))}", arrays)):
        raise ValueError("checksum mismatch (the file changed after it was written)")
    ids, sizes = arrays.pop(BLOCKS, None), arrays.pop(SIZES, None)
    extra = {k: arrays.pop(k) for k in [k for k in arrays if k.startswith("_")]}
    if ids is None or sizes is None or ids.shape != sizes.shape or ids.ndim != 1 or \
            (sizes < 0).any() or any(len(v) != sizes.sum() for v in arrays.values()):
        raise ValueError("its blocks' ids and sizes do not match its arrays")
    parts = {k: np.split(v, np.cumsum(sizes)[:-1]) for k, v in arrays.items()}
    return {int(b): {**{k: p[i] for k, p in parts.items()}, **extra} for i, b in enumerate(ids)}


def _names(folder: Path) -> list[str]:
    try:
        return os.listdir(folder)
    except FileNotFoundError:
        return []
