"""A sweep on a cluster started the way a batch system starts one (README "On an HPC
cluster"): a `dask scheduler` process writing a scheduler file, `dask worker` processes
reading it (what a SLURM job script, or dask-jobqueue's SLURMCluster, runs), a kernel cache
shared through $DITHERLAB_CACHE_DIR, and `ditherlab submit --scheduler ADDRESS`."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from distributed import Client

import sweeps
from engine.jit import cache_dir

from ..helpers import SIMULATE_OUTPUTS, wait_for

pytestmark = [pytest.mark.long, pytest.mark.cluster, pytest.mark.subprocess]
# a dask scheduler and workers started by hand

# the scene of tests/helpers.py's SIMULATE_SPEC: its kernels are compiled once for both
SPEC = {"name": "hpc", "friction": "lugre", "dither": "square-velocity",
        "outputs": list(SIMULATE_OUTPUTS),
        "accuracy": "draft", "time": {"t_end": 4.0, "t_transient": 1.0},
        "grid": {"W": [0.0, 0.3], "omega": [200.0], "v_ref": [0.2, 0.4]}}


def _written(path) -> dict | None:
    """The JSON at ``path`` once it is written, else None."""
    text = path.read_text() if path.exists() else ""
    return json.loads(text) if text.strip() else None


def _wait_for_workers(address: str, n: int, seconds=120.0) -> None:
    with Client(address, timeout="30s") as client:
        client.wait_for_workers(n, timeout=seconds)


@pytest.fixture
def batch_cluster(tmp_path):
    shared = tmp_path / "shared-cache"
    # the folder a site shares between its jobs, holding what earlier jobs compiled: here a
    # copy of this test run's kernel cache (its other tests compile this scene), so the
    # workers load the kernels instead of compiling them again (24 s of a CI run's CPU)
    ours = cache_dir()
    if ours.is_dir():
        shutil.copytree(ours, shared / ours.name, ignore=shutil.ignore_patterns("compiling"))
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(shared)}
    sched_file = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                               "--port", "0", "--dashboard-address", ":0",
                               "--scheduler-file", str(sched_file)], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        address = wait_for(lambda: _written(sched_file), f"{sched_file} written", 120,
                           process=procs[0])["address"]
        procs += [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker",
                                    "--scheduler-file", str(sched_file), "--nthreads", "1",
                                    "--nworkers", "1", "--no-dashboard"], env=env,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                  for _ in range(2)]
        _wait_for_workers(address, 2)
        yield address, env
    finally:
        for p in procs[::-1]:
            p.terminate()
        for p in procs:
            p.wait(timeout=60)


def test_submit_to_batch_started_workers(batch_cluster, tmp_path):
    address, env = batch_cluster
    spec = tmp_path / "hpc.json"
    spec.write_text(json.dumps(SPEC))
    out = subprocess.run([sys.executable, "-m", "sweeps.cli", "submit", str(spec), "--store",
                          str(tmp_path / "store"), "--scheduler", address, "-q"],
                         capture_output=True, text=True, timeout=600, env=env)
    assert out.returncode == 0, out.stderr
    assert "done" in out.stdout and "4/4 ok" in out.stdout
    # the batch-started workers use the shared kernel cache ($DITHERLAB_CACHE_DIR)
    with Client(address, timeout="30s") as client:
        where = client.run(lambda: str(__import__("engine.jit").jit.cache_dir()))
    assert len(where) == 2 and all(Path(w) == tmp_path / "shared-cache" / cache_dir().name
                                   for w in where.values()), where
    # the numbers equal those of the service's own local cluster
    key = sweeps.load_spec(SPEC).sweep_id
    remote = sweeps.open_sweep(key, store=tmp_path / "store")
    sweeps.run_sweep(SPEC, store=tmp_path / "local", workers=1, progress=False)
    local = sweeps.open_sweep(key, store=tmp_path / "local")
    for name in SPEC["outputs"]:
        np.testing.assert_array_equal(remote[name].values, local[name].values)
