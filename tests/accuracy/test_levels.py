"""Accuracy levels on the Fig. 10(d) scene (docs/ACCURACY.md, sweeps.spec.accuracy).

The levels are calibrated by scripts/work_precision.py on tau in [0, 100]; here a short
window (tau in [0, 10], observed on [5, 10]) checks, through the same path the sweep
service takes (``make_plan(spec, level)`` -> ``run_block``), that the levels are ordered
(draft less accurate than standard, standard than reference) and that each stays within
its documented bound ``sweeps.spec.accuracy.TARGET_ERROR``.

Reference: DP5 at rtol 1e-12 (atol 1e-15), confirmed by an independent RK4 run with 128
steps per half-period (no error control, no kink location) that must agree with it far
below the tightest bound. Error: the largest relative error over the outputs a Fig. 10
user queries (v_slow_p2p, F_mean, v_mean). No timing is asserted.
"""
import numpy as np
import pytest

from engine import status as S
from engine.blocks import run_block
from engine.settings import Settings
from sweeps.spec.accuracy import TARGET_ERROR
from sweeps.planning.plan import make_plan
from sweeps.spec import parse_spec
from sweeps.spec.models import LEVELS

QUERIED = ["v_mean", "v_slow_p2p", "F_mean"]   # (the gallery's order: one kernel)
SPEC = {  # Fig. 10(d): LuGre slider, paper Sec. 5.1 parameters, square-velocity dither
    "name": "fig10-short", "friction": "lugre", "dither": "square-velocity",
    "method": "simulate", "outputs": QUERIED,
    "time": {"t_end": 10.0, "t_transient": 5.0},
    "grid": {"W": [0.4], "omega": [1000.0], "v_ref": [0.4], "v_d": [0.1]},
}


def _run(plan, scene, settings) -> dict:
    res = run_block(scene, plan.block_points(0), plan.params, settings)
    assert res.status[0] == S.OK, f"{scene.integrator} {settings}: status {res.status[0]}"
    return {k: float(v[0]) for k, v in res.outputs.items()}


def _error(out: dict, ref: dict) -> float:
    return max(abs(out[q] - ref[q]) / abs(ref[q]) for q in QUERIED)


@pytest.fixture(scope="module")
def reference():
    plan = make_plan(parse_spec(SPEC), "reference")
    dp5 = _run(plan, plan.scene.with_(integrator="dopri5"), Settings(rtol=1e-12, atol=1e-15))
    rk4 = _run(plan, plan.scene.with_(integrator="rk4"), Settings(steps_per_period=128))
    assert _error(rk4, dp5) < 1e-3 * TARGET_ERROR["reference"]
    return dp5


@pytest.fixture(scope="module")
def level_errors(reference):
    errs = {}
    for level in LEVELS:
        plan = make_plan(parse_spec(SPEC), level)
        errs[level] = _error(_run(plan, plan.scene, plan.numerics.settings), reference)
    return errs


@pytest.mark.long
def test_levels_are_ordered(level_errors):
    assert level_errors["draft"] > level_errors["standard"] > level_errors["reference"]


@pytest.mark.parametrize("level", LEVELS)
def test_level_within_documented_bound(level_errors, level):
    assert np.isfinite(level_errors[level])
    assert level_errors[level] <= TARGET_ERROR[level]


def test_explicit_numerics_carry_atol_units():
    """An explicit ``accuracy`` table reaches the engine's Settings unchanged, natural
    atol units included (engine.settings.Settings.atol_units)."""
    spec = parse_spec({**SPEC, "accuracy": {"integrator": "dopri5", "rtol": 1e-7,
                                            "atol": 1e-9, "atol_units": "natural"}})
    s = make_plan(spec).numerics.settings
    assert (s.rtol, s.atol, s.atol_units) == (1e-7, 1e-9, "natural")
    with pytest.raises(ValueError, match="atol_units"):
        parse_spec({**SPEC, "accuracy": {"integrator": "dopri5", "atol_units": "relative"}})
