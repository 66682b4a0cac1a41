"""Crash-safe journal of finished blocks (DESIGN.md §4): the truth a cube is rebuilt from.

The submitting process is the only writer. The blocks it finishes together go to one
``.npz`` file ``<sweep>/journal/group-00000042.npz`` (store.journal_groups; journals
written before groups, and :meth:`Journal.write`, have a file per block,
``block-000042.npz``), written under a temporary name, fsynced and renamed, so a file
with a final name is always complete. The cube is rebuilt from the journal (``rebuild``)
and published every few blocks and at the end; a resumed sweep computes only the blocks
the journal lacks.

A block is a :class:`store.record.BlockRecord` (the same record the worker made and
``store.points.fill`` writes into the cube); its file holds one array per field and output,
named as the record's fields (``index``, ``status``, ``cost_s``, ``steps``, ``evals``) and
outputs (``F_mean``, ...).

Every file also holds ``_sha256``: the SHA-256 of its block id (group number) and of each
array's name, dtype, shape and bytes. Reading checks it, the fields and dtypes, and
(``rebuild``) the cube's shape, index range and status codes and the plan's points of the
block. A file that fails any check, or has no checksum (older journals, other programs),
is never read as data: it is moved to ``journal/bad/`` with one warning line and its
points are computed again. ``_engine``, inside the checksum, is the records'
``fingerprint``, the results fingerprint of the worker that computed the blocks
(``Journal.load(b).fingerprint``).
"""

from __future__ import annotations

import io
import os
import re
import time
import warnings
from collections.abc import Iterator, Mapping, Sequence
from contextlib import suppress
from pathlib import Path

import numpy as np

from . import journal_groups as groups
from .atomic import atomic_write, remove_stale_temps
from .points import fill
from .record import BlockRecord

CHECKSUM = "_sha256"
ENGINE = "_engine"   # the results fingerprint of the worker that computed the block (ASCII)
BAD_DIR = "bad"
_NAME = re.compile(r"^block-(\d+)\.npz$")


class JournalWarning(UserWarning):
    """A journal block was set aside (damaged, unverifiable, or not of this sweep)."""


class BadBlock(ValueError):
    """Why a block file cannot be trusted (the warning's text)."""


def checksum(block_id: int, arrays: Mapping[str, np.ndarray]) -> np.ndarray:
    """SHA-256 (32 uint8) of a block's id and its arrays' names, dtypes, shapes and bytes."""
    return groups.digest(f"block {int(block_id)}", arrays)


