"""Which outputs each analysis path can produce, and the default selection."""
from __future__ import annotations

from engine import outputs as engine_outputs


def allowed_outputs(method: str) -> tuple[str, ...]:
    """All outputs of path ``method`` ('simulate' | 'averaged' | 'hbm')."""
    return tuple(engine_outputs.BY_PATH[method])


def resolve_outputs(method: str, requested: list[str] | None) -> tuple[str, ...]:
    """The requested outputs, or every output of the path when none were named."""
    return tuple(requested) if requested else allowed_outputs(method)


def output_attrs(method: str, name: str) -> tuple:
    """(long_name, units) of an output, plus ``(dim, size)`` for a vector output
    (``alpha_hist`` over ``alpha_bin``), as ``store.empty_cube`` takes them."""
    meta = engine_outputs.describe(method, name)
    extra = engine_outputs.VECTOR.get(name) if method == "simulate" else None
    return (*meta, extra) if extra else meta
