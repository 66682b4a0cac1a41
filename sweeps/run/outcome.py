"""How a run ends: :class:`SubmitResult`, and the final state recorded in the catalogue
(giving the lease back) when the run finished or stopped (:func:`final_result`), when this
call only attached to another process's run (:func:`attached_result`), or when it raised
(:func:`abort`)."""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import store
from engine import status as S
from store.flags import INFERRED

from .lease_holder import CANCELLED, LEASE_LOST, SHUTDOWN
from .sink import done_blocks, point_counts

log = logging.getLogger("ditherlab")


@dataclass
class SubmitResult:
    sweep_id: str
    cube_path: Path
    state: str
    n_points: int
    n_ok: int
    n_failed: int
    blocks_run: int
    blocks_total: int
    wall_s: float
    timings: dict = field(default_factory=dict)  # phase -> seconds (cluster, warm_up, compute)
    message: str = ""       # why the run stopped early, or what went wrong
    attached_to: str = ""   # the owner whose run this call waited for (it computed nothing)


def final_result(plan, sweep, catalogue, cube, *, blocks_run, t0, timings, owner=None,
                 lease=None, stopped=None, max_blocks=None) -> SubmitResult:
    """The run's final state, recorded in the catalogue (giving the lease back):

    every point final -> ``done``, or ``partial`` when some failed or went non-finite;
    points left -> ``cancelled`` (cancel, ``max_blocks``) or ``queued`` (serve stopping),
    and so too every point final but a cancel or a stopping serve before the error
    estimate (else the cube stayed ``done`` unchecked: serve did not queue it again, and
    ``status`` had no estimate to show). Without a lease (nothing was left to compute) the
    row is settled unless a live process holds it.
    """
    from ..estimates.error_reruns import needs_estimate   # (numerics: not at import)

    counts = point_counts(cube)
    n = cube["status"].size
    n_done_blocks = len(done_blocks(plan, cube))
    progress = f"{n_done_blocks}/{len(plan.blocks)} blocks"
    unchecked = stopped in (SHUTDOWN, CANCELLED) and needs_estimate(plan, sweep, cube)
    if unchecked:
        progress += ", before the error estimate"
    if counts["done_points"] == n and not unchecked:
        state = "partial" if counts["failed_points"] else "done"
        message = failures_text(cube, plan.path) if counts["failed_points"] else ""
    elif stopped == SHUTDOWN:
        state = "queued"
        message = (f"re-queued after {progress}: serve {lease.owner} stopped; the next "
                   "serve or submit resumes it")
    elif stopped == CANCELLED:
        state, message = "cancelled", f"cancelled after {progress}; submit again to resume"
    elif stopped == LEASE_LOST:
        state, message = "running", f"another process took the sweep over after {progress}"
    else:
        state = "cancelled"
        message = (f"stopped after {progress} (max_blocks={max_blocks}); submit again to "
                   "resume")
    fields = dict(message=message, done_blocks=n_done_blocks, **counts)
    if lease is not None:
        if stopped != LEASE_LOST:
            lease.end(state, **fields)
        else:
            lease.close()
    else:
        try:
            catalogue.get(plan.sweep_id)   # adopts a cube whose row was lost
        except LookupError:
            catalogue.register(plan.sweep_id, plan.spec.name, plan.spec.to_json(),
                               plan.n_points, len(plan.blocks), sweep.root)
        catalogue.finish(plan.sweep_id, state, owner=owner, **fields)
    n_ok = counts["done_points"] - counts["failed_points"]
    return SubmitResult(plan.sweep_id, sweep.cube, state, n, n_ok, counts["failed_points"],
                        blocks_run, len(plan.blocks), time.perf_counter() - t0, timings,
                        message=message)


