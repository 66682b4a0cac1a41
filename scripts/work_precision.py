"""Work-precision study: what accuracy costs, measured (writes docs/ACCURACY.md).

Run: ``.venv/bin/python scripts/work_precision.py [--quick] [--scenes fig10 sec7 ...]
[--no-effects] [--replot]``

For each canonical scene (:data:`SCENES`, each a sweep spec of one grid point, so the
scene, parameters and point are exactly those the sweep service would build through
``sweeps.plan.make_plan``) every integrator of ``engine.integrators.METHODS`` is run over
its step/tolerance ladder (:data:`LADDERS`): ``rk4`` over steps per (half-)period (or the
step ``h`` without dither), ``dopri5`` and ``rodas4`` over ``rtol`` with
``atol = ATOL_RATIO * rtol``. Each run is timed through ``engine.batch.run_block`` (one
point, numba compiled beforehand, median of ``--repeats`` wall times).

Error of a queried output ``q`` against the scene's reference ``q_ref``
(:func:`quantity_error`): ``|q - q_ref| / |q_ref|`` for velocities, forces and times,
``|q - q_ref|`` for time fractions (already in [0, 1]). The *combined* error of a run is the
largest over the scene's queried outputs (``SCENES[name]["queried"]``).

Reference: the first entry of ``SCENES[name]["refs"]`` (DP5 at rtol 1e-12); every other
entry is an independent converged run (RK4 with many steps, RODAS at a tight tolerance)
and the tables report how far they agree with it, per output.

Also measured: the accuracy levels of ``sweeps.accuracy`` on every scene (through
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
import math
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from engine import params as P
from engine import status as S
from engine.batch import run_block
from engine.settings import Settings
from sweeps.plan import make_plan
from sweeps.spec import parse_spec
from sweeps.spec_models import LEVELS

DOCS = ROOT / "docs"
RESULTS = DOCS / "work_precision.json"
ATOL_RATIO = 1e-3          # atol = ATOL_RATIO * rtol on the ladders (states ~1e-2 .. 1)
MAX_STEPS = 10**9          # no ladder rung may fail for want of a step budget
QUENCH_RATIO = 0.1         # Fig. 10 "quenched" when v_slow_p2p < QUENCH_RATIO * v_ref
FIG10_W = (0.0, 0.2, 0.3, 0.4, 0.5, 0.6)   # Fig. 10 (a)-(f)

ALL_SIM = ["v_mean", "v_slow_p2p", "F_mean", "stick_fraction", "presliding_fraction",
           "slip_fraction", "long_stick_fraction", "max_stick", "near_slip_fraction",
           "alpha_hist"]
FRACTIONS = ("stick_fraction", "presliding_fraction", "slip_fraction", "long_stick_fraction",
             "near_slip_fraction", "alpha_hist")


def _spec(name, friction, dither, W, omega, v_ref, t_transient, params=None):
    return {"name": name, "friction": friction, "dither": dither, "method": "simulate",
            "outputs": ALL_SIM, "accuracy": "standard", "params": params or {},
            "time": {"t_end": 100.0, "t_transient": t_transient},
            "grid": {"W": [W], "omega": [omega], "v_ref": [v_ref], "v_d": [0.1]}}


DP5_REF = ("dopri5", {"rtol": 1e-12, "atol": 1e-15})
SCENES = {
    # Fig. 10(d): LuGre slider, square-velocity dither; window [50, 100] (the start-up from
    # rest would otherwise dominate v_slow_p2p).
    "fig10": {
        "spec": _spec("fig10", "lugre", "square-velocity", 0.4, 1000.0, 0.4, 50.0),
        "queried": ("v_slow_p2p", "F_mean", "v_mean"),
        "refs": [DP5_REF, ("rk4", {"steps_per_period": 512})]},
    # Sec. 7 / Figs. 11-12: elasto-plastic, sine-velocity dither, slow force 1.7 sin(0.3 tau).
    "sec7": {
        "spec": _spec("sec7", "elastoplastic", "sine-velocity", 1.5, 100.0, 0.1, 20.0,
                      {"lam": 0.8, "slow_force": {"amplitude": 1.7, "omega": 0.3}}),
        "queried": ("v_slow_p2p", "F_mean", "v_mean", "stick_fraction", "presliding_fraction",
                    "max_stick", "slip_fraction", "near_slip_fraction", "long_stick_fraction",
                    "alpha_hist"),
        # DP5 at rtol 1e-12 stalls here (zero-length steps on an alpha kink at tau ~ 1.92):
        # shown with the service's default step budget
        "refs": [("dopri5", {"rtol": 1e-11, "atol": 1e-14}),
                 ("rodas4", {"rtol": 1e-9, "atol": 1e-12}),
                 ("rk4", {"steps_per_period": 4096}),
                 ("dopri5", {**DP5_REF[1], "max_steps": Settings().max_steps})]},
    # Sec. 7 slider without dither from rest over [0, 100] (DESIGN.md §1's reference shares
    # stick 0.527, pre-sliding 0.123, slip 0.350): alpha reaches 1, so the sliding share
    # hinges on the sliding gap (engine.observables); scripts/reference_phases.py checks
    # the reference independently (scipy DOP853 with restarts at every kink)
    "ep_nodither": {
        "spec": _spec("ep_nodither", "elastoplastic", "sine-velocity", 0.0, 1000.0, 0.1, 0.0,
                      {"lam": 0.8, "slow_force": {"amplitude": 1.7, "omega": 0.3}}),
        "queried": ("stick_fraction", "presliding_fraction", "slip_fraction",
                    "near_slip_fraction", "long_stick_fraction", "max_stick", "alpha_hist",
                    "v_slow_p2p", "F_mean", "v_mean"),
        "refs": [("dopri5", {"rtol": 1e-13, "atol": 1e-16}),
                 ("dopri5", {"rtol": 1e-12, "atol": 1e-15}),
                 ("rodas4", {"rtol": 1e-10, "atol": 1e-13})]},
    # Fig. 10(a): the undithered stick-slip cycle (W = 0: the plan compiles dither "none").
    "nodither": {
        "spec": _spec("nodither", "lugre", "square-velocity", 0.0, 1000.0, 0.4, 50.0),
        "queried": ("v_slow_p2p", "F_mean", "v_mean"),
        # v_slow_p2p without dither is the peak-to-peak of v at the *step ends*: the
        # reference needs fine steps (RK4), an adaptive run samples the peaks coarsely
        "refs": [("rk4", {"h": 1e-5}), ("rk4", {"h": 4e-5}), DP5_REF]},
    # Fig. 10(d) with a 100x stiffer bristle (sigma0 = 1e4): fast bristle relaxation.
    "stiff": {
        "spec": _spec("stiff", "lugre", "square-velocity", 0.4, 1000.0, 0.4, 50.0,
                      {"sigma0": 1e4}),
        "queried": ("v_slow_p2p", "F_mean", "v_mean"),
        "refs": [DP5_REF, ("rk4", {"steps_per_period": 512})]},
    # sigma0 = 1e6 (tests/hard's stiff case): past the explicit/stiff crossover, calibrates
    # the stiff method's levels (sweeps.accuracy.STIFF_LEVELS).
    "stiff6": {
        "spec": _spec("stiff6", "lugre", "square-velocity", 0.4, 1000.0, 0.4, 50.0,
                      {"sigma0": 1e6}),
        "queried": ("v_slow_p2p", "F_mean", "v_mean"),
        "refs": [DP5_REF, ("rodas4", {"rtol": 1e-10, "atol": 1e-13}),
                 ("rk4", {"steps_per_period": 4096})],
        "ladders": {"rk4": [{"steps_per_period": n} for n in (512, 1024, 2048)],
                    "rodas4": [{"rtol": 10.0 ** -k} for k in range(2, 11)]}},
}

LADDERS = {
    ("rk4", "square-velocity"): [{"steps_per_period": n}
                                 for n in (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 128)],
    ("rk4", "sine-velocity"): [{"steps_per_period": n}
                               for n in (8, 16, 24, 32, 48, 64, 96, 128, 256, 512, 1024)],
    ("rk4", "none"): [{"h": h} for h in (0.02, 0.01, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)],
    "dopri5": [{"rtol": 10.0 ** -k} for k in range(3, 12)],
    "rodas4": [{"rtol": 10.0 ** -k} for k in range(2, 9)],
}
METHOD_ORDER = ("rk4", "dopri5", "rodas4")


# --------------------------------------------------------------------------- running
def plan_of(spec: dict, level: str | None = None):
    """The sweep service's plan of ``spec`` (scene, params, numerics) at ``level``."""
    return make_plan(parse_spec(spec), level)


