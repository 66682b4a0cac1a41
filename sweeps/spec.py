"""Sweep specification: parse, validate, canonicalise, hash (DESIGN.md §3).

A spec arrives as TOML, JSON or a dict and is validated by pydantic before anything
runs; every fault becomes one line naming the field, the value received and what is
allowed (:class:`SpecError`). The sweep id is a hash of what changes results
(physics, grid, time window, accuracy, engine version) and never of cosmetic fields
(``name``, ``description``, ``block_size``).
"""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Annotated, Literal

import tomllib
from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    NonNegativeFloat,
    PositiveFloat,
    PositiveInt,
    Tag,
    ValidationError,
    field_validator,
    model_validator,
)

from .version import __version__

SYSTEMS = ("slider", "contact")
FRICTIONS = ("coulomb", "stribeck", "lugre", "elastoplastic")
DITHERS = ("none", "square-velocity", "sine-velocity", "sine-force")
METHODS = ("simulate", "averaged", "hbm")
LEVELS = ("draft", "standard", "reference")
AXES = ("W", "omega", "v_ref", "v_d")
DEFAULT_MAX_POINTS = 250_000
COSMETIC = ("name", "description", "block_size")


class SpecError(ValueError):
    """A refused spec; ``problems`` holds one message per fault."""

    def __init__(self, problems: list[str]):
        self.problems = problems
        super().__init__("invalid sweep spec:\n" + "\n".join(f"  - {p}" for p in problems))


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Range(_Strict):
    """An axis as ``num`` points from ``start`` to ``stop`` (inclusive)."""

    start: float
    stop: float
    num: PositiveInt
    scale: Literal["linear", "log"] = "linear"

    @model_validator(mode="after")
    def _log_positive(self):
        if self.scale == "log" and (self.start <= 0 or self.stop <= 0):
            raise ValueError(f"a log range needs start > 0 and stop > 0, got start={self.start}, "
                             f"stop={self.stop}")
        return self


def _dict_or_other(tag_for_dict: str, tag_for_other: str):
    """Discriminate a union by 'is it a table?', so a fault gives one message, not one
    per branch."""
    return Discriminator(lambda v: tag_for_dict if isinstance(v, (dict, BaseModel))
                         else tag_for_other)


Axis = Annotated[Annotated[list[float], Field(min_length=1), Tag("list")] | Annotated[Range, Tag("range")],
                 _dict_or_other("range", "list")]


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

    @model_validator(mode="after")
    def _fs_ge_fc(self):
        if self.fs is not None and self.fc is not None and self.fs < self.fc:
            raise ValueError(f"fs must be >= fc (static level above Coulomb level), got "
                             f"fs={self.fs}, fc={self.fc}")
        return self


class TimeWindow(_Strict):
    t_end: PositiveFloat = 100.0
    t_transient: NonNegativeFloat = 20.0

    @model_validator(mode="after")
    def _transient_inside(self):
        if self.t_transient >= self.t_end:
            raise ValueError(f"t_transient must be < t_end, got t_transient={self.t_transient}, "
                             f"t_end={self.t_end}")
        return self


class ExplicitAccuracy(_Strict):
    """Explicit numerics instead of a level: an integrator and its step policy."""

    integrator: str = "dopri5"
    rtol: PositiveFloat | None = None
    atol: PositiveFloat | None = None
    # "natural": atol per state component times its natural scale (engine.settings.Settings)
    atol_units: Literal["absolute", "natural"] = "absolute"
    steps_per_period: PositiveInt | None = None
    step: PositiveFloat | None = None


class Spec(_Strict):
    name: str = "sweep"
    description: str = ""
    system: Literal["slider", "contact"] = "slider"
    friction: Literal["coulomb", "stribeck", "lugre", "elastoplastic"] = "lugre"
    dither: Literal["none", "square-velocity", "sine-velocity", "sine-force"] = "square-velocity"
    method: Literal["simulate", "averaged", "hbm"] = "simulate"
    outputs: list[str] | None = None
    accuracy: Annotated[Annotated[Literal["draft", "standard", "reference"], Tag("level")] | Annotated[ExplicitAccuracy, Tag("explicit")],
                        _dict_or_other("explicit", "level")] = "standard"
    params: Params = Params()
    time: TimeWindow = TimeWindow()
    grid: Grid = Grid()
    block_size: PositiveInt | None = None

    @field_validator("outputs")
    @classmethod
    def _outputs_unique(cls, v):
        if v is not None and len(set(v)) != len(v):
            raise ValueError(f"outputs must not repeat a name, got {v}")
        return v

    def canonical(self) -> dict:
        """The result-changing content as plain data (no cosmetic fields).

        A field added later with a default that reproduces the old behaviour is left out
        at that default, so existing sweeps keep their ids (and resume): ``atol_units``.
        """
        data = self.model_dump(mode="json", exclude=set(COSMETIC))
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


