"""Figures of a cube in the style of the paper: Fig. 9, Fig. 14, Figs. 5/13.

Drawn with matplotlib's object API on an Agg canvas (no pyplot, no global backend
switch, safe in threads and on machines without a display). Every figure is
``FIGSIZE`` inches at ``DPI`` (980 x 700 pixels for PNG), written atomically in the
format its suffix names (``FIGURE_FORMATS``: png, pdf, svg) into an existing folder.

- ``stability_map``: v_ref on x, W on y; PU and SU shaded, their boundaries drawn
  solid (PU) and dashed (SU) as in Fig. 9, and the line W = v_ref. The labels are
  ``query.stability_chart``'s (connected components, ``query.stability_labels``,
  DESIGN.md §1): the primary zone is one PU area wherever it lifts off W = 0.
- ``stick_slip_map``: omega on x (log if the grid is log-spaced), W on y; the
  long-duration stick-slip zone of Fig. 14 shaded and outlined.
- ``friction_curves``: effective friction against v_ref, one line per W.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import BoundaryNorm, ListedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from . import attrs as A
from .axes import axis_label, cell_edges, figure_format, is_log_spaced
from .cubedata import as_dataset
from .flags import COMPUTED
from .layout import atomic_write
from .query import (
    NO_DATA,
    PU,
    STABLE,
    SU,
    effective_friction_curve,
    plane,
    stability_chart,
    zone_map,
)

FIGSIZE = (7.0, 5.0)
DPI = 140
NO_DATA_COLOUR = "#c8c8c8"
STABILITY_COLOURS = {NO_DATA: NO_DATA_COLOUR, STABLE: "#ffffff", PU: "#e4572e", SU: "#4c72b0"}
STABILITY_NAMES = {
    NO_DATA: "not computed / failed",
    STABLE: "stable",
    PU: "primary unstable (PU)",
    SU: "secondary unstable (SU)",
}
ZONE_COLOURS = {0.0: "#ffffff", 1.0: "#f2a541"}


# Fixed margins (fractions of the figure), room for a two-line title on top and the legend
# or colour bar on the right: a layout engine ("tight", "constrained") measures every tick
# label and draws the figure twice, which was 60 % of a map's drawing time (issue 28).
MARGINS = {"left": 0.095, "right": 0.70, "bottom": 0.105, "top": 0.885}


def _figure() -> tuple[Figure, object]:
    fig = Figure(figsize=FIGSIZE, dpi=DPI)
    FigureCanvasAgg(fig)
    fig.subplots_adjust(**MARGINS)
    ax = fig.add_subplot()
    ax.grid(True, color="0.85", linewidth=0.6)
    ax.set_axisbelow(True)
    return fig, ax


def warm() -> None:
    """Load what a first map needs (matplotlib's Agg, fonts, mathtext) by drawing a figure
    into memory: a process that draws on demand (the web view's) calls it at start."""
    import io

    fig, ax = _figure()
    ax.set_xlabel(r"$v_\mathrm{ref}$ x")
    fig.savefig(io.BytesIO(), format="png")


def _grid_on_top(ax) -> None:
    """Light grid lines drawn over a shaded map (they would vanish below it)."""
    ax.set_axisbelow(False)
    ax.grid(True, color="0.25", alpha=0.18, linewidth=0.6)


def _save(fig: Figure, path) -> Path:
    fmt = figure_format(path)
    return atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format=fmt, dpi=DPI))


def _title(ds: xr.Dataset, what: str, da: xr.DataArray, title: str | None) -> str:
    if title is not None:
        return title
    sweep = ds.attrs.get(A.NAME) or "cube"
    sweep_id = str(ds.attrs.get(A.SWEEP_ID, ""))[:10]
    # the averaged theory is the omega -> infinity limit: its omega coordinate means nothing
    hidden = {"omega"} if ds.attrs.get("path") == "averaged" else set()
    fixed = ", ".join(
        f"{k} = {float(c):g}" for k, c in da.coords.items() if c.ndim == 0 and k not in hidden
    )
    if hidden:
        fixed = ", ".join(filter(None, [fixed, "averaged (omega -> infinity)"]))
    head = f"{what}: {sweep}" + (f" ({sweep_id})" if sweep_id else "")
    return head + (f"\n{fixed}" if fixed else "")


