"""Kernel parts compile without a CPython wrapper: only kernels are called from Python.

numba compiles every ``njit`` function with a CPython wrapper: machine code that unboxes
Python arguments (arrays, records, tuples), calls the function and boxes its result, so
that Python can call it. The engine's functions are built by factories and called from
other jitted functions, almost none from Python (``njit(entry=True)`` marks those): the
block kernel, the point kernel, a method's ``alloc``, the analysis paths' kernels,
``engine.dither.fixed_step`` (the spec's step check), the gallery's trajectory loop, and
every part of a scene with a brought model, which engine.systems.first_step calls one by
one (engine.systems.probed). The other functions' wrappers (a right-hand side, a law, DP5's
attempt, the event locator, ...) were generated, optimised, turned into machine code and
cached for nothing: 0.4-0.5 s of the cheap sweep scene's 4.6 s first compile, 27 functions
(docs/PERFORMANCE.md). An entry made by a factory is named apart from the same function
as a part (engine.jit.njit), so the two never share a cache entry.

So :func:`engine.jit.njit` compiles a function that is not an entry with numba's
``no_cpython_wrapper`` and makes its dispatcher a :class:`KernelPart`. numba's own call
of such a dispatcher from Python would jump to a wrapper that does not exist (a
segmentation fault); :meth:`KernelPart.__call__` instead compiles a twin with a wrapper,
without the disk cache (the cache index does not tell the two kinds apart), and calls it.
So a test, a user trying their law in a notebook, or an entry point not marked as one
still gets the right answer, only with a compile of its own; a kernel calling a part
is unchanged (numba links the part's code in and inlines it). numba.cuda compiles a part
called from a GPU kernel as a device function, which has no wrapper anyway.

numba internals (pinned to 0.68 in pyproject.toml): tests/engine/test_kernel_parts.py.
"""
from __future__ import annotations

import threading

from numba.core.registry import CPUDispatcher

_TWINS = threading.Lock()


class KernelPart(CPUDispatcher):
    """A CPU dispatcher compiled without a CPython wrapper (see the module docstring)."""

    def __call__(self, *args, **kws):
        return self.from_python()(*args, **kws)

    def from_python(self) -> CPUDispatcher:
        """This function's twin with a CPython wrapper, compiled per process, uncached."""
        twin = self.__dict__.get("_ditherlab_twin")
        if twin is None:
            import numba

            with _TWINS:
                twin = self.__dict__.get("_ditherlab_twin")
                if twin is None:
                    options = {k: v for k, v in self.targetoptions.items()
                               if k not in ("no_cpython_wrapper", "nopython")}
                    twin = numba.njit(cache=False, **options)(self.py_func)
                    self._ditherlab_twin = twin
        return twin


def part(dispatcher):
    """``dispatcher`` (compiled with ``no_cpython_wrapper``) as a :class:`KernelPart`
    (unchanged where it is none: ``NUMBA_DISABLE_JIT=1`` makes njit return the function)."""
    if type(dispatcher) is CPUDispatcher:
        dispatcher.__class__ = KernelPart
    return dispatcher
