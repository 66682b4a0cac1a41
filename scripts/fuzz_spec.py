#!/usr/bin/env python
"""Fuzz the sweep-spec validator (issues 9 and 10): mutations of valid specs, written as
TOML or JSON files, each through ``sweeps.spec.load_spec`` and, when refused, through
``ditherlab plan`` (``sweeps.cli.main`` in-process) against an empty temporary store.

Every case must end in a refusal (``SpecError``: exit 2, one line per fault, each under
300 characters and naming the field, no numpy reprs, nothing written to the store) or in
an accepted spec that plans (``make_plan``) and builds its empty cube; never in another
exception, never slower than 1 s, never growing memory. Cases whose mutation is invalid by
construction (NaN, a string for a number, a repeated grid value, an unknown integrator,
...) must be refused; a few benign mutations must be accepted.

    .venv/bin/python scripts/fuzz_spec.py [--n 1000] [--seed 1] [--show 5]

Prints counts per category and outcome, then the first ``--show`` faults of each kind.
The process runs under a 4 GiB address-space limit, so a validator that builds a huge
grid fails with MemoryError (counted as a traceback) instead of taking the machine.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import random
import re
import resource
import signal
import sys
import tempfile
import time
import tomllib
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SPECS = sorted((ROOT / "specs").glob("*.toml"))
MINIMAL = {"name": "t", "grid": {"W": {"start": 0.0, "stop": 3.0, "num": 4}, "omega": [100.0]}}

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
AXES = ("W", "omega", "v_ref", "v_d")
DEEP = "__DEEP__"


# --- writing specs as files ----------------------------------------------------------

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)


def to_toml(data: dict) -> str:
    lines = [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in data.items()
             if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines.append(f"[{_toml_key(k)}]")
            lines += [f"{_toml_key(kk)} = {_toml_value(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


def deep_text(depth: int, fmt: str, kind: str) -> str:
    if kind == "list":
        return "[" * depth + "1" + "]" * depth
    if fmt == "json":
        return '{"a": ' * depth + "1" + "}" * depth
    return "{ a = " * depth + "1" + " }" * depth


class Case:
    def __init__(self, category: str, label: str, expect: str, data=None, fmt="toml",
                 raw: bytes | None = None, deep: tuple | None = None):
        self.category, self.label, self.expect = category, label, expect
        self.data, self.fmt, self.raw, self.deep = data, fmt, raw, deep

    def payload(self) -> bytes:
        if self.raw is not None:
            return self.raw
        text = (json.dumps(self.data) if self.fmt == "json" else to_toml(self.data))
        if self.deep is not None:
            text = text.replace(json.dumps(DEEP), deep_text(*self.deep), 1)
        return text.encode()


# --- mutations ---------------------------------------------------------------------------

def _copy(d):
    return json.loads(json.dumps(d))


def _set(data: dict, path: tuple, value) -> None:
    node = data
    for key in path[:-1]:
        if not isinstance(node.get(key), dict):
            node[key] = {}
        node = node[key]
    node[path[-1]] = value


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


def _put(data, path, value):
    if isinstance(path[-1], int):
        node = data
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    else:
        _set(data, path, value)


def m_type(rng, base):
    data = _copy(base)
    path = _numeric_leaf(rng, data)
    good = {"pos": 2.0, "nonneg": 1.0, "unit": 0.5, "gap": 1e-9, "any": 0.0}.get(
        NUMERIC.get(path, "pos"), 0.5)
    choice = rng.choice(["str-number", "str", "list", "table", "bool", "date"])
    value = {"str-number": str(good), "str": "abc", "list": [good], "table": {"x": good},
             "bool": True, "date": "2024-01-01"}[choice]
    _put(data, path, value)
    return Case("type", f"{'.'.join(map(str, path))}={value!r}", "refuse", data,
                rng.choice(["toml", "json"]))


def m_nonfinite(rng, base):
    data = _copy(base)
    if rng.random() < 0.2:
        data["accuracy"] = {"integrator": "dopri5",
                            rng.choice(["rtol", "atol"]): rng.choice([math.inf, math.nan])}
        return Case("nonfinite", f"accuracy={data['accuracy']}", "refuse", data, "toml")
    path = _numeric_leaf(rng, data)
    value = rng.choice([math.nan, math.inf, -math.inf])
    _put(data, path, value)
    return Case("nonfinite", f"{'.'.join(map(str, path))}={value}", "refuse", data,
                rng.choice(["toml", "json"]))


def m_num(rng, base):
    data = _copy(base)
    axis = rng.choice(AXES)
    num = rng.choice([0, -1, -2**63, 10**6, 10**9, 10**12, 10**18, 2**63, 2**64, 10**30,
                      1.5, 3.0, "10", True, 1e300])
    _set(data, ("grid", axis), {"start": 0.1, "stop": 1.0, "num": num})
    fmt = rng.choice(["toml", "json"])
    if fmt == "toml" and isinstance(num, int) and not isinstance(num, bool) and \
            not -2**63 <= num < 2**63:
        fmt = "json"   # TOML integers are 64-bit
    return Case("num", f"grid.{axis}.num={num!r}", "refuse", data, fmt)


def m_product(rng, base):
    """Each axis under the budget, their product far over it (the grid must not be built)."""
    data = _copy(base)
    data["method"] = "averaged" if rng.random() < 0.5 else data.get("method", "simulate")
    for axis in AXES:
        _set(data, ("grid", axis), {"start": 0.1, "stop": 1.0, "num": rng.choice([1000, 200_000])})
    return Case("product", "4 axes", "refuse", data, "toml")


def m_deep(rng, base):
    data = _copy(base)
    depth = rng.choice([64, 500, 1000, 5000, 100_000])
    fmt = rng.choice(["toml", "json"])
    where = rng.choice([("grid", "W"), ("params", "sigma0"), ("name",), ("colour",),
                        ("accuracy",)])
    _set(data, where, DEEP)
    return Case("deep", f"{'.'.join(where)} depth {depth}", "refuse", data, fmt,
                deep=(depth, fmt, rng.choice(["list", "table"])))


def m_long(rng, base):
    data = _copy(base)
    n = rng.choice([1000, 100_000, 1_000_000])
    s = rng.choice(["x", "é", "\n", "\\", "'"]) * n
    where = rng.choice(["literal", "key", "output", "integrator", "scale", "units", "number"])
    if where == "literal":
        path = rng.choice(list(LITERALS))
        _set(data, path, s)
        label = path[0]
    elif where == "key":
        data[rng.choice(["params", "time", "grid"])] = {s: 1.0}
        label = "key"
    elif where == "output":
        data["outputs"] = [s]
        label = "outputs"
    elif where == "integrator":
        data["accuracy"] = {"integrator": s}
        label = "accuracy.integrator"
    elif where == "scale":
        _set(data, ("grid", "omega"), {"start": 1.0, "stop": 10.0, "num": 3, "scale": s})
        label = "grid.omega.scale"
    elif where == "units":
        data["accuracy"] = {"integrator": "dopri5", "atol_units": s}
        label = "accuracy.atol_units"
    else:
        _set(data, ("params", "sigma0"), "1" * n)
        label = "params.sigma0"
    return Case("long", f"{label} ({n} chars)", "refuse", data, rng.choice(["toml", "json"]))


def m_unknown(rng, base):
    data = _copy(base)
    key = rng.choice(["colour", "sigma_0", "W", "t-end", "num", "integrator", "Params"])
    where = rng.choice([(), ("params",), ("time",), ("grid",), ("params", "slow_force")])
    _set(data, (*where, key), 1.0)
    return Case("unknown", ".".join((*where, key)), "refuse", data, rng.choice(["toml", "json"]))


def m_duplicate(rng, base):
    data = _copy(base)
    axis = rng.choice(AXES)
    kind = rng.choice(["list", "list-int", "range", "log-range", "ulp-range"])
    x = rng.choice([0.1, 0.5, 1.0, 3.0])
    if kind == "list":
        value = [x, 2 * x, x]
    elif kind == "list-int":
        value = [1, 1.0, 2.0]
    elif kind == "range":
        value = {"start": x, "stop": x, "num": rng.choice([2, 5])}
    elif kind == "log-range":
        value = {"start": x, "stop": x, "num": 3, "scale": "log"}
    else:   # two adjacent floats, many points: linspace repeats values
        value = {"start": 1.0, "stop": math.nextafter(1.0, 2.0), "num": 5}
    _set(data, ("grid", axis), value)
    return Case("duplicate", f"grid.{axis} {kind}", "refuse", data, rng.choice(["toml", "json"]))


def m_integrator(rng, base):
    data = _copy(base)
    data["method"] = "simulate"
    if data.get("system") == "contact":
        data["system"], data["friction"] = "slider", "lugre"
    bad = rng.choice([
        {"integrator": "euler"}, {"integrator": ""}, {"integrator": "RK4"},
        {"integrator": "dopri"}, {"integrator": 5}, {"integrator": None},
        {"integrator": "rk4", "rtol": 1e-6}, {"integrator": "rk4", "atol": 1e-9},
        {"integrator": "rk4", "atol_units": "natural"},
        {"integrator": "dopri5", "steps_per_period": 8}, {"integrator": "dopri5", "step": 1e-3},
        {"integrator": "rosenbrock", "step": 1e-3},
        {"integrator": "rodas4", "steps_per_period": 4},
        {"integrator": "dopri5", "rtol": "1e-6"}, {"integrator": "rk4", "steps_per_period": 0},
        {"integrator": "rk4", "steps_per_period": 2.5},
        {"integrator": "dopri5", "rtol": 1e-8, "method": "x"}])
    data["accuracy"] = bad
    return Case("integrator", json.dumps(bad), "refuse", data, "json" if None in
                bad.values() else rng.choice(["toml", "json"]))


def m_unstable(rng, base):
    """RK4 on the Sec. 7 scene with a sine dither: one or two steps per period is beyond
    RK4's stability bound (h omega = 2 pi, pi > 2.83) whatever the rest."""
    data = _copy(BASE_SEC7)
    n = rng.choice([1, 2])
    data["accuracy"] = {"integrator": "rk4", "steps_per_period": n}
    data["grid"]["W"] = [rng.choice([0.5, 1.0, 2.0])]
    data["grid"]["omega"] = [rng.choice([300.0, 1000.0, 3000.0])]
    return Case("unstable", f"rk4 N={n} W={data['grid']['W']} omega={data['grid']['omega']}",
                "refuse", data, "toml")


