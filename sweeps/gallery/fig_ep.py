"""Figs. 11-13: the elasto-plastic slider of Sec. 7 under sine-velocity dither (v_ref = 0.1,
slow force 1.7 sin(0.3 tau), lam = 0.8; read from the fig14 scene)."""
from __future__ import annotations

import numpy as np

from engine import params as P

from . import plotting as G
from . import trajectories as T
from .verdicts import Check, FigureResult, above, below, monotone

CASES = ((0.0, 100.0), (1.5, 100.0), (2.5, 100.0))     # (W, omega) of Figs. 11, 12
FIG13_W = (0.5, 0.8, 1.5, 2.0)                          # dither velocities, omega = 100
EDGE = 20.0            # low-pass edge (rad per unit tau) of Sec. 7: not given; 5x below omega
STOPPED = 0.01         # Fig. 11: |filtered v| below this counts as stopped
LONG = P.PAPER_DEFAULTS["long_stick"]   # long-duration stick: a run longer than this (tau)
EQUAL = 0.2            # "almost equal share": differ by less than 20% of the larger
VD_READINGS = (0.1, 0.01)   # Sec. 7 gives no vd; Secs. 5.1-5.2 use both
EP_NOTES = ["Sec. 7 gives no vd: vd = 0.1 (the Sec. 5.1 value used first) drawn; Fig. 12 "
            "judged under both of the paper's values, 0.1 and 0.01.",
            f"'Long-duration' sticking (never defined): an alpha = 0 run longer than {LONG} tau.",
            "The frequency unit is read as rad per unit tau (docs/MODEL.md Sec. 1)."]


def _runs(ctx, vd=None):
    s = T.sec7(ctx)
    if vd is not None:
        s["vd"] = vd
    return [T.cached_run(W=W, omega=om, model=ctx.run_model, **s) for W, om in CASES]


def _longest(t, mask):
    return float(T.stick_runs(t, np.where(mask, 0.0, 1.0)).max(initial=0.0))


def fig11(ctx) -> FigureResult:
    runs = _runs(ctx)
    fig, ax = G.panels(3, 1, title="Fig. 11: displacement (dashed) and filtered velocity "
                       "(solid)", sharex=True, width=7.5, height=2.0)
    stops = []
    for a, r, (W, om) in zip(ax, runs, CASES):
        dt = r.t[1] - r.t[0]
        vf = T.lowpass(r.v, dt, EDGE)
        stops.append(_longest(r.t, np.abs(vf) < STOPPED))
        a.plot(*G.thin(r.t, vf), lw=0.8, label="filtered velocity")
        a.plot(*G.thin(r.t, r.x), "--", lw=0.8, label="displacement")
        G.label(a, "without dither" if W == 0 else f"W = {W}, omega = {om:g}")
        a.set(xlabel=f"time {G.TAU}")
    ax[0].legend(fontsize=7)
    png = G.save(fig, ctx.png("fig11"))
    checks = [above("without dither the slider stops for long times", "longest stop (tau)",
                    stops[0], LONG)]
    checks += [below(f"with W = {W} it does not stop for long", "longest stop (tau)", s, LONG)
               for (W, _), s in zip(CASES[1:], stops[1:])]
    # the filtered velocity alone misses sticking under a weak dither (the slider then moves
    # with the dither while the interface sticks): the stick runs of alpha say it
    checks += [below(f"with W = {W} no long-duration stick (Sec. 7's reading of Fig. 11)",
                     "longest alpha = 0 run (tau)", r.outputs["max_stick"], LONG,
                     convention=f"'long-duration' = a stick run over {LONG} tau")
               for (W, _), r in zip(CASES[1:], runs[1:])]
    return FigureResult(
        "fig11", "Fig. 11: displacement and filtered velocity", "Fig. 11, Sec. 7",
        "Without dither the slider moves by long-duration stick-slip; with dither W = 1.5 "
        "and 2.5 at frequency 100 its (filtered) motion has no long stops.", png, checks,
        numbers={f"stop_W{W}": s for (W, _), s in zip(CASES, stops)}
        | {f"max_stick_W{W}": r.outputs["max_stick"] for (W, _), r in zip(CASES, runs)},
        choices=EP_NOTES + [f"Filter edge for Sec. 7 not given: {EDGE:g} rad per unit tau, "
                            "8th-order Butterworth, zero phase.",
                            f"'Stopped': |filtered v| < {STOPPED}."])


