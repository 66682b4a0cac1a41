"""Cost studies of scripts/work_precision.py: stiff crossover, effect costs, averaged path.

- :func:`study_crossover` -- Fig. 10(d) on a short window (tau in [0, 10], observed on
  [5, 10]) at sigma0 = 1e2 ... 1e6: for each method, the cheapest rung of its ladder whose
  combined error is <= each target of :data:`TARGETS` against DP5 at rtol 1e-12
  (atol 1e-15). Where the explicit methods turn stability-bound, this says from which
  sigma0 on the stiff method pays (``sweeps.spec.accuracy.STIFF_SIGMA0``).
- :func:`study_effects` -- "only the effects a scene calls for": the Sec. 7 scene
  (elasto-plastic, sine-velocity dither, slow force: every effect present) with each effect
  (a) present, (b) made to vanish by its parameter but still compiled in, (c) vanishing and
  compiled out (the Scene flag off, what ``sweeps.planning.plan`` does). (b) and (c) integrate the
  same trajectory, so their time ratio is the saving of specialisation alone; (a) against
  (c) is the whole cost of the effect (the trajectory changes too, hence evals and
  ns/eval). Observables: the plain scene without outputs against one output at a time.
  Times are medians of round-robin repeats of the three variants (paired, same run).
- :func:`study_averaged` -- the averaged path through ``run_block``: steps == evals == 0
  at every point, and its time per point.
"""
from __future__ import annotations

import time

import numpy as np
import wp_core as wp

from engine import params as P
from engine import status as S
from engine.blocks import run_block
from engine.scene import Scene
from engine.settings import Settings

TARGETS = (1e-2, 1e-4, 1e-7)
SIGMA0S = (1e2, 1e3, 1e4, 3e4, 1e5, 3e5, 1e6)
CROSS_LADDER = {
    "rk4": [{"steps_per_period": n} for n in (1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024,
                                              2048, 4096)],
    "dopri5": [{"rtol": 10.0 ** -k} for k in range(3, 12)],
    "rodas4": [{"rtol": 10.0 ** -k} for k in range(2, 10)],
}
MAX_RUN_S = 20.0   # a ladder stops climbing once one rung costs this much

SEC7_PARAMS = {"v_ref": 0.1, "W": 1.5, "omega": 100.0, "vd": 0.1, "lam": 0.8, "slow_a": 1.7,
                   "slow_omega": 0.3, "t_end": 100.0, "t_transient": 20.0}
EFFECT_NUMERICS = {"rk4": {"steps_per_period": 64}, "dopri5": {"rtol": 1e-6}}
# effect -> (parameter overrides that make it vanish, Scene changes that compile it out)
EFFECTS = {
    "Stribeck (fs = fc)": ({"fs": 1.0}, {"stribeck": False}),
    "bristle damping (sigma1 = 0)": ({"sigma1": 0.0}, {"bristle_damping": False}),
    "viscous (sigma2 = 0)": ({"sigma2": 0.0}, {"viscous": False}),
    "slow force (A_s = 0)": ({"slow_a": 0.0}, {"slow_force": False}),
    "dither (W = 0 / 'none')": ({"W": 0.0}, {"dither": "none"}),
}


# --------------------------------------------------------------------------- crossover
def _fig10_short(sigma0: float) -> dict:
    spec = wp._spec("cross", "lugre", "square-velocity", 0.4, 1000.0, 0.4, 5.0,
                    {"sigma0": sigma0})
    spec["time"] = {"t_end": 10.0, "t_transient": 5.0}
    return spec


def _climb(plan, method, ref, queried, rungs):
    """Cheapest rung reaching each target: {target: row or None}, and all rows run."""
    hits, rows = {t: None for t in TARGETS}, []
    for s in rungs:
        row = wp.run_setting(plan, method, s, 1)
        row["error"] = wp.errors(row, ref, queried)
        rows.append(row)
        for t in TARGETS:
            if hits[t] is None and row["error"]["combined"] <= t:
                hits[t] = row
        if all(h is not None for h in hits.values()) or row["time"] > MAX_RUN_S:
            break
    return hits, rows


def study_crossover(quick: bool) -> dict:
    """Cheapest setting per (sigma0, method, target) on the short Fig. 10(d) window."""
    out = {}
    queried = wp.SCENES["fig10"]["queried"]
    for sigma0 in (SIGMA0S[::2] if quick else SIGMA0S):
        plan = wp.plan_of(_fig10_short(sigma0))
        for m in wp.METHOD_ORDER:
            wp.warm_up(plan.scene.with_(integrator=m), plan.params, plan.block_points(0))
        ref = wp.run_setting(plan, *wp.DP5_REF, 1)
        entry = {"ref_time": ref["time"], "ref_outputs": ref["outputs"], "methods": {}}
        for m in wp.METHOD_ORDER:
            hits, rows = _climb(plan, m, ref, queried, CROSS_LADDER[m])
            entry["methods"][m] = {
                "hits": {f"{t:.0e}": (None if h is None else
                                      {k: h[k] for k in ("label", "time", "evals", "error")})
                         for t, h in hits.items()},
                "rows": [{k: r[k] for k in ("label", "time", "evals", "steps", "status", "error")}
                         for r in rows]}
            print(f"  sigma0={sigma0:.0e} {m:7s} " + "  ".join(
                f"{t:.0e}: {h['label'] if h else '-'} "
                f"{(1e3 * h['time']) if h else float('nan'):.1f} ms"
                for t, h in hits.items()), flush=True)
        entry["levels"] = _levels_both(plan, ref, queried)
        out[f"{sigma0:.0e}"] = entry
    return out


