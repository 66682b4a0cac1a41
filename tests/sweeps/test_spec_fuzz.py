"""Property: no mutation of a valid spec gets past validation, slows it or crashes it
(issue 10). Each generated invalid spec, written as a TOML or JSON file, must end in a
SpecError whose lines are short and name the field, and in exit status 2 from
``ditherlab plan`` / ``submit`` (``sweeps.cli.main`` in-process) with nothing written to
the store. ``scripts/fuzz_spec.py`` runs many more cases than this CI-sized sample."""
import contextlib
import io
import json
import math
import tempfile
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sweeps import cli
from sweeps.spec import MAX_LINE, SpecError, load_spec, parse_spec

VALID = {
    "name": "fuzz", "friction": "elastoplastic", "dither": "sine-velocity",
    "method": "simulate", "outputs": ["F_mean", "stick_fraction"], "accuracy": "draft",
    "params": {"sigma0": 100.0, "lam": 0.8, "slow_force": {"amplitude": 1.7, "omega": 0.3}},
    "time": {"t_end": 50.0, "t_transient": 10.0},
    "grid": {"W": {"start": 0.0, "stop": 3.0, "num": 4},
             "omega": {"start": 10.0, "stop": 1000.0, "num": 3, "scale": "log"},
             "v_ref": [0.1], "v_d": [0.1]},
}
NUMBERS = [("params", "sigma0"), ("params", "lam"), ("params", "slow_force", "amplitude"),
           ("params", "slow_force", "omega"), ("params", "fc"), ("params", "e0"),
           ("time", "t_end"), ("time", "t_transient"), ("grid", "W", "start"),
           ("grid", "omega", "stop"), ("grid", "v_ref", 0), ("grid", "v_d", 0)]
TABLES = [(), ("params",), ("time",), ("grid",), ("params", "slow_force"), ("grid", "W")]
SAFE_TEXT = st.text(st.characters(blacklist_categories=("Cs", "Cc")), max_size=30)
DEEP = "__DEEP__"


# --- writing ----------------------------------------------------------------------------

def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return "{ " + ", ".join(f"{json.dumps(k, ensure_ascii=False)} = {_toml(x)}"
                            for k, x in v.items()) + " }"


def to_text(data: dict, fmt: str) -> str:
    if fmt == "json":
        return json.dumps(data)
    lines = [f"{json.dumps(k)} = {_toml(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines += [f"[{json.dumps(k)}]"] + [f"{json.dumps(kk, ensure_ascii=False)} = "
                                               f"{_toml(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


def put(data: dict, path, value) -> dict:
    data = json.loads(json.dumps(data))
    node = data
    for key in path[:-1]:
        node = node.setdefault(key, {}) if isinstance(node, dict) else node[key]
    node[path[-1]] = value
    return data


def dotted(path) -> str:
    return ".".join(str(p) for p in path)


# --- mutations: (data, fmt, deep, field the message must name) --------------------------

@st.composite
def wrong_type(draw):
    path = draw(st.sampled_from(NUMBERS))
    value = draw(st.one_of(
        st.floats(allow_nan=False, allow_infinity=False).map(str),     # "100"
        st.booleans(), SAFE_TEXT,
        st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=3),
        st.dictionaries(st.sampled_from(["x", "y"]), st.integers(0, 9), min_size=1)))
    return put(VALID, path, value), draw(st.sampled_from(["toml", "json"])), None, dotted(path)


@st.composite
def non_finite(draw):
    path = draw(st.sampled_from(NUMBERS + [("accuracy", "rtol"), ("accuracy", "atol"),
                                           ("accuracy", "step")]))
    value = draw(st.sampled_from([math.nan, math.inf, -math.inf]))
    data = VALID
    if path[0] == "accuracy":
        data = {**VALID, "accuracy": {"integrator": "rk4" if path[1] == "step" else "dopri5"}}
    field = dotted(path[:2]) if path[0] == "grid" else dotted(path)
    return put(data, path, value), draw(st.sampled_from(["toml", "json"])), None, field


