"""Averaged stability over the grid W x v_ref (Fig. 9, Sec. 6): the numbers, not the labels.

The stable / PU / SU labels of a stability chart are a rule on the whole (v_ref, W) plane
(DESIGN.md §1: PU = an unstable point whose 4-neighbour connected component of unstable
points contains a point at the chart's smallest W; SU = an unstable point whose component
does not), so that the primary zone "extends over the whole range of reference velocity"
as the paper's Fig. 9 shows. That rule has one implementation,
``store.query.stability_labels`` (connected components by ``scipy.ndimage.label``); the
engine may not import the store (tests/test_layering.py), so callers that want labels
(the gallery's Fig. 9: sweeps/gallery/fig_averaged.py, the tests) pass :func:`stability_chart`'s
``unstable`` / ``valid`` arrays to it::

    from store.query import stability_labels
    c = stability_chart(W, v_ref, p)
    labels = stability_labels(c["unstable"], c["valid"], w_axis=0, v_ref_axis=1, W=W)
"""
from __future__ import annotations

import numpy as np

from .quadrature import N_QUAD
from .stability import linearisation


def stability_chart(W, v_ref, p, *, dither="square-velocity", vd=None, n_quad=N_QUAD,
                    side=1.0, tol=0.0):
    """Averaged stability chart of Fig. 9 on the grid ``W x v_ref``.

    Parameters
    ----------
    W, v_ref : (nW,), (nv,) array_like
        Grid axes.
    p, dither, vd, n_quad, side
        As in :func:`engine.analysis.stability.jacobian`; ``vd`` scalar.
    tol : float
        Threshold on the largest real part above which a point counts as unstable.

    Returns
    -------
    dict with (nW, nv) arrays ``max_real_eig``, ``F_eff``, ``valid`` (bool, the
    eigenvalue is defined), ``unstable`` (bool, ``max_real_eig > tol``) and ``stable``
    (bool, valid and not unstable). For PU / SU labels see the module docstring.
    """
    Wg, vg = np.meshgrid(np.asarray(W, float), np.asarray(v_ref, float), indexing="ij")
    _J, F, lam = linearisation(vg, Wg, p, dither=dither, vd=vd, n_quad=n_quad, side=side)
    valid = ~np.isnan(lam)
    unstable = lam > tol                                  # NaN compares False
    return {"max_real_eig": lam, "F_eff": F, "valid": valid, "unstable": unstable,
            "stable": valid & ~unstable}
