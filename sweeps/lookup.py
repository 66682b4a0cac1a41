"""Finding a sweep in a store by what a user typed, and saying when it is stale.

Used alike by the command line and the Python API (``sweeps.api``); reads only: the
catalogue is opened read-only (a snapshot in memory), so a lookup never creates a store,
adopts a cube or migrates a catalogue on disk.

A key is a sweep id, a unique id prefix or a sweep name. A name given to several sweeps
(a spec edited and submitted again under the same name) means the one made by the
installed engine when exactly one is (stale sweeps are never served as current, README
"Which engine made this cube"), and among those the one of a brought model's source as it
is now (:func:`model_changed`); otherwise the lookup is refused with the candidates listed.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from .errors import AmbiguousSweepError, UserError

STALE = "stale: engine changed"


def store_root(arg: str | os.PathLike | None = None) -> Path:
    """The store folder: ``arg``, else ``$DITHERLAB_STORE``, else ``./ditherlab-store``
    (the one default store: every command, the API, the gallery and the web view)."""
    from store.layout import DEFAULT_STORE, ENV_STORE

    return Path(arg or os.environ.get(ENV_STORE) or DEFAULT_STORE)


def catalogue(root: Path):
    """The store's catalogue for reading (never writes, also on a missing store path)."""
    import store

    return store.Catalogue(root, readonly=True)


def resolve_sweep(root: Path, key: str, need_cube: bool = True) -> tuple[str, Path]:
    """A sweep id, id prefix or name -> ``(sweep id, cube path)``.

    With ``need_cube=False`` the cube may not exist yet (a queued sweep). Raises
    :class:`UserError` when nothing matches or the cube is missing, and
    :class:`AmbiguousSweepError` (exit 2) when the key fits several current sweeps.
    """
    import store

    rows = catalogue(root).matches(key)
    if not rows:
        raise UserError(f"no sweep {key!r} in store {root} (see `ditherlab status`)")
    if len(rows) > 1:
        current = [r for r in rows if not is_stale(r)]
        if len(current) > 1:   # an edited brought model: the sweep of its source as it is
            current = [r for r in current if not model_changed(r)] or current
        if len(current) != 1:
            raise AmbiguousSweepError(_ambiguity(key, current or rows))
        rows = current
    sweep_id = rows[0]["sweep_id"]
    cube = store.SweepDir(root, sweep_id).cube
    if need_cube and not cube.exists():
        if rows[0].get("state") == "queued":
            raise UserError(f"sweep {sweep_id} is queued and has no cube yet; `ditherlab serve` "
                            f"computes it (or `ditherlab submit` it without --detach)")
        raise UserError(f"sweep {sweep_id} has no cube yet at {cube}; submit it again")
    return sweep_id, cube


def _ambiguity(key: str, rows: list[dict]) -> str:
    shown = "; ".join(f"{r['sweep_id']} ({r['state']}, {r['n_points']} points, created "
                      f"{str(r['created'])[:19]})" for r in rows[:6])
    more = f"; and {len(rows) - 6} more" if len(rows) > 6 else ""
    return f"{key!r} names {len(rows)} sweeps: {shown}{more}; pass the sweep id"


def engine_of(row: dict, ds=None) -> str:
    """Fingerprint of the engine that made a sweep: the cube's ``engine_fingerprint``
    attribute, else the catalogue's; ``''`` when neither recorded one."""
    made = ds.attrs.get("engine_fingerprint", "") if ds is not None else ""
    return str(made or row.get("engine_fingerprint") or "")


def is_stale(row: dict, ds=None) -> bool:
    """True when a sweep was made by an engine other than the installed one.

    Judged by the recorded fingerprint; without one (a sweep from before fingerprints,
    or a row registered before its run began), by whether its spec still hashes to its id.
    """
    from .version import results_fingerprint

    made = engine_of(row, ds)
    if made:
        return made != results_fingerprint()
    return not _hashes_to_its_id(row)


def _hashes_to_its_id(row: dict) -> bool:
    """The row's spec, loaded now, still hashes to its sweep id (which covers the engine
    and a brought model's source: sweeps.spec.models.Spec.sweep_id); False also when it
    cannot be loaded (a brought model moved, broken or not importable here)."""
    from .spec.load import load_spec

    try:
        spec = load_spec(json.loads(row["spec_json"]), max_points=max(int(row["n_points"]), 1))
    except Exception:  # noqa: BLE001 -- a user's module may raise anything on import
        return False
    return spec.sweep_id == row["sweep_id"]


