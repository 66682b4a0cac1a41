"""A cube as a file: :func:`publish` (atomic: a temporary file with its space reserved,
written by store.netcdf_write, fsync, rename), :func:`open_cube` (an ``xarray.Dataset``
fully in memory, a :class:`CubeError` that says how to repair an unreadable file),
:func:`read_cube` (the same file as a :class:`store.cubedata.Cube`, without xarray),
:func:`disagreement` between a published cube and one in memory, and :func:`cube_bytes`
for space checks.

The writer and :func:`read_cube` use h5netcdf directly: the file is what xarray's
``to_netcdf(engine="h5netcdf")`` wrote before (tests/test_cf.py checks it against CF-1.8):
float variables and coordinates carry ``_FillValue = NaN``, integer ones none (with a
fill value xarray would decode int8 flags as float, pydata/xarray#1576), data variables
zlib level 1 with shuffle (HDF5's own chunks, filtered in threads by store.netcdf_write).
Level 1 rather than 4: a publish is all compression, and level 1 is 1.4x faster on a real
cube for 2 % more bytes (on noise-like values the same speed and size; docs/BATCH.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import attrs as A
from .atomic import atomic_write, remove_stale_temps
from .cube import AXES
from .cubedata import Cube, Variable
from .errors import StoreError, ensure_space
from .layout import SPEC_NAME
from .netcdf_write import space_bound, write_netcdf


def _check_layout(ds, where: str) -> None:
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


def publish(ds, path) -> Path:
    """Write the cube ``ds`` (a :class:`Cube`, or an ``xarray.Dataset``) to ``path``
    atomically (temporary file, fsync, rename, fsync folder).

    A reader of ``path`` sees the previous file or the new one, never a torn file; a
    writer killed before the rename leaves the old file intact. The temporary file's
    space is reserved before HDF5 writes it, so HDF5 never meets a full disk (which it
    survives badly: a write failing inside HDF5 ends the process with a segmentation
    fault; store.netcdf_write); a disk without that space raises
    ``store.errors.NoSpaceError`` with the previous cube untouched. Temporary files of
    dead writers in the same folder are removed first. Returns ``path``.
    """
    path = Path(path)
    cube = ds if isinstance(ds, Cube) else Cube.from_dataset(ds)
    _check_layout(cube, f"publish({path})")
    if path.parent.exists():
        remove_stale_temps(path.parent)
    ensure_space(path, space_bound(cube))   # (the numbers for the message; reserve() is the guard)
    return atomic_write(path, lambda tmp: write_netcdf(cube, tmp))


def cube_bytes(ds) -> int:
    """The most bytes ``ds`` can take as a published file (for free-space checks before
    a run): ``store.netcdf_write.space_bound``, the space a publish reserves."""
    return space_bound(ds if isinstance(ds, Cube) else Cube.from_dataset(ds))


class CubeError(StoreError, ValueError):
    """A cube file that cannot be read; the message says how to repair it."""


def open_cube(path):
    """Read a cube fully into memory as an ``xarray.Dataset`` and close the file
    (read-only; works on a read-only store).

    Raises
    ------
    FileNotFoundError
        If there is no file at ``path``.
    CubeError
        (a ``ValueError``) if the file is unreadable or not a ditherlab cube (dims other
        than ``AXES``, no ``status``); the message names the command that republishes
        it from the sweep's journal.
    """
    import xarray as xr

    path = _existing(path)
    try:
        with xr.open_dataset(path, engine="h5netcdf", decode_timedelta=False) as f:
            ds = f.load()
        _check_layout(ds, f"open_cube({path})")
    except READ_ERRORS as err:
        raise unreadable(path, err) from err
    return ds


def read_cube(path) -> Cube:
    """The cube at ``path`` as written (:class:`Cube`, h5netcdf alone, no decoding but
    the fill value dropped from the attributes); errors as :func:`open_cube`."""
    import h5netcdf

    path = _existing(path)
    try:
        with h5netcdf.File(path, "r") as f:
            def var(v) -> Variable:
                return Variable(v.dimensions, v[...],
                                {k: x for k, x in v.attrs.items() if k != "_FillValue"})

            coords = {d: var(f.variables[d]) for d in f.dimensions}
            cube = Cube(coords, {k: var(v) for k, v in f.variables.items() if k not in coords},
                        dict(f.attrs))
        _check_layout(cube, f"read_cube({path})")
    except READ_ERRORS as err:
        raise unreadable(path, err) from err
    return cube


READ_ERRORS = (OSError, KeyError, ValueError, RuntimeError)   # h5py: a torn file raises


def _existing(path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no cube at {path}; has the sweep been published yet?")
    return path


def unreadable(path: Path, err: Exception) -> CubeError:
    """The CubeError of a cube file that ``err`` (one of :data:`READ_ERRORS`) kept from
    being read: what went wrong, and the command that republishes it."""
    text = f"{type(err).__name__}: {err}".replace("\n", " ")
    return CubeError(f"the cube at {path} is unreadable ({text[:160]}); {republish_hint(path)}")


def republish_hint(path: Path) -> str:
    """How to rebuild the cube at ``path`` from its sweep's journal, in a few words."""
    spec = Path(path).parent / SPEC_NAME
    how = f" (ditherlab submit {spec} --store {spec.parent.parent})" if spec.exists() else ""
    return f"submit the spec again{how} to republish it from the journal"


def disagreement(path, ds, ignore: tuple[str, ...] = ()) -> str | None:
    """``None`` if the published cube at ``path`` holds exactly ``ds`` (every variable
    and coordinate, and ``ds``'s attributes but ``created`` and those in ``ignore``;
    attributes only the file has are kept), else why not, in a few words."""
    try:
        pub = read_cube(path)
    except FileNotFoundError:
        return "the cube is missing"
    except CubeError as err:
        return f"the cube is unreadable ({err.__cause__})"
    ds = ds if isinstance(ds, Cube) else Cube.from_dataset(ds)
    if set(pub.variables) != set(ds.variables):
        return "the cube has other variables than the journal's"
    for name, var in ds.variables.items():
        if not var.equals(pub.variables[name]):
            return f"the cube's {name} differs from the journal's"
    keys = [k for k in ds.attrs if k != A.CREATED and k not in ignore]
    attrs = [A.canonical_json(A.encode({k: d.attrs.get(k) for k in keys})) for d in (ds, pub)]
    if attrs[0] != attrs[1]:
        return "the cube's attributes differ from the journal's"
    return None