def _shade(ax, da: xr.DataArray, colours: dict, x: str, y: str) -> tuple[bool, bool]:
    """pcolormesh of the 2-D label array ``da`` (dims y, x); returns the log flags."""
    da = da.sortby(x).sortby(y).transpose(y, x)
    logx, logy = is_log_spaced(da[x].values), is_log_spaced(da[y].values)
    colours = {NO_DATA: NO_DATA_COLOUR, **colours}
    keys = sorted(colours)
    bounds = [keys[0] - 0.5] + [k + 0.5 for k in keys]
    values = np.where(np.isnan(da.values.astype(float)), NO_DATA, da.values)
    ax.pcolormesh(
        cell_edges(da[x].values, logx),
        cell_edges(da[y].values, logy),
        values,
        cmap=ListedColormap([colours[k] for k in keys]),
        norm=BoundaryNorm(bounds, len(keys)),
        shading="flat",
    )
    ax.set_xscale("log" if logx else "linear")
    ax.set_yscale("log" if logy else "linear")
    ax.set_xlabel(axis_label(da[x]))
    ax.set_ylabel(axis_label(da[y]))
    _grid_on_top(ax)
    return logx, logy


def _fine(centres: np.ndarray, log: bool) -> np.ndarray:
    """Two sample points just inside each cell's edges, so a contour of a
    cell-replicated mask at 0.5 runs exactly along the cell edges of ``_shade``."""
    edges = cell_edges(centres, log)
    pad = 1e-4 * np.diff(edges)
    return np.column_stack([edges[:-1] + pad, edges[1:] - pad]).reshape(-1)


def _outline(ax, mask: xr.DataArray, x: str, y: str, style: str) -> None:
    """Draw the boundary of the cells where ``mask`` (bool, dims y/x) is true."""
    mask = mask.sortby(x).sortby(y).transpose(y, x)
    if not mask.values.any() or mask.values.all():
        return
    fine = np.repeat(np.repeat(mask.values.astype(float), 2, axis=0), 2, axis=1)
    xs = _fine(mask[x].values, is_log_spaced(mask[x].values))
    ys = _fine(mask[y].values, is_log_spaced(mask[y].values))
    ax.contour(xs, ys, fine, levels=[0.5], colors="k", linewidths=1.2, linestyles=style)


def _mark_computed(ax, ds: xr.Dataset, sel, x: str, y: str) -> list:
    """A refined sweep's computed points as small dots (the rest were inferred); the
    legend handle, or nothing for an exhaustive sweep."""
    if "provenance" not in ds:
        return []
    flags = plane(ds, "provenance", (y, x), sel, "map")
    yy, xx = np.nonzero(flags.values == COMPUTED)
    n, total = len(xx), flags.size
    return ax.plot(flags[x].values[xx], flags[y].values[yy], linestyle="none", marker=".",
                   markersize=2.0, color="0.15", alpha=0.6,
                   label=f"computed ({n} of {total};\nothers inferred)")


