"""The GPU target: the engine's own kernels compiled by numba.cuda, one thread a point.

There is no second copy of the physics. A scene's point integrator
(:func:`engine.kernels.point_kernel`: system, friction law, dither, observables, method,
all ``njit`` closures) is called from a CUDA kernel; numba.cuda compiles every ``njit``
function it reaches for the GPU (``numba.cuda.target.CUDATypingContext.resolve_value_type``
turns a CPU dispatcher into a device function), float64 throughout. What differs per target
is only where a point's scratch lives: the CPU block kernel allocates it once per block with
numpy, a GPU thread takes it from its local memory, shaped by the method's
:attr:`engine.integrators.Stepper.shapes` and zeroed. The kernel's source is generated from
those shapes (:func:`engine.gpu_source.kernel_source`), since ``cuda.local.array`` wants
literal shapes.

Each thread reads its point's row of ``points``, overrides the four grid columns of a local
copy of ``p`` and runs ``run_point`` with its own settings record (the driver writes the
per-point fixed step and tolerances into it). Methods without ``shapes`` (the Rosenbrock
solver: dense ``n x n`` matrices) stay on the CPU: :func:`unsupported` says why.

The GPU's float64 differs from the CPU's in its ``exp``/``pow`` and in fused multiply-adds,
so a GPU cube agrees with a CPU cube within the accuracy level, not bit for bit
(``../shared/recipes/gpu.md``: 8e-14 on a fixed-step LuGre trajectory).

``NUMBA_ENABLE_CUDASIM=1`` runs the same kernel in numba's CUDA simulator (no GPU, slow):
the tests' way to check the kernel's indexing and scratch handling without a GPU.
"""
from __future__ import annotations

import math
import os
import threading
from functools import cache

import numpy as np

from . import status as S
from .deep_stack import on_a_deep_stack
from .gpu_source import kernel_namespace, kernel_source, simulated
from .kernels import method_module, point_kernel

THREADS_PER_BLOCK = 128   # a CUDA block of threads (points); 4 warps
MAX_REGISTERS = 0         # a cap on a thread's registers (0: ptxas chooses; Fig. 14's
#                           kernel takes 184, the anchors' 119: scripts/bench_gpu.py --regs)


class NoGPU(RuntimeError):
    """No usable CUDA device (or no numba.cuda): the message says what to do."""


def _numpy_removed_names() -> None:
    """Alias the names numpy 2.5 removed and numba-cuda 0.30 still registers overloads for:
    without them its first kernel compile fails with ``AttributeError: module 'numpy' has no
    attribute 'row_stack'`` (``../shared/recipes/gpu.md``, seen on a lent machine)."""
    for old, new in (("row_stack", "vstack"), ("trapz", "trapezoid"), ("in1d", "isin")):
        if not hasattr(np, old) and hasattr(np, new):
            setattr(np, old, getattr(np, new))


def _no_small_grid_warning() -> None:
    """A small launch (the error estimate's re-runs, a warm-up, a small sweep) is wanted:
    numba-cuda's "Grid size N will likely result in GPU under-utilization" is no news to the
    user. Its own switch, set in the environment too (numba re-reads its config when the
    environment changes); a ``warnings`` filter around the launch is not thread-safe and let
    the warning through on a lent H200 (docs/measured/h200-2026-11-27.txt). Process-wide:
    the warning is off for the caller's own kernels too, and setting a ``NUMBA_*`` variable
    makes numba's next config reload re-read them all from the environment (which would
    reset numba's cache folder: engine.jit.njit sets it again before each kernel it makes)."""
    os.environ["NUMBA_CUDA_LOW_OCCUPANCY_WARNINGS"] = "0"
    try:
        from numba.cuda.core import config
    except ImportError:   # another numba-cuda layout, or the simulator's
        return
    config.CUDA_LOW_OCCUPANCY_WARNINGS = 0


def check_device() -> str:
    """The GPU's name (``"simulator"`` under the CUDA simulator); :class:`NoGPU` if none."""
    try:
        from numba import cuda
    except ImportError as exc:   # pragma: no cover -- numba ships numba.cuda
        raise NoGPU(f"numba.cuda cannot be imported ({exc}); "
                    "install the GPU extra: pip install -e '.[gpu]'") from None
    if simulated():
        return "simulator"
    try:
        available = cuda.is_available()
    except Exception:   # noqa: BLE001 -- a broken driver install answers with any error
        available = False
    if not available:
        raise NoGPU("no CUDA GPU here (numba.cuda.is_available() is False): run without "
                    "--device cuda, or on a machine with an NVIDIA GPU and "
                    "pip install -e '.[gpu]'")
    try:
        dev = cuda.get_current_device()
        name = dev.name.decode() if isinstance(dev.name, bytes) else str(dev.name)
        major, minor = dev.compute_capability
    except Exception as exc:   # noqa: BLE001 -- a driver that lists a GPU it cannot open
        raise NoGPU(f"a CUDA GPU is listed but cannot be opened ({type(exc).__name__}: "
                    f"{exc}); run without --device cuda, or check the driver (nvidia-smi)"
                    ) from None
    return f"{name} (cc {major}.{minor})"


def unsupported(scene) -> str | None:
    """Why ``scene`` cannot run on the GPU (None: it can)."""
    if scene.path != "simulate":
        return f"the {scene.path!r} path has no time integration (it runs on the CPU)"
    if point_kernel(scene).shapes is None:
        return (f"the {method_module(scene).NAME!r} integrator runs on the CPU only "
                "(dense n x n matrices per point)")
    return None


