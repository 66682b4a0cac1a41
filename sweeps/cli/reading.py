"""``ditherlab status``, ``query`` and ``map``: commands that only read a store.

They never write: the catalogue is read as a snapshot (``sweeps.lookup.catalogue``), so a
store path that does not exist stays absent and a read-only store works.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from ..errors import RefusedError
from ..exports import draw_map, parse_selection, query_text
from ..lookup import (STALE, catalogue, inferred_note, is_stale, open_checked, read_notes,
                      read_sweep, resolve_sweep, stale_note, store_root)


def parse_sel(items: list[str] | None) -> dict[str, float]:
    """``--sel AXIS=VALUE ...`` as a dict, by the rules of sweeps.exports.parse_selection
    (``map --kind friction`` takes several W curves before this, sweeps.cli.gallery_commands)."""
    pairs = []
    for item in items or ():
        axis, eq, value = item.partition("=")
        if not eq:
            raise RefusedError(f"--sel: expected AXIS=VALUE (e.g. v_d=0.1), got {item!r}")
        pairs.append((axis.strip(), value))
    return parse_selection(pairs)


def _read(args):
    """The cube of ``args.sweep``, found, opened and checked, its warnings said (query,
    map): sweeps.lookup.read_sweep, the read path of the API and the web view too."""
    root = store_root(args.store)
    sweep_id, _, ds = read_sweep(root, args.sweep)
    for note in read_notes(root, sweep_id, ds):
        print(f"ditherlab: warning: {note}", file=sys.stderr)
    return ds


def cmd_status(args) -> int:
    import store

    from ..service import queue_hint

    root = store_root(args.store)
    if getattr(args, "format", "table") == "json":
        return _status_json(root, args.sweep)
    cat = catalogue(root)
    if args.sweep:
        sweep_id, cube = resolve_sweep(root, args.sweep, need_cube=False)
        row = cat.get(sweep_id)
        row["path"] = str(cube.parent)   # where it is now (a store may have been moved)
        ds = open_checked(sweep_id, cube, _header) if cube.exists() else None
        live, note = cat.live_state(row), stale_note(row, ds, root)
        row["state"] = f"{live} ({STALE})" if note else live
        for key, value in _shown(row, live).items():
            print(f"{key:>14}: {value}")
        if note:
            print(f"{'':>16}{note}")
        elif live == store.catalogue.STALLED:
            print(f"{'':>16}the submitting process ({row['owner']}) is gone; submit the spec "
                  "again to resume (finished blocks are kept)")
        elif live == "queued":
            print(f"{'':>16}{queue_hint(cat, [row])}")
        if ds is not None:   # checked: not another sweep's estimate and warnings
            _print_error_estimate(ds)
            _warn_accuracy(ds)
        return 0
    rows = cat.list()
    if not rows:
        print(f"no sweeps in {root}")
        return 0
    lives = [cat.live_state(r) for r in rows]
    states = [live + (f" ({STALE})" if is_stale(r) else "") for r, live in zip(rows, lives)]
    w = max(10, *(len(s) + 1 for s in states))
    print(f"{'sweep':<13}{'name':<24}{'state':<{w}}{'points':>8}{'done':>8}{'failed':>8}"
          f"{'blocks':>10}  note")
    for r, state, live in zip(rows, states, lives):
        blocks = f"{r['done_blocks']}/{r['n_blocks']}" if r["n_blocks"] else "-"
        print(f"{r['sweep_id']:<13}{r['name'][:23]:<24}{state:<{w}}{r['n_points']:>8}"
              f"{r['done_points']:>8}{r['failed_points']:>8}{blocks:>10}  "
              f"{_note(r, live, root)}")
    hint = queue_hint(cat, rows)
    if hint:
        print(hint)
    return 0


def _status_json(root: Path, key: str | None) -> int:
    """``status --format json``: the data the web view's pages show (sweeps.overview)."""
    from ..overview import store_summary, sweep_detail

    if key:
        sweep_id, cube = resolve_sweep(root, key, need_cube=False)
        ds = open_checked(sweep_id, cube, _header) if cube.exists() else None
        data = sweep_detail(root, sweep_id, ds)
    else:
        data = store_summary(root)
    print(json.dumps(data, indent=1))
    return 0


def _header(cube: Path):
    """The cube's attributes (all ``status`` reads of it), or an unreadable cube's one line."""
    import store

    try:
        return store.read_header(cube)
    except OSError:
        store.open_cube(cube)   # raises the one-line CubeError that says how to repair it
        raise


