"""A cube in the writing process: numpy arrays with their dims and attributes, the netCDF
data model and nothing more (:class:`Cube`, :class:`Variable`).

The submitting process builds, fills and publishes cubes many times a run; it never needs
xarray's indexing or alignment, and building an ``xarray.Dataset`` costs a fresh process
about a second (xarray and pandas, and dask.array, which xarray imports when it first
wraps an array with dask installed; a netCDF write with xarray also imports
dask.distributed for its lock). So the writer's cube is this plain record, written with
h5netcdf directly (store.cube_io), and readers get an ``xarray.Dataset``
(``store.open_cube``, or :meth:`Cube.to_dataset` for a cube in memory). Indexing reads
like xarray's where the runner needs it: ``cube["status"].values``, ``cube.variables``,
``cube.data_vars``, ``cube.sizes``, ``cube.attrs``.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np


class Variable:
    """One netCDF variable: its dimension names, a numpy array, its attributes."""

    __slots__ = ("dims", "data", "attrs")

    def __init__(self, dims, data, attrs: Mapping | None = None):
        self.dims = (dims,) if isinstance(dims, str) else tuple(dims)
        self.data = np.asarray(data)
        self.attrs = dict(attrs or {})
        if self.data.ndim != len(self.dims):
            raise ValueError(f"a variable over {self.dims} needs {len(self.dims)} dimensions, "
                             f"got an array of shape {self.data.shape}")

    @property
    def values(self) -> np.ndarray:
        return self.data

    @property
    def shape(self) -> tuple[int, ...]:
        return self.data.shape

    @property
    def dtype(self):
        return self.data.dtype

    @property
    def size(self) -> int:
        return self.data.size

    @property
    def nbytes(self) -> int:
        return self.data.nbytes

    def copy(self, deep: bool = True) -> Variable:
        return Variable(self.dims, self.data.copy() if deep else self.data, self.attrs)

    def equals(self, other) -> bool:
        """Same dims and values (NaN equal to NaN); attributes are not compared."""
        data = np.asarray(other.values)
        return tuple(other.dims) == self.dims and data.shape == self.shape and \
            np.array_equal(self.data, data, equal_nan=self.data.dtype.kind == "f"
                           and data.dtype.kind == "f")


class Cube:
    """Coordinates (one 1-D variable per dimension), data variables over them, global
    attributes: what a cube file holds (README "Store layout")."""

    def __init__(self, coords: Mapping[str, Variable], data_vars: Mapping[str, Variable],
                 attrs: Mapping | None = None):
        self.coords, self.data_vars = dict(coords), dict(data_vars)
        self.attrs = dict(attrs or {})
        for name, var in self.data_vars.items():
            unknown = [d for d in var.dims if d not in self.coords]
            if unknown:
                raise ValueError(f"variable {name!r}: dimensions {unknown} have no coordinate")

    @property
    def variables(self) -> dict[str, Variable]:
        return {**self.coords, **self.data_vars}

    @property
    def sizes(self) -> dict[str, int]:
        return {name: var.size for name, var in self.coords.items()}

    dims = sizes

    def __getitem__(self, name: str) -> Variable:
        if name in self.data_vars:
            return self.data_vars[name]
        return self.coords[name]

    def __setitem__(self, name: str, var: Variable) -> None:
        self.data_vars[name] = var

    def __contains__(self, name: object) -> bool:
        return name in self.data_vars or name in self.coords

    def copy(self, deep: bool = True) -> Cube:
        return Cube({k: v.copy(deep) for k, v in self.coords.items()},
                    {k: v.copy(deep) for k, v in self.data_vars.items()}, self.attrs)

    def to_dataset(self):
        """The same cube as an ``xarray.Dataset`` (sharing the arrays), for queries."""
        import xarray as xr

        def var(v: Variable):
            return xr.Variable(v.dims, v.data, v.attrs)

        return xr.Dataset({k: var(v) for k, v in self.data_vars.items()},
                          coords={k: var(v) for k, v in self.coords.items()},
                          attrs=self.attrs)

    @classmethod
    def from_dataset(cls, ds) -> Cube:
        """A cube of any object shaped like a dataset (``xarray.Dataset`` included):
        ``coords``, ``data_vars`` with ``dims``, ``values``, ``attrs``; arrays shared."""
        def var(v) -> Variable:
            return Variable(v.dims, np.asarray(v.values), v.attrs)

        return cls({str(k): var(v) for k, v in ds.coords.items()},
                   {str(k): var(v) for k, v in ds.data_vars.items()}, ds.attrs)


def as_dataset(ds):
    """``ds`` as an ``xarray.Dataset``: a :class:`Cube` is converted, anything else is
    returned as it is (the queries take either)."""
    return ds.to_dataset() if isinstance(ds, Cube) else ds