@st.composite
def huge_num(draw):
    axis = draw(st.sampled_from(["W", "omega", "v_ref", "v_d"]))
    num = draw(st.one_of(st.integers(10**7 + 1, 2**200), st.integers(-2**70, 0),
                         st.sampled_from([10**9, 10**12, 2**63, 2**64])))
    fmt = "toml" if -2**63 <= num < 2**63 and draw(st.booleans()) else "json"
    data = put(VALID, ("grid", axis), {"start": 0.1, "stop": 1.0, "num": num})
    return data, fmt, None, f"grid.{axis}"


@st.composite
def deep_nesting(draw):
    depth = draw(st.one_of(st.integers(17, 200), st.sampled_from([500, 1000, 5000, 100_000])))
    where = draw(st.sampled_from([("grid", "W"), ("params", "sigma0"), ("name",), ("extra",)]))
    fmt = draw(st.sampled_from(["toml", "json"]))
    kind = draw(st.sampled_from(["list", "table"]))
    return put(VALID, where, DEEP), fmt, (depth, kind), None    # any line saying "nested"


@st.composite
def long_string(draw):
    n = draw(st.sampled_from([301, 5_000, 100_000]))
    s = draw(st.sampled_from(["x", "é", "\\", "'", " "])) * n
    where = draw(st.sampled_from(["friction", "accuracy", "key", "outputs", "integrator",
                                  "scale", "sigma0", "name"]))
    data, field = json.loads(json.dumps(VALID)), where
    if where == "key":
        table = draw(st.sampled_from(["params", "time", "grid"]))
        data[table] = {**data[table], s: 1.0}
        field = table
    elif where == "outputs":
        data["outputs"] = [s]
    elif where == "integrator":
        data["accuracy"], field = {"integrator": s}, "accuracy.integrator"
    elif where == "scale":
        data["grid"]["omega"]["scale"], field = s, "grid.omega.scale"
    elif where == "sigma0":
        data["params"]["sigma0"], field = s, "params.sigma0"
    else:
        data[where] = s
    return data, "json", None, field


@st.composite
def unknown_key(draw):
    table = draw(st.sampled_from(TABLES))
    key = draw(SAFE_TEXT.filter(lambda k: k and k not in (
        "name", "description", "system", "friction", "dither", "method", "outputs",
        "accuracy", "params", "time", "grid", "block_size", "sigma0", "lam", "slow_force",
        "amplitude", "omega", "t_end", "t_transient", "W", "v_ref", "v_d", "start", "stop",
        "num", "scale")))
    data = put(VALID, (*table, key), draw(st.one_of(st.integers(0, 9), SAFE_TEXT)))
    return data, draw(st.sampled_from(["toml", "json"])), None, dotted(table) or key[:30]


@st.composite
def duplicate_values(draw):
    axis = draw(st.sampled_from(["W", "omega", "v_ref", "v_d"]))
    x = draw(st.floats(0.01, 100.0))
    kind = draw(st.sampled_from(["list", "range"]))
    if kind == "list":
        others = draw(st.lists(st.floats(0.01, 100.0), max_size=3))
        value = draw(st.permutations([x, x, *others]))
    else:
        value = {"start": x, "stop": x, "num": draw(st.integers(2, 50))}
    data = put(VALID, ("grid", axis), value)
    return data, draw(st.sampled_from(["toml", "json"])), None, f"grid.{axis}"