def _note(row: dict, live: str, root: Path, width: int = 90) -> str:
    """The last column of ``status``: progress and ETA, the error, or when it changed; for a
    finished sweep whose cube records accuracy warnings, how many and where to read them."""
    from store import SweepDir

    from ..overview import UNREADABLE, cube_warnings
    from ..service import progress_text

    if live == "running":
        text = progress_text(row) + (", cancel requested" if row["cancel_requested"] else "")
    elif live == "stalled":
        text = f"{row['owner']} is gone; submit the spec again to resume"
    elif live == "queued":
        text = row["message"] or f"queued {row['queued_at'][:19]}"
    elif live == "done":
        text = f"finished {row['updated'][:19]}"
    else:
        text = row["message"] or f"{live} {row['updated'][:19]}"
    if live in ("done", "partial"):
        found = cube_warnings(SweepDir(root, row["sweep_id"]).cube)
        if found == [UNREADABLE]:   # (it was counted as "1 accuracy warning")
            text = f"the cube cannot be read (`ditherlab status {row['sweep_id']}`); {text}"
        elif found:
            text = (f"{len(found)} accuracy warning{'s' * (len(found) > 1)} (`ditherlab "
                    f"status {row['sweep_id']}`); {text}")
    return text if len(text) <= width else text[:width - 3] + "..."


def _shown(row: dict, live: str) -> dict:
    """A catalogue row for ``status SWEEP``: times readable, progress and ETA added."""
    import time

    from ..service import clock_text, progress_text

    shown = {k: v for k, v in row.items() if k not in ("spec_json", "aliases")}
    earlier = [a for a in str(row.get("aliases") or "").splitlines() if a and a != row["name"]]
    if earlier:   # the same spec submitted under other names before; they still find it
        shown["also_named"] = ", ".join(earlier)
    beat = float(row.get("heartbeat") or 0.0)
    shown["heartbeat"] = f"{time.time() - beat:.1f} s ago" if beat else "-"
    started = float(row.get("run_started") or 0.0)
    shown["run_started"] = (time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(started))
                            if started else "-")
    if live == "running":
        shown["progress"] = progress_text(row)
    elif live == "failed":
        shown["error"] = row["message"]
    if started and live != "running" and row["state"] != "queued":
        shown["run_took"] = clock_text(
            _seconds_between(started, row["updated"]))
    return shown


def _seconds_between(epoch: float, iso: str) -> float | None:
    from datetime import datetime

    try:
        return datetime.fromisoformat(iso).timestamp() - epoch
    except ValueError:
        return None


def _print_error_estimate(ds) -> None:
    raw = ds.attrs.get("error_estimate")
    if not raw:
        return
    est = json.loads(raw) if isinstance(raw, str) else raw
    if "change" not in est:   # written before the gate existed
        print(f"{'error est.':>14}: (an old estimate without promises; submit again)")
        return
    print(f"{'error est.':>14}: change against {est['compared_with']} on "
          f"{est['sample_points']} sample points (fractions absolute, others relative)")
    for name, change in est["change"].items():
        flag = "ok" if change <= est["promise"][name] else "OVER PROMISE"
        print(f"{'':>16}{name:<22} {change:9.2e}  promise {est['promise'][name]:7.0e}  {flag}")


def _warn_accuracy(ds) -> None:
    """One stderr line per accuracy warning recorded in the cube
    (sweeps.estimates.error_estimate)."""
    from store.attrs import accuracy_warnings

    for w in accuracy_warnings(ds.attrs):
        print(f"ditherlab: warning: {w}", file=sys.stderr)


def warn_inferred(ds, sel) -> None:
    """Values, not classes, read from a refined cube's inferred points: say so once."""
    import store

    if "provenance" in ds:
        note = inferred_note(store.select(ds, parse_sel(sel))["provenance"].values)
        if note:
            print(f"ditherlab: warning: {note}", file=sys.stderr)


def cmd_query(args) -> int:
    sel = parse_sel(args.sel)   # a malformed selection is refused before the store is read
    ds = _read(args)
    text = query_text(ds, args.var, sel, args.format)
    warn_inferred(ds, args.sel)
    sys.stdout.write(text)
    return 0


def open_for_map(args):
    """The cube ``map`` draws (``args.sweep``), after checking ``args.output``'s name and
    folder (before any work) and with its stale and accuracy warnings said."""
    import store

    try:
        store.figure_format(args.output)
    except ValueError as exc:
        raise RefusedError(str(exc)) from None
    return _read(args)


def cmd_map(args) -> int:
    sel = parse_sel(args.sel)   # a malformed selection is refused before the store is read
    ds = open_for_map(args)
    draw_map(ds, args.kind, sel, args.output)
    if args.kind == "friction":   # curves of values, not a map of classes
        warn_inferred(ds, args.sel)
    print(f"wrote {args.output}")
    return 0