def failures_text(cube, path: str) -> str:
    """``K of N points failed: ...`` with why, by cause, and what to do: the integrator gave
    up (its step budget or step size: a stiff model), the state went non-finite, or the
    point's whole block failed (a warning said why as it did). It ended "(submit again to
    retry them)" whatever the cause, and a run again fails the same points."""
    status = cube["status"].values
    failed = (status != S.OK) & (status != S.NOT_COMPUTED)
    computed = np.ones(status.shape, bool)   # (a refined sweep's inferred points copy one)
    if store.cube.PROVENANCE in cube.data_vars:
        computed = cube[store.cube.PROVENANCE].values.reshape(status.shape) != INFERRED
    gave_up = (status == S.FAILED) & computed
    if path != "simulate":   # (sweeps.planning: averaged, HBM ...: no integrator)
        causes = [(gave_up, f"had no {path} solution (its method did not converge, or "
                   "omega <= 0)")]
    else:   # a whole block's failure journals no work: 0 right-hand-side evaluations
        evals = cube["evals"].values
        causes = [(gave_up & (evals > 0), "the integrator gave up (its step budget or step "
                   "size: a stiff model? integrator = \"rodas4\")"),
                  (gave_up & (evals == 0), "in blocks that failed (the warnings said why; "
                   "submit again runs them again)")]
    causes.append(((status == S.NON_FINITE) & computed, "went non-finite (NaN or inf)"))
    causes.append((failed & ~computed, "inferred from failed points (refine = true)"))
    parts = [f"{int(np.sum(where))} {why}" for where, why in causes if np.any(where)]
    return f"{int(np.sum(failed))} of {status.size} points failed: " + "; ".join(parts)


def attached_result(plan, sweep, row, t0) -> SubmitResult:
    """The result of the run this call attached to, read from its published cube."""
    n = plan.n_points
    n_failed, n_ok = row["failed_points"], row["done_points"] - row["failed_points"]
    if sweep.cube.exists():
        try:
            counts = point_counts(store.read_cube(sweep.cube))
            n_failed = counts["failed_points"]
            n_ok = counts["done_points"] - n_failed
        except Exception as err:  # noqa: BLE001 -- the row's counts will do
            log.warning("cannot read %s: %s", sweep.cube, err)
    return SubmitResult(plan.sweep_id, sweep.cube, row["state"], n, n_ok, n_failed, 0,
                        len(plan.blocks), time.perf_counter() - t0, {},
                        message=row["message"],
                        attached_to=row.get("attached_to") or "another process")


def abort(plan, sink, lease, exc: BaseException, *, serving: bool,
          publish: bool = True) -> None:
    """The run raised: keep what was finished (publish, unless ``publish`` is False: done
    already; never when the lease was taken over, the new holder's cube is not ours to
    overwrite), and give the lease back as ``failed`` with the error, or -- interrupted
    (Ctrl-C, a second signal to serve) -- as ``cancelled`` (``queued`` under serve),
    resumable."""
    counts, progress = {}, "starting"
    if sink is not None:
        try:
            sink.settle()
        except Exception as err:  # noqa: BLE001 -- the journal keeps the blocks anyway
            log.warning("could not add the last journaled blocks to the cube: %s", err)
        try:
            if publish and not lease.lost.is_set() and sink.stopped != LEASE_LOST:
                store.publish(sink.cube, sink.sweep.cube)
        except store.errors.NoSpaceError:
            pass   # the previous cube stays whole; the error itself is reported
        except Exception as err:  # noqa: BLE001 -- the journal keeps the blocks anyway
            log.warning("could not publish the cube after the run stopped: %s", err)
        counts = dict(done_blocks=len(sink.done), **point_counts(sink.cube))
        progress = f"{len(sink.done)}/{len(plan.blocks)} blocks"
    try:
        if isinstance(exc, Exception):
            text = f"{type(exc).__name__}: {exc}".strip().splitlines()[0][:500]
            lease.end("failed", message=f"the run crashed after {progress}: {text}", **counts)
        elif serving:
            lease.end("queued", message=f"interrupted after {progress}; re-queued", **counts)
        else:
            lease.end("cancelled", message=(f"interrupted after {progress}; submit again to "
                                            "resume"), **counts)
    except Exception as err:  # noqa: BLE001 -- do not hide the original error
        if not isinstance(exc, store.errors.NoSpaceError):   # SQLite is out of space too
            log.warning("could not record the stop of sweep %s: %s", plan.sweep_id, err)
        lease.close()


def unusable(plan, sweep) -> str | None:
    """Why a done sweep's cube cannot be served as it is, in a few words, or None: missing,
    unreadable (a truncated or foreign file), or every point final but its error estimate
    never computed (a stop between the last block and the estimate). Before, only a missing
    cube was queued again: ``submit --detach`` said "done, already complete" over the others."""
    from ..estimates.error_reruns import needs_estimate

    try:
        cube = store.read_cube(sweep.cube)
    except FileNotFoundError:
        return "cube missing"
    except (OSError, ValueError) as err:   # (store.cube_io.CubeError is a ValueError)
        cause = str(err.__cause__ or err).splitlines()[0]
        return f"cube unreadable: {cause if len(cause) <= 90 else cause[:87] + '...'}"
    return "error estimate missing" if needs_estimate(plan, sweep, cube) else None
