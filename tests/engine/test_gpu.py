"""The GPU target (engine/gpu.py, issue 36) without a GPU.

- numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, in a child process: numba reads it at
  import) runs the generated kernel of every case of tests/engine/gpu_cases.py: one thread a
  point, the per-thread settings record and scratch, the output and counter columns. In the
  simulator the engine's functions run as their CPU machine code, so the GPU path must equal
  the CPU block kernel bit for bit; on a GPU (its own exp and fused multiply-adds) the
  promise is the accuracy level's (scripts/gpu_check.py --run and bench_gpu.py compare there).
- The scratch a GPU thread allocates (Stepper.shapes) mirrors the CPU's ``alloc()``.
- No GPU: ``Settings(device="cuda")`` is one clear error; the Rosenbrock solver and the
  analysis paths say they stay on the CPU.

The device build's type check (PTX for a Hopper GPU, no GPU needed but the CUDA compiler)
is scripts/gpu_check.py, run where the ``gpu`` extra is installed.
"""
import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from engine import gpu
from engine import status as S
from engine.blocks import run_block
from engine.kernels import point_kernel
from tests.engine.common import scene
from tests.engine.gpu_cases import CASES, build

ROOT = Path(__file__).resolve().parents[2]

# one child for every case (the simulator is chosen at numba's import; a child each cost
# ~1.5 s of start-up per case): a JSON line per case, its error caught and sent as text
CHILD = """
import dataclasses, json, sys, traceback
import numpy as np
from engine.blocks import run_block
from tests.engine.gpu_cases import build

for case_id in sys.argv[1:]:
    try:
        scene, p, points, settings = build(case_id)
        cpu = run_block(scene, points, p, settings)
        dev = run_block(scene, points, p, dataclasses.replace(settings, device="cuda"))
    except Exception:
        print(json.dumps({"case": case_id, "error": traceback.format_exc()}), flush=True)
        continue
    print(json.dumps({
        "case": case_id,
        "equal": {k: bool(np.array_equal(cpu.outputs[k], dev.outputs[k], equal_nan=True))
                  for k in cpu.outputs},
        "finite": {k: bool(np.isfinite(cpu.outputs[k]).any()) for k in cpu.outputs},
        "status": [cpu.status.tolist(), dev.status.tolist()],
        "counters": [[cpu.steps.tolist(), cpu.rejected.tolist(), cpu.evals.tolist()],
                     [dev.steps.tolist(), dev.rejected.tolist(), dev.evals.tolist()]],
    }), flush=True)
"""


def _simulator_env() -> dict:
    """A child's environment: numba's CUDA simulator on (read at numba's import), this
    checkout first on the path."""
    return {**os.environ, "NUMBA_ENABLE_CUDASIM": "1",
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}


@pytest.fixture(scope="module")
def simulated():
    """Every case through the simulator in one child: ``(case -> its line, the child)``."""
    proc = subprocess.run([sys.executable, "-c", CHILD, *sorted(CASES)], capture_output=True,
                          text=True, env=_simulator_env(), cwd=ROOT, timeout=2400)
    lines = [json.loads(ln) for ln in proc.stdout.splitlines() if ln.startswith("{")]
    return {got["case"]: got for got in lines}, proc


@pytest.mark.long
@pytest.mark.subprocess
@pytest.mark.timeout(2400)   # the first case's setup compiles every case's CPU kernels
@pytest.mark.parametrize("case_id", sorted(CASES))
def test_the_simulated_gpu_kernel_equals_the_cpu_block_kernel(simulated, case_id):
    results, proc = simulated
    assert case_id in results, (proc.returncode, proc.stderr[-3000:])   # the child died
    got = results[case_id]
    assert "error" not in got, got.get("error")
    cpu_status, dev_status = got["status"]
    assert dev_status == cpu_status and all(s == 0 for s in cpu_status), got["status"]
    assert got["counters"][0] == got["counters"][1]
    assert all(got["equal"].values()), got["equal"]
    assert all(got["finite"].values()), got["finite"]   # the case computes real numbers


# a launch in which no thread writes its status (as on a GPU when device code raises: without
# debug=True the thread returns early and the error is dropped)
SILENT = """
import json
import numpy as np
from engine import gpu
from tests.engine.gpu_cases import build

scene, p, points, settings = build("lugre-square-rk4")
gpu._launch = lambda kernel, scene, grid, stream, args: None
out, status, counters, _ = gpu.run(scene, points, p, np.zeros(1))
print(json.dumps({"status": status.tolist(), "all_nan": bool(np.isnan(out).all())}))
"""


