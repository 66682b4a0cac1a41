"""Adaptive refinement of map boundaries (issue 11, sweeps.planning.refine): a synthetic class with a
known boundary is recovered exactly; on real maps the refined and the full cube agree cell
for cell; a refined sweep killed part-way resumes to the same cube.

Here the synthetic classes and refined averaged charts (computed in this process);
simulated maps, kills and the command line: tests/e2e/test_refine.py."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

import store
import sweeps
from sweeps.planning.refine import Refinement, default_stride



def refine_synthetic(truth: np.ndarray, path="simulate", margin=None, coarse=None):
    """Drive a Refinement over a known class field; (inferred class per point, computed)."""
    ref = Refinement(path, truth.shape, coarse)
    values = np.full(truth.size, np.nan)
    while (idx := ref.next_points(values.reshape(truth.shape), margin)).size:
        values[idx] = truth.ravel()[idx]
    sources = ref.sources()
    assert ref.asked[sources].all()        # every point takes the values of a computed one
    return truth.ravel()[sources].reshape(truth.shape), ref.asked.reshape(truth.shape)


@pytest.mark.parametrize("n", [31, 61, 100])
def test_a_known_boundary_is_recovered_exactly(n):
    """Stick-slip below the line omega_c = 300 W (the scaling Fig. 14 suggests) on a
    (W, omega) plane, two v_ref slices with different slopes: every cell's class is
    recovered, and only a band along the boundary is computed: the points on cell edges
    whose ends agree are inferred (sweeps.planning.refine), which halves the share of whole-cell
    refinement (measured there: 23 / 12 / 7.5 % for n = 31 / 61 / 100)."""
    W, omega = np.linspace(0, 3, n), np.geomspace(10, 1000, n)
    truth = np.zeros((n, n, 2, 1))
    for k, slope in enumerate((300.0, 150.0)):
        truth[:, :, k, 0] = omega[None, :] < slope * W[:, None]
    inferred, computed = refine_synthetic(truth)
    np.testing.assert_array_equal(inferred, truth)
    share = computed.mean()
    assert share < {31: 0.15, 61: 0.075, 100: 0.045}[n], share
    assert computed[[0, 0, -1, -1], [0, -1, 0, -1]].all()   # the corners always are


def test_a_disc_inside_the_lattice_is_recovered():
    g = np.linspace(-1, 1, 65)
    truth = np.zeros((65, 1, 65, 1))   # the averaged path's plane: (W, v_ref), axes 0 and 2
    truth[:, 0, :, 0] = (g[:, None] ** 2 + g[None, :] ** 2) < 0.3
    inferred, computed = refine_synthetic(truth, path="averaged")
    np.testing.assert_array_equal(inferred, truth)
    assert computed.mean() < 0.3


def test_a_band_between_lattice_points_is_missed_without_a_margin_and_found_with_one():
    """The limit of class-only refinement, and what the margin (max_real_eig) buys: a
    stable band of three W values between two coarse lattice rows (stride 8), where the
    largest eigenvalue dips below 0; both lattice rows are unstable, but the eigenvalue's
    variation across the cell exceeds its distance from 0, so the cell is split."""
    n = 33
    a = np.arange(n, dtype=float)[:, None, None, None]
    eig = np.broadcast_to((a - 14.3) ** 2 / 4 - 0.5, (n, 1, n, 1)).copy()
    truth = (eig < 0).astype(float)          # stable = 1 on W indices 13..15
    assert truth[:, 0, 0, 0].sum() == 3
    inferred, _ = refine_synthetic(truth, path="averaged", coarse=8)
    assert (inferred != truth).any()
    inferred, _ = refine_synthetic(truth, path="averaged", margin=eig, coarse=8)
    np.testing.assert_array_equal(inferred, truth)


def test_default_stride_leaves_about_four_steps():
    assert [default_stride(n) for n in (5, 9, 17, 31, 61, 400)] == [1, 2, 4, 8, 16, 128]


CHART = {"name": "refine-chart", "friction": "lugre", "method": "averaged",
         "grid": {"W": {"start": 0.0, "stop": 1.2, "num": 61},
                  "v_ref": {"start": 0.005, "stop": 1.2, "num": 60}, "v_d": [0.1, 0.01]}}


def _pair(spec: dict, root):
    full = sweeps.run_sweep(spec, store=root, progress=False)
    ref = sweeps.run_sweep({**spec, "name": spec["name"] + "-r", "refine": True}, store=root,
                           progress=False)
    assert full.state == ref.state == "done"
    with warnings.catch_warnings():   # classes are compared; inferred values are expected
        warnings.simplefilter("ignore", sweeps.InferredPointsWarning)
        return sweeps.open_sweep(full.sweep_id, root), sweeps.open_sweep(ref.sweep_id, root)


def test_refined_stability_chart_labels_equal_the_full_grid(tmp_path):
    full, ref = _pair(CHART, tmp_path)
    for vd in (0.1, 0.01):
        np.testing.assert_array_equal(store.stability_chart(ref, sel={"v_d": vd}).values,
                                      store.stability_chart(full, sel={"v_d": vd}).values)
    flags = ref["provenance"].values
    assert set(np.unique(flags)) == {0, 1} and (flags == 0).mean() < 0.5
    computed = flags == 0                          # computed points hold the full values
    np.testing.assert_array_equal(ref["F_eff"].values[computed], full["F_eff"].values[computed])


def test_refined_fig09_at_400x400_labels_every_cell_as_the_full_grid(tmp_path):
    """Issue 11's Fig. 9 target: the 400x400 averaged chart (v_d = 0.1), refined, has
    identical labels. A first lattice of stride 64 missed an SU island of about 10 x 16
    cells near v_ref = 0.18, W = 0.31 (86 cells); the stride is now at most 16."""
    spec = {"name": "fig09-400", "friction": "lugre", "dither": "square-velocity",
            "method": "averaged", "outputs": ["F_eff", "max_real_eig", "stable"],
            "grid": {"W": {"start": 0.0, "stop": 1.2, "num": 400},
                     "v_ref": {"start": 0.005, "stop": 1.2, "num": 400}, "v_d": [0.1]}}
    full, ref = _pair(spec, tmp_path)
    labels = [store.stability_chart(ds, sel={"v_d": 0.1}).values for ds in (full, ref)]
    assert (labels[0] == store.query.SU).sum() > 0
    np.testing.assert_array_equal(labels[1], labels[0])
    assert (ref["provenance"].values == 0).mean() < 0.2
