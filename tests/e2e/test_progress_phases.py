"""The progress display names each phase of a submit (issue 27): the points, with the error
estimate's finer re-runs counted ``k/N`` beside them (they run among the blocks, issue 37)
and on a bar of their own if some are left after the points, then publishing the cube; it
no longer sits at "99 %" while the estimate runs unmentioned (a 100-point draft Fig. 14 sweep showed 95 % for
13 s, then 100 % for 6 s more). Checked on the sequence of states the display went
through (tqdm redraws with a carriage return), not on their timing.

Here a submit's phases in order, on threads and on a local cluster; a quiet run and the
bars' redraw: tests/sweeps/run/test_progress_phases.py."""
import re

import pytest

from sweeps.planning.plan import make_plan
from sweeps.run import submit as submit_module
from sweeps.run.phases import shown
from sweeps.run.submit import submit
from sweeps.estimates.error_reruns import SampleRuns
from sweeps.spec import parse_spec

from ..sweeps.run.test_progress_phases import SPEC, _states

pytestmark = pytest.mark.cluster   # what it starts (tests/conftest.py)


def _count(state: str) -> tuple[int, int]:
    k, n = re.search(r"\| *(\d+)/(\d+) \[", state).groups()
    return int(k), int(n)


def _reruns(states: list[str]) -> list[tuple[int, int]]:
    """The re-run counts shown: beside the points (``error estimate k/N``, re-runs that
    ran among the blocks) and on the estimate's own bar (those left after the points)."""
    out = []
    for s in states:
        if s.startswith("points:") and (m := re.search(r"error estimate (\d+)/(\d+)\]", s)):
            out.append((int(m.group(1)), int(m.group(2))))
        elif s.startswith("error estimate:"):
            out.append(_count(s))
    return out


@pytest.mark.long
@pytest.mark.parametrize("where", ["threads", "cluster"])
def test_a_submit_names_its_phases_in_order(tmp_path, capfd, monkeypatch, where):
    """8 points run on threads of the submitter (priced below a cluster's start); with
    the threshold at 0 on a local cluster. Either way the re-runs run among the points."""
    if where == "cluster":
        monkeypatch.setattr(submit_module, "IN_PROCESS_BELOW_S", 0.0)
    plan = make_plan(parse_spec(SPEC))
    n_rerun = len(SampleRuns(plan).order)
    res = submit(plan, tmp_path / "store", progress=shown(True))
    assert res.state == "done", res.message
    assert ("cluster_s" in res.timings) == (where == "cluster"), res.timings
    states = _states(capfd.readouterr().err, plan)
    phases = [s.split(":")[0] for s in states]
    order = [p for i, p in enumerate(phases) if i == 0 or p != phases[i - 1]]
    cluster = where == "cluster"
    expected = ["starting a local cluster of 2 workers"] * cluster + [
        "points", "error estimate", "publishing the cube"] + ["stopping the local cluster"] * cluster
    # the estimate's own bar only when re-runs were left after the last point
    assert order in (expected, [p for p in expected if p != "error estimate"]), states
    points = [_count(s) for s in states if s.startswith("points:")]
    reruns = _reruns(states)
    assert points[-1] == (plan.n_points, plan.n_points), states   # all shown before ...
    assert reruns and reruns[-1] == (n_rerun, n_rerun), states    # ... and every re-run
    assert {n for _, n in reruns} == {n_rerun}, states
    assert [k for k, _ in reruns] == sorted(k for k, _ in reruns), states
