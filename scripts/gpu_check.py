"""Compile the GPU kernel of every scene variant for a Hopper GPU (PTX, compute capability
9.0) without a GPU: the type check of the device build that the CUDA simulator cannot give
(the simulator runs the engine's CPU machine code; tests/engine/test_gpu.py).

    .venv/bin/pip install -e '.[gpu]'          # numba-cuda with the CUDA compiler (NVVM)
    .venv/bin/python scripts/gpu_check.py     # every case of tests/engine/gpu_cases.py
    .venv/bin/python scripts/gpu_check.py lugre-square-rk4 gms-servo-sine-velocity-dopri5
    python3 scripts/gpu_check.py --run [--jobs N] [CASE ...]   # on a GPU: run there and on the CPU

numba.cuda asks the current device for its compute capability when it compiles a device
function (``numba.cuda.dispatcher.CUDADispatcher.compile_device``); with no device here a
stand-in answers (9, 0) for this process. Prints one line per case (PTX size, seconds) and
exits 1 when one fails to compile, naming the construct numba.cuda refused (e.g. a numpy
ufunc such as ``np.exp``, which numba.cuda does not lower: kernels use ``math``).

``--run`` (on a machine with a GPU) runs each case's points on the GPU and on the CPU
instead, each case in its own process (``--jobs N`` at a time), and prints the statuses, the
step counts and the largest relative difference per output; it exits 1 when a status
differs or a difference exceeds the case's tolerance: ``FIXED_TOL`` relative for a
fixed-step method on a continuous law (the issue's 1e-9: the same steps, only the GPU's
``exp`` and fused multiply-adds differ); otherwise the standard level's promise for the output
(``sweeps.spec.accuracy.promise``, docs/ACCURACY.md 5.1; the cases run at rtol 1e-6), on
``|gpu - cpu| / max(|cpu|, 1)``: rounding moves an accept/reject decision, and from there
the two runs take other steps, each within what the step control keeps (seen on an H200:
2e-6 on v_slow_p2p, 714 against 722 evaluations). The static laws (coulomb, stribeck) are
discontinuous at the edge of their stick band, so a rounding-level difference there books
a step as stuck on one device and sliding on the other: fixed-step RK4 on the Coulomb
slider differed by 2.2e-5 in v_mean on an H200 (the same steps), inside the promise.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
CC = (9, 0)
FIXED_TOL = 1e-9


def run_case(case_id: str) -> tuple[bool, str]:
    """One case on the GPU and the CPU: ``(agrees, what was seen)``."""
    import dataclasses

    import numpy as np

    from engine.blocks import run_block
    from sweeps.spec.accuracy import STATIC_LAWS, promise
    from tests.engine.gpu_cases import build

    scene, p, points, settings = build(case_id)
    cpu = run_block(scene, points, p, settings)
    t0 = time.perf_counter()
    dev = run_block(scene, points, p, dataclasses.replace(settings, device="cuda"))
    seconds = time.perf_counter() - t0
    fixed = scene.integrator == "rk4" and scene.friction not in STATIC_LAWS
    worst, over = {}, []
    for name, c in cpu.outputs.items():
        g = dev.outputs[name]
        both = np.isfinite(c) & np.isfinite(g)
        scale = np.maximum(np.abs(c[both]), 1e-12 if fixed else 1.0)
        diff = np.abs(g[both] - c[both]) / scale
        worst[name] = float(diff.max()) if diff.size else 0.0
        if not np.array_equal(np.isfinite(c), np.isfinite(g)):
            worst[name] = float("inf")
        tol = FIXED_TOL if fixed else promise("standard", name, scene.friction)
        if worst[name] > tol:
            over.append(f"{name} {worst[name]:.1e} > {tol:.0e}")
    same_status = np.array_equal(cpu.status, dev.status)
    top = max(worst, key=worst.get)
    seen = (f"first launch {seconds:5.1f} s, status {'same' if same_status else 'DIFFERS'}, "
            f"evaluations cpu {cpu.evals.tolist()} gpu {dev.evals.tolist()}, "
            f"largest diff {worst[top]:.1e} ({top}{'; over: ' + ', '.join(over) if over else ''})")
    return same_status and not over, seen


def run_cases(case_ids: list[str], jobs: int) -> int:
    """``--run``: each case in a child process, ``jobs`` at a time; the failures."""
    import subprocess
    from concurrent.futures import ThreadPoolExecutor

    def child(case_id):
        proc = subprocess.run([sys.executable, __file__, "--one", case_id],
                              capture_output=True, text=True)
        lines = proc.stdout.strip().splitlines()
        if proc.returncode > 1 or not lines:
            tail = (proc.stderr.strip().splitlines() or ["?"])[-1]
            return False, f"{case_id:40s} BAD FAILED: {tail[:200]}"
        return proc.returncode == 0, lines[-1]

    failed = 0
    with ThreadPoolExecutor(max(1, jobs)) as pool:
        for ok, line in pool.map(child, case_ids):
            failed += not ok
            print(line, flush=True)
    return failed


def _stand_in_device() -> None:
    """Answer numba.cuda's compute-capability question when no GPU is present."""
    from numba import cuda
    from numba.cuda import dispatcher

    if cuda.is_available():
        return

    class Device:
        compute_capability = CC

    dispatcher.get_current_device = lambda: Device()


