"""One trajectory from Python: observables, counters, and optionally the steps themselves.

>>> from engine import Scene, pack, simulate
>>> scene = Scene(friction="lugre", dither="square-velocity", outputs=("v_slow_p2p",))
>>> r = simulate(scene, pack(v_ref=0.4, W=0.4, omega=1000.0, t_end=1.0))
>>> r.status, r.outputs["v_slow_p2p"]                           # doctest: +SKIP
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import params as P
from .integrators.problem import CTR_EVALS, CTR_NREC, CTR_REJECTED, CTR_SIZE, CTR_STEPS
from .compiling import compile_once
from .jit import load_numba_registries
from .kernels import make_config, point_kernel
from .scene import ANALYSIS_PATHS, Scene
from .settings import Settings


@dataclass
class Simulation:
    """Result of :func:`simulate`.

    Attributes
    ----------
    outputs : name -> value of each scalar observable of ``scene.outputs``.
    status : engine.status code.
    steps, rejected, evals : accepted steps, rejected (or retaken) steps, RHS evaluations.
    y_end : final state ``(n,)``.
    alpha_hist : time shares of alpha in 10 equal bins of [0, 1] (stick in the first), when
        ``"alpha_hist"`` was asked.
    t, y : recorded times ``(k,)`` and states ``(k, n)`` when ``record=True``: every
        ``record_every``-th accepted step end (all stops included when ``record_every=1``),
        or with ``record_dt`` the instants ``j * record_dt >= record_from`` from the
        method's dense output (the steps are not shortened to hit them).
    truncated : True when the recording buffer filled up before the end.
    """

    outputs: dict
    status: int
    steps: int
    rejected: int
    evals: int
    y_end: np.ndarray
    alpha_hist: np.ndarray | None = None
    t: np.ndarray | None = None
    y: np.ndarray | None = field(default=None, repr=False)
    truncated: bool = False


def pack_for(scene: Scene, values: dict) -> np.ndarray:
    """The parameter vector of ``scene`` from a dict: shared names (engine.params) and the
    models' own (a GMS law's ``k``, ``alpha``, ``C``), the system's defaults elsewhere."""
    from . import registry

    shared = {k: v for k, v in values.items() if k in P.INDEX}
    own = {k: v for k, v in values.items() if k not in P.INDEX}
    return registry.pack(scene.friction, scene.system, own, **shared)


def simulate(scene: Scene, p, settings: Settings | None = None, *, record: bool = False,
             record_every: int = 1, record_dt: float | None = None, record_from: float = 0.0,
             max_records: int = 2_000_000) -> Simulation:
    """Integrate one trajectory of ``scene`` with parameters ``p`` from ``(e0, v0, z0)``.

    Parameters
    ----------
    scene : compile-time choices (``scene.path`` must be ``"simulate"``).
    p : parameter vector (``engine.registry.pack``; ``engine.params.pack`` for the paper's
        laws) or a dict of overrides of the system's defaults (:func:`pack_for`).
    settings : tolerances / steps (default ``Settings()``).
    record : keep ``(t, y)`` of every ``record_every``-th accepted step, at most
        ``max_records`` rows (API only; the batch path never records).
    record_dt, record_from : instead, keep ``(t, y)`` at the uniform instants
        ``j * record_dt`` in ``[record_from, t_end]``, interpolated by the method's
        continuous extension (order 4 for dopri5 and rodas4, 3 for rk4); implies ``record``.
    """
    if scene.path in ANALYSIS_PATHS:
        raise ValueError(f"scene.path: simulate() integrates in time; {scene.path!r} is "
                         "an analysis path, use engine.blocks.run_block")
    p = pack_for(scene, p) if isinstance(p, dict) else np.ascontiguousarray(p, dtype=np.float64)
    if p.shape != (scene.n_params,):
        raise ValueError(f"p: expected {scene.n_params} parameters for this scene "
                         f"(engine.registry.pack), got shape {p.shape}")
    scene.check_params(p)
    if record_every < 1:
        raise ValueError(f"record_every must be >= 1, got {record_every}")
    if record_dt is not None and not record_dt > 0.0:
        raise ValueError(f"record_dt must be > 0 (time units), got {record_dt}")
    sampled = record_dt is not None
    record = record or sampled
    load_numba_registries()   # (before pk.alloc, numba's first compile here)
    pk = point_kernel(scene, sampled_record=sampled)
    cfg = make_config(settings or Settings(), record_every, record_dt or 0.0, record_from)
    y, obs = np.empty(pk.n), np.empty(pk.obs_size)
    out = np.empty(pk.n_out)
    ctr = np.zeros(CTR_SIZE, dtype=np.int64)
    rec = np.empty((max_records if record else 0, pk.n + 1))
    args = (p, cfg, pk.alloc(), y, obs, out, ctr, rec)
    compile_once(pk.run_point, args, scene)   # (once per machine: the others load it)
    status = pk.run_point(*args)
    k = int(ctr[CTR_NREC])
    return Simulation(
        outputs={nm: float(out[j]) for j, nm in enumerate(pk.names)}, status=int(status),
        steps=int(ctr[CTR_STEPS]), rejected=int(ctr[CTR_REJECTED]), evals=int(ctr[CTR_EVALS]),
        y_end=y.copy(),
        alpha_hist=out[len(pk.names):].copy() if pk.n_out > len(pk.names) else None,
        t=rec[:k, 0].copy() if record else None, y=rec[:k, 1:].copy() if record else None,
        truncated=bool(record and k >= max_records),
    )
