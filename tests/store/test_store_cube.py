"""The result cube's layout and round trip (DESIGN.md §4, STYLE.md 'Roundtrip tests')."""

import json

import numpy as np
import pytest
import xarray as xr
from storetest_cubes import ATTRS, COORDS, OUTPUTS, block_record, make_cube

import store
from store import attrs as A


def test_layout_follows_design_section_4(cube, tmp_path):
    path = store.publish(cube, tmp_path / "s" / "cube.nc")
    ds = xr.open_dataset(path, engine="h5netcdf")  # the contract: plain xarray can read it
    try:
        assert tuple(ds.dims) == store.AXES
        assert [ds.sizes[a] for a in store.AXES] == [len(COORDS[a]) for a in store.AXES]
        for name in [*OUTPUTS, "status", "cost_s", "steps", "evals"]:
            assert ds[name].dims == store.AXES
        assert ds["omega"].attrs == {   # UDUNITS units (CF); the meaning is in long_name
            "long_name": "dither angular frequency, rad per unit of the non-dimensional time tau",
            "units": "1",
        }
        assert all(set(ds[a].attrs) == {"long_name", "units"} for a in store.AXES)
        assert ds["F_mean"].dtype == np.float64
        assert (ds["F_mean"].attrs["long_name"], ds["F_mean"].attrs["units"]) == OUTPUTS["F_mean"]
        # int8 survives h5netcdf + CF decoding (no _FillValue that would turn it into float)
        assert ds["status"].dtype == np.int8 and (ds["status"] == store.NOT_COMPUTED).all()
        assert ds["steps"].dtype == np.int64 and ds["evals"].dtype == np.int64
        assert ds["cost_s"].attrs["units"] == "s"
        flags = ds["status"].attrs
        assert flags["flag_values"].dtype == np.int8
        assert flags["flag_values"].tolist() == [0, 1, 2, 3]
        assert flags["flag_meanings"].split() == ["ok", "not_yet_computed", "failed", "non_finite"]
        assert ds["F_mean"].encoding["zlib"] and ds["status"].encoding["zlib"]
        assert ds.attrs["spec"] == ATTRS["spec"] and ds.attrs["sweep_id"] == ATTRS["sweep_id"]
        assert json.loads(ds.attrs["engine_settings"]) == ATTRS["engine_settings"]
        assert ds.attrs["adaptive"] == "true"  # bools are refused by netCDF; stored as JSON
        assert {"created", "ditherlab_version", "Conventions"} <= set(ds.attrs)
    finally:
        ds.close()


def test_status_codes_agree_with_engine():
    from engine import status as S  # engine.status is plain Python (no numba)

    assert (store.OK, store.NOT_COMPUTED, store.FAILED, store.NON_FINITE) == (
        S.OK,
        S.NOT_COMPUTED,
        S.FAILED,
        S.NON_FINITE,
    )
    assert store.STATUS_MEANINGS == tuple(S.MEANINGS[k] for k in range(4))


def test_axis_units_and_long_names_can_be_overridden():
    ds = make_cube(
        axis_units={"W": "m/s", "omega": "rad/s"}, axis_long_names={"W": "velocity amplitude v_a"}
    )
    assert ds["W"].attrs == {"long_name": "velocity amplitude v_a", "units": "m/s"}
    assert ds["omega"].attrs["units"] == "rad/s" and ds["v_ref"].attrs["units"] == "1"


def test_roundtrip_is_identical(cube, tmp_path):
    index = np.array([0, 5, 17, cube["status"].size - 1])
    store.fill(cube, block_record(cube, index))
    path = store.publish(cube, tmp_path / "cube.nc")
    back = store.open_cube(path)
    xr.testing.assert_identical(store.as_dataset(cube), store.as_dataset(back))
    store.publish(back, path)  # republishing a reopened cube (with file encodings) is stable
    xr.testing.assert_identical(store.as_dataset(cube), store.as_dataset(store.open_cube(path)))
    more = np.array([1, 2])  # a reopened cube can be filled further (resume)
    store.fill(back, block_record(cube, more, seed=1))
    store.fill(cube, block_record(cube, more, seed=1))
    xr.testing.assert_identical(store.as_dataset(cube), store.as_dataset(back))


def test_fill_uses_c_order_over_axes(cube):
    shape = tuple(len(COORDS[a]) for a in store.AXES)
    multi = (np.array([2, 0, 1]), np.array([3, 1, 0]), np.array([1, 0, 1]), np.array([0, 0, 0]))
    index = np.ravel_multi_index(multi, shape)
    record = block_record(cube, index)
    store.fill(cube, record)
    ds = cube.to_dataset()
    for k, point in enumerate(zip(*multi)):
        at = dict(zip(store.AXES, point))
        assert ds["F_mean"].isel(at).item() == record.outputs["F_mean"][k]
        assert ds["status"].isel(at).item() == record.status[k]
        assert ds["evals"].isel(at).item() == record.evals[k]
    assert np.count_nonzero(cube["status"].values != store.OK) == cube["status"].size - \
        np.count_nonzero(record.status == store.OK)


