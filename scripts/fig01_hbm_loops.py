"""Figs. 1-2: friction-velocity loops of the Sec. 3 contact model by harmonic balance.

    .venv/bin/python scripts/fig01_hbm_loops.py    -> out/fig01_hbm_loops.png

Fig. 1 parameters (engine.params.CONTACT_DEFAULTS: sigma0 = 1e5 N/m, sigma1 = 1e3 N s/m,
sigma2 = 0, fs = 1.5 N, fc = 1 N, vs = vd = 1e-3 m/s, delta = 1), v_m = v_a = 1e-3 m/s.
The paper does not give its frequencies; omega = 1 ... 1e5 rad/s are drawn. Left: F
against u for several omega, with the high-frequency asymptote F_inf(u) (z frozen at
its average); middle: loop area, F at the least velocity, F_min/F_max against omega;
right: harmonic amplitudes |F_n| (Fig. 2), with and without bristle damping.
Prints the table behind the Fig. 1/2 claims.
"""
from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from engine import params as P
from engine.analysis import contact_hbm

VM = VA = 1e-3
OUT = os.path.join(os.path.dirname(__file__), "..", "out")


def asymptote(p, u):
    """F_inf(u) = sigma0 Z + sigma1(u) (u - sigma0 |u| Z / g(u)), Z = v_m/(sigma0 <|u|/g>);
    <|u|/g> from the sine rule (Y = v / A of engine.analysis.effective)."""
    from engine.analysis.stability import averages
    A = averages(VM, VA, p, dither="sine-velocity", n_quad=256)[0]
    Y = VM / A                                   # sigma0 Z
    g = p[P.FC] + (p[P.FS] - p[P.FC]) * np.exp(-np.abs(u) / p[P.VS])
    s1 = p[P.SIGMA1] * np.exp(-(u / p[P.VD]) ** 2)
    return Y + s1 * (u - np.abs(u) * Y / g) + p[P.SIGMA2] * u


def main():
    p = P.pack(P.CONTACT_DEFAULTS)
    p0 = P.pack(P.CONTACT_DEFAULTS, sigma1=0.0)
    omegas = np.logspace(0, 5, 21)
    res = [contact_hbm(VM, VA, w, p) for w in omegas]
    res0 = [contact_hbm(VM, VA, w, p0) for w in omegas]
    loops = [r.loop(w, VA) for r, w in zip(res, omegas)]
    print(f"{'omega':>9s} {'H':>4s} {'F_mean':>8s} {'F_min':>8s} {'F_max':>8s} {'F(vmin)':>8s} {'loop':>10s}  |F_1..F_5| (N)")
    for w, r, L in zip(omegas, res, loops):
        amps = " ".join(f"{a:.2e}" for a in np.abs(r.F_coef[1:6]))
        print(f"{w:9.3g} {r.H:4d} {L['F_mean']:8.4f} {L['F_min']:8.4f} {L['F_max']:8.4f} "
              f"{L['F_at_vmin']:8.4f} {L['loop_area']:10.3e}  {amps}")
    print("sigma1 = 0: |F_1..F_5| at omega = 1 and 1e5:",
          np.abs(res0[0].F_coef[1:6]), np.abs(res0[-1].F_coef[1:6]))

    fig, ax = plt.subplots(1, 3, figsize=(16, 4.8))
    for w in (1.0, 10.0, 100.0, 1e3, 1e5):
        r = contact_hbm(VM, VA, w, p)
        ax[0].plot(np.r_[r.u, r.u[0]] * 1e3, np.r_[r.F, r.F[0]], label=f"omega = {w:g}")
    u = np.linspace(0, 2 * VA, 400) + VM - VA
    ax[0].plot(u * 1e3, asymptote(p, u), "k:", label="asymptote")
    ax[0].set(xlabel="u (mm/s)", ylabel="F (N)", title="Fig. 1: loops")
    ax[0].legend(fontsize=8)
    ax[1].semilogx(omegas, [L["loop_area"] / max(x["loop_area"] for x in loops) for L in loops], label="loop area / max")
    for k in ("F_at_vmin", "F_min", "F_max", "F_mean"):
        ax[1].semilogx(omegas, [L[k] - 1.0 for L in loops], label=f"{k} - 1 N")
    ax[1].set(xlabel="omega (rad/s)", title="loop quantities")
    ax[1].legend(fontsize=8)
    for n in range(1, 6):
        ax[2].loglog(omegas, [abs(r.F_coef[n]) for r in res], c=f"C{n}", label=f"|F_{n}|")
        ax[2].loglog(omegas, [abs(r.F_coef[n]) + 1e-16 for r in res0], "--", c=f"C{n}", lw=0.8)
    ax[2].set(xlabel="omega (rad/s)", ylabel="N", title="Fig. 2: harmonics (dashed: sigma1 = 0)")
    ax[2].legend(fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, "fig01_hbm_loops.png")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {os.path.normpath(path)}")


if __name__ == "__main__":
    main()
