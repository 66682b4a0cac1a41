"""Every shipped spec and gallery scene keeps every level's promise (issue 30).

Run: ``.venv/bin/python scripts/promise_check.py [--levels draft standard reference]
[--only NAME ...] [--store DIR] [--json OUT]``

For each spec of ``specs/`` that is not a gallery scene (``demo-*``) and each gallery scene
at the small size (``sweeps.gallery.scenes``: Figs. 1, 9, 10, 14 and the lam = 0.5 twin),
the sweep is run at each accuracy level (the spec's ``accuracy`` replaced) with the
service's own error estimate (sweeps.estimate: a stratified sample re-run one level finer,
compared per output with what the level promises, sweeps.accuracy.promise). A level keeps
its promise on a spec when the estimate records no warning. The averaged and harmonic-
balance specs have no integration error to estimate and are listed as such.

Printed: one line per (spec, level) with the largest change relative to its promise and
the warnings; the exit status is 1 when any warns. ``tests/accuracy/test_promises.py``
(slow) runs the same check.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LEVELS = ("draft", "standard", "reference")


def shipped_specs() -> dict[str, dict]:
    """name -> spec dict: the demo specs of specs/ as written, the gallery scenes small."""
    import tomllib

    from sweeps.gallery.scenes import REGISTRY, SPECS

    scene_files = {s.spec_file for s in REGISTRY.values()}
    out = {}
    for path in sorted(SPECS.glob("*.toml")):
        if path.name not in scene_files:
            with open(path, "rb") as fh:
                out[path.stem] = tomllib.load(fh)
    for name, scene in REGISTRY.items():
        out[f"{name}-small"] = scene.spec("small")
    return out


def check(specs: dict[str, dict], levels=LEVELS, store=None, workers=2, log=print) -> list:
    """Run every spec at every level; returns ``[(name, level, estimate or None)]``, the
    estimate being the cube's ``error_estimate`` (None: nothing to estimate)."""
    from sweeps.api import open_sweep, run_sweep

    store = store or tempfile.mkdtemp(prefix="promise-")
    rows = []
    for name, spec in specs.items():
        for level in levels:
            spec_l = {**spec, "accuracy": level, "name": f"{spec.get('name', name)}-{level}"}
            res = run_sweep(spec_l, store, workers=workers, progress=False)
            ds = open_sweep(res.sweep_id, store)
            est = json.loads(ds.attrs["error_estimate"]) if "error_estimate" in ds.attrs else None
            rows.append((name, level, est))
            log(_line(name, level, est))
    return rows


def _line(name, level, est) -> str:
    if est is None:
        return f"{name:<22}{level:<10} (no integration error to estimate)"
    worst = max(((c / est["promise"][k], k) for k, c in est["change"].items()
                 if est["promise"].get(k)), default=(0.0, "-"))
    return (f"{name:<22}{level:<10} worst change/promise {worst[0]:.2g} ({worst[1]}); "
            f"{len(est['warnings'])} warnings" + "".join(f"\n    {w}" for w in est["warnings"]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", nargs="+", default=list(LEVELS), choices=LEVELS)
    ap.add_argument("--only", nargs="+", metavar="NAME")
    ap.add_argument("--store", default=None)
    ap.add_argument("--json", default=None, help="write the estimates here")
    args = ap.parse_args(argv)
    specs = shipped_specs()
    if args.only:
        specs = {k: v for k, v in specs.items() if k in args.only}
    rows = check(specs, args.levels, args.store)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 1 if any(est and est["warnings"] for _, _, est in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
