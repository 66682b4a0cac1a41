"""Atomic publish (DESIGN.md §4): a reader sees the old cube or the new one, never a torn
file, even when the writer is killed with SIGKILL in the middle of an HDF5 write."""

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr
from storetest_cubes import ATTRS, block_record, make_cube
from storetest_writer import noise

from tests.guarantee import skip_unless_ci

import store
from store import errors, netcdf_write
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
    written = []

    def full(dset, data, pool):   # the disk fills up half-way through the chunks
        written.append(dset.name)
        if len(written) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(dset, data, pool)

    real = netcdf_write._write_chunks
    monkeypatch.setattr(netcdf_write, "_write_chunks", full)
    with pytest.raises(NoSpaceError, match=r"no space left on device writing .*cube.nc: "
                       r"free \d+\.\d MB and submit again"):
        store.publish(make_cube(), path)
    monkeypatch.undo()
    assert len(written) == 2 and path.read_bytes() == before and _temps(tmp_path) == []


def test_a_disk_that_cannot_hold_the_file_is_refused_before_hdf5_writes(cube, tmp_path,
                                                                          monkeypatch):
    """The reservation is the guard (HDF5 meeting a full disk ends the process with a
    segmentation fault: store.netcdf_write); a refused one writes nothing."""
    path = store.publish(cube, tmp_path / "cube.nc")
    before = path.read_bytes()
    asked = []

    def no_room(fd, nbytes):
        asked.append((os.fstat(fd).st_size, nbytes))
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(netcdf_write, "reserve", no_room)
    monkeypatch.setattr(netcdf_write, "_write", lambda *a: pytest.fail("HDF5 was started"))
    with pytest.raises(NoSpaceError):
        store.publish(make_cube(), path)
    assert asked == [(0, netcdf_write.space_bound(make_cube()))]
    assert path.read_bytes() == before and _temps(tmp_path) == []


def test_where_space_cannot_be_reserved_the_image_is_made_in_memory(cube, tmp_path,
                                                                     monkeypatch):
    def unsupported(fd, nbytes):
        raise netcdf_write.ReserveUnsupported(errno.EOPNOTSUPP, "not here")

    images = []
    image = netcdf_write.netcdf_image
    monkeypatch.setattr(netcdf_write, "reserve", unsupported)
    monkeypatch.setattr(netcdf_write, "netcdf_image", lambda c: images.append(c) or image(c))
    path = store.publish(cube, tmp_path / "cube.nc")
    monkeypatch.undo()
    assert len(images) == 1 and store.cube_io.disagreement(path, cube) is None
    store.publish(cube, tmp_path / "reserved.nc")
    xr.testing.assert_identical(store.open_cube(path), store.open_cube(tmp_path / "reserved.nc"))


@pytest.mark.parametrize("shape", [(1, 1, 1, 1), (3, 4, 2, 1), (37, 29, 3, 2), (600, 600, 1, 1)])
@pytest.mark.parametrize("values", ["noise", "constant", "nan"])
def test_chunks_filtered_here_read_back_exactly_and_fit_the_reserved_space(tmp_path, shape,
                                                                           values):
    """store.netcdf_write filters the chunks itself (shuffle, ISA-L deflate, edge chunks
    padded, incompressible chunks stored shuffled only): h5py's own filters read them
    back exactly, and the file never outgrows the space reserved for it."""
    coords = {a: np.arange(n, dtype=float) for a, n in zip(store.AXES, shape)}
    outputs = {"F_mean": ("mean friction", "1"),
               "alpha_hist": ("histogram", "1", ("alpha_bin", 10))}
    cube = store.empty_cube(coords, outputs, ATTRS)
    rng = np.random.default_rng(7)
    for var in cube.data_vars.values():
        var.data[...] = {"noise": rng.random(var.shape) * 100, "constant": 3,
                         "nan": np.nan}[values] if var.dtype.kind == "f" else \
            rng.integers(-100, 100, var.shape)
    path = store.publish(cube, tmp_path / "cube.nc")
    assert store.cube_io.disagreement(path, cube) is None
    assert path.stat().st_size <= netcdf_write.space_bound(cube)
    assert path.stat().st_blocks * 512 < path.stat().st_size + 64 * 1024   # reservation given back
    with h5py.File(path) as f:
        for name, var in cube.data_vars.items():
            dset = f[name]
            assert dset.compression == "gzip" and dset.shuffle
            np.testing.assert_array_equal(dset[...], var.data)
            masks = {dset.id.get_chunk_info(i).filter_mask
                     for i in range(dset.id.get_num_chunks())}
            assert masks <= {0, netcdf_write.DEFLATE_SKIPPED}


def test_an_incompressible_chunk_is_stored_shuffled_only(tmp_path):
    data = np.frombuffer(np.random.default_rng(3).bytes(8 * 4096), np.float64).reshape(
        64, 64, 1, 1)
    mask, raw = netcdf_write._filtered_chunk(data, (0, 0, 0, 0), (64, 64, 1, 1))
    shuffled = data.view(np.uint8).reshape(-1, 8).T.tobytes()
    assert (mask, raw) == (netcdf_write.DEFLATE_SKIPPED, shuffled)
    coords = {a: np.arange(n, dtype=float) for a, n in zip(store.AXES, data.shape)}
    cube = store.empty_cube(coords, {"F_mean": ("mean friction", "1")}, ATTRS)
    cube["F_mean"].data[...] = data
    path = store.publish(cube, tmp_path / "cube.nc")
    np.testing.assert_array_equal(store.read_cube(path)["F_mean"].data, data)


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


def test_a_real_full_disk_is_a_no_space_error_not_a_segfault(tmp_path):
    """A 600 x 600 noise cube (2.9 MB) published onto a 1-MB tmpfs: HDF5 writing into a
    full disk ends the process with SIGSEGV (tried: exit 139, store.netcdf_write); the
    reservation makes it a NoSpaceError with nothing left behind. Root only (tmpfs)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(disk)],
                             capture_output=True, text=True)
    if mounted.returncode != 0:
        skip_unless_ci(f"cannot mount a tmpfs here: {mounted.stderr.strip() or 'not root'}")
    try:
        proc = subprocess.run([sys.executable, str(HERE / "storetest_writer.py"),
                               str(disk / "cube.nc"), str(N_BIG)],
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 1, proc.stderr[-2000:]
        assert proc.stdout.splitlines() == ["start 0"]
        assert proc.stderr.strip().splitlines()[-1].startswith(
            f"store.errors.NoSpaceError: no space left on device writing {disk}/cube.nc")
        assert list(disk.iterdir()) == [] and errors.free_bytes(disk) > 900 * 1024
    finally:
        subprocess.run(["umount", "--lazy", str(disk)], capture_output=True)
