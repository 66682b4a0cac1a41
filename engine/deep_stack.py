"""numba compiles on a deep Python data stack: up to half of a first compile was ``mmap``.

Since 3.11, CPython keeps a thread's Python frames in 16 KiB chunks of a data stack: a call
that does not fit in the current chunk maps a new one, and the return that empties it unmaps
it at once (``push_chunk`` and ``_PyThreadState_PopFrame``; CPython issue gh-142183, mended
in 2026 for 3.13 and 3.14 by one spare chunk per thread, not for 3.11 or 3.12). numba's
compiler is deep, recursive Python (type inference, ``deepcopy`` of its IR for inlining);
wherever its busiest calls sit on a chunk boundary, each of them maps and unmaps a chunk.
Where the boundaries fall depends on the frames below the compile, so the cost depended on
the thread that compiled. The cheap sweep's scene (scripts/bench_efficiency.py) compiled in
6.0-8.0 s on a main thread and in 8.1-9.1 s on a worker thread (309,000 ``mmap`` calls, 2.2
to 3.3 s of system time), Fig. 14's in 18.8-20.6 s on a thread; on a deep stack, 5.5-5.8 s
and 9.4 s, with 0.2 s of system time (AMD EPYC, 2 cores; docs/PERFORMANCE.md).

:func:`install` wraps numba's compile of a CPU function, ``Dispatcher.compile`` (called by
engine.compiling.compile_once, and by a dispatcher called from Python with argument types it has
no machine code for), so that the compile runs in a frame of :func:`_on_a_deep_stack`,
whose code object claims an evaluation stack of ``RESERVE`` bytes it never uses. CPython
gives that frame a new chunk twice its size (``push_chunk`` rounds up to a power of two),
and every frame the compile pushes lives in the other half: no chunk is mapped or unmapped
until the compile returns (the deepest compile measured, Fig. 14's scene, stayed inside).
Pages never touched are never committed. A compile nested in a compile (a callee typed
from its caller) runs on the same stack. numba.cuda's dispatcher is not wrapped: engine.gpu
makes a kernel's first launch, which compiles it, through :func:`on_a_deep_stack`.

numba internals (pinned to 0.68 in pyproject.toml): tests/engine/test_deep_stack.py fails
if its compiles stop passing through ``Dispatcher.compile``.
"""
from __future__ import annotations

import threading

RESERVE = 1 << 20   # bytes of the data stack kept for a compile

_IN_COMPILE = threading.local()


def _call(fn, args, kws):
    return fn(*args, **kws)


_on_a_deep_stack = type(_call)(
    _call.__code__.replace(co_stacksize=RESERVE // 8, co_name="_on_a_deep_stack",
                           co_qualname="_on_a_deep_stack"),
    _call.__globals__, "_on_a_deep_stack")


def on_a_deep_stack(fn, *args, **kws):
    """``fn(*args, **kws)`` with ``RESERVE`` bytes of the Python data stack above it that
    no other call's chunk shares (re-entrant: a nested call adds no stack)."""
    if getattr(_IN_COMPILE, "active", False):
        return fn(*args, **kws)
    _IN_COMPILE.active = True
    try:
        return _on_a_deep_stack(fn, args, kws)
    finally:
        _IN_COMPILE.active = False


def install() -> None:
    """Run every numba compile of a CPU dispatcher through :func:`on_a_deep_stack`."""
    from numba.core import dispatcher

    original = dispatcher.Dispatcher.compile
    if getattr(original, "_ditherlab", False):
        return

    def compile(self, sig):
        return on_a_deep_stack(original, self, sig)

    compile._ditherlab = True
    compile.__wrapped__ = original
    dispatcher.Dispatcher.compile = compile
