"""The cube a plan fills: its coordinates, variables and attributes (the spec, versions,
the engine's scene and parameters), every point NOT_COMPUTED at first (sweeps.run.submit)."""
from __future__ import annotations

import functools
import sys
import time

import store
from engine import params as P

from ..spec.methods import output_attrs
from ..spec.grid import AXIS_PARAM
from ..planning.plan import Plan
from ..version import __version__, results_fingerprint


def cube_attrs(plan: Plan) -> dict:
    return {
        "name": plan.spec.name,
        "sweep_id": plan.sweep_id,
        "spec": plan.spec.to_json(),
        "spec_hash": plan.sweep_id,
        "ditherlab_version": __version__,
        "engine_fingerprint": results_fingerprint(),   # also in the sweep id
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "path": plan.path,
        "system": plan.spec.system, "friction": plan.spec.friction,
        "dither": plan.spec.dither,
        "engine_settings": plan.numerics.as_dict() if plan.path == "simulate" else {},
        "engine_scene": {k: (list(v) if isinstance(v, tuple) else v)
                         for k, v in vars(plan.scene).items()},
        "engine_params": {k: v for k, v in P.unpack(plan.params).items()
                          if k not in AXIS_PARAM.values()},   # the axes are the coordinates
        "Conventions": "CF-1.8",
        **software_versions(),
    }


@functools.cache
def software_versions() -> dict[str, str]:
    """``<package>_version`` of what computed the cube (the engine's own is its fingerprint);
    read once per process (importlib.metadata: 85 ms, twice per submit before)."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"python_version": sys.version.split()[0]}
    for pkg in ("numpy", "numba", "scipy", "dask", "xarray", "h5netcdf"):
        try:
            out[f"{pkg}_version"] = version(pkg)
        except PackageNotFoundError:
            out[f"{pkg}_version"] = "not installed"
    return out


def empty_cube(plan: Plan):
    """A cube with every point NOT_COMPUTED, the coordinates, variables and attributes of
    ``plan``."""
    variables = {name: output_attrs(plan.path, name, plan.scene.system) for name in plan.outputs}
    units = {"omega": "rad/s", "W": "m/s", "v_ref": "m/s", "v_d": "m/s"} \
        if plan.spec.system == "contact" else None
    names = {"omega": "dither angular frequency: inf, the averaged theory is the limit "
                      "omega -> infinity"} if plan.path == "averaged" else None
    cube = store.empty_cube(plan.coords, variables, cube_attrs(plan), axis_units=units,
                            axis_long_names=names)
    if plan.spec.refine:
        store.cube.add_provenance(cube)
    return cube
