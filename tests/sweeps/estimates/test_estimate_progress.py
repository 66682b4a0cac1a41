"""The error estimate's bar goes on from the count of finished re-runs last shown beside
the points (sweeps.estimates.error_reruns._error_estimate, SampleRuns.shown). Before, it
counted again when the points ended: a re-run that finished after the points' bar last
showed ``k/N`` and before that count opened no bar at all, and the display stopped at
``k/N`` (a race tests/e2e/test_progress_phases.py could lose). Here the race is set up
exactly: every re-run is finished, the points' bar showed one fewer."""
from __future__ import annotations

import contextlib

from sweeps.estimates import error_reruns
from sweeps.estimates.error_reruns import SampleRuns, _error_estimate
from sweeps.planning.plan import make_plan
from sweeps.spec import parse_spec

SPEC = {"name": "bar", "friction": "lugre", "dither": "square-velocity",
        "method": "simulate", "outputs": ["v_mean"], "accuracy": "draft",
        "time": {"t_end": 4.0, "t_transient": 1.0},
        "grid": {"W": [0.1, 0.3], "omega": [100.0], "v_ref": [0.2, 0.4], "v_d": [0.1]}}


def test_the_estimate_bar_counts_on_from_what_the_points_bar_showed(monkeypatch):
    plan = make_plan(parse_spec(SPEC))
    runs = SampleRuns(plan)
    total = len(runs.order)
    runs.shown = total - 1                           # the points' bar showed N-1/N ...
    monkeypatch.setattr(runs, "finished", lambda: total)   # ... and the last one ended since

    def gather(client, tick=None, idle=None):        # every re-run, as as_completed yields
        for _ in range(total if tick is not None else 0):
            tick()
        return "records"

    monkeypatch.setattr(runs, "gather", gather)
    monkeypatch.setattr(error_reruns.errest, "compare", lambda *args: {"compared": args[4]})
    bars = []

    @contextlib.contextmanager
    def display(what, n, unit, initial=0):
        bar = {"what": what, "n": n, "initial": initial, "updates": 0}
        bars.append(bar)

        class Bar:
            def update(self, k=1):
                bar["updates"] += k

            def keep_alive(self):
                pass

        yield Bar()

    out = _error_estimate(plan, client=None, cube=None, started=runs, display=display)
    assert out == {"compared": runs.finer.label}
    assert bars == [{"what": "error estimate", "n": total, "initial": total - 1,
                     "updates": 1}], bars   # the bar ends at N/N