@cache
def block_kernel(scene):
    """The CUDA kernel ``block[grid, threads](points, p, cfg, rec, out, status, counters)``
    of ``scene`` (compiled at its first launch, once per process and argument types)."""
    from numba import cuda

    why = unsupported(scene)
    if why:
        raise ValueError(f"device cuda: {why}")
    _numpy_removed_names()
    _no_small_grid_warning()
    pk = point_kernel(scene)
    source = kernel_source(pk.shapes, pk.n, pk.obs_size, pk.n_out, scene.n_params,
                           simulated())
    namespace = kernel_namespace(pk)
    exec(compile(source, f"<engine.gpu kernel of {scene.friction}/{scene.system}>", "exec"),
         namespace)
    cap = {"max_registers": MAX_REGISTERS} if MAX_REGISTERS and not simulated() else {}
    return cuda.jit(namespace["block"], **cap)


def _launch(kernel, scene, grid: int, stream, args) -> None:
    """``kernel[grid, THREADS_PER_BLOCK, stream](*args)``; a first launch that fails to
    compile is one ValueError naming the rule kernel code breaks."""
    compiled = bool(getattr(kernel, "overloads", True))   # (the simulator compiles nothing)
    try:
        launch = kernel[grid, THREADS_PER_BLOCK, stream]
        if compiled:
            launch(*args)
        else:   # a first launch compiles: on a deep data stack, as the CPU's (deep_stack)
            on_a_deep_stack(launch, *args)
    except Exception as exc:   # noqa: BLE001 -- the first launch compiles: numba.cuda's
        if compiled:           # lowering raises bare KeyErrors (a numpy ufunc) as well as
            raise              # NumbaErrors; a launch of a compiled kernel fails as it is
        first = str(exc).strip().splitlines()
        raise ValueError(
            f"device cuda: the {scene.friction}/{scene.system} kernel does not compile for "
            f"the GPU ({type(exc).__name__}: {first[0] if first else ''}); its functions "
            "must use math.* for elementary functions, not numpy ufuncs (docs/MODELS.md), "
            "or run without --device cuda") from None


# Launches (a stream and the device arrays of one block's shapes) kept for later launches
# of the same shapes: while blocks run, no device memory is allocated or freed. numba-cuda
# frees device memory through a per-context queue that is not thread-safe (its flush pops
# from a deque that another thread may be emptying: blocks are launched from several
# threads, sweeps.run.local.GPU_LAUNCHES), and a free (cuMemFree) may wait for every kernel
# on the device, which would hold the other threads' next launches back. Allocations and
# frees happen under _POOL_LOCK only.
_IDLE: dict[tuple, list] = {}
_POOL_LOCK = threading.Lock()
MAX_IDLE = 8   # launches kept idle (the oldest shapes' go first)


def _take(shapes: tuple):
    """``(stream, device arrays)`` of these ``(shape, dtype)``s: an idle one, or new."""
    from numba import cuda

    with _POOL_LOCK:
        idle = _IDLE.get(shapes)
        if idle:
            return idle.pop()
        stream = cuda.stream()   # a stream a launch: launches from several threads overlap
        return stream, tuple(cuda.device_array(shape, dtype, stream=stream)
                             for shape, dtype in shapes)


def _give_back(shapes: tuple, launch) -> None:
    with _POOL_LOCK:
        _IDLE.setdefault(shapes, []).append(launch)
        while sum(len(v) for v in _IDLE.values()) > MAX_IDLE:
            oldest = next(iter(_IDLE))
            del _IDLE[oldest][0]          # freed here, under the lock
            if not _IDLE[oldest]:
                del _IDLE[oldest]


def cost_order(points: np.ndarray) -> np.ndarray:
    """The order the GPU runs ``points`` in: by dither frequency, highest first, then by
    dither amplitude, largest first (a point's steps grow with omega: fixed steps per
    half-period, or the adaptive step following the dither; and with W, which sets how many
    stick-slip switches a period holds: Fig. 14's scene at omega = 1000 takes 16,000 steps at
    W = 0 and 850,000 at W = 3), so the 32 threads of a warp, which wait for their slowest,
    finish together."""
    return np.lexsort((-points[:, 0], -points[:, 1]))


def run(scene, points: np.ndarray, p: np.ndarray, cfg: np.ndarray):
    """Integrate ``points`` on the GPU: ``(out, status, counters, seconds)`` as the CPU
    block kernel fills them (``engine.blocks.run_block``), in the caller's order;
    ``seconds`` is the kernel's wall time, transfers included."""
    import time

    check_device()
    pk = point_kernel(scene)
    order = cost_order(points)
    points = np.ascontiguousarray(points[order])
    m = points.shape[0]
    kernel = block_kernel(scene)
    rec = np.empty((0, pk.n + 1))
    out = np.full((m, pk.n_out), np.nan)
    # FAILED until a thread writes its point's status: an exception raised in device code
    # (a brought model's ``raise``) returns from the kernel without a word unless it was
    # compiled with debug=True, and the point would have read OK with NaN outputs
    status = np.full(m, S.FAILED, dtype=np.int8)
    counters = np.zeros((m, 3), dtype=np.int64)
    if m == 0:
        return out, status, counters, 0.0
    t0 = time.perf_counter()
    hosts = (points, p, cfg, rec, out, status, counters)
    shapes = tuple((a.shape, a.dtype) for a in hosts)
    launch = _take(shapes)
    stream, devs = launch
    try:
        for dev, host in zip(devs, hosts):
            if host.size:
                dev.copy_to_device(host, stream=stream)
        _launch(kernel, scene, math.ceil(m / THREADS_PER_BLOCK), stream, devs)
        out, status, counters = (d.copy_to_host(stream=stream) for d in devs[4:])
        stream.synchronize()
    finally:
        _give_back(shapes, launch)
    back = np.empty_like(order)
    back[order] = np.arange(m)
    return out[back], status[back], counters[back], time.perf_counter() - t0
