"""Sweep service: spec -> plan -> dask -> journaled HDF5 cube (DESIGN.md §3-5).

Re-exports load their module on first use, so ``ditherlab --help`` does not import dask,
numba or xarray.
"""
import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "api": ["open_sweep", "run_sweep"],
        "plan": ["Plan", "make_plan"],
        "outcome": ["SubmitResult"],
        "run": ["submit"],
        "spec": ["SpecError", "load_spec", "parse_spec"],
        "spec_models": ["Spec"],
        "version": ["__version__"],
    },
)
