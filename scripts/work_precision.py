"""Work-precision study: what accuracy costs, measured (writes docs/ACCURACY.md).

Run: ``.venv/bin/python scripts/work_precision.py [--quick] [--scenes fig10 sec7 ...]
[--no-effects] [--replot]``

For each canonical scene (:data:`SCENES`, each a sweep spec of one grid point, so the
scene, parameters and point are exactly those the sweep service would build through
``sweeps.planning.plan.make_plan``) every integrator of ``engine.integrators.METHODS`` is run over
its step/tolerance ladder (:data:`LADDERS`): ``rk4`` over steps per (half-)period (or the
step ``h`` without dither), ``dopri5`` and ``rodas4`` over ``rtol`` with
``atol = ATOL_RATIO * rtol``. Each run is timed through ``engine.blocks.run_block`` (one
point, numba compiled beforehand, median of ``--repeats`` wall times).

Error of a queried output ``q`` against the scene's reference ``q_ref``
(:func:`quantity_error`): ``|q - q_ref| / |q_ref|`` for velocities, forces and times,
``|q - q_ref|`` for time fractions (already in [0, 1]). The *combined* error of a run is the
largest over the scene's queried outputs (``SCENES[name]["queried"]``).

Reference: the first entry of ``SCENES[name]["refs"]`` (DP5 at rtol 1e-12); every other
entry is an independent converged run (RK4 with many steps, RODAS at a tight tolerance)
and the tables report how far they agree with it, per output.

Also measured: the accuracy levels of ``sweeps.spec.accuracy`` on every scene (through
``make_plan(spec, level)``, i.e. the integrator and settings the service would use); the
Fig. 10 quench verdict over the paper's W values at every level; the explicit/stiff
crossover in sigma0; and the "only the effects a scene calls for" cost table
(scripts/work_precision_costs.py). Results go to docs/work_precision.json, the PNG
diagrams to docs/wp_<scene>.png, the tables into docs/ACCURACY.md between its
``<!-- BEGIN generated:... -->`` markers (scripts/work_precision_report.py).
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from wp_core import (  # noqa: E402 (after the sys.path set-up)
    ATOL_RATIO,
    DP5_REF,
    FIG10_W,
    LADDERS,
    METHOD_ORDER,
    QUENCH_RATIO,
    RESULTS,
    SCENES,
    errors,
    is_reference,
    plan_of,
    run_setting,
    settings_of,
    timed_run,
    warm_up,
)

from engine import status as S
from sweeps.spec.models import LEVELS


# --------------------------------------------------------------------------- studies
def ladder(name: str, method: str, dither: str) -> list[dict]:
    own = SCENES[name].get("ladders", {}).get(method)
    return own or LADDERS.get((method, dither)) or LADDERS[method]


def study_scene(name: str, quick: bool, repeats: int, ladders: bool = True) -> dict:
    """Reference runs, their agreement, and every method's ladder on scene ``name``
    (``ladders=False``: the references alone, for the levels study)."""
    cfg = SCENES[name]
    plan = plan_of(cfg["spec"])
    for m in METHOD_ORDER:
        warm_up(plan.scene.with_(integrator=m), plan.params, plan.block_points(0))
    refs = [run_setting(plan, m, s, 1) for m, s in cfg["refs"]]
    for r in refs:
        print(f"  ref {r['method']:7s} {r['label']:12s} {r['time']:.3f} s  status {r['status']}",
              flush=True)
        r["agreement"] = errors(r, refs[0], cfg["queried"])
    if refs[0]["status"][0] != S.OK:
        raise RuntimeError(f"{name}: the reference run {refs[0]['label']} failed")
    rows = []
    for m in METHOD_ORDER if ladders else ():
        steps = ladder(name, m, plan.scene.dither)
        for s in (steps[::2] if quick else steps):
            row = run_setting(plan, m, s, repeats)
            row["error"] = errors(row, refs[0], cfg["queried"])
            row["is_reference"] = is_reference(row, refs[0])
            rows.append(row)
            print(f"  {m:7s} {row['label']:12s} err {row['error']['combined']:9.2e} "
                  f"t {1e3 * row['time']:9.2f} ms evals {row['evals']}", flush=True)
    return {"dither": plan.scene.dither, "queried": list(cfg["queried"]), "refs": refs,
            "runs": rows}


def study_levels(results: dict, repeats: int) -> dict:
    """Error and cost of each level of sweeps.spec.accuracy on each studied scene."""
    out = {}
    for name, res in results.items():
        ref, out[name] = res["refs"][0], {}
        for level in LEVELS:
            plan = plan_of(SCENES[name]["spec"], level)
            warm_up(plan.scene, plan.params, plan.block_points(0))
            row = timed_run(plan.scene, plan.params, plan.block_points(0),
                            plan.numerics.settings, repeats)
            row.update(numerics=plan.numerics.as_dict(), dither=plan.scene.dither,
                       error=errors(row, ref, SCENES[name]["queried"]))
            out[name][level] = row
            print(f"  {name:9s} {level:9s} {plan.numerics.integrator:8s} err "
                  f"{row['error']['combined']:9.2e} t {1e3 * row['time']:9.2f} ms", flush=True)
    return out


def study_quench(repeats: int) -> dict:
    """Fig. 10 (a)-(f): v_slow_p2p and the quench verdict per W, per level and reference."""
    spec = dict(SCENES["fig10"]["spec"])
    spec["grid"] = {**spec["grid"], "W": list(FIG10_W)}
    out = {}
    for level in (None,) + LEVELS:
        plan = plan_of(spec, level or "reference")
        scene = plan.scene
        pts = np.concatenate([plan.block_points(b) for b in range(len(plan.blocks))])
        settings = plan.numerics.settings
        if level is None:
            scene, settings = scene.with_(integrator=DP5_REF[0]), settings_of(DP5_REF[1])
        pts = pts[np.argsort(pts[:, 0])]
        warm_up(scene, plan.params, pts[:1])
        row = timed_run(scene, plan.params, pts, settings, 1 if level is None else repeats)
        p2p = row["outputs"]["v_slow_p2p"]
        row["W"] = [float(w) for w in pts[:, 0]]
        v_ref = spec["grid"]["v_ref"][0]
        row["quenched"] = [bool(x < QUENCH_RATIO * v_ref) for x in p2p]
        row["integrator"] = scene.integrator
        out[level or "reference run"] = row
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="every other ladder rung, 1 repeat")
    ap.add_argument("--scenes", nargs="*", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-effects", action="store_true", help="skip the effect-cost table")
    ap.add_argument("--levels-only", action="store_true",
                    help="references and the accuracy levels only (per-output promises), "
                         "merged into an existing docs/work_precision.json")
    ap.add_argument("--replot", action="store_true",
                    help="only redraw PNGs and tables from docs/work_precision.json")
    args = ap.parse_args(argv)
    import work_precision_report as report
    if args.replot:
        report.write_all(json.loads(RESULTS.read_text()))
        return
    repeats = 1 if args.quick else args.repeats
    if args.levels_only:
        data = json.loads(RESULTS.read_text()) if RESULTS.exists() else {"scenes": {}}
        fresh = {n: study_scene(n, args.quick, repeats, ladders=False) for n in args.scenes}
        for n, res in fresh.items():   # keep the ladders of an earlier full run
            old = data["scenes"].get(n, {})
            data["scenes"][n] = {**res, "runs": old.get("runs", [])}
        print("levels", flush=True)
        data.setdefault("levels", {}).update(study_levels(fresh, repeats))
        data.setdefault("meta", {})["levels_run"] = {
            "engine": _engine_version(), "date": time.strftime("%Y-%m-%d %H:%M"),
            "loadavg": [round(float(x), 2) for x in _loadavg()]}
        RESULTS.write_text(json.dumps(data, indent=1, default=_json_default))
        report.write_all(data)
        return
    data = {"meta": {"quick": args.quick, "repeats": repeats, "atol_ratio": ATOL_RATIO,
                     "engine": _engine_version(),
                     "date": time.strftime("%Y-%m-%d %H:%M"),
                     "loadavg": [round(float(x), 2) for x in _loadavg()]}, "scenes": {}}
    import work_precision_costs as costs
    stages = [(f"scene {n}", ("scenes", n), lambda n=n: study_scene(n, args.quick, repeats))
              for n in args.scenes]
    stages += [("levels", ("levels",), lambda: study_levels(data["scenes"], repeats)),
               ("quench verdict", ("quench",), lambda: study_quench(repeats)),
               ("stiff crossover", ("crossover",), lambda: costs.study_crossover(args.quick))]
    if not args.no_effects:
        stages += [("effects", ("effects",),
                 lambda: costs.study_effects(max(repeats, costs.EFFECT_REPEATS))),
                   ("averaged path", ("averaged",), lambda: costs.study_averaged(repeats))]
    for title, key, fn in stages:
        print(title, flush=True)
        target = data
        for k in key[:-1]:
            target = target[k]
        target[key[-1]] = fn()
        RESULTS.write_text(json.dumps(data, indent=1, default=_json_default))  # partial
    report.write_all(data)


def _engine_version() -> str:
    """The commit of the engine/ sources this run used (and whether they were edited);
    ``$WP_ENGINE_COMMIT`` names it for a run from an exported snapshot (``git archive``)."""
    import os
    import subprocess
    if os.environ.get("WP_ENGINE_COMMIT"):
        return os.environ["WP_ENGINE_COMMIT"] + " (snapshot)"
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                             capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "engine"], cwd=ROOT, check=True,
                               capture_output=True, text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return rev + (" + uncommitted engine edits" if dirty else "")


def _loadavg():
    try:
        import os
        return os.getloadavg()
    except OSError:
        return (float("nan"),) * 3


def _json_default(x):
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    raise TypeError(type(x))


if __name__ == "__main__":
    main()
