"""A cube as a file: :func:`publish` (atomic: the image made in memory, free space
checked, temporary file, fsync, rename), :func:`open_cube` (fully into memory, a
:class:`CubeError` that says how to repair an unreadable file), :func:`disagreement`
between a published cube and one in memory, and :func:`cube_bytes` for space checks."""

from __future__ import annotations

import sys
from contextlib import nullcontext
from pathlib import Path

import numpy as np
import xarray as xr

from . import attrs as A
from .atomic import atomic_write, remove_stale_temps
from .cube import AXES
from .errors import StoreError
from .layout import SPEC_NAME

COMPRESSION = {"zlib": True, "complevel": 4, "shuffle": True}


def _check_layout(ds: xr.Dataset, where: str) -> None:
    if not set(AXES) <= set(ds.dims) or "status" not in ds \
            or any(a not in ds.coords for a in AXES):
        raise ValueError(
            f"{where}: not a ditherlab cube: dims {tuple(ds.dims)} (expected {AXES}), "
            f"variables {list(ds.data_vars)} (expected 'status' among them)"
        )
    for name, var in ds.data_vars.items():
        if var.dims[:len(AXES)] != AXES or len(var.dims) > len(AXES) + 1:
            raise ValueError(f"{where}: variable {name!r} has dims {var.dims}, expected {AXES} "
                             "(and at most one extra trailing dimension)")


def _encoding(ds: xr.Dataset) -> dict[str, dict]:
    enc = {}
    for name, var in ds.data_vars.items():
        enc[name] = dict(COMPRESSION)
        if np.issubdtype(var.dtype, np.integer):
            enc[name]["_FillValue"] = (
                None  # with a fill value xarray decodes int8 as float (pydata/xarray#1576)
            )
    return enc


def publish(ds: xr.Dataset, path) -> Path:
    """Write ``ds`` to ``path`` atomically (temporary file, fsync, rename, fsync folder).

    A reader of ``path`` sees the previous file or the new one, never a torn file; a
    writer killed before the rename leaves the old file intact. The netCDF image is
    made in memory first, so HDF5 never meets a full disk (which it survives badly: a
    failed flush inside HDF5 can end the process with a segmentation fault); free space
    is checked before the temporary file is written, and a full disk raises
    ``store.errors.NoSpaceError`` with the previous cube untouched. Temporary files of
    dead writers in the same folder are removed first. Returns ``path``.
    """
    path = Path(path)
    _check_layout(ds, f"publish({path})")
    out = ds.copy(deep=False)
    for var in out.variables.values():
        var.encoding = {}  # drop encodings read from an earlier file (source, chunks)
    if path.parent.exists():
        remove_stale_temps(path.parent)
    with _local_writes():
        image = out.to_netcdf(engine="h5netcdf", encoding=_encoding(out))
    return atomic_write(path, image)


def _local_writes():
    """xarray takes a dask.distributed lock for every netCDF write while a distributed
    ``Client`` is dask's default scheduler (a user's ``Client(cluster)`` is), and for an
    in-memory image that lock fails ("Semaphore or Lock ... not known"). A cube is
    numpy-backed, so dask's synchronous scheduler is right. ``store`` never imports dask:
    this only configures it when something else already has."""
    dask = sys.modules.get("dask")
    return dask.config.set(scheduler="synchronous") if dask is not None else nullcontext()


def cube_bytes(ds: xr.Dataset) -> int:
    """A generous size of ``ds`` as a published file: its values uncompressed plus
    HDF5's metadata (for free-space checks before a run)."""
    return int(sum(v.nbytes for v in ds.variables.values())) + 64 * 1024 + 2048 * len(ds.variables)


class CubeError(StoreError, ValueError):
    """A cube file that cannot be read; the message says how to repair it."""


def open_cube(path) -> xr.Dataset:
    """Read a cube fully into memory and close the file (read-only; works on a read-only
    store).

    Raises
    ------
    FileNotFoundError
        If there is no file at ``path``.
    CubeError
        (a ``ValueError``) if the file is unreadable or not a ditherlab cube (dims other
        than ``AXES``, no ``status``); the message names the command that republishes
        it from the sweep's journal.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no cube at {path}; has the sweep been published yet?")
    try:
        with xr.open_dataset(path, engine="h5netcdf", decode_timedelta=False) as f:
            ds = f.load()
        _check_layout(ds, f"open_cube({path})")
    except (OSError, KeyError, ValueError, RuntimeError) as err:  # h5py: a torn file raises
        spec = path.parent / SPEC_NAME
        how = (f" (ditherlab submit {spec} --store {path.parent.parent})"
               if spec.exists() else "")
        text = f"{type(err).__name__}: {err}".replace("\n", " ")
        raise CubeError(
            f"the cube at {path} is unreadable ({text[:160]}); submit the spec again{how} "
            "to republish it from the journal"
        ) from err
    return ds


def disagreement(path, ds: xr.Dataset) -> str | None:
    """``None`` if the published cube at ``path`` holds exactly ``ds`` (every variable
    and coordinate, and ``ds``'s attributes but ``created``; attributes only the file has
    are kept), else why not, in a few words."""
    try:
        pub = open_cube(path)
    except FileNotFoundError:
        return "the cube is missing"
    except CubeError as err:
        return f"the cube is unreadable ({err.__cause__})"
    if set(pub.variables) != set(ds.variables):
        return "the cube has other variables than the journal's"
    for name, var in ds.variables.items():
        if not var.equals(pub.variables[name]):
            return f"the cube's {name} differs from the journal's"
    keys = [k for k in ds.attrs if k != A.CREATED]
    attrs = [A.canonical_json(A.encode({k: d.attrs.get(k) for k in keys})) for d in (ds, pub)]
    if attrs[0] != attrs[1]:
        return "the cube's attributes differ from the journal's"
    return None
