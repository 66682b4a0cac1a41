"""Sweep service: spec -> plan -> dask -> journaled HDF5 cube (DESIGN.md §3-5)."""
from .api import open_sweep, run_sweep
from .plan import Plan, make_plan
from .run import SubmitResult, submit
from .spec import Spec, SpecError, load_spec, parse_spec
from .version import __version__

__all__ = ["Plan", "Spec", "SpecError", "SubmitResult", "__version__", "load_spec",
           "make_plan", "open_sweep", "parse_spec", "run_sweep", "submit"]
