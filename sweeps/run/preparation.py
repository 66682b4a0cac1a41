"""What a run starts from, read before and under the sweep's lease (sweeps.run.submit):
the blocks still to run, from the cube rebuilt from the journal (:func:`blocks_to_run`; before
that, those without a journal file: :func:`blocks_unjournaled`), the
room they need on disk (:func:`check_space`), a published cube equal to the journal
(:func:`republish`), and the lease itself, or the final row of the run this process
attached to (:func:`take_lease`); whether the error estimate's re-runs go among the blocks
(:func:`overlaps_estimate`)."""
from __future__ import annotations

import logging

import numpy as np

import store
from engine import status as S
from store.catalogue_db import FINAL
from store.lease import owner_tag

from .lease_holder import Lease, wait_while_held
from ..planning.plan import Plan
from ..estimates.error_reruns import ESTIMATE_FILE

log = logging.getLogger("ditherlab")


def blocks_to_run(plan: Plan, cube) -> list[int]:
    """Blocks with a point whose status is not OK: never computed, or failed before
    (DESIGN.md §4: a resubmitted spec computes only the points whose status is not 0).
    A refined sweep's blocks are known level by level: sweeps.run.refined.replay."""
    if plan.spec.refine:
        from .refined import replay

        return replay(plan, cube)
    status = cube["status"].values.ravel()
    return [b for b, index in enumerate(plan.blocks) if np.any(status[index] != S.OK)]


def every_block(plan: Plan) -> list[int] | None:
    """The blocks of a sweep with nothing journaled (None for a refined sweep: its first
    level is not known before its replay)."""
    return None if plan.spec.refine else list(range(len(plan.blocks)))


def blocks_unjournaled(plan: Plan, journal) -> list[int] | None:
    """The blocks known to be still to run before the store is read (a cluster's start
    overlaps the read: sweeps.run.submit): those without a journal file (a resumed sweep;
    its journaled blocks' points are checked by the read), every block of a sweep with
    nothing journaled (None for a refined sweep, whose first level is not known yet; [] for
    a resumed one, which resumes level by level: sweeps.run.refined). The names of the
    journal's files cost a directory listing, not a read of the blocks."""
    files = journal.files()
    if not files:
        return every_block(plan)
    if plan.spec.refine:
        return []
    return [b for b in range(len(plan.blocks)) if b not in files]


def checked_blocks(plan: Plan):
    """The blocks the journal is checked against: a refined sweep's are not known before
    its replay (sweeps.run.refined), so only checksums and index ranges are checked."""
    return None if plan.spec.refine else plan.blocks


def check_space(plan: Plan, sweep, cube, todo: list[int]) -> None:
    """Refuse to start (``store.errors.NoSpaceError``) unless the journal blocks still to
    write and one more copy of the cube fit on the store's disk, counted generously."""
    per_point = sum(v.size for v in cube.data_vars.values()) // cube["status"].size + 1
    need = sum(store.journal.block_bytes(len(plan.blocks[b]), per_point) for b in todo)
    store.errors.ensure_space(sweep.root, need + store.cube_io.cube_bytes(cube))


def republish(plan: Plan, sweep, cube, renamed: bool = False) -> None:
    """Publish ``cube`` (rebuilt from the journal), saying so when the published cube
    was missing, unreadable or different (a run killed before its last publish, a
    damaged file), but not for the new name alone of a renamed sweep (said already)."""
    cosmetic = (store.attrs.NAME, store.attrs.SPEC) if renamed else ()   # the new name alone
    why = store.cube_io.disagreement(sweep.cube, cube, cosmetic) if sweep.cube.exists() else None
    store.publish(cube, sweep.cube)
    if why:
        log.warning("sweep %s: %s; republished it from the journal", plan.sweep_id, why)


def take_lease(plan: Plan, catalogue, owner, stop, progress):
    """``(Lease, None)`` once this process holds the sweep, or ``(None, row)`` with the
    final row of the run it attached to."""
    while True:
        lease, row = Lease.take(catalogue, plan.sweep_id, owner, stop)
        if lease is not None:
            return lease, None
        row = wait_while_held(catalogue, plan.sweep_id, progress.attached(plan.sweep_id))
        if row["state"] in FINAL:
            return None, row
        # queued again (a serve stopped) or stalled (the holder died): take it over
        progress.note(f"sweep {plan.sweep_id}: {row['owner'] or 'its runner'} stopped "
                      f"({catalogue.live_state(row)}); taking it over")


def held_elsewhere(catalogue, sweep, sweep_id: str, owner: str | None) -> bool:
    """Another live process runs the sweep now: this call will attach to it and compute
    nothing (:func:`take_lease`), so it starts no cluster early (it did: a second submitter
    started two worker processes, on the cores the run it waited for was using, and
    stopped them unused). A sweep without a folder is not looked up (an unknown id makes
    the catalogue scan the store)."""
    if not sweep.root.exists():
        return False
    try:
        row = catalogue.get(sweep_id)
    except LookupError:
        return False
    return row["state"] == "running" and row.get("owner") != (owner or owner_tag()) and \
        catalogue.alive(row)


def overlaps_estimate(plan: Plan, sweep) -> bool:
    """An exhaustive simulated sweep without a saved error estimate: its re-runs are
    dispatched with its blocks (a refined sweep gives them to its levels' tails)."""
    return plan.path == "simulate" and not plan.spec.refine and \
        not (sweep.root / ESTIMATE_FILE).exists()
