"""The gallery's command line: scenes listed, every refusal one line with exit 2, and the
scenes reading their parameters from specs/ (one source)."""
import tomllib
from pathlib import Path

import pytest

from sweeps.cli.main import main
from sweeps.gallery.scenes import REGISTRY, SPECS, get_scene, shrink

from ...helpers import in_process

ROOT = Path(__file__).resolve().parents[3]


def test_scenes_lists_every_scene_with_its_points():
    status, out, _ = in_process("scenes")
    assert status == 0
    for scene in REGISTRY.values():
        line = next(l for l in out.splitlines() if l.startswith(scene.name + " "))
        assert line.split()[1:3] == [str(scene.n_points("small")), str(scene.n_points("full"))]


def test_scenes_lists_every_figure_the_gallery_draws_with_its_recipe():
    """A user finds Fig. 12 (a trajectory figure, no sweep) from the command line."""
    from sweeps.gallery.build import FIGURES, RECIPES

    _, out, _ = in_process("scenes")
    assert set(RECIPES) == set(FIGURES)
    for key, recipe in RECIPES.items():
        assert f"{key:<15}{recipe}" in out.splitlines()
    assert "W = 0, 1.5, 2.5 at omega 100, vd 0.1 and 0.01" in RECIPES["fig12"]


@pytest.mark.parametrize("argv, message", [
    (("submit", "--scene", "nope"), "unknown scene 'nope'; known scenes: fig01"),
    (("plan", "--scene", "fig99"), "unknown scene 'fig99'"),
    (("submit", "specs/fig14.toml", "--scene", "fig14"), "give a spec or --scene fig14, not both"),
    (("plan",), "missing spec: give a spec or --scene NAME"),
    (("submit",), "missing spec: give a spec or --scene NAME"),
    (("map", "--kind", "stick-slip", "-o", "x.png"), "missing sweep: give a sweep or --scene"),
    (("map", "fig14", "--scene", "fig14", "--kind", "stick-slip", "-o", "x.png"), "not both"),
    (("submit", "specs/fig14.toml", "--size", "small"), "--size applies to --scene only"),
    (("map", "fig14", "--kind", "stick-slip", "--pick", "3", "-o", "x.png"),
     "--pick applies to --kind friction only"),
    (("query", "fig14", "--sel", "W=0.1", "--sel", "W=0.2"), "--sel W: given twice"),
    # the web's rules (sweeps.exports.parse_selection), refused before the store is read
    (("query", "fig14", "--sel", "v_d=nan"), "--sel v_d: expected a number, got NaN"),
    (("query", "fig14", "--sel", "vd=0.1"), "--sel vd: unknown axis; the axes are W, omega"),
    (("map", "fig14", "--kind", "stability", "--sel", "W=fast", "-o", "x.png"),
     "--sel W: expected a number, got 'fast'"),
    (("map", "fig14", "--kind", "friction", "--pick", "3", "--sel", "W=0.1", "-o", "x.png"),
     "give --pick N or --sel W=VALUE, not both"),
    (("map", "fig14", "--kind", "friction", "--pick", "0", "-o", "x.png"), "--pick: must be >= 1"),
    (("gallery", "--only", "fig03"), "--only: unknown figure fig03"),
])
def test_refusals_are_one_line_with_exit_2(argv, message):
    status, _, err = in_process(*argv)
    assert status == 2
    assert message in err
    assert err.count("\n") == 1 and err.startswith("ditherlab: ")


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_a_full_scene_is_its_spec_file(name):
    scene = get_scene(name)
    with open(SPECS / scene.spec_file, "rb") as fh:
        data = tomllib.load(fh)
    full = scene.spec("full")
    assert {k: v for k, v in full.items() if k not in ("name", "params", "refine")} == \
        {k: v for k, v in data.items() if k not in ("name", "params", "refine")}
    assert full.get("params", {}) == {**data.get("params", {}), **scene.params}
    assert full.get("refine", False) == (scene.refine or data.get("refine", False))


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_a_small_scene_changes_only_grid_counts(name):
    full, small = get_scene(name).spec("full"), get_scene(name).spec("small")
    for axis, values in small["grid"].items():
        ref = full["grid"][axis]
        if isinstance(values, dict):
            assert {k: v for k, v in values.items() if k != "num"} == \
                {k: v for k, v in ref.items() if k != "num"}
        else:
            assert set(values) <= set(ref) and values[0] == ref[0]


def test_shrink_keeps_the_ends():
    assert shrink([0, 1, 2, 3, 4, 5, 6], 3) == [0, 3, 6]
    assert shrink({"start": 0.0, "stop": 1.0, "num": 81}, 5)["num"] == 5


@pytest.mark.long
def test_map_pick_draws_a_handful_of_w_curves(tmp_path, capsys):
    """--pick N and repeated --sel W=... on an averaged cube (small demo spec, a second)."""
    store = str(tmp_path / "store")
    spec = tmp_path / "s.toml"
    spec.write_text((ROOT / "specs" / "demo-stability.toml").read_text()
                    .replace("num = 81", "num = 9").replace("num = 100", "num = 12"))
    assert main(["submit", str(spec), "--store", store, "-q"]) == 0
    capsys.readouterr()
    out = tmp_path / "pick.png"
    assert main(["map", "demo-stability", "--kind", "friction", "--pick", "3", "--store", store,
                 "-o", str(out)]) == 0
    assert "(W = 0, 0.5, 1)" in capsys.readouterr().out          # ends + middle of 0..1
    assert out.read_bytes()[:4] == b"\x89PNG"
    assert main(["map", "demo-stability", "--kind", "friction", "--sel", "W=0.26",
                 "--sel", "W=0.74", "--store", store, "-o", str(out)]) == 0
    assert "(W = 0.25, 0.75)" in capsys.readouterr().out         # nearest grid values


def test_a_figure_that_cannot_be_computed_is_not_a_verdict_and_fails_the_command(
        tmp_path, monkeypatch):
    """A figure whose computation raises (e.g. its spec file missing, as in a package
    installed without specs/ before 0.2) is ``not computed`` on the page, never ``does not
    hold`` (a verdict on the paper's claim), and ``gallery`` exits 1 naming it."""
    from sweeps.gallery import build

    def broken(ctx):
        raise OSError("scene spec fig01-hbm.toml cannot be read")

    monkeypatch.setitem(build.FIGURES, "fig01", broken)
    status, out, err = in_process("gallery", "--only", "fig01", "-o", tmp_path / "g",
                                  "--store", tmp_path / "store")
    assert status == 1
    assert "fig01           not computed" in out
    assert "ditherlab: fig01 could not be computed: OSError: scene spec" in err
    page = (tmp_path / "g" / "gallery.md").read_text()
    assert "| [fig01](#fig01) | not computed |" in page
    assert "0 does not hold, 1 not computed" in page


def test_the_scene_specs_ship_inside_the_package():
    """specs/ in a checkout is a link to sweeps/specs, which the wheel carries
    (pyproject package-data): an installed ditherlab has its scenes (CI checks it too)."""
    assert SPECS == ROOT / "sweeps" / "specs"
    assert (ROOT / "specs").resolve() == SPECS
    for scene in REGISTRY.values():
        assert (SPECS / scene.spec_file).is_file()
