"""The whole path through the real command line on small grids: spec -> plan -> dask ->
journaled HDF5 cube -> query -> maps, checking the cube layout of DESIGN.md §4."""
import json

import matplotlib.image as mpimg
import numpy as np
import pytest
import xarray as xr

from sweeps.spec import load_spec

from ..helpers import AVERAGED_SPEC, SIMULATE_SPEC, ditherlab, in_process

pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)

AXES = ("W", "omega", "v_ref", "v_d")


def check_layout(cube_path, spec, outputs):
    ds = xr.open_dataset(cube_path, engine="h5netcdf")
    try:
        assert tuple(ds.dims) == AXES and tuple(ds.coords) == AXES
        for axis in AXES:
            assert ds[axis].attrs["long_name"] and ds[axis].attrs["units"]
        assert ds["omega"].attrs["units"] == "1"
        for name in outputs:
            assert ds[name].dims == AXES and ds[name].dtype == np.float64
            assert ds[name].attrs["long_name"] and "units" in ds[name].attrs
        st = ds["status"]
        assert st.dtype == np.int8 and st.dims == AXES
        assert list(st.attrs["flag_values"]) == [0, 1, 2, 3]
        assert st.attrs["flag_meanings"].split() == ["ok", "not_yet_computed", "failed",
                                                     "non_finite"]
        assert ds["cost_s"].dims == AXES and float(ds["cost_s"].min()) >= 0.0
        assert json.loads(ds.attrs["spec"]) == json.loads(spec.to_json())
        assert ds.attrs["spec_hash"] == spec.sweep_id
        for key in ("ditherlab_version", "created", "engine_settings"):
            assert key in ds.attrs
        return ds.load()
    finally:
        ds.close()


@pytest.mark.long
def test_simulated_sweep_end_to_end(tmp_path, spec_file):
    store = tmp_path / "store"
    path = spec_file(SIMULATE_SPEC)
    spec = load_spec(path)
    proc = ditherlab("submit", str(path), "--workers", "2", "--quiet", store=store, check=True)
    assert "done" in proc.stdout
    cube = store / spec.sweep_id / "cube.nc"
    ds = check_layout(cube, spec, spec.outputs)
    assert (ds["status"] == 0).all()
    assert (ds["steps"] > 0).all() and (ds["evals"] >= ds["steps"]).all()
    assert float(ds["cost_s"].sum()) > 0
    settings = json.loads(ds.attrs["engine_settings"])
    assert settings["label"] == "draft" and settings["integrator"]
    # the same spec again returns at once, computing nothing
    again = ditherlab("submit", str(path), "--quiet", store=store, check=True)
    assert "already complete" in again.stdout

    table = ditherlab("query", "e2e-sim", "--var", "v_mean", "--format", "json", store=store,
                      check=True)
    rows = json.loads(table.stdout)
    assert len(rows) == 8 and {"W", "omega", "v_ref", "v_d", "v_mean"} <= set(rows[0])
    csv = ditherlab("query", spec.sweep_id[:6], "--sel", "W=0.4", "--format", "csv",
                    store=store, check=True)
    assert csv.stdout.splitlines()[0].startswith("W,omega,v_ref,v_d")
    status = ditherlab("status", store=store, check=True)
    assert spec.sweep_id in status.stdout and "done" in status.stdout


def test_averaged_sweep_and_maps(tmp_path, spec_file):
    store = tmp_path / "store"
    path = spec_file(AVERAGED_SPEC)
    spec = load_spec(path)
    ditherlab("submit", str(path), "--quiet", store=store, check=True)
    ds = check_layout(store / spec.sweep_id / "cube.nc", spec, ["F_eff", "max_real_eig",
                                                                "stable"])
    assert (ds["status"] == 0).all()
    assert int(ds["steps"].sum()) == 0  # the averaged path integrates nothing
    for kind in ("stability", "friction"):
        png = tmp_path / f"{kind}.png"
        ditherlab("map", "e2e-avg", "--kind", kind, "-o", str(png), store=store, check=True)
        img = mpimg.imread(png)
        assert img.shape[0] >= 400 and img.shape[1] >= 600 and img.std() > 0.01


