"""Mutated sweep specs as cases (issue 10): :class:`Case` (a spec, how it is written, what
must happen to it), writing it as a TOML or JSON file, and :func:`check`, which runs one
case through ``load_spec`` and ``ditherlab plan`` / ``submit`` and returns its faults (an
empty list is a pass). The mutations that make cases: tests/sweeps/spec/spec_mutations.py;
they drive tests/sweeps/spec/test_spec_fuzz.py (hypothesis) and scripts/fuzz_spec.py (a seeded
``random.Random``, many more cases)."""
from __future__ import annotations

import contextlib
import json
import math
import re
import resource
import tomllib
from pathlib import Path

from ...helpers import cpu_seconds

ROOT = Path(__file__).resolve().parents[3]
SPECS = sorted((ROOT / "specs").glob("*.toml"))
MINIMAL = {"name": "t", "grid": {"W": {"start": 0.0, "stop": 3.0, "num": 4}, "omega": [100.0]}}
# the Sec. 7 scene at small size (elastoplastic, sine dither): where the stability bound and
# the step budget bite
VALID = {
    "name": "fuzz", "friction": "elastoplastic", "dither": "sine-velocity",
    "method": "simulate", "outputs": ["F_mean", "stick_fraction"], "accuracy": "draft",
    "params": {"sigma0": 100.0, "lam": 0.8, "slow_force": {"amplitude": 1.7, "omega": 0.3}},
    "time": {"t_end": 50.0, "t_transient": 10.0},
    "grid": {"W": {"start": 0.0, "stop": 3.0, "num": 4},
             "omega": {"start": 10.0, "stop": 1000.0, "num": 3, "scale": "log"},
             "v_ref": [0.1], "v_d": [0.1]},
}

DEEP = "__DEEP__"
# a refusal's line names a field (or the file, or says what is wrong with it as a whole)
FIELD = re.compile(r"^(ditherlab: )?(/|(spec|name|description|system|friction|dither|method|"
                   r"outputs|accuracy|params|time|grid|block_size|refine|colour|sigma_0|W|"
                   r"t-end|num|integrator|Params)[.:])")


class Case:
    """One mutated spec: ``expect`` "refuse" or "accept"; ``field`` the prefix a refusal's
    line must start with ("nested" for deep nesting: a line must say so; None: any field)."""

    def __init__(self, category: str, label: str, expect: str, data=None, fmt="toml",
                 raw: bytes | None = None, deep: tuple | None = None, field: str | None = None):
        self.category, self.label, self.expect, self.field = category, label, expect, field
        self.data, self.fmt, self.raw, self.deep = data, fmt, raw, deep

    def __repr__(self) -> str:
        return f"Case({self.category}: {self.label[:80]}, {self.fmt}, expect {self.expect})"

    def payload(self) -> bytes:
        if self.raw is not None:
            return self.raw
        text = (json.dumps(self.data) if self.fmt == "json" else to_toml(self.data))
        if self.deep is not None:
            text = text.replace(json.dumps(DEEP), deep_text(*self.deep), 1)
        return text.encode()


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
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k, ensure_ascii=False)


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


def bases() -> list[dict]:
    """The valid specs mutated: the shipped figure specs, a minimal one and :data:`VALID`."""
    return [tomllib.loads(p.read_text()) for p in SPECS] + [MINIMAL, VALID]


# --- checking one case ---------------------------------------------------------------------

def check(case: Case, tmp: Path, index: int = 0, commands=("plan",)) -> dict:
    """Run ``case``; returns ``{"case", "outcome", "faults", "cpu_s", ...}``. Faults: another
    exception than SpecError, an invalid spec accepted or a valid one refused, a refusal
    line over MAX_LINE, with a numpy repr or naming no (or not the mutated) field, over 1 s
    of CPU, an accepted spec that does not plan, and for each CLI ``commands`` an exit
    status other than 2, another first line, or anything written to the store."""
    from sweeps.run.new_cube import empty_cube
    from sweeps.errors import MAX_LINE
    from sweeps.planning.plan import make_plan
    from sweeps.spec import SpecError, load_spec

    path = tmp / f"case{index}.{case.fmt}"
    path.write_bytes(case.payload())
    out = {"case": case, "faults": []}
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with cpu_seconds() as spent:   # CPU seconds: no machine load inflates them
        try:
            with _captured_warnings() as caught:
                spec = load_spec(path)
            out["outcome"], out["warnings"] = "accepted", caught
        except SpecError as exc:
            out["outcome"], out["lines"] = "refused", exc.problems
        except (KeyboardInterrupt, SystemExit):
            raise
        except BaseException as exc:  # noqa: BLE001 -- what the fuzzer is for
            out["outcome"], out["error"] = "traceback", f"{type(exc).__name__}: {str(exc)[:120]}"
    out["cpu_s"] = spent()
    out["rss_growth_mb"] = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024
    faults = out["faults"]
    if out["outcome"] == "accepted":
        try:
            empty_cube(make_plan(spec))
        except Exception as exc:  # noqa: BLE001
            faults.append(f"accepted, then make_plan/empty_cube: {type(exc).__name__}: "
                          f"{str(exc)[:120]}")
    if out["cpu_s"] > 1.0:
        faults.append(f"slow: {out['cpu_s']:.2f} s of CPU")
    if out["rss_growth_mb"] > 200:
        faults.append(f"memory: peak grew {out['rss_growth_mb']:.0f} MB")
    if out["outcome"] == "traceback":
        faults.append(f"traceback: {out['error']}")
    if case.expect == "refuse" and out["outcome"] == "accepted":
        faults.append("accepted an invalid spec")
    if case.expect == "accept" and out["outcome"] == "refused":
        faults.append(f"refused a valid spec: {out['lines'][0][:150]}")
    lines = out.get("lines", [])
    if out["outcome"] == "refused" and not lines:
        faults.append("refused without a line")
    for line in lines:
        if len(line) > MAX_LINE:
            faults.append(f"line of {len(line)} chars: {line[:80]}...")
        if "np.float" in line or "np.int" in line or "array(" in line:
            faults.append(f"numpy repr: {line[:150]}")
        if case.field is None and not FIELD.match(line):
            faults.append(f"no field named: {line[:150]}")
    if lines and case.field == "nested" and not any("nested" in line for line in lines):
        faults.append(f"deep nesting not named: {lines[0][:150]}")
    elif lines and case.field not in (None, "nested") and \
            not any(line.startswith((case.field, "/")) for line in lines):   # or the file
        faults.append(f"{case.field} not named: {lines[0][:150]}")
    if out["outcome"] == "refused":
        for command in commands:
            faults += _cli_faults(command, path, tmp / f"store{index}")
    return out


def _cli_faults(command: str, path: Path, store: Path) -> list[str]:
    from ...helpers import in_process

    rc, _, err = in_process(command, path, "--store", store)
    faults = []
    if rc != 2:
        faults.append(f"cli {command} exit {rc}: {err[:150]}")
    if store.exists():
        faults.append(f"cli {command} wrote to the store: {sorted(store.rglob('*'))[:3]}")
    lines = err.splitlines()
    if not lines or lines[0] != "ditherlab: invalid sweep spec:":
        faults.append(f"cli {command}: unexpected first line {lines[:1]}")
    return faults


@contextlib.contextmanager
def _captured_warnings():
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield caught
