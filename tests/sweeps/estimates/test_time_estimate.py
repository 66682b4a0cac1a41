"""The wall-time model of sweeps.estimates.time_estimate: how a measured per-point cost
becomes a sweep's wall on CPU workers and on a GPU. The calibration itself (timing sample
points on this machine) runs in tests/e2e (``ditherlab plan``); here the per-point cost is
given, so the arithmetic is checked exactly and nothing is compiled."""
import pytest

from sweeps.estimates import time_estimate as te
from sweeps.spec import parse_spec

SPEC = {"name": "est", "friction": "lugre", "dither": "square-velocity", "accuracy": "draft",
        "time": {"t_end": 1.0, "t_transient": 0.2},
        "grid": {"W": [0.3], "omega": [300.0], "v_ref": [0.4], "v_d": [0.1]}}


@pytest.fixture
def per_point(monkeypatch):
    """Every calibration measures 0.25 s a point (no kernel compiled or run)."""
    monkeypatch.setattr(te, "warm_up", lambda *args: 0.0)
    monkeypatch.setattr(te, "_time_block", lambda plan, pts: 0.25)


def test_plan_of_fewer_blocks_than_workers_is_not_shared_among_them(per_point):
    """One block is one worker's: a one-point sweep on two workers takes a whole point's
    time, not half of it (the estimate was n_points * per_point / workers)."""
    est = te.estimate(parse_spec(SPEC), "draft", workers=2)
    assert est.wall_s == pytest.approx(0.25 + te.TASK_OVERHEAD_S, rel=1e-12)


def test_blocks_run_in_rounds_of_one_block_per_worker(per_point):
    from sweeps.planning.plan import make_plan

    spec = parse_spec({**SPEC, "grid": {**SPEC["grid"], "W": [0.0, 0.1, 0.2, 0.3, 0.4]}})
    assert [len(b) for b in make_plan(spec).blocks] == [1] * 5   # (MIN_BLOCKS)
    est = te.estimate(spec, "draft", workers=2)   # 5 one-point blocks on 2 workers: 3 rounds
    assert est.wall_s == pytest.approx(3 * (0.25 + te.TASK_OVERHEAD_S), rel=1e-12)


def test_a_gpu_launch_lasts_its_slowest_point_or_its_points_at_the_gpus_rate():
    """Fig. 14 on an H200 (docs/GPU.md): a 961-point launch took its slowest thread's ~45 s;
    the rates here (2,000 and 1,000 points/s) are illustrative, not measured: a small launch
    is bound by its slowest point, a full block by the rate."""
    assert te.gpu_wall([961], 45.0, 2000.0) == pytest.approx(45.0 + te.TASK_OVERHEAD_S)
    assert te.gpu_wall([131072, 1000], 45.0, 1000.0) == pytest.approx(
        131.072 + 45.0 + 2 * te.TASK_OVERHEAD_S)
