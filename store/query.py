"""Questions asked of a cube: zone maps, stability charts, friction curves, tables.

Every function takes a cube (``xarray.Dataset`` with dims ``AXES``, or a
``store.cubedata.Cube``) and an optional ``sel``: a dict ``axis -> value`` picking the
nearest grid value of that axis (``{"v_d": 0.1}``; strings such as ``"0.1"`` are accepted).
A value beyond either end of the grid by more than half the end step (a relative 1e-9 on
a one-value axis), or NaN, is refused: asking for ``v_d = 0.01`` of a cube that holds only
``v_d = 0.1`` is an error, not a silent substitution. Points whose ``status`` is not ok
come out as NaN (or ``NO_DATA``).

``stability_labels`` is the one implementation of the PU / SU rule of DESIGN.md §1
(connected components in the ``(v_ref, W)`` plane): ``stability_chart`` and the maps use
it, and so do the users of ``engine.analysis.stability_chart`` (the Fig. 9 script, tests),
whose ``unstable`` / ``valid`` arrays it labels (the engine may not import the store).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd
import xarray as xr

from .cube import AXES, OK, PROVENANCE, output_names
from .cubedata import as_dataset

NO_DATA, STABLE, PU, SU = -1, 0, 1, 2
STABILITY_MEANINGS = "no_data stable primary_unstable secondary_unstable"


def _nearest(ds: xr.Dataset, axis: str, value) -> int:
    """Position of the grid value of ``axis`` nearest to ``value``."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"sel[{axis!r}]: expected a number, got {value!r}") from None
    grid = ds[axis].values
    if not np.isfinite(x):   # NaN is off every grid; inf only on an axis holding it (omega)
        if (grid == x).any():
            return int(np.flatnonzero(grid == x)[0])
        raise ValueError(
            f"sel[{axis!r}] = {x:g} is off the grid; available {axis} values: {_show(grid)}"
        )
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
    ds, sel = as_dataset(ds), dict(sel or {})
    unknown = sorted(set(sel) - set(AXES))
    if unknown:
        raise ValueError(f"sel: unknown axis {unknown}; axes are {AXES}")
    picks = {axis: [_nearest(ds, axis, value)] for axis, value in sel.items()}
    return ds.isel(picks) if picks else ds


def _variable(ds: xr.Dataset, var: str, what: str) -> None:
    if var not in output_names(ds) and not (var == PROVENANCE and var in ds):
        raise ValueError(f"{what}: the cube has no variable {var!r}; available: {output_names(ds)}")


def plane(
    ds: xr.Dataset, var: str, dims: tuple[str, str], sel=None, what: str = "query"
) -> xr.DataArray:
    """Variable ``var`` over the two axes ``dims`` (in that order), NaN where status != 0.

    Every other axis must have one value after ``sel``; otherwise a ``ValueError``
    names the axis, its values and how to choose one.
    """
    ds = as_dataset(ds)
    _variable(ds, var, what)
    sub = select(ds, sel)
    for axis in AXES:
        if axis not in dims and sub.sizes[axis] > 1:
            raise ValueError(
                f"{what}: axis {axis!r} has {sub.sizes[axis]} values {_show(sub[axis].values)}; "
                f"choose one with sel={{'{axis}': value}} (--sel {axis}=VALUE)"
            )
    squeeze = {a: 0 for a in AXES if a not in dims}
    sub = sub.isel(squeeze).transpose(*dims, ...)   # a vector output keeps its own dim last
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


def _plane_structure(ndim: int, plane_axes: tuple[int, int]) -> np.ndarray:
    """4-neighbour structuring element of ``scipy.ndimage.label``: neighbours along the two
    ``plane_axes`` only, so components never join across any other axis."""
    structure = np.zeros((3,) * ndim, bool)
    centre = [1] * ndim
    structure[tuple(centre)] = True
    for axis in plane_axes:
        for side in (0, 2):
            at = list(centre)
            at[axis] = side
            structure[tuple(at)] = True
    return structure


