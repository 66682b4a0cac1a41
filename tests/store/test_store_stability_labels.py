"""store.query.stability_labels: PU / SU by connected components (DESIGN.md §1).

PU = an unstable point whose 4-neighbour connected component of unstable points in the
(v_ref, W) plane contains a point at the chart's smallest W; SU = an unstable point whose
component does not; no-data points never join a component. Every array here is small
enough that its components are known by construction. Arrays are written with W as rows
(row 0 = smallest W, as on the paper's Fig. 9 read upside down) and v_ref as columns,
so ``w_axis=0, v_ref_axis=1`` unless a test says otherwise.
"""

import numpy as np
import pytest
from storetest_cubes import averaged_cube

import store
from store.query import NO_DATA, PU, STABLE, SU, stability_labels

U, S, X = "U", "S", "X"  # unstable, stable, no data (in the pictures below)


def _picture(rows):
    """(unstable, valid) bool arrays from a list of rows of U / S / X."""
    return (np.array([[c == U for c in r] for r in rows]),
            np.array([[c != X for c in r] for r in rows]))


def _labels(rows, **kw):
    unstable, valid = _picture(rows)
    return stability_labels(unstable, valid, w_axis=0, v_ref_axis=1, **kw)


def test_band_broken_at_w_min_in_some_columns_is_connected_through_its_neighbours():
    """The primary band lifts off W = min at columns 3-5 (as on Fig. 9 above
    v_ref = 0.2986) but stays connected to columns 0-2 above the gap: every point of it
    is PU. The old per-v_ref rule called columns 3-5 SU (a vertical cut at column 3)."""
    rows = [
        [U, U, U, S, S, S],  # W = min
        [U, U, U, U, S, S],
        [S, U, U, U, U, S],
        [S, S, S, U, U, U],
        [S, S, S, S, S, U],
    ]
    lab = _labels(rows)
    unstable, _ = _picture(rows)
    assert np.all(lab[unstable] == PU) and np.all(lab[~unstable] == STABLE)
    assert np.all(lab[:, 3:][unstable[:, 3:]] == PU)  # columns that never touch W = min


def test_island_not_touching_w_min_is_su_and_diagonal_contact_does_not_connect():
    """An island away from W = min is SU; an island that meets the primary zone only at a
    corner (diagonal neighbour) stays SU: 4-neighbour connectivity."""
    lab = _labels(
        [
            [U, U, S, S, S, S],
            [U, U, S, S, S, S],
            [S, S, U, U, S, S],  # (2, 2) touches the PU block only at the corner (1, 1)
            [S, S, U, S, S, U],
            [S, S, S, S, U, U],  # a second island, diagonal to nothing unstable
        ]
    )
    assert lab.tolist() == [
        [PU, PU, STABLE, STABLE, STABLE, STABLE],
        [PU, PU, STABLE, STABLE, STABLE, STABLE],
        [STABLE, STABLE, SU, SU, STABLE, STABLE],
        [STABLE, STABLE, SU, STABLE, STABLE, SU],
        [STABLE, STABLE, STABLE, STABLE, SU, SU],
    ]
    # the same island joined by one edge neighbour, (1, 2), becomes PU
    joined = _labels(
        [
            [U, U, S, S],
            [U, U, U, S],
            [S, S, U, U],
            [S, S, U, S],
        ]
    )
    assert np.all(joined[joined != STABLE] == PU)


def test_no_data_is_never_part_of_a_component_and_splits_one():
    """A no-data point is NO_DATA whatever its value, and unstable points on either side
    of it are not connected through it."""
    # a gap in one column: the part above it is SU
    assert _labels([[U, S], [X, S], [U, S]]).tolist() == [
        [PU, STABLE], [NO_DATA, STABLE], [SU, STABLE]
    ]
    # a whole no-data column: the part beyond it is SU ...
    assert _labels([[U, X, S], [U, X, U], [U, X, U]]).tolist() == [
        [PU, NO_DATA, STABLE], [PU, NO_DATA, SU], [PU, NO_DATA, SU]
    ]
    # ... unless it is joined to the primary zone around the missing points
    assert _labels([[U, X, S], [U, X, U], [U, U, U], [S, X, S]]).tolist() == [
        [PU, NO_DATA, STABLE], [PU, NO_DATA, PU], [PU, PU, PU], [STABLE, NO_DATA, STABLE]
    ]
    # a no-data point at W = min does not anchor the point above it
    assert _labels([[X, S], [U, S]]).tolist() == [[NO_DATA, STABLE], [SU, STABLE]]
    # unstable but invalid counts as no data
    lab = stability_labels(np.ones((2, 2), bool), np.array([[True, False], [True, True]]))
    assert lab.tolist() == [[PU, NO_DATA], [PU, PU]]


