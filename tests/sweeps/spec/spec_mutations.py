"""The one mutator of sweep specs (issues 9, 10), shared by the CI-sized property test
(tests/sweeps/spec/test_spec_fuzz.py, driven by hypothesis) and the long fuzzing run
(scripts/fuzz_spec.py, driven by a seeded ``random.Random``).

A mutation takes a random source (``random.Random``'s interface) and a valid spec (a
dict, :func:`spec_cases.bases`) and returns a :class:`spec_cases.Case`: the spec changed,
the format it is written in, whether it must be refused or accepted, and the field a
refusal must name. :data:`MUTATIONS` lists them all.
"""
from __future__ import annotations

import json
import math
import string
import tomllib

from .spec_cases import DEEP, ROOT, VALID, Case, to_toml

NUMERIC = {  # leaf path -> kind, for mutations of numbers
    ("params", "sigma0"): "pos", ("params", "sigma1"): "nonneg", ("params", "sigma2"): "nonneg",
    ("params", "vs"): "pos", ("params", "fc"): "pos", ("params", "fs"): "pos",
    ("params", "delta"): "pos", ("params", "delta_d"): "pos", ("params", "lam"): "unit",
    ("params", "long_stick"): "pos", ("params", "stick_band"): "pos",
    ("params", "slip_gap"): "gap", ("params", "alpha_near"): "unit",
    ("params", "e0"): "any", ("params", "v0"): "any", ("params", "z0"): "any",
    ("params", "slow_force", "amplitude"): "any", ("params", "slow_force", "omega"): "nonneg",
    ("time", "t_end"): "pos", ("time", "t_transient"): "nonneg",
}
LITERALS = {("system",): ("slider", "contact"),
            ("friction",): ("coulomb", "stribeck", "lugre", "elastoplastic"),
            ("dither",): ("none", "square-velocity", "sine-velocity", "sine-force"),
            ("method",): ("simulate", "averaged", "hbm"),
            ("accuracy",): ("draft", "standard", "reference")}
KNOWN_KEYS = {"name", "description", "system", "friction", "dither", "method", "outputs",
              "accuracy", "params", "time", "grid", "block_size", "refine", "slow_force",
              "amplitude", "omega", "t_end", "t_transient", "W", "v_ref", "v_d", "start",
              "stop", "num", "scale", *(k[-1] for k in NUMERIC)}
INTEGRATORS = ("rk4", "dopri5", "rodas4", "rosenbrock")
AXES = ("W", "omega", "v_ref", "v_d")
# --- helpers ---------------------------------------------------------------------------

def _copy(d):
    return json.loads(json.dumps(d))


def _set(data: dict, path: tuple, value) -> None:
    node = data
    for key in path[:-1]:
        if isinstance(node, list):
            node = node[key]
            continue
        if not isinstance(node.get(key), (dict, list)):
            node[key] = {}
        node = node[key]
    node[path[-1]] = value


def _dotted(path) -> str:
    """The field a refusal names: a grid value by its axis (``grid.W``), else the path."""
    path = tuple(map(str, path))
    return ".".join(path[:2] if path[0] == "grid" else path)


def _fmt(rng) -> str:
    return rng.choice(["toml", "json"])


def _text(rng, n: int) -> str:
    """Up to ``n`` random printable characters, non-ASCII included."""
    alphabet = string.ascii_letters + string.digits + " _-.é€😀\\'\"[]{}=#"
    return "".join(rng.choice(alphabet) for _ in range(rng.randint(1, n)))


def _numeric_leaf(rng, data) -> tuple:
    """A numeric leaf: a physical parameter, a time, or a grid value (list or range)."""
    if rng.random() < 0.6:
        return rng.choice(list(NUMERIC))
    axis = rng.choice(AXES)
    ax = data.get("grid", {}).get(axis)
    if isinstance(ax, dict):
        return ("grid", axis, rng.choice(["start", "stop"]))
    if isinstance(ax, list) and ax:
        return ("grid", axis, rng.randrange(len(ax)))
    _set(data, ("grid", axis), [0.5])
    return ("grid", axis, 0)


# --- mutations ---------------------------------------------------------------------------

