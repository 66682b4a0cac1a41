"""Spec validation (DESIGN.md §3): one clear message per fault naming the field, the value
and what is allowed; the sweep id hashes results-changing content only."""
import numpy as np
import pytest

from sweeps.spec import SpecError, load_spec, parse_spec

BASE = {"name": "t", "grid": {"W": {"start": 0.0, "stop": 3.0, "num": 4}, "omega": [100.0]}}


def refused(data, **kw) -> list[str]:
    with pytest.raises(SpecError) as info:
        parse_spec(data, **kw)
    return info.value.problems


@pytest.mark.parametrize("data, field, hint", [
    ({"colour": "red"}, "colour", "unknown key"),
    ({"name": "a\nb"}, "name", "one line of printable characters"),
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
    c = spec.grid_facts.coords
    np.testing.assert_allclose(c["W"], [0, 1, 2, 3])
    np.testing.assert_allclose(c["omega"], [10, 100, 1000])
    assert c["v_d"].tolist() == [0.1]          # paper Sec. 5.1 default vd
    pts = spec.grid_facts.points
    assert pts.shape == (12, 4)
    # C order over (W, omega, v_ref, v_d): the flat index is the cube position
    np.testing.assert_allclose(pts[1], [0.0, 100.0, 0.0, 0.1])


# --- issue 10: validation that cannot be fooled, made slow or crashed -------------------

import json
import math
import tracemalloc
import warnings

from sweeps.spec import MAX_LINE, SpecWarning

from ...helpers import cpu_seconds

NUMERIC_FIELDS = [  # every float of a spec, as a path, with a valid value
    ("params", "sigma0"), ("params", "sigma1"), ("params", "sigma2"), ("params", "vs"),
    ("params", "fc"), ("params", "fs"), ("params", "delta"), ("params", "delta_d"),
    ("params", "lam"), ("params", "long_stick"), ("params", "stick_band"),
    ("params", "slip_gap"), ("params", "alpha_near"), ("params", "e0"), ("params", "v0"),
    ("params", "z0"), ("params", "slow_force", "amplitude"), ("params", "slow_force", "omega"),
    ("time", "t_end"), ("time", "t_transient"),
    ("grid", "W", "start"), ("grid", "W", "stop"), ("grid", "omega", 0),
    ("accuracy", "rtol"), ("accuracy", "atol"),
]


def with_value(path, value, data=None) -> dict:
    data = json.loads(json.dumps(data or BASE))
    if path[0] == "accuracy":
        data["accuracy"] = {"integrator": "dopri5"}
    node = data
    for key in path[:-1]:
        node = node.setdefault(key, {})
    node[path[-1]] = value
    return data


def field_of(path) -> str:
    return ".".join(str(p) for p in path[:2]) if path[0] == "grid" else ".".join(path)


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("path", NUMERIC_FIELDS, ids=lambda p: ".".join(map(str, p)))
def test_nan_and_inf_refused_everywhere(path, value):
    (msg,) = refused(with_value(path, value))
    assert msg.startswith(field_of(path)), msg
    assert "finite" in msg, msg


def test_t_end_and_rtol_inf_refused():
    assert "finite" in refused({**BASE, "time": {"t_end": math.inf}})[0]
    assert refused({**BASE, "accuracy": {"integrator": "dopri5", "rtol": math.inf}})[0] \
        .startswith("accuracy.rtol:")


@pytest.mark.parametrize("path, value", [
    (("time", "t_end"), "100"), (("params", "sigma0"), True), (("params", "lam"), "0.8"),
    (("grid", "W", "num"), "10"), (("grid", "W", "num"), 10.0), (("block_size",), "4"),
    (("grid", "W", "start"), "0"),
])
def test_no_coercion_from_strings_or_bools(path, value):
    (msg,) = refused(with_value(path, value))
    assert msg.startswith(".".join(path[:3])), msg
    assert "valid" in msg or "must be" in msg, msg


def test_ints_are_fine_where_floats_are_expected():
    spec = parse_spec({**BASE, "time": {"t_end": 50, "t_transient": 10},
                       "params": {"sigma0": 200}})
    assert spec.time.t_end == 50.0 and isinstance(spec.time.t_end, float)


def _no_linspace_over(monkeypatch, limit=10_000):
    """Fail if any axis of more than ``limit`` values is built."""
    for name in ("linspace", "geomspace"):
        real = getattr(np, name)

        def guarded(start, stop, num=50, *a, _real=real, **kw):
            assert num <= limit, f"built an axis of {num} values"
            return _real(start, stop, num, *a, **kw)
        monkeypatch.setattr(np, name, guarded)


@pytest.mark.parametrize("num", [10**6, 10**9, 10**12, 2**63, 2**64, 10**30])
def test_huge_num_refused_in_constant_memory(num, monkeypatch):
    _no_linspace_over(monkeypatch)
    data = {**BASE, "grid": {"W": {"start": 0.0, "stop": 1.0, "num": num}}}
    tracemalloc.start()
    try:
        with cpu_seconds() as spent:
            (msg,) = refused(data)
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert spent() < 1.0
    assert peak < 5_000_000, peak
    assert msg.startswith("grid.W.num:") or msg.startswith("grid: ") and "W=" in msg, msg


def test_product_of_axes_over_budget_refused_before_building(monkeypatch):
    _no_linspace_over(monkeypatch, limit=100_000)
    ax = {"start": 0.1, "stop": 1.0, "num": 1000}
    (msg,) = refused({**BASE, "grid": {a: ax for a in ("W", "omega", "v_ref", "v_d")}})
    assert "1000000000000 points" in msg and "budget" in msg


def test_num_must_be_a_positive_bounded_int():
    for num in (0, -1, 1.5, 10**7 + 1):
        (msg,) = refused({**BASE, "grid": {"W": {"start": 0.0, "stop": 1.0, "num": num}}})
        assert msg.startswith("grid.W.num:"), msg


@pytest.mark.parametrize("axis, value, repeated", [
    ("W", [0.1, 0.2, 0.1], "0.1"),
    ("v_ref", [1, 1.0], "1.0"),
    ("omega", {"start": 5.0, "stop": 5.0, "num": 3}, "5.0"),
    ("v_d", {"start": 0.1, "stop": 0.1, "num": 2, "scale": "log"}, "0.1"),
    ("W", {"start": 1.0, "stop": math.nextafter(1.0, 2.0), "num": 5}, "1.0"),
])
def test_repeated_grid_values_refused(axis, value, repeated):
    (msg,) = refused({**BASE, "grid": {**BASE["grid"], axis: value}})
    assert msg.startswith(f"grid.{axis}: repeats the value {repeated}"), msg


def test_messages_show_plain_python_values():
    (msg,) = refused({**BASE, "grid": {"W": {"start": -100, "stop": 1.0, "num": 3}}})
    assert msg == "grid.W: dither amplitude must be >= 0, got -100.0", msg
    (msg,) = refused({**BASE, "grid": {**BASE["grid"], "v_d": [-0.5, 0.1]}})
    assert "np." not in msg and msg.endswith("got -0.5"), msg


@pytest.mark.parametrize("where", ["friction", "accuracy", "key", "outputs", "integrator",
                                   "scale", "name", "sigma0"])
def test_echoed_values_are_truncated(where):
    s = "é" * 1_000_000
    data = json.loads(json.dumps(BASE))
    if where == "key":
        data["params"] = {s: 1.0}
    elif where == "outputs":
        data["outputs"] = [s]
    elif where == "integrator":
        data["accuracy"] = {"integrator": s}
    elif where == "scale":
        data["grid"]["W"]["scale"] = s
    elif where == "sigma0":
        data["params"] = {"sigma0": s}
    else:
        data[where] = s
    with cpu_seconds() as spent:
        (msg,) = refused(data)
    assert spent() < 1.0
    assert len(msg) < 300 and "..." in msg, msg


def test_at_most_max_problems_lines():
    problems = refused({**BASE, **{f"k{i}": 1 for i in range(50)}})
    assert len(problems) == 21 and problems[-1] == "spec: ... and 30 more faults"
    assert all(len(p) <= MAX_LINE for p in problems)


def test_fs_below_a_default_fc_is_refused():
    (msg,) = refused({**BASE, "params": {"fc": 2.0}})     # default fs = 1.5
    assert msg.startswith("params: fs must be >= fc") and "default" in msg


def test_contact_sine_force_refused():
    (msg,) = refused({**BASE, "system": "contact", "dither": "sine-force"})
    assert msg.startswith("dither: 'sine-force' needs a mass")


def test_numpy_values_from_the_python_api():
    spec = parse_spec({**BASE, "grid": {"W": np.linspace(0.0, 1.0, 3),
                                        "omega": (np.float64(100.0),)},
                       "params": {"sigma0": np.float64(150.0)}})
    assert spec.grid_facts.coords["W"].tolist() == [0.0, 0.5, 1.0]


# --- files ------------------------------------------------------------------------------

def test_non_utf8_file_is_one_line(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes('name = "café"\n'.encode("latin-1"))
    with pytest.raises(SpecError) as info:
        load_spec(path)
    (msg,) = info.value.problems
    assert "not UTF-8" in msg and "0xe9" in msg, msg


def test_utf8_bom_is_accepted(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes('name = "t"\n'.encode("utf-8-sig"))
    assert load_spec(path).name == "t"


@pytest.mark.parametrize("fmt", ["toml", "json"])
@pytest.mark.parametrize("depth", [20, 500, 100_000])
def test_deep_nesting_is_one_line(tmp_path, fmt, depth):
    path = tmp_path / f"deep.{fmt}"
    deep = "[" * depth + "1" + "]" * depth
    path.write_text(f"[grid]\nW = {deep}\n" if fmt == "toml" else f'{{"grid": {{"W": {deep}}}}}')
    with cpu_seconds() as spent, pytest.raises(SpecError) as info:
        load_spec(path)
    assert spent() < 1.0
    (msg,) = info.value.problems
    assert "nested" in msg, msg


def test_deep_dict_from_the_python_api():
    data: dict = {}
    node = data
    for _ in range(5000):
        node["a"] = {}
        node = node["a"]
    (msg,) = refused({**BASE, "params": data})
    assert msg.startswith("params.a.a") and "nested" in msg, msg


def test_huge_json_integer_is_one_line(tmp_path):
    path = tmp_path / "big.json"
    path.write_text('{"time": {"t_end": 1' + "0" * 5000 + "}}")
    with pytest.raises(SpecError, match="malformed JSON"):
        load_spec(path)
    (msg,) = refused({"time": {"t_end": 10**400}})
    assert msg.startswith("time.t_end:") and len(msg) < 120, msg


def test_oversized_file_refused(tmp_path):
    path = tmp_path / "big.toml"
    path.write_text("# " + "x" * 1_100_000 + "\n")
    with pytest.raises(SpecError, match="more than the 1000000"):
        load_spec(path)


def test_saved_spec_json_parses_again():
    """What the store keeps (Spec.to_json) must load again (service, is_stale)."""
    for data in [BASE, {**BASE, "accuracy": {"integrator": "rk4", "steps_per_period": 4}},
                 {**BASE, "accuracy": {"integrator": "dopri5", "rtol": 1e-7,
                                       "atol_units": "natural"}}]:
        spec = parse_spec(data)
        assert parse_spec(json.loads(spec.to_json())).sweep_id == spec.sweep_id


def test_example_specs_still_validate():
    from pathlib import Path

    specs = sorted((Path(__file__).parents[3] / "specs").glob("*.toml"))
    assert len(specs) >= 6
    with warnings.catch_warnings():
        warnings.simplefilter("error", SpecWarning)
        for path in specs:
            load_spec(path)


def test_the_grid_is_resolved_once_per_spec(monkeypatch):
    """Parsing, planning (at every level), the error estimate's finer numerics and the
    plan's points all read the one GridFacts of the spec (issue 27: the axes were built
    about six times per submit, the full mesh once more for the time estimate)."""
    from sweeps.estimates.error_estimate import finer_numerics
    from sweeps.planning.plan import make_plan
    from sweeps.spec.grid import GridFacts

    built = []
    real = GridFacts.of.__func__
    monkeypatch.setattr(GridFacts, "of",
                        classmethod(lambda cls, spec: built.append(1) or real(cls, spec)))
    spec = parse_spec({**BASE, "accuracy": "draft", "dither": "square-velocity",
                       "grid": {"W": [0.0, 0.5], "omega": [100.0, 300.0], "v_ref": [0.4]}})
    plans = [make_plan(spec, level) for level in (None, "draft", "standard", "reference")]
    finer_numerics(plans[0])
    assert plans[0].points is plans[1].points is spec.grid_facts.points
    assert len(built) == 1


def test_a_gpu_sweeps_error_reruns_run_on_the_cpu():
    """The error estimate's dozen re-runs of a GPU sweep run on the CPU at every level, the
    top one (tolerances / 100) too: one GPU thread is ~10x slower than a core (docs/GPU.md,
    measured on an H200), so on the GPU they would be the sweep's tail."""
    from sweeps.estimates.error_estimate import finer_numerics
    from sweeps.planning.plan import make_plan

    spec = parse_spec({**BASE, "device": "cuda", "dither": "square-velocity",
                       "grid": {"W": [0.0, 0.5], "omega": [100.0, 300.0], "v_ref": [0.4]}})
    for level in ("draft", "standard", "reference"):
        plan = make_plan(spec, level)
        assert plan.numerics.settings.device == "cuda", level
        assert finer_numerics(plan).settings.device == "cpu", level
