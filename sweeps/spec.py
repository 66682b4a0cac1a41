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
- every echoed value is cut to about :data:`ECHO_CHARS` characters and shown as plain
  Python (never ``np.float64(...)``); at most :data:`MAX_PROBLEMS` lines per refusal;
- what the engine cannot run is refused here too (:mod:`sweeps.feasibility`): an unknown
  integrator, options the chosen integrator ignores, an explicit fixed step outside its
  method's stability region, a point certain to exhaust the step budget.
"""
from __future__ import annotations

import hashlib
import json
import math
import reprlib
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import tomllib
from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    NonNegativeFloat,
    PositiveFloat,
    Tag,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from .errors import MAX_LINE, MAX_PROBLEMS, SpecError  # noqa: F401  (re-exported)
from .version import __version__

SYSTEMS = ("slider", "contact")
FRICTIONS = ("coulomb", "stribeck", "lugre", "elastoplastic")
DITHERS = ("none", "square-velocity", "sine-velocity", "sine-force")
METHODS = ("simulate", "averaged", "hbm")
LEVELS = ("draft", "standard", "reference")
AXES = ("W", "omega", "v_ref", "v_d")
DEFAULT_MAX_POINTS = 250_000
COSMETIC = ("name", "description", "block_size")

MAX_AXIS_POINTS = 10_000_000      # num of one range, and values of one list axis
MAX_DEPTH = 16                    # nesting of tables and lists (a spec needs 3)
# a spec file: pure-Python tomllib reads ~1 MB of escapes per second, json 100x faster
MAX_FILE_BYTES = {"TOML": 1_000_000, "JSON": 10_000_000}
ECHO_CHARS = 80                   # an echoed value is cut to this many characters
MIN_RTOL = 1e-14                  # double precision holds no tighter relative error


_ECHO = reprlib.Repr()
_ECHO.maxstring, _ECHO.maxother, _ECHO.maxlong = ECHO_CHARS - 4, ECHO_CHARS - 4, 40
_ECHO.maxlist = _ECHO.maxtuple = _ECHO.maxdict = _ECHO.maxset = 6
_ECHO.maxlevel = 3


def show(value) -> str:
    """``value`` as a short plain-Python repr for a message: numpy scalars as Python
    numbers, strings and containers cut to about :data:`ECHO_CHARS` characters."""
    if hasattr(value, "dtype") and hasattr(value, "item") and getattr(value, "ndim", 1) == 0:
        value = value.item()          # np.float64(-100.0) -> -100.0
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 128:
        return f"an integer of {int(value.bit_length() * math.log10(2)) + 1} digits"
    try:
        text = _ECHO.repr(value)
    except Exception:  # noqa: BLE001 -- an odd object from the Python API
        text = f"<{type(value).__name__}>"
    return text if len(text) <= ECHO_CHARS else text[:ECHO_CHARS - 3] + "..."


class _Strict(BaseModel):
    # strict: no "100" for 100, no true for 1 (an int is still fine for a float);
    # allow_inf_nan=False: NaN and infinities are refused in every float field
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


class Range(_Strict):
    """An axis as ``num`` points from ``start`` to ``stop`` (inclusive)."""

    start: float
    stop: float
    num: Annotated[int, Field(gt=0, le=MAX_AXIS_POINTS)]
    scale: Literal["linear", "log"] = "linear"

    @model_validator(mode="after")
    def _log_positive(self):
        if self.scale == "log" and (self.start <= 0 or self.stop <= 0):
            raise ValueError(f"a log range needs start > 0 and stop > 0, got start={self.start!r}, "
                             f"stop={self.stop!r}")
        return self


def _dict_or_other(tag_for_dict: str, tag_for_other: str):
    """Discriminate a union by 'is it a table?', so a fault gives one message, not one
    per branch."""
    return Discriminator(lambda v: tag_for_dict if isinstance(v, (dict, BaseModel))
                         else tag_for_other)


Axis = Annotated[Annotated[list[float], Field(min_length=1, max_length=MAX_AXIS_POINTS), Tag("list")]
                 | Annotated[Range, Tag("range")], _dict_or_other("range", "list")]


class Grid(_Strict):
    """The four axes of every cube; an omitted axis has the single system default."""

    W: Axis | None = None
    omega: Axis | None = None
    v_ref: Axis | None = None
    v_d: Axis | None = None


class SlowForce(_Strict):
    amplitude: float = 0.0
    omega: NonNegativeFloat = 0.0


class Params(_Strict):
    """Physical parameters not swept; ``None`` means the system default (paper Sec. 5.1
    set for the slider, Fig. 1 SI set for the contact system)."""

    sigma0: PositiveFloat | None = None
    sigma1: NonNegativeFloat | None = None
    sigma2: NonNegativeFloat | None = None
    vs: PositiveFloat | None = None
    fc: PositiveFloat | None = None
    fs: PositiveFloat | None = None
    delta: PositiveFloat | None = None
    delta_d: PositiveFloat | None = None
    lam: Annotated[float, Field(gt=0.0, lt=1.0)] | None = None
    slow_force: SlowForce = SlowForce()
    long_stick: PositiveFloat | None = None
    stick_band: PositiveFloat | None = None
    slip_gap: Annotated[float, Field(gt=0.0, lt=0.1)] | None = None     # engine.observables
    alpha_near: Annotated[float, Field(gt=0.0, lt=1.0)] | None = None   # near_slip_fraction
    e0: float = 0.0
    v0: float = 0.0
    z0: float = 0.0


class TimeWindow(_Strict):
    t_end: PositiveFloat = 100.0
    t_transient: NonNegativeFloat = 20.0

    @model_validator(mode="after")
    def _transient_inside(self):
        if self.t_transient >= self.t_end:
            raise ValueError(f"t_transient must be < t_end, got t_transient={self.t_transient!r}, "
                             f"t_end={self.t_end!r}")
        return self


def integrator_names() -> tuple[str, ...]:
    """The integrators an explicit ``accuracy`` may name (``engine.integrators.METHODS``)."""
    from engine.integrators import METHODS as INTEGRATORS

    return tuple(sorted(INTEGRATORS))


def is_adaptive(integrator: str) -> bool:
    """True when the integrator controls its step by ``rtol`` / ``atol``."""
    from engine.integrators import METHODS as INTEGRATORS

    return bool(INTEGRATORS[integrator].ADAPTIVE)


class ExplicitAccuracy(_Strict):
    """Explicit numerics instead of a level: an integrator and its step policy.

    An adaptive method (``dopri5``, ``rodas4`` alias ``rosenbrock``) takes ``rtol``,
    ``atol`` and ``atol_units``; the fixed-step ``rk4`` takes ``steps_per_period`` (with
    dither) or ``step`` (without). An option the method would ignore is refused, and so is
    a fixed step outside the method's stability region (:mod:`sweeps.feasibility`).
    """

    integrator: str = "dopri5"
    rtol: Annotated[float, Field(ge=MIN_RTOL, lt=1.0)] | None = None
    atol: PositiveFloat | None = None
    # "natural": atol per state component times its natural scale (engine.settings.Settings)
    atol_units: Literal["absolute", "natural"] = "absolute"
    steps_per_period: Annotated[int, Field(ge=1, le=1_000_000)] | None = None
    step: PositiveFloat | None = None

    @field_validator("integrator")
    @classmethod
    def _known_integrator(cls, v: str) -> str:
        names = integrator_names()
        if v not in names:
            raise ValueError(f"unknown integrator {show(v)}; allowed: {', '.join(names)}")
        return v

    @field_validator("rtol", "atol", "atol_units", "steps_per_period", "step")
    @classmethod
    def _used_by_integrator(cls, v, info: ValidationInfo):
        method = info.data.get("integrator")
        if v is None or method is None:       # not given, or the integrator was refused
            return v
        name = info.field_name
        if is_adaptive(method) and name in ("steps_per_period", "step"):
            raise ValueError(f"{method!r} chooses its own steps and ignores {name}; drop it "
                             "(set rtol/atol), or use integrator = 'rk4'")
        if not is_adaptive(method) and name in ("rtol", "atol", "atol_units") and \
                not (name == "atol_units" and v == "absolute"):
            raise ValueError(f"{method!r} takes fixed steps and ignores {name}; drop it (set "
                             "steps_per_period, or step without dither), or use an adaptive "
                             "integrator such as 'dopri5'")
        return v


class Refine(_Strict):
    """Adaptive refinement of the map's class boundary (sweeps.refine): ``coarse`` is the
    stride of the first lattice (a power of two; default about 4 lattice steps per axis of a
    zone map, 8 of a stability chart: sweeps.refine.FIRST_STEPS)."""

    coarse: Annotated[int, Field(ge=1, le=1 << 20)] | None = None

    @field_validator("coarse")
    @classmethod
    def _power_of_two(cls, v):
        if v is not None and v & (v - 1):
            raise ValueError(f"must be a power of two (1, 2, 4, 8, ...), got {show(v)}")
        return v


class Spec(_Strict):
    name: Annotated[str, Field(max_length=200)] = "sweep"
    description: Annotated[str, Field(max_length=10_000)] = ""
    system: Literal["slider", "contact"] = "slider"
    friction: Literal["coulomb", "stribeck", "lugre", "elastoplastic"] = "lugre"
    dither: Literal["none", "square-velocity", "sine-velocity", "sine-force"] = "square-velocity"
    method: Literal["simulate", "averaged", "hbm"] = "simulate"
    outputs: Annotated[list[str], Field(max_length=100)] | None = None
    accuracy: Annotated[Annotated[Literal["draft", "standard", "reference"], Tag("level")] | Annotated[ExplicitAccuracy, Tag("explicit")],
                        _dict_or_other("explicit", "level")] = "standard"
    params: Params = Params()
    time: TimeWindow = TimeWindow()
    grid: Grid = Grid()
    block_size: Annotated[int, Field(ge=1, le=MAX_AXIS_POINTS)] | None = None
    refine: bool | Refine = False

    @field_validator("outputs")
    @classmethod
    def _outputs_unique(cls, v):
        if v is not None and len(set(v)) != len(v):
            raise ValueError(f"outputs must not repeat a name, got {show(v)}")
        return v

    def canonical(self) -> dict:
        """The result-changing content as plain data (no cosmetic fields).

        A field added later with a default that reproduces the old behaviour is left out
        at that default, so existing sweeps keep their ids (and resume): ``atol_units``.
        """
        data = self.model_dump(mode="json", exclude=set(COSMETIC))
        if data.get("refine") is False:
            del data["refine"]   # the exhaustive grid, as before the field existed
        acc = data.get("accuracy")
        if isinstance(acc, dict) and acc.get("atol_units") == "absolute":
            del acc["atol_units"]
        return data

    @property
    def sweep_id(self) -> str:
        """12 hex digits of sha256 over the canonical spec, the package version and the
        results fingerprint (sweeps.version: a hash of the engine sources and of the
        planning modules that pick levels and tolerances), so a cube made by another
        engine or another level table is never found as this spec's result."""
        from .version import results_fingerprint

        blob = json.dumps({"spec": self.canonical(), "engine": __version__,
                           "engine_fingerprint": results_fingerprint()},
                          sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(blob.encode()).hexdigest()[:12]

    def to_json(self) -> str:
        """Canonical JSON of the whole spec (cosmetic fields included), sorted keys."""
        return json.dumps(self.model_dump(mode="json"), sort_keys=True)


# --- loading -----------------------------------------------------------------------

_TAGS = ("list", "range", "level", "explicit")
_MESSAGES = {  # pydantic's wording -> ours, by error type
    "float_type": "must be a valid number", "int_type": "must be a valid integer",
    "string_type": "must be a string", "bool_type": "must be true or false",
    "finite_number": "must be a finite number (no NaN or infinity)",
    "model_type": "must be a table of keys", "dict_type": "must be a table of keys",
    "model_attributes_type": "must be a table of keys",
    "list_type": "must be a list", "int_from_float": "must be a valid integer",
}


def _loc(parts) -> str:
    """``grid.W.start`` from pydantic's loc, each part cut short (keys may be long)."""
    names = []
    for part in parts:
        if part in _TAGS:
            continue
        text = str(part)
        names.append(text if len(text) <= 40 else show(text))
    return ".".join(names)


def _format_error(err: dict) -> str:
    loc = _loc(err["loc"])
    value = err.get("input")
    kind = err["type"]
    msg = err["msg"].removeprefix("Value error, ").replace("Input should be", "must be")
    if kind == "too_short":
        return f"{loc}: needs at least one value, got {show(value)}"
    if kind == "extra_forbidden":
        return f"{loc}: unknown key (check the spelling; see README 'Spec reference')"
    if kind == "missing":
        return f"{loc}: missing (a range needs start, stop and num)" if ".grid." in f".{loc}" \
            else f"{loc}: missing"
    if kind == "literal_error":
        return f"{loc}: got {show(value)}; {msg.lower()}"
    if kind == "value_error":
        return f"{loc or 'spec'}: {msg}"
    parts = loc.split(".")
    if parts[0] == "grid" and (len(parts) == 2 or len(parts) == 3 and parts[2].isdigit()) \
            and kind in ("list_type", "float_type", "finite_number", "model_type"):
        what = "finite numbers" if kind == "finite_number" else "numbers"
        return (f"{loc}: an axis is a list of {what} or a range {{start, stop, num, scale}}, "
                f"got {show(value)}")
    if kind in _MESSAGES:
        return f"{loc or 'spec'}: {_MESSAGES[kind]}, got {show(value)}"
    return f"{loc or 'spec'}: {msg[:1].lower()}{msg[1:]}, got {show(value)}"


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
                stack.append((copy, k, f"{path}.{_loc([k])}" if path else _loc([k]), depth + 1))
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
    (:func:`_check_semantics`, :func:`sweeps.feasibility.check`). Warnings (a point that
    may exhaust its step budget) go through :mod:`warnings` as :class:`SpecWarning`.
    """
    import warnings

    from . import feasibility
    from .grid import axis_size

    if not isinstance(data, dict):
        raise SpecError([f"spec: expected a table of keys, got {type(data).__name__}"])
    data = _plain(data)
    try:
        spec = Spec.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors(include_url=False)
        raise SpecError([_format_error(e) for e in errors[:MAX_PROBLEMS]],
                        more=len(errors) - min(len(errors), MAX_PROBLEMS)) from None
    sizes = {axis: axis_size(spec, axis) for axis in AXES}
    n = math.prod(sizes.values())
    if n > max_points:
        shape = " x ".join(f"{a}={k}" for a, k in sizes.items())
        raise SpecError(_check_choices(spec) + [
            f"grid: {n} points ({shape}) is over the point budget of {max_points}; "
            f"coarsen an axis or split the sweep"])
    problems = _check_choices(spec) + _check_grid(spec)
    if not problems:
        found, notes = feasibility.check(spec)
        problems += found
        for note in notes:
            warnings.warn(note, SpecWarning, stacklevel=2)
    if problems:
        raise SpecError(problems)
    return spec


class SpecWarning(UserWarning):
    """A spec that is accepted but may not run as hoped (e.g. may exhaust its steps)."""


def _check_choices(spec: Spec) -> list[str]:
    """Faults in the combination of choices, without the grid's values."""
    from .grid import system_defaults
    from .outputs import allowed_outputs

    problems = []
    allowed = allowed_outputs(spec.method)
    for name in spec.outputs or ():
        if name not in allowed:
            problems.append(f"outputs: {show(name)} is not produced by method={spec.method!r}; "
                            f"allowed: {', '.join(allowed)}")
    if spec.method == "hbm" and spec.system != "contact":
        problems.append("method: 'hbm' solves the Sec. 3 contact model; set system = 'contact'")
    if spec.system == "contact" and spec.method == "averaged":
        problems.append("method: 'averaged' applies to the slider system; use 'simulate' or "
                        "'hbm' for system = 'contact'")
    if spec.system == "contact" and spec.dither == "sine-force":
        problems.append("dither: 'sine-force' needs a mass; the contact system (no inertia) "
                        "takes 'sine-velocity', 'square-velocity' or 'none'")
    if spec.refine is not False:
        problems += _check_refine(spec)
    if spec.method == "averaged" and spec.grid.omega is not None:
        problems.append("grid.omega: the averaged theory is the limit omega -> infinity and "
                        "has no dither frequency; drop grid.omega (the cube's omega is inf) or "
                        "use method = 'simulate'")
    theory = {"averaged": ("coulomb", "stribeck", "lugre"), "hbm": ("lugre",)}
    if spec.method in theory and spec.friction not in theory[spec.method]:
        problems.append(f"friction: method={spec.method!r} has no theory for {spec.friction!r} "
                        f"(it covers {', '.join(theory[spec.method])}); use method = 'simulate'")
    defaults = system_defaults(spec.system)
    fc = spec.params.fc if spec.params.fc is not None else defaults["fc"]
    fs = spec.params.fs if spec.params.fs is not None else defaults["fs"]
    if fs < fc:
        problems.append(f"params: fs must be >= fc (static level above Coulomb level), got "
                        f"fs={fs!r}, fc={fc!r}" + ("" if spec.params.fs is not None and
                                                    spec.params.fc is not None
                                                    else " (one of them the default)"))
    return problems


def _check_refine(spec: Spec) -> list[str]:
    """Refinement needs a class to refine on (sweeps.refine.CLASS_OUTPUT)."""
    from .outputs import resolve_outputs
    from .refine import CLASS_OUTPUT, PLANES

    if spec.method not in CLASS_OUTPUT:
        return [f"refine: the {spec.method} path draws no zone map or stability chart; "
                "drop refine"]
    need = CLASS_OUTPUT[spec.method]
    if need not in resolve_outputs(spec.method, spec.outputs):
        return [f"refine: refining the {spec.method} map needs the output {need!r} (its "
                f"classes); add it to outputs"]
    a, b = PLANES[spec.method]
    return [] if getattr(spec.grid, a) is not None or getattr(spec.grid, b) is not None \
        else [f"refine: sweep {a} or {b} (the map's plane) to refine"]


def _check_grid(spec: Spec) -> list[str]:
    """Faults in the axis values (built here: the size was checked before)."""
    from .grid import axis_values

    problems = []
    for axis in AXES:
        raw = getattr(spec.grid, axis)
        if raw is None:
            continue   # a default value (the averaged path's omega is inf by design)
        values = axis_values(spec, axis)
        bad = values[~np.isfinite(values)]
        if bad.size:
            why = " (the range's span overflows)" if isinstance(raw, Range) else ""
            problems.append(f"grid.{axis}: values must be finite, got {show(bad[0])}{why}")
            continue
        low = float(values.min())
        if axis == "v_d" and low <= 0:
            problems.append(f"grid.{axis}: must be > 0, got {show(low)}")
        elif axis == "W" and low < 0:
            problems.append(f"grid.W: dither amplitude must be >= 0, got {show(low)}")
        elif axis == "omega" and spec.dither != "none" and low <= 0:
            problems.append(f"grid.omega: dither frequency must be > 0, got {show(low)}")
        repeated = _repeated(values)
        if repeated is not None:
            how = ("the range gives it more than once (start == stop, or more points than "
                   "floats between them)" if isinstance(raw, Range) else "list it once")
            problems.append(f"grid.{axis}: repeats the value {show(repeated)}; a cube axis "
                            f"needs distinct values ({how})")
    return problems


def _repeated(values: np.ndarray) -> float | None:
    """A value that occurs more than once in ``values``, or None."""
    if values.size < 2:
        return None
    ordered = np.sort(values)
    same = np.flatnonzero(ordered[1:] == ordered[:-1])
    return float(ordered[same[0]]) if same.size else None


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