def _format_error(err: dict) -> str:
    loc = ".".join(str(part) for part in err["loc"] if part not in _TAGS)
    value = err.get("input")
    msg = err["msg"].removeprefix("Value error, ").replace("Input should be", "must be")
    if err["type"] == "too_short":
        return f"{loc}: needs at least one value, got {value!r}"
    if err["type"] == "extra_forbidden":
        return f"{loc}: unknown key (check the spelling; see README 'Spec reference')"
    if err["type"] == "literal_error":
        return f"{loc}: got {value!r}; {msg.lower()}"
    if err["type"] == "value_error":
        return f"{loc or 'spec'}: {msg}"
    if loc.startswith("grid.") and err["type"] in ("list_type", "float_parsing", "float_type"):
        return (f"{loc}: an axis is a list of numbers or a range {{start, stop, num, scale}}, "
                f"got {value!r}")
    return f"{loc or 'spec'}: {msg[:1].lower()}{msg[1:]}, got {value!r}"


def parse_spec(data: dict, *, max_points: int = DEFAULT_MAX_POINTS) -> Spec:
    """Validate a spec given as a dict; raise :class:`SpecError` listing every fault."""
    from .grid import axis_values  # local: grid imports spec types

    if not isinstance(data, dict):
        raise SpecError([f"spec: expected a table of keys, got {type(data).__name__}"])
    try:
        spec = Spec.model_validate(data)
    except ValidationError as exc:
        raise SpecError([_format_error(e) for e in exc.errors()]) from None
    problems = _check_semantics(spec)
    sizes = {axis: len(axis_values(spec, axis)) for axis in AXES}
    n = math.prod(sizes.values())
    if n > max_points:
        shape = " x ".join(f"{a}={k}" for a, k in sizes.items())
        problems.append(f"grid: {n} points ({shape}) is over the point budget of {max_points}; "
                        f"coarsen an axis or split the sweep")
    if problems:
        raise SpecError(problems)
    return spec


def _check_semantics(spec: Spec) -> list[str]:
    from .grid import axis_values
    from .outputs import allowed_outputs

    problems = []
    allowed = allowed_outputs(spec.method)
    for name in spec.outputs or ():
        if name not in allowed:
            problems.append(f"outputs: {name!r} is not produced by method={spec.method!r}; "
                            f"allowed: {', '.join(allowed)}")
    for axis in AXES:
        values = axis_values(spec, axis)
        bad = [x for x in values if not math.isfinite(x)]
        if bad:
            problems.append(f"grid.{axis}: values must be finite, got {bad[0]!r}")
        elif axis in ("v_d",) and min(values) <= 0:
            problems.append(f"grid.{axis}: must be > 0, got {min(values)!r}")
        elif axis == "W" and min(values) < 0:
            problems.append(f"grid.W: dither amplitude must be >= 0, got {min(values)!r}")
        elif axis == "omega" and spec.dither != "none" and min(values) <= 0:
            problems.append(f"grid.omega: dither frequency must be > 0, got {min(values)!r}")
    if spec.method == "hbm" and spec.system != "contact":
        problems.append("method: 'hbm' solves the Sec. 3 contact model; set system = 'contact'")
    if spec.system == "contact" and spec.method == "averaged":
        problems.append("method: 'averaged' applies to the slider system; use 'simulate' or "
                        "'hbm' for system = 'contact'")
    theory = {"averaged": ("coulomb", "stribeck", "lugre"), "hbm": ("lugre",)}
    if spec.method in theory and spec.friction not in theory[spec.method]:
        problems.append(f"friction: method={spec.method!r} has no theory for {spec.friction!r} "
                        f"(it covers {', '.join(theory[spec.method])}); use method = 'simulate'")
    return problems


def load_spec(source: str | Path | dict, *, max_points: int = DEFAULT_MAX_POINTS) -> Spec:
    """Load a spec from a ``.toml`` / ``.json`` file path or a dict."""
    if isinstance(source, dict):
        return parse_spec(source, max_points=max_points)
    path = Path(source)
    try:
        text = path.read_text()
    except OSError as exc:
        raise SpecError([f"{path}: cannot read the spec file ({exc.strerror})"]) from None
    try:
        data = json.loads(text) if path.suffix == ".json" else tomllib.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        kind = "JSON" if path.suffix == ".json" else "TOML"
        raise SpecError([f"{path}: malformed {kind}: {exc}"]) from None
    return parse_spec(data, max_points=max_points)
