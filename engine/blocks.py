"""The entry point of the sweep service: integrate (or analyse) a block of grid points.

See docs/ARCHITECTURE.md: ``run_block(scene, points, p, settings) -> BlockResult``.
Never raises for a bad *point* (its status says what happened); raises ValueError for a
malformed *call* (shapes, unknown outputs), naming the argument.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from . import params as P
from . import status as S
from .compiling import compile_once
from .jit import load_numba_registries
from .kernels import block_kernel, block_work, make_config, point_kernel
from .observables import N_HIST
from .scene import ANALYSIS_PATHS, Scene
from .settings import Settings

POINT_AXES = P.POINT_AXES   # the columns of ``points``


@dataclass
class BlockResult:
    """Per-point results of one block (all arrays of length n = len(points))."""

    outputs: dict[str, np.ndarray]   # name -> (n,) float64 ((n, 10) for alpha_hist),
                                     # exactly scene.outputs
    status: np.ndarray               # (n,) int8, engine.status codes
    steps: np.ndarray                # (n,) int64 accepted steps (0 for analysis paths)
    rejected: np.ndarray             # (n,) int64
    evals: np.ndarray                # (n,) int64 right-hand-side evaluations
    cost_s: np.ndarray               # (n,) float64 block wall time apportioned by evals


def _check(scene: Scene, points: np.ndarray, p: np.ndarray) -> None:
    if points.ndim != 2 or points.shape[1] != len(POINT_AXES):
        raise ValueError(f"points: expected shape (n, {len(POINT_AXES)}) with columns "
                         f"{POINT_AXES}, got {points.shape}")
    if p.shape != (scene.n_params,):
        raise ValueError(f"p: expected the parameter vector of shape ({scene.n_params},) from "
                         f"engine.registry.pack (engine.params.pack for the paper's laws), "
                         f"got {p.shape}")
    scene.check_params(p)


def run_block(scene: Scene, points, p, settings: Settings | None = None) -> BlockResult:
    """Integrate every point of ``points`` (``(n, 4)``: W, omega, v_ref, vd) for ``scene``.

    Parameters
    ----------
    scene : compile-time choices; ``scene.path`` ``"simulate"`` (with ``scene.integrator``
        of ``engine.integrators.METHODS``) or ``"averaged"`` / ``"hbm"`` (engine.analysis).
    points : float64 ``(n, 4)``; column j overrides ``p[W]``, ``p[OMEGA]``, ``p[V_REF]``, ``p[VD]``.
    p : the parameter vector (``engine.params.pack``), shape ``(N_PARAMS,)``.
    settings : run-time numerics (defaults: ``Settings()``); ``settings.device``
        ``"cuda"`` integrates on the GPU, one thread a point (:mod:`engine.gpu`; its
        :class:`~engine.gpu.NoGPU` says when there is none). The analysis paths have no
        time integration and run on the CPU whatever the device.
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    p = np.ascontiguousarray(p, dtype=np.float64)
    _check(scene, points, p)
    if scene.path in ANALYSIS_PATHS:
        return _analysis(scene, points, p)
    settings = settings or Settings()
    m = points.shape[0]
    pk = point_kernel(scene, record=False)   # (the block kernel's: engine.kernels)
    names = pk.names
    if settings.device == "cuda":
        from . import gpu

        out, status, counters, wall = gpu.run(scene, points, p, make_config(settings))
    else:
        out = np.full((m, pk.n_out), np.nan)
        status = np.full(m, S.NOT_COMPUTED, dtype=np.int8)
        counters = np.zeros((m, 3), dtype=np.int64)
        kernel = block_kernel(scene)
        args = (points, p, make_config(settings), out, status, counters,
                *block_work(scene, p))
        compile_once(kernel, args, scene)   # (once per machine: the others load it)
        t0 = time.perf_counter()
        kernel(*args)
        wall = time.perf_counter() - t0
    evals = counters[:, 2]
    share = evals / evals.sum() if evals.sum() > 0 else np.full(m, 1.0 / max(m, 1))
    outputs = {nm: out[:, j].copy() for j, nm in enumerate(names)}
    if pk.n_out > len(names):
        outputs["alpha_hist"] = out[:, len(names):len(names) + N_HIST].copy()
    return BlockResult(
        outputs=outputs, status=status,
        steps=counters[:, 0].copy(), rejected=counters[:, 1].copy(), evals=evals.copy(),
        cost_s=wall * share,
    )


def _analysis(scene: Scene, points: np.ndarray, p: np.ndarray) -> BlockResult:
    """Averaged / harmonic-balance paths (engine.analysis, no time integration)."""
    from .analysis.block import analysis_block  # lazy: written by the analysis package
    load_numba_registries()   # (before its kernels load from the cache)

    m = points.shape[0]
    t0 = time.perf_counter()
    outputs, status = analysis_block(scene, points, p)
    wall = time.perf_counter() - t0
    zeros = np.zeros(m, dtype=np.int64)
    return BlockResult(
        outputs={nm: np.asarray(outputs[nm], dtype=np.float64) for nm in scene.outputs},
        status=np.asarray(status, dtype=np.int8), steps=zeros, rejected=zeros.copy(),
        evals=zeros.copy(), cost_s=np.full(m, wall / max(m, 1)),
    )
