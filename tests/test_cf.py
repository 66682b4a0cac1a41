"""Cubes are CF-clean and readable by the usual netCDF tools (DESIGN.md §4, issue 14).

Each cube is made by the service's own writer (``sweeps.run.new_cube.empty_cube`` from a real plan,
then ``store.publish``) for every analysis path, so every output's ``long_name``/``units``
and every global attribute is checked; only the computing is skipped (values stay NaN,
status "not yet computed"), which CF does not look at.

cfchecker 4.1 needs the UDUNITS-2 C library (Debian: libudunits2-0; `.ci/run` installs it)
and three XML tables it would download: ``tests/data/cf/`` holds empty tables (the cubes use
no standard names, area types or regions), so the check runs offline.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import store
import sweeps
from sweeps.run.new_cube import empty_cube

TABLES = Path(__file__).parent / "data" / "cf"
SPECS = {
    "simulate": {"name": "cf-sim", "friction": "elastoplastic", "dither": "sine-velocity",
                 "outputs": ["v_mean", "v_slow_p2p", "F_mean", "stick_fraction",
                             "presliding_fraction", "slip_fraction", "long_stick_fraction",
                             "max_stick", "near_slip_fraction", "alpha_hist"],
                 "grid": {"W": [0.0, 0.5], "omega": [100.0, 200.0]}},
    "averaged": {"name": "cf-avg", "friction": "lugre", "method": "averaged",
                 "grid": {"W": [0.0, 0.5], "v_ref": [0.1, 0.2]}},
    "hbm": {"name": "cf-hbm", "system": "contact", "friction": "lugre", "method": "hbm",
            "dither": "sine-velocity", "grid": {"omega": [10.0, 100.0]}},
}


def _checker():
    try:
        from cfchecker.cfchecks import CFChecker, CFVersion
    except (ImportError, FileNotFoundError) as err:   # cfunits: no UDUNITS-2 library
        if os.environ.get("CI"):
            raise   # CI installs it (.ci/run): a missing checker there is a failure
        pytest.skip(f"cfchecker unusable here ({err}); install libudunits2-0")
    return CFChecker(cfStandardNamesXML=str(TABLES / "standard-names.xml"),
                     cfAreaTypesXML=str(TABLES / "area-types.xml"),
                     cfRegionNamesXML=str(TABLES / "region-names.xml"),
                     silent=True, version=CFVersion((1, 8)))


@pytest.fixture(scope="module", params=sorted(SPECS))
def cube_file(request, tmp_path_factory):
    plan = sweeps.make_plan(sweeps.load_spec(SPECS[request.param]))
    path = tmp_path_factory.mktemp(request.param) / "cube.nc"
    return store.publish(empty_cube(plan), path)


def test_cfchecks_finds_no_error_and_no_warning(cube_file):
    checker = _checker()
    checker.checker(str(cube_file))
    counts = checker.get_counts()
    assert (counts["FATAL"], counts["ERROR"], counts["WARN"]) == (0, 0, 0), checker.results


def test_cube_names_conventions_versions_and_engine(cube_file):
    with xr.open_dataset(cube_file, engine="h5netcdf") as ds:
        assert ds.attrs["Conventions"] == "CF-1.8"
        for key in ("numpy_version", "numba_version", "ditherlab_version",
                    "engine_fingerprint", "python_version"):
            assert ds.attrs[key] and ds.attrs[key] != "not installed", key
        params = store.decode_attr(ds.attrs["engine_params"])
        assert not {"W", "omega", "v_ref", "vd"} & set(params)   # axes are coordinates


def test_netcdf_c_and_lazy_dask_reads_agree_with_h5netcdf(cube_file):
    pytest.importorskip("netCDF4")
    with xr.open_dataset(cube_file, engine="h5netcdf") as a, \
            xr.open_dataset(cube_file, engine="netcdf4") as b, \
            xr.open_dataset(cube_file, engine="h5netcdf", chunks={}) as lazy:
        assert lazy["status"].chunks is not None   # dask-backed, nothing loaded yet
        for name in a.variables:
            assert a[name].dtype == b[name].dtype, name
            np.testing.assert_array_equal(a[name].values, b[name].values)
            np.testing.assert_array_equal(a[name].values, lazy[name].values)


def test_averaged_cube_has_no_fake_omega():
    """The averaged theory is the limit omega -> infinity: the cube says inf, not a default
    frequency, and a spec that sweeps omega on that path is refused."""
    plan = sweeps.make_plan(sweeps.load_spec(SPECS["averaged"]))
    ds = empty_cube(plan)
    assert ds["omega"].values.tolist() == [np.inf]
    assert "limit omega -> infinity" in ds["omega"].attrs["long_name"]
    with pytest.raises(sweeps.SpecError, match="grid.omega: the averaged theory"):
        sweeps.load_spec({**SPECS["averaged"], "grid": {"omega": [100.0]}})
