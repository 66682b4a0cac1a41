"""Figs. 1-2: the Sec. 3 contact model (no inertia, SI units) by harmonic balance.

u(t) = v_m + v_a cos(omega t) with v_m = v_a (both from the ``fig01`` scene, specs/
fig01-hbm.toml); Fig. 1 parameters (engine.params.CONTACT_DEFAULTS). The paper does not
give its frequencies: the loops are drawn at omega = 1, 10, 100, 1e3, 1e5 rad/s and the
loop quantities over the scene's omega range.
"""
from __future__ import annotations

import numpy as np

from engine import params as P
from engine.analysis import contact_hbm

from . import plotting as G
from .verdicts import Check, FigureResult, above, below, monotone

LOOP_OMEGAS = (1.0, 10.0, 100.0, 1e3, 1e5)
STIFF = 10.0          # the stiffness claim: sigma0 x STIFF
HARMONICS = (2, 3, 4, 5)
ATTENUATION = 0.1     # "strong attenuation": |F_n| at the top frequency < 0.1 x at the lowest


def _axis(ctx):
    """v_m, v_a and the omega grid of the fig01 scene at this size."""
    spec = ctx.spec("fig01")
    grid = spec["grid"]
    om = grid["omega"]
    omegas = np.logspace(np.log10(om["start"]), np.log10(om["stop"]), om["num"])
    return float(grid["v_ref"][0]), float(grid["W"][0]), omegas


def _scan(v_m, v_a, omegas, p):
    res = [contact_hbm(v_m, v_a, w, p) for w in omegas]
    return res, [r.loop(w, v_a) for r, w in zip(res, omegas)]


