"""The explorer: an averaged stability chart and effective-friction curves computed on
request, for parameters set in the page.

The page's fields become a spec dict (:func:`spec_from_query`), validated by the same
``load_spec`` as ``ditherlab submit`` and planned by ``make_plan``; its blocks run here, in
the web server's process, whose numba kernels stay loaded between requests (a warm-up at
start compiles or loads them). The cube is filled in memory, never written, and drawn by
the map functions of ``ditherlab map``; the page shows the spec as TOML to submit as a
sweep. One computation at a time (:class:`Busy` otherwise) and at most
``MAX_AXIS`` x ``MAX_AXIS`` points.
"""
from __future__ import annotations

import threading
from concurrent.futures import Future, ThreadPoolExecutor

from ..errors import RefusedError
from .errors import Busy
from .first_imports import after_imports
from .lru import LRU

MAX_AXIS = 400
PARAMS = ("sigma0", "sigma1", "sigma2", "vs", "fc", "fs")
FRICTIONS = ("lugre", "stribeck", "coulomb")
DITHERS = ("square-velocity", "sine-velocity", "sine-force")
DEFAULTS = {"friction": "lugre", "dither": "square-velocity", "v_d": "0.1",
            "W_start": "0", "W_stop": "1.2", "W_num": "121",
            "v_ref_start": "0.005", "v_ref_stop": "1.2", "v_ref_num": "120", "curves": "5"}
KEEP = 4


def _number(query: dict, name: str, kind=float):
    text = str(query.get(name, DEFAULTS.get(name, ""))).strip()
    try:
        return kind(text)
    except ValueError:
        raise RefusedError(f"{name}: expected a number, got {text[:40]!r}") from None


def spec_from_query(query: dict) -> dict:
    """The explorer's spec dict from the page's fields (strings); a field out of range is
    refused in one sentence (400)."""
    friction = query.get("friction", DEFAULTS["friction"])
    dither = query.get("dither", DEFAULTS["dither"])
    if friction not in FRICTIONS:
        raise RefusedError(f"friction: one of {', '.join(FRICTIONS)}, got {friction[:40]!r}")
    if dither not in DITHERS:
        raise RefusedError(f"dither: one of {', '.join(DITHERS)}, got {dither[:40]!r}")
    grid = {}
    for axis in ("W", "v_ref"):
        num = _number(query, f"{axis}_num", int)
        if not 1 <= num <= MAX_AXIS:
            raise RefusedError(f"{axis}_num: the explorer computes 1 to {MAX_AXIS} values per "
                               f"axis, got {num}")
        grid[axis] = {"start": _number(query, f"{axis}_start"),
                      "stop": _number(query, f"{axis}_stop"), "num": num}
    grid["v_d"] = [_number(query, "v_d")]
    params = {p: _number(query, p) for p in PARAMS if str(query.get(p, "")).strip()}
    return {"name": "explorer", "friction": friction, "dither": dither, "method": "averaged",
            "outputs": ["F_eff", "max_real_eig", "stable"], "params": params, "grid": grid}


def curves_wanted(query: dict) -> int:
    n = _number(query, "curves", int)
    if not 1 <= n <= 20:
        raise RefusedError(f"curves: 1 to 20 friction curves, got {n}")
    return n


def compute(spec_dict: dict):
    """The averaged cube of ``spec_dict`` (an ``xarray.Dataset``), computed here."""
    from store.points import fill

    from ..run.new_cube import empty_cube
    from ..planning.plan import make_plan
    from ..spec.load import SpecError, load_spec
    from ..workers.task import compute_block

    try:
        plan = make_plan(load_spec(spec_dict, max_points=MAX_AXIS * MAX_AXIS))
    except SpecError as exc:
        raise RefusedError(str(exc)) from None
    cube = empty_cube(plan)
    for b, idx in enumerate(plan.blocks):
        fill(cube, compute_block(plan.scene, plan.block_points(b), plan.params,
                                 plan.numerics.settings, idx))
    return cube.to_dataset()


class Explorer:
    """One computation at a time, the last ``KEEP`` results kept by spec."""

    def __init__(self):
        self.pool = ThreadPoolExecutor(1, thread_name_prefix="ditherlab-explorer")
        self._results = LRU(KEEP)   # futures of cubes by spec
        self._running: str | None = None
        self._lock = threading.Lock()

    def warm_up(self) -> Future:
        """Compile (or load from numba's cache) the averaged kernels before the first click."""
        small = spec_from_query({"W_num": "3", "v_ref_num": "3"})
        return self.pool.submit(after_imports, compute, small)

    def cube(self, key: str, spec_dict: dict) -> Future:
        with self._lock:
            held = self._results.get(key)
            if held is not None:
                return held
            if self._running is not None:
                raise Busy("another explorer computation is running; try again in a moment")
            self._running = key
            fut = self.pool.submit(after_imports, self._compute, key, spec_dict)
            self._results.put(key, fut)
            return fut

    def _compute(self, key: str, spec_dict: dict):
        try:
            return compute(spec_dict)
        except BaseException:
            self._results.pop(key)   # a failure is not kept
            raise
        finally:
            with self._lock:
                self._running = None
