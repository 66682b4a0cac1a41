"""How far off were the plan's estimates? A small record in the store.

``ditherlab plan`` writes its estimate of each level to ``<store>/estimates.json``;
``submit`` adds the measured wall time when the same sweep finishes at that level
(:func:`record_run`, called by the runner's callers: the command line, ``run_sweep``,
serve); the next ``plan`` prints how the last estimate compared with reality. No number of
a cube comes from here: off the computing path (sweeps.version).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

FILE = "estimates.json"


def _load(root: Path) -> dict:
    try:
        return json.loads((Path(root) / FILE).read_text())
    except (OSError, ValueError):
        return {}


def _save(root: Path, data: dict) -> None:
    from store.atomic import atomic_write

    atomic_write(Path(root) / FILE, lambda tmp: tmp.write_text(json.dumps(data, indent=1)))


def record_estimate(root: Path, sweep_id: str, estimates: dict[str, float]) -> None:
    """Remember the estimated wall seconds per level for ``sweep_id``."""
    data = _load(root)
    data[sweep_id] = {"estimated_s": estimates, "when": time.time()}
    _save(root, data)


def record_actual(root: Path, sweep_id: str, level: str, wall_s: float) -> None:
    """Remember the measured wall time of a sweep that was estimated before."""
    data = _load(root)
    if sweep_id in data and level in data[sweep_id]["estimated_s"]:
        data[sweep_id].setdefault("actual_s", {})[level] = wall_s
        _save(root, data)


def record_run(root: Path, plan, result) -> None:
    """After a run (a :class:`sweeps.run.outcome.SubmitResult`): its measured compute time,
    when it computed blocks and ran to its end (every point final, not stopped)."""
    if "compute_s" in result.timings and result.state in ("done", "partial"):
        record_actual(Path(root), plan.sweep_id, plan.numerics.label,
                      result.timings["compute_s"])


def recorded(root: Path, sweep_id: str) -> dict:
    """What ``plan --record`` estimated for ``sweep_id`` (wall seconds per level) and what
    ``submit`` measured at the level it ran: ``{"estimated_s": {...}, "actual_s": {...}}``,
    empty when ``plan`` was never asked to record it. Reads only."""
    row = _load(root).get(sweep_id) or {}
    return {k: dict(row[k]) for k in ("estimated_s", "actual_s") if isinstance(row.get(k), dict)}


def last_comparison(root: Path) -> str | None:
    """One line on the newest estimate that has a measured counterpart."""
    rows = [(v["when"], k, v) for k, v in _load(root).items() if v.get("actual_s")]
    if not rows:
        return None
    _, sweep_id, row = max(rows)
    level, actual = next(iter(row["actual_s"].items()))
    est = row["estimated_s"][level]
    return (f"last checked estimate: sweep {sweep_id} at {level}: estimated {est:.1f} s, "
            f"took {actual:.1f} s ({(est - actual) / actual * 100:+.0f} %)")
