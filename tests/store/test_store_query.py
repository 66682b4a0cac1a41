"""Queries on hand-made cubes whose answers are known by construction.

Labels follow DESIGN.md §1: PU = an unstable point whose 4-neighbour connected component
of unstable points in the (v_ref, W) plane contains a point at the smallest W (W = 0 on
the paper's Fig. 9); SU = an unstable point whose component does not. A missing point is
no data and never joins a component (more cases: test_store_stability_labels.py).
"""

import numpy as np
import pandas as pd
import pytest
from storetest_cubes import STABLE_GRID, V_REF, W, averaged_cube

import store
from store import NO_DATA, PU, STABLE, SU

EXPECTED = np.array(
    [  # by the rule above: one component reaches W = 0 through the v_ref = 0.8 column;
        # only the island at v_ref = 0.2, W = 0.6-0.8 is cut off (a column-by-column rule
        # also calls (W, v_ref) = (0.2, 0.4), (0.4, 0.4), (0.4, 1), (0.6, 1), (1, 1) SU)
        [PU, STABLE, PU, STABLE, PU, PU],
        [PU, STABLE, PU, PU, PU, NO_DATA],
        [PU, STABLE, STABLE, PU, PU, PU],
        [STABLE, STABLE, SU, STABLE, PU, PU],
        [STABLE, STABLE, SU, STABLE, PU, STABLE],
        [STABLE, STABLE, STABLE, STABLE, PU, PU],
    ]
)


def test_pu_su_labels_by_construction():
    chart = store.stability_chart(averaged_cube(), sel={"v_d": 0.1})
    assert chart.dims == ("v_ref", "W") and chart.dtype == np.int8
    np.testing.assert_array_equal(chart.values, EXPECTED.T)
    assert chart.attrs["flag_values"].tolist() == [NO_DATA, STABLE, PU, SU]
    assert chart.attrs["flag_meanings"].split() == [
        "no_data",
        "stable",
        "primary_unstable",
        "secondary_unstable",
    ]


def test_labels_from_max_real_eig_and_from_a_descending_w_axis():
    from_eig = store.stability_chart(averaged_cube(with_stable=False), sel={"v_d": 0.01})
    np.testing.assert_array_equal(from_eig.values, EXPECTED.T)
    flipped = store.stability_chart(
        averaged_cube(W=W[::-1], stable=STABLE_GRID[::-1]), sel={"v_d": 0.1}
    )
    np.testing.assert_array_equal(flipped["W"].values, W)
    np.testing.assert_array_equal(flipped.values, EXPECTED.T)


def test_zone_map_threshold_and_missing_points():
    outputs = {"long_stick_fraction": ("fraction in long sticks", "1")}
    ds = store.empty_cube(
        {"W": [0.0, 1.0], "omega": [10.0, 100.0, 1000.0], "v_ref": [0.1], "v_d": [0.1]}, outputs
    )
    ds["long_stick_fraction"].values[..., 0, 0] = [[0.0, 0.05, 0.3], [0.0, 0.0, 0.7]]
    ds["status"].values[..., 0, 0] = [[0, 0, 0], [0, 3, 0]]
    zone = store.zone_map(ds)
    assert zone.dims == ("W", "omega")
    np.testing.assert_array_equal(zone.values, [[0.0, 1.0, 1.0], [0.0, np.nan, 1.0]])
    np.testing.assert_array_equal(
        store.zone_map(ds, threshold=0.1).values, [[0, 0, 1], [0, np.nan, 1]]
    )
    assert zone["omega"].attrs["units"] == "1"  # axis metadata survives


def test_effective_friction_curve_prefers_f_eff_and_masks_bad_points():
    ds = averaged_cube()
    curve = store.effective_friction_curve(ds, sel={"v_d": 0.1})
    assert curve.name == "F_eff" and curve.dims == ("W", "v_ref")
    expected = ds["F_eff"].isel(omega=0, v_d=0).where(ds["status"].isel(omega=0, v_d=0) == 0)
    np.testing.assert_array_equal(curve.values, expected.values)
    assert np.isnan(curve.values[1, 5])  # the failed point
    simulated = store.empty_cube(
        {"W": [0.0], "omega": [1.0], "v_ref": [0.1, 0.2], "v_d": [0.1]},
        {"F_mean": ("mean friction", "1")},
    )
    assert store.effective_friction_curve(simulated).name == "F_mean"


def test_table_rows_and_columns():
    ds = averaged_cube()
    frame = store.table(ds, var="F_eff", sel={"v_d": "0.01"})
    assert isinstance(frame, pd.DataFrame)
    assert list(frame.columns) == ["W", "omega", "v_ref", "v_d", "F_eff", "status"]
    assert len(frame) == W.size * V_REF.size and set(frame["v_d"]) == {0.01}
    first = frame.iloc[1]  # C order: v_ref varies fastest after the fixed v_d
    assert (first["W"], first["v_ref"]) == (0.0, 0.1)
    assert first["F_eff"] == ds["F_eff"].sel(W=0.0, v_ref=0.1, v_d=0.01).item()
    assert list(store.table(ds).columns)[4:] == ["F_eff", "max_real_eig", "stable", "status"]


