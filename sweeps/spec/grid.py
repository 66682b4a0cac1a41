"""Grid axes: expansion of lists and ranges, defaults, the spec's parameter vector, and
the grid's facts, resolved once per spec (:class:`GridFacts`, ``Spec.grid_facts``).

Points are enumerated in C order over ``AXES = (W, omega, v_ref, v_d)``, the order of
the cube's dimensions, so a point's flat index is its position in the cube.

:func:`axis_size` reads a size from the spec's fields without building any axis, so the
point budget is checked in O(1) memory whatever ``num`` is (sweeps.spec.load); axes are
built only after that check, once (``spec.grid_facts``), and the plan carries them.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from engine import params as P
from store.cube import AXES as CUBE_AXES

if TYPE_CHECKING:   # the models reach their grid's facts here (Spec.grid_facts), not back
    from .models import Spec

# The four axes of every cube in its dimension order, and the engine parameter each one
# sets: the one table of their two spellings (the cube and the spec say v_d, the parameter
# vector vd), joined from the cube's axes (store.cube.AXES) and the columns of the engine's
# points (engine.params.POINT_AXES). The spec's Grid has a field for each.
AXIS_PARAM = dict(zip(CUBE_AXES, P.POINT_AXES))
AXES = tuple(AXIS_PARAM)


def system_defaults(system: str) -> dict:
    """The shared parameters' defaults of a system (engine.contract.MechanicalSystem)."""
    from engine import registry

    return registry.system(system).defaults or P.PAPER_DEFAULTS


def base_params(spec: Spec) -> np.ndarray:
    """The parameter vector of the spec's non-swept values (system defaults elsewhere),
    followed by the models' own parameters (engine.registry.pack)."""
    from engine import registry

    values = {name: value for name, value in spec.params.model_dump().items()
              if name in P.INDEX and value is not None}
    values["slow_a"] = spec.params.slow_force.amplitude
    values["slow_omega"] = spec.params.slow_force.omega
    values["t_end"] = spec.time.t_end
    values["t_transient"] = spec.time.t_transient
    return registry.pack(spec.friction, spec.system, spec.model_values,
                         system_defaults(spec.system), **values)


def default_axis(spec: Spec, axis: str) -> list[float]:
    """The single value of an axis the spec does not sweep."""
    if axis == "omega" and spec.dither == "none":
        return [0.0]
    if axis == "omega" and spec.method == "averaged":
        return [np.inf]   # the averaged theory is the limit omega -> infinity (no omega value)
    if axis == "omega":
        return [1000.0]
    return [system_defaults(spec.system)[AXIS_PARAM[axis]]]


def axis_size(spec: Spec, axis: str) -> int:
    """The number of values of one axis, from the spec's fields (nothing is built)."""
    raw = getattr(spec.grid, axis)
    if raw is None:
        return 1
    if isinstance(raw, (list, tuple)):   # a list of values, else a Range
        return len(raw)
    return raw.num


def axis_values(spec: Spec, axis: str) -> np.ndarray:
    """The coordinate values of one axis, float64."""
    raw = getattr(spec.grid, axis)
    if raw is None:
        return np.asarray(default_axis(spec, axis), dtype=float)
    if isinstance(raw, (list, tuple)):   # a list of values, else a Range
        return np.asarray(raw, dtype=float)
    if raw.scale == "log":
        return np.geomspace(raw.start, raw.stop, raw.num)
    return np.linspace(raw.start, raw.stop, raw.num)


@dataclass(frozen=True)
class GridFacts:
    """What the grid of a spec is, worked out once (``Spec.grid_facts``) and carried on the
    plan: the coordinates of each axis, the points, the extremes the spec-time checks need,
    and the dither in effect."""

    coords: dict[str, np.ndarray]   # axis -> values (float64), in AXES order
    dither: str                     # "none" when the spec has none or W = 0 everywhere

    @classmethod
    def of(cls, spec: Spec) -> GridFacts:
        coords = {axis: axis_values(spec, axis) for axis in AXES}
        W = coords["W"]
        # no dither anywhere: no switches to step onto, no dither term, no dither to resolve
        dither = spec.dither if spec.dither != "none" and W.any() else "none"
        return cls(coords, dither)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self.coords.values())

    @cached_property
    def points(self) -> np.ndarray:
        """All grid points, ``(n, 4)`` with columns (W, omega, v_ref, v_d), C order."""
        mesh = np.meshgrid(*self.coords.values(), indexing="ij")
        return np.stack([m.ravel() for m in mesh], axis=1)

    @property
    def W_max(self) -> float:
        return float(np.abs(self.coords["W"]).max())

    @property
    def v_max(self) -> float:
        return float(np.abs(self.coords["v_ref"]).max())

    @property
    def omega_min(self) -> float:
        return float(self.coords["omega"].min())

    @property
    def omega_max(self) -> float:
        return float(self.coords["omega"].max())

    def largest_step(self, steps_per_period: int, h: float) -> float:
        """The largest fixed step over the grid (at the smallest omega), as the engine's
        driver sets it (:func:`engine.dither.fixed_step`)."""
        from engine.dither import CODE, fixed_step

        return float(fixed_step(CODE[self.dither], self.omega_min, steps_per_period, h))
