"""Questions asked of a cube: zone maps, stability charts, friction curves, tables.

Every function takes a cube (``xarray.Dataset`` with dims ``AXES``) and an optional
``sel``: a dict ``axis -> value`` picking the nearest grid value of that axis
(``{"v_d": 0.1}``; strings such as ``"0.1"`` from a command line are accepted).
A value beyond either end of the grid by more than half the end step (a relative
1e-9 on a one-value axis) is refused, so asking for ``v_d = 0.01`` of a cube that
holds only ``v_d = 0.1`` is an error, not a silent substitution. Points whose ``status`` is not ok come out as NaN (or ``NO_DATA``).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd
import xarray as xr

from .cube import AXES, OK, output_names

NO_DATA, STABLE, PU, SU = -1, 0, 1, 2
STABILITY_MEANINGS = "no_data stable primary_unstable secondary_unstable"


def _nearest(ds: xr.Dataset, axis: str, value) -> int:
    """Position of the grid value of ``axis`` nearest to ``value``."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"sel[{axis!r}]: expected a number, got {value!r}") from None
    grid = ds[axis].values
    ordered = np.sort(grid)
    i = int(np.argmin(np.abs(grid - x)))
    if grid.size == 1:
        tolerance = 1e-9 * max(1.0, abs(x))
    else:  # beyond an end of the grid: half of the step at that end
        tolerance = 0.5 * (ordered[1] - ordered[0] if x < ordered[0] else ordered[-1] - ordered[-2])
    if abs(grid[i] - x) > tolerance and not ordered[0] < x < ordered[-1]:
        raise ValueError(
            f"sel[{axis!r}] = {x:g} is off the grid; available {axis} values: {_show(grid)}"
        )
    return i