def block_bytes(n_points: int, n_values: int) -> int:
    """A generous size on disk of one block file: ``n_points`` rows of ``n_values``
    numbers (every field and output value of a point), rounded up to whole 4 KiB pages."""
    raw = 8 * n_points * n_values + 300 * (n_values + 1)
    return -(-raw // 4096) * 4096


class Journal:
    """The journal folder of one sweep: ``Journal(SweepDir(store_root, id).journal)``.

    Parameters
    ----------
    folder
        The journal folder; created on the first ``write``.
    """

    def __init__(self, folder):
        self.folder = Path(folder)
        self._seq: int | None = None   # the last group written (this writer's)

    def __repr__(self) -> str:
        return f"Journal({str(self.folder)!r})"

    def path(self, block_id: int) -> Path:
        """The final file name of block ``block_id``."""
        if int(block_id) != block_id or block_id < 0:
            raise ValueError(f"block_id must be a non-negative integer, got {block_id!r}")
        return self.folder / f"block-{int(block_id):06d}.npz"

    def write(self, block_id: int, record: BlockRecord) -> Path:
        """Record a finished block atomically (temporary name, fsync, rename), with its
        checksum and the record's ``fingerprint`` (the engine that computed it; none if
        None). Free space is checked first (``store.errors.NoSpaceError``). Writing a block
        again replaces it. Returns the file's path."""
        path = self.path(block_id)
        arrays = record.arrays()
        if record.fingerprint is not None:
            arrays[ENGINE] = np.frombuffer(record.fingerprint.encode("ascii"), np.uint8)
        buf = io.BytesIO()
        np.savez(buf, **arrays, **{CHECKSUM: checksum(block_id, arrays)})
        return atomic_write(path, buf.getbuffer())

    def write_group(self, items: list[tuple[int, BlockRecord]]) -> Path:
        """Record finished blocks ``(block_id, record)`` of one engine (their fingerprint)
        as one group file, as :meth:`write` but one fsync for them all
        (store.journal_groups). Returns its path."""
        prints = {r.fingerprint for _, r in items}
        if len(prints) != 1:
            raise ValueError(f"journal group: blocks of several engines {sorted(map(str, prints))}")
        engine = prints.pop()
        extra = {} if engine is None else {ENGINE: np.frombuffer(engine.encode("ascii"), np.uint8)}
        arrays = [(b, r.arrays()) for b, r in items if self.path(b)]   # (ids checked)
        self._seq = groups.next_seq(self.folder) if self._seq is None else self._seq + 1
        return atomic_write(self.folder / groups.file_name(self._seq),
                            groups.image(self._seq, arrays, extra, CHECKSUM))

    def last_group(self) -> Path | None:
        """The group file this writer wrote last, or was writing when interrupted (then
        it exists only if the rename was reached); None before its first group."""
        return None if self._seq is None else self.folder / groups.file_name(self._seq)

    def files(self) -> dict[int, Path]:
        """Block id -> file (its block file, or the last group holding it), unverified.
        Temporary files of writers that are gone are removed first."""
        if not self.folder.is_dir():
            return {}
        with suppress(OSError):   # a read-only store keeps its leftovers
            remove_stale_temps(self.folder)
        found = (( _NAME.match(p.name), p) for p in sorted(self.folder.iterdir()))
        return {**{int(m.group(1)): p for m, p in found if m}, **groups.index(self.folder)}

    def _where(self, block_id: int) -> Path:
        return self.files().get(block_id) or self.path(block_id)

    def load(self, block_id: int, path: Path | None = None, memo: dict | None = None
             ) -> BlockRecord:
        """The verified record of one block (its file, or its group file: ``memo`` a dict
        kept while reading a journal, store.journal_groups.block); ``BadBlock`` saying why
        it cannot be trusted (unreadable, no or wrong checksum, fields or dtypes wrong)."""
        path = self._where(block_id) if path is None else path
        arrays = self._group_block(block_id, path, memo) if groups.NAME.match(path.name) \
            else self._block_file(block_id, path)
        engine = arrays.pop(ENGINE, None)
        try:
            record = BlockRecord.from_arrays(arrays, strict=True)
        except ValueError as err:
            raise BadBlock(_brief(err)) from None
        record.fingerprint = None if engine is None else engine.tobytes().decode("ascii",
                                                                                 "replace")
        return record

    @staticmethod
    def _group_block(block_id: int, path: Path, memo: dict | None) -> dict:
        try:
            return groups.block(path, block_id, CHECKSUM, memo)
        except Exception as err:  # noqa: BLE001 -- as a block file's: unreadable, checksum...
            raise BadBlock(f"group {path.name}, all its blocks: {_brief(err)}") from None

    @staticmethod
    def _block_file(block_id: int, path: Path) -> dict:
        try:
            with open(path, "rb") as f, np.load(f, allow_pickle=False) as npz:
                arrays = {k: npz[k] for k in npz.files}
        except Exception as err:  # noqa: BLE001 -- BadZipFile, zlib.error, OSError, ValueError...
            raise BadBlock(f"unreadable ({_brief(err)})") from None
        stored = arrays.pop(CHECKSUM, None)
        if stored is None:
            raise BadBlock("no checksum (written before ditherlab checked its journal, or by "
                           "another program)")
        if not np.array_equal(stored, checksum(block_id, arrays)):
            raise BadBlock("checksum mismatch (the file changed after it was written)")
        return arrays

    def read(self, blocks: Sequence[np.ndarray] | None = None, repair: bool = True
             ) -> Iterator[tuple[int, BlockRecord]]:
        """Yield ``(block_id, record)`` for every verified block, in id order.

        ``blocks`` (the plan's flat indices per block id) also refuses a block whose
        points are not those of its id. A refused block is set aside (``set_aside``)
        when ``repair``; without it (a reader that does not hold the sweep) it is only
        skipped, silently: its writer will set it aside.
        """
        memo: dict = {}
        for block_id, path in sorted(self.files().items()):
            try:
                record = self.load(block_id, path, memo)
                if blocks is not None:
                    _check_plan(block_id, record.index, blocks)
            except BadBlock as err:
                if repair:
                    self.set_aside(block_id, str(err), path)
                continue
            yield block_id, record

    def done(self, blocks: Sequence[np.ndarray] | None = None) -> set[int]:
        """Ids of the blocks with a verified file (bad ones are set aside)."""
        return {block_id for block_id, _ in self.read(blocks)}

    def set_aside(self, block_id: int, reason: str, path: Path | None = None) -> Path | None:
        """Move a block file that cannot be trusted to ``journal/bad/`` (kept for a look,
        never read again) with one ``JournalWarning``; its points will be recomputed.
        Returns the new path, or None if it could not be moved (a read-only store)."""
        path = self._where(block_id) if path is None else path
        dest = self.folder / BAD_DIR / f"{path.name}.{time.strftime('%Y%m%dT%H%M%S')}-{os.getpid()}"
        # a group file that cannot be read has no block ids (journal_groups.index: a
        # negative key): named by its file ("block -2 is bad" before)
        what = f"block {block_id}" if block_id >= 0 else f"file {path.name}"
        try:
            dest.parent.mkdir(exist_ok=True)
            os.replace(path, dest)
        except FileNotFoundError:   # another process set it aside first
            return None
        except OSError as err:
            _warn(f"journal: {what} ({path}) is bad: {reason}; it is ignored and "
                  f"will be recomputed (could not move it aside: {err.strerror})")
            return None
        _warn(f"journal: {what} is bad: {reason}; moved to {dest}, its points "
              "will be recomputed")
        return dest


def _check_plan(block_id: int, index: np.ndarray, blocks: Sequence[np.ndarray]) -> None:
    if block_id >= len(blocks):
        raise BadBlock(f"block id {block_id} is beyond this sweep's {len(blocks)} blocks")
    if not np.array_equal(index, blocks[block_id]):
        raise BadBlock(f"its points are not those of block {block_id} of this sweep")


def _brief(err: BaseException, width: int = 160) -> str:
    text = f"{type(err).__name__}: {err}".replace("\n", " ")
    return text if len(text) <= width else text[: width - 3] + "..."


def _warn(message: str) -> None:
    warnings.warn(message, JournalWarning, stacklevel=3)


def rebuild(ds_empty, journal: Journal, blocks: Sequence[np.ndarray] | None = None,
            repair: bool = True):
    """A new cube: a deep copy of ``ds_empty`` with every verified journal block filled in.

    A block that does not fit the cube (outputs, shapes, index range, status codes;
    with ``blocks``, the plan's points of its id) is set aside like a damaged one
    (``Journal.read``; only skipped without ``repair``). Blocks are applied in id
    order, so a point journalled twice keeps the later block's result. ``ds_empty``
    itself is not modified.
    """
    ds = ds_empty.copy(deep=True)
    for block_id, record in journal.read(blocks, repair=repair):
        try:
            fill(ds, record)   # checks everything before it writes anything
        except ValueError as err:
            if repair:
                journal.set_aside(block_id, f"it does not fit the cube ({_brief(err)})")
    return ds
