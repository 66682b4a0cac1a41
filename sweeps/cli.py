"""The ``ditherlab`` command line (DESIGN.md §5).

    ditherlab submit SPEC.toml [--store DIR] [--scheduler tcp://HOST:PORT | --workers N] [--detach]
    ditherlab serve [--store DIR] [--scheduler tcp://HOST:PORT | --workers N]
    ditherlab status [SWEEP]
    ditherlab cancel SWEEP [--wait]
    ditherlab query SWEEP [--var NAME] [--sel AXIS=VALUE ...] [--format table|csv|json]
    ditherlab map SWEEP --kind stick-slip|stability|friction [--sel AXIS=VALUE ...] -o FILE.png
    ditherlab plan SPEC.toml

Exit status: 0 success, 1 a run or lookup failed, 2 the input (spec, arguments) was refused.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from contextlib import contextmanager
from pathlib import Path

from . import history
from .spec import DEFAULT_MAX_POINTS, SpecError, load_spec

EXIT_FAILED, EXIT_REFUSED, EXIT_INTERRUPTED = 1, 2, 130


class UserError(Exception):
    """A lookup or argument problem, reported as one line without a traceback."""

    exit_status = EXIT_FAILED


def store_root(arg: str | None) -> Path:
    return Path(arg or os.environ.get("DITHERLAB_STORE") or "ditherlab-store")


def parse_sel(items: list[str] | None) -> dict[str, float]:
    sel = {}
    for item in items or ():
        axis, eq, value = item.partition("=")
        if not eq:
            raise UserError(f"--sel: expected AXIS=VALUE (e.g. v_d=0.1), got {item!r}")
        try:
            sel[axis.strip()] = float(value)
        except ValueError:
            raise UserError(f"--sel {axis}: value must be a number, got {value!r}") from None
    return sel


def resolve_sweep(root: Path, key: str, need_cube: bool = True) -> tuple[str, Path]:
    """A sweep id, id prefix or name -> (sweep id, cube path); with ``need_cube=False``
    the cube may not exist yet (a queued sweep)."""
    import store

    cat = store.Catalogue(root)
    try:
        row = cat.find(key)
    except LookupError as exc:  # an ambiguous id prefix
        raise UserError(str(exc)) from None
    if row is None:
        raise UserError(f"no sweep {key!r} in store {root} (see `ditherlab status`)")
    if row["name"] == key and row["sweep_id"] != key and is_stale(row):
        # a name: prefer the newest sweep of that name made by the installed engine
        current = [r for r in cat.list() if r["name"] == key and not is_stale(r)
                   and store.SweepDir(root, r["sweep_id"]).cube.exists()]
        if current:
            row = max(current, key=lambda r: r["created"])
    cube = store.SweepDir(root, row["sweep_id"]).cube
    if need_cube and not cube.exists():
        raise UserError(f"sweep {row['sweep_id']} has no cube yet at {cube}; submit it again")
    return row["sweep_id"], cube


# --- which engine made a sweep (README "Which engine made this cube") -------------------

STALE = "stale: engine changed"


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
    try:
        spec = load_spec(json.loads(row["spec_json"]), max_points=max(row["n_points"], 1))
    except (SpecError, ValueError, TypeError):
        return True
    return spec.sweep_id != row["sweep_id"]


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


def _warn_stale(root: Path, sweep_id: str, ds) -> None:
    """One stderr line when the sweep being served is stale (query, map)."""
    import store

    note = stale_note(store.Catalogue(root).get(sweep_id), ds, root)
    if note:
        print(f"ditherlab: warning: {note}", file=sys.stderr)


# --- commands --------------------------------------------------------------------------

def cmd_submit(args) -> int:
    import store

    from .plan import make_plan
    from .run import submit

    spec = load_spec(args.spec, max_points=args.max_points)
    plan = make_plan(spec)
    root = store_root(args.store)
    print(f"sweep {plan.sweep_id} '{spec.name}': {plan.n_points} points in "
          f"{len(plan.blocks)} blocks, path={plan.path}", file=sys.stderr)
    if args.detach:
        return _submit_detached(plan, root)
    try:
        res = submit(plan, root, scheduler=args.scheduler, workers=args.workers,
                     progress=not args.quiet)
    except KeyboardInterrupt:
        raise Interrupted(f"interrupted; {_kept(plan, root)}; "
                          "submit the spec again to resume") from None
    except store.layout.NoSpaceError as exc:
        raise UserError(f"{exc}; {_kept(plan, root)}") from None
    if res.attached_to:
        verb = f"attached to the run in {res.attached_to}"
    else:
        verb = "already complete" if res.blocks_run == 0 else f"ran {res.blocks_run} blocks"
    print(f"{res.sweep_id}: {res.state}, {verb}; {res.n_ok}/{res.n_points} ok, "
          f"{res.n_failed} failed; {res.wall_s:.1f} s\ncube: {res.cube_path}")
    if res.message:
        print(f"{res.sweep_id}: {res.message}", file=sys.stderr)
    return 0 if res.state == "done" else EXIT_FAILED


def _kept(plan, root: Path) -> str:
    """What a stopped submit kept: ``the journal keeps the N finished blocks (of M)``."""
    import store

    try:
        n = len(store.Journal(store.SweepDir(root, plan.sweep_id).journal).files())
    except OSError:
        return "the journal keeps its finished blocks"
    return f"the journal keeps the {n} finished blocks (of {len(plan.blocks)})"


def _submit_detached(plan, root: Path) -> int:
    """``submit --detach``: queue the sweep for ``ditherlab serve`` and return at once."""
    import store

    from .service import enqueue

    row = enqueue(plan, root)
    cat = store.Catalogue(root)
    state = cat.live_state(row)
    if state == "queued":
        print(f"{row['sweep_id']}: queued")
        if not cat.servers():
            print(f"ditherlab: no `ditherlab serve` is running on store {root}; start one to "
                  "run the queue", file=sys.stderr)
    elif state == "running":
        print(f"{row['sweep_id']}: running in {row['owner']} (`ditherlab status "
              f"{row['sweep_id']}` shows its progress)")
    else:
        print(f"{row['sweep_id']}: {state}, already complete")
    return 0


def cmd_serve(args) -> int:
    from .service import serve

    return serve(store_root(args.store), scheduler=args.scheduler, workers=args.workers,
                 progress=False)


def cmd_cancel(args) -> int:
    import store

    from .service import cancel

    try:
        row = cancel(store_root(args.store), args.sweep, wait=args.wait)
    except LookupError as exc:
        raise UserError(str(exc)) from None
    state, sid = store.Catalogue.live_state(row), row["sweep_id"]
    if state == "cancelled":
        print(f"{sid}: cancelled; {row['message']}")
    elif state == "running" and row["cancel_requested"]:
        print(f"{sid}: cancel requested; {row['owner']} stops after its blocks in flight "
              f"(`ditherlab status {sid}` shows when)")
    else:
        print(f"{sid}: {state}; nothing to cancel")
    return 0


def cmd_status(args) -> int:
    import store

    from .service import queue_hint

    root = store_root(args.store)
    cat = store.Catalogue(root)
    if args.sweep:
        sweep_id, cube = resolve_sweep(root, args.sweep, need_cube=False)
        row = cat.get(sweep_id)
        ds = store.open_cube(cube) if cube.exists() else None
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
        if ds is not None:
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
              f"{r['done_points']:>8}{r['failed_points']:>8}{blocks:>10}  {_note(r, live)}")
    hint = queue_hint(cat, rows)
    if hint:
        print(hint)
    return 0


def _note(row: dict, live: str, width: int = 90) -> str:
    """The last column of ``status``: progress and ETA, the error, or when it changed."""
    from .service import progress_text

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
    return text if len(text) <= width else text[:width - 3] + "..."


def _shown(row: dict, live: str) -> dict:
    """A catalogue row for ``status SWEEP``: times readable, progress and ETA added."""
    import time

    from .service import format_seconds, progress_text

    shown = {k: v for k, v in row.items() if k != "spec_json"}
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
        shown["run_took"] = format_seconds(
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
    """One stderr line per accuracy warning recorded in the cube (sweeps.errors)."""
    from .errors import warnings_of

    for w in warnings_of(ds):
        print(f"ditherlab: warning: {w}", file=sys.stderr)


def cmd_query(args) -> int:
    import store

    root = store_root(args.store)
    sweep_id, cube = resolve_sweep(root, args.sweep)
    ds = store.open_cube(cube)
    _warn_stale(root, sweep_id, ds)
    _warn_accuracy(ds)
    try:
        df = store.table(ds, var=args.var, sel=parse_sel(args.sel))
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if args.format == "csv":
        sys.stdout.write(df.to_csv(index=False))
    elif args.format == "json":
        print(json.dumps(json.loads(df.to_json(orient="records")), indent=1))
    else:
        print(df.to_string(index=False))
    return 0


def cmd_map(args) -> int:
    import store

    root = store_root(args.store)
    sweep_id, cube = resolve_sweep(root, args.sweep)
    ds = store.open_cube(cube)
    _warn_stale(root, sweep_id, ds)
    _warn_accuracy(ds)
    draw = {"stick-slip": store.stick_slip_map, "stability": store.stability_map,
            "friction": store.friction_curves}[args.kind]
    try:
        draw(ds, args.output, sel=parse_sel(args.sel))
    except ValueError as exc:
        raise UserError(str(exc)) from None
    print(f"wrote {args.output}")
    return 0


def cmd_plan(args) -> int:
    from .calibrate import estimates, format_seconds
    from .plan import make_plan

    spec = load_spec(args.spec, max_points=args.max_points)
    plan = make_plan(spec)
    shape = " x ".join(f"{a}={len(v)}" for a, v in plan.coords.items())
    print(f"sweep      {plan.sweep_id}  '{spec.name}'")
    print(f"points     {plan.n_points}  ({shape})  in {len(plan.blocks)} interleaved blocks")
    print(f"path       {plan.path}" + ("" if plan.path == "simulate" else
                                       "  (no time integration)"))
    print(f"scene      system={spec.system} friction={spec.friction} dither={plan.scene.dither}")
    if plan.path == "simulate":
        on = [k for k, v in plan.effects().items() if v]
        off = [k for k, v in plan.effects().items() if not v]
        print(f"effects    compiled in: {', '.join(on) or '-'}; left out: {', '.join(off) or '-'}")
        s = plan.numerics.settings
        stops = ("; steps land on every square-wave switch"
                 if plan.scene.dither == "square-velocity" else "")
        print(f"numerics   {plan.numerics.integrator} ({plan.numerics.label}): rtol={s.rtol:g} "
              f"atol={s.atol:g}{' (natural units)' if s.atol_units == 'natural' else ''}{stops}")
    print(f"outputs    {', '.join(plan.outputs)}")
    print(f"estimates  (calibrated now on this machine, {args.workers} workers, compute "
          f"phase; cluster start and first compilation come on top)")
    found = estimates(spec, workers=args.workers)
    for est in found:
        print(f"  {est.level:<10} {est.integrator:<11} {format_seconds(est.per_point_s):>9} "
              f"per point  ->  {format_seconds(est.wall_s)} wall")
    root = store_root(args.store)
    previous = history.last_comparison(root)
    try:
        history.record_estimate(root, plan.sweep_id, {e.level: e.wall_s for e in found})
    except OSError:   # a read-only store (or a full disk): shown, just not remembered
        pass
    if previous:
        print(previous)
    return 0


# --- parser ----------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="ditherlab", description="Parameter sweeps of friction "
                                 "dynamics under dither: submit, inspect, query, draw.")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--store", help="store folder (default $DITHERLAB_STORE or "
                        "./ditherlab-store)")
    sub = ap.add_subparsers(dest="command", required=True)

    p = sub.add_parser("submit", parents=[common], help="run a sweep spec (resumes a partial one)")
    p.add_argument("spec", help="spec file (.toml or .json)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", help="address of an existing dask scheduler, tcp://HOST:PORT")
    where.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    p.add_argument("--max-points", type=int, default=DEFAULT_MAX_POINTS, help="point budget")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--detach", action="store_true",
                   help="queue the sweep for `ditherlab serve` and return its id at once")
    p.set_defaults(func=cmd_submit)

    p = sub.add_parser("serve", parents=[common],
                       help="run queued sweeps, oldest first, until SIGTERM or Ctrl-C")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", help="address of an existing dask scheduler, tcp://HOST:PORT")
    where.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    p.set_defaults(func=cmd_serve)

    p = sub.add_parser("cancel", parents=[common],
                       help="cancel a queued sweep, or stop a running one after its blocks "
                       "in flight (the journal is kept; submitting again resumes)")
    p.add_argument("sweep")
    p.add_argument("--wait", action="store_true", help="return once the run has stopped")
    p.set_defaults(func=cmd_cancel)

    p = sub.add_parser("status", parents=[common], help="list sweeps, or show one")
    p.add_argument("sweep", nargs="?")
    p.set_defaults(func=cmd_status)

    p = sub.add_parser("query", parents=[common], help="print a cube's values")
    p.add_argument("sweep")
    p.add_argument("--var", help="variable (default: all outputs)")
    p.add_argument("--sel", action="append", metavar="AXIS=VALUE", help="nearest-point selection")
    p.add_argument("--format", choices=("table", "csv", "json"), default="table")
    p.set_defaults(func=cmd_query)

    p = sub.add_parser("map", parents=[common], help="draw a map PNG from a cube")
    p.add_argument("sweep")
    p.add_argument("--kind", required=True, choices=("stick-slip", "stability", "friction"))
    p.add_argument("--sel", action="append", metavar="AXIS=VALUE")
    p.add_argument("-o", "--output", required=True, help="PNG file to write")
    p.set_defaults(func=cmd_map)

    p = sub.add_parser("plan", parents=[common],
                       help="what a spec will run, and its cost per accuracy level")
    p.add_argument("spec")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--max-points", type=int, default=DEFAULT_MAX_POINTS)
    p.set_defaults(func=cmd_plan)
    return ap


def main(argv: list[str] | None = None) -> int:
    """Run one command; every fault ends in one line on stderr and the exit status of the
    README (0 ok, 1 failed, 2 refused, 130 interrupted), never a traceback
    (``DITHERLAB_DEBUG=1`` shows the traceback of an unexpected error)."""
    args = build_parser().parse_args(argv)
    if getattr(args, "workers", 1) is not None and getattr(args, "workers", 1) < 1:
        print("ditherlab: --workers must be >= 1", file=sys.stderr)
        return EXIT_REFUSED
    with _one_line_warnings():
        try:
            return args.func(args)
        except SpecError as exc:
            return _fail(exc, EXIT_REFUSED)
        except (UserError, Interrupted) as exc:
            return _fail(exc, exc.exit_status)
        except KeyboardInterrupt:
            return _fail("interrupted", EXIT_INTERRUPTED)
        except Exception as exc:  # noqa: BLE001 -- the one-line promise (README)
            return _fail_unexpected(exc)


class Interrupted(Exception):
    """Ctrl-C, told with what was kept and how to resume."""

    exit_status = EXIT_INTERRUPTED


def _fail(message, status: int) -> int:
    print(f"ditherlab: {message}", file=sys.stderr)
    return status


def _fail_unexpected(exc: Exception) -> int:
    """Store faults (disk full, read-only, damaged files), OS and SQLite errors, and bugs:
    one line each."""
    import sqlite3

    import store

    if os.environ.get("DITHERLAB_DEBUG"):
        raise exc
    if isinstance(exc, store.layout.StoreError):
        return _fail(exc, exc.exit_status)
    if isinstance(exc, OSError):
        where = f" ({exc.filename})" if exc.filename else ""
        return _fail(f"{exc.strerror or exc}{where}", EXIT_FAILED)
    if isinstance(exc, sqlite3.Error):
        if "full" in str(exc):   # SQLite's "database or disk is full"
            return _fail(f"no space left on device writing the catalogue ({exc}): free "
                         "some space and run the command again", EXIT_FAILED)
        return _fail(f"catalogue error: {exc}", EXIT_FAILED)
    text = f"{type(exc).__name__}: {exc}".replace("\n", " ")
    return _fail(f"internal error: {text[:300]} (DITHERLAB_DEBUG=1 shows the traceback)",
                 EXIT_FAILED)


@contextmanager
def _one_line_warnings():
    """Warnings (a journal block set aside, a busy port) and log records as
    ``ditherlab: warning: ...`` lines."""
    import logging
    import warnings

    def show(message, category, filename, lineno, file=None, line=None):
        text = str(message).replace("\n", " ")
        print(f"ditherlab: warning: {text}", file=file or sys.stderr)

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("ditherlab: warning: %(message)s"))
    logger = logging.getLogger("ditherlab")
    saved = warnings.showwarning
    warnings.showwarning = show
    logger.addHandler(handler)
    try:
        yield
    finally:
        warnings.showwarning = saved
        logger.removeHandler(handler)


if __name__ == "__main__":
    sys.exit(main())