def _show(values: np.ndarray, limit: int = 12) -> str:
    text = [f"{v:g}" for v in values]
    if len(text) > limit:
        text = text[: limit // 2] + ["..."] + text[-limit // 2 :]
    return "[" + ", ".join(text) + "]"


def select(ds: xr.Dataset, sel: Mapping[str, object] | None = None) -> xr.Dataset:
    """``ds`` with each axis of ``sel`` fixed at its nearest grid value (kept as a
    length-1 axis, so the result is still a cube)."""
    sel = dict(sel or {})
    unknown = sorted(set(sel) - set(AXES))
    if unknown:
        raise ValueError(f"sel: unknown axis {unknown}; axes are {AXES}")
    picks = {axis: [_nearest(ds, axis, value)] for axis, value in sel.items()}
    return ds.isel(picks) if picks else ds


def _variable(ds: xr.Dataset, var: str, what: str) -> None:
    if var not in output_names(ds):
        raise ValueError(f"{what}: the cube has no variable {var!r}; available: {output_names(ds)}")


def plane(
    ds: xr.Dataset, var: str, dims: tuple[str, str], sel=None, what: str = "query"
) -> xr.DataArray:
    """Variable ``var`` over the two axes ``dims`` (in that order), NaN where status != 0.

    Every other axis must have one value after ``sel``; otherwise a ``ValueError``
    names the axis, its values and how to choose one.
    """
    _variable(ds, var, what)
    sub = select(ds, sel)
    for axis in AXES:
        if axis not in dims and sub.sizes[axis] > 1:
            raise ValueError(
                f"{what}: axis {axis!r} has {sub.sizes[axis]} values {_show(sub[axis].values)}; "
                f"choose one with sel={{'{axis}': value}} (--sel {axis}=VALUE)"
            )
    squeeze = {a: 0 for a in AXES if a not in dims}
    sub = sub.isel(squeeze).transpose(*dims)
    return sub[var].where(sub["status"] == OK)


def zone_map(
    ds: xr.Dataset, var: str = "long_stick_fraction", threshold: float = 0.0, sel=None
) -> xr.DataArray:
    """Where long-duration stick-slip is present (Fig. 14): 1 if ``var > threshold``, else 0.

    Returns
    -------
    xarray.DataArray
        float64 over ``("W", "omega")``: 1.0 stick-slip, 0.0 none, NaN not computed
        or failed. ``threshold`` and ``var`` are recorded in the attributes.
    """
    values = plane(ds, var, ("W", "omega"), sel, "zone_map")
    zone = values.copy(data=np.where(values.isnull(), np.nan, (values > threshold).astype(float)))
    zone.attrs = {
        "long_name": f"long-duration stick-slip present (1) or absent (0): {var} > {threshold:g}",
        "units": "1",
        "source_variable": var,
        "threshold": float(threshold),
    }
    return zone.rename("stick_slip_zone")


def _stability_source(ds: xr.Dataset) -> str:
    for name in ("stable", "max_real_eig"):
        if name in output_names(ds):
            return name
    raise ValueError(
        f"stability_chart: needs the output 'stable' or 'max_real_eig' (method = 'averaged'); "
        f"the cube has {output_names(ds)}"
    )


def stability_chart(ds: xr.Dataset, sel=None) -> xr.DataArray:
    """Stable / primary unstable (PU) / secondary unstable (SU) labels (Fig. 9).

    At each ``v_ref``, an unstable point is PU when every point from the smallest
    ``W`` (W = 0 on the paper's charts) up to it is unstable, and SU when a stable
    point lies between; a missing point (status != 0) also breaks the connection.

    Returns
    -------
    xarray.DataArray
        int8 over ``("v_ref", "W")`` (W ascending): ``STABLE`` 0, ``PU`` 1, ``SU`` 2,
        ``NO_DATA`` -1; a CF flag variable (``flag_values``, ``flag_meanings``).
    """
    source = _stability_source(ds)
    values = plane(ds, source, ("v_ref", "W"), sel, "stability_chart").sortby("W")
    valid = values.notnull()
    unstable = ((values == 0) if source == "stable" else (values > 0)) & valid
    primary = np.logical_and.accumulate(unstable.values, axis=1)
    labels = np.where(
        ~valid.values, NO_DATA, np.where(primary, PU, np.where(unstable.values, SU, STABLE))
    )
    chart = xr.DataArray(
        labels.astype(np.int8), coords=valid.coords, dims=valid.dims, name="stability"
    )
    chart.attrs = {
        "long_name": "stability of the averaged equilibrium",
        "source_variable": source,
        "flag_values": np.array([NO_DATA, STABLE, PU, SU], dtype=np.int8),
        "flag_meanings": STABILITY_MEANINGS,
    }
    return chart


def effective_friction_curve(ds: xr.Dataset, sel=None, var: str | None = None) -> xr.DataArray:
    """Effective friction against slip velocity, one curve per ``W`` (Figs. 5, 13).

    ``var`` defaults to ``F_eff`` (averaged cubes) or else ``F_mean`` (simulated and
    harmonic-balance cubes). Returns float64 over ``("W", "v_ref")``, NaN where not ok.
    """
    if var is None:
        candidates = [v for v in ("F_eff", "F_mean") if v in output_names(ds)]
        if not candidates:
            raise ValueError(
                f"effective_friction_curve: needs 'F_eff' or 'F_mean'; the cube has {output_names(ds)}"
            )
        var = candidates[0]
    return plane(ds, var, ("W", "v_ref"), sel, "effective_friction_curve")


def table(ds: xr.Dataset, var: str | None = None, sel=None) -> pd.DataFrame:
    """One row per grid point: the four axes, the output(s) and ``status``.

    ``var`` picks one output (default: all). Rows come in the cube's C order.
    """
    names = output_names(ds) if var is None else [var]
    for name in names:
        _variable(ds, name, "table")
    sub = select(ds, sel)[names + ["status"]]
    frame = sub.to_dataframe().reset_index()
    return frame[list(AXES) + names + ["status"]]
