"""A cube's global attributes, read without xarray (``ditherlab status SWEEP`` starts in a
fraction of a second: h5py alone, no xarray, pandas or dask)."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace


def read_header(path) -> SimpleNamespace:
    """An object with the cube's global attributes as ``.attrs`` (str values decoded), as a
    stand-in for the dataset where only its attributes are read. Raises ``OSError`` for an
    unreadable file."""
    import h5py

    with h5py.File(Path(path), "r") as f:
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()
                 if not k.startswith("_")}
    return SimpleNamespace(attrs=attrs)
