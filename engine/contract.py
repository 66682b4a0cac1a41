"""The model contract: what a friction law and a mechanical system are to the engine.

docs/MODELS.md states it as numbered rules, with a worked example; this module is the code
those rules name. A model is a plain Python object (a class instance) that declares its
parameters and states and, given a :class:`Build` context, returns numba-compilable
functions. The engine's own laws (LuGre, elasto-plastic, Stribeck, Coulomb, Dahl, GMS) and
systems (slider, contact, servo) are written against it, and so is a model a user brings by
import path (``friction = "mylab.laws:GMS"``).

Everything a model compiles is built inside its ``build(b)`` with the decorator ``b.jit``
(the engine's cached ``njit`` on the CPU), closing over compile-time constants: the parameter
indices ``b.ix[name]``, the state offsets ``b.z0`` / ``b.m0``, the scene's effect flags
(``b.scene``). A term the spec does not call for is a Python ``if`` at build time and is
never compiled in.

The state vector ``y`` of a point is laid out as

    [ system states | law states | F quadrature | system tail states | law modes ]
      0 ..            b.z0 ..      b.qf (or -1)   b.tail0 ..           b.m0 ..

the leading ``n_err`` components under error control (:meth:`MechanicalSystem.error_size`);
modes are discrete (stick/slip of an element), stored as floats, with zero rate, changed
only by the law's ``update_modes``: after an accepted step, where a square-wave dither
switches (u jumps there, ``landed = -1``), and at a step's start for a switch too close
after it to land on (engine.integrators.adaptive).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple


class ModelError(ValueError):
    """A model (built in or brought by a user) that cannot be used: one line, no traceback."""


@dataclass(frozen=True)
class Param:
    """One parameter a model declares beyond the shared set of :mod:`engine.params`.

    ``default`` a float (or, with ``vector=True``, a tuple of floats; None: required);
    ``lo`` / ``hi`` the allowed closed range (``lo_open`` / ``hi_open`` exclude the end);
    ``unit`` a UDUNITS string or "1"; ``doc`` one line. A vector parameter's length may set
    the number of states (GMS: one element per entry of ``k``).
    """

    default: Any = None
    unit: str = "1"
    doc: str = ""
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    vector: bool = False
    max_len: int = 64

    def check(self, name: str, value) -> list[float]:
        """The value as a list of floats, or ModelError naming what is allowed."""
        if self.vector and not isinstance(value, (list, tuple)):
            raise ModelError(f"{name}: expected a list of numbers, got {value!r}")
        values = list(value) if self.vector else [value]
        if self.vector and not 1 <= len(values) <= self.max_len:
            raise ModelError(f"{name}: expected 1 to {self.max_len} values, got {len(values)}")
        out = []
        for v in values:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ModelError(f"{name}: expected a number, got {v!r}")
            v = float(v)
            low = v <= self.lo if self.lo_open else v < self.lo
            high = v >= self.hi if self.hi_open else v > self.hi
            if not math.isfinite(v) or low or high:
                raise ModelError(f"{name}: {v!r} is outside the allowed range {self.range_text()}")
            out.append(v)
        return out

    def range_text(self) -> str:
        lo = "(" if self.lo_open else "["
        hi = ")" if self.hi_open else "]"
        return f"{lo}{self.lo:g}, {self.hi:g}{hi}"


class LawKernels(NamedTuple):
    """What a friction law's ``build(b)`` returns (njit functions; see FrictionLaw)."""

    rates: Callable          # rates(u, y, dy, hold, p) -> F: writes dy[z0 : z0 + n_states]
    force: Callable          # force(u, y, hold, p) -> (F, alpha): no rates written
    n_switches: int          # number of switching functions (0: none)
    switches: Callable | None  # switches(u, y, hold, p, g): g[:n_switches]
    init: Callable           # init(p, y): the law's states (and modes) at t = 0
    scales: Callable         # scales(p, out): natural scale of each law state, out[z0 + i]
    update_modes: Callable | None = None  # update_modes(u, y, hold, p, landed) -> changed


class SystemKernels(NamedTuple):
    """What a system's ``build(b)`` returns (njit functions; see MechanicalSystem)."""

    drive: Callable          # drive(t, y, p, sq) -> (u, fext, hold)
    dynamics: Callable       # dynamics(t, y, p, sq, u, fext, F, dy): the system's own rates
    position: Callable       # position(t, y, p): displacement (its rate is the body velocity)
    velocity: Callable       # velocity(t, y, p, sq): the body velocity
    init: Callable           # init(p, y): the system's states (y is zeroed before)
    scales: Callable         # scales(p, out): natural scales of the system's states
    outputs: Any = None      # SystemOutputs or None


