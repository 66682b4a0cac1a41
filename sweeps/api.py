"""The Python API: the command line's path, returning xarray objects, composable with dask.

    res = sweeps.run_sweep("specs/fig14.toml", store="ditherlab-store")   # or a dict, a Spec
    ds = sweeps.open_sweep(res.sweep_id, store="ditherlab-store", chunks={})   # lazy (dask)

``run_sweep(..., client=client)`` runs on an existing ``dask.distributed.Client`` (a
``LocalCluster``, a ``SpecCluster``, a dask-jobqueue ``SLURMCluster``'s client: README "On
an HPC cluster"); ``scheduler=`` takes an address instead.
"""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

from .errors import InferredPointsWarning, RefusedError
from .lookup import inferred_note, read_notes, read_sweep, store_root
from .spec.load import DEFAULT_MAX_POINTS, Spec, SpecWarning, load_spec


def run_sweep(spec, store: str | Path | None = None, *, client=None,
              scheduler: str | None = None, workers: int = 2, progress: bool = True,
              max_points: int = DEFAULT_MAX_POINTS, dashboard: str | None = None,
              device: str | None = None):
    """Validate, plan and run a sweep; resume it if partial, return at once if complete.

    Parameters
    ----------
    spec
        A :class:`sweeps.Spec`, a spec dict, or a ``.toml``/``.json`` path.
    store
        The store folder (default ``$DITHERLAB_STORE`` or ``./ditherlab-store``).
    client
        An existing ``dask.distributed.Client`` to compute on (it is left open). Else
        ``scheduler`` (an address), else a LocalCluster of ``workers`` processes
        (``dashboard``: its dashboard address, none by default).
    device
        ``"cuda"``: the points on this machine's NVIDIA GPU, one thread a point
        (docs/GPU.md; a :class:`sweeps.RefusedError` without one); default: the spec's
        ``device`` (``"cpu"``). A GPU sweep has its own sweep id.

    Returns
    -------
    sweeps.SubmitResult
        ``sweep_id``, ``state``, counts and ``cube_path``; open the cube with
        :func:`open_sweep`. Raises :class:`sweeps.SpecError` for a refused spec.
    """
    from .estimates.time_history import record_run
    from .planning.plan import make_plan
    from .run.phases import shown
    from .run.submit import submit
    from .workers.compute import Compute

    _refuse_in_spawned_import()
    if not isinstance(spec, Spec):
        spec = load_spec(spec, max_points=max_points)
    if device is not None and device != spec.device:
        if device not in ("cpu", "cuda"):
            raise RefusedError(f"device: expected 'cpu' or 'cuda', got {device!r}")
        spec = spec.model_copy(update={"device": device})
    plan, root = make_plan(spec), store_root(store)
    if plan.device_note:   # "device cuda: ...: this sweep runs on the CPU" (the CLI prints it)
        warnings.warn(plan.device_note, SpecWarning, stacklevel=2)
    compute = Compute.chosen(workers=workers, scheduler=scheduler, client=client,
                             dashboard=dashboard)
    res = submit(plan, root, compute, progress=shown(progress))
    record_run(root, plan, res)
    return res


def _refuse_in_spawned_import() -> None:
    """Every dask worker process starts by importing the user's script again, as
    ``__mp_main__`` (multiprocessing's 'spawn'). A script that calls :func:`run_sweep` at its
    top level, not under ``if __name__ == "__main__":``, would have each worker run the
    sweep again (and wait forever on the first run's lease): the worker says so in one line
    and exits, and the submitter's cluster start fails
    (:func:`sweeps.workers.cluster.dask_client`)."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_globals.get("__name__") == "__mp_main__":   # this worker dies quietly
            print(f"ditherlab: error: a dask worker process imported "
                  f"{frame.f_globals.get('__file__', 'your script')}, which calls run_sweep at "
                  f"its top level: put the call under 'if __name__ == \"__main__\":'",
                  file=sys.stderr, flush=True)
            raise SystemExit(2)
        frame = frame.f_back


def open_sweep(key: str, store: str | Path | None = None, *, chunks=None):
    """The cube of a sweep (id, id prefix or name) as an ``xarray.Dataset``.

    ``chunks=None`` (default) loads it into memory and closes the file; ``chunks={}`` or a
    dict of sizes per axis opens it lazily as dask arrays (close it with ``ds.close()`` or
    a ``with`` block). A ``UserWarning`` when it was made by another engine than the
    installed one, and one per accuracy warning the cube records (as ``ditherlab query``
    says them); a :class:`sweeps.InferredPointsWarning` when it is refined
    (``refine = true``) with inferred points, whose outputs are a computed neighbour's
    (``ds.where(ds.provenance == store.COMPUTED)`` keeps the computed ones). Raises
    ``sweeps.errors.UserError`` when no sweep matches or the cube is another sweep's, and its
    subclass ``AmbiguousSweepError`` (also a ``LookupError``) when a name fits several
    current sweeps, listing them: pass an id.
    """
    import warnings

    import xarray as xr

    def lazy(cube):
        return xr.open_dataset(cube, engine="h5netcdf", chunks=chunks, decode_timedelta=False)

    root = store_root(store)
    sweep_id, _, ds = read_sweep(root, key, None if chunks is None else lazy)
    for note in read_notes(root, sweep_id, ds):
        warnings.warn(note, stacklevel=2)
    note = inferred_note(ds["provenance"].values) if "provenance" in ds else None
    if note:
        warnings.warn(f"sweep {sweep_id}: {note}", InferredPointsWarning, stacklevel=2)
    return ds
