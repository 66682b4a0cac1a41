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
import numbers
import os
import sys
import traceback
from pathlib import Path

from .contract import ModelError

# what user code may raise that ends in one line (a ModelError): any exception, and a
# sys.exit(), which would otherwise end `ditherlab` silently with the code it names
USER_FAULTS = (Exception, SystemExit)


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
    except USER_FAULTS as exc:   # user code: any fault, sys.exit too, is one line
        raise ModelError(f"{kind} {ref!r}: cannot import {module_name!r}: {one_line(exc)}"
                         f"{where(exc)}") from None


def short(value, limit: int = 60) -> str:
    """``repr(value)`` cut to about ``limit`` characters (an echoed spec value)."""
    try:
        text = repr(value)
    except Exception:   # noqa: BLE001  (a user's __repr__, or an int past str's digit limit)
        text = f"<a {type(value).__name__}>"
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


def hook(ref: str, what: str, fn, *args, count: bool = False):
    """``fn(*args)``: a model's own hook (``n_states``, ``effects``, ...), any fault of it as
    one ModelError line naming the model, the hook and the user's file and line. ``count``:
    the result must be a whole number (before, ``int()`` cut 2.5 to 2 states)."""
    try:
        value = fn(*args)
    except ModelError:
        raise
    except USER_FAULTS as exc:   # user code: any fault, sys.exit too, is one line
        raise ModelError(f"{ref!r}: {what} failed: {one_line(exc)}{where(exc)}") from None
    if not count:
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Real) \
            or not float(value).is_integer():
        raise ModelError(f"{ref!r}: {what} must return a whole number, got {short(value)}")
    return int(value)


# The child of :func:`isolated`: sys.path, then (fn, args) from stdin; ("ok", value) or
# ("raised", exception) pickled into the file named by argv[1] (stdout is the user's).
_CHILD = """
import pickle, sys
stdin = sys.stdin.buffer
sys.path[:] = pickle.load(stdin)
try:
    fn, args = pickle.load(stdin)
    out = ("ok", fn(*args))
except BaseException as exc:
    out = ("raised", exc)
try:
    data = pickle.dumps(out)
    pickle.loads(data)   # (an exception that pickles but cannot be made again)
except Exception:
    from engine.contract import ModelError
    data = pickle.dumps(("raised", ModelError(f"{type(out[1]).__name__}: {out[1]}")))
with open(sys.argv[1], "wb") as fh:
    fh.write(data)
import os
os._exit(0)   # (the result is out: a crash while tearing down is not the user's)
"""
CRASHES = {"SIGSEGV", "SIGBUS", "SIGILL", "SIGFPE", "SIGABRT"}   # a fault in compiled code
TIMEOUT_ENV = "DITHERLAB_MODEL_TIMEOUT_S"   # how long :func:`isolated` waits for a result
TIMEOUT_S = 600.0   # compiling a brought model's kernels takes 10-60 s; its sample points more
# how long one task of a brought model's points may run (sweeps.workers.task.watched): a
# block takes seconds, its kernels compiled before (another knob than the first-step check's)
BLOCK_TIMEOUT_ENV = "DITHERLAB_BLOCK_TIMEOUT_S"


def timeout_s(env: str = TIMEOUT_ENV, default: float = TIMEOUT_S) -> float:
    """``$env`` (seconds, > 0; :data:`TIMEOUT_ENV` or :data:`BLOCK_TIMEOUT_ENV`), else
    ``default``; a bad value is a :class:`ModelError` line."""
    text = os.environ.get(env, "").strip()
    try:
        value = float(text) if text else default
    except ValueError:
        raise ModelError(f"{env}={text!r}: expected a number of seconds") from None
    if not value > 0:
        raise ModelError(f"{env}={text!r}: expected a number of seconds above 0")
    return value


def block_timeout_s() -> float:
    """``$DITHERLAB_BLOCK_TIMEOUT_S`` (:data:`BLOCK_TIMEOUT_ENV`), else :data:`TIMEOUT_S`."""
    return timeout_s(BLOCK_TIMEOUT_ENV, TIMEOUT_S)


def isolated(who: str, fn, *args):
    """``fn(*args)`` in a child Python process, for code a user brings: numba checks no
    bounds, so a model that reads or writes outside its arrays can kill the process that
    runs it with a segmentation fault -- ``ditherlab plan`` and ``submit`` died so at the
    spec's first-step check, with no line at all. Here the child dies instead, and the
    crash is one :class:`ModelError` line naming ``who``. ``fn`` and ``args`` must pickle
    (``fn`` by its module and name); ``fn``'s exceptions are raised again here (its
    ModelError lines unchanged), its value returned. The child has this process's
    environment and ``sys.path`` (a user's module found from the current folder too); its
    output is shown only when it ends without a result. Costs a Python start (~1 s). A child
    without a result after :func:`timeout_s` (an endless loop in a kernel: it hung ``plan``)
    is killed, and that is one line too."""
    import pickle
    import signal
    import subprocess
    import tempfile

    limit = timeout_s()
    with tempfile.TemporaryDirectory(prefix="ditherlab-isolated-") as tmp:
        result = Path(tmp) / "result.pickle"
        try:
            proc = subprocess.run([sys.executable, "-c", _CHILD, str(result)],
                                  input=pickle.dumps(list(sys.path)) + pickle.dumps((fn, args)),
                                  capture_output=True, timeout=limit)
        except subprocess.TimeoutExpired:   # (subprocess.run killed the child)
            raise ModelError(f"{who}: no result after {limit:g} s -- an endless loop in its "
                             "kernels, or a stiff model spending its step budget (integrator "
                             f"= \"rodas4\")? ({TIMEOUT_ENV} sets how long to wait)") from None
        if result.exists():
            try:
                status, value = pickle.loads(result.read_bytes())
            except Exception as exc:  # noqa: BLE001 -- one line, whatever came back
                raise ModelError(f"{who}: its result could not be read back "
                                 f"({one_line(exc)})") from None
        elif proc.returncode < 0:
            try:
                name = signal.Signals(-proc.returncode).name
            except ValueError:
                name = f"signal {-proc.returncode}"
            why = ("a crash in compiled code, not an exception -- a read or write outside "
                   "its arrays? numba checks no bounds" if name in CRASHES else
                   "killed from outside: out of memory?")
            raise ModelError(f"{who}: the process running it died ({name}): {why}")
        else:
            said = proc.stderr.decode(errors="replace").strip().splitlines()
            raise ModelError(f"{who}: the process running it ended (exit {proc.returncode}) "
                             f"without a result: {said[-1] if said else 'no message'}")
    if status == "raised":
        raise value
    return value
