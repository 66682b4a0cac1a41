"""The catalogue (``/``), its JSON (``/api/sweeps?after=N``), and one page per sweep
(``/sweep/ID``, ``/api/sweep/ID``)."""
from __future__ import annotations

import json

from tornado.web import HTTPError

from store.cube import AXES

from .base import Base, in_executor
from .sweep_view import sweep_view

SORTS = ("created", "name", "state", "done", "path", "finished", "sweep_id")
SORT_KEYS = {
    "created": lambda r: r["created"], "name": lambda r: r["name"].lower(),
    "state": lambda r: r["state_text"], "path": lambda r: r["path"],
    "done": lambda r: r["done_points"] / max(r["n_points"], 1),
    "finished": lambda r: r["finished"] or "", "sweep_id": lambda r: r["sweep_id"],
}


class Catalogue(Base):
    async def get(self):
        q = self.get_query_argument("q", "").strip()
        state = self.get_query_argument("state", "").strip()
        sort = self.get_query_argument("sort", "created")
        desc = self.get_query_argument("desc", "1" if sort == "created" else "") == "1"
        if sort not in SORTS:
            raise HTTPError(400, f"sort: one of {', '.join(SORTS)}, got {sort[:40]!r}")
        live = self.ctx.live
        cursor, rows, servers = await in_executor(live.snapshot)
        key = (cursor, q, state, sort, desc)
        html = live.pages.get(key)
        if html is None:   # one rendering per catalogue change and view, for every reader
            html = await in_executor(_render, rows, servers, q, state, sort, desc, cursor,
                                     self.ctx.root.name)   # (its name: no server folder)
            live.pages.put(key, html)
        self.set_header("Content-Type", "text/html; charset=utf-8")
        self.finish(html)


def _render(rows, servers, q, state, sort, desc, cursor, store) -> str:
    from .base import TEMPLATES

    states = sorted({r["state"] for r in rows} | ({"stale"} if any(r["stale"] for r in rows)
                                                  else set()))
    shown = [r for r in rows if _matches(r, q, state)]
    shown.sort(key=SORT_KEYS[sort], reverse=desc)
    return TEMPLATES.get_template("catalogue.html").render(
        rows=shown, total=len(rows), cursor=cursor, q=q, state=state, states=states,
        sort=sort, desc=desc, servers=servers, store=store)


def _matches(row: dict, q: str, state: str) -> bool:
    if state and not (row["state"] == state or (state == "stale" and row["stale"])):
        return False
    if not q:
        return True
    q = q.lower()
    return (q in row["name"].lower() or row["sweep_id"].startswith(q)
            or any(q in n.lower() for n in row["earlier_names"]))


class ApiSweeps(Base):
    async def get(self):
        try:
            after = int(self.get_query_argument("after", "0"))
        except ValueError:
            raise HTTPError(400, "after: expected the integer cursor of the last answer")
        live = self.ctx.live
        data = await in_executor(live.changes, after)
        key = ("api", data["cursor"], after)
        body = live.pages.get(key)
        if body is None:   # serialised once per catalogue change and cursor
            body = await in_executor(lambda: json.dumps(data, allow_nan=False, default=str))
            live.pages.put(key, body)
        self.set_header("Content-Type", "application/json")
        self.finish(body)


class ApiSweep(Base):
    async def get(self, sweep_id):
        await self.sweep_or_404(sweep_id)
        view = await in_executor(sweep_view, self.ctx, sweep_id, {})
        self.json(view["detail"])


class SweepPage(Base):
    async def get(self, sweep_id):
        await self.sweep_or_404(sweep_id)
        sel = self.selection()
        pick = self.get_query_argument("pick", "5")
        if not pick.isdigit() or not 1 <= int(pick) <= 50:
            raise HTTPError(400, f"pick: 1 to 50 friction curves, got {pick[:40]!r}")
        var = self.get_query_argument("var", "")
        view = await in_executor(sweep_view, self.ctx, sweep_id, sel)
        if var and var not in view["variables_names"]:
            raise HTTPError(400, f"var: the cube has no variable {var[:40]!r}")
        self.page("sweep.html", v=view, sel=sel, pick=int(pick), var=var, axes=AXES)
