"""The submitting process stays light (issue 11: a 400x400 averaged chart end to end in
about 2 s). A fresh process pays ~0.35 s to import xarray and pandas, ~0.65 s for
dask.array (imported by xarray as it wraps its first array, since dask is installed)
and ~0.55 s for dask.distributed (imported by xarray's netCDF writer for its lock):
more than half of that budget. So the writer's cube is ``store.cubedata.Cube``, written
with h5netcdf, and an in-process (averaged) submit must import none of them."""
import json
import subprocess
import sys

import pytest


from ..helpers import AVERAGED_SPEC

pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)

HEAVY = ("xarray", "pandas", "dask.array", "distributed", "matplotlib")


@pytest.mark.long
def test_an_averaged_submit_imports_no_xarray_pandas_dask_or_matplotlib(tmp_path, spec_file):
    path = spec_file(AVERAGED_SPEC)
    code = ("import json, sys\n"
            "from sweeps.cli.main import main\n"
            f"code = main(['submit', {str(path)!r}, '--quiet', '--store', "
            f"{str(tmp_path / 'store')!r}])\n"
            f"print(json.dumps([code, [m for m in {HEAVY!r} if m in sys.modules]]))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600, check=True)
    code, heavy = json.loads(proc.stdout.strip().splitlines()[-1])
    assert code == 0, proc.stderr
    assert heavy == [], f"the submitting process imported {heavy}"
    # and the cube it wrote is what readers expect
    import xarray as xr

    cube = next((tmp_path / "store").glob("*/cube.nc"))
    with xr.open_dataset(cube, engine="h5netcdf") as ds:
        assert int((ds["status"] == 0).sum()) == ds["status"].size == 21 * 25
        assert ds["status"].dtype == "int8" and ds["F_eff"].dtype == "float64"
