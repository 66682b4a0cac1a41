"""The result cube of a sweep (DESIGN.md §4): build it, fill it, publish it, open it.

A cube is an ``xarray.Dataset`` with dims and coordinates exactly ``AXES`` =
``("W", "omega", "v_ref", "v_d")`` (length 1 where an axis is not swept) and:

- one float64 variable per requested output (NaN until computed);
- ``status`` int8, a CF flag variable: 0 ok, 1 not yet computed, 2 failed, 3 non-finite
  (the codes of ``engine.status``, repeated here because ``store`` never imports
  ``engine``; a test checks they agree);
- ``cost_s`` float64 seconds, ``steps`` and ``evals`` int64 per point.

Points are addressed by a *flat index* in C order over ``AXES``
(``np.ravel_multi_index((iW, iomega, iv_ref, iv_d), shape)``); ``grid_points`` turns
flat indices into ``(n, 4)`` parameter rows in the column order of ``AXES``.

On disk it is one HDF5/netCDF4 file written by ``publish`` (zlib, atomic rename) and
readable with ``xarray.open_dataset(path, engine="h5netcdf")``.
"""

from __future__ import annotations

import importlib.metadata
import sys
from collections.abc import Mapping
from contextlib import nullcontext
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import xarray as xr

from . import attrs as A
from .layout import SPEC_NAME, StoreError, atomic_write, remove_stale_temps
from .status import FAILED, NON_FINITE, NOT_COMPUTED, OK, STATUS_MEANINGS  # noqa: F401

AXES = ("W", "omega", "v_ref", "v_d")
AXIS_META = {  # axis -> (long_name, default units); the contact system overrides units
    "W": ("dither velocity amplitude", "1"),
    "omega": ("dither angular frequency, rad per unit of the non-dimensional time tau", "1"),
    "v_ref": ("reference (slip) velocity", "1"),
    "v_d": ("bristle-damping characteristic velocity vd", "1"),
}
BOOKKEEPING = {  # name -> (dtype, initial value, long_name, units)
    "status": (np.int8, NOT_COMPUTED, "point status", None),
    "cost_s": (np.float64, 0.0, "wall-clock cost of the point", "s"),
    "steps": (np.int64, 0, "accepted integrator steps", "1"),
    "evals": (np.int64, 0, "right-hand-side evaluations", "1"),
}
# refined sweeps (sweeps.refine): per point, computed or inferred from computed neighbours
PROVENANCE = "provenance"
PROVENANCE_MEANINGS = ("computed", "inferred", "not_yet_decided")
RESERVED = frozenset(AXES) | frozenset(BOOKKEEPING) | {"index", PROVENANCE}
COMPRESSION = {"zlib": True, "complevel": 4, "shuffle": True}


def _check_axis(name: str, values) -> np.ndarray:
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(
            f"coords[{name!r}] must be a non-empty 1-D list of numbers, got shape {arr.shape}"
        )
    infinite_limit = name == "omega" and arr.size == 1 and arr[0] == np.inf
    if not (np.all(np.isfinite(arr)) or infinite_limit):
        raise ValueError(f"coords[{name!r}] must be finite (omega may be the single value inf: "
                         f"an averaged theory's limit), got {arr.tolist()}")
    if np.unique(arr).size != arr.size:
        raise ValueError(
            f"coords[{name!r}] has repeated values (drop the duplicates), got {arr.tolist()}"
        )
    return arr


def _axis_coords(coords, axis_units, axis_long_names) -> dict[str, xr.Variable]:
    unknown = set(coords) - set(AXES)
    missing = [a for a in AXES if a not in coords]
    if unknown or missing:
        raise ValueError(
            f"coords must have exactly the axes {AXES}; missing {missing}, unknown {sorted(unknown)}"
        )
    for label, override in (("axis_units", axis_units), ("axis_long_names", axis_long_names)):
        bad = set(override or {}) - set(AXES)
        if bad:
            raise ValueError(f"{label}: unknown axis {sorted(bad)}; axes are {AXES}")
    out = {}
    for a in AXES:
        long_name = (axis_long_names or {}).get(a, AXIS_META[a][0])
        units = (axis_units or {}).get(a, AXIS_META[a][1])
        out[a] = xr.Variable(a, _check_axis(a, coords[a]), {"long_name": long_name, "units": units})
    return out