def signature(scene, p, cfg):
    """The kernel's argument types (engine.gpu.block_kernel's launch)."""
    from numba.core import types
    from numba.np.numpy_support import from_dtype

    f8 = types.float64
    return (f8[:, ::1], f8[::1], from_dtype(cfg.dtype)[::1], f8[:, ::1], f8[:, ::1],
            types.int8[::1], types.int64[:, ::1])


def compile_case(case_id: str) -> int:
    """PTX of one case's kernel (its length)."""
    from numba import cuda

    from engine import gpu
    from engine.kernels import make_config, point_kernel
    from tests.engine.gpu_cases import build

    scene, p, _, settings = build(case_id)
    gpu._numpy_removed_names()
    why = gpu.unsupported(scene)
    if why:
        raise ValueError(why)
    pk = point_kernel(scene)
    source = gpu.kernel_source(pk.shapes, pk.n, pk.obs_size, pk.n_out, scene.n_params)
    namespace = gpu.kernel_namespace(pk)
    exec(compile(source, f"<gpu_check {case_id}>", "exec"), namespace)
    ptx, _ = cuda.compile_ptx(namespace["block"], signature(scene, p, make_config(settings)),
                              cc=CC)
    return len(ptx)


def main(argv: list[str]) -> int:
    from tests.engine.gpu_cases import CASES

    if argv[:1] == ["--one"]:   # a child of --run
        try:
            ok, seen = run_case(argv[1])
        except Exception as exc:   # noqa: BLE001 -- one line, exit 1
            ok, seen = False, f"FAILED {type(exc).__name__}: {str(exc)[:200]}"
        print(f"{argv[1]:40s} {'ok ' if ok else 'BAD'} {seen}", flush=True)
        return 0 if ok else 1
    if argv[:1] == ["--run"]:
        jobs = int(argv[2]) if argv[1:2] == ["--jobs"] else 1
        rest = argv[3:] if argv[1:2] == ["--jobs"] else argv[1:]
        return 1 if run_cases(rest or list(CASES), jobs) else 0
    _stand_in_device()
    failed = 0
    for case_id in argv or list(CASES):
        t0 = time.perf_counter()
        try:
            size = compile_case(case_id)
        except Exception as exc:   # noqa: BLE001 -- report every case, then exit 1
            failed += 1
            first = str(exc).strip().splitlines()
            print(f"{case_id:40s} FAILED {type(exc).__name__}: {first[0] if first else ''}",
                  flush=True)
            continue
        print(f"{case_id:40s} ptx {size / 1e3:7.0f} kB  {time.perf_counter() - t0:5.1f} s",
              flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