class SystemOutputs(NamedTuple):
    """Observables a system adds (names, accumulator slots and njit hooks on its slots)."""

    names: tuple             # output names, in the order finish writes them
    size: int                # accumulator slots (o = obs[base : base + size])
    start: Callable          # start(t, y, p, sq, o)
    observe: Callable        # observe(t0, y0, t1, y1, ymid, p, sq, o)
    finish: Callable         # finish(t, y, p, o, out, span): out[:len(names)]; span = the
    #                          window's length
    stop: Callable | None = None   # stop(t, y, p, is_period, o): at the driver's stops
    period_stops: bool = False     # the driver must stop on dither period boundaries


@dataclass
class Build:
    """The compile-time context a model builds its kernels in.

    ``jit`` the decorator to compile with; ``scene`` the Scene (effect flags, dither,
    outputs); ``ix`` parameter name -> index into ``p`` (shared names and the models' own);
    ``size`` vector parameter -> length; ``z0`` first law state, ``n_law`` law states,
    ``m0`` first mode slot, ``qf`` the F quadrature (-1: none), ``tail0`` the system's
    tail states, ``n_err`` the components under error control; ``values`` the models' own parameter values (for sizes, never numbers
    compiled in: those are read from ``p`` at run time).
    """

    jit: Callable
    scene: Any
    ix: dict
    size: dict
    z0: int = 0
    n_law: int = 0
    m0: int = 0
    qf: int = -1
    tail0: int = 0
    n_err: int = 0
    values: dict = field(default_factory=dict)


class FrictionLaw:
    """Base of a friction law (docs/MODELS.md, rules 1-9). Override what differs.

    ``name`` what specs and cubes call it; ``params`` its own parameters (Param), given in a
    spec's ``[params]`` flat, or as the table ``[params] <group> = {...}`` when ``group`` is
    set; ``phases`` how its phase observables are read (``"band"``: stick is
    ``|u| < stick_band``, located inside a step; ``"alpha"``: the alpha returned by ``force``
    at a step's midpoint holds for the step; ``"elasto"``: the elasto-plastic bookkeeping,
    built-in only); ``switch_jumps``: its switches mark jumps of the right-hand side, or
    corners where an error control that sees neither end of a dip would step over them (the
    integrators then also probe for grazing crossings, and under a sine dither cap a step
    at a quarter of its period: GMS, Dahl, the static laws).
    """

    name: str = ""
    group: str | None = None
    params: dict = {}
    phases: str = "band"
    switch_jumps: bool = False
    averaged: str | None = None   # built-in averaged model ("lugre", "static"), else None

    def n_states(self, size: dict) -> int:
        return 1

    def n_modes(self, size: dict) -> int:
        return 0

    def check(self, values: dict) -> None:
        """Optional: ModelError when the parameter values (name -> list of floats) do not go
        together (the ranges of each are checked before)."""

    def build(self, b: Build) -> LawKernels:
        raise NotImplementedError

    def build_steady(self, b: Build) -> Callable | None:
        """Optional: njit ``steady(u, p) -> F``, the steady-state friction at constant
        sliding velocity ``u``; the averaged path needs it. None: no averaged model."""
        return None

    def effects(self, scene) -> dict:
        """The effects the plan lists for this law (name -> on)."""
        return {}

    def relaxation_factor(self, values: dict) -> float:
        """Optional: how many times faster than ``sigma0 |u| / fc`` (LuGre's bristle, Eq. 2.3
        linearised) the law's states relax at most, for its own parameter ``values`` (name ->
        list of floats, checked). The planner's test of a fixed step's stability reads it
        (sweeps.spec.fixed_step: RK4 at draft under a square wave, explicit ``rk4``)."""
        return 1.0


class MechanicalSystem:
    """Base of a mechanical system (docs/MODELS.md, rules 10-15)."""

    name: str = ""
    group: str | None = None
    params: dict = {}
    state_names: tuple = ()
    dithers: tuple = ("none", "square-velocity", "sine-velocity", "sine-force")
    outputs: dict = {}            # own observables: name -> (long_name, units)
    defaults: dict | None = None  # the shared parameters' defaults (engine.params)
    # the accuracy levels' atol in each state's natural scale (Settings.atol_units =
    # "natural"), for a system in units where the states are far from 1 (the contact, in SI:
    # z ~ fc / sigma0 = 1e-5 m); else absolute, calibrated on the paper's slider
    natural_atol: bool = False

    def n_states(self, scene) -> int:
        return len(self.state_names)

    def n_tail(self, scene) -> int:
        return 0

    def error_size(self, scene, law, n_law: int, n_total: int) -> int:
        """Leading components under error control (default: own states and the law's)."""
        return self.n_states(scene) + n_law

    def build(self, b: Build) -> SystemKernels:
        raise NotImplementedError