def fig12(ctx) -> FigureResult:
    runs = _runs(ctx)
    fig, ax = G.panels(3, 2, title="Fig. 12: EP-function alpha and its histogram", width=4.0,
                       height=2.1)
    for k, (r, (W, om)) in enumerate(zip(runs, CASES)):
        a = ax[2 * k]
        a.plot(*G.thin(r.t, r.alpha, max_points=20000), lw=0.4)
        a.set(xlabel=f"time {G.TAU}", ylabel="alpha")
        G.label(a, "without dither" if W == 0 else f"W = {W}, omega = {om:g}")
        G.histogram(ax[2 * k + 1], r.alpha_hist)
        G.label(ax[2 * k + 1], f"{r.steps} solver steps")
    png = G.save(fig, ctx.png("fig12"))
    checks, numbers = [], {}
    for vd in VD_READINGS:
        cs, ns = _fig12_checks(_runs(ctx, vd), f"vd = {vd}")
        checks += cs
        numbers |= {f"{k}_vd{vd}": x for k, x in ns.items()}
    return FigureResult(
        "fig12", "Fig. 12: EP-function histories and histograms", "Fig. 12, Sec. 7",
        "\"one concludes that the sticking and slipping phases have almost equal share [...] "
        "under the action of dither, long-duration stick-slip is replaced by short-duration "
        "stick-slip phases. [...] one may conclude that the relative share of the slipping "
        "time increases with the strength of the dither.\" (Sec. 7; W = 1.5, 2.5, "
        "frequency 100)", png, checks, numbers=numbers,
        choices=EP_NOTES + [
            "The paper's histograms count solver samples (18 805, 50 162, 55 937: ODE45 steps, "
            "denser where the solver is slow); ours are shares of time in 10 bins of alpha.",
            "Slipping read as alpha in the last bin (0.9, 1]: alpha = 1 exactly holds only to "
            "round-off (docs/MODEL.md Sec. 7).",
            f"'Almost equal' read as shares within {EQUAL:.0%} of the larger (a convention)."],
        loose=["Fig. 12 / Sec. 7: the histograms count ODE45's samples (18 805, 50 162, 55 937), "
               "whose density follows the step control, not time; and vd is not given: the "
               "'almost equal' stick and slip shares come out "
               + "; ".join(f"{numbers[f'stick_W0.0_vd{vd}']:.3f} vs "
                           f"{numbers[f'slip_W0.0_vd{vd}']:.3f} at vd = {vd}"
                           for vd in VD_READINGS) + " (shares of time)."])


def _fig12_checks(runs, reading):
    stick = [r.outputs["stick_fraction"] for r in runs]
    slip = [float(r.alpha_hist[-1]) for r in runs]
    longest = [r.outputs["max_stick"] for r in runs]
    gap = abs(stick[0] - slip[0]) / max(stick[0], slip[0])
    checks = [
        below("without dither sticking and slipping have almost equal shares",
              f"stick {stick[0]:.3f}, slip {slip[0]:.3f}; relative gap", gap, EQUAL,
              reading=reading, convention="'almost equal' = within 20 % of the larger"),
        above("without dither the sticking is long-duration", "longest stick (tau)",
              longest[0], LONG, reading=reading,
              convention=f"'long-duration' = a stick run over {LONG} tau"),
        Check("with dither only short-duration sticking", ", ".join(
            f"W={W}: {m:.3g}" for (W, _), m in zip(CASES[1:], longest[1:])),
              f"longest stick < {LONG} tau", bool(max(longest[1:]) < LONG), reading=reading),
        monotone("the slip share increases with the dither strength (Figs. 12(d), (f))",
                 "slip share", [W for W, _ in CASES[1:]], slip[1:], increasing=True,
                 reading=reading),
    ]
    numbers = ({f"stick_W{W}": x for (W, _), x in zip(CASES, stick)}
               | {f"slip_W{W}": x for (W, _), x in zip(CASES, slip)}
               | {f"max_stick_W{W}": x for (W, _), x in zip(CASES, longest)})
    return checks, numbers


