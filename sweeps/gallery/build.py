"""Build the gallery: every figure of the paper with computed content, then the page.

    from sweeps.gallery.build import build
    results = build(Context(size="small", outdir="gallery"))
"""
from __future__ import annotations

import time

from . import fig_averaged, fig_contact, fig_ep, fig_lugre, fig_stability, fig_vm, fig_zone
from .page import write_page
from .verdicts import Check, FigureResult

#: key -> drawing function, in the paper's order; the two "beyond" entries go last
FIGURES = {
    "fig01": fig_contact.fig01, "fig02": fig_contact.fig02,
    "fig05": fig_averaged.fig05, "fig06": fig_lugre.fig06, "fig07": fig_averaged.fig07,
    "fig08": fig_lugre.fig08, "fig09": fig_stability.fig09, "fig10": fig_lugre.fig10,
    "fig11": fig_ep.fig11, "fig12": fig_ep.fig12, "fig13": fig_ep.fig13,
    "fig14": fig_zone.fig14, "fig15": fig_vm.fig15, "fig16": fig_vm.fig16,
    "fig17": fig_vm.fig17,
    "beyond_scaling": fig_zone.beyond_scaling, "beyond_sine": fig_averaged.beyond_sine,
}

_SEC7 = "elasto-plastic slider, sine-velocity dither, lam 0.8 (specs/fig14.toml), dopri5"
_SLOW = "v_ref 0.1, slow force 1.7 sin(0.3 tau), t_end 100"
#: key -> how the figure is computed (``ditherlab scenes`` lists them)
RECIPES = {
    "fig01": "scene fig01: harmonic balance of the Sec. 3 contact model over omega",
    "fig02": "scene fig01's omega range, harmonic balance, both sigma1 readings",
    "fig05": "averaged theory (Eqs. 5.9-5.14), W = 0.25, 0.5, 1, vd = 0.1, 0.01",
    "fig06": "2 LuGre runs: square wave W 0.5, omega 1000, slow force 1.7 sin(0.5 tau), "
             "vd 0.1 / 0.01, 3 slow periods, filtered",
    "fig07": "averaged theory, sine force, a Omega = 0.5, 0.75 (Eq. 5.20 and the full model)",
    "fig08": "2 LuGre runs: sine force 1500 sin(2000 tau), slow force 1.7 sin(0.5 tau), "
             "vd 0.1 / 0.01, filtered",
    "fig09": "scene fig09 (averaged stability chart) and a fine W grid",
    "fig10": "12 LuGre runs: square wave omega 1000, v_ref 0.4, W = 0 ... 0.6, vd 0.1 / 0.01",
    "fig11": f"3 runs, W = 0, 1.5, 2.5 at omega 100, {_SLOW}; {_SEC7}",
    "fig12": f"6 runs, W = 0, 1.5, 2.5 at omega 100, vd 0.1 and 0.01, {_SLOW}; {_SEC7}",
    "fig13": f"4 runs, v_m = 0, W = 0.5, 0.8, 1.5, 2 at omega 100, slow force 1.7 sin(0.3 "
             f"tau), 3 slow periods; {_SEC7}",
    "fig14": "scenes fig14 (refined sweep)",
    "fig15": f"3 runs without dither, v_m = 0.1, 0.5, 1, no slow force, t_end 100; {_SEC7}",
    "fig16": f"12 runs, v_m = 0.1, 0.5, 1, W = 0 / 1.5 / 2.5 / 3 at omega 100, no slow force, "
             f"t_end 100; {_SEC7}",
    "fig17": "fig16's runs, EP-function histograms",
    "beyond_scaling": "scenes fig14 and fig14-lam0.5 (refined sweeps)",
    "beyond_sine": "averaged theory, square vs sine-velocity dither, W = 0.5",
}


def build(ctx, only=None, log=print) -> list[FigureResult]:
    """Draw every figure (or the keys in ``only``) into ``ctx.outdir`` and write
    ``gallery.md`` and ``index.html`` there. A figure that raises is reported on the page
    as ``not computed`` (with its error; never as a verdict on the paper's claim) and the
    rest are still drawn."""
    results = []
    with ctx.shared_cluster():   # one LocalCluster for every simulated sweep
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
