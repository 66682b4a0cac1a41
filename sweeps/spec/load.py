"""Sweep specification: parse, validate, canonicalise, hash (DESIGN.md §3).

A spec arrives as TOML, JSON or a dict and is validated by pydantic before anything
runs; every fault becomes one line naming the field, the value received and what is
allowed (:class:`SpecError`). The sweep id is a hash of what changes results
(physics, grid, time window, accuracy, engine version) and never of cosmetic fields
(``name``, ``description``, ``block_size``).

Validation cannot be fooled, made slow or crashed (issues 9 and 10):

- types are strict (no ``"100"`` for 100, no ``true`` for 1; an int is fine where a float
  is expected), NaN and infinities are refused everywhere;
- a file is read as UTF-8 (a byte-order mark is skipped), at most :data:`MAX_FILE_BYTES`
  (1 MB of TOML, 10 MB of JSON: a large explicit axis belongs in a range, or in JSON), and
  nesting deeper than :data:`MAX_DEPTH` is refused before pydantic sees it;
- the grid's size is the product of the axis lengths read from the spec's fields, checked
  against the point budget *before* any axis is built (O(1) memory whatever ``num`` is);
- an axis may not repeat a value (a cube coordinate must be unique);
- every echoed value is cut to about :data:`sweeps.spec.messages.ECHO_CHARS` characters and
  shown as plain Python (never ``np.float64(...)``); at most :data:`MAX_PROBLEMS` lines per refusal;
- what the engine cannot run is refused here too (:mod:`sweeps.spec.feasibility`): an unknown
  integrator, options the chosen integrator ignores, an explicit fixed step outside its
  method's stability region, a point certain to exhaust the step budget.

The models are :mod:`sweeps.spec.models`, the wording of faults :mod:`sweeps.spec.messages`,
the checks of choices and axis values :mod:`sweeps.spec.checks`; this module loads and
parses.
"""
from __future__ import annotations

import functools
import json
import math
import warnings
from pathlib import Path

import tomllib
from pydantic import ValidationError

from . import feasibility
from ..errors import MAX_LINE, MAX_PROBLEMS, SpecError  # noqa: F401  (re-exported)
from .grid import AXES, axis_size
from .checks import check_choices, check_grid
from .messages import format_error, format_loc, show
from .models import MAX_AXIS_POINTS, Spec

DEFAULT_MAX_POINTS = 250_000
MAX_DEPTH = 16                    # nesting of tables and lists (a spec needs 3)
# a spec file: pure-Python tomllib reads ~1 MB of escapes per second, json 100x faster
MAX_FILE_BYTES = {"TOML": 1_000_000, "JSON": 10_000_000}


def _plain(data, max_depth: int = MAX_DEPTH):
    """A copy of ``data`` as plain JSON-like Python (tuples as lists, numpy scalars and
    small arrays as Python numbers and lists), or a :class:`SpecError` when it nests
    deeper than ``max_depth`` or holds a key that is not a string. Iterative: no
    recursion, whatever the depth."""
    def convert(v):
        if isinstance(v, tuple):
            return list(v)
        if hasattr(v, "dtype") and hasattr(v, "tolist"):          # numpy scalar or array
            if getattr(v, "size", 1) <= MAX_AXIS_POINTS:
                return v.tolist()
        return v

    root = [convert(data)]
    stack = [(root, 0, "", 0)]
    while stack:
        parent, key, path, depth = stack.pop()
        value = parent[key]
        if not isinstance(value, (dict, list)):
            continue
        if depth >= max_depth:
            raise SpecError([f"{path or 'spec'}: nested more than {max_depth} levels deep "
                             "(a spec needs 3: grid.W.start)"])
        if isinstance(value, dict):
            copy = {}
            for k, v in value.items():
                if not isinstance(k, str):
                    raise SpecError([f"{path or 'spec'}: keys must be strings, got {show(k)}"])
                copy[k] = convert(v)
            parent[key] = copy
            for k in copy:
                where = f"{path}.{format_loc([k])}" if path else format_loc([k])
                stack.append((copy, k, where, depth + 1))
        else:
            copy = [convert(v) for v in value]
            parent[key] = copy
            for i in range(len(copy)):
                if isinstance(copy[i], (dict, list)):
                    stack.append((copy, i, f"{path}.{i}" if path else str(i), depth + 1))
    return root[0]


