"""The error estimate of a finished simulated run (sweeps.estimate): the error sample
re-run one accuracy level finer on the cluster, compared, attached to the cube and saved
beside it as ``<sweep>/error_estimate.json``, so that no cube goes unchecked."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from engine import status as S

from . import estimate as errest
from . import task
from .plan import Plan
from .sink import BlockSink

ESTIMATE_FILE = "error_estimate.json"   # the sweep's error estimate (sweeps.estimate)


def estimate_into(plan: Plan, client, sink: BlockSink, timings: dict) -> None:
    """The error estimate (sweeps.estimate) of a finished simulated sweep, into its cube
    and ``<sweep>/error_estimate.json``; a failure is recorded as a warning, never lost."""
    t = time.perf_counter()
    try:
        estimate = _error_estimate(plan, client, sink.cube)
    except Exception as exc:  # noqa: BLE001 -- say so in the cube, keep the results
        estimate = {"compared_with": None, "level": plan.numerics.label,
                    "sample_points": 0, "change": {}, "promise": {},
                    "warnings": [f"the error estimate could not be computed "
                                 f"({type(exc).__name__}: {exc}); submit again"]}
    errest.attach(sink.cube, estimate)
    if estimate["compared_with"] is not None:
        _write_json(sink.sweep.root / ESTIMATE_FILE, estimate)
    timings["error_estimate_s"] = time.perf_counter() - t


def _error_estimate(plan: Plan, client, cube) -> dict:
    """Re-run the error sample one accuracy level finer on the cluster, one task per
    point (sweeps.estimate), and compare."""
    finer = errest.finer_numerics(plan)
    index, pts = errest.sample(plan)
    scene = plan.scene.with_(integrator=finer.integrator)
    futures = [client.submit(task.compute_block, scene, pts[i:i + 1], plan.params, finer.settings,
                             pure=False) for i in range(len(pts))]
    parts = client.gather(futures)
    result = {k: np.concatenate([part[k] for part in parts]) for k in parts[0]
              if k != "error"}
    return errest.compare(plan, cube, index, result, finer.label)


def _write_json(path: Path, data: dict) -> None:
    """Write ``data`` as JSON atomically (temporary name, fsync, rename)."""
    import os

    tmp = path.with_name(path.name + f".tmp{os.getpid()}")
    with open(tmp, "w") as f:
        json.dump(data, f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def complete(cube) -> bool:
    return not (cube["status"].values == S.NOT_COMPUTED).any()


def needs_estimate(plan: Plan, sweep, cube) -> bool:
    """A finished simulated sweep without a saved error estimate (its run was killed
    between the last block and the estimate): it is computed before the sweep is done,
    so that no cube goes unchecked."""
    return (plan.path == "simulate" and complete(cube)
            and not (sweep.root / ESTIMATE_FILE).exists())


def attach_saved_estimate(sweep, cube) -> bool:
    """Put the sweep's saved error estimate (if any) into ``cube``; True when there was one."""
    path = sweep.root / ESTIMATE_FILE
    try:
        errest.attach(cube, json.loads(path.read_text()))
    except (OSError, ValueError, KeyError):
        return False
    return True
