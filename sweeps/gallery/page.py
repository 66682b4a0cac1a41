"""The gallery page: ``gallery.md`` (Markdown) and ``index.html`` (static, no scripts), per
figure the image beside the paper's claim, the numbers, the verdict with its reason (per
reading where the paper leaves a value open), the conventions next to the thresholds they
set, which points were computed, the readings taken, and a closing section "Where the paper
is loose or wrong" with the numbers."""
from __future__ import annotations

import html
import time
from collections import Counter

from .verdicts import FAILS, HOLDS, NOT_COMPUTED, PARTLY

COLOURS = {HOLDS: "#2e7d32", PARTLY: "#b26a00", FAILS: "#c62828", NOT_COMPUTED: "#616161"}
# a flex row stretches its items to the row's height (align-items: stretch), which distorted
# a wide figure beside a long text column: items keep their own height, and a figure wider
# than it is tall by 2.2 or more sits above its text (.wide)
CSS = """body{font-family:sans-serif;max-width:1400px;margin:auto;padding:1em;color:#222}
.fig{display:flex;gap:1.5em;border-top:1px solid #ccc;padding:1em 0;align-items:flex-start}
.fig.wide{flex-direction:column}
.fig img{max-width:55%;height:auto;flex:none;align-self:flex-start;border:1px solid #eee}
.fig.wide img{max-width:100%}
.txt{flex:1;font-size:0.92em}.v{font-weight:bold;padding:0 .4em;color:#fff;border-radius:3px}
td,th{padding:2px 8px;text-align:left}li{margin:2px 0}"""


def summary(results) -> list[tuple[str, str, str, float]]:
    """``(key, title, verdict, wall seconds)`` per figure: the verdict table."""
    return [(r.key, r.title, r.verdict, r.wall) for r in results]


def write_page(results, ctx) -> None:
    ctx.outdir.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("%Y-%m-%d %H:%M")
    (ctx.outdir / "gallery.md").write_text(_markdown(results, ctx.size, stamp))
    (ctx.outdir / "index.html").write_text(_html(results, ctx.size, stamp))


def _head(results, size, stamp) -> str:
    n = Counter(r.verdict for r in results)
    return (f"Size `{size}`, built {stamp}. {len(results)} figures: "
            + ", ".join(f"{n[v]} {v}" for v in (HOLDS, PARTLY, FAILS, NOT_COMPUTED)
                         if n[v] or v != NOT_COMPUTED) + ".")


def _numbers(r) -> str:
    return ", ".join(f"{k} = {v:.4g}" for k, v in r.numbers.items())


def _check_md(c) -> str:
    where = f"*{c.reading}*: " if c.reading else ""
    return f"- {'ok' if c.ok else 'NO'}: {where}{c.claim}: {c.measured} (rule {c.rule_text})"


def _verdict_line(r) -> str:
    per = r.readings
    if not per:
        return r.verdict
    return r.verdict + " (" + "; ".join(f"{v} under {n}" for n, v in per.items()) + ")"


LOOSE_HEAD = "Where the paper is loose or wrong"
CONVENTIONS = ("A threshold the paper does not give is a convention: it is named as such next to "
               "the number it judges (\"convention: ...\"). A check marked \"check of the "
               "engine\" compares the engine with an independent reference "
               "(sweeps/gallery/reference.py) and is decisive: if it fails, the figure is not "
               "the paper's model and its verdict is \"does not hold\".")


def _markdown(results, size, stamp) -> str:
    out = ["# ditherlab gallery: the paper's figures, recomputed", "",
           "Chatterjee, Singha, Karmakar, J. Sound Vib. 269 (2004) 61-89. Each verdict follows "
           "from the numbers by the thresholds in `sweeps/gallery/` (stated in each rule).", "",
           CONVENTIONS, "",
           _head(results, size, stamp), "", "| figure | verdict | time (s) |", "|---|---|---|"]
    out += [f"| [{r.title}](#{r.key}) | {_verdict_line(r)} | {r.wall:.1f} |" for r in results]
    for r in results:
        out += ["", f"## {r.title} <a id=\"{r.key}\"></a>", "",
                f"![{r.key}]({r.png.name})", "", f"*{r.ref}*", "",
                f"**Paper's claim.** {r.claim}", "", "**Numbers.**", ""]
        out += [_check_md(c) for c in r.checks]
        out += ["", "Measured: " + _numbers(r), ""]
        if r.computed:
            out += [f"Points: {r.computed}.", ""]
        out += [f"**Verdict: {_verdict_line(r)}.** {r.reason}", "",
                "**Readings and choices.**", ""]
        out += [f"- {c}" for c in r.choices] or ["- none"]
    out += ["", f"## {LOOSE_HEAD} <a id=\"loose\"></a>", ""]
    out += [f"- **{r.key}**: {x}" for r in results for x in r.loose] or ["- (none found)"]
    return "\n".join(out) + "\n"


