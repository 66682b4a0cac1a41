"""numba's CPU registries loaded without its BLAS probe (an import of scipy.linalg)."""
from __future__ import annotations

import sys

_REGISTRIES_LOADED = False


def _blas_is_scipys() -> None:
    """numba.np.arraymath's BLAS probe, answered: scipy (a dependency) carries one."""


def load_numba_registries() -> None:
    """Load numba's CPU typing and target registries now, as numba does at a process's
    first compile or kernel-cache load, less one probe: importing numba.np.arraymath asks
    whether a BLAS exists by importing scipy.linalg, 0.35 s of the 0.6 s load here, in
    every process that runs a kernel (a ``submit``, each pytest worker, a dask worker's
    fork server; issue 37's warm cheap sweep took 1.9 s in all). ditherlab depends on
    scipy, so the answer is yes; it decides only arraymath's ``_HAVE_BLAS`` (whether
    ``np.correlate`` and ``np.convolve`` use BLAS). numba's own ``ensure_blas`` is back
    before this returns, and the linear algebra that a brought law may call imports
    scipy.linalg when it is compiled, as before. Nothing changes in a kernel
    (tests/engine/test_registries.py).

    Called where a kernel is first compiled or loaded (engine.compiling.compile_once,
    engine.api.simulate, the analysis path, the fork server's preload); a process whose
    first compile goes elsewhere runs numba's probe, only slower. Under numba's compiler
    lock, as numba refreshes: no other thread compiles while the probe is swapped. numba
    internals (pinned in pyproject.toml): if the probe moves, numba runs it."""
    global _REGISTRIES_LOADED
    if _REGISTRIES_LOADED:
        return
    from numba.core.compiler_lock import global_compiler_lock
    from numba.core.registry import cpu_target
    from numba.np import linalg

    with global_compiler_lock:
        swap = "numba.np.arraymath" not in sys.modules   # (else numba has probed)
        probe = getattr(linalg, "ensure_blas", None) if swap else None
        try:
            if probe is not None:
                linalg.ensure_blas = _blas_is_scipys
            cpu_target.typing_context.refresh()
            cpu_target.target_context.refresh()
        finally:
            if probe is not None:
                linalg.ensure_blas = probe
                arraymath = sys.modules.get("numba.np.arraymath")
                if getattr(arraymath, "ensure_blas", None) is _blas_is_scipys:
                    arraymath.ensure_blas = probe   # (its own name, bound at import)
        _REGISTRIES_LOADED = True
