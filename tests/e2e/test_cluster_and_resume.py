"""The same sweep on an external dask cluster, and crash/resume of the submitter
(DESIGN.md §4-5): a `dask scheduler` and two `dask worker` processes on loopback, stopped by
process id; a submitter killed with SIGKILL part-way leaves a readable cube and a journal
from which the next submit runs only the missing blocks."""
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import store
from sweeps.spec import load_spec

from ..helpers import BIN, SIMULATE_SPEC, assert_same_results, ditherlab, results, wait_for

pytestmark = [pytest.mark.long, pytest.mark.cluster, pytest.mark.subprocess]
# dask clusters and resumes

DASK = Path(sys.executable).parent / "dask"
def test_external_cluster_gives_the_local_cube(tmp_path, spec_file):
    path = spec_file(SIMULATE_SPEC)
    spec = load_spec(path)
    local, remote = tmp_path / "local", tmp_path / "remote"
    ditherlab("submit", str(path), "--quiet", store=local, check=True)

    sched_file = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--no-dashboard", "--scheduler-file", str(sched_file)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        wait_for(sched_file.exists, "the scheduler file", 60)
        for _ in range(2):
            procs.append(subprocess.Popen(
                [str(DASK), "worker", "--scheduler-file", str(sched_file), "--nthreads", "1",
                 "--no-dashboard", "--host", "127.0.0.1"],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        address = json.loads(sched_file.read_text())["address"]
        from distributed import Client
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        proc = ditherlab("submit", str(path), "--scheduler", address, "--quiet", store=remote,
                         check=True)
        assert "done" in proc.stdout
    finally:
        for p in procs:
            os.kill(p.pid, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.kill(p.pid, signal.SIGKILL)
    cube = f"{spec.sweep_id}/cube.nc"
    assert_same_results(results(local / cube), results(remote / cube))


# 32 one-point blocks of ~0.1-0.3 s each: long enough to be killed mid-flight
RESUME_SPEC = SIMULATE_SPEC.replace("block_size = 2", "block_size = 1").replace(
    "t_end = 12.0", "t_end = 300.0").replace(
    'accuracy = "draft"', 'accuracy = "standard"').replace(
    "W = [0.0, 0.2, 0.4, 0.6]", "W = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]").replace(
    "v_ref = [0.4]", "v_ref = [0.3, 0.4]")


def test_kill_9_then_resume_equals_clean_run(tmp_path, spec_file, env, gate):
    """SIGKILL after three blocks, the others held at the gate (certainly mid-run)."""
    path = spec_file(RESUME_SPEC)
    spec = load_spec(path)
    crashed, clean = tmp_path / "crashed", tmp_path / "clean"
    journal = crashed / spec.sweep_id / "journal"
    proc = subprocess.Popen([str(BIN), "submit", str(path), "--quiet", "--store", str(crashed)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                            start_new_session=True)
    n_blocks = 32
    gate.let(3)
    done = lambda: len(store.Journal(journal).files())   # journaled blocks
    wait_for(lambda: done() >= 3 or proc.poll() is not None, "three journaled blocks", 300,
             poll=0.02)
    os.killpg(proc.pid, signal.SIGKILL)  # the submitter and its local cluster, mid-flight
    proc.wait()
    gate.open()
    before = done()
    assert before == 3, f"{before} blocks done before the kill"

    cube = crashed / spec.sweep_id / "cube.nc"
    with xr.open_dataset(cube, engine="h5netcdf") as ds:   # the published cube is readable
        assert set(np.unique(ds["status"].values)) <= {0, 1}
    # the catalogue row still says running, but its owner is dead: status says stalled
    listing = ditherlab("status", store=crashed, check=True).stdout
    assert f"{spec.sweep_id[:12]}" in listing and "stalled" in listing, listing
    detail = ditherlab("status", spec.sweep_id, store=crashed, check=True).stdout
    assert "state: stalled" in detail and "submit the spec again to resume" in detail, detail

    resumed = ditherlab("submit", str(path), "--quiet", store=crashed, check=True)
    ran = int(resumed.stdout.split("ran ")[1].split(" blocks")[0])
    assert ran == n_blocks - before, resumed.stdout
    detail = ditherlab("status", spec.sweep_id, store=crashed, check=True).stdout
    assert "state: done" in detail and "owner: \n" in detail + "\n", detail
    ditherlab("submit", str(path), "--quiet", store=clean, check=True)
    assert_same_results(results(cube), results(clean / spec.sweep_id / "cube.nc"))
