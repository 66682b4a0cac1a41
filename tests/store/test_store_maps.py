"""The PNG maps: right size, and the shaded areas in proportion to the labelled cells
(the maps show what the queries say, Fig. 9 / Fig. 14 style)."""

import numpy as np
import pytest
from matplotlib import colormaps
from matplotlib.colors import to_rgb
from matplotlib.image import imread

import store
from store import maps as M

SIZE = (round(M.FIGSIZE[1] * M.DPI), round(M.FIGSIZE[0] * M.DPI))  # (rows, columns) = (700, 980)


def _pixels(image: np.ndarray, colour: str) -> int:
    rgb = np.round(np.asarray(to_rgb(colour)) * 255)
    return int(np.count_nonzero(np.all(np.round(image[..., :3] * 255) == rgb, axis=-1)))


def _inside_axes(image: np.ndarray) -> np.ndarray:
    """The part of the image inside the axes frame (found as the long dark spine lines),
    which leaves out the legend drawn to the right of the axes."""
    dark = image[..., :3].mean(axis=-1) < 0.3  # the spines are antialiased over two pixels
    cols = np.flatnonzero(dark.sum(axis=0) > 0.5 * image.shape[0])
    rows = np.flatnonzero(dark.sum(axis=1) > 0.4 * image.shape[1])
    return image[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1]


def fig9_like_cube():
    """PU below W = 0.3 + 0.4 v_ref, an SU band above it at v_ref > 0.5, a failed patch."""
    W, v_ref = np.linspace(0, 1.2, 61), np.linspace(0.02, 1.2, 60)
    ds = store.empty_cube(
        {"W": W, "omega": [1e3], "v_ref": v_ref, "v_d": [0.1]},
        {"stable": ("stable (1) or unstable (0)", "1"), "F_eff": ("effective friction", "1")},
        {"name": "fig09-like", "sweep_id": "9a9a9a9a9a9a"},
    )
    w, v = np.meshgrid(W, v_ref, indexing="ij")
    unstable = (w < 0.3 + 0.4 * v) | ((w > 0.55 + 0.2 * v) & (w < 0.65 + 0.25 * v) & (v > 0.5))
    ds["stable"].values[...] = (~unstable)[:, None, :, None]
    ds["F_eff"].values[...] = (
        1 + 0.5 * np.exp(-((v / 0.1) ** 2)) - 0.6 * np.exp(-((v / (w + 0.05)) ** 2))
    )[:, None, :, None]
    status = np.zeros(w.shape, np.int8)
    status[50:55, :4] = store.FAILED
    ds["status"].values[...] = status[:, None, :, None]
    return ds.to_dataset()   # as a reader gets it (store.open_cube)


def test_stability_map_areas_match_the_chart(tmp_path):
    ds = fig9_like_cube()
    path = M.stability_map(ds, tmp_path / "fig9.png")
    image = imread(path)
    assert image.shape[:2] == SIZE
    chart = store.stability_chart(ds).values
    inside = _inside_axes(image)
    pu, su, missing = (
        _pixels(inside, M.STABILITY_COLOURS[k]) for k in (store.PU, store.SU, store.NO_DATA)
    )
    cells = {k: np.count_nonzero(chart == k) for k in (store.PU, store.SU, store.NO_DATA)}
    assert cells[store.PU] > 0 and cells[store.SU] > 0 and cells[store.NO_DATA] == 20
    assert su / pu == pytest.approx(cells[store.SU] / cells[store.PU], rel=0.1)
    assert missing / pu == pytest.approx(cells[store.NO_DATA] / cells[store.PU], rel=0.15)


def test_stick_slip_map_on_a_log_omega_axis(tmp_path):
    omega, W = np.geomspace(10, 1000, 21), np.linspace(0, 3, 16)
    ds = store.empty_cube(
        {"W": W, "omega": omega, "v_ref": [0.1], "v_d": [0.1]},
        {"long_stick_fraction": ("fraction in long sticks", "1")},
        {"name": "fig14-like"},
    )
    w, o = np.meshgrid(W, omega, indexing="ij")
    ds["long_stick_fraction"].values[...] = np.where(w < 0.5 + 0.4 * np.log10(o), 0.2, 0.0)[
        ..., None, None
    ]
    ds["status"].values[...] = 0
    ds["status"].values[:3, :3] = store.NOT_COMPUTED
    image = imread(M.stick_slip_map(ds, tmp_path / "fig14.png"))
    assert image.shape[:2] == SIZE
    zone = store.zone_map(ds).values
    inside = _inside_axes(image)
    zone_px, missing_px = _pixels(inside, M.ZONE_COLOURS[1.0]), _pixels(inside, M.NO_DATA_COLOUR)
    # on a log omega axis every cell has the same width, so pixel areas follow cell counts
    assert zone_px / missing_px == pytest.approx(
        np.count_nonzero(zone == 1) / np.count_nonzero(np.isnan(zone)), rel=0.15
    )


def test_friction_curves_draw_one_line_per_w(tmp_path):
    ds = fig9_like_cube().isel(W=slice(0, 61, 12))
    image = imread(M.friction_curves(ds, tmp_path / "curves.png"))
    assert image.shape[:2] == SIZE
    cmap = colormaps["viridis"]
    W = ds["W"].values
    for w in W:
        colour = cmap((w - W.min()) / (W.max() - W.min()))
        assert _pixels(image, colour) > 200, f"no line for W = {w}"


def test_maps_refuse_what_the_queries_refuse(tmp_path):
    with pytest.raises(
        ValueError, match="zone_map: the cube has no variable 'long_stick_fraction'"
    ):
        M.stick_slip_map(fig9_like_cube(), tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize(
    "values, log",
    [
        (np.geomspace(10, 1000, 5), True),
        (np.linspace(0, 3, 5), False),
        (np.geomspace(1, 2, 2), False),
        (np.array([0.1, 0.2, 0.4, 0.5]), False),
    ],
)
def test_log_spacing_detection(values, log):
    assert M.is_log_spaced(values) is log


def test_an_output_path_that_cannot_be_a_figure_says_why(tmp_path):
    """A file where the folder should be, and a folder where the file should be: each its
    own line (the first was reported as a missing folder to mkdir, the second as a temp
    file's 'Is a directory' after the figure was drawn)."""
    (tmp_path / "afile").write_text("")
    (tmp_path / "d.png").mkdir()
    for under in ("x.png", "sub/x.png"):
        with pytest.raises(ValueError, match=r"afile is a file, not a folder$"):
            store.figure_format(tmp_path / "afile" / under)
    with pytest.raises(ValueError, match=r"d.png: it is a folder; name a file$"):
        store.figure_format(tmp_path / "d.png")
    with pytest.raises(ValueError, match=r"the folder .*nope does not exist \(create it first"):
        store.figure_format(tmp_path / "nope" / "x.png")
