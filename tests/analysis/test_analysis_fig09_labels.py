"""The Fig. 9 chart of specs/fig09.toml, labelled by connected components (DESIGN.md §1).

The spec's averaged path, on a coarser grid, computed block by block as ``ditherlab
submit`` does (sweeps.planning.plan + sweeps.workers.task.compute_block, no cluster, no files) and labelled
by the store's query. Above v_ref = 0.2986 the undithered equilibrium is stable, so the
primary zone lifts off W = 0 there; the paper says it "extends over the whole range of
reference velocity" (Sec. 6, Fig. 9): it must stay one PU zone, not be cut at
v_ref ~ 0.2986 and called SU (what a per-v_ref rule did).
"""
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

import store
from store import PU, STABLE, SU
from sweeps.run.new_cube import empty_cube
from sweeps.planning.plan import make_plan
from sweeps.spec import load_spec
from sweeps.workers.task import compute_block

SPEC = Path(__file__).resolve().parents[2] / "specs" / "fig09.toml"
V_C = 0.2986  # undithered threshold (DESIGN.md §1; test_analysis_stability.py computes it)


@pytest.fixture(scope="module")
def fig09_cube():
    data = tomllib.loads(SPEC.read_text())
    W, v_ref = data["grid"]["W"], data["grid"]["v_ref"]
    assert W["start"] == 0.0 and v_ref["stop"] >= 1.2  # the chart this test is about
    data["grid"]["W"] = {**W, "num": 49}  # the spec's range, a coarser grid
    data["grid"]["v_ref"] = {**v_ref, "num": 48}
    plan = make_plan(load_spec(data))
    cube = empty_cube(plan)
    for b in range(len(plan.blocks)):
        store.fill(cube, compute_block(plan.scene, plan.block_points(b), plan.params,
                                       plan.numerics.settings, plan.blocks[b]))
    assert np.all(cube["status"].values == store.OK)
    return cube


@pytest.mark.parametrize("vd", [0.1, 0.01])
def test_fig09_primary_zone_is_one_pu_component_over_every_v_ref(fig09_cube, vd):
    chart = store.stability_chart(fig09_cube, sel={"v_d": vd})  # (v_ref, W), both ascending
    lab, v, W = chart.values, chart["v_ref"].values, chart["W"].values
    assert W[0] == 0.0 and v[-1] == pytest.approx(1.2)
    # the chart's W = 0 row: unstable below v_c, stable above (the zone lifts off W = 0)
    assert np.all(lab[v < V_C - 0.01, 0] == PU) and np.all(lab[v > V_C + 0.01, 0] == STABLE)
    # ... and yet one PU component, present in every v_ref column of the chart
    _, n_pu = ndimage.label(lab == PU)
    assert n_pu == 1
    assert np.all((lab == PU).any(axis=1)), v[~(lab == PU).any(axis=1)]
    # no vertical cut: no SU cell next to a PU cell, none in the two lowest W rows
    su, pu = lab == SU, lab == PU
    assert not (su[1:] & pu[:-1]).any() and not (su[:-1] & pu[1:]).any()
    assert not (su[:, 1:] & pu[:, :-1]).any() and not (su[:, :-1] & pu[:, 1:]).any()
    assert not su[:, :2].any()
    # the primary zone lies below the diagonal: enough dither (W > v_ref) stabilises
    vg, Wg = np.meshgrid(v, W, indexing="ij")
    assert np.all(Wg[pu] < vg[pu] + 0.05)


def test_fig09a_secondary_zone_stays_su(fig09_cube):
    """Fig. 9(a), vd = 0.1: the minor zone above the diagonal at the higher v_ref is its own
    component, away from W = 0: SU (it runs on to the chart's top W = 1.2)."""
    chart = store.stability_chart(fig09_cube, sel={"v_d": 0.1})
    lab, v, W = chart.values, chart["v_ref"].values, chart["W"].values
    vg, Wg = np.meshgrid(v, W, indexing="ij")
    su = lab == SU
    assert su.sum() > 50
    assert np.all(Wg[su] > vg[su]) and vg[su].min() > 0.1 and vg[su].max() > 1.0
    assert su[:, -1].any()
