"""Kernel factory: one Scene + method -> jitted point and block integrators, cached per process.

Everything a Scene switches off is absent from the compiled code (its flags are Python
constants closed over by the njit factories). Kernels are cached with
``functools.lru_cache`` on the (hashable, frozen) Scene; a worker process compiles each
scene once. Recording steps (API only) is a run-time choice in the API's kernel (an empty
``rec`` array records nothing) and absent from the block kernel (``record=False``);
recording at uniform instants from the dense output is a compile-time one
(``point_kernel(scene, sampled_record=True)``). The batch path carries neither.
"""
from __future__ import annotations

import math
import types
from collections.abc import Callable
from functools import cache
from typing import NamedTuple

import numpy as np

from . import params as P
from . import status as S
from .integrators import METHODS
from .integrators.driver import make_solve
from .integrators.problem import (
    CONFIG,
    CTR_SIZE,
    N_ATOL,
    Problem,
    record_sample,
)
from .compiling import compile_once
from .jit import njit
from .observables import N_HIST, make_observer
from .settings import Settings
from .systems import make_system, probed


class PointKernel(NamedTuple):
    """Compiled pieces of one scene (sizes are Python ints)."""

    n: int                 # state size
    obs_size: int          # accumulator length
    names: tuple           # scalar outputs, column order of ``out``
    n_out: int             # columns of ``out``: the scalars, then N_HIST alpha_hist shares
    alloc: Callable        # alloc() -> work (method scratch)
    run_point: Callable    # run_point(p, cfg, work, y, obs, out, ctr, rec) -> status
    shapes: tuple | None   # the shapes of alloc()'s arrays (Stepper.shapes; None: CPU only)
    inlined: Callable      # run_point compiled into its caller (numba IR): the block kernel


def make_config(settings: Settings, record_every: int = 1, sample_dt: float = 0.0,
                sample_t0: float = 0.0) -> np.ndarray:
    """:class:`Settings` (and the API's recording choices) as the kernels' settings record:
    a one-element array of :data:`engine.integrators.problem.CONFIG` (the kernels read
    ``cfg[0]``; the driver writes the per-point fields into it)."""
    cfg = np.zeros(1, CONFIG)
    c = cfg[0]
    c["rtol"], c["atol"] = settings.rtol, settings.atol
    c["atol_natural"] = settings.atol_units == "natural"
    c["atol_i"] = settings.atol      # absolute; natural: scaled per point
    c["max_steps"] = settings.max_steps
    c["steps_per_period"] = settings.steps_per_period
    c["h_free"] = settings.h
    c["record_every"] = record_every
    c["sample_dt"], c["sample_t0"] = sample_dt, sample_t0
    return cfg


def method_module(scene):
    """The integrator module of ``scene.integrator`` (ValueError naming the known ones)."""
    try:
        return METHODS[scene.integrator]
    except KeyError:
        raise ValueError(f"integrator: unknown integrator {scene.integrator!r}; "
                         f"known: {sorted(METHODS)}") from None


@njit(error_model="numpy", refcount=False)
def _record_instant(t, y, p, sq, obs, ctr, rec):
    """The sampling hook of a ``sampled_record`` kernel: one row of ``rec`` per instant."""
    record_sample(t, y, ctr, rec)


PERIOD_CAP = 0.25   # of a sine dither's period: the longest adaptive step (see period_cap)


def period_cap(scene, system) -> float:
    """The share of a sine dither's period an adaptive step may span: ``PERIOD_CAP`` where
    a reversal stepped over unseen changes the dynamics (switches that mark jumps, or
    discrete modes: engine.integrators.adaptive), else 0 (no cap)."""
    jumps = system.event_jumps or system.update_modes is not None
    return PERIOD_CAP if jumps and scene.dither in ("sine-velocity", "sine-force") else 0.0


def step_cap_note(scene) -> str:
    """The step cap of ``scene`` in words for ``ditherlab plan`` and the web's sweep page
    ("" where none is compiled in, or the method takes fixed steps)."""
    from .integrators import METHODS
    from .systems import make_system

    if not scene.integrator or not METHODS[scene.integrator].ADAPTIVE:
        return ""
    cap = period_cap(scene, make_system(scene))
    return f"; steps of at most {cap:g} dither period (a reversal is not stepped over)" \
        if cap else ""


def _inlinable(func):
    """A copy of the njit-to-be ``func`` that numba inlines into its caller (numba IR).

    The block kernel calls ``run_point`` inlined. As a dispatcher of its own, the whole point
    integrator (which its library links in) was optimised, turned into machine code, wrapped
    and cached once more for ``run_point`` alone, on the batch path that never calls it from
    Python: 0.46-0.48 s of the cheap scene's 5.0-5.2 s first compile (docs/PERFORMANCE.md).
    Inlined, it adds 0.05 s to the block kernel's compile, since numba copies an inlined
    callee's scope once (engine.inline_scope; before, inlining cost what it saved). The copy
    has its own name, so its dispatcher's UUID differs from the plain one's (engine.jit)."""
    copy = types.FunctionType(func.__code__, func.__globals__, func.__name__,
                              func.__defaults__, func.__closure__)
    copy.__qualname__ = func.__qualname__ + "_inlined"
    return njit(inline="always", error_model="numpy")(copy)


