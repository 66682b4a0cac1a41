"""The sweeps of a store as plain data: what ``ditherlab status --format json`` prints and
what the web view's catalogue shows and polls (one source for scripts and pages).

Each sweep is a dict of JSON values (:func:`sweep_summary`): id, name and earlier names,
the live state (``stalled`` for a dead runner) and whether it is stale, point and block
counts, ETA, path (simulate / averaged / hbm), accuracy warnings read from the cube, and
when it finished. Reading only: the catalogue is a snapshot, cubes are opened for their
attributes alone.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from .lookup import STALE, catalogue, is_stale

FINAL = ("done", "partial", "failed", "cancelled")


def earlier_names(row: dict) -> list[str]:
    """The names a sweep was submitted under before its current one."""
    return [a for a in str(row.get("aliases") or "").splitlines() if a and a != row["name"]]


def spec_method(row: dict) -> str:
    """The sweep's path (a spec's ``method``), ``?`` for an unreadable spec."""
    try:
        return str(json.loads(row["spec_json"]).get("method") or "simulate")
    except (ValueError, TypeError, AttributeError):
        return "?"


def _stat(path: Path):
    try:
        return os.stat(path)
    except OSError:
        return None


UNREADABLE = "the cube cannot be read; `ditherlab status SWEEP` says how to repair it"


def cube_warnings(cube: Path, cache: dict | None = None, st=None) -> list[str]:
    """The accuracy warnings a cube records ([] without a cube or estimate). ``cache`` maps
    a path to ``(stat key, warnings)``: an unchanged cube (same inode, size and mtime: a
    publish is a rename) is not opened again. ``st``: the cube's ``os.stat``, if known."""
    from store.attrs import accuracy_warnings

    st = st or _stat(cube)
    if st is None:
        return []
    key = (st.st_ino, st.st_size, st.st_mtime_ns)
    if cache is not None and cache.get(cube, (None,))[0] == key:
        return cache[cube][1]
    try:
        import store

        found = accuracy_warnings(store.read_header(cube).attrs)
    except OSError:   # unreadable (a damaged cube): `status SWEEP` says how to repair it
        found = [UNREADABLE]
    if cache is not None:
        cache[cube] = (key, found)
    return found


def sweep_summary(row: dict, live: str, root: Path, cache: dict | None = None) -> dict:
    """One sweep as JSON values (see the module docstring)."""
    from store import SweepDir

    from .run.progress import eta_s

    stale = is_stale(row)
    cube = root / row["sweep_id"] / "cube.nc"   # one stat per sweep (1,000 in a catalogue)
    st = _stat(cube)
    if st is None:   # an older store's cube.h5, or none yet
        cube = SweepDir(root, row["sweep_id"]).cube
        st = _stat(cube)
    return {
        "sweep_id": row["sweep_id"], "name": row["name"], "earlier_names": earlier_names(row),
        "state": live, "stale": stale, "state_text": live + (f" ({STALE})" if stale else ""),
        "n_points": int(row["n_points"]), "done_points": int(row["done_points"]),
        "failed_points": int(row["failed_points"]), "n_blocks": int(row["n_blocks"]),
        "done_blocks": int(row["done_blocks"]),
        "eta_s": _rounded(eta_s(row)) if live == "running" else None,
        "cancel_requested": bool(row.get("cancel_requested")),
        "path": spec_method(row), "folder": str(cube.parent),
        "has_cube": st is not None, "warnings": cube_warnings(cube, cache, st) if st else [],
        "created": str(row["created"]), "updated": str(row["updated"]),
        "finished": str(row["updated"]) if live in FINAL else None,
        "message": str(row.get("message") or ""), "owner": str(row.get("owner") or ""),
    }


def store_summary(root: Path, cache: dict | None = None) -> dict:
    """Every sweep of the store at ``root`` and its serve processes, as JSON values."""
    cat = catalogue(root)
    rows = cat.list()
    sweeps = [sweep_summary(r, cat.live_state(r), root, cache) for r in rows]
    servers = [{k: s[k] for k in ("owner", "sweep_id", "cluster", "device", "started")}
               for s in cat.servers()]
    return {"store": str(root), "sweeps": sweeps, "servers": servers}


def sweep_detail(root: Path, sweep_id: str, ds=None) -> dict:
    """One sweep with its spec, engine fingerprint and error estimate (``status SWEEP
    --format json``; the web view's sweep page)."""
    from .lookup import stale_note
    from .version import results_fingerprint

    cat = catalogue(root)
    row = cat.get(sweep_id)
    out = sweep_summary(row, cat.live_state(row), root)
    attrs = dict(ds.attrs) if ds is not None else {}
    raw = attrs.get("error_estimate")
    try:
        estimate = json.loads(raw) if isinstance(raw, str) else (raw or None)
    except ValueError:
        estimate = None
    out.update(spec=json.loads(row["spec_json"]),
               engine_fingerprint=str(attrs.get("engine_fingerprint")
                                      or row.get("engine_fingerprint") or ""),
               installed_engine=results_fingerprint(), stale_note=stale_note(row, ds, root),
               error_estimate=estimate)
    return out


def _rounded(seconds: float | None) -> float | None:
    """An ETA to the second: a row changes when its progress does, not on every read."""
    return None if seconds is None else float(round(seconds))
