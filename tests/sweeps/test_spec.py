"""Spec validation (DESIGN.md §3): one clear message per fault naming the field, the value
and what is allowed; the sweep id hashes results-changing content only."""
import numpy as np
import pytest

from sweeps import grid
from sweeps.spec import SpecError, load_spec, parse_spec

BASE = {"name": "t", "grid": {"W": {"start": 0.0, "stop": 3.0, "num": 4}, "omega": [100.0]}}


def refused(data, **kw) -> list[str]:
    with pytest.raises(SpecError) as info:
        parse_spec(data, **kw)
    return info.value.problems


@pytest.mark.parametrize("data, field, hint", [
    ({"colour": "red"}, "colour", "unknown key"),
    ({"params": {"sigma0": -1.0}}, "params.sigma0", "greater than 0"),
    ({"params": {"sigma0": "stiff"}}, "params.sigma0", "valid number"),
    ({"grid": {"W": []}}, "grid.W", "at least one value"),
    ({"grid": {"W": "abc"}}, "grid.W", "list of numbers or a range"),
    ({"grid": {"omega": {"start": 0, "stop": 10, "num": 3, "scale": "log"}}}, "grid.omega",
     "log range needs start > 0"),
    ({"grid": {"v_d": {"start": 0.1, "stop": 1, "num": 0}}}, "grid.v_d.num", "greater than 0"),
    ({"friction": "magic"}, "friction", "'lugre'"),
    ({"accuracy": "best"}, "accuracy", "'draft'"),
    ({"time": {"t_end": 10, "t_transient": 20}}, "time", "t_transient must be < t_end"),
    ({"outputs": ["F_eff"]}, "outputs", "not produced by method='simulate'"),
    ({"params": {"fc": 2.0, "fs": 1.0}}, "params", "fs must be >= fc"),
    ({"method": "hbm"}, "method", "system = 'contact'"),
    ({"grid": {"W": [-1.0]}}, "grid.W", ">= 0"),
])
def test_one_clear_message_per_fault(data, field, hint):
    problems = refused(data)
    assert len(problems) == 1, problems
    assert problems[0].startswith(field + ":") and hint in problems[0], problems[0]


def test_two_faults_two_messages():
    problems = refused({"colour": 1, "params": {"sigma0": -1.0}})
    assert len(problems) == 2


def test_point_budget_names_the_grid_shape():
    data = {"grid": {"W": {"start": 0, "stop": 1, "num": 100}, "omega": {"start": 1, "stop": 2,
                                                                       "num": 100}}}
    (msg,) = refused(data, max_points=5000)
    assert "10000 points" in msg and "W=100 x omega=100" in msg and "budget of 5000" in msg


def test_malformed_toml_is_refused(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("name = 'x'\n[grid\nW = [1]\n")
    with pytest.raises(SpecError, match="malformed TOML"):
        load_spec(path)


def test_toml_json_and_dict_give_the_same_sweep(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text('name = "t"\n[grid]\nW = { start = 0.0, stop = 3.0, num = 4 }\n'
                    'omega = [100.0]\n')
    import json
    js = tmp_path / "s.json"
    js.write_text(json.dumps(BASE))
    assert load_spec(toml).sweep_id == load_spec(js).sweep_id == parse_spec(BASE).sweep_id


def test_hash_ignores_cosmetic_fields_but_not_physics():
    a = parse_spec(BASE)
    assert parse_spec({**BASE, "name": "other", "description": "x", "block_size": 3}
                      ).sweep_id == a.sweep_id
    assert parse_spec({**BASE, "params": {"sigma0": 200.0}}).sweep_id != a.sweep_id
    assert parse_spec({**BASE, "accuracy": "draft"}).sweep_id != a.sweep_id


def test_axes_ranges_and_defaults():
    spec = parse_spec({"grid": {"W": {"start": 0, "stop": 3, "num": 4},
                                "omega": {"start": 10, "stop": 1000, "num": 3, "scale": "log"}}})
    c = grid.coords(spec)
    np.testing.assert_allclose(c["W"], [0, 1, 2, 3])
    np.testing.assert_allclose(c["omega"], [10, 100, 1000])
    assert c["v_d"].tolist() == [0.1]          # paper Sec. 5.1 default vd
    pts = grid.points(spec)
    assert pts.shape == (12, 4)
    # C order over (W, omega, v_ref, v_d): the flat index is the cube position
    np.testing.assert_allclose(pts[1], [0.0, 100.0, 0.0, 0.1])
