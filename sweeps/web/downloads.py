"""Downloads: ``cube.nc`` as published, a query selection as CSV or JSON (the bytes of
``ditherlab query --format csv|json``), and each map as PNG, SVG or PDF (drawn by the code
of ``ditherlab map``, cached per cube publish). Work per request is bounded: a selection
over ``MAX_CELLS`` cells is refused (413), as are maps when too many wait (503)."""
from __future__ import annotations

import asyncio

from tornado.web import HTTPError

from .base import Base, in_executor
from .renders import MEDIA

MAX_CELLS = 2_000_000


def _snapshot(ctx, sweep_id: str):
    """The sweep's cube as published now, read and checked (sweeps.lookup.open_checked,
    the read path of the command line and the API)."""
    from ..lookup import open_checked

    try:
        return open_checked(sweep_id, ctx.cube_path(sweep_id), ctx.cubes.get)
    except FileNotFoundError:
        raise HTTPError(404, f"sweep {sweep_id} has no cube yet") from None


class CubeFile(Base):
    async def get(self, sweep_id):
        await self.sweep_or_404(sweep_id)
        snap = await in_executor(_snapshot, self.ctx, sweep_id)
        self.set_header("Content-Type", "application/x-netcdf")
        self.set_header("Content-Disposition", f'attachment; filename="{sweep_id}.nc"')
        self.finish(snap.data)


def _query(ctx, sweep_id: str, var: str | None, sel: dict, fmt: str) -> bytes:
    from ..exports import query_text, selection_size

    ds = _snapshot(ctx, sweep_id).ds
    if var and var not in ds.data_vars:
        raise HTTPError(400, f"var: the cube has no variable {var[:40]!r}")
    cells = selection_size(ds, var, sel)
    if cells > MAX_CELLS:
        raise HTTPError(413, f"the selection has {cells} cells, over the {MAX_CELLS} the web "
                        "view serves; fix more axes with sel.AXIS=VALUE or use "
                        "`ditherlab query`")
    return query_text(ds, var, sel, fmt).encode()


class Query(Base):
    async def get(self, sweep_id, fmt):
        await self.sweep_or_404(sweep_id)
        sel = self.selection()
        var = self.get_query_argument("var", "") or None
        data = await in_executor(_query, self.ctx, sweep_id, var, sel, fmt)
        self.set_header("Content-Type", "text/csv; charset=utf-8" if fmt == "csv"
                        else "application/json")
        self.set_header("Content-Disposition", f'attachment; filename="{sweep_id}.{fmt}"')
        self.finish(data)


class MapImage(Base):
    async def get(self, sweep_id, kind, fmt):
        await self.sweep_or_404(sweep_id)
        sel = self.selection()
        pick = self.get_query_argument("pick", "")
        if pick and (not pick.isdigit() or not 1 <= int(pick) <= 50):
            raise HTTPError(400, f"pick: 1 to 50 friction curves, got {pick[:40]!r}")
        if pick and kind != "friction":
            raise HTTPError(400, "pick: applies to the friction map only")
        snap = await in_executor(_snapshot, self.ctx, sweep_id)
        npick = int(pick) if pick else None
        key = (sweep_id, snap.key, kind, tuple(sorted(sel.items())), npick, fmt)
        maps = self.ctx.maps
        fut = maps.get(key, lambda: maps.draw(snap.ds, kind, sel, npick, fmt))
        data = await asyncio.wrap_future(fut)
        self.set_header("Content-Type", MEDIA[fmt])
        if self.get_query_argument("download", "") == "1":
            self.set_header("Content-Disposition",
                            f'attachment; filename="{sweep_id}-{kind}.{fmt}"')
        self.finish(data)
