"""netCDF-safe attributes: which values HDF5/netCDF accepts and how the rest is stored.

netCDF attributes are strings, numbers or 1-D numeric arrays. h5netcdf refuses
booleans (``CompatibilityError: boolean dtypes are not a supported NetCDF feature``,
checked with h5netcdf 1.8) and cannot store dicts, lists of strings or ``None``.
Every such value is therefore stored as a canonical JSON string (sorted keys, no
spaces) — the same form as the sweep spec — and ``decode`` turns it back.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import numpy as np

# Conventional global attributes of a cube (DESIGN.md §4). The caller supplies them;
# store.cube fills CREATED, VERSION and CONVENTIONS when they are missing.
SWEEP_ID = "sweep_id"  # the hash of the canonical spec
NAME = "name"  # the spec's human name
SPEC = "spec"  # the spec as canonical JSON
VERSION = "ditherlab_version"  # package version that computed the cube
FINGERPRINT = "engine_fingerprint"  # hash of the engine sources that computed it
CREATED = "created"  # UTC ISO-8601 creation time
SETTINGS = "engine_settings"  # engine settings actually used (JSON)
CONVENTIONS = "Conventions"


def canonical_json(value: Any) -> str:
    """JSON with sorted keys and no whitespace: equal values give equal strings."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=_jsonable)


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"attribute value of type {type(value).__name__} is not JSON-serialisable")


def _is_plain_scalar(value: Any) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return False
    return isinstance(value, (str, int, float, np.integer, np.floating))


def encode(attrs: Mapping[str, Any] | None) -> dict[str, Any]:
    """Attributes ready for netCDF: strings and numbers kept, everything else as JSON.

    Parameters
    ----------
    attrs
        Any mapping of attribute name (str) to value.

    Returns
    -------
    dict
        Same keys; bools, ``None``, dicts, lists, tuples and arrays become canonical
        JSON strings (``True`` -> ``"true"``).
    """
    out = {}
    for key, value in (attrs or {}).items():
        if not isinstance(key, str) or not key:
            raise ValueError(f"attribute names must be non-empty strings, got {key!r}")
        out[key] = value if _is_plain_scalar(value) else canonical_json(value)
    return out


def decode(value: Any) -> Any:
    """Inverse of ``encode`` for one value: parse JSON text, pass anything else through."""
    if isinstance(value, str):
        try:
            return json.loads(value)
        except ValueError:
            return value
    return value


decode_attr = decode   # the name store re-exports (``store.decode_attr``)


def accuracy_warnings(attrs: Mapping) -> list[str]:
    """The accuracy warnings a cube's ``error_estimate`` attribute records (none: [])."""
    raw = attrs.get("error_estimate")
    if not raw:
        return []
    try:
        est = json.loads(raw) if isinstance(raw, str) else raw
    except ValueError:
        return []
    return [str(w) for w in est.get("warnings", [])]
