"""A sweep on the GPU on a dask cluster goes to its GPU workers (issue 36,
sweeps.workers.matching): workers started with ``--resources GPU=1``.

The GPU worker runs under numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1`` in its
environment: the real kernel, no GPU); the submitter has no GPU at all. Every block and
every error-estimate re-run is computed by the GPU worker, none by the plain worker beside
it, and the cube equals the CPU sweep's (the simulator runs the engine's CPU machine code).
A cluster without a GPU worker is one line, nothing computed.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import store
import sweeps

from ..helpers import SIMULATE_OUTPUTS
from .test_foreign_worker import scheduler  # noqa: F401 -- the fixture

pytestmark = [pytest.mark.long, pytest.mark.cluster, pytest.mark.subprocess]

SPEC = {"name": "gpu-workers", "friction": "lugre", "dither": "square-velocity",
        "outputs": list(SIMULATE_OUTPUTS),
        "accuracy": "draft", "block_size": 2,
        "device": "cuda", "time": {"t_end": 0.5, "t_transient": 0.1},
        "grid": {"W": [0.0, 0.2, 0.4, 0.6], "omega": [200.0], "v_ref": [0.3]}}


def _env(log: Path, gpu: bool) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    return env | {"DITHERLAB_BLOCK_LOG": str(log)} | ({"NUMBA_ENABLE_CUDASIM": "1"} if gpu
                                                       else {})


def _submit(tmp_path, address, store_dir):
    spec = tmp_path / "gpu.json"
    spec.write_text(json.dumps(SPEC))
    return subprocess.run([str(Path(sys.executable).parent / "ditherlab"), "submit", str(spec),
                           "--store", str(store_dir), "--scheduler", address, "-q"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=900,
                          env=_env(tmp_path / "submitter.log", gpu=False))


def test_the_gpu_workers_compute_every_block_and_the_cube_is_the_cpus(  # noqa: F811
        scheduler, tmp_path):
    address, start, _ = scheduler
    gpu_log, cpu_log = tmp_path / "gpu-worker.log", tmp_path / "cpu-worker.log"
    start(_env(cpu_log, gpu=False), 0)
    start(_env(gpu_log, gpu=True), 1, "--resources", "GPU=1")
    out = _submit(tmp_path, address, tmp_path / "store")
    assert out.returncode == 0, out.stderr
    assert not cpu_log.exists(), "the worker without a GPU computed a block"
    assert len(gpu_log.read_text().splitlines()) >= 2   # 2 blocks (and the re-runs)
    assert not (tmp_path / "submitter.log").exists()
    path = [ln.split("cube: ")[1] for ln in out.stdout.splitlines() if ln.startswith("cube: ")]
    res = sweeps.run_sweep({**SPEC, "device": "cpu"}, store=tmp_path / "cpu", workers=1,
                           progress=False)
    with xr.open_dataset(path[0], engine="h5netcdf") as g, \
            xr.open_dataset(res.cube_path, engine="h5netcdf") as cpu:
        assert json.loads(g.attrs["engine_settings"])["device"] == "cuda"
        assert (g["status"] == 0).all()
        for name in SPEC["outputs"]:
            assert np.array_equal(g[name].values, cpu[name].values, equal_nan=True), name


def test_without_a_gpu_worker_the_gpu_sweep_is_one_line(scheduler, tmp_path):  # noqa: F811
    address, start, _ = scheduler
    cpu_log = tmp_path / "cpu-worker.log"
    start(_env(cpu_log, gpu=False), 0)
    out = _submit(tmp_path, address, tmp_path / "store")
    assert out.returncode == 1, out.stderr
    lines = out.stderr.strip().splitlines()
    assert "Traceback" not in out.stderr and len(lines) == 1, out.stderr
    assert lines[0].startswith("ditherlab: device cuda: none of the 1 workers of this "
                               "cluster has a GPU resource, nothing was computed"), lines[0]
    assert "--resources GPU=1" in lines[0]
    assert not cpu_log.exists()
    sweep = store.SweepDir(tmp_path / "store", sweeps.load_spec(SPEC).sweep_id)
    assert not store.Journal(sweep.journal).files()
