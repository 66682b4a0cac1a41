"""The sweep spec as pydantic models: :class:`Spec` and its tables (grid axes, physical
parameters, time window, explicit accuracy, refinement), the names each choice allows, and
the spec's canonical form and hash, the sweep id (DESIGN.md §3).

Types are strict (no ``"100"`` for 100, no ``true`` for 1; an int is fine where a float is
expected) and NaN and infinities are refused everywhere. Loading a spec and wording its
faults is :mod:`sweeps.spec`; checks that need the grid's values or the engine are
:mod:`sweeps.spec.checks` and :mod:`sweeps.spec.feasibility`.
"""
from __future__ import annotations

import hashlib
import json
from functools import cached_property
from typing import Annotated, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    NonNegativeFloat,
    PositiveFloat,
    Tag,
    ValidationInfo,
    field_validator,
    model_validator,
)

from . import model_params
from .messages import show
from engine.registry import LAW_NAMES, SYSTEM_NAMES

from ..version import __version__

SYSTEMS = SYSTEM_NAMES       # built in; a spec may also name a model by import path
FRICTIONS = LAW_NAMES
DITHERS = ("none", "square-velocity", "sine-velocity", "sine-force")
METHODS = ("simulate", "averaged", "hbm")
LEVELS = ("draft", "standard", "reference")
COSMETIC = ("name", "description", "block_size")

MAX_AXIS_POINTS = 10_000_000      # num of one range, and values of one list axis
MIN_RTOL = 1e-14                  # double precision holds no tighter relative error


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
    """The four axes of every cube (``grid.AXES``); an omitted axis has the single system
    default."""

    W: Axis | None = None
    omega: Axis | None = None
    v_ref: Axis | None = None
    v_d: Axis | None = None


class SlowForce(_Strict):
    amplitude: float = 0.0
    omega: NonNegativeFloat = 0.0


class Params(_Strict):
    """Physical parameters not swept; ``None`` means the system default (paper Sec. 5.1
    set for the slider, Fig. 1 SI set for the contact system).

    A friction law's or system's own parameters (engine.contract: Dahl's ``dahl_alpha``,
    the GMS table ``gms = { k = [...], alpha = [...], C = ... }``, ``servo = { ... }``) are
    further keys, checked against the models the spec names (:meth:`Spec._models`)."""

    model_config = ConfigDict(extra="allow", frozen=True, strict=True, allow_inf_nan=False)

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

    An adaptive method (``dopri5``, ``rodas4`` alias ``rosenbrock``) takes ``rtol``, ``atol``
    and ``atol_units`` ("natural": per state, times its scale; not given: the system's own,
    natural on the SI contact); ``rk4`` takes ``steps_per_period`` (with dither) or ``step``
    (without). An option the method would ignore is refused, and so is a fixed step outside
    the method's stability region (:mod:`sweeps.spec.feasibility`)."""

    integrator: str = "dopri5"
    rtol: Annotated[float, Field(ge=MIN_RTOL, lt=1.0)] | None = None
    atol: PositiveFloat | None = None
    atol_units: Literal["absolute", "natural"] | None = None   # None: model_params.atol_units
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
    """Adaptive refinement of the map's class boundary (sweeps.planning.refine): ``coarse`` is the
    stride of the first lattice (a power of two; default about 4 lattice steps per axis of a
    zone map, 8 of a stability chart: sweeps.planning.refine.FIRST_STEPS)."""

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
    # a built-in name (engine.registry) or an import path 'module:Name' / 'file.py:Name'
    system: Annotated[str, Field(min_length=1, max_length=500)] = "slider"
    friction: Annotated[str, Field(min_length=1, max_length=500)] = "lugre"
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
    device: Literal["cpu", "cuda"] = "cpu"   # cuda: the points on a GPU (engine.gpu)

    @field_validator("system", "friction")
    @classmethod
    def _known_model(cls, v, info: ValidationInfo):   # ModelError (a ValueError): one line
        return model_params.resolved(info.field_name, v)

    @property
    def model_values(self) -> dict:
        """The models' own parameters from ``[params]`` (sweeps.spec.model_params)."""
        return model_params.values(self)

    @property
    def brought_models(self) -> dict:
        """Import path -> source digest of each model the spec brings (model_params)."""
        return model_params.brought(self)

    @property
    def model_sizes(self) -> tuple:
        """``engine.Scene.sizes``: the lengths of the models' vector parameters."""
        return model_params.sizes(self)

    @field_validator("name")
    @classmethod
    def _name_one_line(cls, v):   # a name is typed on command lines, one catalogue line
        if any(ord(c) < 32 or ord(c) == 127 for c in v):
            raise ValueError(f"name must be one line of printable characters, got {show(v)}")
        return v

    @field_validator("outputs")
    @classmethod
    def _outputs_unique(cls, v):
        if v is not None and len(set(v)) != len(v):
            raise ValueError(f"outputs must not repeat a name, got {show(v)}")
        return v

    def canonical(self) -> dict:
        """The result-changing content as plain data (no cosmetic fields). A field added
        later with a default that reproduces the old behaviour is left out at that default,
        so existing sweeps keep their ids (and resume): ``refine`` (the exhaustive grid),
        ``device`` (the CPU; a GPU sweep is another sweep), ``atol_units`` (not given, or
        the system's own: the same numbers)."""
        data = self.model_dump(mode="json", exclude=set(COSMETIC))
        for key in [k for k, old in (("refine", False), ("device", "cpu")) if data[k] == old]:
            del data[key]
        acc, own = data.get("accuracy"), model_params.atol_units(self)
        if isinstance(acc, dict) and acc.get("atol_units") in (None, own):
            del acc["atol_units"]
        return data

    @property
    def sweep_id(self) -> str:
        """12 hex digits of sha256 over the canonical spec, the package version and the
        results fingerprint (sweeps.version: a hash of the engine sources and of the
        planning modules that pick levels and tolerances) and, for a model brought by import
        path, its module's source, so a cube made by another engine, another level table or
        another version of the user's model is never found as this spec's result."""
        from ..version import results_fingerprint

        content = {"spec": self.canonical(), "engine": __version__,
                   "engine_fingerprint": results_fingerprint()}
        if brought := self.brought_models:   # a user's model: its source is code too
            content["models"] = brought
        blob = json.dumps(content, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(blob.encode()).hexdigest()[:12]

    @cached_property
    def grid_facts(self):
        """The grid resolved once (:class:`sweeps.spec.grid.GridFacts`: coordinates, extremes,
        the dither in effect), built on first use: only after the point budget is checked
        (sweeps.spec.load). ``model_copy(update=...)`` would carry it over unchanged."""
        from .grid import GridFacts

        return GridFacts.of(self)

    def to_json(self) -> str:
        """Canonical JSON of the whole spec (cosmetic fields included), sorted keys."""
        return json.dumps(self.model_dump(mode="json"), sort_keys=True)
