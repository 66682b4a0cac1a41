"""Figs. 6, 8 (simulated effective friction against the averaged theory) and Fig. 10
(velocity histories of the tracking system): LuGre slider trajectories."""
from __future__ import annotations

import numpy as np

from engine import params as P
from engine.analysis import effective_friction, max_real_eig, sine_force_simplified
from engine.analysis.stability import jacobian

from . import plotting as G
from . import trajectories as T
from .verdicts import Check, FigureResult, below

RMS_OK = 0.05          # "clearly demonstrates validity": RMS of F_f - <F>(v_f) below 5% of fc
QUENCHED = 0.01        # Fig. 10: a slow peak-to-peak velocity below this is "quenched"
SLOW = (1.7, 0.5)      # Sec. 5: 1.7 sin(0.5 tau)
CASES = {"fig06": ("square-velocity", 0.5, 1000.0, 16),
         "fig08": ("sine-force", 0.75, 2000.0, 16)}


def _compare(key, ctx):
    dither, W, omega, per = CASES[key]
    t_slow = 2 * np.pi / SLOW[1]
    dt = 2 * np.pi / omega / per
    out = {}
    for vd in (0.1, 0.01):
        r = T.run(friction="lugre", dither=dither, W=W, omega=omega, v_ref=0.0, slow=SLOW,
                  vd=vd, t_end=3 * t_slow, dt=dt)
        keep = r.t >= t_slow
        vf, Ff = T.lowpass(r.v, dt)[keep], T.lowpass(r.F, dt)[keep]
        dev = Ff - effective_friction(vf, W, P.pack(vd=vd), dither=dither)
        out[vd] = (vf, Ff, float(np.sqrt(np.mean(dev ** 2))), r)
    return out


def _draw_compare(key, ctx, out, title):
    dither, W, _, _ = CASES[key]
    fig, ax = G.panels(1, 2, title=title, width=4.2, height=3.2)
    for a, (vd, (vf, Ff, rms, _)) in zip(ax, out.items()):
        vv, ff = G.thin(vf, Ff, max_points=4000)
        a.plot(vv, ff, ".", ms=1.5, c="C0", label="simulation, filtered")
        grid = np.linspace(vf.min(), vf.max(), 300)
        a.plot(grid, effective_friction(grid, W, P.pack(vd=vd), dither=dither), "ko", ms=2.5,
               mfc="none", markevery=6, label="averaged theory")
        if dither == "sine-force":
            a.plot(grid, sine_force_simplified(grid, W, 1.0, 0.004), "r--", lw=1,
                   label="Eq. 5.20")
        a.set(xlabel="filtered velocity", ylabel="filtered friction")
        G.label(a, f"vd = {vd}; RMS gap {rms:.3f}")
        a.legend(fontsize=7)
    return G.save(fig, ctx.png(key))


def _compare_result(key, ctx, title, ref, claim, choices):
    out = _compare(key, ctx)
    png = _draw_compare(key, ctx, out, title)
    checks = [below(f"filtered simulation on the averaged curve, vd = {vd}",
                    "RMS of F_f - <F>(v_f)", rms, RMS_OK) for vd, (_, _, rms, _) in out.items()]
    return FigureResult(key, title, ref, claim, png, checks,
                        numbers={f"rms_{vd}": rms for vd, (_, _, rms, _) in out.items()},
                        choices=choices)


FILTER_NOTE = ("Filter: 8th-order Butterworth, edge 500 rad per unit tau (the paper's 'lower "
               "band edge frequency 500', unit read as rad per unit tau), applied forward-"
               "backward (zero phase) instead of the paper's analog filter.")


def fig06(ctx) -> FigureResult:
    return _compare_result(
        "fig06", ctx, "Fig. 6: simulated vs averaged friction, square dither", "Fig. 6, Sec. 5.1",
        "Filtered simulated friction against filtered velocity follows the averaged curves "
        "of Fig. 5(a), (b) (square wave W = 0.5, omega = 1000, slow force 1.7 sin(0.5 tau)).",
        [FILTER_NOTE, "Square wave entered as a velocity on the interface (Sec. 5.1, Fig. 4); "
         "3 slow periods from rest, the first discarded; dopri5 rtol 1e-7 stepping onto every "
         "switch."])


