"""Grid axes: expansion of lists and ranges, defaults, and point enumeration.

Points are enumerated in C order over ``AXES = (W, omega, v_ref, v_d)``, the order of
the cube's dimensions, so a point's flat index is its position in the cube.

:func:`axis_size` and :func:`shape` read the sizes from the spec's fields without
building any axis, so the point budget is checked in O(1) memory whatever ``num`` is
(sweeps.spec.parse_spec); axes are built only after that check.
"""
from __future__ import annotations

import numpy as np

from engine import params as P

from .models import AXES, Range, Spec

# the engine parameter each cube axis overrides
AXIS_PARAM = {"W": "W", "omega": "omega", "v_ref": "v_ref", "v_d": "vd"}


def system_defaults(system: str) -> dict:
    return P.CONTACT_DEFAULTS if system == "contact" else P.PAPER_DEFAULTS


def base_params(spec: Spec) -> np.ndarray:
    """The parameter vector of the spec's non-swept values (system defaults elsewhere)."""
    values = {name: value for name, value in spec.params.model_dump().items()
              if name != "slow_force" and value is not None}
    values["slow_a"] = spec.params.slow_force.amplitude
    values["slow_omega"] = spec.params.slow_force.omega
    values["t_end"] = spec.time.t_end
    values["t_transient"] = spec.time.t_transient
    return P.pack(system_defaults(spec.system), **values)


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
    if isinstance(raw, Range):
        return raw.num
    return len(raw)


def axis_values(spec: Spec, axis: str) -> np.ndarray:
    """The coordinate values of one axis, float64."""
    raw = getattr(spec.grid, axis)
    if raw is None:
        return np.asarray(default_axis(spec, axis), dtype=float)
    if isinstance(raw, Range):
        if raw.scale == "log":
            return np.geomspace(raw.start, raw.stop, raw.num)
        return np.linspace(raw.start, raw.stop, raw.num)
    return np.asarray(raw, dtype=float)


def coords(spec: Spec) -> dict[str, np.ndarray]:
    return {axis: axis_values(spec, axis) for axis in AXES}


def shape(spec: Spec) -> tuple[int, ...]:
    return tuple(axis_size(spec, axis) for axis in AXES)


def points(spec: Spec) -> np.ndarray:
    """All grid points as an ``(n, 4)`` array with columns (W, omega, v_ref, v_d), C order."""
    mesh = np.meshgrid(*coords(spec).values(), indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=1)