def m_budget(rng, base):
    data = _copy(BASE_SEC7 if rng.random() < 0.5 else FIG10)
    data["grid"]["omega"] = [rng.choice([1e8, 1e9, 1e12])]
    data["grid"]["W"] = [0.5]
    return Case("budget", f"{data['dither']} omega={data['grid']['omega'][0]:g}", "refuse",
                data, "toml")


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
    return Case("bytes", kind, "refuse", raw=raw, fmt=rng.choice(["toml", "json"]))


def m_toplevel(rng, base):
    value = rng.choice(["[1, 2]", "3", '"spec"', "null", "[]", "true"])
    return Case("toplevel", value, "refuse", raw=value.encode(), fmt="json")


def m_bigint(rng, base):
    data = _copy(base)
    path = rng.choice([("time", "t_end"), ("params", "sigma0"), ("params", "e0")])
    _set(data, path, rng.choice([10**400, -10**400, 2**1024]))
    if path == ("time", "t_end"):
        data.setdefault("time", {})["t_transient"] = 0.0
    return Case("bigint", ".".join(path), "refuse", data, "json")


def m_benign(rng, base):
    """Valid changes: an int where a float is expected, reordered keys, a JSON null for
    an optional parameter: must be accepted."""
    data = _copy(base)
    kind = rng.choice(["int", "order", "null", "explicit"])
    if kind == "int":
        data.setdefault("time", {}).update({"t_end": 50, "t_transient": 10})
    elif kind == "order":
        data = dict(reversed(list(data.items())))
    elif kind == "null":
        _set(data, ("params", "sigma1"), None)
        return Case("benign", kind, "accept", data, "json")
    elif data.get("method") == "simulate":
        data["accuracy"] = rng.choice([{"integrator": "dopri5", "rtol": 1e-7},
                                       {"integrator": "rk4", "steps_per_period": 256}])
        if data.get("dither") == "none" or data["accuracy"]["integrator"] == "dopri5":
            pass
    return Case("benign", kind, "accept", data, rng.choice(["toml", "json"]))


