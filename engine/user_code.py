"""Loading the code a user brings (engine.registry) and wording its faults in one line.

A module named by import path (``pkg.module``, found from the current folder too, as
``python -m`` would) or by file (``path/file.py``, imported under a name made from its
path); any exception while importing it becomes a :class:`ModelError` naming the module, the
exception and the user's file and line (:func:`where`), never a traceback.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
import traceback
from pathlib import Path

from .contract import ModelError


def import_module(kind: str, ref: str, module_name: str):
    try:
        if module_name.endswith(".py") or "/" in module_name:
            path = Path(module_name)
            if not path.is_file():
                raise ModelError(f"{kind} {ref!r}: no file {module_name!r}")
            name = "ditherlab_user_" + hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:12]
            if name in sys.modules:
                return sys.modules[name]
            spec = importlib.util.spec_from_file_location(name, path)
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            try:
                spec.loader.exec_module(module)
            except BaseException:
                del sys.modules[name]
                raise
            return module
        try:
            return importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            # `ditherlab` started from a project folder: its packages are importable from
            # there, as with `python -m` (the console script's sys.path lacks the folder)
            here = str(Path.cwd())
            if here in sys.path or exc.name is None or \
                    exc.name.split(".")[0] != module_name.split(".")[0]:
                raise
            sys.path.append(here)
            return importlib.import_module(module_name)
    except ModelError:
        raise
    except SyntaxError as exc:
        raise ModelError(f"{kind} {ref!r}: cannot import {module_name!r}: SyntaxError "
                         f"({exc.msg}) at {Path(exc.filename or '?').name} line {exc.lineno}") \
            from None
    except Exception as exc:   # noqa: BLE001  (user code: any fault is one line)
        raise ModelError(f"{kind} {ref!r}: cannot import {module_name!r}: {one_line(exc)}"
                         f"{where(exc)}") from None


def short(value, limit: int = 60) -> str:
    """``repr(value)`` cut to about ``limit`` characters (an echoed spec value)."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return f"{type(exc).__name__}: {text[:200]}"


def where(exc: BaseException, module=None) -> str:
    """' (at file.py line N)' for the innermost frame outside ditherlab and the stdlib."""
    frames = traceback.extract_tb(exc.__traceback__)
    ours = Path(__file__).resolve().parent.parent
    for frame in reversed(frames):
        path = Path(frame.filename)
        if "importlib" in frame.filename or ours in path.resolve().parents:
            continue
        return f" (at {path.name} line {frame.lineno})"
    return ""
