"""A spec (plain data) written as TOML, for the pages: the sweep page shows its spec this
way and the explorer's "submit this as a sweep" shows the TOML to paste into a file.
Top-level values first, then one ``[table]`` per dict, nested dicts as inline tables, as
the specs in ``sweeps/specs/`` are written."""
from __future__ import annotations

import json
import math


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        return ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)   # a TOML basic string is a JSON string
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def _key(k: str) -> str:
    return k if k.replace("_", "").replace("-", "").isalnum() and k.isascii() else json.dumps(k)


def _drop_none(v):
    if isinstance(v, dict):
        return {k: _drop_none(x) for k, x in v.items() if x is not None and x != {}}
    return v


def spec_toml(spec: dict) -> str:
    """``spec`` (a spec dict, None meaning "the default") as TOML text."""
    spec = _drop_none(spec)
    lines, tables = [], []
    for k, v in spec.items():
        (tables if isinstance(v, dict) else lines).append((k, v))
    out = [f"{_key(k)} = {_value(v)}" for k, v in lines]
    for k, table in tables:
        out += ["", f"[{_key(k)}]"] + [f"{_key(n)} = {_value(x)}" for n, x in table.items()]
    return "\n".join(out) + "\n"
