"""The one place that sets up and saves a gallery figure (every fig*.py draws through it).

Object API on an Agg canvas (no pyplot state, no display), panels labelled (a), (b), ... as
in the paper, one PNG per figure written atomically (a temporary name, then a rename).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

DPI = 110
PANEL_W, PANEL_H = 3.6, 2.6        # inches per panel
TAU = r"$\tau$"


def panels(rows: int, cols: int, *, title: str = "", sharex=False, sharey=False,
           width: float = PANEL_W, height: float = PANEL_H):
    """A figure of ``rows x cols`` panels labelled (a), (b), ... row by row.

    Returns ``(fig, axes)`` with ``axes`` a flat list (row-major), each with a light grid.
    """
    fig = Figure(figsize=(width * cols, height * rows + (0.35 if title else 0.0)), dpi=DPI,
                 layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.subplots(rows, cols, sharex=sharex, sharey=sharey, squeeze=False)
    axes = list(np.ravel(grid))
    for k, ax in enumerate(axes):
        ax.grid(True, color="0.88", linewidth=0.6)
        ax.set_axisbelow(True)
        ax.set_title(f"({chr(ord('a') + k)})", loc="left", fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig, axes


def label(ax, text: str) -> None:
    """A panel's own subtitle, right of its (a)/(b) letter."""
    ax.set_title(text, loc="right", fontsize=8)


def save(fig: Figure, path) -> Path:
    """Write ``fig`` to ``path`` (PNG) atomically; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.png")
    fig.savefig(tmp, format="png", dpi=DPI)
    os.replace(tmp, path)
    return path


def thin(*arrays, max_points: int = 6000):
    """Every k-th sample so that a line has at most ``max_points`` vertices."""
    n = len(arrays[0])
    k = max(1, n // max_points)
    return tuple(np.asarray(a)[::k] for a in arrays)


def histogram(ax, shares, *, xlabel=r"EP-function $\alpha$") -> None:
    """The paper's alpha histogram (Figs. 12, 17) as time shares in 10 bins of [0, 1]."""
    edges = np.linspace(0.0, 1.0, len(shares) + 1)
    ax.bar(edges[:-1], shares, width=np.diff(edges), align="edge", color="#4c72b0",
           edgecolor="k", linewidth=0.5)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("share of time")
    ax.set_xlim(0.0, 1.0)
