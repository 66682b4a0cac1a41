"""PNG diagrams and markdown tables of scripts/work_precision.py (docs/ACCURACY.md).

Generated tables replace the text between ``<!-- BEGIN generated:NAME -->`` and
``<!-- END generated:NAME -->`` in docs/ACCURACY.md; the prose around them is written by
hand and survives a regeneration. ``write_all(data)`` takes the dict the study saved to
docs/work_precision.json.
"""
from __future__ import annotations

import math
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import wp_core as wp

DOC = wp.DOCS / "ACCURACY.md"
COLORS = {"rk4": "tab:blue", "dopri5": "tab:orange", "rodas4": "tab:green"}
FLOOR = 1e-16   # an error of exactly 0 is drawn here
TARGETS = (1e-2, 1e-4, 1e-7)


def _e(x: float) -> str:
    return "fail" if not math.isfinite(x) else ("0" if x == 0 else f"{x:.1e}")


def _k(n: int) -> str:
    return f"{n / 1e3:.0f}k" if n < 1e6 else f"{n / 1e6:.1f}M"


def _ms(t: float) -> str:
    return f"{1e3 * t:.3g}"


# --------------------------------------------------------------------------- plots
def plot_scene(name: str, res: dict) -> str:
    """One log-log panel per queried output and one for their max; returns the file name."""
    panels = ["combined"] + res["queried"]
    ncol = min(len(panels), 4)
    nrow = math.ceil(len(panels) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 4.0 * nrow), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax, q in zip(axes.flat, panels):
        for m in wp.METHOD_ORDER:
            rows = [r for r in res["runs"] if r["method"] == m and math.isfinite(r["error"].get(q, math.inf))
                    and not wp.is_reference(r, res["refs"][0])]
            if not rows:
                continue
            xs = [1e3 * r["time"] for r in rows]
            ys = [max(r["error"][q], FLOOR) for r in rows]
            ax.loglog(xs, ys, "o-", color=COLORS[m], label=m, ms=4)
            for x, y, r in zip(xs, ys, rows):
                ax.annotate(r["label"].split("=")[1], (x, y), fontsize=6,
                            xytext=(2, 2), textcoords="offset points")
        for t in TARGETS:
            ax.axhline(t, color="0.7", lw=0.8, ls="--")
        ax.set_title(f"{name}: {'max over queried' if q == 'combined' else q}", fontsize=9)
        ax.set_xlabel("wall time per point [ms]")
        ax.set_ylabel("relative error" if q not in wp.FRACTIONS else "absolute error")
        ax.grid(True, which="major", alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.suptitle(f"{name}: error against the reference run vs wall time per point; "
                 "points labelled by N (rk4 steps per (half-)period), h, or rtol; dashed: "
                 "1e-2, 1e-4, 1e-7; an error of exactly 0 is drawn at 1e-16", fontsize=9)
    fig.tight_layout()
    fname = f"wp_{name}.png"
    fig.savefig(wp.DOCS / fname, dpi=110)
    plt.close(fig)
    return fname


def plot_crossover(cross: dict) -> str:
    """Cheapest time per point reaching each target against sigma0, per method."""
    fig, axes = plt.subplots(1, len(TARGETS), figsize=(4.2 * len(TARGETS), 3.8), squeeze=False)
    for ax, t in zip(axes[0], TARGETS):
        for m in wp.METHOD_ORDER:
            pts = [(float(s), e["methods"][m]["hits"][f"{t:.0e}"]) for s, e in cross.items()]
            pts = [(s, 1e3 * h["time"]) for s, h in pts if h is not None]
            if pts:
                ax.loglog(*zip(*pts), "o-", color=COLORS[m], label=m)
        ax.set_title(f"Fig. 10(d), tau in [0, 10]: error <= {t:.0e}", fontsize=9)
        ax.set_xlabel("sigma0")
        ax.set_ylabel("cheapest time per point [ms]")
        ax.grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(wp.DOCS / "wp_crossover.png", dpi=110)
    plt.close(fig)
    return "wp_crossover.png"


# --------------------------------------------------------------------------- tables
def table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def _value(x) -> str:
    """A reference value: a number, or the largest bin of a histogram."""
    if isinstance(x, list):
        return f"max bin {max(x):.6g}"
    return f"{x:.10g}"


def _e_or_dash(x) -> str:
    return "-" if x is None else _e(x)


def refs_table(scenes: dict) -> str:
    out = []
    for name, res in scenes.items():
        r0 = res["refs"][0]
        rows = [[f"{r0['method']} {r0['label']}", "(reference)", _ms(r0["time"]),
                 *[_value(r0["outputs"][q][0]) for q in res["queried"]]]]
        for r in res["refs"][1:]:
            ok = r["status"][0] == 0
            rows.append([f"{r['method']} {r['label']}", "agrees to" if ok else
                         f"**failed** (status {r['status'][0]})", _ms(r["time"]),
                         *[_e_or_dash(r["agreement"].get(q)) for q in res["queried"]]])
        out.append(f"**{name}**\n\n" + table(["run", "", "ms"] + res["queried"], rows))
    return "\n\n".join(out)


def runs_table(res: dict) -> str:
    rows = []
    for r in res["runs"]:
        err = ("(= reference)" if wp.is_reference(r, res["refs"][0])
               else _e(r["error"]["combined"]))
        rows.append([r["method"], r["label"], _ms(r["time"]), r["steps"], r["rejected"],
                     r["evals"], err,
                     *[_e_or_dash(r["error"].get(q)) for q in res["queried"]]])
    return table(["method", "setting", "ms/point", "steps", "rejected", "evals", "error"]
                 + res["queried"], rows)


def cheapest_table(scenes: dict) -> str:
    rows = []
    for name, res in scenes.items():
        for m in wp.METHOD_ORDER:
            cells = []
            for t in TARGETS:
                ok = [r for r in res["runs"] if r["method"] == m and r["error"]["combined"] <= t
                      and not wp.is_reference(r, res["refs"][0])]
                best = min(ok, key=lambda r: r["time"], default=None)
                cells.append("not reached" if best is None else
                             f"{best['label']}: {_ms(best['time'])} ms, {_k(best['evals'])} ev")
            rows.append([name, m, *cells])
    return table(["scene", "method"] + [f"error <= {t:.0e}" for t in TARGETS], rows)


def levels_table(levels: dict, bounds: dict | None) -> str:
    rows = []
    for name, by_level in levels.items():
        for level, r in by_level.items():
            n = r["numerics"]
            if n["integrator"] != "rk4":
                setting = f"rtol={n['rtol']:.0e}, atol={n['atol']:.0e}"
            else:
                setting = f"h={n['h']:g}" if r["dither"] == "none" else f"N={n['steps_per_period']}"
            bound = bounds.get(level) if bounds else None
            ok = "" if bound is None else ("yes" if r["error"]["combined"] <= bound else "**no**")
            rows.append([name, level, n["integrator"], setting, _e(r["error"]["combined"]),
                         ok, _ms(r["time"]), r["evals"]])
    return table(["scene", "level", "integrator", "setting", "error", "within bound",
                  "ms/point", "evals"], rows)


PROMISE_COLUMNS = ("v_mean", "v_slow_p2p", "F_mean", "stick_fraction", "presliding_fraction",
                   "slip_fraction", "near_slip_fraction", "long_stick_fraction", "max_stick",
                   "alpha_hist")
SHORT = {"v_mean": "v_mean", "v_slow_p2p": "p2p", "F_mean": "F_mean", "stick_fraction": "stick",
         "presliding_fraction": "pre", "slip_fraction": "slip", "near_slip_fraction": "near",
         "long_stick_fraction": "long", "max_stick": "max_st", "alpha_hist": "hist"}


def promises_table(levels: dict) -> str:
    """Per scene and level: the error of every output against the scene's reference, marked
    ** where it exceeds what the level promises for it (sweeps.spec.accuracy.promise)."""
    from sweeps.spec.accuracy import promise
    rows = []
    for name, by_level in levels.items():
        friction = wp.SCENES[name]["spec"]["friction"] if name in wp.SCENES else None
        for level, r in by_level.items():
            cells = []
            for o in PROMISE_COLUMNS:
                e = r["error"].get(o)
                if e is None:
                    cells.append("-")
                    continue
                cells.append(_e(e) if e <= promise(level, o, friction) else f"**{_e(e)}**")
            n = r["numerics"]
            tol = f"{n['integrator']} " + (f"{n['rtol']:.0e}" if n["integrator"] != "rk4" else
                                           (f"h={n['h']:g}" if r["dither"] == "none"
                                            else f"N={n['steps_per_period']}"))
            rows.append([name, level, tol, _ms(r["time"]), *cells])
    return table(["scene", "level", "numerics", "ms/point", *(SHORT[o] for o in PROMISE_COLUMNS)],
                 rows)


def promise_rows() -> str:
    from sweeps.spec.accuracy import LAW_PROMISE_OVERRIDES, TARGET_ERROR, promise
    rows = [[o, *(f"{promise(lv, o):.0e}" for lv in TARGET_ERROR)] for o in PROMISE_COLUMNS]
    for law, by_output in LAW_PROMISE_OVERRIDES.items():
        for o in by_output:
            rows.append([f"{o} ({law})", *(f"{promise(lv, o, law):.0e}" for lv in TARGET_ERROR)])
    return table(["output", *TARGET_ERROR], rows)


def quench_table(quench: dict) -> str:
    ws = next(iter(quench.values()))["W"]
    rows = []
    for level, r in quench.items():
        cells = [f"{p:.3g} {'Q' if q else 'S'}" for p, q in
                 zip(r["outputs"]["v_slow_p2p"], r["quenched"])]
        rows.append([level, *cells, _ms(r["time"])])
    return table(["run"] + [f"W={w:g}" for w in ws] + ["ms/point"], rows)


def crossover_table(cross: dict) -> str:
    rows = []
    for s, e in cross.items():
        for m in wp.METHOD_ORDER:
            cells = [("-" if h is None else f"{h['label']}: {_ms(h['time'])} ms")
                     for h in e["methods"][m]["hits"].values()]
            rows.append([s, m, *cells])
    return table(["sigma0", "method"] + [f"error <= {t:.0e}" for t in TARGETS], rows)


def crossover_levels_table(cross: dict, bounds: dict) -> str:
    """Per sigma0 and level: DP5 at LEVELS against the stiff method at STIFF_LEVELS."""
    rows = []
    for s, e in cross.items():
        for level, by_m in e.get("levels", {}).items():
            cells = []
            for m in ("dopri5", "rodas4"):
                r = by_m[m]
                flag = "" if r["error"]["combined"] <= bounds[level] else " (**over**)"
                cells.append(f"{_e(r['error']['combined'])}{flag}, {_ms(r['time'])} ms")
            t = {m: by_m[m]["time"] for m in by_m}
            rows.append([s, level, *cells, f"{t['dopri5'] / t['rodas4']:.2f}"])
    header = ["sigma0", "level", "dopri5 at LEVELS: error, time",
              "rodas4 at STIFF_LEVELS: error, time", "time dopri5 / rodas4"]
    return table(header, rows)


def effects_table(effects: dict) -> str:
    out = []
    for m, e in effects.items():
        rows = []
        for r in e["rows"]:
            v = r["variants"]
            cells = [f"{_ms(c['time'])} ms, {c['evals']} ev, {c['ns_per_eval']:.0f} ns/ev"
                     for c in v]
            if len(v) == 3:
                rows.append([r["effect"], *cells, f"{v[1]['time'] / v[2]['time']:.2f}",
                             f"{v[0]['time'] / v[2]['time']:.2f}", _e(r["b_vs_c_max_diff"])])
            else:
                rows.append([r["effect"], cells[0], "", cells[1],
                             "", f"{v[0]['time'] / v[1]['time']:.2f}", ""])
        out.append(f"**{m}, {e['label']}**\n\n" + table(
            ["effect", "(a) present", "(b) zero, compiled in", "(c) compiled out",
             "b / c", "a / c", "max |b - c|"], rows))
    return "\n\n".join(out)


def averaged_text(a: dict, levels: dict) -> str:
    std = levels.get("fig10", {}).get("standard")
    ratio = f" ({std['time'] / a['time_per_point']:,.0f}x less than a fig10 point at " \
            f"`standard`)" if std else ""
    return (f"`run_block(Scene(path='averaged', friction='lugre', dither='square-velocity'))` "
            f"on {a['points']} points (W in [0, 1] x v_ref in [0.02, 1]): max steps = "
            f"{a['steps_max']}, max evals = {a['evals_max']}, max rejected = "
            f"{a['rejected_max']}, all status OK: {a['all_ok']}; "
            f"{1e6 * a['time_per_point']:.2f} us per point{ratio}.")


# --------------------------------------------------------------------------- document
def replace_section(text: str, name: str, body: str) -> str:
    begin, end = f"<!-- BEGIN generated:{name} -->", f"<!-- END generated:{name} -->"
    block = f"{begin}\n{body}\n{end}"
    if begin in text:
        return re.sub(re.escape(begin) + r".*?" + re.escape(end), lambda _: block, text,
                      flags=re.DOTALL)
    return text + f"\n\n{block}\n"


def sections(data: dict) -> dict:
    from sweeps.spec.accuracy import TARGET_ERROR
    sc = data["scenes"]
    meta = data["meta"]
    sec = {"meta": (f"Generated {meta['date']} from engine {meta.get('engine', '?')} "
                    f"({'quick' if meta['quick'] else 'full'} run, "
                    f"median of {meta['repeats']} repeat(s), load average at start "
                    f"{meta['loadavg']} on 2 cores shared with other jobs: absolute times "
                    f"are noisy, ratios within one table are the meaningful part)."),
           "refs": refs_table(sc), "cheapest": cheapest_table(sc)}
    for name, res in sc.items():
        sec[f"wp-{name}"] = f"![{name}]({plot_scene(name, res)})\n\n" + runs_table(res)
    if "levels" in data:
        sec["levels"] = levels_table(data["levels"], TARGET_ERROR)
        sec["promises"] = (promise_rows() + "\n\nMeasured (error against each scene's "
                           "reference; ** over the promise):\n\n"
                           + promises_table(data["levels"]))
    if "quench" in data:
        sec["quench"] = quench_table(data["quench"])
    if "crossover" in data:
        sec["crossover"] = (f"![crossover]({plot_crossover(data['crossover'])})\n\n"
                            + crossover_table(data["crossover"]))
        sec["crossover-levels"] = crossover_levels_table(data["crossover"], TARGET_ERROR)
    if "effects" in data:
        sec["effects"] = effects_table(data["effects"])
    if "averaged" in data:
        sec["averaged"] = averaged_text(data["averaged"], data.get("levels", {}))
    return sec


def write_all(data: dict) -> None:
    text = DOC.read_text() if DOC.exists() else "# Accuracy: what it costs, measured\n"
    for name, body in sections(data).items():
        text = replace_section(text, name, body)
    DOC.write_text(text)
    print(f"wrote {DOC} and its PNGs")
