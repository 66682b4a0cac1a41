"""Figs. 15-17: the elasto-plastic slider at three command velocities, without slow force,
without (Fig. 15) and with (Figs. 16, 17) sine-velocity dither."""
from __future__ import annotations

from . import plotting as G
from . import trajectories as T
from .fig_ep import EP_NOTES, LONG
from .verdicts import Check, FigureResult, monotone

V_M = (0.1, 0.5, 1.0)
DITHER = (1.5, 100.0)     # (W, omega) of Figs. 16, 17: not given; the Figs. 11-12 values
#: readings of the unstated dither of Figs. 16-17: the two of Figs. 11-12 and a stronger one
DITHERS = {f"W = {W:g}, omega = 100": (W, 100.0) for W in (1.5, 2.5, 3.0)}
T_TRANSIENT = 20.0        # shares and means over [20, t_end]
WINDOW = 2.0              # Fig. 17 shows a short ("high-frequency") window of this length (tau)
NOTES = EP_NOTES + [
    f"The dither of Figs. 16-17 is not given: W = {DITHER[0]}, omega = {DITHER[1]:g} "
    "(as in Figs. 11-12) drawn; judged under W = 1.5, 2.5 and 3.0 at omega = 100.",
    "No slow force ('without any slow excitation'); from rest; shares and means over "
    f"[{T_TRANSIENT:g}, t_end]."]


def _runs(ctx, dithered: bool, dither=DITHER):
    s = {**T.sec7(ctx), "slow": (0.0, 0.0), "t_transient": T_TRANSIENT}
    s.pop("v_ref")
    W, om = dither if dithered else (0.0, 100.0)
    return [T.cached_run(W=W, omega=om, v_ref=v, model=ctx.run_model, **s) for v in V_M]


def _histories(ctx, key, runs, title, *, friction: bool):
    fig, ax = G.panels(3, 2, title=title, width=4.0, height=2.0, sharex=True)
    for k, (r, v) in enumerate(zip(runs, V_M)):
        ax[2 * k].plot(*G.thin(r.t, r.x), lw=0.8, label="displacement")
        right = ax[2 * k + 1]
        right.plot(*G.thin(r.t, T.lowpass(r.v, r.t[1] - r.t[0], 20.0)), "--", lw=0.7,
                   label="velocity (filtered)")
        if friction:
            right.plot(*G.thin(r.t, T.lowpass(r.F, r.t[1] - r.t[0], 20.0)), lw=0.7,
                       label="friction (filtered)")
        for a in ax[2 * k: 2 * k + 2]:
            G.label(a, f"v_m = {v}")
            a.set(xlabel=f"time {G.TAU}")
    ax[0].legend(fontsize=7)
    ax[1].legend(fontsize=7)
    return G.save(fig, ctx.png(key))


def fig15(ctx) -> FigureResult:
    runs = _runs(ctx, False)
    png = _histories(ctx, "fig15", runs, "Fig. 15: without dither", friction=False)
    longest = [r.outputs["max_stick"] for r in runs]
    checks = [Check(f"v_m = {v}: long-duration stick-slip without dither",
                    f"longest stick {m:.3g} tau", f"> {LONG} tau", bool(m > LONG))
              for v, m in zip(V_M, longest)]
    return FigureResult(
        "fig15", "Fig. 15: histories without dither", "Fig. 15, Sec. 7",
        "Without dither the slider moves by long-duration stick-slip (what Fig. 16's dither "
        "suppresses).", png, checks,
        numbers={f"max_stick_v{v}": m for v, m in zip(V_M, longest)}
        | {f"F_mean_v{v}": r.outputs["F_mean"] for v, r in zip(V_M, runs)}, choices=NOTES)


def _no_long_stick(claim: str, longest, reading="") -> Check:
    """The check that no sticking run at any v_m is longer than LONG."""
    return Check(claim, ", ".join(f"v_m={v}: {m:.3g}" for v, m in zip(V_M, longest)),
                 f"longest stick < {LONG} tau", bool(max(longest) < LONG), reading=reading)


