"""Fig. 9: stability chart of the averaged velocity-tracking system (Sec. 6).

    .venv/bin/python scripts/fig09_stability_chart.py   -> out/fig09_stability_chart.png

Square-velocity dither, LuGre, the Sec. 5.1 parameters, vd = 0.1 (a) and 0.01 (b).
Like the paper, the chart covers the v_ref range where the undithered system is
unstable (v_ref < v_c ~ 0.2986); a third panel shows vd = 0.01 over a wider v_ref range.
Labels come from store.query.stability_labels, the one implementation of DESIGN.md §1:
PU = an unstable point whose 4-neighbour connected component of unstable points in the
(v_ref, W) plane reaches W = 0 (so the primary zone, which "extends over the whole range of
reference velocity", stays PU where it lifts off W = 0 above v_c); SU = an unstable point
whose component does not. The kink W = v_ref uses the right derivative
(side = +1). Prints the PU boundary, the SU extents, and for vd = 0.01 the thin
unstable features on a fine grid (dW = 2e-5).
"""
from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap
from scipy.optimize import brentq

from engine import params as P
from engine.analysis import jacobian, max_real_eig, stability_chart
from store.query import PU, SU, stability_labels

OUT = os.path.join(os.path.dirname(__file__), "..", "out")
CMAP = ListedColormap(["#dddddd", "white", "#d62728", "#1f77b4"])   # unknown, stable, PU, SU


def labels(W, v, vd):
    """(nW, nv) int8 stable / PU / SU labels of the averaged chart (store's rule)."""
    c = stability_chart(W, v, P.pack(vd=vd))
    return stability_labels(c["unstable"], c["valid"], w_axis=0, v_ref_axis=1, W=W)


def runs(mask, axis):
    """Contiguous runs of True in a 1-D mask as (first, last) axis values."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return []
    br = np.flatnonzero(np.diff(idx) > 1)
    return [(axis[a], axis[b]) for a, b in zip(np.r_[idx[0], idx[br + 1]], np.r_[idx[br], idx[-1]])]


def describe(W, v, lab, vd, every):
    print(f"\nvd = {vd}: PU points {np.sum(lab == PU)}, SU points {np.sum(lab == SU)} of {lab.size}")
    for j in range(0, v.size, every):
        pu = W[lab[:, j] == PU]
        su = "; ".join(f"{a:.4f}-{b:.4f}" for a, b in runs(lab[:, j] == SU, W))
        top = f"{pu.max():.4f}" if pu.size else "-"
        print(f"  v_ref={v[j]:.4f}  PU: W <= {top:<7}  SU: {su or '-'}")


def thin_features(vd=0.01):
    """SU features for vd = 0.01 on a fine W grid, as offsets W - v_ref."""
    v = np.linspace(0.005, 0.295, 59)
    W = np.arange(0.0, 0.6, 2e-5)
    lab = labels(W, v, vd)
    print(f"\nvd = {vd}, fine grid dW = 2e-5: SU runs as W - v_ref (width)")
    for j in range(v.size):
        rs = runs(lab[:, j] == SU, W)
        if rs:
            print(f"  v_ref={v[j]:.3f}: " + "; ".join(f"[{a - v[j]:+.5f}, {b - v[j]:+.5f}] ({b - a + 2e-5:.5f})" for a, b in rs))


def main():
    v_c = brentq(lambda x: max_real_eig(jacobian(x, 0.0, P.pack())[0]), 0.2, 0.4, xtol=1e-12)
    print(f"undithered (W = 0) unstable for v_ref < v_c = {v_c:.6f}")
    W = np.linspace(0, 0.6, 601)
    v = np.linspace(0.002, 0.298, 149)
    vw = np.linspace(0.002, 1.0, 300)
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    for k, (vd, vax) in enumerate([(0.1, v), (0.01, v), (0.01, vw)]):
        lab = labels(W, vax, vd)
        if k < 2:
            describe(W, vax, lab, vd, every=12)
        ax[k].pcolormesh(vax, W, lab, cmap=CMAP, vmin=-1.5, vmax=2.5, shading="nearest")
        ax[k].set_title(f"vd = {vd}" + (" (wider v_ref)" if k == 2 else "") + ": red PU, blue SU")
        ax[k].set_xlabel("v_ref")
        ax[k].set_ylabel("W")
    thin_features()
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, "fig09_stability_chart.png")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {os.path.normpath(path)}")


if __name__ == "__main__":
    main()
