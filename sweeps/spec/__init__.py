"""The spec: what a sweep asks for (the pydantic models), how a refusal is worded, the grid's
axes and their values, what each method produces, what the accuracy levels mean in numerics,
and whether the engine can run it (choices, axis values, fixed-step stability, step budget).
:func:`load_spec` / :func:`parse_spec` (sweeps.spec.load) put the checks together.

Inside, the imports run ``messages`` <- ``models`` <- ``grid``, ``methods`` <- ``accuracy``,
``checks`` <- ``fixed_step`` <- ``feasibility`` <- ``load``.
"""
import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "load": ["DEFAULT_MAX_POINTS", "MAX_LINE", "MAX_PROBLEMS", "SpecError", "SpecWarning",
                 "load_spec", "parse_spec"],
        "models": ["Spec"],
    },
)