@cache
def point_kernel(scene, sampled_record: bool = False, record: bool = True) -> PointKernel:
    """Build (once per process) the one-point integrator of ``scene``.

    ``sampled_record``: ``rec`` receives the state at the instants ``k cfg.sample_dt``
    (dense output, no stops) instead of every ``cfg.record_every``-th step end.
    ``record=False``: no recording compiled in at all (the block kernel's; the batch path
    never records). Its step loop is smaller: the cheap scene's first compile 3.70-3.77 ->
    3.37-3.40 s, where the API's kernel and the block kernel shared one driver before.
    """
    system = make_system(scene)
    observer = make_observer(scene, system)
    problem = Problem(n=system.n, n_err=system.n_err, rhs=system.rhs,
                      n_events=system.n_events, events=system.events,
                      observe=observer.observe, record=record and not sampled_record,
                      needs_mid=observer.needs_mid, graze=system.event_jumps,
                      period_cap=period_cap(scene, system),
                      sampling=sampled_record,
                      sample=_record_instant, update_modes=system.update_modes)
    stepper = method_module(scene).make_stepper(problem)
    solve = make_solve(stepper, observer, scene.dither, system.update_modes)
    init, obs_init, finish, scales = system.init, observer.init, observer.finish, system.scales
    n_err = system.n_err
    if n_err > N_ATOL:
        raise ValueError(f"{scene.system}: {n_err} controlled components, room for {N_ATOL}")

    def run_point(p, cfg, work, y, obs, out, ctr, rec):
        c = cfg[0]
        init(p, y)
        if c.atol_natural:
            atol = c.atol_i[:n_err]
            scales(p, atol)
            for i in range(n_err):
                atol[i] *= c.atol
        obs_init(obs)
        ctr[:] = 0
        status = solve(work, y, p, c, obs, ctr, rec)
        if status != S.OK:
            out[:] = np.nan
            return status
        finish(p[P.T_END], y, p, obs, out)
        for j in range(out.size):
            if not math.isfinite(out[j]):
                return S.NON_FINITE
        return S.OK

    inlined = _inlinable(run_point)
    run_point = njit(error_model="numpy", entry=True)(run_point)
    n_out = len(observer.names) + (N_HIST if observer.hist else 0)
    return PointKernel(system.n, observer.size, observer.names, n_out, stepper.alloc,
                       run_point, stepper.shapes, inlined)


PAD = 64   # bytes kept free around each scratch array: a cache line of its own


def _scratch(shape, dtype=np.float64) -> np.ndarray:
    """Zeros shaped ``shape``, with ``PAD`` unused bytes before and after them, so that no
    cache line holds both this array and another allocation. The threads of a small sweep
    (sweeps.run.local) each run a block kernel; numpy's small arrays of two threads could
    share a line, and writing them every step cost the 2-thread cheap sweep 25 % in its
    points (0.66 -> 0.82 s of summed point cost, before the padding)."""
    size, pad = int(np.prod(shape)), PAD // np.dtype(dtype).itemsize
    return np.zeros(size + 2 * pad, dtype)[pad:pad + size].reshape(shape)


def _zeros(shapes):
    """Scratch arrays shaped as ``shapes`` (nested tuples of shapes, as Stepper.shapes)."""
    if shapes and isinstance(shapes[0], int):
        return _scratch(shapes)
    return tuple(_zeros(s) for s in shapes)


def block_work(scene, p: np.ndarray) -> tuple:
    """The scratch the block kernel of ``scene`` borrows, allocated here by numpy: the
    method's work (shaped by ``Stepper.shapes``; else its own ``alloc()``), a copy of ``p``,
    the state, the accumulators, one row of outputs, the counters and an empty record."""
    pk = point_kernel(scene, record=False)
    if pk.shapes is None:   # (compiled once per machine, as the kernels: engine.jit)
        compile_once(pk.alloc, (), scene)
        work = pk.alloc()
    else:
        work = _zeros(pk.shapes)
    return (work, _scratch(p.shape), _scratch((pk.n,)), _scratch((pk.obs_size,)),
            _scratch((pk.n_out,)), _scratch((CTR_SIZE,), np.int64), np.empty((0, pk.n + 1)))


@cache
def block_kernel(scene) -> Callable:
    """njit ``run(points, p, cfg, out, status, counters, *block_work(scene, p))`` over a
    block of grid points.

    ``points`` ``(m, 4)``: columns W, omega, v_ref, vd overriding ``p``; ``out``
    ``(m, n_out)``: the scene's scalar outputs in order, then the alpha_hist shares;
    ``status`` ``(m,)`` int8; ``counters`` ``(m, 3)`` int64: accepted steps, rejected steps,
    evaluations. Its scratch comes from :func:`block_work`, so it allocates nothing itself
    and compiles without numba's runtime (NRT; 0.2-0.3 s of the cheap scene's first
    compile), unless a model is brought: ``run_point`` is compiled into it, and with it
    the model's ``init`` and its outputs' ``finish``, which may allocate (a brought law's
    ``np.zeros`` in ``init`` did not compile without NRT: every block failed after the
    spec check had passed). The built-in models allocate nothing there; if one did, its
    kernel would not compile (a TypingError in every test that runs it), never run wrong.
    """
    pk = point_kernel(scene, record=False)
    k = pk.n_out
    run_point = pk.inlined
    cols = (P.W, P.OMEGA, P.V_REF, P.VD)

    @njit(error_model="numpy", entry=True, refcount=probed(scene))
    def run(points, p, cfg, out, status, counters, work, q, y, obs, o, ctr, rec):
        # element loops, not ``out[j, :] = o``: an array-to-array slice assignment makes
        # numba compile its shape-mismatch message (str, repr, concatenation: ~3 s of the
        # first compile in each process that compiles), for an error these shapes cannot
        # raise; run_block allocates ``out`` with the k = pk.n_out columns written here
        for j in range(points.shape[0]):
            for i in range(q.size):
                q[i] = p[i]
            for c in range(4):
                q[cols[c]] = points[j, c]
            status[j] = run_point(q, cfg, work, y, obs, o, ctr, rec)
            for i in range(k):
                out[j, i] = o[i]
            for i in range(3):
                counters[j, i] = ctr[i]
    return run