def test_select_is_nearest_neighbour():
    ds = averaged_cube()
    assert store.select(ds, {"W": 0.27, "v_d": 0.012})["W"].values.tolist() == [0.2]
    assert store.select(ds, {"v_ref": 1.04})["v_ref"].values.tolist() == [1.0]  # within half a step


@pytest.mark.parametrize(
    "call, message",
    [
        (
            lambda ds: store.select(ds, {"vd": 0.1}),
            r"sel: unknown axis \['vd'\]; axes are \('W', 'omega', 'v_ref', 'v_d'\)",
        ),
        (
            lambda ds: store.select(ds, {"v_d": 0.5}),
            r"sel\['v_d'\] = 0.5 is off the grid; available v_d values: \[0.1, 0.01\]",
        ),
        (lambda ds: store.select(ds, {"omega": 10.0}), r"available omega values: \[1000\]"),
        (lambda ds: store.select(ds, {"W": "fast"}), r"sel\['W'\]: expected a number, got 'fast'"),
        (
            lambda ds: store.stability_chart(ds),
            r"stability_chart: axis 'v_d' has 2 values \[0.1, 0.01\]; choose one with sel",
        ),
        (
            lambda ds: store.zone_map(ds, sel={"v_d": 0.1}),
            r"zone_map: the cube has no variable 'long_stick_fraction'; available: \['F_eff'",
        ),
        (lambda ds: store.table(ds, var="F_mean"), r"table: the cube has no variable 'F_mean'"),
        (
            lambda ds: store.effective_friction_curve(ds.drop_vars("F_eff"), sel={"v_d": 0.1}),
            r"needs 'F_eff' or 'F_mean'",
        ),
        (
            lambda ds: store.stability_chart(
                ds.drop_vars(["stable", "max_real_eig"]), sel={"v_d": 0.1}
            ),
            r"needs the output 'stable' or 'max_real_eig'",
        ),
    ],
)
def test_error_messages(call, message):
    with pytest.raises(ValueError, match=message):
        call(averaged_cube())


def test_zone_map_of_a_cube_with_a_vector_output(tmp_path):
    """Fig. 14's cube holds alpha_hist over alpha_bin: the map's plane keeps that dim out of
    the way (found by scripts/bench_maps.py: `transpose` refused the extra dim), and the
    map draws."""
    outputs = {"long_stick_fraction": ("fraction in long sticks", "1"),
               "alpha_hist": ("alpha shares", "1", ("alpha_bin", 10))}
    ds = store.empty_cube(
        {"W": [0.0, 1.0], "omega": [10.0, 100.0, 1000.0], "v_ref": [0.1], "v_d": [0.1]}, outputs
    )
    ds["long_stick_fraction"].values[..., 0, 0] = [[0.0, 0.05, 0.3], [0.0, 0.0, 0.7]]
    ds["status"].values[...] = 0
    np.testing.assert_array_equal(store.zone_map(ds).values, [[0, 1, 1], [0, 0, 1]])
    store.stick_slip_map(ds, tmp_path / "zones.png")
    assert (tmp_path / "zones.png").stat().st_size > 1000


def test_a_cut_through_the_chart_is_labelled_in_the_whole_plane():
    """Column v_ref = 0.4 of STABLE_GRID is unstable at W = 0.2, 0.4 only: alone it would
    not reach W = 0 (SU), but through its neighbours' band it does, so PU (EXPECTED)."""
    ds = averaged_cube()
    cut = store.stability_chart(ds, sel={"v_d": 0.1, "v_ref": 0.4})
    assert cut.sizes == {"v_ref": 1, "W": 6}
    np.testing.assert_array_equal(cut.values[0], EXPECTED[:, 3])
    point = store.stability_chart(ds, sel={"v_d": 0.1, "v_ref": 0.4, "W": 0.2})
    assert point.values.tolist() == [[PU]]


@pytest.mark.parametrize("axis, value", [("W", float("nan")), ("W", "nan"), ("v_ref", "inf"),
                                         ("omega", float("-inf"))])
def test_a_non_finite_selection_off_the_grid_is_refused(axis, value):
    with pytest.raises(ValueError, match=rf"sel\['{axis}'\] = -?(nan|inf) is off the grid"):
        store.select(averaged_cube(), {axis: value})


def test_an_infinite_grid_value_is_selected_exactly():
    ds = averaged_cube().assign_coords(omega=[np.inf])   # the averaged limit, omega = inf
    assert store.select(ds, {"omega": "inf"})["omega"].values.tolist() == [np.inf]
