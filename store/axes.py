"""Axes and files of the maps: the file format a name asks for, cell edges around grid
values (geometric on a log-spaced axis), and axis labels from the cube's CF attributes."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

SYMBOLS = {"W": r"$W$", "omega": r"$\omega$", "v_ref": r"$v_\mathrm{ref}$", "v_d": r"$v_d$"}

FIGURE_FORMATS = ("png", "pdf", "svg")


def figure_format(path) -> str:
    """The format ``path``'s suffix asks for, after checking it and its folder.

    Raises ``ValueError`` (one line: what to do) for another suffix or a missing folder:
    a figure is never written in a format its name does not say, nor into a folder the
    user did not make.
    """
    path = Path(path)
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in FIGURE_FORMATS:
        raise ValueError(f"cannot write {path}: the file name must end in "
                         f"{', '.join('.' + f for f in FIGURE_FORMATS)} (got {path.suffix or 'none'})")
    folder = path.parent
    above = next((a for a in (folder, *folder.parents) if a.exists()), None)
    if above is not None and not above.is_dir():
        raise ValueError(f"cannot write {path}: {above} is a file, not a folder")
    if not folder.is_dir():
        raise ValueError(f"cannot write {path}: the folder {folder} does not exist "
                         f"(create it first: mkdir -p {folder})")
    if path.is_dir():
        raise ValueError(f"cannot write {path}: it is a folder; name a file")
    return fmt


def is_log_spaced(values: np.ndarray) -> bool:
    """True for >= 3 positive values with a constant ratio and no constant step."""
    v = np.sort(np.asarray(values, dtype=float))
    if v.size < 3 or v[0] <= 0:
        return False
    step, ratio = np.diff(v), np.diff(np.log(v))
    return bool(
        np.allclose(ratio, ratio[0], rtol=1e-3) and not np.allclose(step, step[0], rtol=1e-3)
    )


def cell_edges(values: np.ndarray, log: bool) -> np.ndarray:
    """Cell edges around sorted grid values (midpoints; geometric ones on a log axis)."""
    v = np.log(values) if log else np.asarray(values, dtype=float)
    if v.size == 1:
        half = 0.5 * max(abs(v[0]), 1.0) if not log else 0.5
        edges = np.array([v[0] - half, v[0] + half])
    else:
        mid = 0.5 * (v[1:] + v[:-1])
        edges = np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])
    return np.exp(edges) if log else edges


# what a non-dimensional quantity is measured in, as its long_name says after a comma
# (CF units are "1": store.cube), in the short form an axis label has room for
MEASURED_IN = {"rad per unit of the non-dimensional time tau": r"[rad per unit $\tau$]",
               "in units of the non-dimensional time tau": r"[$\tau$]"}


def axis_label(coord: xr.DataArray) -> str:
    """``"<symbol>  <long_name> [units]"`` ("non-dimensional" for units "1"; a long_name's
    ", rad per unit of the non-dimensional time tau" becomes the unit)."""
    name = str(coord.name)
    units = coord.attrs.get("units", "")
    unit_text = "(non-dimensional)" if units in ("1", "") else f"[{units}]"
    long_name = coord.attrs.get("long_name", name)
    head, _, tail = long_name.partition(", ")
    if tail in MEASURED_IN:
        long_name, unit_text = head, MEASURED_IN[tail]
    return f"{SYMBOLS.get(name, name)}  {long_name} {unit_text}"
