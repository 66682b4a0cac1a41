"""A worker that runs another engine gets no block (DESIGN.md §5, sweeps.workers.matching).

Found as a new user would: a `dask scheduler` with one `dask worker` importing a copy of
the package whose friction law is scaled by 1.001 (started from a folder outside the
checkout, the copy first on its PYTHONPATH; `python -m` puts the current folder first on
sys.path). `ditherlab submit SPEC --scheduler ADDR` of an 8-point LuGre sweep exited 0
with "8/8 ok" and every F_mean, v_mean and v_slow_p2p off (F_mean 1.0664247 against
1.0653299 at W = 0, this module's spec at t_end 20). Now: alone, that worker computes
nothing and the submit says why in one line (exit 1, nothing journaled); beside a good
worker, it computes nothing, a warning names it, and the cube equals a clean local run's.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import store
import sweeps
from sweeps.version import results_fingerprint

from ..helpers import wait_for
from .test_hpc import _wait_for_workers, _written

pytestmark = [pytest.mark.long, pytest.mark.cluster, pytest.mark.subprocess]
# dask workers of another engine

ROOT = Path(__file__).resolve().parents[2]
SPEC = {"name": "foreign", "friction": "lugre", "dither": "square-velocity",
        "outputs": ["F_mean", "v_mean", "v_slow_p2p"], "accuracy": "draft", "block_size": 1,
        "time": {"t_end": 4.0, "t_transient": 1.0},
        "grid": {"W": [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7], "omega": [200.0],
                 "v_ref": [0.2]}}


def _scaled_copy(dest: Path) -> Path:
    """The package with its friction force scaled by 1.001, in ``dest``."""
    for name in ("engine", "sweeps", "store"):
        shutil.copytree(ROOT / name, dest / name, ignore=shutil.ignore_patterns("__pycache__"))
    lugre = dest / "engine" / "friction" / "lugre.py"
    text = lugre.read_text()
    assert text.count("        return F\n") == 1, "the force's return line moved: update the test"
    lugre.write_text(text.replace("        return F\n", "        return F * 1.001\n"))
    return dest


def _fingerprint_of(pythonpath: Path, cwd: Path) -> str:
    out = subprocess.run([sys.executable, "-c", "from sweeps.version import "
                          "results_fingerprint as f; print(f())"], cwd=cwd, text=True,
                         capture_output=True, env={**os.environ, "PYTHONPATH": str(pythonpath)},
                         check=True, timeout=120)
    return out.stdout.strip()


@pytest.fixture
def scheduler(tmp_path):
    """A scheduler and the workers a test adds (``start(env, n_before, *worker_options)``),
    stopped at the end."""
    elsewhere = tmp_path / "elsewhere"   # outside the checkout: no package beside the cwd
    elsewhere.mkdir()
    sched_file = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                               "--host", "127.0.0.1", "--port", "0", "--dashboard-address",
                               "127.0.0.1:0", "--scheduler-file", str(sched_file)],
                              cwd=elsewhere, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]

    def start(env: dict, n_before: int, *options: str) -> None:
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
             "--host", "127.0.0.1", "--no-dashboard", *options], cwd=elsewhere, env=env,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        _wait_for_workers(address, n_before + 1)

    try:
        address = wait_for(lambda: _written(sched_file), f"{sched_file} written", 120,
                           process=procs[0])["address"]
        yield address, start, elsewhere
    finally:
        for p in procs[::-1]:
            p.terminate()
        for p in procs:
            p.wait(timeout=60)


def _submit(tmp_path, address, store_dir):
    spec = tmp_path / "foreign.json"
    spec.write_text(json.dumps(SPEC))
    return subprocess.run([str(Path(sys.executable).parent / "ditherlab"), "submit", str(spec),
                           "--store", str(store_dir), "--scheduler", address, "-q"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=900)


def _foreign_env(tmp_path, elsewhere):
    copy = _scaled_copy(tmp_path / "copy")
    log = tmp_path / "foreign-blocks.log"
    env = {**os.environ, "PYTHONPATH": str(copy), "DITHERLAB_BLOCK_LOG": str(log)}
    fingerprint = _fingerprint_of(copy, elsewhere)
    assert fingerprint != results_fingerprint()
    return env, fingerprint, log


def test_alone_a_foreign_worker_computes_nothing_and_is_named(scheduler, tmp_path):
    address, start, elsewhere = scheduler
    env, fingerprint, log = _foreign_env(tmp_path, elsewhere)
    start(env, 0)
    out = _submit(tmp_path, address, tmp_path / "store")
    assert out.returncode == 1, out.stderr
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("ditherlab: no worker runs this engine, nothing was computed")
    assert fingerprint in last and results_fingerprint() in last and "tcp://127.0.0.1:" in last
    assert not log.exists(), "the foreign worker computed a block"
    sweep = store.SweepDir(tmp_path / "store", sweeps.load_spec(SPEC).sweep_id)
    assert not store.Journal(sweep.journal).files()


def test_beside_a_good_worker_it_computes_nothing_and_the_cube_is_clean(scheduler, tmp_path):
    address, start, elsewhere = scheduler
    env, fingerprint, log = _foreign_env(tmp_path, elsewhere)
    start(env, 0)
    start(dict(os.environ), 1)
    out = _submit(tmp_path, address, tmp_path / "store")
    assert out.returncode == 0, out.stderr
    named = [ln for ln in out.stderr.splitlines() if "another engine" in ln]
    assert len(named) == 1 and fingerprint in named[0] and "gets no block" in named[0], out.stderr
    assert not log.exists(), "the foreign worker computed a block"
    key = sweeps.load_spec(SPEC).sweep_id
    journal = store.Journal(store.SweepDir(tmp_path / "store", key).journal)
    assert {journal.load(b).fingerprint for b in journal.files()} == {results_fingerprint()}
    remote = sweeps.open_sweep(key, store=tmp_path / "store")
    sweeps.run_sweep(SPEC, store=tmp_path / "local", workers=1, progress=False)
    local = sweeps.open_sweep(key, store=tmp_path / "local")
    for name in SPEC["outputs"]:
        np.testing.assert_array_equal(remote[name].values, local[name].values)


def test_the_sink_never_journals_a_block_of_another_engine(tmp_path):
    """The last line of defence, whatever the dispatch did: a block whose result carries
    another fingerprint is not journaled and its points stay to compute; one with this
    engine's is journaled with it."""
    from sweeps.planning.plan import make_plan
    from sweeps.run.lease_holder import Lease
    from sweeps.run.new_cube import empty_cube
    from sweeps.run.sink import BlockSink

    plan = make_plan(sweeps.load_spec(SPEC))
    sweep = store.SweepDir(tmp_path, plan.sweep_id)
    sweep.root.mkdir(parents=True)
    catalogue = store.Catalogue(tmp_path)
    catalogue.register(plan.sweep_id, plan.spec.name, plan.spec.to_json(), plan.n_points,
                       len(plan.blocks), sweep.root, results_fingerprint())
    lease, _ = Lease.take(catalogue, plan.sweep_id, None, None)
    journal = store.Journal(sweep.journal)
    sink = BlockSink(plan, empty_cube(plan), journal, sweep, lease)

    def result(b, fingerprint):
        n = len(plan.blocks[b])
        return store.BlockRecord(plan.blocks[b], np.zeros(n), np.zeros(n), np.ones(n),
                                 np.ones(n), {k: np.full(n, 0.5) for k in plan.outputs},
                                 fingerprint=fingerprint)

    sink.many([(0, result(0, "0123456789ab")), (1, result(1, results_fingerprint())),
               (2, result(2, None))])
    lease.end("failed")
    assert sorted(journal.files()) == [1] and sink.foreign_blocks == 2
    assert journal.load(1).fingerprint == results_fingerprint()
    status = sink.cube["status"].values.ravel()
    assert (status[plan.blocks[0]] != 0).all() and (status[plan.blocks[1]] == 0).all()