def test_slices_over_other_axes_are_independent():
    """A 4-D (W, omega, v_ref, v_d) stack: the same island is PU in the slice where it
    reaches W = min and SU in the others; neighbours along omega or v_d never connect."""
    touches = np.array([[1, 1, 0], [0, 1, 0], [0, 1, 1]], bool)  # reaches row 0
    floating = np.array([[0, 0, 0], [0, 1, 0], [0, 1, 1]], bool)  # the same island, lifted
    unstable = np.zeros((3, 2, 3, 2), bool)  # (W, omega, v_ref, v_d)
    unstable[:, 0, :, 0] = touches
    unstable[:, 1, :, 0] = floating
    unstable[:, 0, :, 1] = floating
    unstable[:, 1, :, 1] = floating
    lab = stability_labels(unstable, w_axis=0, v_ref_axis=2)
    assert lab.shape == unstable.shape and lab.dtype == np.int8
    assert np.all(lab[:, 0, :, 0][touches] == PU)
    for o, d in [(1, 0), (0, 1), (1, 1)]:
        plane = lab[:, o, :, d]
        assert np.all(plane[floating] == SU) and np.all(plane[~floating] == STABLE), (o, d)
    # the result does not depend on where the extra axes are, nor on a looped computation
    looped = np.empty_like(lab)
    for o in range(2):
        for d in range(2):
            looped[:, o, :, d] = stability_labels(unstable[:, o, :, d], w_axis=0, v_ref_axis=1)
    np.testing.assert_array_equal(lab, looped)
    moved = stability_labels(np.moveaxis(unstable, (0, 2), (-1, 0)), w_axis=-1, v_ref_axis=0)
    np.testing.assert_array_equal(np.moveaxis(moved, (-1, 0), (0, 2)), lab)


def test_coordinates_order_the_grid_before_labelling():
    """With W descending the smallest W is the last row; with a shuffled v_ref axis the
    neighbours are the grid neighbours, not the array neighbours."""
    two = [[U, S, S], [U, S, S], [S, S, U], [S, S, U]]  # PU at W = min, SU above
    ascending = _labels(two)
    assert ascending.tolist() == [[PU, STABLE, STABLE], [PU, STABLE, STABLE],
                                  [STABLE, STABLE, SU], [STABLE, STABLE, SU]]
    W = np.arange(4.0)
    np.testing.assert_array_equal(_labels(two[::-1], W=W[::-1]), ascending[::-1])
    chain = [[U, S, S], [U, U, S], [S, U, U], [S, S, U]]  # one component, all PU
    order = [2, 0, 1]  # columns 2 and 0 side by side: not neighbours on the grid
    unstable, valid = _picture(chain)
    shuffled = stability_labels(unstable[:, order], valid[:, order], w_axis=0, v_ref_axis=1,
                                v_ref=np.arange(3.0)[order])
    np.testing.assert_array_equal(shuffled, _labels(chain)[:, order])
    assert np.all(shuffled[unstable[:, order]] == PU)


def test_refuses_a_one_dimensional_array_and_equal_axes():
    with pytest.raises(ValueError, match="needs a \\(v_ref, W\\) plane"):
        stability_labels(np.ones(3, bool))
    with pytest.raises(ValueError, match="must differ"):
        stability_labels(np.ones((2, 2), bool), w_axis=1, v_ref_axis=-1)


def test_stability_chart_labels_a_cube_by_components():
    """store.stability_chart uses the same labels: the hand-made cube's two unstable zones
    that leave W = min only through a neighbouring column are PU (the old per-v_ref rule
    made them SU), and the one enclosed island is SU."""
    chart = store.stability_chart(averaged_cube(), sel={"v_d": 0.1})
    # storetest_cubes.STABLE_GRID, rows W = 0 .. 1.0, columns v_ref: 0.05 .. 1.0
    assert chart.sel(W=0.2, v_ref=0.4, method="nearest").item() == PU  # old rule: SU
    assert chart.sel(W=1.0, v_ref=1.0, method="nearest").item() == PU  # old rule: SU
    island = chart.sel(v_ref=0.2, method="nearest").values[3:5]
    assert island.tolist() == [SU, SU]
    assert np.count_nonzero(chart.values == SU) == 2
