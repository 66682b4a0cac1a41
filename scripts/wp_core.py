"""The work-precision study's shared pieces: its scenes (each a one-point sweep spec), the
integrators' ladders, how a setting is run and timed, and the error measures. Imported by
scripts/work_precision.py (the study), work_precision_costs.py and work_precision_report.py
(one-way: this module imports none of them); see work_precision.py for the method.
"""
from __future__ import annotations

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
from engine.blocks import run_block
from engine.settings import Settings
from sweeps.planning.plan import make_plan
from sweeps.spec import parse_spec

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
    # the stiff method's levels (sweeps.spec.accuracy.STIFF_LEVELS).
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
    if name == "max_stick":     # against the long-stick threshold (sweeps.spec.accuracy.promise)
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
