"""The web server's first imports, made by one thread at a time.

The server's work runs on threads: pages read cubes on the event loop's pool, the explorer
computes (and warms up, at start) on its own, maps are handed to the drawing processes by a
third. Each imports what it needs when first asked, and CPython's import locks hand a thread
a *partially initialized* module when another thread is importing the same package and that
package imports itself in a circle (its deadlock avoidance; python/cpython#87681 is one
report): dask's ``__init__`` imports ``dask.base``, which imports ``dask``. A page opening
its first cube (xarray asks for ``dask.base``) while the explorer's warm-up imported dask
was answered 500, "cannot import name 'annotate' from partially initialized module
'dask.base'" (CI, 11-29; here 5 server starts in 9 when the first request was a map).

Every thread of the server calls :func:`ready` before its work: the first caller imports
:data:`MODULES` (what the web's threads import, and with them their packages) under a lock,
the others wait for it, once; after that :func:`ready` returns at once. The listening line
is not delayed (importing xarray and dask is 1-1.5 s here).
"""
from __future__ import annotations

import importlib
import threading

MODULES = (
    # third-party packages the threads reach first: xarray probes dask lazily
    "numpy", "pandas", "xarray", "dask", "dask.base", "h5netcdf",
    "h5netcdf.legacyapi", "numba",
    # the modules the web's threads import inside functions, and their module-level imports
    "store", "store.cube", "store.cube_io", "store.points", "store.query", "store.flags",
    "sweeps.lookup", "sweeps.exports", "sweeps.overview", "sweeps.estimates.time_history",
    "sweeps.spec.load", "sweeps.planning.plan", "sweeps.run.new_cube", "sweeps.workers.task",
)
_lock = threading.Lock()
_ready = False


def ready() -> None:
    """Return once :data:`MODULES` are imported (by this thread if it is the first)."""
    global _ready
    if _ready:
        return
    with _lock:
        if not _ready:
            for name in MODULES:
                importlib.import_module(name)
            _ready = True


def after_imports(fn, *args):
    """``fn(*args)`` once :func:`ready` returned: what the server's threads run."""
    ready()
    return fn(*args)
