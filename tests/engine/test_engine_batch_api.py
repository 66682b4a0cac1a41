"""The batch entry point's contract (docs/ARCHITECTURE.md, engine/blocks.py) and the
one-trajectory API: shapes, status codes per point, counters, cost apportioning, the
analysis-path dispatch, and every error message a caller can see."""
import sys
import types

import numpy as np
import pytest

from engine import params as P
from engine import status as S
from engine.api import simulate
from engine.blocks import POINT_AXES, BlockResult, run_block
from engine.scene import Scene
from engine.settings import Settings
from tests.engine.common import ALL, scene
from tests.helpers import SIMULATE_OUTPUTS

P_SHORT = P.pack(t_end=0.5, t_transient=0.1)
POINTS = np.array([[0.3, 200.0, 0.4, 0.1], [0.0, 200.0, 0.2, 0.1], [0.5, 300.0, 0.4, 0.01]])
# the scene of a draft LuGre sweep with square dither, as a plan makes it (the e2e tests'
# SIMULATE_SPEC, tests/helpers.py, and test_fixed_costs', test_hpc's, test_gpu_workers'): the
# quick tests below share its kernels with those sweeps instead of compiling a scene of their
# own (15-25 s of the quick set's 3 minutes each)
SWEPT = Scene.from_params(P_SHORT, dither="square-velocity", outputs=SIMULATE_OUTPUTS)


@pytest.mark.long
def test_block_contract_and_point_overrides():
    res = run_block(scene(), POINTS, P_SHORT, Settings(rtol=1e-8, atol=1e-10))
    assert isinstance(res, BlockResult) and POINT_AXES == ("W", "omega", "v_ref", "vd")
    assert list(res.outputs) == list(ALL)
    assert all(v.shape == ((3, 10) if k == "alpha_hist" else (3,)) and v.dtype == np.float64
               for k, v in res.outputs.items())
    assert res.status.dtype == np.int8 and np.all(res.status == S.OK)
    assert np.all(res.steps > 0) and np.all(res.evals >= 6 * res.steps)
    assert np.allclose(res.cost_s / res.cost_s.sum(), res.evals / res.evals.sum())
    for j, (W, omega, v_ref, vd) in enumerate(POINTS):     # each row = its own simulate()
        one = simulate(scene(), P.pack(t_end=0.5, t_transient=0.1, W=W, omega=omega,
                                       v_ref=v_ref, vd=vd), Settings(rtol=1e-8, atol=1e-10))
        scalars = [k for k in ALL if k != "alpha_hist"]
        assert [res.outputs[k][j] for k in scalars] == [one.outputs[k] for k in scalars]
        assert np.array_equal(res.outputs["alpha_hist"][j], one.alpha_hist)
        assert (res.steps[j], res.rejected[j], res.evals[j]) == (one.steps, one.rejected,
                                                                 one.evals)


def test_bad_points_get_a_status_not_an_exception():
    sc = SWEPT
    pts = POINTS.copy()
    pts[1, 3] = np.nan                               # vd = NaN: sigma1(u) is NaN
    res = run_block(sc, pts, P_SHORT)
    assert res.status.tolist() == [S.OK, S.NON_FINITE, S.OK]
    assert np.isnan(res.outputs["v_mean"][1]) and np.isfinite(res.outputs["v_mean"][0])
    failed = run_block(sc, POINTS, P_SHORT, Settings(max_steps=20))
    assert np.all(failed.status == S.FAILED) and np.all(failed.steps + failed.rejected <= 20)


@pytest.mark.long
def test_rk4_counts_four_evaluations_per_step():
    res = run_block(scene(integrator="rk4"), POINTS[:1], P.pack(t_end=0.5),
                    Settings(steps_per_period=4))
    # 31 whole half-periods pi/200 in [0, 0.5], 4 steps each; the last 0.83 of one: 4 steps
    assert res.steps[0] == 4 * 32 and res.evals[0] == 4 * res.steps[0]


def test_analysis_paths_dispatch_lazily(monkeypatch):
    calls = []

    def analysis_block(sc, points, p):
        calls.append(sc.path)
        return {"F_eff": points[:, 0] * 2}, np.zeros(len(points), np.int8)
    monkeypatch.setitem(sys.modules, "engine.analysis.block",
                        types.SimpleNamespace(analysis_block=analysis_block))
    res = run_block(Scene(path="averaged", outputs=("F_eff",)), POINTS, P_SHORT)
    assert calls == ["averaged"] and np.array_equal(res.outputs["F_eff"], 2 * POINTS[:, 0])
    assert res.status.dtype == np.int8 and np.all(res.steps == 0)
    assert res.cost_s.shape == (3,)


def test_recording_and_decimation():
    p = P.pack(t_end=0.2, W=0.3, omega=200.0, v_ref=0.4)
    full = simulate(SWEPT, p, record=True)
    every3 = simulate(SWEPT, p, record=True, record_every=3)
    assert len(full.t) == full.steps and full.t[-1] == 0.2
    assert np.array_equal(every3.t, full.t[2::3]) and np.array_equal(every3.y, full.y[2::3])
    short = simulate(SWEPT, p, record=True, max_records=5)
    assert short.truncated and len(short.t) == 5
    assert simulate(SWEPT, p).t is None


@pytest.mark.parametrize("call,match", [
    (lambda: run_block(scene(), np.zeros((2, 3)), P_SHORT),
     r"points: expected shape \(n, 4\) with columns \('W', 'omega', 'v_ref', 'vd'\), got \(2, 3\)"),
    (lambda: run_block(scene(), POINTS, np.zeros(5)), r"p: expected the parameter vector"),
    (lambda: run_block(scene(outputs=("v_max",)), POINTS, P_SHORT),
     r"outputs: unknown simulate observable\(s\) \['v_max'\]"),
    (lambda: run_block(scene(integrator="euler"), POINTS, P_SHORT),
     r"integrator: unknown integrator 'euler'; known: .*'dopri5'.*'rk4'"),
    (lambda: simulate(scene(system="contact", dither="sine-force"), P_SHORT),
     r"dither: 'sine-force' needs a mass"),
    (lambda: simulate(Scene(path="hbm"), P_SHORT), r"'hbm' is an analysis path"),
    (lambda: simulate(scene(), P_SHORT, record=True, record_every=0),
     r"record_every must be >= 1, got 0"),
])
def test_error_messages(call, match):
    with pytest.raises(ValueError, match=match):
        call()