def stability_map(ds: xr.Dataset, path, sel=None, title: str | None = None) -> Path:
    """Fig. 9-style stability chart of an averaged cube, written to ``path`` (PNG).

    ``sel`` fixes the axes other than v_ref and W (e.g. ``{"v_d": 0.1}``).
    """
    ds = as_dataset(ds)
    chart = stability_chart(ds, sel)
    fig, ax = _figure()
    present = set(np.unique(chart.values).tolist())
    _shade(ax, chart.astype(float), STABILITY_COLOURS, x="v_ref", y="W")
    _outline(ax, chart == PU, "v_ref", "W", "solid")
    _outline(ax, chart == SU, "v_ref", "W", "dashed")
    lo = max(float(chart.v_ref.min()), float(chart.W.min()))
    hi = min(float(chart.v_ref.max()), float(chart.W.max()))
    handles = [
        Patch(facecolor=STABILITY_COLOURS[k], edgecolor="0.3", label=STABILITY_NAMES[k])
        for k in (STABLE, PU, SU, NO_DATA)
        if k in present or k in (PU, SU)
    ]
    handles += _mark_computed(ax, ds, sel, "v_ref", "W")
    if hi > lo:
        handles += ax.plot(
            [lo, hi],
            [lo, hi],
            color="0.2",
            linestyle="-.",
            linewidth=1.0,
            label=r"$W = v_\mathrm{ref}$",
        )
    ax.legend(
        handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False
    )
    ax.set_title(_title(ds, "Stability chart", chart, title), fontsize=10)
    return _save(fig, path)


def stick_slip_map(
    ds: xr.Dataset,
    path,
    sel=None,
    title: str | None = None,
    var: str = "long_stick_fraction",
    threshold: float = 0.0,
) -> Path:
    """Fig. 14-style map of the long-duration stick-slip zone over (omega, W), to ``path``."""
    ds = as_dataset(ds)
    zone = zone_map(ds, var, threshold, sel)
    fig, ax = _figure()
    _shade(ax, zone, ZONE_COLOURS, x="omega", y="W")
    _outline(ax, zone == 1.0, "omega", "W", "solid")
    handles = [
        Patch(facecolor=ZONE_COLOURS[1.0], edgecolor="0.3", label="long-duration stick-slip"),
        Patch(facecolor=ZONE_COLOURS[0.0], edgecolor="0.3", label="no long-duration stick"),
    ]
    if zone.isnull().any():
        handles.append(
            Patch(facecolor=NO_DATA_COLOUR, edgecolor="0.3", label=STABILITY_NAMES[NO_DATA])
        )
    handles += _mark_computed(ax, ds, sel, "omega", "W")
    ax.legend(
        handles=handles,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=8,
        frameon=False,
        title=f"{var} > {threshold:g}",
        title_fontsize=8,
    )
    ax.set_title(_title(ds, "Stick-slip zone", zone, title), fontsize=10)
    return _save(fig, path)


def friction_curves(
    ds: xr.Dataset, path, sel=None, title: str | None = None, var: str | None = None
) -> Path:
    """Effective friction against v_ref, one line per W (Figs. 5, 13), to ``path``."""
    ds = as_dataset(ds)
    curves = effective_friction_curve(ds, sel, var).sortby("W").sortby("v_ref")
    fig, ax = _figure()
    norm = Normalize(float(curves.W.min()), float(curves.W.max()) + (curves.sizes["W"] == 1))
    cmap = ScalarMappable(norm=norm, cmap="viridis")
    marker = "o" if curves.sizes["v_ref"] <= 25 else None
    for w in curves.W.values:
        ax.plot(
            curves.v_ref.values,
            curves.sel(W=w).values,
            color=cmap.to_rgba(w),
            marker=marker,
            markersize=3,
            linewidth=1.3,
            label=f"W = {w:g}",
        )
    if curves.sizes["W"] <= 10:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    else:
        bar = fig.add_axes((MARGINS["right"] + 0.03, MARGINS["bottom"], 0.025,
                            MARGINS["top"] - MARGINS["bottom"]))   # in the right margin
        fig.colorbar(cmap, cax=bar, label=axis_label(curves.W))
    ax.set_xscale("log" if is_log_spaced(curves.v_ref.values) else "linear")
    ax.set_xlabel(axis_label(curves.v_ref))
    units = curves.attrs.get("units", "")
    ax.set_ylabel(
        f"{curves.name}  {curves.attrs.get('long_name', '')}"
        + (f" [{units}]" if units not in ("", "1") else "")
    )
    ax.set_title(_title(ds, "Effective friction", curves, title), fontsize=10)
    return _save(fig, path)
