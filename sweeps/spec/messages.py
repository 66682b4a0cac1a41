"""How a refused spec is worded: every echoed value short and in plain Python
(:func:`show`), and each pydantic fault as one line naming the field, the value received
and what is allowed (:func:`format_error`; sweeps.spec.load)."""
from __future__ import annotations

import math
import reprlib

ECHO_CHARS = 80                   # an echoed value is cut to this many characters


_ECHO = reprlib.Repr()
_ECHO.maxstring, _ECHO.maxother, _ECHO.maxlong = ECHO_CHARS - 4, ECHO_CHARS - 4, 40
_ECHO.maxlist = _ECHO.maxtuple = _ECHO.maxdict = _ECHO.maxset = 6
_ECHO.maxlevel = 3


def show(value) -> str:
    """``value`` as a short plain-Python repr for a message: numpy scalars as Python
    numbers, strings and containers cut to about :data:`ECHO_CHARS` characters."""
    if hasattr(value, "dtype") and hasattr(value, "item") and getattr(value, "ndim", 1) == 0:
        value = value.item()          # np.float64(-100.0) -> -100.0
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 128:
        return f"an integer of {int(value.bit_length() * math.log10(2)) + 1} digits"
    try:
        text = _ECHO.repr(value)
    except Exception:  # noqa: BLE001 -- an odd object from the Python API
        text = f"<{type(value).__name__}>"
    return text if len(text) <= ECHO_CHARS else text[:ECHO_CHARS - 3] + "..."


_TAGS = ("list", "range", "level", "explicit")
_MESSAGES = {  # pydantic's wording -> ours, by error type
    "float_type": "must be a valid number", "int_type": "must be a valid integer",
    "string_type": "must be a string", "bool_type": "must be true or false",
    "finite_number": "must be a finite number (no NaN or infinity)",
    "model_type": "must be a table of keys", "dict_type": "must be a table of keys",
    "model_attributes_type": "must be a table of keys",
    "list_type": "must be a list", "int_from_float": "must be a valid integer",
}


def format_loc(parts) -> str:
    """``grid.W.start`` from pydantic's loc, each part cut short (keys may be long)."""
    names = []
    for part in parts:
        if part in _TAGS:
            continue
        text = str(part)
        names.append(text if len(text) <= 40 else show(text))
    return ".".join(names)


def format_error(err: dict) -> str:
    loc = format_loc(err["loc"])
    value = err.get("input")
    kind = err["type"]
    msg = err["msg"].removeprefix("Value error, ").replace("Input should be", "must be")
    if kind == "too_short":
        return f"{loc}: needs at least one value, got {show(value)}"
    if kind == "extra_forbidden":
        return f"{loc}: unknown key (check the spelling; see docs/SPEC.md)"
    if kind == "missing":
        return f"{loc}: missing (a range needs start, stop and num)" if ".grid." in f".{loc}" \
            else f"{loc}: missing"
    if kind == "literal_error":
        return f"{loc}: got {show(value)}; {msg.lower()}"
    if kind == "value_error":
        if loc and (msg.startswith(f"{loc}:") or msg.startswith(f"{loc} '")):
            # a model's own line (engine.registry) names its field already
            return msg
        if not loc and msg.startswith("params"):
            return msg
        return f"{loc or 'spec'}: {msg}"
    parts = loc.split(".")
    if parts[0] == "grid" and (len(parts) == 2 or len(parts) == 3 and parts[2].isdigit()) \
            and kind in ("list_type", "float_type", "finite_number", "model_type"):
        what = "finite numbers" if kind == "finite_number" else "numbers"
        return (f"{loc}: an axis is a list of {what} or a range {{start, stop, num, scale}}, "
                f"got {show(value)}")
    if kind in _MESSAGES:
        return f"{loc or 'spec'}: {_MESSAGES[kind]}, got {show(value)}"
    return f"{loc or 'spec'}: {msg[:1].lower()}{msg[1:]}, got {show(value)}"