def _bookkeeping(shape: tuple[int, ...]) -> dict[str, xr.Variable]:
    out = {}
    for name, (dtype, initial, long_name, units) in BOOKKEEPING.items():
        attrs = {"long_name": long_name}
        if name == "status":
            attrs["flag_values"] = np.arange(len(STATUS_MEANINGS), dtype=np.int8)
            attrs["flag_meanings"] = " ".join(STATUS_MEANINGS)
        else:
            attrs["units"] = units
        out[name] = xr.Variable(AXES, np.full(shape, initial, dtype=dtype), attrs)
    return out


def _global_attrs(attrs: Mapping | None) -> dict:
    out = {
        A.CONVENTIONS: "CF-1.8",
        A.CREATED: datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    try:
        out[A.VERSION] = importlib.metadata.version("ditherlab")
    except importlib.metadata.PackageNotFoundError:
        out[A.VERSION] = "unknown"
    out.update(attrs or {})
    return A.encode(out)


def empty_cube(
    coords: Mapping[str, np.ndarray],
    variables: Mapping[str, tuple[str, str]],
    attrs: Mapping | None = None,
    axis_units: Mapping[str, str] | None = None,
    axis_long_names: Mapping[str, str] | None = None,
) -> xr.Dataset:
    """A cube with every point not yet computed: outputs NaN, status 1, costs 0.

    Parameters
    ----------
    coords
        Axis name -> 1-D values without repeats, for each of ``AXES`` (a length-1
        list for an axis that is not swept). Any order is kept as given; queries
        and maps sort where they need to.
    variables
        Output name -> ``(long_name, units)``, e.g. ``engine.outputs.SIMULATE``, or
        ``(long_name, units, (dim, size))`` for an output with one extra trailing
        dimension (e.g. ``alpha_hist`` over ``alpha_bin``: 10 equal bins of [0, 1], whose
        centres become the coordinate).
    attrs
        Global attributes (see ``store.attrs``: ``sweep_id``, ``name``, ``spec``,
        ``engine_settings`` ...). Non-scalars are stored as canonical JSON strings;
        ``created``, ``ditherlab_version`` and ``Conventions`` are added when missing.
    axis_units, axis_long_names
        Per-axis overrides of ``AXIS_META`` (the contact system is SI: ``"m/s"``).

    Returns
    -------
    xarray.Dataset
        In memory, dims ``AXES``; fill it with ``fill`` and write it with ``publish``.
    """
    axes = _axis_coords(coords, axis_units, axis_long_names)
    shape = tuple(axes[a].size for a in AXES)
    data = {}
    for name, meta in variables.items():
        if name in RESERVED:
            raise ValueError(
                f"variables: {name!r} is a reserved name ({sorted(RESERVED)}); rename the output"
            )
        if not (
            isinstance(meta, (tuple, list))
            and len(meta) in (2, 3)
            and all(isinstance(m, str) for m in meta[:2])
        ):
            raise ValueError(
                f"variables[{name!r}] must be (long_name, units) strings, got {meta!r}"
            )
        dims, full = AXES, shape
        if len(meta) == 3:
            dim, size = meta[2]
            dims, full = AXES + (dim,), shape + (int(size),)
            axes[dim] = _bin_coord(dim, int(size))
        data[name] = xr.Variable(
            dims, np.full(full, np.nan), {"long_name": meta[0], "units": meta[1]}
        )
    data.update(_bookkeeping(shape))
    return xr.Dataset(data, coords=axes, attrs=_global_attrs(attrs))


def _bin_coord(dim: str, size: int) -> xr.Variable:
    """Centres of ``size`` equal bins of [0, 1], with their CF cell bounds described."""
    centres = (np.arange(size) + 0.5) / size
    return xr.Variable(dim, centres, {
        "long_name": f"centre of the {dim} (equal bins of [0, 1])", "units": "1",
        "comment": f"bin k covers [k/{size}, (k+1)/{size}); the last bin includes 1",
    })


def output_names(ds: xr.Dataset) -> list[str]:
    """The cube's output variables (every data variable except the bookkeeping ones and
    a refined sweep's ``provenance``)."""
    return [str(v) for v in ds.data_vars if v not in BOOKKEEPING and v != PROVENANCE]


def add_provenance(ds: xr.Dataset) -> None:
    """Give ``ds`` the ``provenance`` flag variable of a refined sweep (int8, CF flags: 0
    computed, 1 inferred, 2 not yet decided), every point not yet decided."""
    ds[PROVENANCE] = xr.Variable(AXES, np.full(shape_of(ds), 2, dtype=np.int8), {
        "long_name": "computed, or inferred from computed neighbours (adaptive refinement)",
        "flag_values": np.arange(len(PROVENANCE_MEANINGS), dtype=np.int8),
        "flag_meanings": " ".join(PROVENANCE_MEANINGS)})


def shape_of(ds: xr.Dataset) -> tuple[int, ...]:
    """Grid shape in ``AXES`` order."""
    return tuple(int(ds.sizes[a]) for a in AXES)


def check_index(ds: xr.Dataset, flat_index) -> np.ndarray:
    """``flat_index`` as a 1-D int64 array, after checking it addresses points of ``ds``."""
    idx = np.asarray(flat_index)
    size = int(np.prod(shape_of(ds)))
    if idx.ndim != 1 or (idx.size and not np.issubdtype(idx.dtype, np.integer)):
        raise ValueError(
            f"flat_index must be a 1-D integer array, got dtype {idx.dtype} shape {idx.shape}"
        )
    if idx.size and (idx.min() < 0 or idx.max() >= size):
        raise ValueError(
            f"flat_index must lie in [0, {size}) for a cube of shape {shape_of(ds)}, "
            f"got range [{idx.min()}, {idx.max()}]"
        )
    return idx.astype(np.int64)


def grid_points(ds: xr.Dataset, flat_index=None) -> np.ndarray:
    """Parameter rows ``(n, 4)`` float64 of the points ``flat_index`` (all by default).

    Columns follow ``AXES`` (the engine's ``POINT_AXES`` order: W, omega, v_ref, vd).
    """
    size = int(np.prod(shape_of(ds)))
    idx = np.arange(size) if flat_index is None else check_index(ds, flat_index)
    multi = np.unravel_index(idx, shape_of(ds))
    return np.column_stack([ds[a].values[m] for a, m in zip(AXES, multi)]).astype(np.float64)


def pending_index(ds: xr.Dataset) -> np.ndarray:
    """Flat indices of the points whose status is not ok (to resume a sweep)."""
    return np.flatnonzero(ds["status"].values.reshape(-1) != OK)


def status_counts(ds: xr.Dataset) -> dict[str, int]:
    """Number of points per status meaning, e.g. ``{"ok": 90, "not_yet_computed": 10, ...}``."""
    counts = np.bincount(
        ds["status"].values.reshape(-1).astype(np.int64), minlength=len(STATUS_MEANINGS)
    )
    return {m: int(c) for m, c in zip(STATUS_MEANINGS, counts)}


def _columns(ds, n, values, status, cost_s, steps, evals) -> dict[str, np.ndarray]:
    outputs = output_names(ds)
    missing, extra = sorted(set(outputs) - set(values)), sorted(set(values) - set(outputs))
    if missing or extra:
        raise ValueError(
            f"fill: values must have exactly the cube's outputs {outputs}; missing {missing}, unknown {extra}"
        )
    columns = {**values, "status": status, "cost_s": cost_s, "steps": steps, "evals": evals}
    columns = {k: np.asarray(v) for k, v in columns.items()}
    for name, col in columns.items():
        expected = (n,) + tuple(ds[name].shape[len(AXES):])
        if col.shape != expected:
            raise ValueError(f"fill: {name} has shape {col.shape}, expected {expected} "
                             "like flat_index")
    bad = ~np.isin(columns["status"], np.arange(len(STATUS_MEANINGS)))
    if bad.any():
        raise ValueError(
            f"fill: status codes must be in 0..{len(STATUS_MEANINGS) - 1}, got {np.unique(columns['status'][bad]).tolist()}"
        )
    return columns


def fill(
    ds: xr.Dataset, flat_index, values: Mapping[str, np.ndarray], status, cost_s, steps, evals
) -> None:
    """Write the results of some points into ``ds`` in place.

    Parameters
    ----------
    ds
        A cube from ``empty_cube`` or ``open_cube`` (in memory).
    flat_index
        ``(n,)`` int, C-order flat indices over ``AXES``.
    values
        Output name -> ``(n,)`` float; exactly the cube's outputs.
    status
        ``(n,)`` int codes 0..3; ``cost_s`` ``(n,)`` seconds; ``steps``, ``evals`` ``(n,)`` int.

    Everything is checked before anything is written, so a refused call leaves ``ds``
    unchanged.
    """
    idx = check_index(ds, flat_index)
    columns = _columns(ds, idx.size, values, status, cost_s, steps, evals)
    for name, col in columns.items():
        var = ds.variables[name]
        var.load()  # numpy-backed from here on, so writes go into the dataset itself
        flat = var.data.reshape((-1,) + var.shape[len(AXES):])   # a view: points first
        flat[idx] = col


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
    ``store.layout.NoSpaceError`` with the previous cube untouched. Temporary files of
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
