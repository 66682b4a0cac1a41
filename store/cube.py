"""The result cube of a sweep (DESIGN.md §4): build it, fill it, publish it, open it.

A cube is a :class:`store.cubedata.Cube` (the netCDF data model in numpy; readers get an
``xarray.Dataset`` from ``store.open_cube``) with dims and coordinates exactly ``AXES`` =
``("W", "omega", "v_ref", "v_d")`` (length 1 where an axis is not swept) and:

- one float64 variable per requested output (NaN until computed);
- ``status`` int8, a CF flag variable: 0 ok, 1 not yet computed, 2 failed, 3 non-finite
  (the codes of ``engine.status``, repeated here because ``store`` never imports
  ``engine``; a test checks they agree);
- ``cost_s`` float64 seconds, ``steps`` and ``evals`` int64 per point.

Points are addressed by a *flat index* in C order over ``AXES``
(``np.ravel_multi_index((iW, iomega, iv_ref, iv_d), shape)``).

On disk it is one HDF5/netCDF4 file written by ``publish`` (zlib, atomic rename) and
readable with ``xarray.open_dataset(path, engine="h5netcdf")``.

This module holds the layout (axes, bookkeeping variables, attributes) and builds an empty
cube; addressing and filling points is :mod:`store.points`, publishing and opening the
file :mod:`store.cube_io`.
"""

from __future__ import annotations

import importlib.metadata
from collections.abc import Mapping
from datetime import datetime, timezone

import numpy as np

from . import attrs as A
from .cubedata import Cube, Variable
from .flags import FAILED, NON_FINITE, NOT_COMPUTED, OK, STATUS_MEANINGS  # noqa: F401
from .flags import COMPUTED, INFERRED, PROVENANCE_MEANINGS, UNDECIDED  # noqa: F401

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
# refined sweeps (sweeps.planning.refine): per point, computed or inferred from computed neighbours
PROVENANCE = "provenance"   # its codes: store.flags (COMPUTED, INFERRED, UNDECIDED)
RESERVED = frozenset(AXES) | frozenset(BOOKKEEPING) | {"index", PROVENANCE}


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


def _axis_coords(coords, axis_units, axis_long_names) -> dict[str, Variable]:
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
        out[a] = Variable(a, _check_axis(a, coords[a]), {"long_name": long_name, "units": units})
    return out


def _bookkeeping(shape: tuple[int, ...]) -> dict[str, Variable]:
    out = {}
    for name, (dtype, initial, long_name, units) in BOOKKEEPING.items():
        attrs = {"long_name": long_name}
        if name == "status":
            attrs["flag_values"] = np.arange(len(STATUS_MEANINGS), dtype=np.int8)
            attrs["flag_meanings"] = " ".join(STATUS_MEANINGS)
        else:
            attrs["units"] = units
        out[name] = Variable(AXES, np.full(shape, initial, dtype=dtype), attrs)
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
) -> Cube:
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
    Cube
        In memory, dims ``AXES``; fill it with ``fill`` and write it with ``publish``
        (``.to_dataset()`` for an ``xarray.Dataset``).
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
        data[name] = Variable(
            dims, np.full(full, np.nan), {"long_name": meta[0], "units": meta[1]}
        )
    data.update(_bookkeeping(shape))
    return Cube(axes, data, _global_attrs(attrs))


def _bin_coord(dim: str, size: int) -> Variable:
    """Centres of ``size`` equal bins of [0, 1], with their CF cell bounds described."""
    centres = (np.arange(size) + 0.5) / size
    return Variable(dim, centres, {
        "long_name": f"centre of the {dim} (equal bins of [0, 1])", "units": "1",
        "comment": f"bin k covers [k/{size}, (k+1)/{size}); the last bin includes 1",
    })


def output_names(ds: Cube) -> list[str]:
    """The cube's output variables (every data variable except the bookkeeping ones and
    a refined sweep's ``provenance``)."""
    return [str(v) for v in ds.data_vars if v not in BOOKKEEPING and v != PROVENANCE]


def add_provenance(ds: Cube) -> None:
    """Give ``ds`` the ``provenance`` flag variable of a refined sweep (int8, CF flags:
    store.flags' ``COMPUTED``, ``INFERRED``, ``UNDECIDED``), every point not yet decided."""
    ds[PROVENANCE] = Variable(AXES, np.full(shape_of(ds), UNDECIDED, dtype=np.int8), {
        "long_name": "computed, or inferred from computed neighbours (adaptive refinement)",
        "flag_values": np.arange(len(PROVENANCE_MEANINGS), dtype=np.int8),
        "flag_meanings": " ".join(PROVENANCE_MEANINGS)})


def shape_of(ds: Cube) -> tuple[int, ...]:
    """Grid shape in ``AXES`` order."""
    return tuple(int(ds.sizes[a]) for a in AXES)
