"""Compile the GPU kernel of every scene variant for a Hopper GPU (PTX, compute capability
9.0) without a GPU: the type check of the device build that the CUDA simulator cannot give
(the simulator runs the engine's CPU machine code; tests/engine/test_gpu.py).

    .venv/bin/pip install -e '.[gpu]'          # numba-cuda with the CUDA compiler (NVVM)
    .venv/bin/python scripts/gpu_check.py     # every case of tests/engine/gpu_cases.py
    .venv/bin/python scripts/gpu_check.py lugre-square-rk4 gms-servo-sine-velocity-dopri5

numba.cuda asks the current device for its compute capability when it compiles a device
function (``numba.cuda.dispatcher.CUDADispatcher.compile_device``); with no device here a
stand-in answers (9, 0) for this process. Prints one line per case (PTX size, seconds) and
exits 1 when one fails to compile, naming the construct numba.cuda refused (e.g. a numpy
ufunc such as ``np.exp``, which numba.cuda does not lower: kernels use ``math``).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
CC = (9, 0)


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
