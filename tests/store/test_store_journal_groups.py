"""Journal groups (store.journal_groups): the blocks a submitter finishes together in one
file with one fsync. Read back block by block as block files are; a block journaled again
keeps its last result; a damaged group is set aside whole; a journal of block files (the
layout before groups) still opens, with groups after it."""

import warnings

from dataclasses import replace

import numpy as np
import xarray as xr
from storetest_cubes import block_record

import store
from store.journal import JournalWarning
from store.record import FIELDS

BLOCKS = {0: np.arange(0, 8), 1: np.arange(8, 16), 3: np.array([23, 16, 20])}


def _payload(cube, index, seed=0, fingerprint=None):
    return replace(block_record(cube, index, seed), fingerprint=fingerprint)


def test_a_group_reads_back_as_its_blocks_with_their_engine(cube, tmp_path):
    journal = store.Journal(tmp_path / "journal")
    journal.write_group([(b, _payload(cube, i, seed=b, fingerprint="fp1"))
                         for b, i in BLOCKS.items()])
    assert [p.name for p in (tmp_path / "journal").iterdir()] == ["group-00000000.npz"]
    read = dict(journal.read())
    assert sorted(read) == sorted(BLOCKS) and journal.done() == set(BLOCKS)
    for b, index in BLOCKS.items():
        expected, got = _payload(cube, index, seed=b).arrays(), read[b].arrays()
        assert set(got) == set(expected)
        for key, array in expected.items():
            np.testing.assert_array_equal(got[key], array)
            assert got[key].dtype == FIELDS.get(key, np.float64)
        assert read[b].fingerprint == journal.load(b).fingerprint == "fp1"
    # the cube rebuilt from the group equals the cube filled block by block
    direct = cube.copy(deep=True)
    for b, index in BLOCKS.items():
        store.fill(direct, _payload(cube, index, seed=b))
    xr.testing.assert_identical(store.rebuild(cube, journal).to_dataset(), direct.to_dataset())


def test_block_files_then_groups_in_the_order_written(cube, tmp_path):
    journal = store.Journal(tmp_path / "journal")
    journal.write(0, _payload(cube, BLOCKS[0], seed=10))      # a journal of earlier versions
    journal.write(1, _payload(cube, BLOCKS[1], seed=11))
    journal.write_group([(1, _payload(cube, BLOCKS[1], seed=21))])
    journal.write_group([(3, _payload(cube, BLOCKS[3], seed=23))])
    again = store.Journal(tmp_path / "journal")                # a later writer numbers on
    again.write_group([(3, _payload(cube, BLOCKS[3], seed=33))])
    read = dict(again.read())
    assert sorted(read) == [0, 1, 3]
    for b, seed in ((0, 10), (1, 21), (3, 33)):
        np.testing.assert_array_equal(read[b].cost_s, _payload(cube, BLOCKS[b], seed=seed).cost_s)
    assert sorted(p.name for p in (tmp_path / "journal").iterdir())[-1] == "group-00000002.npz"


def test_a_damaged_group_is_set_aside_whole_and_older_results_stand(cube, tmp_path):
    journal = store.Journal(tmp_path / "journal")
    journal.write_group([(0, _payload(cube, BLOCKS[0], seed=1))])
    path = journal.write_group([(0, _payload(cube, BLOCKS[0], seed=2)),
                                (1, _payload(cube, BLOCKS[1], seed=2))])
    data = bytearray(path.read_bytes())
    data[len(data) // 3: len(data) // 3 + 64] = b"\xff" * 64
    path.write_bytes(bytes(data))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        done = journal.done()
    assert done == set()                   # both blocks set aside with their group ...
    lines = [str(w.message) for w in caught if issubclass(w.category, JournalWarning)]
    assert len(lines) == 1 and "group-00000001.npz, all its blocks" in lines[0], lines
    assert [p.name.split(".")[0] for p in (tmp_path / "journal" / "bad").iterdir()] == [
        "group-00000001"]
    read = dict(journal.read())            # ... and block 0's earlier result read from now on
    assert sorted(read) == [0]
    np.testing.assert_array_equal(read[0].cost_s, _payload(cube, BLOCKS[0], seed=1).cost_s)


def test_a_block_of_other_points_sets_its_group_aside(cube, tmp_path):
    journal = store.Journal(tmp_path / "journal")
    journal.write_group([(0, _payload(cube, BLOCKS[0])), (1, _payload(cube, BLOCKS[1]))])
    plan = [BLOCKS[0], BLOCKS[0]]          # this sweep's block 1 holds other points
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert journal.done(plan) == {0}   # block 0 has its own points: its values stand
    assert any("its points are not those of block 1" in str(w.message) for w in caught)
    assert journal.done(plan) == set()     # the group is in bad/: block 0 is computed again