def settings_of(setting: dict) -> Settings:
    s = dict(setting)
    if "rtol" in s:
        s.setdefault("atol", ATOL_RATIO * s["rtol"])
    s.setdefault("max_steps", MAX_STEPS)
    return Settings(**s)


def label(method: str, setting: dict) -> str:
    if "steps_per_period" in setting:
        return f"N={setting['steps_per_period']}"
    if "h" in setting and "rtol" not in setting:
        return f"h={setting['h']:g}"
    return f"rtol={setting['rtol']:.0e}"


def warm_up(scene, p, points) -> None:
    """Compile ``scene`` (numba) on a 0.01-tau run so that no timing includes it."""
    q = p.copy()
    q[P.T_END], q[P.T_TRANSIENT] = 0.01, 0.0
    run_block(scene, points, q, Settings(max_steps=100_000))


def timed_run(scene, p, points, settings: Settings, repeats: int) -> dict:
    """Outputs, counters and median wall time per point of ``run_block``."""
    walls, res = [], None
    for i in range(repeats):
        t0 = time.perf_counter()
        res = run_block(scene, points, p, settings)
        walls.append(time.perf_counter() - t0)
        if walls[-1] > 2.0:      # long runs: one timing is precise enough
            break
    n = len(points)
    return {"outputs": {k: np.asarray(v, dtype=float).tolist() for k, v in res.outputs.items()},
            "status": [int(s) for s in res.status], "steps": int(res.steps.sum()) // n,
            "rejected": int(res.rejected.sum()) // n, "evals": int(res.evals.sum()) // n,
            "time": float(np.median(walls)) / n}