@pytest.mark.long
def test_stick_slip_map_png(tmp_path, spec_file):
    store = tmp_path / "store"
    path = spec_file(SIMULATE_SPEC.replace('friction = "lugre"', 'friction = "elastoplastic"')
                     .replace('"max_stick"]', '"max_stick", "long_stick_fraction"]'))
    ditherlab("submit", str(path), "--quiet", store=store, check=True)
    png = tmp_path / "zones.png"
    ditherlab("map", "e2e-sim", "--kind", "stick-slip", "-o", str(png), store=store, check=True)
    img = mpimg.imread(png)
    assert img.shape[0] >= 400 and img.shape[1] >= 600 and img.std() > 0.01


BAD_SPECS = {
    "unknown key": ('name = "x"\ncolour = "red"\n', "colour: unknown key"),
    "wrong type": ('[params]\nsigma0 = "stiff"\n', "params.sigma0: must be a valid number"),
    "negative stiffness": ('[params]\nsigma0 = -100.0\n', "params.sigma0: must be greater than 0"),
    "empty axis": ('[grid]\nW = []\n', "grid.W: needs at least one value"),
    "over budget": ('[grid]\nW = { start = 0, stop = 1, num = 1000 }\n'
                    'omega = { start = 1, stop = 1000, num = 1000 }\n', "over the point budget"),
    "unknown friction law": ('friction = "velcro"\n', "friction: got 'velcro'"),
    "malformed TOML": ('name = "x"\n[grid\nW = [1]\n', "malformed TOML"),
}


@pytest.mark.parametrize("case", sorted(BAD_SPECS))
def test_bad_spec_is_refused_and_nothing_written(tmp_path, spec_file, case):
    """Each refusal through the command's main in this process; one through the installed
    ``ditherlab`` command itself (a process start costs about 0.8 s)."""
    text, message = BAD_SPECS[case]
    store = tmp_path / "store"
    argv = ("submit", str(spec_file(text)), "--quiet", "--store", str(store))
    if case == "malformed TOML":
        proc = ditherlab(*argv)
        status, err = proc.returncode, proc.stderr
    else:
        status, _, err = in_process(*argv)
    assert status == 2
    assert message in err, err
    assert err.count("\n  - ") == 1  # one clear message
    assert not store.exists()


def test_unknown_sweep_and_bad_selection(tmp_path, spec_file):
    store = tmp_path / "store"
    proc = ditherlab("query", "nosuch", store=store)
    assert proc.returncode == 1 and "no sweep 'nosuch'" in proc.stderr
    ditherlab("submit", str(spec_file(AVERAGED_SPEC)), "--quiet", store=store, check=True)
    proc = ditherlab("query", "e2e-avg", "--var", "nonsense", store=store)   # refused: 2
    assert proc.returncode == 2 and "nonsense" in proc.stderr
    proc = ditherlab("query", "e2e-avg", "--sel", "W:0.1", store=store)
    assert proc.returncode == 2 and "AXIS=VALUE" in proc.stderr


@pytest.mark.long
def test_harmonic_balance_sweep_fig1_loop_grows_then_shrinks(tmp_path):
    """method = "hbm" through the service on the Sec. 3 contact model (Fig. 1 parameters):
    the loop area first grows with frequency, then shrinks (Sec. 3, Fig. 1), and no point is
    integrated in time."""
    store = tmp_path / "store"
    spec = load_spec("specs/fig01-hbm.toml")
    ditherlab("submit", "specs/fig01-hbm.toml", "--quiet", store=store, check=True)
    with xr.open_dataset(store / spec.sweep_id / "cube.nc", engine="h5netcdf") as ds:
        assert ds["omega"].attrs["units"] == "rad/s"
        assert (ds["status"] == 0).all() and int(ds["steps"].sum()) == 0
        area = ds["loop_area"].squeeze().values
    peak = int(np.argmax(area))
    assert 0 < peak < len(area) - 1
    assert area[peak] > 5 * area[0] and area[peak] > 100 * area[-1]
