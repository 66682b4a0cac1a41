"""The servo's hunting map (engine.systems.servo; ``ditherlab map --kind hunting``): its
hunting amplitude over (omega, W) on a log colour scale, the quenched cells outlined, drawn
with the helpers of :mod:`store.maps`."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from .maps import _figure, _grid_on_top, _outline, _save, _title
from .axes import axis_label, cell_edges, is_log_spaced
from .cubedata import as_dataset


def hunting_map(ds: xr.Dataset, path, sel=None, title: str | None = None,
                var: str = "hunt_amplitude") -> Path:
    """Fig. 14-style map of a servo's hunting amplitude over (omega, W) (engine.systems.servo):
    the amplitude on a log colour scale, the cells where the hunting is quenched (below 1 %
    of the largest amplitude) outlined, to ``path``."""
    from matplotlib.colors import LogNorm

    from .query import plane

    ds = as_dataset(ds)
    amp = plane(ds, var, ("W", "omega"), sel, "hunting_map").sortby("omega").sortby("W")
    amp = amp.transpose("W", "omega")
    fig, ax = _figure()
    logx, logy = is_log_spaced(amp["omega"].values), is_log_spaced(amp["W"].values)
    values = amp.values.astype(float)
    top = np.nanmax(values) if np.isfinite(values).any() else 1.0
    floor = max(top * 1e-4, 1e-12)
    mesh = ax.pcolormesh(cell_edges(amp["omega"].values, logx), cell_edges(amp["W"].values, logy),
                         np.clip(values, floor, None), norm=LogNorm(floor, max(top, floor * 10)),
                         cmap="viridis", shading="flat")
    fig.colorbar(mesh, ax=ax, label=f"{var} (half peak-to-peak error)")
    _outline(ax, amp < 0.01 * top, "omega", "W", "solid")
    ax.set_xscale("log" if logx else "linear")
    ax.set_yscale("log" if logy else "linear")
    ax.set_xlabel(axis_label(amp["omega"]))
    ax.set_ylabel(axis_label(amp["W"]))
    _grid_on_top(ax)
    ax.set_title(_title(ds, "Hunting (outlined: < 1 % of the most)", amp, title),
                 fontsize=10)
    return _save(fig, path)
