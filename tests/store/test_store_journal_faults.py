"""The journal is the truth (issue 10): a block that cannot be trusted -- torn, bit-flipped,
rewritten, without a checksum, of the wrong shape, with unknown status codes, or holding
another block's points -- is never read as data and never stops the sweep: it is moved to
journal/bad/ with one warning and its points come back as not yet computed."""

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from storetest_cubes import block_record

import store
from store.journal import CHECKSUM, JournalWarning, checksum

PLAN = [np.arange(0, 8), np.arange(8, 16), np.arange(16, 24)]   # the plan's blocks


def _journal(cube, folder):
    journal = store.Journal(folder)
    for b, index in enumerate(PLAN):
        journal.write(b, block_record(cube, index, seed=b))
    return journal


def _rewrite(path, change, keep_checksum=True):
    """Rewrite a block file as another program would: np.savez of changed arrays."""
    with np.load(path) as npz:
        arrays = {k: npz[k] for k in npz.files}
    stored = arrays.pop(CHECKSUM)
    change(arrays)
    if keep_checksum:
        arrays[CHECKSUM] = stored
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def _flip_bytes(path, n=8):
    """Flip the bytes of F_mean's first value where they lie in the (uncompressed) file."""
    data = bytearray(path.read_bytes())
    with np.load(path) as npz:
        start = data.find(npz["F_mean"].tobytes())
    assert start > 0
    data[start:start + n] = bytes(b ^ 0xFF for b in data[start:start + n])
    path.write_bytes(bytes(data))


def _set(key, value):
    def change(arrays):
        arrays[key] = value
    return change


FAULTS = {
    "flipped bytes": lambda p: _flip_bytes(p),
    "truncated": lambda p: p.write_bytes(p.read_bytes()[:300]),
    "empty": lambda p: p.write_bytes(b""),
    "wrong numbers, old checksum": lambda p: _rewrite(
        p, lambda a: a["F_mean"].__setitem__(0, 1e9)),
    "no checksum (rewritten)": lambda p: _rewrite(
        p, lambda a: a["F_mean"].__setitem__(0, 1e9), keep_checksum=False),
    "wrong shape": lambda p: _rewrite(p, _set("status", np.zeros(3, np.int8))),
    "wrong dtype": lambda p: _rewrite(p, _set("status", np.zeros(8, np.float64))),
    "a field missing": lambda p: _rewrite(p, lambda a: a.pop("evals")),
}


@pytest.mark.parametrize("fault", FAULTS)
def test_a_bad_block_is_set_aside_and_its_points_recomputed(cube, tmp_path, fault):
    journal = _journal(cube, tmp_path / "journal")
    clean = store.rebuild(cube, journal, PLAN)
    FAULTS[fault](journal.path(1))
    with pytest.warns(JournalWarning, match=r"journal: block 1 is bad: .*moved to .*bad/"
                      r"block-000001\.npz.*recomputed") as caught:
        rebuilt = store.rebuild(cube, journal, PLAN)
    assert len(caught) == 1 and "\n" not in str(caught[0].message)
    assert not journal.path(1).exists()
    assert [p.name[:16] for p in (tmp_path / "journal" / "bad").iterdir()] == ["block-000001.npz"]
    status = rebuilt["status"].values.reshape(-1)
    assert (status[PLAN[1]] == store.NOT_COMPUTED).all()          # to be computed again
    assert np.isnan(rebuilt["F_mean"].values.reshape(-1)[PLAN[1]]).all()   # never read as data
    keep = np.r_[PLAN[0], PLAN[2]]
    for name in rebuilt.data_vars:
        np.testing.assert_array_equal(rebuilt[name].values.reshape(-1)[keep],
                                      clean[name].values.reshape(-1)[keep])
    assert journal.done(PLAN) == {0, 2}   # and nothing more to warn about


