"""Cubes as the pages read them: whole, once per publish.

A runner publishes a cube by writing a temporary file and renaming it over ``cube.nc``
(store.cube_io). :func:`read_cube_bytes` opens the file once and reads that one inode to
its end, so a publish during the read leaves it the old cube, whole; the next request
finds the new inode. :class:`Cubes` keeps the last few cubes read (bytes and the opened
``xarray.Dataset``) keyed by that inode, size and mtime: an unchanged cube is read once,
and everything drawn from it (maps) is cached under the same key.
"""
from __future__ import annotations

import io
import os
from pathlib import Path

from .lru import LRU

MAX_CUBE_BYTES = 1 << 30        # a bigger cube is downloaded with the CLI, not served
KEEP = 8                        # cubes held in memory


class CubeSnapshot:
    """One published cube: ``key`` (inode, size, mtime_ns), its bytes and its Dataset."""

    def __init__(self, key: tuple, data: bytes):
        import xarray as xr

        from store.cube import AXES

        self.key, self.data = key, data
        with xr.open_dataset(io.BytesIO(data), engine="h5netcdf",
                             decode_timedelta=False) as f:
            self.ds = f.load()
        if "status" not in self.ds or tuple(self.ds["status"].dims) != AXES:
            raise ValueError("not a ditherlab cube (no status over W, omega, v_ref, v_d)")


def stat_key(st: os.stat_result) -> tuple:
    return (st.st_ino, st.st_size, st.st_mtime_ns)


def read_cube_bytes(path: Path, after_open=None) -> tuple[tuple, bytes]:
    """``(key, bytes)`` of the file at ``path``, read through one descriptor (whole,
    even if the file is replaced meanwhile). ``after_open`` (tests) runs between the
    open and the read."""
    with open(path, "rb") as f:
        st = os.fstat(f.fileno())
        if st.st_size > MAX_CUBE_BYTES:
            raise OverflowError(f"the cube is {st.st_size / 2**20:.0f} MiB, over the "
                                f"{MAX_CUBE_BYTES >> 20} MiB the web view serves; use "
                                "`ditherlab query` or copy cube.nc")
        if after_open is not None:
            after_open()
        return stat_key(st), f.read()


class Cubes:
    """The last ``KEEP`` cubes read, by path; thread-safe."""

    def __init__(self, keep: int = KEEP):
        self._held = LRU(keep)   # snapshots by path

    def get(self, path: Path) -> CubeSnapshot:
        """The cube at ``path`` as published now (read again only when it changed)."""
        key = stat_key(os.stat(path))   # FileNotFoundError: no cube yet
        held = self._held.get(path)
        if held is not None and held.key == key:
            return held
        from store.cube_io import READ_ERRORS, unreadable

        try:
            snap = CubeSnapshot(*read_cube_bytes(path))
        except FileNotFoundError:   # gone since the stat: no cube (404)
            raise
        except READ_ERRORS as err:   # a torn or foreign file: 409 and how to republish it,
            raise unreadable(path, err) from err   # as `ditherlab status` says (was a 500)
        self._held.put(path, snap)
        return snap