def m_type(rng, base):
    data = _copy(base)
    path = _numeric_leaf(rng, data)
    good = {"pos": 2.0, "nonneg": 1.0, "unit": 0.5, "gap": 1e-9, "any": 0.0}.get(
        NUMERIC.get(path, "pos"), 0.5)
    value = rng.choice([str(good), str(rng.uniform(-1e6, 1e6)), _text(rng, 30), [good],
                        [rng.uniform(0, 10) for _ in range(rng.randint(1, 3))], {"x": good},
                        True, False, "2024-01-01"])
    _set(data, path, value)
    return Case("type", f"{'.'.join(map(str, path))}={value!r}", "refuse", data, _fmt(rng),
                field=_dotted(path))


def m_nonfinite(rng, base):
    data = _copy(base)
    value = rng.choice([math.nan, math.inf, -math.inf])
    if rng.random() < 0.2:
        key = rng.choice(["rtol", "atol", "step"])
        data["accuracy"] = {"integrator": "rk4" if key == "step" else "dopri5", key: value}
        return Case("nonfinite", f"accuracy={data['accuracy']}", "refuse", data, _fmt(rng),
                    field=f"accuracy.{key}")
    path = _numeric_leaf(rng, data)
    _set(data, path, value)
    return Case("nonfinite", f"{'.'.join(map(str, path))}={value}", "refuse", data, _fmt(rng),
                field=_dotted(path))


def m_num(rng, base):
    data = _copy(base)
    axis = rng.choice(AXES)
    num = rng.choice([0, -1, -2**63, 10**9, 10**12, 10**18, 2**63, 2**64, 10**30,
                      rng.randint(10**7 + 1, 2**200), rng.randint(-2**70, 0),
                      1.5, 3.0, "10", True, 1e300])
    _set(data, ("grid", axis), {"start": 0.1, "stop": 1.0, "num": num})
    fmt = _fmt(rng)
    if fmt == "toml" and isinstance(num, int) and not isinstance(num, bool) and \
            not -2**63 <= num < 2**63:
        fmt = "json"   # TOML integers are 64-bit
    return Case("num", f"grid.{axis}.num={num!r}", "refuse", data, fmt, field=f"grid.{axis}")


def m_product(rng, base):
    """Each axis under the budget, their product far over it (the grid must not be built)."""
    data = _copy(base)
    data["method"] = "averaged" if rng.random() < 0.5 else data.get("method", "simulate")
    for axis in AXES:
        _set(data, ("grid", axis), {"start": 0.1, "stop": 1.0, "num": rng.choice([1000, 200_000])})
    return Case("product", "4 axes", "refuse", data, "toml", field="grid")


def m_deep(rng, base):
    data = _copy(base)
    depth = rng.choice([rng.randint(17, 200), 500, 1000, 5000, 100_000])
    fmt = _fmt(rng)
    where = rng.choice([("grid", "W"), ("params", "sigma0"), ("name",), ("colour",),
                        ("accuracy",)])
    _set(data, where, DEEP)
    return Case("deep", f"{'.'.join(where)} depth {depth}", "refuse", data, fmt,
                deep=(depth, fmt, rng.choice(["list", "table"])), field="nested")


def m_long(rng, base):
    data = _copy(base)
    n = rng.choice([301, 1000, 100_000, 1_000_000])
    s = rng.choice(["x", "é", "\n", "\\", "'", " "]) * n
    where = rng.choice(["literal", "key", "output", "integrator", "scale", "units", "number",
                        "name"])
    if where == "literal":
        path = rng.choice(list(LITERALS))
        _set(data, path, s)
        field = path[0]
    elif where == "key":
        table = rng.choice(["params", "time", "grid"])
        data[table] = {s: 1.0}
        field = table
    elif where == "output":
        data["outputs"], field = [s], "outputs"
    elif where == "integrator":
        data["accuracy"], field = {"integrator": s}, "accuracy.integrator"
    elif where == "scale":
        _set(data, ("grid", "omega"), {"start": 1.0, "stop": 10.0, "num": 3, "scale": s})
        field = "grid.omega"
    elif where == "units":
        data["accuracy"] = {"integrator": "dopri5", "atol_units": s}
        field = "accuracy.atol_units"
    elif where == "name":
        data["name"], field = s, "name"
    else:
        _set(data, ("params", "sigma0"), "1" * n)
        field = "params.sigma0"
    return Case("long", f"{field} ({n} chars)", "refuse", data, _fmt(rng), field=field)


