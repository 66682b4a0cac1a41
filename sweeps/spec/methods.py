"""What each method (the spec's ``method``, the engine's path) produces: its outputs and the
default selection, their cube attributes, and for a refined sweep (``refine = true``) the
map plane and the class output the refinement follows (sweeps.planning.refine)."""
from __future__ import annotations

from engine import outputs as engine_outputs

# the 2-D plane of a refined map, and the output whose value is the class on it
PLANES = {"simulate": ("W", "omega"), "averaged": ("W", "v_ref")}
CLASS_OUTPUT = {"simulate": "long_stick_fraction", "averaged": "stable"}


def allowed_outputs(method: str, system: str = "slider") -> tuple[str, ...]:
    """All outputs of path ``method`` ('simulate' | 'averaged' | 'hbm') on ``system`` (the
    simulate path adds the system's own, engine.outputs.path_outputs)."""
    return tuple(engine_outputs.path_outputs(method, system))


def resolve_outputs(method: str, requested: list[str] | None,
                    system: str = "slider") -> tuple[str, ...]:
    """The requested outputs, or every output of the path when none were named."""
    return tuple(requested) if requested else allowed_outputs(method, system)


def output_attrs(method: str, name: str, system: str = "slider") -> tuple:
    """(long_name, units) of an output, plus ``(dim, size)`` for a vector output
    (``alpha_hist`` over ``alpha_bin``), as ``store.empty_cube`` takes them."""
    meta = engine_outputs.describe(method, name, system)
    extra = engine_outputs.VECTOR.get(name) if method == "simulate" else None
    return (*meta, extra) if extra else meta
