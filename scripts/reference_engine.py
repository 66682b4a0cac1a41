"""Independent high-accuracy references for the engine's hard cases (tests/hard/).

Run: ``.venv/bin/python scripts/reference_engine.py [CASE ...] [--list]``
writes ``tests/hard/references.json`` (merging with the cases already there).

Method (independent of ``engine/``: its own right-hand side, written from DESIGN.md §1,
and scipy's integrators): the LuGre slider

    de = v_ref - v,   dv = e - F,   dz = u - sigma0 |u| z / g(u),
    F  = sigma0 z + sigma1(u) dz + sigma2 u,   u = v + W sq(omega t),

from rest, integrated by ``scipy.integrate.solve_ivp`` restarted at every square-wave
switching instant ``t_k = k pi / omega`` (so no step ever crosses a discontinuity of
the right-hand side), with the method and tolerances stored next to each result:
``Radau`` for the stiff cases (sigma0 >= 1e4; scipy's finite-difference Jacobian),
``DOP853`` otherwise; ``rtol`` as listed per case and
``atol = rtol * [fc, v_scale, fc / sigma0]`` for ``(e, v, z)``, ``v_scale = max(v_ref, W)``.
Each case is run twice: at ``rtol``, and at ``rtol / 10`` with at least 8 steps per
half-period (``max_step = pi / (8 omega)``, so that the second run is a different
discretisation even where one step per half-period already meets ``rtol``); the stored
``self_error`` is the difference of the two in the error units below, an estimate of the
reference's own error (``q`` is the second, finer run).

Quantities of interest (as in ../shared/anchors/README.md):
``q = [z(t_end), e(t_end), v(t_end), mean v, p2p v]``, mean and peak-to-peak of ``v``
over the switching instants ``k pi / omega`` in ``[t_end / 2, t_end]``; error units
``scale = [fc / sigma0, fc, v_ref, v_ref, |p2p_ref|]``.
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib
import time

import numpy as np
import scipy
from scipy.integrate import solve_ivp

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = ROOT / "tests" / "hard" / "references.json"

#: The paper's Sec. 5.1 set (DESIGN.md §1), vd = 0.1, and the fig10 anchor scene.
FIG10 = {"sigma0": 100.0, "sigma1": 10.0, "sigma2": 0.004, "vs": 0.1, "vd": 0.1, "fc": 1.0,
         "fs": 1.5, "W": 0.4, "omega": 1000.0, "v_ref": 0.4, "t_end": 100.0}

#: name -> (parameter overrides of FIG10, rtol of the reference)
CASES = {
    "fig10": ({}, 1e-11),
    "sigma0_1e4": ({"sigma0": 1e4, "t_end": 5.0}, 1e-10),
    "sigma0_1e6": ({"sigma0": 1e6, "t_end": 5.0}, 1e-10),
    "vd_1e-3": ({"vd": 1e-3}, 1e-11),
    "W_eq_vref_0.1": ({"W": 0.1, "v_ref": 0.1}, 1e-11),
    "omega_1e5": ({"omega": 1e5, "t_end": 2.0}, 1e-11),
    "vref_1e-6": ({"v_ref": 1e-6, "W": 0.0}, 1e-11),
    "vref_1e-6_dither": ({"v_ref": 1e-6}, 1e-11),
}


def rhs(t, y, c, sq):
    """Slider right-hand side (e, v, z) on a half-period with square-wave sign sq."""
    e, v, z = y
    u = v + c["W"] * sq
    gu = c["fc"] + (c["fs"] - c["fc"]) * math.exp(-(u / c["vs"]) ** 2)
    s1 = c["sigma1"] * math.exp(-(u / c["vd"]) ** 2)
    dz = u - c["sigma0"] * abs(u) * z / gu
    F = c["sigma0"] * z + s1 * dz + c["sigma2"] * u
    return [c["v_ref"] - v, e - F, dz]


def sample_indices(omega: float, t_end: float) -> tuple[float, int, int]:
    """Half-period hp, last full switch K = floor(t_end/hp), first sample kmin."""
    hp = math.pi / omega
    return hp, math.floor(t_end / hp), math.ceil(0.5 * t_end / hp)


def integrate(c: dict, method: str, rtol: float, max_step: float = np.inf) -> np.ndarray:
    """q of one case, restarting the integrator at every switching instant."""
    hp, K, kmin = sample_indices(c["omega"], c["t_end"])
    atol = rtol * np.array([c["fc"], max(c["v_ref"], c["W"]), c["fc"] / c["sigma0"]])
    y = np.zeros(3)
    vs = []
    for k in range(K + 1):
        t0, t1 = k * hp, ((k + 1) * hp if k < K else c["t_end"])
        if t1 > t0:
            sol = solve_ivp(rhs, (t0, t1), y, method=method, rtol=rtol, atol=atol,
                            max_step=max_step, args=(c, 1.0 if k % 2 == 0 else -1.0))
            if sol.status != 0:
                raise RuntimeError(f"{method} failed on half-period {k}: {sol.message}")
            y = sol.y[:, -1]
        if kmin <= k + 1 <= K:
            vs.append(y[1])
    vs = np.array(vs)
    return np.array([y[2], y[0], y[1], vs.mean(), vs.max() - vs.min()])


def error_units(q, q_ref, c) -> float:
    """max_i |q_i - q_ref_i| / scale_i (module docstring)."""
    scale = np.array([c["fc"] / c["sigma0"], c["fc"], c["v_ref"], c["v_ref"], abs(q_ref[4])])
    return float(np.max(np.abs(np.asarray(q) - q_ref) / scale))


def reference(name: str) -> dict:
    """Compute one case at rtol and rtol/10; return its JSON record."""
    overrides, rtol = CASES[name]
    c = {**FIG10, **overrides}
    method = "Radau" if c["sigma0"] >= 1e4 else "DOP853"
    t0 = time.perf_counter()
    q1 = integrate(c, method, rtol)
    q2 = integrate(c, method, rtol / 10, max_step=math.pi / (8 * c["omega"]))
    return {
        "params": c, "q": q2.tolist(), "q_coarse": q1.tolist(),
        "self_error": error_units(q1, q2, c), "method": method,
        "rtol": rtol / 10, "atol": "rtol * [fc, max(v_ref, W), fc / sigma0]",
        "restarts": "every switching instant k pi / omega",
        "max_step": "pi / (8 omega) in the finer run",
        "seconds": round(time.perf_counter() - t0, 1), "scipy": scipy.__version__,
        "script": "scripts/reference_engine.py",
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", help=f"subset of {list(CASES)}")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    args = ap.parse_args(argv)
    if args.list:
        for name, (ov, rtol) in CASES.items():
            print(f"{name:18s} rtol={rtol:g} {ov}")
        return
    unknown = set(args.cases) - set(CASES)
    if unknown:
        ap.error(f"unknown case(s) {sorted(unknown)}; known: {list(CASES)}")
    store = json.loads(OUT.read_text()) if OUT.exists() else {}
    for name in args.cases or CASES:
        rec = reference(name)
        store[name] = rec
        print(f"{name:18s} {rec['method']} rtol={rec['rtol']:g} self_error={rec['self_error']:.2e} "
              f"({rec['seconds']} s) q={rec['q']}", flush=True)
        OUT.parent.mkdir(parents=True, exist_ok=True)
        OUT.write_text(json.dumps(store, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
