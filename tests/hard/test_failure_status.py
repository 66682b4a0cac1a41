"""A run that cannot finish within its budget says so (status FAILED, outputs NaN): never a
silent wrong number (engine.status; DESIGN.md §4 status codes)."""
from __future__ import annotations

import numpy as np
import pytest

from engine import params as P
from engine import status as S
from engine.api import simulate
from engine.blocks import run_block
from engine.settings import Settings

from .hardcases import FIG10, OUTPUTS, run, scene_of

STIFF = {**FIG10, "sigma0": 1e6, "t_end": 5.0}


@pytest.mark.parametrize("method", ["dopri5", "rodas4"])
def test_tiny_step_budget_gives_failed_not_a_number(method):
    r = run(FIG10, method, 1e-6, max_steps=10)
    assert r.status == S.FAILED
    assert r.steps + r.rejected <= 10
    assert np.all(np.isnan(r.q))
    assert all(np.isnan(v) for v in r.outputs.values()), r.outputs


def test_explicit_method_on_the_stiff_case_fails_at_a_budget_the_stiff_one_meets():
    """sigma0 = 1e6: DP5 is stability-bound (h < 3.3 g / (sigma0 |u|) ~ 4e-6) and needs
    ~7e5 steps for 5 tau; with a budget of 1e5 it must report FAILED, while RODAS finishes
    within the same budget."""
    budget = 100_000
    explicit = run(STIFF, "dopri5", 1e-4, max_steps=budget)
    assert explicit.status == S.FAILED
    assert np.all(np.isnan(explicit.q))
    stiff = run(STIFF, "rodas4", 1e-4, max_steps=budget)
    assert stiff.status == S.OK
    assert np.all(np.isfinite(stiff.q))


def test_block_marks_only_the_points_over_budget():
    """run_block (the sweep entry point): a point that needs more steps than max_steps is
    FAILED with NaN outputs; its neighbour in the same block is OK and finite."""
    scene = scene_of("dopri5")   # (kernel shared)
    p = P.pack(**{**FIG10, "t_end": 2.0})
    # omega = 1e5 stops at 63662 switches in 2 tau, omega = 1e3 at 637
    points = np.array([[0.4, 1e3, 0.4, 0.1], [0.4, 1e5, 0.4, 0.1]])
    res = run_block(scene, points, p, Settings(rtol=1e-6, atol=1e-9, max_steps=20_000))
    assert list(res.status) == [S.OK, S.FAILED]
    # each point's outputs as one row (alpha_hist is a vector)
    rows = [np.hstack([res.outputs[k][j] for k in res.outputs]) for j in (0, 1)]
    assert np.all(np.isfinite(rows[0]))
    assert np.all(np.isnan(rows[1]))


# long: rodas4's block kernel is this test's own compilation (~15 s)
@pytest.mark.long
@pytest.mark.parametrize("method", ["dopri5", "rodas4"])
def test_the_block_kernel_gives_the_one_point_kernels_bits(method):
    """The block kernel (engine.kernels.block_kernel) copies each point's results into its
    rows element by element; the API (engine.api.simulate) runs the same ``run_point`` on
    one point: for a finished point, a non-finite one (vd = NaN) and one over its step
    budget, the same status, counters and output bits (NaN included)."""
    scene = scene_of(method)   # (kernels shared)
    p = P.pack(**{**FIG10, "t_end": 2.0})
    points = np.array([[0.4, 1e3, 0.4, 0.1], [0.4, 1e3, 0.4, np.nan], [0.4, 1e5, 0.4, 0.1]])
    settings = Settings(rtol=1e-6, atol=1e-9, max_steps=20_000)
    res = run_block(scene, points, p, settings)
    assert list(res.status) == [S.OK, S.NON_FINITE, S.FAILED]
    for j, row in enumerate(points):
        q = p.copy()
        q[[P.W, P.OMEGA, P.V_REF, P.VD]] = row
        one = simulate(scene, q, settings)
        assert (res.status[j], res.steps[j], res.rejected[j], res.evals[j]) == \
            (one.status, one.steps, one.rejected, one.evals)
        block = np.array([res.outputs[k][j] for k in OUTPUTS])
        assert block.tobytes() == np.array([one.outputs[k] for k in OUTPUTS]).tobytes()


@pytest.mark.parametrize("method", ["dopri5", "rodas4"])
def test_blow_up_is_reported_not_returned(method):
    """Negative bristle stiffness (refused by the spec layer, forced here) makes z grow like
    exp(sigma0 |u| t / g): the engine must end with FAILED or NON_FINITE and NaN outputs."""
    r = run({**FIG10, "sigma0": -100.0, "t_end": 5.0}, method, 1e-6, max_steps=200_000)
    assert r.status in (S.FAILED, S.NON_FINITE), S.MEANINGS[r.status]
    assert np.all(np.isnan(r.q))
    assert all(np.isnan(v) for v in r.outputs.values())
