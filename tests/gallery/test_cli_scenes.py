"""The gallery's command line: scenes listed, every refusal one line with exit 2, and the
scenes reading their parameters from specs/ (one source)."""
import tomllib
from pathlib import Path

import pytest

from sweeps.cli.main import main
from sweeps.gallery.scenes import REGISTRY, SPECS, get_scene, shrink

ROOT = Path(__file__).resolve().parents[2]


def _run(capsys, *argv):
    status = main(list(argv))
    out = capsys.readouterr()
    return status, out.out, out.err


def test_scenes_lists_every_scene_with_its_points(capsys):
    status, out, _ = _run(capsys, "scenes")
    assert status == 0
    for scene in REGISTRY.values():
        line = next(l for l in out.splitlines() if l.startswith(scene.name + " "))
        assert line.split()[1:3] == [str(scene.n_points("small")), str(scene.n_points("full"))]


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
     "apply to --kind friction only"),
    (("map", "fig14", "--kind", "friction", "--pick", "3", "--sel", "W=0.1", "-o", "x.png"),
     "give --pick N or --sel W=VALUE, not both"),
    (("map", "fig14", "--kind", "friction", "--pick", "0", "-o", "x.png"), "--pick: must be >= 1"),
    (("gallery", "--only", "fig03"), "--only: unknown figure fig03"),
])
def test_refusals_are_one_line_with_exit_2(capsys, argv, message):
    status, _, err = _run(capsys, *argv)
    assert status == 2
    assert message in err
    assert err.count("\n") == 1 and err.startswith("ditherlab: ")


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_a_full_scene_is_its_spec_file(name):
    scene = get_scene(name)
    with open(SPECS / scene.spec_file, "rb") as fh:
        data = tomllib.load(fh)
    full = scene.spec("full")
    assert {k: v for k, v in full.items() if k not in ("name", "params")} == \
        {k: v for k, v in data.items() if k not in ("name", "params")}
    assert full.get("params", {}) == {**data.get("params", {}), **scene.params}


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
