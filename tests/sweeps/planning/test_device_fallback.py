"""A spec asking for ``device = "cuda"`` whose scene the GPU cannot run (the averaged and
harmonic-balance paths, the Rosenbrock solver: engine.gpu.unsupported) is the CPU's sweep:
its id, its cube's spec, and a line saying so (the command line prints it, also before
``--detach`` queues the CPU's sweep; ``run_sweep`` warns). Before, the Python API ran it on the CPU
without a word under a sweep id of its own, its cube's spec saying ``"device": "cuda"``."""
import json
import warnings

import pytest

import sweeps
from sweeps.planning.plan import make_plan
from sweeps.spec import SpecWarning, load_spec

SPEC = {"name": "avg-on-gpu", "friction": "lugre", "dither": "square-velocity",
        "method": "averaged", "grid": {"W": [0.0, 0.5], "v_ref": [0.1, 0.5], "v_d": [0.1]}}


def test_a_cpu_only_scene_asked_for_the_gpu_plans_as_the_cpu_sweep():
    cpu = make_plan(load_spec(SPEC))
    gpu = make_plan(load_spec({**SPEC, "device": "cuda"}))
    assert gpu.device_note.startswith("device cuda: the 'averaged' path has no time "
                                      "integration") and gpu.device_note.endswith(
        "this sweep runs on the CPU")
    assert gpu.sweep_id == cpu.sweep_id and gpu.spec.device == "cpu"
    assert not cpu.device_note


def test_run_sweep_warns_and_writes_the_cpu_cube(tmp_path):
    with pytest.warns(SpecWarning, match="this sweep runs on the CPU"):
        res = sweeps.run_sweep(SPEC, tmp_path / "store", device="cuda", progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SpecWarning)   # the CPU's own request: no word
        again = sweeps.run_sweep(SPEC, tmp_path / "store", progress=False)
    assert again.sweep_id == res.sweep_id and res.state == "done"
    with sweeps.open_sweep(res.sweep_id, tmp_path / "store") as ds:
        assert json.loads(ds.attrs["spec"])["device"] == "cpu"