def fig08(ctx) -> FigureResult:
    return _compare_result(
        "fig08", ctx, "Fig. 8: simulated vs averaged friction, sine force", "Fig. 8, Sec. 5.2",
        "With the force 1500 sin(2000 tau) the filtered simulated friction is nearly viscous "
        "at low velocity and agrees with Eqs. 5.20-5.21.",
        [FILTER_NOTE, "1500 sin(2000 tau) read as a Omega^2 sin(Omega tau) with Omega = 2000, "
         "so the velocity amplitude a Omega = 0.75.",
         "Compared with the averaged full LuGre model (sine-force rule); Eq. 5.20 drawn too."])


def fig10(ctx) -> FigureResult:
    spec = ctx.spec("fig10")
    grid, tm = spec["grid"], spec["time"]
    Ws, omega, v_ref = grid["W"], grid["omega"][0], grid["v_ref"][0]
    vds = (0.1, 0.01)
    p2p = {vd: [] for vd in vds}
    fig, ax = G.panels(2, 3, title=f"Fig. 10: velocity histories, v_ref = {v_ref}, square "
                       f"dither omega = {omega:g} (vd = 0.1)", sharex=True, sharey=True)
    for vd in vds:
        for k, W in enumerate(Ws):
            r = T.run(friction="lugre", dither=spec["dither"], W=W, omega=omega, v_ref=v_ref,
                      slow=(0.0, 0.0), vd=vd, t_end=tm["t_end"], t_transient=tm["t_transient"],
                      dt=0.02)
            p2p[vd].append(r.outputs["v_slow_p2p"])
            if vd == 0.1 and k < len(ax):
                ax[k].plot(r.t, r.v, lw=0.7)
                G.label(ax[k], f"W = {W}; p2p {r.outputs['v_slow_p2p']:.3f}")
                ax[k].set(xlabel=f"time {G.TAU}", ylabel="velocity")
    png = G.save(fig, ctx.png("fig10"))
    eig = max_real_eig(jacobian(np.full(len(Ws), v_ref), np.asarray(Ws, float), P.pack(vd=0.1))[0])
    a = p2p[0.1]
    checks = [
        Check("dither reduces or quenches the self-sustained oscillation (vd = 0.1)",
              ", ".join(f"W={W}: {x:.3g}" for W, x in zip(Ws, a)),
              "p2p(W) < p2p(0) for every W > 0", bool(all(x < a[0] for x in a[1:]))),
    ] + [below(f"complete quenching at W = {W} (Fig. 10({'abcdef'[Ws.index(W)]}))",
               "slow p2p velocity", a[Ws.index(W)], QUENCHED) for W in (0.4, 0.6) if W in Ws]
    agree = [(e < 0) == (x < QUENCHED) for e, x in zip(eig[1:], a[1:])]
    checks.append(Check("(not in the paper) the averaged stability (Eqs. 6.4-6.7) predicts "
                        "which W quench", ", ".join(f"W={W}: eig {e:.3g}" for W, e in
                                                    zip(Ws, eig)),
                        "max Re eig < 0 exactly where quenched, W > 0", bool(all(agree))))
    return FigureResult(
        "fig10", "Fig. 10: velocity histories vs W", "Fig. 10, Sec. 6, Eqs. 6.1-6.3",
        "High-frequency dither quenches or reduces the self-sustained velocity oscillation; "
        "complete quenching at W = 0.4 and 0.6.", png, checks,
        numbers={f"p2p_{vd}_W{W}": x for vd in vds for W, x in zip(Ws, p2p[vd])}
        | {f"eig_W{W}": float(e) for W, e in zip(Ws, eig)},
        choices=["vd is not given for Fig. 10: vd = 0.1 drawn, 0.01 also computed (numbers).",
                 "'Quenched' read as a slow peak-to-peak velocity below 0.01 over "
                 f"[{tm['t_transient']}, {tm['t_end']}] (dither-period averages, engine).",
                 "No slow force (Sec. 6 system, Eqs. 6.1-6.3), from rest."])
