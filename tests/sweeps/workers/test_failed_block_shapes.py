"""A block whose computation raises is filled into the cube as FAILED with NaN outputs,
in each output's own shape: alpha_hist's NaN rows are (n, 10) like the cube's, so a failed
block of a histogram sweep does not stop the run at the fill (it did: "fill: alpha_hist has
shape (1,), expected (1, 10)")."""
import numpy as np
import pytest

from store.points import fill
from sweeps.planning.plan import make_plan
from sweeps.run.new_cube import empty_cube
from sweeps.spec.load import load_spec
from sweeps.workers.task import compute_block

SPEC = {"name": "hist-fail", "friction": "elastoplastic", "dither": "square-velocity",
        "outputs": ["F_mean", "alpha_hist"], "time": {"t_end": 5.0, "t_transient": 1.0},
        "grid": {"W": [0.0, 0.5], "omega": [100.0], "v_ref": [0.1], "v_d": [0.1]}}


@pytest.mark.long   # 17-30 s of first compilations (2 cores): quick set <= 3 min, issue 38
def test_a_failed_block_of_a_histogram_sweep_fills_nan_rows_of_the_cubes_shape():
    plan = make_plan(load_spec(SPEC))
    cube = empty_cube(plan)
    bad_points = plan.block_points(0)[:, :2]   # two columns of four: run_block raises
    record = compute_block(plan.scene, bad_points, plan.params, plan.numerics.settings,
                           plan.blocks[0])
    assert record.error.startswith("ValueError")
    fill(cube, record)
    hist = cube["alpha_hist"].values.reshape(-1, cube["alpha_hist"].shape[-1])
    assert hist.shape[1] == 10 and np.isnan(hist[plan.blocks[0]]).all()
    assert (cube["status"].values.reshape(-1)[plan.blocks[0]] != 0).all()
