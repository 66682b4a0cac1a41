"""What the read commands hand out, written once for the command line and the web view:
the selection they read (:func:`parse_selection`), ``query``'s table, CSV and JSON text
(:func:`query_text`) and ``map``'s figures (:func:`draw_map`, the kinds in :data:`MAPS`).
``ditherlab query`` prints :func:`query_text`'s string and the web view serves its bytes,
so a download equals the command's output byte for byte."""
from __future__ import annotations

import json
import math
from typing import NamedTuple

from .errors import RefusedError

QUERY_FORMATS = ("table", "csv", "json")


class MapKind(NamedTuple):
    """What a map kind is drawn over and from: the axes it is drawn over (each needs more
    than one value; a selection of one is refused), the axis drawn as curves (a friction
    map's W), the outputs it reads (any one of them), the store function that draws it."""
    over: tuple[str, ...]
    curves: str | None
    outputs: tuple[str, ...]
    draw: str


# the one table of map kinds: the CLI's --kind, the web's routes and planes are built on it
MAPS = {
    "stick-slip": MapKind(("W", "omega"), None, ("long_stick_fraction",), "stick_slip_map"),
    "stability": MapKind(("v_ref", "W"), None, ("stable", "max_real_eig"), "stability_map"),
    "friction": MapKind(("v_ref",), "W", ("F_eff", "F_mean"), "friction_curves"),
    "hunting": MapKind(("W", "omega"), None, ("hunt_amplitude",), "hunting_map"),
}


def plane(kind: str) -> tuple[str, ...]:
    """The axes a ``kind`` map shows (drawn over, and as curves)."""
    m = MAPS[kind]
    return (m.curves, *m.over) if m.curves else m.over


def parse_selection(pairs, option: str = "--sel {axis}") -> dict[str, float]:
    """``(axis, text)`` pairs -> ``{axis: value}``, the one set of rules of the command
    line's ``--sel AXIS=VALUE`` and the web view's ``sel.AXIS=VALUE``: a cube axis, a number
    (not NaN), one value per axis (the same value twice is one). ``option`` names a pair in
    the refusal (``--sel {axis}``, ``sel.{axis}``)."""
    from store.cube import AXES

    sel: dict[str, float] = {}
    for axis, text in pairs:
        name = option.format(axis=str(axis)[:40])
        if axis not in AXES:
            raise RefusedError(f"{name}: unknown axis; the axes are {', '.join(AXES)}")
        try:
            x = float(text)
        except ValueError:
            raise RefusedError(f"{name}: expected a number, got {str(text)[:40]!r}") from None
        if math.isnan(x):
            raise RefusedError(f"{name}: expected a number, got NaN")
        if axis in sel and sel[axis] != x:
            raise RefusedError(f"{name}: given twice ({sel[axis]:g} and {str(text).strip()}); "
                               "a selection takes one value per axis")
        sel[axis] = x
    return sel


def _json_value(x):
    """A table cell for JSON: full precision (repr), NaN (not computed) as null, an
    infinite value (omega = inf, the averaged limit) as the string "inf" / "-inf"."""
    if isinstance(x, float):
        return None if x != x else ("inf" if x == math.inf else "-inf" if x == -math.inf
                                    else x)
    return x


def query_text(ds, var: str | None, sel: dict, fmt: str) -> str:
    """The text ``ditherlab query`` prints for ``fmt`` (table, csv or json), ending in a
    newline. A selection the cube cannot answer is refused (``RefusedError``)."""
    import store

    try:
        df = store.table(ds, var=var, sel=sel)
    except ValueError as exc:
        raise RefusedError(str(exc)) from None
    if fmt == "csv":
        return df.to_csv(index=False)
    if fmt == "json":   # not DataFrame.to_json: it rounds to 10 decimals, inf -> null
        rows = [{k: _json_value(v) for k, v in row.items()}
                for row in df.to_dict(orient="records")]
        return json.dumps(rows, indent=1) + "\n"
    return df.to_string(index=False) + "\n"


def selection_size(ds, var: str | None, sel: dict) -> int:
    """Cells :func:`query_text` would write (rows x columns), known before any work: the
    web view refuses a selection above its cap with this number."""
    import numpy as np

    rows = int(np.prod([n for axis, n in ds.sizes.items() if axis not in sel] or [1]))
    return rows * (len(ds.sizes) + (1 if var else len(ds.data_vars)))


def refuse_map_axes(kind: str, sel: dict, ds) -> None:
    """A selection of an axis the map is drawn over (with more than one value in ``ds``)
    is refused, not drawn as a one-column map (a stability cut labelled alone would also
    lose its PU link to W = 0)."""
    over = MAPS[kind].over
    fixed = [axis for axis in sel if axis in over and ds.sizes[axis] > 1]
    if fixed:
        raise RefusedError(f"--sel {fixed[0]}: {fixed[0]} is an axis of the {kind} map "
                           f"({' x '.join(over)}), not a value to fix; `ditherlab query` "
                           f"reads a cut through it")


def draw_map(ds, kind: str, sel: dict, path) -> None:
    """Draw the ``kind`` map of ``ds`` at ``sel`` into ``path`` (png, pdf or svg by its
    suffix): the one drawing behind ``ditherlab map`` and the web view's maps. A friction
    map draws every W of ``ds`` (``ds.sel(W=[...])`` picks curves first)."""
    import store

    refuse_map_axes(kind, sel, ds)
    draw = getattr(store, MAPS[kind].draw)
    try:
        draw(ds, path, sel=sel)
    except ValueError as exc:
        raise RefusedError(str(exc)) from None


def pick_w(ds, n: int) -> list[float]:
    """``--pick N``: N of the cube's W values, evenly spread, first and last included."""
    import numpy as np

    from .gallery.scenes import shrink

    return [float(w) for w in shrink(list(np.sort(ds.W.values)), n)]
