"""Sweep service: spec -> plan -> dask -> journaled HDF5 cube (DESIGN.md §3-5).

Re-exports load their module on first use, so ``ditherlab --help`` does not import dask,
numba or xarray.
"""
import importlib.util as _util

import lazy_loader as _lazy


def _check_not_shadowed(*names: str) -> None:
    """With an editable install (``pip install -e``), a folder named ``store`` or
    ``engine`` in the folder of the running script (or the current folder under
    ``python -m``) is found first, as an empty namespace package, and hides ditherlab's
    own package (so does one on ``$PYTHONPATH``, e.g. a store named ``store`` there): the run
    would fail later with a puzzling AttributeError. Say it now: an ImportError, or from
    the ``ditherlab`` command one line and exit 2 (it is raised before the command's own
    one-line handler exists)."""
    import sys

    for name in names:
        spec = _util.find_spec(name)
        if spec is not None and spec.origin is None and spec.submodule_search_locations:
            where = ", ".join(spec.submodule_search_locations)
            line = (f"the folder {where} hides ditherlab's '{name}' package (Python finds it "
                    f"first: the script's folder, the current one under -m, or $PYTHONPATH): "
                    f"rename that folder or run from another folder")
            if sys.argv and sys.argv[0].rsplit("/", 1)[-1] == "ditherlab":
                print(f"ditherlab: {line}", file=sys.stderr)
                raise SystemExit(2)
            raise ImportError(line)


_check_not_shadowed("store", "engine")

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submod_attrs={
        "api": ["open_sweep", "run_sweep"],
        "errors": ["InferredPointsWarning"],
        "planning.plan": ["Plan", "make_plan"],
        "run.outcome": ["SubmitResult"],
        "run.submit": ["submit"],
        "spec.load": ["SpecError", "load_spec", "parse_spec"],
        "spec.models": ["Spec"],
        "version": ["__version__"],
    },
)