def model_changed(row: dict) -> bool:
    """The sweep brings a model by import path (``module:Name``) whose source is not the
    one it was made with: its spec no longer hashes to its id, which covers the model's
    source (sweeps.spec.models.Spec.sweep_id); also when the model cannot be read here.
    False for the built-in models. A name given again after the user edited their law
    meant two current sweeps and was refused; it now means the one of the source as it is
    (only asked when a name is ambiguous: reading the spec imports the model)."""
    from engine.registry import is_import_path

    try:
        raw = json.loads(row["spec_json"])
    except (KeyError, TypeError, ValueError):
        return False
    if not any(is_import_path(str(raw.get(k, ""))) for k in ("friction", "system")):
        return False
    return not _hashes_to_its_id(row)


def stale_note(row: dict, ds=None, root: Path | None = None) -> str | None:
    """One line saying a sweep is stale and how to recompute it, or None if current."""
    import store

    from .version import results_fingerprint

    if not is_stale(row, ds):
        return None
    made = engine_of(row, ds) or "(not recorded)"
    saved = store.SweepDir(root, row["sweep_id"]).spec if root is not None else None
    spec = f" (e.g. {saved})" if saved is not None and saved.exists() else ""
    return (f"sweep {row['sweep_id']} was made by engine {made}, the installed engine is "
            f"{results_fingerprint()}; `ditherlab submit SPEC`{spec} recomputes it")


def read_sweep(root: Path, key: str, opener=None) -> tuple[str, Path, object]:
    """The one read path of a sweep's cube, for the command line, the Python API and the
    web view: find the sweep (:func:`resolve_sweep`), then :func:`open_checked`. Returns
    ``(sweep id, cube path, what opener returned)``; say :func:`read_notes` as you warn."""
    sweep_id, cube = resolve_sweep(root, key)
    return sweep_id, cube, open_checked(sweep_id, cube, opener)


def open_checked(sweep_id: str, cube: Path, opener=None):
    """``opener(cube)`` (default ``store.open_cube``; a lazy open, the header alone, the
    web's snapshot: its ``ds`` is checked), refused (and closed) when the cube is another
    sweep's (:func:`check_cube_of`)."""
    import store

    opened = (opener or store.open_cube)(cube)
    ds = getattr(opened, "ds", opened)
    try:
        check_cube_of(ds, sweep_id, cube)
    except BaseException:
        if opened is ds and hasattr(ds, "close"):   # a file this call opened
            ds.close()
        raise
    return opened


def read_notes(root: Path, sweep_id: str, ds) -> list[str]:
    """What a reader of a sweep's cube is warned of, one line each: a stale engine
    (:func:`stale_note`), then every accuracy warning the cube records."""
    from store.attrs import accuracy_warnings

    note = stale_note(catalogue(root).get(sweep_id), ds, root)
    return ([note] if note else []) + accuracy_warnings(ds.attrs)


def check_cube_of(ds, sweep_id: str, cube: Path) -> None:
    """Refuse to serve a cube that another sweep wrote (a file copied or moved between
    sweep folders): its numbers would be served as this sweep's, with status ok."""
    from store.cube_io import republish_hint

    found = ds.attrs.get("sweep_id")
    if found is None or str(found) == sweep_id:
        return
    home = cube.parent.parent / str(found)
    if not home.exists():   # the sweep's own folder, renamed or moved
        raise UserError(f"the folder {cube.parent} holds sweep {found} under another name; "
                        f"`mv {cube.parent} {home}` puts it back")
    raise UserError(f"the cube at {cube} is sweep {found}'s, not {sweep_id}'s; "
                    f"{republish_hint(cube)}")


def inferred_note(provenance) -> str | None:
    """One line saying how many of these points a refined sweep inferred, or None.

    ``provenance`` is the cube's flag (store.flags: ``COMPUTED``, ``INFERRED``), whole or
    a selection. An inferred point holds a computed neighbour's outputs: they settle the
    map's class there (zone, stability label) but are not computed values."""
    import numpy as np

    from store.flags import INFERRED

    flags = np.asarray(provenance)
    n = int((flags == INFERRED).sum())
    if not n:
        return None
    return (f"{n} of {flags.size} points are inferred (provenance = {INFERRED}; the spec has "
            "refine = true): their outputs are a computed neighbour's values, which settle the "
            "zone or stability class there but are not computed to the accuracy level's "
            "promise; for computed values everywhere submit the spec with refine = false")