def fig13(ctx) -> FigureResult:
    s = {**T.sec7(ctx), "v_ref": 0.0}
    t_slow = 2 * np.pi / s["slow"][1]
    s["t_end"] = 3 * t_slow
    fig, ax = G.panels(2, 2, title="Fig. 13: effective friction of the elasto-plastic "
                       "slider, v_m = 0, omega = 100", sharex=True, sharey=True)
    extent, longest, raw, r2 = [], [], [], []
    for a, W in zip(ax, FIG13_W):
        r = T.cached_run(W=W, omega=100.0, model=ctx.run_model, **s)
        dt = r.t[1] - r.t[0]
        keep = r.t >= t_slow
        vf, Ff = T.lowpass(r.v, dt, EDGE)[keep], T.lowpass(r.F, dt, EDGE)[keep]
        still = np.abs(vf) < STOPPED
        extent.append(float(np.ptp(Ff[still])) if still.any() else 0.0)
        longest.append(_longest(r.t[keep], still))
        raw.append(r.outputs["max_stick"])
        lo = np.abs(vf) < 0.5 * W
        r2.append(float(np.corrcoef(vf[lo], Ff[lo])[0, 1] ** 2) if lo.sum() > 2 else 0.0)
        a.plot(*G.thin(vf, Ff), lw=0.6)
        a.set(xlabel="filtered velocity", ylabel="filtered friction")
        G.label(a, f"dither velocity {W}")
    png = G.save(fig, ctx.png("fig13"))
    checks = [above(f"W = {W}: a vertical line at zero velocity (long sticking)",
                    "longest filtered stop (tau)", m, LONG)
              for W, m in zip(FIG13_W[:2], longest[:2])]
    checks += [below(f"W = {W}: sticking disappears", "longest filtered stop (tau)", m, LONG)
               for W, m in zip(FIG13_W[2:], longest[2:])]
    checks.append(monotone("the extent of the sticking force decreases with W",
                           "range of F_f while |v_f| < 0.01", FIG13_W, extent, increasing=False))
    checks += [above(f"W = {W}: low-velocity curve resembles viscous damping",
                     "R^2 of a line through F_f(v_f), |v_f| < W/2", x, 0.9,
                     convention="'resembles linear' = R^2 above 0.9")
               for W, x in zip(FIG13_W[2:], r2[2:])]
    return FigureResult(
        "fig13", "Fig. 13: effective friction, elasto-plastic", "Fig. 13, Sec. 7",
        "\"One observes zero-velocity vertical line in the effective friction plots shown in "
        "Figs. 13(a) and (b), and this indicates the existence of long-duration sticking "
        "phases [...] the extent of sticking force decreases with the increasing strength of "
        "dither. When the strength of fast excitation is strong enough, sticking phases "
        "disappear, and the corresponding low-velocity effective friction curves resemble "
        "linear viscous damping characteristics as observed in Figs. 13(c) and (d).\" "
        "(Sec. 7; dither velocity 0.5, 0.8, 1.5, 2, frequency 100)", png, checks,
        numbers={**{f"extent_W{W}": x for W, x in zip(FIG13_W, extent)},
                 **{f"stop_W{W}": x for W, x in zip(FIG13_W, longest)},
                 **{f"max_stick_W{W}": x for W, x in zip(FIG13_W, raw)},
                 **{f"r2_W{W}": x for W, x in zip(FIG13_W, r2)}},
        choices=EP_NOTES + ["Slow force of Sec. 7 (1.7 sin(0.3 tau)) with v_m = 0; 3 slow "
                            "periods, the first discarded.",
                            f"Filter edge {EDGE:g} rad per unit tau (not given for Sec. 7).",
                            "The 'vertical line' is a feature of the filtered plot: measured as "
                            f"the longest run with |filtered v| < {STOPPED} (the unfiltered "
                            "alpha = 0 runs are cut by every dither period; max_stick in the "
                            "numbers)."])