BAD_ACCURACY = [
    ({"integrator": "rk4", "steps_per_period": 8, "rtol": 1e-6}, "accuracy.rtol"),
    ({"integrator": "rk4", "steps_per_period": 8, "atol": 1e-9}, "accuracy.atol"),
    ({"integrator": "rk4", "steps_per_period": 8, "atol_units": "natural"}, "accuracy.atol_units"),
    ({"integrator": "dopri5", "steps_per_period": 8}, "accuracy.steps_per_period"),
    ({"integrator": "dopri5", "step": 1e-3}, "accuracy.step"),
    ({"integrator": "rodas4", "steps_per_period": 4}, "accuracy.steps_per_period"),
    ({"integrator": "rk4", "steps_per_period": 1}, "accuracy"),          # unstable
    ({"integrator": "rk4", "steps_per_period": 2}, "accuracy"),          # unstable
    ({"integrator": "rk4", "step": 1e-3}, "accuracy.step"),              # ignored with dither
    ({"integrator": "dopri5", "rtol": 1e-20}, "accuracy.rtol"),
    ({"integrator": "dopri5", "rtol": 2.0}, "accuracy.rtol"),
]


@st.composite
def bad_integrator(draw):
    if draw(st.booleans()):
        name = draw(SAFE_TEXT.filter(lambda s: s not in ("rk4", "dopri5", "rodas4",
                                                        "rosenbrock")))
        acc, field = {"integrator": name}, "accuracy.integrator"
    else:
        acc, field = draw(st.sampled_from(BAD_ACCURACY))
    return {**VALID, "accuracy": acc}, draw(st.sampled_from(["toml", "json"])), None, field


MUTATIONS = st.one_of(wrong_type(), non_finite(), huge_num(), deep_nesting(), long_string(),
                      unknown_key(), duplicate_values(), bad_integrator())


def write(tmp: Path, data: dict, fmt: str, deep) -> Path:
    text = to_text(data, fmt)
    if deep is not None:
        depth, kind = deep
        inner = ("[" * depth + "1" + "]" * depth if kind == "list" else
                 ('{"a": ' * depth if fmt == "json" else "{ a = " * depth) + "1"
                 + ("}" * depth if fmt == "json" else " }" * depth))
        text = text.replace(json.dumps(DEEP), inner, 1)
    path = tmp / f"spec.{fmt}"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_valid_base_is_valid(tmp_path):
    for fmt in ("toml", "json"):
        assert load_spec(write(tmp_path, VALID, fmt, None)).sweep_id == parse_spec(VALID).sweep_id


@settings(max_examples=60, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(MUTATIONS)
def test_invalid_specs_are_refused_cleanly(case):
    data, fmt, deep, field = case
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        path = write(tmp, data, fmt, deep)
        t0 = time.perf_counter()
        with pytest.raises(SpecError) as info:          # any other exception fails the test
            load_spec(path)
        assert time.perf_counter() - t0 < 1.0
        lines = info.value.problems
        assert lines and all(len(line) <= MAX_LINE for line in lines), lines
        assert all("np.float" not in line and "np.int" not in line for line in lines), lines
        if field is None:
            assert any("nested" in line for line in lines), lines
        else:
            assert any(line.startswith(field) for line in lines), (field, lines)
        store = tmp / "store"
        for command in ("plan", "submit"):
            err = io.StringIO()
            t0 = time.perf_counter()
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                status = cli.main([command, str(path), "--store", str(store)])
            assert time.perf_counter() - t0 < 1.0
            assert status == 2, err.getvalue()
            out = err.getvalue().splitlines()
            assert out[0] == "ditherlab: invalid sweep spec:", out
            assert not store.exists(), f"{command} wrote {list(store.rglob('*'))}"


@pytest.mark.parametrize("command", ["plan", "submit"])
def test_cli_refuses_with_exit_2_and_writes_nothing(tmp_path, capsys, command):
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\naccuracy = { integrator = "euler" }\n[time]\nt_end = "100"\n'
                    "[grid]\nW = [0.5, 0.5]\n")
    store = tmp_path / "store"
    assert cli.main([command, str(path), "--store", str(store)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "ditherlab: invalid sweep spec:"
    assert err[1].startswith("  - accuracy.integrator: unknown integrator 'euler'")
    assert err[2] == "  - time.t_end: must be a valid number, got '100'"
    assert not store.exists()
