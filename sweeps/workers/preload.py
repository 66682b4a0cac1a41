"""What the local cluster's fork server imports once, before it forks the workers
(sweeps.workers.local_start.start_method): dask's worker, the engine's block task, and numba's
typing and target registries, which numba otherwise loads at a process's first compilation
or kernel-cache load (0.25 s here; 0.6 s when numba's BLAS check imports scipy.linalg,
which engine.jit.load_numba_registries answers without the import). A worker forked from
the server starts with all of it in memory instead of importing it again, each worker on
its own (issue 37: the start of 16 spawned workers took 15 s on a 16-core machine)."""
import distributed  # noqa: F401

from engine import blocks  # noqa: F401
from engine.jit import load_numba_registries

from . import task  # noqa: F401

load_numba_registries()