MUTATIONS = [m_type, m_nonfinite, m_num, m_product, m_deep, m_long, m_unknown, m_duplicate,
             m_integrator, m_unstable, m_budget, m_bytes, m_toplevel, m_bigint, m_benign]
BASE_SEC7 = tomllib.loads((ROOT / "specs" / "fig14.toml").read_text())
BASE_SEC7["grid"] = {"W": [1.0], "omega": [3000.0], "v_ref": [0.1], "v_d": [0.1]}
FIG10 = tomllib.loads((ROOT / "specs" / "fig10.toml").read_text())


# --- running -----------------------------------------------------------------------------

class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang("over 20 s")


FIELD = re.compile(r"^(ditherlab: )?(/|(spec|name|description|system|friction|dither|method|"
                   r"outputs|accuracy|params|time|grid|block_size|colour|sigma_0|W|t-end|num|"
                   r"integrator|Params)[.:])")


def run_case(case: Case, tmp: Path, index: int) -> dict:
    from sweeps import cli
    from sweeps.run.new_cube import empty_cube
    from sweeps.planning.plan import make_plan
    from sweeps.spec import SpecError, load_spec

    path = tmp / f"case{index}.{case.fmt}"
    path.write_bytes(case.payload())
    out = {"case": case, "faults": []}
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    signal.alarm(20)
    t0 = time.perf_counter()
    try:
        with _captured_warnings() as caught:
            spec = load_spec(path)
        out["seconds"] = time.perf_counter() - t0
        out["outcome"] = "accepted"
        out["warnings"] = caught
        try:
            empty_cube(make_plan(spec))
        except Exception as exc:  # noqa: BLE001
            out["faults"].append(f"accepted, then make_plan/empty_cube: {type(exc).__name__}: "
                                 f"{str(exc)[:120]}")
    except SpecError as exc:
        out["seconds"] = time.perf_counter() - t0
        out["outcome"] = "refused"
        out["lines"] = exc.problems
    except BaseException as exc:  # noqa: BLE001 -- what the fuzzer is for
        if isinstance(exc, KeyboardInterrupt):
            raise
        out["seconds"] = time.perf_counter() - t0
        out["outcome"] = "traceback"
        out["error"] = f"{type(exc).__name__}: {str(exc)[:120]}"
    finally:
        signal.alarm(0)
    out["rss_growth_mb"] = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024
    if out["seconds"] > 1.0:
        out["faults"].append(f"slow: {out['seconds']:.2f} s")
    if out["rss_growth_mb"] > 200:
        out["faults"].append(f"memory: peak grew {out['rss_growth_mb']:.0f} MB")
    if out["outcome"] == "traceback":
        out["faults"].append(f"traceback: {out['error']}")
    if case.expect == "refuse" and out["outcome"] == "accepted":
        out["faults"].append("accepted an invalid spec")
    if case.expect == "accept" and out["outcome"] == "refused":
        out["faults"].append(f"refused a valid spec: {out['lines'][0][:150]}")
    for line in out.get("lines", ()):
        if len(line) > 300:
            out["faults"].append(f"line of {len(line)} chars: {line[:80]}...")
        if "np.float" in line or "np.int" in line or "array(" in line:
            out["faults"].append(f"numpy repr: {line[:150]}")
        if not FIELD.match(line):
            out["faults"].append(f"no field named: {line[:150]}")
    if out["outcome"] == "refused":
        store = tmp / f"store{index}"
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            rc = cli.main(["plan", str(path), "--store", str(store)])
        if rc != 2:
            out["faults"].append(f"cli plan exit {rc}: {err.getvalue()[:150]}")
        if store.exists() and any(store.iterdir()):
            out["faults"].append("cli plan wrote to the store")
        lines = err.getvalue().splitlines()
        if not lines or lines[0] != "ditherlab: invalid sweep spec:":
            out["faults"].append(f"cli: unexpected first line {lines[:1]}")
    return out


