"""Every gallery rule can fail: each figure is drawn again on a deliberately wrong model
(``Context.model``: parameter overrides for every engine computation, ``W_scale`` on every
dither amplitude; ``Context.theory``: overrides for the averaged theory alone) and its
verdict -- or, for a figure judged under several readings of an unstated value, the verdict
of a reading -- must differ from the paper model's, pinned in CORRECT (asserted on the paper
model by tests/e2e/test_gallery_figures.py::test_small_verdicts).

The wrong models: sigma1 dropped, the Stribeck exponent changed (delta 2 -> 1), the averaged
theory's g perturbed (fs 1.5 -> 1.6), g perturbed in the engine (simulation and theory
alike, caught only by the independent references of sweeps/gallery/reference.py), the
dither amplitude halved or cut tenfold, lam ignored (z_ba -> 0).
"""
import pytest

from sweeps.gallery.build import FIGURES
from sweeps.gallery.context import Context
from sweeps.gallery.verdicts import FAILS, HOLDS, PARTLY

pytestmark = pytest.mark.cluster   # what it starts (tests/conftest.py)

#: the paper model's verdicts at the small size (and per reading where there are readings)
CORRECT = {
    "fig01": (HOLDS, {}),
    "fig02": (PARTLY, {"delta_d = 2 (Eq. 2.5 as in Sec. 2)": PARTLY,
                       "delta_d = 1 (Sec. 3's delta = 1 also in Eq. 2.5)": PARTLY}),
    "fig05": (PARTLY, {}),
    "fig06": (HOLDS, {}),
    "fig07": (HOLDS, {}),
    "fig08": (PARTLY, {}),
    "fig09": (PARTLY, {}),
    "fig10": (HOLDS, {}),
    "fig11": (HOLDS, {}),
    "fig12": (PARTLY, {"vd = 0.1": PARTLY, "vd = 0.01": HOLDS}),
    "fig13": (HOLDS, {}),
    "fig15": (HOLDS, {}),
    "fig16": (HOLDS, {f"W = {W}, omega = 100": HOLDS for W in ("1.5", "2.5", "3")}),
    "fig17": (PARTLY, {"W = 1.5, omega = 100": PARTLY, "W = 2.5, omega = 100": HOLDS,
                       "W = 3, omega = 100": HOLDS}),
    "beyond_sine": (HOLDS, {}),
}

#: figure -> (what is wrong, Context.model, Context.theory)
WRONG = {
    "fig01": ("sigma1 dropped", {"sigma1": 0.0}, {}),
    "fig02": ("sigma1 dropped", {"sigma1": 0.0}, {}),
    "fig05": ("averaged theory with a perturbed g (fs 1.6)", {}, {"fs": 1.6}),
    "fig06": ("g perturbed in the engine, simulation and theory alike", {"fs": 1.6}, {}),
    "fig07": ("Stribeck exponent 1 instead of 2", {"delta": 1.0}, {}),
    "fig08": ("dither amplitude halved", {"W_scale": 0.5}, {}),
    "fig09": ("sigma1 dropped", {"sigma1": 0.0}, {}),
    "fig10": ("dither amplitude halved", {"W_scale": 0.5}, {}),
    "fig11": ("dither amplitude cut tenfold", {"W_scale": 0.1}, {}),
    "fig12": ("lam ignored (z_ba -> 0)", {"lam": 1e-3}, {}),
    "fig13": ("dither amplitude halved", {"W_scale": 0.5}, {}),
    "fig15": ("lam ignored (z_ba -> 0)", {"lam": 1e-3}, {}),
    "fig16": ("dither amplitude cut tenfold", {"W_scale": 0.1}, {}),
    "fig17": ("dither amplitude cut tenfold", {"W_scale": 0.1}, {}),
    "beyond_sine": ("averaged theory with a wrong Stribeck velocity (vs 1)", {}, {"vs": 1.0}),
}
#: trajectory figures: 3-20 s each (docs/GALLERY.md), long: CI runs them (`-m long`)
LONG = {"fig06", "fig08", "fig10", "fig11", "fig12", "fig13", "fig15", "fig16", "fig17"}


def test_every_paper_figure_but_the_sweep_ones_has_a_wrong_model():
    assert set(WRONG) == set(CORRECT) == set(FIGURES) - {"fig14", "beyond_scaling"}


@pytest.mark.long
@pytest.mark.parametrize("key", [pytest.param(k, marks=pytest.mark.long) if k in LONG else k
                                 for k in WRONG])
def test_the_rule_fails_on_a_wrong_model(key, tmp_path):
    what, model, theory = WRONG[key]
    ctx = Context(size="small", outdir=tmp_path / "out", store=tmp_path / "store", workers=1,
                  model=model, theory=theory)
    res = FIGURES[key](ctx)
    assert (res.verdict, res.readings) != CORRECT[key], (key, what, res.reason)
    assert res.verdict != HOLDS or CORRECT[key][0] != HOLDS, (key, what)


@pytest.mark.long   # two refined dask sweeps, about a minute
@pytest.mark.timeout(2400)
def test_fig14_rule_fails_without_the_elastic_stick(tmp_path):
    """lam = z_ba/z_ss cut to 0.05 (nearly LuGre): long stick leaves most of the plane, and
    the zone's boundary no longer grows with W as Fig. 14's does."""
    ctx = Context(size="small", outdir=tmp_path / "out", store=tmp_path / "store", workers=2,
                  model={"lam": 0.05})
    assert FIGURES["fig14"](ctx).verdict in (FAILS, PARTLY)
