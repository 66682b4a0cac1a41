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

import importlib.util
import json
import os
import subprocess
import sys
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


# netCDF4-python and h5py each bring their own HDF5 library (their wheels bundle different
# builds: HDF5 2.2.0 and 2.0.0 here), and two in one process is a known hazard (netcdf4-python
# #653, h5py #2171). A pytest worker goes on with h5py after this module, so what needs
# netCDF4 (cfchecker reads with it, and the netCDF-C read below) runs in a child process.
CHILD = r"""
import json, sys
import numpy as np
cube, arrays, tables = sys.argv[1:4]
found = {}
try:
    from cfchecker.cfchecks import CFChecker, CFVersion
except (ImportError, FileNotFoundError) as err:   # cfunits: no UDUNITS-2 library
    found["cf_unusable"] = repr(err)
else:
    checker = CFChecker(cfStandardNamesXML=f"{tables}/standard-names.xml",
                        cfAreaTypesXML=f"{tables}/area-types.xml",
                        cfRegionNamesXML=f"{tables}/region-names.xml",
                        silent=True, version=CFVersion((1, 8)))
    checker.checker(cube)
    found["counts"] = checker.get_counts()
    found["results"] = repr(checker.results)[-3000:]
import xarray as xr
with xr.open_dataset(cube, engine="netcdf4") as ds:
    np.savez(arrays, **{name: ds[name].values for name in ds.variables})
    found["dtypes"] = {name: str(ds[name].dtype) for name in ds.variables}
print(json.dumps(found))
"""


@pytest.fixture(scope="module")
def netcdf_c(cube_file, tmp_path_factory):
    """What netCDF-C tools see in ``cube_file`` (from a child process): cfchecker's counts
    and every variable as netCDF4-python reads it."""
    if importlib.util.find_spec("netCDF4") is None:   # (found, not imported: see above)
        # the test extra installs it: missing there (CI) is a failure, as cfchecker is
        assert not os.environ.get("CI"), "netCDF4 is not installed"
        pytest.skip("netCDF4 is not installed (the test extra installs it)")
    arrays = tmp_path_factory.mktemp("netcdf-c") / "arrays.npz"
    out = subprocess.run([sys.executable, "-c", CHILD, str(cube_file), str(arrays), str(TABLES)],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    found = json.loads(out.stdout.splitlines()[-1])
    with np.load(arrays) as npz:
        found["arrays"] = {name: npz[name] for name in npz.files}
    return found


@pytest.fixture(scope="module", params=sorted(SPECS))
def cube_file(request, tmp_path_factory):
    plan = sweeps.make_plan(sweeps.load_spec(SPECS[request.param]))
    path = tmp_path_factory.mktemp(request.param) / "cube.nc"
    return store.publish(empty_cube(plan), path)


def test_cfchecks_finds_no_error_and_no_warning(netcdf_c):
    if "cf_unusable" in netcdf_c:
        # CI installs the library (.ci/run): a missing checker there is a failure
        assert not os.environ.get("CI"), netcdf_c["cf_unusable"]
        pytest.skip(f"cfchecker unusable here ({netcdf_c['cf_unusable']}); "
                    "install libudunits2-0")
    counts = netcdf_c["counts"]
    assert (counts["FATAL"], counts["ERROR"], counts["WARN"]) == (0, 0, 0), \
        netcdf_c["results"]


def test_cube_names_conventions_versions_and_engine(cube_file):
    with xr.open_dataset(cube_file, engine="h5netcdf") as ds:
        assert ds.attrs["Conventions"] == "CF-1.8"
        for key in ("numpy_version", "numba_version", "ditherlab_version",
                    "engine_fingerprint", "python_version"):
            assert ds.attrs[key] and ds.attrs[key] != "not installed", key
        params = store.decode_attr(ds.attrs["engine_params"])
        assert not {"W", "omega", "v_ref", "vd"} & set(params)   # axes are coordinates


def test_netcdf_c_and_lazy_dask_reads_agree_with_h5netcdf(cube_file, netcdf_c):
    with xr.open_dataset(cube_file, engine="h5netcdf") as a, \
            xr.open_dataset(cube_file, engine="h5netcdf", chunks={}) as lazy:
        assert lazy["status"].chunks is not None   # dask-backed, nothing loaded yet
        assert set(netcdf_c["arrays"]) == set(a.variables)
        for name in a.variables:
            b = netcdf_c["arrays"][name]
            assert str(a[name].dtype) == netcdf_c["dtypes"][name], name
            np.testing.assert_array_equal(a[name].values, b)
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
