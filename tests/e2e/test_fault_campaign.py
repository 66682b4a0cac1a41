"""The fault campaign of scripts/fault_campaign.py, small (issue 10): kill -9 the submitter
(and `ditherlab serve`) after the last block is journaled -- before the final publish -- and
at a journal count; every published cube stays readable, the resume computes exactly the
blocks missing from the journal, and the final cube equals a clean run's but for cost_s.
The slow one adds random instants, serve, and single dask workers killed mid-sweep (the
submitter finishes by itself with an identical cube)."""
import importlib.util
import sys
from pathlib import Path

import pytest

from ..helpers import SIMULATE_SPEC

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "fault_campaign.py"


def _campaign_module():
    spec = importlib.util.spec_from_file_location("fault_campaign", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module   # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def _check(fc, trials) -> None:
    table = "\n".join([fc.HEADER, *map(fc.row, trials), fc.summary(trials)])
    assert all(t.survived and t.identical for t in trials), table
    assert all(t.bad_reads == 0 for t in trials) and sum(t.reads for t in trials) > 0, table


@pytest.mark.long
def test_a_kill_after_the_last_block_is_survived(tmp_path):
    """8 blocks of 2 points, killed once every block is journaled: the window where the next
    submit used to say 'already complete' over a half-empty cube. (~1 min: one kill; a kill
    mid-run is test_cluster_and_resume.py's, the rest the slow campaign's.)"""
    fc = _campaign_module()
    (trial,) = fc.campaign(SIMULATE_SPEC, tmp_path, n_submit=1, n_serve=0, say=lambda _: None)
    _check(fc, [trial])
    assert trial.mode == "after-last" and trial.killed
    assert trial.journaled == 8 and trial.expected == trial.resumed == 0


@pytest.mark.slow
def test_fault_campaign_submit_and_serve(tmp_path):
    fc = _campaign_module()
    n_serve = 3 if fc.has_serve() else 0
    trials = fc.campaign(fc.SPEC, tmp_path, n_submit=6, n_serve=n_serve, seed=1,
                         say=lambda _: None, n_worker=2)
    _check(fc, trials)
    assert sum(t.killed for t in trials) >= 6
