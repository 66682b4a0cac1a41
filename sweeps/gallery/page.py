"""The gallery page: ``gallery.md`` (Markdown) and ``index.html`` (static, no scripts), per
figure the image beside the paper's claim, the numbers, the verdict with its reason, and the
readings taken where the paper is ambiguous or wrong."""
from __future__ import annotations

import html
import time
from collections import Counter

from .verdicts import FAILS, HOLDS, NOT_COMPUTED, PARTLY

COLOURS = {HOLDS: "#2e7d32", PARTLY: "#b26a00", FAILS: "#c62828", NOT_COMPUTED: "#616161"}
CSS = """body{font-family:sans-serif;max-width:1400px;margin:auto;padding:1em;color:#222}
.fig{display:flex;gap:1.5em;border-top:1px solid #ccc;padding:1em 0}
.fig img{max-width:55%;height:auto;border:1px solid #eee}
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


def _markdown(results, size, stamp) -> str:
    out = ["# ditherlab gallery: the paper's figures, recomputed", "",
           "Chatterjee, Singha, Karmakar, J. Sound Vib. 269 (2004) 61-89. Each verdict follows "
           "from the numbers by the thresholds in `sweeps/gallery/` (stated in each rule).", "",
           _head(results, size, stamp), "", "| figure | verdict | time (s) |", "|---|---|---|"]
    out += [f"| [{r.title}](#{r.key}) | {r.verdict} | {r.wall:.1f} |" for r in results]
    for r in results:
        out += ["", f"## {r.title} <a id=\"{r.key}\"></a>", "",
                f"![{r.key}]({r.png.name})", "", f"*{r.ref}*", "",
                f"**Paper's claim.** {r.claim}", "", "**Numbers.**", ""]
        out += [f"- {'ok' if c.ok else 'NO'}: {c.claim}: {c.measured} (rule {c.rule})"
                for c in r.checks]
        out += ["", "Measured: " + _numbers(r), "",
                f"**Verdict: {r.verdict}.** {r.reason}", "",
                "**Readings and choices.**", ""]
        out += [f"- {c}" for c in r.choices] or ["- none"]
    return "\n".join(out) + "\n"


def _html(results, size, stamp) -> str:
    e = html.escape
    rows = "".join(f"<tr><td><a href='#{r.key}'>{e(r.title)}</a></td><td><span class=v "
                   f"style='background:{COLOURS[r.verdict]}'>{e(r.verdict)}</span></td>"
                   f"<td>{r.wall:.1f}</td></tr>" for r in results)
    body = [f"<h1>ditherlab gallery</h1><p>{e(_head(results, size, stamp))}</p>",
            f"<table><tr><th>figure</th><th>verdict</th><th>time (s)</th></tr>{rows}</table>"]
    for r in results:
        checks = "".join(f"<li>{'&#10004;' if c.ok else '&#10008;'} {e(c.claim)}: "
                         f"{e(c.measured)} <small>(rule {e(c.rule)})</small></li>"
                         for c in r.checks)
        choices = "".join(f"<li>{e(c)}</li>" for c in r.choices) or "<li>none</li>"
        body.append(
            f"<div class=fig id='{r.key}'><img src='{e(r.png.name)}' alt='{e(r.key)}'>"
            f"<div class=txt><h2>{e(r.title)}</h2><p><i>{e(r.ref)}</i></p>"
            f"<p><b>Paper's claim.</b> {e(r.claim)}</p><p><b>Numbers.</b></p><ul>{checks}</ul>"
            f"<p><small>Measured: {e(_numbers(r))}</small></p>"
            f"<p><b>Verdict:</b> <span class=v style='background:{COLOURS[r.verdict]}'>"
            f"{e(r.verdict)}</span> {e(r.reason)}</p>"
            f"<p><b>Readings and choices.</b></p><ul>{choices}</ul></div></div>")
    return ("<!doctype html><html><head><meta charset='utf-8'><title>ditherlab gallery"
            f"</title><style>{CSS}</style></head><body>{''.join(body)}</body></html>\n")
