"""What the sweep page shows, as plain data: the sweep's row and detail (``status SWEEP
--format json``), its spec as TOML, the plan the installed code makes of it, the error
estimate per output against its promise, the grid and variables, the counts of computed
and inferred points, and the maps that fit the cube with the axes left to choose."""
from __future__ import annotations

import json
from urllib.parse import urlencode

import numpy as np

from store.cube import AXES

from ..exports import MAPS, plane
from .tomltext import spec_toml


def fitting_maps(ds) -> list[str]:
    """The map kinds this cube can draw (one of their outputs present, each axis they are
    drawn over with more than one value)."""
    from store.query import output_names

    names = set(output_names(ds))
    return [kind for kind, m in MAPS.items()
            if names & set(m.outputs) and all(ds.sizes[a] > 1 for a in m.over)]


def map_controls(ds, kind: str, sel: dict) -> dict:
    """The axes a ``kind`` map is not drawn over that have several values: each with its
    values and the one chosen (the selection's nearest, else the first)."""
    controls = {}
    for axis in AXES:
        if axis in plane(kind) or ds.sizes[axis] < 2:
            continue
        values = [float(x) for x in ds[axis].values]
        want = sel.get(axis, values[0])
        chosen = values[int(np.argmin([abs(x - want) for x in values]))]
        controls[axis] = {"values": values, "chosen": chosen}
    return controls


def _plan(spec: dict) -> dict | str:
    from engine.kernels import step_cap_note

    from ..planning.plan import make_plan
    from ..spec.load import SpecError, load_spec

    try:
        plan = make_plan(load_spec(spec, max_points=10**9))
    except (SpecError, ValueError) as exc:
        return f"the installed code cannot plan this spec: {exc}"
    s = plan.numerics.settings
    effects = plan.effects()
    return {"sweep_id": plan.sweep_id, "path": plan.path, "points": plan.n_points,
            "blocks": len(plan.blocks), "scene": f"system={plan.spec.system} friction="
            f"{plan.spec.friction} dither={plan.scene.dither}",
            "on": [k for k, v in effects.items() if v], "off": [k for k, v in effects.items()
                                                                 if not v],
            "numerics": (f"{plan.numerics.integrator} ({plan.numerics.label}): rtol={s.rtol:g} "
                         f"atol={s.atol:g}{' (natural units)' if s.atol_units == 'natural' else ''}"
                         f"{step_cap_note(plan.scene)}" if plan.path == "simulate"
                         else "no time integration"),
            "outputs": list(plan.outputs)}


def _estimate(detail: dict) -> list[dict]:
    est = detail.get("error_estimate") or {}
    return [{"output": name, "change": change, "promise": est["promise"].get(name),
             "over": change > est["promise"].get(name, float("inf"))}
            for name, change in est.get("change", {}).items()]


def _counts(ds) -> dict:
    from store.flags import COMPUTED, INFERRED
    from store.points import status_counts

    counts = status_counts(ds)
    if "provenance" in ds:
        flags = ds["provenance"].values
        counts["computed"] = int((flags == COMPUTED).sum())
        counts["inferred"] = int((flags == INFERRED).sum())
    return counts


def _axes(ds) -> list[dict]:
    out = []
    for axis in AXES:
        c = ds[axis]
        out.append({"name": axis, "n": int(c.size), "min": float(c.min()), "max": float(c.max()),
                    "units": str(c.attrs.get("units", "")),
                    "shown": ", ".join(f"{x:g}" for x in c.values[:8])
                    + (" ..." if c.size > 8 else "")})
    return out


def _variables(ds) -> list[dict]:
    return [{"name": n, "long_name": str(v.attrs.get("long_name", "")),
             "units": str(v.attrs.get("units", "")), "dims": " x ".join(v.dims)}
            for n, v in ds.data_vars.items()]


SHOWN_ELSEWHERE = ("spec", "error_estimate", "accuracy_warnings", "name", "sweep_id")


def _provenance(ds) -> list[tuple[str, str]]:
    """The cube's global attributes (versions, engine settings, scene, parameters, times),
    but those the page shows elsewhere."""
    return [(k, str(v)) for k, v in ds.attrs.items() if k not in SHOWN_ELSEWHERE]


def sweep_view(ctx, sweep_id: str, sel: dict) -> dict:
    """Everything the sweep page of ``sweep_id`` (looked up in the catalogue) shows."""
    from ..lookup import open_checked
    from ..overview import sweep_detail
    from .live import row_inside_store

    from store.cube_io import CubeError

    cube_path = ctx.cube_path(sweep_id)
    ds, cube_error = None, None
    if cube_path.exists():
        try:
            ds = open_checked(sweep_id, cube_path, ctx.cubes.get).ds
        except CubeError as err:   # a torn cube: the page without it, saying how to repair
            cube_error = ctx.shown(str(err))
    detail = row_inside_store(ctx.root, sweep_detail(ctx.root, sweep_id, ds))
    from ..estimates.time_history import recorded

    view = {"detail": detail, "toml": spec_toml(detail["spec"]), "plan": ctx.plan(sweep_id,
                                                                                  detail["spec"]),
            "time_estimate": recorded(ctx.root, sweep_id),
            "estimate": _estimate(detail), "has_cube": ds is not None, "maps": [],
            "variables_names": [], "cube_error": cube_error}
    if ds is None:
        return view
    view.update(axes=_axes(ds), variables=_variables(ds), counts=_counts(ds),
                variables_names=list(ds.data_vars), provenance=_provenance(ds))
    for kind in fitting_maps(ds):
        controls = map_controls(ds, kind, sel)
        query = {f"sel.{a}": repr(c["chosen"]) for a, c in controls.items()}
        view["maps"].append({"kind": kind, "controls": controls,
                             "query": urlencode(query), "plane": plane(kind)})
    view["query_sel"] = urlencode({f"sel.{a}": repr(x) for a, x in sel.items()})
    return view


def plan_cached(cache, sweep_id: str, spec: dict):
    """The plan summary of a sweep's spec, computed once per server (``cache``: an LRU)."""
    summary = cache.get(sweep_id)
    if summary is None:
        summary = _plan(json.loads(json.dumps(spec)))
        cache.put(sweep_id, summary)
    return summary
