"""Atomic publish (DESIGN.md §4): a reader sees the old cube or the new one, never a torn
file, even when the writer is killed with SIGKILL in the middle of an HDF5 write."""

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from storetest_cubes import block_record, make_cube
from storetest_writer import noise

import store
from store import errors
from store.atomic import temp_name
from store.errors import NoSpaceError

HERE = Path(__file__).parent
N_BIG = 600  # 600 x 600 points, two outputs: ~3 MB of zlib-resistant data, ~0.25 s a publish


def _dead_pid() -> int:
    proc = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
    )
    return int(proc.stdout)


def _temps(folder: Path) -> list[Path]:
    return sorted(folder.glob(".*.tmp-*"))


def test_publish_leaves_only_the_cube(cube, tmp_path):
    path = store.publish(cube, tmp_path / "sweep" / "cube.nc")
    store.publish(cube, path)  # replacing an existing cube
    assert sorted(p.name for p in path.parent.iterdir()) == ["cube.nc"]


def test_writer_dead_before_rename_leaves_old_cube_readable(cube, tmp_path):
    path = store.publish(cube, tmp_path / "cube.nc")
    orphan = temp_name(path).with_name(f".cube.nc.tmp-{_dead_pid()}-deadbeef")
    orphan.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 1000)  # a torn HDF5 file, never renamed
    xr.testing.assert_identical(store.as_dataset(store.open_cube(path)), store.as_dataset(cube))
    index = np.arange(5)
    store.fill(cube, block_record(cube, index))
    store.publish(cube, path)  # the next publish cleans the dead writer's leftover
    assert not orphan.exists() and _temps(tmp_path) == []
    xr.testing.assert_identical(store.as_dataset(store.open_cube(path)), store.as_dataset(cube))


def test_failed_write_keeps_old_cube_and_removes_temp(cube, tmp_path, monkeypatch):
    path = store.publish(cube, tmp_path / "cube.nc")
    before = path.read_bytes()

    def full(self, data):   # the disk fills up half-way through the temporary file
        with open(self, "wb") as f:
            f.write(bytes(data)[:100])
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Path, "write_bytes", full)
    with pytest.raises(NoSpaceError, match=r"no space left on device writing .*cube.nc: "
                       r"free \d+\.\d MB and submit again"):
        store.publish(make_cube(), path)
    monkeypatch.undo()
    assert path.read_bytes() == before and _temps(tmp_path) == []


def test_publish_checks_free_space_before_writing(cube, tmp_path, monkeypatch):
    path = store.publish(cube, tmp_path / "cube.nc")
    before = path.read_bytes()
    monkeypatch.setattr(errors, "free_bytes", lambda p: 10_000)
    with pytest.raises(NoSpaceError) as err:
        store.publish(make_cube(), path)
    assert err.value.free == 10_000 and err.value.needed > 10_000
    assert path.read_bytes() == before and _temps(tmp_path) == []


def _kill_mid_write(path: Path, fraction: float) -> tuple[subprocess.Popen, int]:
    """Start the writer, let it publish twice, then SIGSTOP it while a temporary file
    exists (so it is provably between create and rename) and SIGKILL it."""
    proc = subprocess.Popen(
        [sys.executable, str(HERE / "storetest_writer.py"), str(path), str(N_BIG)],
        stdout=subprocess.PIPE,
        text=True,
    )
    lines = iter(proc.stdout)
    assert next(lines).strip() == "start 0"
    t = time.monotonic()
    assert next(lines).strip() == "done 0" and next(lines).strip() == "start 1"
    assert next(lines).strip() == "done 1"
    duration = time.monotonic() - t
    assert next(lines).strip() == "start 2"
    t0 = time.monotonic()
    while time.monotonic() - t0 < 60:
        if time.monotonic() - t0 >= fraction * duration and _temps(path.parent):
            os.kill(proc.pid, signal.SIGSTOP)
            if _temps(path.parent):
                break
            os.kill(proc.pid, signal.SIGCONT)
        time.sleep(0.002)
    os.kill(proc.pid, signal.SIGKILL)
    out = proc.communicate()[0]
    done = [int(line.split()[1]) for line in out.splitlines() if line.startswith("done")]
    return proc, max([1, *done])


@pytest.mark.parametrize("fraction", [0.15, 0.6])
def test_sigkill_mid_publish_leaves_previous_generation(tmp_path, fraction):
    path = tmp_path / "sweep" / "cube.nc"
    proc, last_done = _kill_mid_write(path, fraction)
    assert proc.returncode == -signal.SIGKILL
    assert _temps(path.parent), "the writer should have died between create and rename"
    ds = store.open_cube(path)
    assert ds.attrs["generation"] == last_done
    np.testing.assert_array_equal(ds["b"].values, last_done)
    np.testing.assert_array_equal(ds["a"].values, noise(N_BIG) + last_done)
    store.publish(ds, path)
    assert _temps(path.parent) == []


def test_disagreement_says_how_a_published_cube_differs_from_the_journal(cube, tmp_path):
    """What submit compares before it trusts a published cube (issue 10)."""
    from store.cube_io import disagreement

    path = store.publish(cube, tmp_path / "cube.nc")
    assert disagreement(path, cube) is None
    assert disagreement(tmp_path / "none.h5", cube) == "the cube is missing"
    filled = cube.copy(deep=True)
    store.fill(filled, block_record(cube, np.arange(4)))
    assert disagreement(path, filled) == "the cube's F_mean differs from the journal's"
    estimated = cube.copy()
    estimated.attrs["error_estimate"] = "{}"
    assert disagreement(path, estimated) == "the cube's attributes differ from the journal's"
    store.publish(estimated, path)
    assert disagreement(path, cube) is None   # attributes only the file has are kept
    path.write_bytes(path.read_bytes()[:3000])
    assert disagreement(path, cube).startswith("the cube is unreadable (")
    later = cube.copy()
    later.attrs["created"] = "2099-01-01T00:00:00+00:00"
    store.publish(later, path)
    assert disagreement(path, cube) is None   # the creation time is not compared
