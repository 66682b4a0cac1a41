"""Blocks on threads of the submitting process: the few calls of a dask client that a run
makes (``submit``, ``gather``, ``cancel``), on a ``concurrent.futures`` thread pool.

The engine's kernels release the GIL while they run (engine.jit: ``nogil``), so the
threads compute side by side; a sweep whose estimated work is below the cost of starting a
cluster runs here, with the same task (:func:`sweeps.workers.task.compute_block`), journal,
cube and fingerprint checks as on a cluster (sweeps.run.local.run_blocks_local). numba
compiles a kernel once per process, under its own lock: the first thread to need it
compiles, the others wait for it.
"""
from __future__ import annotations

from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait


class ThreadClient:
    """``threads`` worker threads (named ``name_k``) behind a dask-like ``submit``
    (``pure`` ignored)."""

    def __init__(self, threads: int, name: str = "ditherlab-block"):
        self.threads = max(1, int(threads))
        self._pool = ThreadPoolExecutor(self.threads, thread_name_prefix=name)

    def submit(self, fn, *args, pure=None, **kwargs) -> Future:
        return self._pool.submit(fn, *args, **kwargs)

    @staticmethod
    def gather(futures):
        return [f.result() for f in futures]

    @staticmethod
    def cancel(futures) -> None:
        for f in futures:
            f.cancel()

    @staticmethod
    def wait_any(futures, timeout: float) -> set:
        """The futures among ``futures`` done within ``timeout`` seconds."""
        return wait(list(futures), timeout=timeout, return_when=FIRST_COMPLETED).done

    def close(self) -> None:
        """Drop what has not started; wait for the blocks running (a numba kernel cannot
        be interrupted)."""
        self._pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> bool:
        self.close()
        return False
