"""The error estimate is a gate (issue 9): a sample re-run 100x more accurately, each output's
change compared with what the level promises, and a warning in the cube and on the
command line wherever a change exceeds it. Nothing wrong passes in silence.

Here the promises and the sample; the gate seen from the command line is
tests/e2e/test_accuracy_gate.py."""

import math

import numpy as np

from sweeps.estimates import error_estimate as errors
from sweeps.spec.accuracy import PROMISE_OVERRIDES, TARGET_ERROR, promise



def test_promise_table():
    assert promise("standard", "F_mean") == TARGET_ERROR["standard"]
    assert promise("draft", "slip_fraction") == PROMISE_OVERRIDES["slip_fraction"]["draft"]
    assert all(promise(lv, o) >= TARGET_ERROR[lv] for lv in TARGET_ERROR
               for o in PROMISE_OVERRIDES)


def test_sample_is_stratified_deterministic_and_has_the_corners():
    shape = (31, 31, 1, 1)
    coords = [np.linspace(0, 3, 31), np.geomspace(10, 1000, 31), [0.1], [0.1]]
    idx = errors.sample_index(shape, coords, "abcdef012345")
    assert len(idx) == errors.SAMPLE_SIZE and len(set(idx)) == len(idx)
    assert np.array_equal(idx, errors.sample_index(shape, coords, "abcdef012345"))
    ij = {tuple(np.unravel_index(i, shape)[:2]) for i in idx}
    assert {(0, 0), (0, 30), (30, 0), (30, 30)} <= ij           # the (W, omega) corners
    rows = {i for i, _ in ij}
    assert len(rows) >= 8            # spread over W, not bunched (Latin hypercube)
    small = errors.sample_index((2, 3, 1, 1), [[0, 1], [1, 2, 3], [0.1], [0.1]], "")
    assert np.array_equal(small, np.arange(6))                 # a small grid: every point


def _finer(spec_changes: dict, level: str):
    from sweeps.planning.plan import make_plan
    from sweeps.spec import parse_spec

    spec = {"name": "finer", "method": "simulate", "friction": "lugre",
            "dither": "sine-velocity", "outputs": ["F_mean"], "accuracy": level,
            "grid": {"W": [0.0, 0.5], "omega": [100.0, 300.0], "v_ref": [0.4]},
            **spec_changes}
    plan = make_plan(parse_spec(spec))
    return plan.numerics, errors.finer_numerics(plan)


def test_the_sample_is_rerun_a_hundred_times_tighter_never_at_the_same_numerics():
    """The comparison run is 100x tighter than the level it checks (its error then about
    1 % of the change it measures), or the next level where that is 10x to 100x tighter:
    never the same run, which would measure nothing, and not 10^4x tighter at 2x the
    price. Before, the next level was taken whatever it was:
    a static law's draft runs at its standard's tolerances (STATIC_RTOL_PER_BAND) and an
    elasto-plastic draft asked for phase shares too (PHASE_LEVELS), so their estimates
    compared two identical runs and said 0; an elasto-plastic standard was compared at
    rtol 1e-12 (its reference, ELASTOPLASTIC_LEVELS)."""
    cases = [({"friction": "coulomb"}, "draft"), ({"friction": "stribeck"}, "draft"),
             ({"friction": "elastoplastic", "outputs": ["slip_fraction"]}, "draft"),
             ({"friction": "elastoplastic"}, "standard"), ({}, "draft"), ({}, "standard"),
             ({}, "reference"), ({"params": {"sigma0": 1e6}}, "draft")]
    for changes, level in cases:
        own, finer = _finer(changes, level)
        assert finer.integrator == own.integrator, (changes, level)
        assert math.isclose(finer.settings.rtol, own.settings.rtol / 100, rel_tol=1e-9), \
            (changes, level, own, finer)
        assert math.isclose(finer.settings.atol, own.settings.atol / 100, rel_tol=1e-9), \
            (changes, level, own, finer)
        assert finer.settings.device == "cpu"
    # where the next level is that run, or 10x to 100x tighter, it is the next level
    assert _finer({}, "standard")[1].label == "reference"
    own, finer = _finer({"params": {"sigma0": 1e6}}, "standard")   # rosenbrock 1e-9
    assert (finer.label, finer.integrator) == ("reference", own.integrator)
    assert math.isclose(finer.settings.rtol, own.settings.rtol / 10, rel_tol=1e-9)
    assert _finer({"params": {"sigma0": 1e6}}, "draft")[1].label == "standard"
    assert _finer({"friction": "elastoplastic"}, "standard")[1].label == "standard/100"
    assert _finer({"friction": "coulomb"}, "draft")[1].label == "draft/100"