def stability_labels(
    unstable, valid=None, *, v_ref_axis: int = 0, w_axis: int = 1, W=None, v_ref=None
) -> np.ndarray:
    """Stable / PU / SU / no-data labels of a stability chart: the one implementation.

    The rule is DESIGN.md §1 ("Labels on a stability chart"), after the paper's Fig. 9:

    - unstable grid points form connected components, 4-neighbour in the ``(v_ref, W)``
      plane (``scipy.ndimage.label``; a diagonal contact does not connect);
    - ``PU`` (primary unstable): an unstable point whose component contains a point at
      the chart's smallest ``W`` (``W = 0`` on the paper's charts);
    - ``SU`` (secondary unstable): an unstable point whose component does not;
    - ``STABLE`` otherwise, and ``NO_DATA`` where ``valid`` is false (not computed,
      failed, NaN): a no-data point is never part of a component, so it can split one.

    A rule applied column by column (at each ``v_ref``, the unbroken run of unstable
    points from the smallest ``W``) is wrong: above ``v_ref = 0.2986`` the undithered
    equilibrium is stable, and the primary zone, which the paper says "extends over the
    whole range of reference velocity" (Sec. 6, Fig. 9), would be cut there and called SU.

    Parameters
    ----------
    unstable : bool array_like, at least 2-D
        True where the averaged equilibrium is unstable.
    valid : bool array_like, optional
        False where there is no data (default: every point valid). Broadcast to
        ``unstable``; an invalid point is labelled ``NO_DATA`` whatever ``unstable`` says.
    v_ref_axis, w_axis : int
        The two axes of the chart plane. Every other axis (omega, v_d, ...) indexes
        independent charts: components never connect across them.
    W, v_ref : 1-D array_like, optional
        Coordinates along ``w_axis`` / ``v_ref_axis``. When given, points are put in
        ascending order before labelling (neighbours are neighbours on the grid) and the
        labels come back in the input order; without them the array is taken as already
        ascending along both axes.

    Returns
    -------
    numpy.ndarray
        int8, the shape of ``unstable``: ``STABLE`` 0, ``PU`` 1, ``SU`` 2, ``NO_DATA`` -1.
    """
    unstable = np.asarray(unstable, bool)
    if unstable.ndim < 2:
        raise ValueError(f"stability_labels: needs a (v_ref, W) plane, got {unstable.shape}")
    valid = np.ones(unstable.shape, bool) if valid is None else np.asarray(valid, bool)
    valid = np.broadcast_to(valid, unstable.shape)
    ndim = unstable.ndim
    if not (-ndim <= v_ref_axis < ndim and -ndim <= w_axis < ndim):
        raise ValueError(f"stability_labels: axes ({v_ref_axis}, {w_axis}) not in a {ndim}-D array")
    v_ref_axis, w_axis = v_ref_axis % ndim, w_axis % ndim
    if v_ref_axis == w_axis:
        raise ValueError("stability_labels: v_ref_axis and w_axis must differ")
    orders = {}
    for axis, coord in ((w_axis, W), (v_ref_axis, v_ref)):
        if coord is not None:
            coord = np.asarray(coord, float)
            if coord.shape != (unstable.shape[axis],):
                raise ValueError(
                    f"stability_labels: coordinate of length {coord.size} for an axis of "
                    f"length {unstable.shape[axis]}"
                )
            orders[axis] = np.argsort(coord, kind="stable")
    for axis, order in orders.items():
        unstable, valid = np.take(unstable, order, axis=axis), np.take(valid, order, axis=axis)
    labels = np.full(unstable.shape, STABLE, np.int8)
    mask = unstable & valid
    if mask.any():
        from scipy import ndimage   # (here: importing it cost a query or map process 0.3 s)
        components, _ = ndimage.label(mask, _plane_structure(mask.ndim, (v_ref_axis, w_axis)))
        at_w_min = np.take(components, 0, axis=w_axis)
        primary = np.isin(components, np.unique(at_w_min[at_w_min > 0]))
        labels[mask] = SU
        labels[primary] = PU
    labels[~valid] = NO_DATA
    for axis, order in orders.items():
        labels = np.take(labels, np.argsort(order), axis=axis)
    return labels


def stability_chart(ds: xr.Dataset, sel=None) -> xr.DataArray:
    """Stable / primary unstable (PU) / secondary unstable (SU) labels (Fig. 9).

    ``sel`` fixes the other axes; ``v_ref`` or ``W`` in it cut the labelled chart.

    A point is unstable where ``stable == 0`` (or, without that output,
    ``max_real_eig > 0``). Labels by connected components, DESIGN.md §1, as computed by
    :func:`stability_labels`: PU = an unstable point whose 4-neighbour component of
    unstable points in the ``(v_ref, W)`` plane reaches the chart's smallest ``W``
    (W = 0 on the paper's charts), so the primary zone "extends over the whole range of
    reference velocity" (paper, Fig. 9) even where it lifts off ``W = 0``; SU = an
    unstable point whose component does not. A missing point (status != 0) is
    ``NO_DATA`` and never joins a component.

    Returns
    -------
    xarray.DataArray
        int8 over ``("v_ref", "W")`` (both ascending): ``STABLE`` 0, ``PU`` 1, ``SU`` 2,
        ``NO_DATA`` -1; a CF flag variable (``flag_values``, ``flag_meanings``).
    """
    source = _stability_source(ds)
    sel = dict(sel or {})
    cut = {axis: sel.pop(axis) for axis in ("v_ref", "W") if axis in sel}
    values = plane(ds, source, ("v_ref", "W"), sel, "stability_chart").sortby(["v_ref", "W"])
    valid = values.notnull()
    unstable = (values == 0) if source == "stable" else (values > 0)
    labels = stability_labels(unstable.values, valid.values, v_ref_axis=0, w_axis=1)
    chart = xr.DataArray(labels, coords=valid.coords, dims=valid.dims, name="stability")
    chart.attrs = {
        "long_name": "stability of the averaged equilibrium",
        "source_variable": source,
        "flag_values": np.array([NO_DATA, STABLE, PU, SU], dtype=np.int8),
        "flag_meanings": STABILITY_MEANINGS,
    }
    # a cut (sel of v_ref or W) is labelled in the whole plane: alone, PU would read SU
    return chart.isel({axis: [_nearest(chart, axis, value)] for axis, value in cut.items()})


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

    ``var`` picks one output (default: every output over the grid axes alone; an output
    with an extra dimension such as ``alpha_hist`` comes only when asked for, one row per
    point and bin, with the bin coordinate as a column). Rows come in the cube's C order.
    """
    ds = as_dataset(ds)
    if var is None:
        names = [n for n in output_names(ds) if ds[n].dims == AXES]
    else:
        names = [var]
    for name in names:
        _variable(ds, name, "table")
    extra = [d for n in names for d in ds[n].dims[len(AXES):]]
    flags = [PROVENANCE] if PROVENANCE in ds and PROVENANCE not in names else []   # refined
    sub = select(ds, sel)[names + ["status"] + flags]
    frame = sub.to_dataframe().reset_index()
    return frame[list(AXES) + extra + names + ["status"] + flags]