def fig01(ctx) -> FigureResult:
    v_m, v_a, omegas = _axis(ctx)
    p = P.pack(P.CONTACT_DEFAULTS)
    res, loops = _scan(v_m, v_a, omegas, p)
    _, stiff = _scan(v_m, v_a, omegas, P.pack(P.CONTACT_DEFAULTS, sigma0=STIFF * p[P.SIGMA0]))
    area = np.array([L["loop_area"] for L in loops])
    area_s = np.array([L["loop_area"] for L in stiff])
    fvmin = [L["F_at_vmin"] for L in loops]
    k = int(np.argmax(area))
    shift = omegas[int(np.argmax(area_s))] / omegas[k]
    fig, ax = G.panels(1, 3, title="Fig. 1: friction-velocity loops of the contact model (HBM)")
    for w in LOOP_OMEGAS:
        r = contact_hbm(v_m, v_a, w, p)
        ax[0].plot(np.r_[r.u, r.u[0]] * 1e3, np.r_[r.F, r.F[0]], lw=1, label=f"{w:g} rad/s")
    ax[0].set(xlabel="velocity u (mm/s)", ylabel="friction F (N)")
    ax[0].legend(fontsize=7)
    ax[1].semilogx(omegas, area * 1e6, "o-", ms=3, label=f"sigma0 = {p[P.SIGMA0]:g} N/m")
    ax[1].semilogx(omegas, area_s * 1e6, "s--", ms=3, label=f"sigma0 = {STIFF * p[P.SIGMA0]:g}")
    ax[1].set(xlabel="omega (rad/s)", ylabel="loop area (N mm/s)")
    ax[1].legend(fontsize=7)
    ax[2].semilogx(omegas, fvmin, "o-", ms=3)
    ax[2].set(xlabel="omega (rad/s)", ylabel="F at least velocity (N)")
    png = G.save(fig, ctx.png("fig01"))
    checks = [
        Check("the loop first grows with frequency, then shrinks",
              f"largest loop {area[k]:.3g} N m/s at omega = {omegas[k]:.3g} rad/s, "
              f"{area[0]:.3g} at {omegas[0]:g}, {area[-1]:.3g} at {omegas[-1]:g}",
              "interior maximum, and the end values < 0.5 x the maximum",
              bool(0 < k < len(area) - 1 and max(area[0], area[-1]) < 0.5 * area[k])),
        below("at very high frequency the loop area is negligible", "area(top)/area(max)",
              area[-1] / area[k], 0.01),
        monotone("friction near zero velocity decreases uniformly with frequency",
                 "F(u_min) [N]", omegas[::max(1, len(omegas) // 6)],
                 fvmin[::max(1, len(omegas) // 6)], increasing=False, tol=1e-9, fmt=".4f"),
        above("stiffer bristles need a higher frequency (not shown in the paper)",
              f"omega of the largest loop, sigma0 x {STIFF:g} / sigma0", shift, 1.0),
    ]
    return FigureResult(
        "fig01", "Fig. 1: friction loops vs frequency", "Fig. 1, Sec. 3, Eqs. 3.1-3.3, App. A",
        "The loop first grows then shrinks with frequency to a negligible asymptotic loop; the "
        "friction near zero velocity decreases uniformly; stiffer bristles need higher "
        "frequencies.", png, checks,
        numbers={"omega_peak": float(omegas[k]), "area_end_ratio": float(area[-1] / area[k]),
                 "F_vmin_low": float(fvmin[0]), "F_vmin_high": float(fvmin[-1]),
                 "stiff_shift": float(shift)},
        choices=["The frequencies of Fig. 1 are not given: loops at 1, 10, 100, 1e3, 1e5 rad/s.",
                 "App. A's HBM with the corrected R0 (X1) and S_n (-sigma0 v_m Y_n) "
                 "(docs/MODEL.md Sec. 6); harmonics added until F changes < 1e-9 N."])


def fig02(ctx) -> FigureResult:
    v_m, v_a, omegas = _axis(ctx)
    p = P.pack(P.CONTACT_DEFAULTS)
    res, _ = _scan(v_m, v_a, omegas, p)
    amp = np.array([[abs(r.F_coef[n]) for n in range(1, 6)] for r in res])   # (omega, n)
    fig, ax = G.panels(1, 2, title="Fig. 2: harmonic content of the friction force (HBM)",
                       width=4.4)
    for n in range(1, 6):
        ax[0].loglog(omegas, amp[:, n - 1], "o-", ms=3, label=f"|F_{n}|")
    ax[0].set(xlabel="omega (rad/s)", ylabel="amplitude (N)")
    ax[0].legend(fontsize=7)
    for j in (0, len(omegas) - 1):
        ax[1].bar(np.arange(1, 6) + (0.2 if j else -0.2), amp[j], width=0.4,
                  label=f"omega = {omegas[j]:g} rad/s")
    ax[1].set(xlabel="harmonic n", ylabel="|F_n| (N)")
    ax[1].legend(fontsize=7)
    png = G.save(fig, ctx.png("fig02"))
    ratios = amp[-1] / amp[0]
    checks = [below(f"harmonic {n} strongly attenuated at high frequency",
                    f"|F_{n}| {amp[0, n - 1]:.2g} -> {amp[-1, n - 1]:.2g} N, ratio",
                    ratios[n - 1], ATTENUATION, decisive=ratios[n - 1] > 1.0)
              for n in HARMONICS]
    checks.insert(0, below("the fundamental is attenuated", f"|F_1| {amp[0, 0]:.2g} -> "
                           f"{amp[-1, 0]:.2g} N, ratio", ratios[0], ATTENUATION))
    return FigureResult(
        "fig02", "Fig. 2: harmonics of the friction force", "Fig. 2, Sec. 3",
        "High frequency of the velocity variation strongly attenuates the higher harmonics of "
        "the friction force.", png, checks,
        numbers={f"F{n}_low": float(amp[0, n - 1]) for n in range(1, 6)}
        | {f"F{n}_high": float(amp[-1, n - 1]) for n in range(1, 6)},
        choices=["'Higher harmonics' read as n = 2..5; 'strong' as a ratio below 0.1 between "
                 "the highest and the lowest frequency of the scene; a harmonic that grows "
                 "makes the claim fail."])
