"""Stability chart over (W, v_ref) and its PU / SU labels (Fig. 9, DESIGN.md §1).

Labelling rule (mirrored by the store's query layer, which may not import engine):

1. a point is *unstable* when ``max_real_eig > tol`` (``tol = 0`` by default); NaN
   (not computed / undefined) is not unstable;
2. along the W axis, sorted by increasing W, at fixed every other coordinate
   (v_ref, omega, v_d), the **PU** (primary unstable) points are the unbroken run of
   unstable points that starts at the smallest W of the grid (the grid's stand-in for
   ``W = 0``): ``PU = logical_and.accumulate(unstable, axis=W)``;
3. **SU** (secondary unstable) = unstable and not PU (separated from the smallest W by
   at least one stable or NaN point);
4. labels: ``STABLE = 0``, ``PU = 1``, ``SU = 2``, ``UNKNOWN = -1`` (NaN input).
"""
from __future__ import annotations

import numpy as np

from .quadrature import N_QUAD
from .stability import jacobian, max_real_eig

STABLE, PU, SU, UNKNOWN = 0, 1, 2, -1
LABELS = {STABLE: "stable", PU: "PU", SU: "SU", UNKNOWN: "unknown"}


def stability_labels(max_real_eig, axis=0, W=None, tol=0.0):
    """Label each point of a stability chart stable / PU / SU (module docstring rule).

    Parameters
    ----------
    max_real_eig : ndarray
        Largest real part of the averaged Jacobian's eigenvalues, any shape.
    axis : int
        The W axis of ``max_real_eig``.
    W : (nW,) array_like, optional
        W coordinate along ``axis``; if given, points are ordered by it (else the array
        is taken as already ascending in W).
    tol : float
        Threshold on the real part above which a point counts as unstable.

    Returns
    -------
    labels : int8 ndarray, same shape.
    """
    m = np.moveaxis(np.asarray(max_real_eig, float), axis, 0)
    order = np.argsort(np.asarray(W, float), kind="stable") if W is not None else np.arange(m.shape[0])
    ms = m[order]
    unstable = ms > tol                                  # NaN compares False
    primary = np.logical_and.accumulate(unstable, axis=0)
    lab = np.where(primary, PU, np.where(unstable, SU, STABLE)).astype(np.int8)
    lab[np.isnan(ms)] = UNKNOWN
    out = np.empty_like(lab)
    out[order] = lab
    return np.moveaxis(out, 0, axis)


def stability_chart(W, v_ref, p, *, dither="square-velocity", vd=None, n_quad=N_QUAD,
                    side=1.0, tol=0.0):
    """Averaged stability chart of Fig. 9 on the grid ``W x v_ref``.

    Parameters
    ----------
    W, v_ref : (nW,), (nv,) array_like
        Grid axes (W ascending for a meaningful PU/SU split).
    p, dither, vd, n_quad, side
        As in :func:`engine.analysis.stability.jacobian`; ``vd`` scalar.

    Returns
    -------
    dict with (nW, nv) arrays ``max_real_eig``, ``stable`` (bool, ``labels == STABLE``),
    ``labels`` (int8) and ``F_eff``.
    """
    Wg, vg = np.meshgrid(np.asarray(W, float), np.asarray(v_ref, float), indexing="ij")
    J, F = jacobian(vg, Wg, p, dither=dither, vd=vd, n_quad=n_quad, side=side)
    lam = max_real_eig(J)
    labels = stability_labels(lam, axis=0, W=W, tol=tol)
    return {"max_real_eig": lam, "stable": labels == STABLE, "F_eff": F, "labels": labels}