@pytest.mark.subprocess
def test_a_point_whose_thread_wrote_no_status_reads_failed_not_ok():
    """Before, the status array went to the GPU as zeros (OK): a brought model's ``raise``
    left its points OK with NaN outputs. Now FAILED until the thread writes the status."""
    proc = subprocess.run([sys.executable, "-c", SILENT], capture_output=True, text=True,
                          env=_simulator_env(), cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(proc.stdout)
    n = len(build("lugre-square-rk4")[2])   # the case's points (tests/engine/gpu_cases.py)
    assert got == {"status": [S.FAILED] * n, "all_nan": True}, got


def test_the_cases_cover_every_builtin_law_system_dither_and_gpu_method():
    """What the cases must cover (tests/engine/gpu_cases.py), held as they are changed to
    share another test's scene: each built-in law, system and dither kind, both methods a
    GPU runs, each effect flag off once, a vector-parameter law and a brought model."""
    from engine.dither import KINDS
    from engine.registry import LAW_NAMES, SYSTEM_NAMES, is_import_path

    scenes = [build(case_id)[0] for case_id in CASES]
    assert {s.friction for s in scenes} >= set(LAW_NAMES)
    assert {s.system for s in scenes} >= set(SYSTEM_NAMES)
    assert {s.dither for s in scenes} >= set(KINDS)
    assert {s.integrator for s in scenes} >= {"rk4", "dopri5"}
    for flag in ("stribeck", "bristle_damping", "viscous"):
        assert any(not getattr(s, flag) for s in scenes), flag
    assert any(s.sizes and max(n for _, n in s.sizes) > 1 for s in scenes)
    assert any(is_import_path(s.friction) for s in scenes)


@pytest.mark.parametrize("integrator", ["rk4", "dopri5"])
def test_the_gpu_scratch_mirrors_the_cpu_scratch(integrator):
    pk = point_kernel(scene(integrator=integrator))

    def shapes_of(work):
        return tuple(shapes_of(w) for w in work) if isinstance(work, tuple) else work.shape

    assert shapes_of(pk.alloc()) == pk.shapes


def test_the_kernel_source_zeroes_every_scratch_array():
    text = gpu.kernel_source(((7, 4), (1, 4)), n=4, obs_size=0, n_out=2, n_params=30)
    assert "cuda.local.array((7, 4), float64)" in text and text.count("= 0.0") == 2
    assert "obs[:0]" in text and "cuda.local.array(30, float64)" in text
    nested = gpu.kernel_source((((7, 4), (1, 4)), (5, 4), (3,)), 4, 3, 2, 30)
    assert "((w_0_0, w_0_1), w_1, w_2)" in nested


def test_without_a_gpu_the_cuda_device_is_one_clear_error():
    if gpu.simulated():
        pytest.skip("this process runs under the CUDA simulator")
    sc, p, points, settings = build("lugre-square-rk4")
    with pytest.raises(gpu.NoGPU, match=r"no CUDA GPU here .* run without --device cuda"):
        run_block(sc, points, p, dataclasses.replace(settings, device="cuda"))
    with pytest.raises(ValueError, match=r"device: expected one of \('cpu', 'cuda'\)"):
        dataclasses.replace(settings, device="gpu")


def test_a_gpu_the_driver_lists_but_cannot_open_is_one_clear_error(monkeypatch):
    """``is_available()`` True, ``get_current_device()`` failing (a driver or container
    mismatch): before, the exception went up as it was (``submit``: "internal error", exit
    1); now NoGPU, which ``submit --device cuda`` turns into one line, exit 2."""
    if gpu.simulated():
        pytest.skip("this process runs under the CUDA simulator")
    from numba import cuda

    def cannot_open():
        raise RuntimeError("CUDA_ERROR_NO_DEVICE")

    monkeypatch.setattr(cuda, "is_available", lambda: True)
    monkeypatch.setattr(cuda, "get_current_device", cannot_open)
    with pytest.raises(gpu.NoGPU, match=r"listed but cannot be opened \(RuntimeError: "
                                        r"CUDA_ERROR_NO_DEVICE\); run without --device cuda"):
        gpu.check_device()


def test_what_stays_on_the_cpu_says_why():
    assert gpu.unsupported(scene(integrator="rk4")) is None
    assert "runs on the CPU only" in gpu.unsupported(scene(integrator="rosenbrock"))
    assert "no time integration" in gpu.unsupported(scene().with_(path="averaged"))
    with pytest.raises(ValueError, match="device cuda: the 'rodas4' integrator"):
        gpu.block_kernel(scene(integrator="rosenbrock"))


def test_the_gpu_runs_points_by_omega_then_amplitude_highest_first():
    """engine.gpu.cost_order: a warp's threads get similar costs (that the results come back
    in the caller's order is the simulator test's: its points are not sorted by omega)."""
    order = gpu.cost_order(np.array([[0.1, 300.0, 0.4, 0.1], [0.1, 10.0, 0.4, 0.1],
                                     [0.1, 100.0, 0.4, 0.1], [3.0, 100.0, 0.4, 0.1],
                                     [0.0, 300.0, 0.4, 0.1]]))
    assert order.tolist() == [0, 4, 3, 2, 1]
