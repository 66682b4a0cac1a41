"""How a run ends (sweeps.run.outcome.final_result): a cancel or a stopping serve that lands
after the last block but before the error estimate leaves the sweep resumable, not ``done``
and unchecked; and a done sweep whose cube cannot be served is queued again by ``submit
--detach`` (sweeps.service.enqueue)."""
from __future__ import annotations

import time

import numpy as np
import pytest
import xarray as xr

import store
from engine import status as S
from sweeps.api import run_sweep
from sweeps.estimates.error_reruns import ESTIMATE_FILE, needs_estimate
from sweeps.planning.plan import make_plan
from sweeps.run.lease_holder import CANCELLED, SHUTDOWN, Lease
from sweeps.run.outcome import failures_text, final_result
from sweeps.run.sink import done_blocks
from sweeps.spec import parse_spec

# 4 draft LuGre points, short: run on threads of this process in a few seconds; the scene
# of test_fixed_costs and test_progress_phases here (one compilation for the three)
SPEC = {"name": "outcome", "friction": "lugre", "dither": "square-velocity",
        "method": "simulate", "outputs": ["v_mean", "F_mean"], "accuracy": "draft",
        "time": {"t_end": 4.0, "t_transient": 1.0},
        "grid": {"W": [0.1, 0.3], "omega": [100.0], "v_ref": [0.2, 0.4], "v_d": [0.1]}}


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished sweep whose saved estimate is then removed: every point final, the
    estimate never computed (a stop between the last block and the estimate)."""
    root = tmp_path_factory.mktemp("store")
    res = run_sweep(SPEC, root, progress=False)
    assert res.state == "done"
    plan = make_plan(parse_spec(SPEC))
    sweep = store.SweepDir(root, plan.sweep_id)
    (sweep.root / ESTIMATE_FILE).unlink()
    cube = store.read_cube(sweep.cube)
    assert needs_estimate(plan, sweep, cube)
    return plan, sweep, store.Catalogue(root), cube


@pytest.mark.parametrize("stopped, state", [(CANCELLED, "cancelled"), (SHUTDOWN, "queued")])
def test_a_stop_before_the_estimate_leaves_the_sweep_to_resume(finished, stopped, state):
    plan, sweep, catalogue, cube = finished
    lease, _ = Lease.take(catalogue, plan.sweep_id)   # (the row is running under us now)
    res = final_result(plan, sweep, catalogue, cube, blocks_run=0, t0=time.perf_counter(),
                       timings={}, lease=lease, stopped=stopped)
    row = catalogue.get(plan.sweep_id)
    assert res.state == state and row["state"] == state, (res, row)
    assert "before the error estimate" in res.message, res.message
    assert row["message"] == res.message


def test_without_a_stop_the_finished_sweep_is_done(finished):
    plan, sweep, catalogue, cube = finished
    res = final_result(plan, sweep, catalogue, cube, blocks_run=0, t0=time.perf_counter(),
                       timings={})
    assert res.state == "done" and res.message == ""


@pytest.fixture
def done_sweep(tmp_path):
    """A finished sweep in a fresh store: its plan and folder."""
    res = run_sweep(SPEC, tmp_path, progress=False)
    assert res.state == "done"
    plan = make_plan(parse_spec(SPEC))
    return plan, store.SweepDir(tmp_path, plan.sweep_id), tmp_path


@pytest.mark.parametrize("damage, why", [
    ("truncate", "cube unreadable"),
    ("delete", "cube missing"),
    ("estimate", "error estimate missing"),
    (None, None),
])
def test_submit_detach_queues_a_done_sweep_again_when_its_cube_is_unusable(done_sweep, damage,
                                                                         why):
    """``submit --detach`` of a done sweep (sweeps.service.enqueue): a truncated cube was
    answered "done, already complete" (exit 0) and never rebuilt."""
    from sweeps.service import enqueue

    plan, sweep, root = done_sweep
    if damage == "truncate":
        sweep.cube.write_bytes(sweep.cube.read_bytes()[:1000])
    elif damage == "delete":
        sweep.cube.unlink()
    elif damage == "estimate":
        (sweep.root / ESTIMATE_FILE).unlink()
    row = enqueue(plan, root)
    if why is None:
        assert row["state"] == "done"
    else:
        assert row["state"] == "queued", row
        assert row["message"].startswith(why) and row["message"].endswith("re-queued"), row


def test_the_status_table_names_a_finished_sweeps_accuracy_warnings(done_sweep):
    """``ditherlab status`` (the table): a done sweep whose cube records an accuracy warning
    says how many and where to read them; before, the table said only "finished"."""
    import json

    from tests.helpers import in_process

    plan, sweep, root = done_sweep
    status, out, _ = in_process("status", "--store", root)
    assert status == 0 and "accuracy warning" not in out
    cube = store.read_cube(sweep.cube)
    est = json.loads(cube.attrs["error_estimate"])
    est["warnings"] = ["v_mean moved 3e-2 at 1 of 4 re-run points, over draft's promise"]
    cube.attrs["error_estimate"] = json.dumps(est)
    store.publish(cube, sweep.cube)
    status, out, _ = in_process("status", "--store", root)
    row = next(line for line in out.splitlines() if line.startswith(plan.sweep_id))
    assert status == 0 and f"1 accuracy warning (`ditherlab status {plan.sweep_id}`)" in row


def test_a_ctrl_c_between_the_journal_and_the_cube_counts_what_the_journal_kept(tmp_path,
                                                                              monkeypatch):
    """A Ctrl-C that lands after a block's journal file is written but before the block is
    in the cube (sweeps.run.sink.BlockSink.many): the row said one block fewer than the
    journal kept (CI, test_ctrl_c_of_a_submitter_reads_cancelled_not_running: 1 against 2)
    and the published cube lacked the block. The interrupt is raised here exactly there."""
    real_fill, calls = store.fill, []

    def fill(cube, record):
        calls.append(record)
        if len(calls) == 2:   # the second finished block: journaled, not yet in the cube
            raise KeyboardInterrupt
        return real_fill(cube, record)

    monkeypatch.setattr(store, "fill", fill)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(SPEC, tmp_path, progress=False)
    monkeypatch.setattr(store, "fill", real_fill)
    plan = make_plan(parse_spec(SPEC))
    sweep = store.SweepDir(tmp_path, plan.sweep_id)
    kept = store.Journal(sweep.journal).files()
    row = store.Catalogue(tmp_path).get(plan.sweep_id)
    assert len(kept) >= 2, kept   # (the interrupted block was journaled)
    assert row["state"] == "cancelled" and row["done_blocks"] == len(kept), (row, kept)
    assert f"interrupted after {len(kept)}/{len(plan.blocks)} blocks" in row["message"], row
    assert sorted(done_blocks(plan, store.read_cube(sweep.cube))) == sorted(kept)


def test_a_ctrl_c_before_the_final_state_is_recorded_leaves_the_row_resumable(tmp_path,
                                                                            monkeypatch):
    """Every block computed and published, then a Ctrl-C before the final state is written
    (sweeps.run.submit.Submission.finish): the row stayed ``running`` under the dead
    process (read as stalled); now it reads cancelled with every block counted, and the
    next submit finishes it."""
    import sweeps.run.submit as submit_module

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(submit_module, "final_result", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(SPEC, tmp_path, progress=False)
    monkeypatch.undo()
    plan = make_plan(parse_spec(SPEC))
    row = store.Catalogue(tmp_path).get(plan.sweep_id)
    assert (row["state"], row["owner"], row["done_blocks"]) == \
        ("cancelled", "", len(plan.blocks)), row
    assert run_sweep(SPEC, tmp_path, progress=False).state == "done"


def test_the_failed_points_are_told_by_cause_with_what_to_do():
    """The summary of a partial run says why its points failed and what to do. It ended
    "(submit again to retry them)" whatever the cause: a stiff brought law that spent a
    draft point's 50-million-step budget in 93 s said only that, and a second submit failed
    the same points again (a newcomer's pass, 2026-11-29). A whole block's failure
    journals no work (0 evaluations); the integrator that gave up did some."""
    status = np.array([S.OK, S.FAILED, S.FAILED, S.NON_FINITE, S.FAILED, S.OK])
    evals = np.array([10, 300_000_008, 0, 50, 0, 12])
    cube = xr.Dataset({"status": ("p", status), "evals": ("p", evals)})
    assert failures_text(cube, "simulate") == (
        '4 of 6 points failed: 1 the integrator gave up (its step budget or step size: a '
        'stiff model? integrator = "rodas4"); 2 in blocks that failed (the warnings said '
        'why; submit again runs them again); 1 went non-finite (NaN or inf)')
    assert failures_text(cube, "averaged") == (
        "4 of 6 points failed: 3 had no averaged solution (its method did not converge, or "
        "omega <= 0); 1 went non-finite (NaN or inf)")


def test_a_refined_sweeps_inferred_failures_are_told_apart():
    """An inferred point copies its source's status with no work of its own (0 evaluations):
    it read as "in blocks that failed ... submit again" (a review)."""
    status = np.array([S.OK, S.FAILED, S.FAILED, S.OK])
    evals = np.array([10, 300_000_008, 0, 0])
    provenance = np.array([0, 0, 1, 1])   # store.flags: COMPUTED, INFERRED
    cube = xr.Dataset({"status": ("p", status), "evals": ("p", evals),
                       "provenance": ("p", provenance)})
    assert failures_text(cube, "simulate") == (
        '2 of 4 points failed: 1 the integrator gave up (its step budget or step size: a '
        'stiff model? integrator = "rodas4"); 1 inferred from failed points (refine = true)')
