"""Build the gallery: every figure of the paper with computed content, then the page.

    from sweeps.gallery.build import build
    results = build(Context(size="small", outdir="gallery"))
"""
from __future__ import annotations

import time

from . import fig_averaged, fig_contact, fig_ep, fig_lugre, fig_vm, fig_zone
from .page import write_page
from .verdicts import Check, FigureResult

#: key -> drawing function, in the paper's order; the two "beyond" entries go last
FIGURES = {
    "fig01": fig_contact.fig01, "fig02": fig_contact.fig02,
    "fig05": fig_averaged.fig05, "fig06": fig_lugre.fig06, "fig07": fig_averaged.fig07,
    "fig08": fig_lugre.fig08, "fig09": fig_averaged.fig09, "fig10": fig_lugre.fig10,
    "fig11": fig_ep.fig11, "fig12": fig_ep.fig12, "fig13": fig_ep.fig13,
    "fig14": fig_zone.fig14, "fig15": fig_vm.fig15, "fig16": fig_vm.fig16,
    "fig17": fig_vm.fig17,
    "beyond_scaling": fig_zone.beyond_scaling, "beyond_sine": fig_averaged.beyond_sine,
}


def build(ctx, only=None, log=print) -> list[FigureResult]:
    """Draw every figure (or the keys in ``only``) into ``ctx.outdir`` and write
    ``gallery.md`` and ``index.html`` there. A figure that raises is reported on the page
    as ``not computed`` (with its error; never as a verdict on the paper's claim) and the
    rest are still drawn."""
    results = []
    for key, draw in FIGURES.items():
        if only and key not in only:
            continue
        t0 = time.perf_counter()
        try:
            res = draw(ctx)
        except Exception as exc:  # noqa: BLE001 -- one figure must not sink the page
            error = f"{type(exc).__name__}: {exc}"
            res = FigureResult(key, key, "", "(the figure could not be computed)",
                               ctx.png(key), [Check("computation", error, "runs", False)],
                               error=error)
        res.wall = time.perf_counter() - t0
        log(f"{key:<15} {res.verdict:<14} {res.wall:6.1f} s")
        results.append(res)
    write_page(results, ctx)
    return results