def test_status_counts(cube):
    index = np.arange(4)
    store.fill(cube, store.BlockRecord(index, np.array([0, 2, 3, 0]), np.zeros(4),
                                       np.zeros(4, int), np.zeros(4, int),
                                       {n: np.zeros(4) for n in OUTPUTS}))
    assert store.status_counts(cube) == {
        "ok": 2,
        "not_yet_computed": cube["status"].size - 4,
        "failed": 1,
        "non_finite": 1,
    }


@pytest.mark.parametrize(
    "change, message",
    [
        (dict(outputs={"F_mean": np.zeros(2)}), r"missing \['long_stick_fraction'\]"),
        (dict(outputs={**{n: np.zeros(2) for n in OUTPUTS}, "x": np.zeros(2)}), r"unknown \['x'\]"),
        (dict(outputs={n: np.zeros((2, 3)) for n in OUTPUTS}),
         r"has shape \(2, 3\), expected \(2,\)"),
        (dict(status=np.array([0, 7])), r"status codes must be in 0..3, got \[7\]"),
        (
            dict(index=np.array([0, 24])),
            r"flat_index must lie in \[0, 24\) for a cube of shape \(3, 4, 2, 1\)",
        ),
        (dict(index=np.array([0.0, 1.0])), r"flat_index must be a 1-D integer array"),
    ],
)
def test_fill_refuses_bad_input_and_writes_nothing(cube, change, message):
    args = dict(
        index=np.array([0, 1]),
        outputs={n: np.ones(2) for n in OUTPUTS},
        status=np.zeros(2, np.int8),
        cost_s=np.ones(2),
        steps=np.ones(2, int),
        evals=np.ones(2, int),
    )
    args.update(change)
    before = cube.copy(deep=True)
    with pytest.raises(ValueError, match=message):
        store.fill(cube, store.BlockRecord(**args))
    xr.testing.assert_identical(store.as_dataset(cube), store.as_dataset(before))


@pytest.mark.parametrize(
    "coords, variables, message",
    [
        ({**COORDS, "x": [1.0]}, OUTPUTS, r"unknown \['x'\]"),
        ({k: v for k, v in COORDS.items() if k != "v_d"}, OUTPUTS, r"missing \['v_d'\]"),
        ({**COORDS, "W": []}, OUTPUTS, r"coords\['W'\] must be a non-empty 1-D"),
        ({**COORDS, "W": [0.1, 0.1]}, OUTPUTS, r"coords\['W'\] has repeated values"),
        ({**COORDS, "omega": [1.0, np.nan]}, OUTPUTS, r"coords\['omega'\] must be finite"),
        (COORDS, {"status": ("s", "1")}, r"'status' is a reserved name"),
        (COORDS, {"F": "force"}, r"variables\['F'\] must be \(long_name, units\)"),
    ],
)
def test_empty_cube_error_messages(coords, variables, message):
    with pytest.raises(ValueError, match=message):
        store.empty_cube(coords, variables)


def test_unknown_axis_in_units_override():
    with pytest.raises(ValueError, match=r"axis_units: unknown axis \['vd'\]"):
        make_cube(axis_units={"vd": "m/s"})


def test_axes_keep_the_given_order():
    ds = make_cube(coords={**COORDS, "v_d": [0.1, 0.01]})  # Fig. 9 lists vd = 0.1 first
    assert ds["v_d"].values.tolist() == [0.1, 0.01]


def test_attrs_encoding_rules():
    encoded = A.encode(
        {
            "s": "x",
            "i": 3,
            "f": 0.5,
            "n": np.int64(2),
            "b": False,
            "none": None,
            "d": {"b": 1, "a": [1, 2]},
            "arr": np.array([1.0, 2.0]),
        }
    )
    assert encoded == {
        "s": "x",
        "i": 3,
        "f": 0.5,
        "n": 2,
        "b": "false",
        "none": "null",
        "d": '{"a":[1,2],"b":1}',
        "arr": "[1.0,2.0]",
    }
    assert A.decode(encoded["d"]) == {"a": [1, 2], "b": 1}


def test_open_cube_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="no cube at"):
        store.open_cube(tmp_path / "nope.h5")
    other = tmp_path / "other.h5"
    xr.Dataset({"x": ("t", np.arange(3.0))}).to_netcdf(other, engine="h5netcdf")
    with pytest.raises(ValueError, match="not a ditherlab cube"):
        store.open_cube(other)


def test_open_cube_names_an_unreadable_file(tmp_path):
    torn = tmp_path / "cube.nc"
    torn.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 1000)
    with pytest.raises(ValueError, match="is unreadable .*submit the spec again"):
        store.open_cube(torn)