def _html_check(c, e) -> str:
    where = f"<i>{e(c.reading)}</i>: " if c.reading else ""
    conv = (f" <small style='color:#8a5a00'>convention: {e(c.convention)}</small>"
            if c.convention else "")
    return (f"<li>{'&#10004;' if c.ok else '&#10008;'} {where}{e(c.claim)}: {e(c.measured)} "
            f"<small>(rule {e(c.rule)})</small>{conv}</li>")


def _badge(v, e) -> str:
    return f"<span class=v style='background:{COLOURS[v]}'>{e(v)}</span>"


def _html_fig(r, e) -> str:
    checks = "".join(_html_check(c, e) for c in r.checks)
    choices = "".join(f"<li>{e(c)}</li>" for c in r.choices) or "<li>none</li>"
    per = "".join(f"<li>{e(n)}: {_badge(v, e)}</li>" for n, v in r.readings.items())
    per = f"<p><b>Under each reading:</b></p><ul>{per}</ul>" if per else ""
    computed = f"<p><b>Points:</b> {e(r.computed)}.</p>" if r.computed else ""
    wide = " wide" if _aspect(r.png) >= 2.2 else ""
    return (f"<div class='fig{wide}' id='{r.key}'><img src='{e(r.png.name)}' alt='{e(r.key)}'>"
            f"<div class=txt><h2>{e(r.title)}</h2><p><i>{e(r.ref)}</i></p>"
            f"<p><b>Paper's claim.</b> {e(r.claim)}</p><p><b>Numbers.</b></p><ul>{checks}</ul>"
            f"<p><small>Measured: {e(_numbers(r))}</small></p>{computed}"
            f"<p><b>Verdict:</b> {_badge(r.verdict, e)} {e(r.reason)}</p>{per}"
            f"<p><b>Readings and choices.</b></p><ul>{choices}</ul></div></div>")


def _aspect(png) -> float:
    """Width / height of a PNG from its header (1.0 when unreadable)."""
    try:
        head = png.read_bytes()[16:24]
        w, h = int.from_bytes(head[:4], "big"), int.from_bytes(head[4:], "big")
        return w / h if h else 1.0
    except OSError:
        return 1.0


def _html(results, size, stamp) -> str:
    e = html.escape
    rows = "".join(f"<tr><td><a href='#{r.key}'>{e(r.title)}</a></td><td>{_badge(r.verdict, e)}"
                   f" <small>{e(_verdict_line(r)[len(r.verdict):])}</small></td>"
                   f"<td>{r.wall:.1f}</td></tr>" for r in results)
    body = [f"<h1>ditherlab gallery</h1><p>{e(_head(results, size, stamp))}</p>",
            f"<p>{e(CONVENTIONS)}</p>",
            f"<table><tr><th>figure</th><th>verdict</th><th>time (s)</th></tr>{rows}</table>"
            f"<p><a href='#loose'>{LOOSE_HEAD}</a></p>"]
    body += [_html_fig(r, e) for r in results]
    loose = "".join(f"<li><b>{e(r.key)}</b>: {e(x)}</li>" for r in results for x in r.loose)
    body.append(f"<h2 id='loose'>{LOOSE_HEAD}</h2><ul>{loose or '<li>(none found)</li>'}</ul>")
    return ("<!doctype html><html><head><meta charset='utf-8'><title>ditherlab gallery"
            f"</title><style>{CSS}</style></head><body>{''.join(body)}</body></html>\n")
