"""Benchmark of the analysis paths (engine/analysis), run on its own:

    .venv/bin/python scripts/bench_analysis.py

Budgets (task brief): a 400 x 400 averaged stability chart <= 2 s on one core; an
effective friction curve of 1000 points <= 50 ms; first-call compile time reported
separately. The machine is shared, so every timing is the best of ``REPEAT`` runs and is
also given relative to a fixed numpy reference workload timed in the same run
(``ref`` = 1e6 exp + 1e6 sqrt on float64), which makes numbers comparable across loads.
Cold compile time: run with ``NUMBA_CACHE_DIR=$(mktemp -d)`` (otherwise the first call
loads numba's on-disk cache). Also prints the convergence of the sine quadrature with n (max error over a v grid
against n = 1024) and harmonic-balance timings.
"""
from __future__ import annotations

import time

import numpy as np

REPEAT = 5


def best(fn, repeat=REPEAT):
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return min(ts)


def main():
    t0 = time.perf_counter()
    from engine import params as P
    from engine.analysis import (
        contact_hbm,
        effective_friction,
        jacobian,
        max_real_eig,
        stability_chart,
    )
    t_import = time.perf_counter() - t0
    p = P.pack()
    x = np.random.default_rng(0).random(1_000_000)
    ref = best(lambda: (np.exp(x), np.sqrt(x)))
    print(f"import {t_import:.3f} s; reference workload {ref * 1e3:.2f} ms")

    # first calls: numba compile (or cache load) + run
    for name, fn in [
        ("effective_friction (square)", lambda: effective_friction(np.linspace(0, 1, 5), 0.5, p)),
        ("effective_friction (sine)", lambda: effective_friction(np.linspace(0, 1, 5), 0.5, p, dither="sine-velocity")),
        ("stability_chart (square)", lambda: stability_chart([0.0, 0.5], [0.1, 0.2], p)),
        ("stability_chart (sine)", lambda: stability_chart([0.0, 0.5], [0.1, 0.2], p, dither="sine-velocity")),
    ]:
        t = time.perf_counter()
        fn()
        print(f"first call {name:32s} {time.perf_counter() - t:7.3f} s (compile or cache load)")

    v = np.linspace(-1.5, 1.5, 1000)
    W400, v400 = np.linspace(0, 1.5, 400), np.linspace(0.001, 1.0, 400)
    rows = [
        ("F_eff 1000 pts, square", lambda: effective_friction(v, 0.5, p), 0.050),
        ("F_eff 1000 pts, sine n=64", lambda: effective_friction(v, 0.5, p, dither="sine-velocity"), 0.050),
        ("chart 400x400, square", lambda: stability_chart(W400, v400, p), 2.0),
        ("chart 400x400, sine n=64", lambda: stability_chart(W400, v400, p, dither="sine-velocity"), None),
    ]
    print(f"\n{'case':28s} {'best s':>9s} {'x ref':>8s} {'budget':>8s} {'ratio':>6s}")
    for name, fn, budget in rows:
        t = best(fn, 3 if "sine" in name and "chart" in name else REPEAT)
        ratio = f"{t / budget:6.2f}" if budget else "     -"
        print(f"{name:28s} {t:9.4f} {t / ref:8.1f} {budget or '-':>8} {ratio}")
    Wg, vg = np.meshgrid(W400, v400, indexing="ij")
    J = jacobian(vg, Wg, p)[0]
    print(f"  of the square chart: Jacobian kernel {best(lambda: jacobian(vg, Wg, p)):.4f} s, "
          f"eigenvalues {best(lambda: max_real_eig(J)):.4f} s")

    print("\nsine quadrature convergence: max |<F>_n - <F>_1024| over v in [-2W, 2W] (801 pts)")
    vv = np.linspace(-2, 2, 801)
    ns = (8, 16, 32, 64, 128, 256)
    print(f"{'vd':>5s} {'W':>4s} " + " ".join(f"{'n=' + str(n):>9s}" for n in ns))
    for vd in (0.1, 0.01):
        for W in (0.5, 1.0, 3.0):
            q = P.pack(vd=vd)
            r = effective_friction(vv * W, W, q, dither="sine-velocity", n_quad=1024)
            errs = [np.abs(effective_friction(vv * W, W, q, dither="sine-velocity", n_quad=n) - r).max() for n in ns]
            print(f"{vd:5.2f} {W:4.1f} " + " ".join(f"{e:9.1e}" for e in errs))

    print("\nharmonic balance (contact model, Fig. 1 parameters, v_m = 1e-3)")
    pc = P.pack(P.CONTACT_DEFAULTS)
    for v_a, w in [(1e-3, 1.0), (1e-3, 100.0), (1e-3, 1e4), (2e-3, 100.0)]:
        r = contact_hbm(1e-3, v_a, w, pc, rtol=1e-6)
        t = best(lambda v_a=v_a, w=w: contact_hbm(1e-3, v_a, w, pc, rtol=1e-6), 3)
        print(f"v_a={v_a:.0e} omega={w:8.0f}: H={r.H:5d} change={r.change:.1e}  {t * 1e3:8.1f} ms")


if __name__ == "__main__":
    main()