def m_unknown(rng, base):
    data = _copy(base)
    key = rng.choice(["colour", "sigma_0", "W", "t-end", "num", "integrator", "Params",
                      _text(rng, 30)])
    where = rng.choice([(), ("params",), ("time",), ("grid",), ("params", "slow_force")])
    if key in KNOWN_KEYS or not key.strip():
        key = "colour"
    _set(data, (*where, key), rng.choice([1.0, 7, _text(rng, 10)]))
    return Case("unknown", ".".join((*where, key)), "refuse", data, _fmt(rng),
                field=".".join(where) or key[:30])


def m_duplicate(rng, base):
    data = _copy(base)
    axis = rng.choice(AXES)
    kind = rng.choice(["list", "list-int", "range", "log-range", "ulp-range"])
    x = rng.choice([0.1, 0.5, 1.0, 3.0, rng.uniform(0.01, 100.0)])
    if kind == "list":
        value = [x, x] + [rng.uniform(0.01, 100.0) for _ in range(rng.randint(0, 3))]
        rng.shuffle(value)
    elif kind == "list-int":
        value = [1, 1.0, 2.0]
    elif kind == "range":
        value = {"start": x, "stop": x, "num": rng.randint(2, 50)}
    elif kind == "log-range":
        value = {"start": x, "stop": x, "num": 3, "scale": "log"}
    else:   # two adjacent floats, many points: linspace repeats values
        value = {"start": 1.0, "stop": math.nextafter(1.0, 2.0), "num": 5}
    _set(data, ("grid", axis), value)
    return Case("duplicate", f"grid.{axis} {kind}", "refuse", data, _fmt(rng),
                field=f"grid.{axis}")


NUMERICS_OF_ANOTHER_INTEGRATOR = [  # (accuracy, the field named): a setting of another method
    ({"integrator": "rk4", "steps_per_period": 8, "rtol": 1e-6}, "accuracy.rtol"),
    ({"integrator": "rk4", "steps_per_period": 8, "atol": 1e-9}, "accuracy.atol"),
    ({"integrator": "rk4", "steps_per_period": 8, "atol_units": "natural"}, "accuracy.atol_units"),
    ({"integrator": "dopri5", "steps_per_period": 8}, "accuracy.steps_per_period"),
    ({"integrator": "dopri5", "step": 1e-3}, "accuracy.step"),
    ({"integrator": "rosenbrock", "step": 1e-3}, "accuracy.step"),
]

BAD_ACCURACY = [  # (accuracy, the field named)
    ({"integrator": "euler"}, "accuracy.integrator"),
    ({"integrator": ""}, "accuracy.integrator"),
    ({"integrator": "RK4"}, "accuracy.integrator"),
    ({"integrator": "dopri"}, "accuracy.integrator"),
    ({"integrator": 5}, "accuracy.integrator"),
    ({"integrator": None}, "accuracy.integrator"),
    *NUMERICS_OF_ANOTHER_INTEGRATOR,
    ({"integrator": "rodas4", "steps_per_period": 4}, "accuracy.steps_per_period"),
    ({"integrator": "dopri5", "rtol": "1e-6"}, "accuracy.rtol"),
    ({"integrator": "rk4", "steps_per_period": 0}, "accuracy.steps_per_period"),
    ({"integrator": "rk4", "steps_per_period": 2.5}, "accuracy.steps_per_period"),
    ({"integrator": "dopri5", "rtol": 1e-8, "method": "x"}, "accuracy"),
    ({"integrator": "dopri5", "rtol": 1e-20}, "accuracy.rtol"),
    ({"integrator": "dopri5", "rtol": 2.0}, "accuracy.rtol"),
]