def fig16(ctx) -> FigureResult:
    runs, bare = _runs(ctx, True), _runs(ctx, False)
    png = _histories(ctx, "fig16", runs, f"Fig. 16: with dither W = {DITHER[0]}, omega = "
                     f"{DITHER[1]:g}", friction=True)
    F0 = [r.outputs["F_mean"] for r in bare]
    checks, numbers = [], {f"F_mean_nodither_v{v}": x for v, x in zip(V_M, F0)}
    for reading, dither in DITHERS.items():
        runs = _runs(ctx, True, dither)
        longest = [r.outputs["max_stick"] for r in runs]
        F = [r.outputs["F_mean"] for r in runs]
        checks += [
            _no_long_stick("dither suppresses long-duration stick-slip", longest, reading),
            Check("the dithered friction is reduced", ", ".join(
                f"v_m={v}: {a:.3g} vs {b:.3g}" for v, a, b in zip(V_M, F, F0)),
                  "mean F with dither < without, every v_m",
                  bool(all(a < b for a, b in zip(F, F0))), reading=reading),
            monotone("friction increases with the sliding velocity (Figs. 16(b), (d), (f))",
                     "mean F", V_M, F, increasing=True, reading=reading),
        ]
        tag = f"_W{dither[0]:g}"
        numbers |= {f"F_mean_v{v}{tag}": x for v, x in zip(V_M, F)}
        numbers |= {f"max_stick_v{v}{tag}": m for v, m in zip(V_M, longest)}
    return FigureResult(
        "fig16", "Fig. 16: histories with dither", "Fig. 16, Sec. 7",
        "\"From Fig. 16, one observes that long-duration stick-slip is suppressed by dither. "
        "[...] a reduction in friction force is observed in dithered system. [...] This "
        "accounts for the increase of friction force with the sliding velocity as observed in "
        "Figs. 16(b), (d) and (f).\" (Sec. 7)", png, checks, numbers=numbers, choices=NOTES)


def fig17(ctx) -> FigureResult:
    runs = _runs(ctx, True)
    fig, ax = G.panels(3, 2, title="Fig. 17: EP-function (solid), friction (dashed) and "
                       f"histogram, with dither W = {DITHER[0]}, omega = {DITHER[1]:g}",
                       width=4.0, height=2.0)
    for k, (r, v) in enumerate(zip(runs, V_M)):
        win = (r.t >= r.t[-1] - WINDOW)
        ax[2 * k].plot(r.t[win], r.alpha[win], lw=0.7, label="alpha")
        ax[2 * k].plot(r.t[win], r.F[win], "--", lw=0.7, label="friction")
        ax[2 * k].set(xlabel=f"time {G.TAU}")
        G.label(ax[2 * k], f"v_m = {v}")
        G.histogram(ax[2 * k + 1], r.alpha_hist)
        G.label(ax[2 * k + 1], f"stick share {r.outputs['stick_fraction']:.3f}")
    ax[0].legend(fontsize=7)
    png = G.save(fig, ctx.png("fig17"))
    checks, numbers = [], {}
    for reading, dither in DITHERS.items():
        runs = _runs(ctx, True, dither)
        stick = [r.outputs["stick_fraction"] for r in runs]
        longest = [r.outputs["max_stick"] for r in runs]
        checks += [
            _no_long_stick("long stick-slip replaced by short-duration phases", longest,
                           reading),
            monotone("the relative duration of short sticking increases with v_m",
                     "stick share", V_M, stick, increasing=True, reading=reading),
        ]
        numbers |= {f"stick_v{v}_W{dither[0]:g}": x for v, x in zip(V_M, stick)}
    bad = [r for r, v in FigureResult("", "", "", "", png, checks).readings.items()
           if v != "holds"]
    return FigureResult(
        "fig17", "Fig. 17: EP-function, friction, histograms", "Fig. 17, Sec. 7",
        "\"as observed in Fig. 17, long-duration stick-slip phases are replaced by "
        "short-duration stick-slip phases. [...] histograms of the collected samples of the "
        "EP-functions clearly show that the total relative duration of the short-time sticking "
        "phase increases with the command velocity\" (Sec. 7)", png, checks,
        numbers=numbers,
        choices=NOTES + [f"Histories drawn over the last {WINDOW:g} tau."],
        loose=["Figs. 16-17: the dither is not given, and the claim that the short-stick share "
               "rises with v_m depends on it: " + "; ".join(
                   f"W = {W:g}: " + ", ".join(f"{numbers[f'stick_v{v}_W{W:g}']:.3f}"
                                              for v in V_M)
                   for W, _ in DITHERS.values()) + f" at v_m = {V_M}"
               + (f" (does not hold under {', '.join(bad)})." if bad else ".")])
