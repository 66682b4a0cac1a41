"""The crash-safe journal (DESIGN.md §4): one file per finished block, only complete files
count, and the cube rebuilt from it equals the cube filled directly."""

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from storetest_cubes import block_record

import store
from store.journal import JournalWarning
from store.record import FIELDS

BLOCKS = {0: np.arange(0, 8), 1: np.arange(8, 16), 3: np.array([23, 16, 20])}


def _record(cube, index, seed=0):
    return block_record(cube, index, seed)


def _journal_with_blocks(cube, folder):
    journal = store.Journal(folder)
    for block_id, index in BLOCKS.items():
        journal.write(block_id, _record(cube, index, seed=block_id))
    return journal


def test_write_done_read_roundtrip(cube, tmp_path):
    journal = _journal_with_blocks(cube, tmp_path / "journal")
    assert journal.done() == set(BLOCKS)
    read = dict(journal.read())
    assert sorted(read) == sorted(BLOCKS)
    for block_id, index in BLOCKS.items():
        expected = _record(cube, index, seed=block_id).arrays()
        got = read[block_id].arrays()
        assert set(got) == set(expected)
        for key, array in expected.items():
            np.testing.assert_array_equal(got[key], array)
            assert got[key].dtype == FIELDS.get(key, np.float64)
    assert sorted(p.name for p in (tmp_path / "journal").iterdir()) == [
        "block-000000.npz",
        "block-000001.npz",
        "block-000003.npz",
    ]


def test_journal_carries_every_bookkeeping_variable(cube):
    assert set(FIELDS) - {"index"} == set(cube.data_vars) - set(store.output_names(cube))


def test_done_ignores_temp_files_and_torn_blocks(cube, tmp_path):
    journal = _journal_with_blocks(cube, tmp_path)
    live_temp = tmp_path / ".block-000004.npz.tmp-1-0badc0de"  # pid 1 is alive: left alone
    live_temp.write_bytes(b"PK\x03\x04 half a zip")
    (tmp_path / "block-000005.npz").write_bytes(b"PK\x03\x04 truncated")  # a disk that lied
    with pytest.warns(JournalWarning, match="block 5 is bad: unreadable.*bad/block-000005.npz"
                      ".*recomputed"):
        assert journal.done() == set(BLOCKS)
    assert sorted(dict(journal.read())) == sorted(BLOCKS)   # set aside: no second warning
    assert live_temp.exists()
    assert [p.name.split(".npz")[0] for p in (tmp_path / "bad").iterdir()] == ["block-000005"]


def test_done_removes_temps_of_dead_writers(cube, tmp_path):
    journal = _journal_with_blocks(cube, tmp_path)
    dead = int(
        subprocess.run(
            [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
        ).stdout
    )
    orphan = tmp_path / f".block-000007.npz.tmp-{dead}-0badc0de"
    orphan.write_bytes(b"PK")
    assert journal.done() == set(BLOCKS) and not orphan.exists()


def test_empty_or_missing_journal(tmp_path):
    journal = store.Journal(tmp_path / "never-written")
    assert journal.done() == set() and list(journal.read()) == []


def test_rewriting_a_block_replaces_it(cube, tmp_path):
    journal = store.Journal(tmp_path)
    journal.write(2, _record(cube, np.arange(3), seed=1))
    journal.write(2, _record(cube, np.arange(3), seed=2))
    ((block_id, record),) = journal.read()
    np.testing.assert_array_equal(record.status, _record(cube, np.arange(3), seed=2).status)


def test_rebuild_equals_filling_directly(cube, tmp_path):
    journal = _journal_with_blocks(cube, tmp_path)
    direct = cube.copy(deep=True)
    for block_id, index in BLOCKS.items():
        store.fill(direct, block_record(cube, index, seed=block_id))
    pristine = cube.copy(deep=True)
    rebuilt = store.rebuild(cube, journal)
    xr.testing.assert_identical(store.as_dataset(rebuilt), store.as_dataset(direct))
    xr.testing.assert_identical(store.as_dataset(cube), store.as_dataset(pristine))  # not modified
    written = np.concatenate(list(BLOCKS.values()))
    not_ok = np.concatenate(
        [i[block_record(cube, i, seed=b).status != 0] for b, i in BLOCKS.items()]
    )
    expected = (set(range(cube["status"].size)) - set(written)) | set(not_ok)
    assert set(np.flatnonzero(rebuilt["status"].values.reshape(-1) != store.OK)) == expected


@pytest.mark.parametrize(
    "arrays, message",
    [
        ({"index": np.arange(2)}, r"block record lacks \['status', 'cost_s', 'steps', 'evals'\]"),
        ({**{k: np.zeros(2, int) for k in FIELDS}, "F_mean": np.zeros(3)}, r"'F_mean': \(3,\)"),
        ({**{k: np.zeros((2, 2), int) for k in FIELDS}, "index": np.arange(2)},
         r"must have index.s length 2 first"),
        ({k: np.zeros(2) for k in FIELDS}, r"flat_index must be a 1-D integer array"),
    ],
)
def test_a_bad_block_record_is_refused_before_anything_is_written(tmp_path, arrays, message):
    with pytest.raises(ValueError, match=message):
        store.Journal(tmp_path).write(0, store.BlockRecord.from_arrays(arrays))
    assert list(tmp_path.iterdir()) == []


def test_block_id_and_name_clash_errors(tmp_path):
    with pytest.raises(ValueError, match="block_id must be a non-negative integer, got -1"):
        store.Journal(tmp_path).path(-1)
    with pytest.raises(ValueError, match=r"output names \['status'\] clash"):
        store.BlockRecord(np.arange(1), np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1),
                          outputs={"status": np.zeros(1)})