def m_integrator(rng, base):
    data = _copy(VALID)   # a simulated, dithered scene: every option below is wrong there
    if rng.random() < 0.3:
        name = _text(rng, 20)
        acc, field = {"integrator": name if name not in INTEGRATORS else "euler"}, \
            "accuracy.integrator"
    else:
        acc, field = rng.choice(BAD_ACCURACY)
    data["accuracy"] = acc
    fmt = "json" if None in acc.values() else _fmt(rng)
    return Case("integrator", json.dumps(acc, ensure_ascii=False), "refuse", data, fmt,
                field=field)


def m_unstable(rng, base):
    """RK4 on the Sec. 7 scene with a sine dither: one or two steps per period is beyond
    RK4's stability bound (h omega = 2 pi, pi > 2.83) whatever the rest."""
    data = _copy(BASE_SEC7)
    n = rng.choice([1, 2])
    data["accuracy"] = {"integrator": "rk4", "steps_per_period": n}
    data["grid"]["W"] = [rng.choice([0.5, 1.0, 2.0])]
    data["grid"]["omega"] = [rng.choice([300.0, 1000.0, 3000.0])]
    return Case("unstable", f"rk4 N={n} W={data['grid']['W']} omega={data['grid']['omega']}",
                "refuse", data, "toml", field="accuracy.steps_per_period")


def m_budget(rng, base):
    data = _copy(BASE_SEC7 if rng.random() < 0.5 else FIG10)
    data["grid"]["omega"] = [rng.choice([1e8, 1e9, 1e12])]
    data["grid"]["W"] = [0.5]
    return Case("budget", f"{data['dither']} omega={data['grid']['omega'][0]:g}", "refuse",
                data, "toml", field="grid.omega")


def m_bytes(rng, base):
    text = to_toml(_copy(base))
    kind = rng.choice(["latin1-name", "random", "bom-utf16", "nul"])
    if kind == "latin1-name":
        raw = text.replace('name = "', 'name = "caf\xe9 ', 1).encode("latin-1", "replace")
    elif kind == "random":
        raw = bytes(rng.randrange(256) for _ in range(rng.choice([10, 1000])))
    elif kind == "bom-utf16":
        raw = text.encode("utf-16")
    else:
        raw = text.encode().replace(b"=", b"\x00=", 1)
    return Case("bytes", kind, "refuse", raw=raw, fmt=_fmt(rng))


def m_toplevel(rng, base):
    value = rng.choice(["[1, 2]", "3", '"spec"', "null", "[]", "true"])
    return Case("toplevel", value, "refuse", raw=value.encode(), fmt="json")


def m_bigint(rng, base):
    data = _copy(base)
    path = rng.choice([("time", "t_end"), ("params", "sigma0"), ("params", "e0")])
    _set(data, path, rng.choice([10**400, -10**400, 2**1024]))
    if path == ("time", "t_end"):
        data.setdefault("time", {})["t_transient"] = 0.0
    return Case("bigint", ".".join(path), "refuse", data, "json", field=".".join(path))


def m_benign(rng, base):
    """Valid changes: an int where a float is expected, reordered keys, a JSON null for
    an optional parameter, explicit numerics within bounds: must be accepted."""
    data = _copy(base)
    kind = rng.choice(["int", "order", "null", "explicit"])
    if kind == "int":
        data.setdefault("time", {}).update({"t_end": 50, "t_transient": 10})
    elif kind == "order":
        data = dict(reversed(list(data.items())))
    elif kind == "null":
        _set(data, ("params", "sigma1"), None)
        return Case("benign", kind, "accept", data, "json")
    elif data.get("method", "simulate") == "simulate":
        data["accuracy"] = rng.choice([{"integrator": "dopri5", "rtol": 1e-7},
                                       {"integrator": "rk4", "steps_per_period": 256}])
    return Case("benign", kind, "accept", data, _fmt(rng))


MUTATIONS = [m_type, m_nonfinite, m_num, m_product, m_deep, m_long, m_unknown, m_duplicate,
             m_integrator, m_unstable, m_budget, m_bytes, m_toplevel, m_bigint, m_benign]
BASE_SEC7 = tomllib.loads((ROOT / "specs" / "fig14.toml").read_text())
BASE_SEC7["grid"] = {"W": [1.0], "omega": [3000.0], "v_ref": [0.1], "v_d": [0.1]}
FIG10 = tomllib.loads((ROOT / "specs" / "fig10.toml").read_text())