@contextlib.contextmanager
def _captured_warnings():
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield caught


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000, help="number of specs (default 1000)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--show", type=int, default=5, help="faults shown per kind")
    args = ap.parse_args(argv)
    limit = 4 * 2**30
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    signal.signal(signal.SIGALRM, _alarm)
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 1000))

    bases = [tomllib.loads(p.read_text()) for p in SPECS] + [MINIMAL]
    rng = random.Random(args.seed)
    results = []
    by_kind = defaultdict(list)
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="fuzz-spec-") as tmpdir:
        for i in range(args.n):
            mutate = MUTATIONS[i % len(MUTATIONS)]
            case = mutate(rng, rng.choice(bases))
            res = run_case(case, Path(tmpdir), i)
            results.append(res)
            for fault in res["faults"]:
                by_kind[re.sub(r"\d+", "N", fault.split(":")[0])].append((case, fault))
            (Path(tmpdir) / f"case{i}.{case.fmt}").unlink()
    table = Counter((r["case"].category, r["outcome"]) for r in results)
    cats = sorted({r["case"].category for r in results})
    print(f"{len(results)} specs in {time.perf_counter() - t_start:.1f} s "
          f"(seed {args.seed})\n")
    print(f"{'category':<12}{'accepted':>10}{'refused':>10}{'traceback':>11}{'faulty':>8}")
    for c in cats:
        faulty = sum(1 for r in results if r["case"].category == c and r["faults"])
        print(f"{c:<12}{table[(c, 'accepted')]:>10}{table[(c, 'refused')]:>10}"
              f"{table[(c, 'traceback')]:>11}{faulty:>8}")
    outcomes = Counter(r["outcome"] for r in results)
    print(f"{'total':<12}{outcomes['accepted']:>10}{outcomes['refused']:>10}"
          f"{outcomes['traceback']:>11}{sum(1 for r in results if r['faults']):>8}\n")
    slowest = max(results, key=lambda r: r["seconds"])
    print(f"slowest: {slowest['seconds']:.3f} s ({slowest['case'].category}: "
          f"{slowest['case'].label[:60]})")
    longest = max((len(line) for r in results for line in r.get("lines", ())), default=0)
    print(f"longest message line: {longest} chars")
    warned = [r for r in results if r.get("warnings")]
    print(f"accepted with a warning: {len(warned)}")
    kinds = Counter(r["error"].split(":")[0] for r in results if r["outcome"] == "traceback")
    if kinds:
        print("tracebacks: " + ", ".join(f"{k} {n}" for k, n in kinds.most_common()))
    print("\nfaults by kind:")
    for kind, items in sorted(by_kind.items(), key=lambda kv: -len(kv[1])):
        print(f"  {kind}: {len(items)}")
        for case, fault in items[:args.show]:
            print(f"      [{case.category}: {case.label[:60]}] {fault[:160]}")
    return 1 if any(r["faults"] for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