def parse_spec(data: dict, *, max_points: int = DEFAULT_MAX_POINTS) -> Spec:
    """Validate a spec given as a dict; raise :class:`SpecError` listing every fault.

    Order: plain data of bounded depth (:func:`_plain`); pydantic (types, ranges, keys);
    the grid's size from the spec's fields against ``max_points`` (no axis is built
    before this); then what needs the axis values and the engine
    (:mod:`sweeps.spec.checks`, :func:`sweeps.spec.feasibility.check`). Warnings (a point that
    may exhaust its step budget) go through :mod:`warnings` as :class:`SpecWarning`.
    """
    if not isinstance(data, dict):
        raise SpecError([f"spec: expected a table of keys, got {type(data).__name__}"])
    data = _plain(data)
    try:
        spec = Spec.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors(include_url=False)
        raise SpecError([format_error(e) for e in errors[:MAX_PROBLEMS]],
                        more=len(errors) - min(len(errors), MAX_PROBLEMS)) from None
    sizes = {axis: axis_size(spec, axis) for axis in AXES}
    n = math.prod(sizes.values())
    if n > max_points:
        shape = " x ".join(f"{a}={k}" for a, k in sizes.items())
        raise SpecError(check_choices(spec) + [
            f"grid: {n} points ({shape}) is over the point budget of {max_points}; "
            f"coarsen an axis or split the sweep"])
    problems = check_choices(spec) + check_grid(spec)
    if not problems:
        found, notes = feasibility.check(spec)
        problems += found
        for note in notes:
            warnings.warn(note, SpecWarning, stacklevel=2)
    if not problems:
        problems += _probe_brought_models(spec)
    if problems:
        raise SpecError(problems)
    return spec


def _probe_brought_models(spec: Spec) -> list[str]:
    """A model the spec brings by import path is compiled and takes its first step here, so
    that bad user code is one line before anything is written (engine.systems.probe)."""
    from engine import registry

    if not any(registry.is_import_path(r) for r in (spec.friction, spec.system)):
        return []
    from engine.contract import ModelError
    from engine.scene import Scene

    from .grid import base_params

    try:
        p = base_params(spec)
        g = spec.grid_facts
        first = [float(c[0]) for c in g.coords.values()]    # (W, omega, v_ref, v_d)
        p[[registry.P.W, registry.P.OMEGA, registry.P.V_REF, registry.P.VD]] = first
        scene = Scene.from_params(p, system=spec.system, friction=spec.friction,
                                  dither=g.dither, outputs=spec.outputs or (),
                                  sizes=spec.model_sizes)
        _probed(scene, p.tobytes())
    except ModelError as exc:
        return [str(exc)]
    return []


@functools.lru_cache(maxsize=64)
def _probed(scene, p_bytes: bytes) -> None:
    """The probe, in a child process (a model that crashes kills that one, not this:
    engine.user_code.isolated); once per process for each scene and parameters passed
    (a command that looks a sweep up loads its spec again)."""
    import numpy as np

    from engine.systems import probe
    from engine.user_code import isolated

    isolated(f"friction {scene.friction!r} on system {scene.system!r}", probe, scene,
             np.frombuffer(p_bytes).copy())


class SpecWarning(UserWarning):
    """A spec that is accepted but may not run as hoped (e.g. may exhaust its steps)."""


def _read_text(path: Path, kind: str) -> str:
    """The file as text: UTF-8 (a byte-order mark is skipped), at most MAX_FILE_BYTES."""
    where = show(str(path)).strip("'\"")
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES[kind]:
            raise SpecError([f"{where}: the spec file has {size} bytes, more than the "
                             f"{MAX_FILE_BYTES[kind]} a {kind} spec may have (sweep a long "
                             "axis as a range)"])
        raw = path.read_bytes()
    except OSError as exc:
        raise SpecError([f"{where}: cannot read the spec file ({exc.strerror or exc})"]) from None
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SpecError([f"{where}: not UTF-8 text (byte {raw[exc.start]:#04x} at offset "
                         f"{exc.start}); save the spec as UTF-8"]) from None


def load_spec(source: str | Path | dict, *, max_points: int = DEFAULT_MAX_POINTS) -> Spec:
    """Load a spec from a ``.toml`` / ``.json`` file path or a dict."""
    if isinstance(source, dict):
        return parse_spec(source, max_points=max_points)
    path = Path(source)
    kind = "JSON" if path.suffix == ".json" else "TOML"
    text = _read_text(path, kind)
    try:
        data = json.loads(text) if kind == "JSON" else tomllib.loads(text)
    except RecursionError:
        raise SpecError([f"{show(str(path)).strip(chr(39))}: nested too deeply to read "
                         f"(a spec nests at most {MAX_DEPTH} levels)"]) from None
    except ValueError as exc:   # JSONDecodeError, TOMLDecodeError, an over-long integer
        text = " ".join(str(exc).split())
        raise SpecError([f"{show(str(path)).strip(chr(39))}: malformed {kind}: "
                         f"{text[:160]}"]) from None
    return parse_spec(data, max_points=max_points)
