"""The error estimate is a gate (issue 9): a sample re-run one level finer, each output's
change compared with what the level promises, and a warning in the cube and on the
command line wherever a change exceeds it. Nothing wrong passes in silence.

Here the promises and the sample; the gate seen from the command line is
tests/e2e/test_accuracy_gate.py."""

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