def _levels_both(plan, ref, queried) -> dict:
    """Each level's DP5 settings and the stiff method's settings, at this sigma0."""
    from sweeps.spec import accuracy as A
    out = {}
    for level in A.LEVELS:
        out[level] = {}
        for m, table in (("dopri5", A.LEVELS), ("rodas4", A.STIFF_LEVELS)):
            row = wp.run_setting(plan, m, dict(table[level]), 1)
            row["error"] = wp.errors(row, ref, queried)
            out[level][m] = {k: row[k] for k in ("label", "time", "evals", "error")}
    return out


# --------------------------------------------------------------------------- effects
def _paired(fns, repeats):
    """Median wall time of each callable, calls interleaved round-robin."""
    times = [[] for _ in fns]
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            t0 = time.perf_counter()
            fn()
            times[i].append(time.perf_counter() - t0)
    return [float(np.median(t)) for t in times]


def _variant(scene, p, settings):
    pts = p[[P.W, P.OMEGA, P.V_REF, P.VD]][None, :].copy()
    wp.warm_up(scene, p, pts)
    res = run_block(scene, pts, p, settings)
    return {"fn": lambda: run_block(scene, pts, p, settings),
            "evals": int(res.evals[0]), "steps": int(res.steps[0]),
            "status": int(res.status[0]),
            "outputs": {k: float(v[0]) for k, v in res.outputs.items()}}


def _settings(method):
    """Numerics of the effect table; rk4 takes the same step in every variant (dither
    'none' gets ``h`` = one sine period / N)."""
    s = EFFECT_NUMERICS[method]
    if method != "rk4":
        return wp.settings_of(s)
    n = s["steps_per_period"]
    return Settings(steps_per_period=n, h=2 * np.pi / SEC7_PARAMS["omega"] / n)


def _row(name, variants, repeats):
    times = _paired([v["fn"] for v in variants], repeats)
    cols = []
    for v, t in zip(variants, times):
        cols.append({"time": t, "evals": v["evals"], "steps": v["steps"],
                     "status": v["status"], "ns_per_eval": 1e9 * t / max(v["evals"], 1)})
    row = {"effect": name, "variants": cols}
    if len(variants) == 3:   # (b) and (c) integrate the same trajectory
        b, c = variants[1]["outputs"], variants[2]["outputs"]
        # without dither v_slow_p2p samples step ends instead of period means (another
        # definition), and DP5 takes other steps without the period stops
        skip = "v_slow_p2p" if "dither" in name else None
        same = [k for k in b if np.isfinite(b[k]) and k != skip]
        row["b_vs_c_max_diff"] = max((abs(b[k] - c[k]) for k in same), default=0.0)
    return row


EFFECT_REPEATS = 7  # the effect ratios are small: more round-robin repeats than the ladders


def study_effects(repeats: int = EFFECT_REPEATS, methods=("rk4", "dopri5")) -> dict:
    """The effect-cost table (module docstring) for each method of ``methods``."""
    out = {}
    for m in methods:
        base = Scene(friction="elastoplastic", dither="sine-velocity", integrator=m,
                     outputs=tuple(wp.ALL_SIM))
        p = P.pack(**SEC7_PARAMS)
        st = _settings(m)
        a = _variant(base, p, st)
        rows = []
        for name, (vanish, flags) in EFFECTS.items():
            q = P.pack(**{**SEC7_PARAMS, **vanish})
            b, c = _variant(base, q, st), _variant(base.with_(**flags), q, st)
            rows.append(_row(name, [a, b, c], repeats))
            print(f"  {m} {name}: " + " ".join(f"{1e3 * v['time']:.1f}ms/{v['ns_per_eval']:.0f}ns"
                                               for v in rows[-1]["variants"]), flush=True)
        rows.append(_row("elasto-plastic phases (vs LuGre)",
                         [a, _variant(base.with_(friction="lugre"), p, st)], repeats))
        rows.extend(_observable_rows(base, p, st, repeats))
        out[m] = {"label": wp.label(m, EFFECT_NUMERICS[m]), "rows": rows}
    return out


def _observable_rows(base, p, st, repeats):
    """Each observable alone (and all of them) against a scene with no outputs."""
    plain = _variant(base.with_(outputs=()), p, st)
    rows = []
    for names in [(o,) for o in wp.ALL_SIM] + [tuple(wp.ALL_SIM)]:
        label = names[0] if len(names) == 1 else "all eight outputs"
        v = _variant(base.with_(outputs=names), p, st)
        rows.append(_row(f"output {label}", [v, plain], repeats))
        print(f"  output {label}: " + " ".join(f"{1e3 * c['time']:.1f}ms"
                                            for c in rows[-1]["variants"]), flush=True)
    return rows


# --------------------------------------------------------------------------- averaged
def study_averaged(repeats: int) -> dict:
    """Fig. 9(a)-like chart through run_block(Scene(path='averaged')): nothing integrated."""
    scene = Scene(path="averaged", friction="lugre", dither="square-velocity",
                  outputs=("F_eff", "max_real_eig", "stable"))
    W, v_ref = np.meshgrid(np.linspace(0.0, 1.0, 41), np.linspace(0.02, 1.0, 50),
                           indexing="ij")
    pts = np.column_stack([W.ravel(), np.full(W.size, 1000.0), v_ref.ravel(),
                           np.full(W.size, 0.1)])
    p = P.pack()
    run_block(scene, pts[:2], p)          # compile
    walls, res = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = run_block(scene, pts, p)
        walls.append(time.perf_counter() - t0)
    return {"points": len(pts), "steps_max": int(res.steps.max()),
            "evals_max": int(res.evals.max()), "rejected_max": int(res.rejected.max()),
            "all_ok": bool(np.all(res.status == S.OK)),
            "time_per_point": float(np.median(walls)) / len(pts)}
