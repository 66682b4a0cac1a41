"""The Python API: the same path as the command line, returning xarray objects."""
from __future__ import annotations

from pathlib import Path

from .plan import make_plan
from .run import SubmitResult, submit
from .spec import DEFAULT_MAX_POINTS, load_spec


def run_sweep(spec, store: str | Path = "ditherlab-store", *, scheduler: str | None = None,
              workers: int = 2, progress: bool = True,
              max_points: int = DEFAULT_MAX_POINTS) -> SubmitResult:
    """Validate, plan and run a sweep (a spec dict, or a .toml/.json path); resume it if
    partial, return at once if complete. Open the cube with :func:`open_sweep`."""
    plan = make_plan(load_spec(spec, max_points=max_points))
    return submit(plan, store, scheduler=scheduler, workers=workers, progress=progress)


def open_sweep(key: str, store: str | Path = "ditherlab-store"):
    """The cube of a sweep (id, id prefix or name) as an in-memory ``xarray.Dataset``;
    a ``UserWarning`` when it was made by another engine than the installed one."""
    import warnings

    import store as _store

    from .cli import resolve_sweep, stale_note

    sweep_id, cube = resolve_sweep(Path(store), key)
    ds = _store.open_cube(cube)
    note = stale_note(_store.Catalogue(Path(store)).get(sweep_id), ds, Path(store))
    if note:
        warnings.warn(note, stacklevel=2)
    return ds