def run_setting(plan, method: str, setting: dict, repeats: int) -> dict:
    scene = plan.scene.with_(integrator=method)
    pts = plan.block_points(0)
    row = timed_run(scene, plan.params, pts, settings_of(setting), repeats)
    row.update(method=method, setting=setting, label=label(method, setting))
    return row


def is_reference(row: dict, ref: dict) -> bool:
    """True when ``row`` ran the very method and settings of the reference run."""
    return (row["method"] == ref["method"]
            and settings_of(row["setting"]) == settings_of(ref["setting"]))


# --------------------------------------------------------------------------- errors
def quantity_error(name: str, q: float, q_ref: float) -> float:
    """Absolute error for time fractions, relative error otherwise (module docstring)."""
    if isinstance(q, list):          # alpha_hist: the largest change of a bin's share
        diffs = [abs(a - b) for a, b in zip(q, q_ref)]
        return max(diffs) if all(math.isfinite(d) for d in diffs) else math.inf
    if not math.isfinite(q):
        return math.inf
    if name in FRACTIONS:
        return abs(q - q_ref)
    if name == "max_stick":     # against the long-stick threshold (sweeps.accuracy.promise)
        return abs(q - q_ref) / max(abs(q_ref), P.PAPER_DEFAULTS["long_stick"])
    if q_ref == 0.0:
        return abs(q)
    return abs(q - q_ref) / abs(q_ref)


def errors(row: dict, ref: dict, names) -> dict:
    """Per-output errors of ``row`` against ``ref`` and their max over ``names``."""
    if row["status"][0] != S.OK:
        return {"combined": math.inf, **{n: math.inf for n in ALL_SIM}}
    e = {n: quantity_error(n, row["outputs"][n][0], ref["outputs"][n][0]) for n in ALL_SIM}
    e["combined"] = max(e[n] for n in names)
    return e


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
    """Error and cost of each level of sweeps.accuracy on each studied scene."""
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
