"""Every shipped spec and gallery scene keeps every level's promise (issue 30).

Run: ``.venv/bin/python scripts/promise_check.py [--levels draft standard reference]
[--only NAME ...] [--spec FILE ...] [--store DIR] [--json OUT]`` (``--spec``: your own
specs instead of the shipped ones)

For each spec of ``specs/`` that is not a gallery scene (``demo-*``) and each gallery scene
at the small size (``sweeps.gallery.scenes``: Figs. 1, 9, 10, 14 and the lam = 0.5 twin),
the sweep is run at each accuracy level (the spec's ``accuracy`` replaced) with the
service's own error estimate (sweeps.estimate: a stratified sample re-run 100x more accurately,
compared per output with what the level promises, sweeps.accuracy.promise), and every
point of a level's cube is compared with the next level's cube the same way. A level keeps
its promise on a spec when neither records a warning. The averaged and harmonic-
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
import warnings
from pathlib import Path

import numpy as np

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


def _read(path: str) -> dict:
    """The spec dict of a file, checked first as ``ditherlab plan`` checks it (a bad file
    is its message, not a traceback)."""
    import tomllib

    from sweeps.errors import SpecError
    from sweeps.spec.load import load_spec

    try:
        load_spec(path)
    except SpecError as exc:
        raise SystemExit(f"promise_check: {exc}") from None
    text = Path(path).read_text(encoding="utf-8-sig")
    return json.loads(text) if path.endswith(".json") else tomllib.loads(text)


def check(specs: dict[str, dict], levels=LEVELS, store=None, workers=2, log=print) -> list:
    """Run every spec at every level; returns ``[(name, level, estimate or None)]``, the
    estimate being the cube's ``error_estimate`` (None: nothing to estimate) with, where
    the next finer level ran too, ``grid_change`` and ``grid_warnings``: every point of the
    grid compared with that level's cube (:func:`grid_compare`)."""
    from sweeps.workers.cluster import dask_client

    store = store or tempfile.mkdtemp(prefix="promise-")
    rows = []
    with dask_client(workers=workers) as client:   # one cluster for every run
        for name, spec in specs.items():
            rows += _check_spec(name, spec, levels, store, client, log)
    return rows


def _check_spec(name: str, spec: dict, levels, store, client, log) -> list:
    """One spec at every level on ``client``: its rows, each level's estimate compared over
    the whole grid with the next finer level's cube."""
    from sweeps.api import InferredPointsWarning, open_sweep, run_sweep

    rows, cubes = [], {}
    for level in levels:
        spec_l = {**spec, "accuracy": level, "name": f"{spec.get('name', name)}-{level}"}
        res = run_sweep(spec_l, store, client=client, progress=False)
        with warnings.catch_warnings():   # a refined sweep's inferred points: compared
            warnings.simplefilter("ignore", InferredPointsWarning)   # only where computed
            ds = cubes[level] = open_sweep(res.sweep_id, store)
        est = json.loads(ds.attrs["error_estimate"]) if "error_estimate" in ds.attrs else None
        rows.append((name, level, est))
    for (_, level, est), finer in zip(rows, levels[1:]):
        if est is not None and LEVELS.index(finer) == LEVELS.index(level) + 1:
            est.update(grid_compare(spec, level, cubes[level], finer, cubes[finer]))
    for row in rows:
        log(_line(*row))
    return rows


def grid_compare(spec: dict, level: str, ds, finer: str, ds_finer) -> dict:
    """Every grid point at ``level`` (``ds``) against the next level (``ds_finer``), per
    output, measured as the error estimate measures its sample
    (sweeps.estimates.error_estimate.output_change) and held to ``level``'s promise: the
    sample is drawn by the sweep's id, which changes with the code, so a promise broken at
    one point of 49 was reported by one version and not by the next."""
    from engine import params as P
    from sweeps.estimates.error_estimate import output_change
    from sweeps.planning.plan import make_plan
    from sweeps.spec.accuracy import promise
    from sweeps.spec.load import load_spec

    plan = make_plan(load_spec({**spec, "accuracy": level}))
    ok = ((ds["status"].values == 0) & (ds_finer["status"].values == 0)).reshape(-1)
    if "provenance" in ds and "provenance" in ds_finer:   # a refined sweep: computed points
        ok &= ((ds["provenance"].values == 0) & (ds_finer["provenance"].values == 0)).reshape(-1)
    change, broken = {}, []
    for name in plan.outputs:
        a, b = (np.asarray(d[name].values) for d in (ds, ds_finer))
        a, b = (x.reshape((-1,) + x.shape[4:])[ok] for x in (a, b))
        change[name] = output_change(name, a, b, float(plan.params[P.LONG_STICK]))
        promised = promise(level, name, plan.spec.friction)
        if not change[name] <= promised:
            broken.append(f"{name}: {change[name]:.2e} off {finer} over the grid's "
                          f"{int(ok.sum())} points; {level} promises {promised:.0e}")
    return {"grid_change": change, "grid_warnings": broken}


def _line(name, level, est) -> str:
    if est is None:
        return f"{name:<22}{level:<10} (no integration error to estimate)"
    worst = max(((c / est["promise"][k], k) for k, c in est["change"].items()
                 if est["promise"].get(k)), default=(0.0, "-"))
    grid = max(((c / est["promise"][k], k) for k, c in est.get("grid_change", {}).items()
                if est["promise"].get(k)), default=None)
    warnings = est["warnings"] + est.get("grid_warnings", [])
    return (f"{name:<22}{level:<10} worst change/promise {worst[0]:.2g} ({worst[1]}) on the "
            f"sample" + (f", {grid[0]:.2g} ({grid[1]}) on the grid" if grid else "") +
            f"; {len(warnings)} warnings" + "".join(f"\n    {w}" for w in warnings))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", nargs="+", default=list(LEVELS), choices=LEVELS)
    ap.add_argument("--only", nargs="+", metavar="NAME")
    ap.add_argument("--spec", nargs="+", metavar="FILE", default=(),
                    help="check these spec files (TOML or JSON) instead of the shipped ones")
    ap.add_argument("--store", default=None)
    ap.add_argument("--json", default=None, help="write the estimates here")
    args = ap.parse_args(argv)
    specs = {Path(f).stem: _read(f) for f in args.spec} if args.spec else shipped_specs()
    if args.only:
        specs = {k: v for k, v in specs.items() if k in args.only}
    rows = check(specs, args.levels, args.store)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 1 if any(est and (est["warnings"] or est.get("grid_warnings"))
                    for _, _, est in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
