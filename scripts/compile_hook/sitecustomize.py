"""Which test compiles what, and for how long (issue 38: CI's time is numba compiling).

Put this folder on ``PYTHONPATH`` and name a log file in ``DITHERLAB_COMPILE_LOG``: every
Python process started so (pytest's workers, the ``ditherlab`` commands and dask workers the
tests start, which inherit the environment) appends one JSON line per top-level numba
compilation: the test running (``PYTEST_CURRENT_TEST``), the function, its seconds. Then
``scripts/compile_costs.py LOG`` sums them. With an empty kernel cache, to see every compile::

    DITHERLAB_CACHE_DIR=$(mktemp -d) DITHERLAB_COMPILE_LOG=/tmp/compiles.jsonl \
        PYTHONPATH=scripts/compile_hook scripts/test -m "long or not long"

Without ``DITHERLAB_COMPILE_LOG`` it does nothing (not even import numba). With it, every
process imports numba at start, so the two tests that check a command imports no numerics
(tests/e2e/test_cli_ecosystem.py) fail under the hook, and only under it. Measured with it
on 2026-11-27: 106 distinct engine kernels, 115 kernel compiles in a cold CI run.
"""
import json
import os
import sys
import time

if os.environ.get("DITHERLAB_COMPILE_LOG"):
    try:
        from numba.core import event
    except ImportError:   # a Python without numba (the system's): nothing to log
        event = None

    if event is not None:
        def _scene_on_stack():
            """The engine Scene being compiled for: the nearest caller's local ``scene``
            (engine.api.simulate, engine.blocks.run_block), as its non-default fields."""
            frame = sys._getframe(2)
            while frame is not None:
                scene = frame.f_locals.get("scene")
                if hasattr(scene, "outputs") and hasattr(scene, "integrator"):
                    return repr(scene)
                frame = frame.f_back
            return None

        class _TopLevelCompiles(event.Listener):
            """Logs the outermost ``numba:compile`` events (nested ones are inside them)."""

            def __init__(self, path: str):
                self.path, self.started = path, []

            def on_start(self, ev):
                self.started.append(time.perf_counter())

            def on_end(self, ev):
                t0 = self.started.pop()
                if self.started:
                    return
                func = getattr(ev.data.get("dispatcher"), "py_func", None)
                line = {"test": os.environ.get("PYTEST_CURRENT_TEST", "").split(" ")[0],
                        "pid": os.getpid(), "argv": " ".join(sys.argv[:2])[-80:],
                        "function": f"{getattr(func, '__module__', '?')}."
                                    f"{getattr(func, '__qualname__', '?')}",
                        "seconds": round(time.perf_counter() - t0, 3),
                        "scene": _scene_on_stack()}
                with open(self.path, "a") as fh:   # one short line: appends do not interleave
                    fh.write(json.dumps(line) + "\n")

        event.register("numba:compile", _TopLevelCompiles(os.environ["DITHERLAB_COMPILE_LOG"]))