def test_a_block_that_does_not_fit_the_cube_is_set_aside(cube, tmp_path):
    """Checksummed (the writer's own bug), but status codes out of range, an index out
    of the cube or another block's points: set aside, never a ValueError."""
    journal = _journal(cube, tmp_path)
    journal.write(0, block_record(cube, PLAN[0], status=np.full(8, 7, np.int8)))
    journal.write(1, block_record(cube, PLAN[1], index=np.arange(100, 108)))
    journal.write(5, block_record(cube, PLAN[2]))
    with pytest.warns(JournalWarning) as caught:
        rebuilt = store.rebuild(cube, journal, PLAN)
    messages = sorted(str(w.message) for w in caught)
    assert "block 0 is bad: it does not fit the cube" in messages[0]
    assert "status codes must be in 0..3, got [7]" in messages[0]
    assert "block 1 is bad: its points are not those of block 1" in messages[1]
    assert "block 5 is bad: block id 5 is beyond this sweep's 3 blocks" in messages[2]
    assert (rebuilt["status"].values.reshape(-1)[:16] == store.NOT_COMPUTED).all()
    assert sorted(dict(journal.read(PLAN))) == [2]


def test_a_block_copied_under_another_id_fails_its_checksum(cube, tmp_path):
    journal = _journal(cube, tmp_path)
    journal.path(2).write_bytes(journal.path(0).read_bytes())
    with pytest.warns(JournalWarning, match="block 2 is bad: checksum mismatch"):
        assert journal.done() == {0, 1}


def test_checksum_covers_names_dtypes_shapes_and_bytes():
    a = {"x": np.arange(3, dtype=np.int64)}
    base = checksum(0, a)
    assert checksum(0, {"x": np.arange(3, dtype=np.int64)}).tobytes() == base.tobytes()
    for other in ({"y": a["x"]}, {"x": a["x"].astype(np.int32)}, {"x": a["x"].reshape(3, 1)},
                  {"x": a["x"] + 1}):
        assert checksum(0, other).tobytes() != base.tobytes()
    assert checksum(1, a).tobytes() != base.tobytes()


def test_without_repair_a_bad_block_is_skipped_quietly_and_left_in_place(cube, tmp_path,
                                                                          recwarn):
    """A process that does not hold the sweep (a reader, a submitter before it takes the
    lease) must not move files the writer may be replacing at that moment."""
    journal = _journal(cube, tmp_path)
    _flip_bytes(journal.path(1))
    rebuilt = store.rebuild(cube, journal, PLAN, repair=False)
    assert journal.path(1).exists() and not recwarn.list
    assert (rebuilt["status"].values.reshape(-1)[PLAN[1]] == store.NOT_COMPUTED).all()


def test_temporaries_of_a_killed_writer_are_removed_on_the_next_read(cube, tmp_path):
    journal = _journal(cube, tmp_path)
    code = ("import sys, numpy as np; sys.path.insert(0, %r); import store; "
            "from storetest_cubes import make_cube, block_record; c = make_cube(); "
            "j = store.Journal(%r); import os, signal; "
            "store.atomic.fsync_file = lambda p: os.kill(os.getpid(), signal.SIGKILL); "
            "j.write(7, block_record(c, np.arange(3)))"
            % (str(__import__("pathlib").Path(__file__).parent), str(tmp_path)))
    proc = subprocess.run([sys.executable, "-c", code])
    assert proc.returncode == -9
    leftovers = list(tmp_path.glob(".block-000007.npz.tmp-*"))
    assert len(leftovers) == 1                      # killed between write and rename
    assert sorted(dict(journal.read())) == [0, 1, 2]
    assert not list(tmp_path.glob(".*.tmp-*"))


def test_rebuild_of_a_good_journal_is_unchanged(cube, tmp_path, recwarn):
    journal = _journal(cube, tmp_path)
    direct = cube.copy(deep=True)
    for b, index in enumerate(PLAN):
        store.fill(direct, block_record(cube, index, seed=b))
    xr.testing.assert_identical(store.as_dataset(store.rebuild(cube, journal, PLAN)),
                                store.as_dataset(direct))
    assert not recwarn.list


def test_an_unreadable_group_file_is_named_by_its_file(cube, tmp_path):
    """A group file (several blocks journaled together) that cannot be read has no block
    ids to name: the warning names the file. It said "journal: block -2 is bad" (a fault
    campaign, 2026-11-29: the index's stand-in key for the unreadable file)."""
    journal = store.Journal(tmp_path / "journal")
    path = journal.write_group([(b, block_record(cube, index, seed=b))
                                for b, index in enumerate(PLAN)])
    path.write_bytes(path.read_bytes()[:200])
    with pytest.warns(JournalWarning) as caught:
        assert journal.done(PLAN) == set()
    messages = [str(w.message) for w in caught]
    assert len(messages) == 1, messages
    message = messages[0]
    assert message.startswith(f"journal: file {path.name} is bad: "), message
    assert "block -" not in message
