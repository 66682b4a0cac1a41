"""numba's compiles run on a deep Python data stack (engine.deep_stack).

A first compile in a worker thread spent half its time mapping and unmapping 16 KiB chunks
of CPython's data stack (309,000 ``mmap`` calls for the cheap sweep's scene; Fig. 14's
scene 18.8-20.6 s against 9.4-9.7 s on the deep stack). These tests need no clock: they
count the thread's page faults (every freshly mapped chunk is a fault when first touched)
and look for the deep frame under numba's compile.
"""
import resource
import sys
import threading

import numba
import pytest
from numba.core import dispatcher, event

from engine import deep_stack, jit  # noqa: F401 -- importing engine.jit installs it

ROUNDS = 2000


def _dive(n):
    return 0 if n == 0 else _dive(n - 1) + 1


def _dives():
    """ROUNDS calls 400 frames deep: each crosses 16 KiB chunk boundaries, down and up."""
    for _ in range(ROUNDS):
        _dive(400)


def _faults_in_a_thread(fn) -> int:
    """Minor page faults of a fresh thread (a shallow stack, as a worker's) running fn."""
    out = []

    def run():
        before = resource.getrusage(resource.RUSAGE_THREAD).ru_minflt
        fn()
        out.append(resource.getrusage(resource.RUSAGE_THREAD).ru_minflt - before)

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    return out[0]


@pytest.mark.skipif(not hasattr(resource, "RUSAGE_THREAD"), reason="Linux's per-thread rusage")
def test_a_deep_stack_maps_no_chunk_per_call():
    plain = _faults_in_a_thread(_dives)
    deep = _faults_in_a_thread(lambda: deep_stack.on_a_deep_stack(_dives))
    if sys.version_info < (3, 13):   # (mended in later CPythons: no fault to save there)
        assert plain >= ROUNDS, plain   # at least one new chunk per round
    assert deep < ROUNDS / 10, (plain, deep)


def test_the_deep_frame_reserves_what_it_says():
    assert deep_stack._on_a_deep_stack.__code__.co_stacksize * 8 >= deep_stack.RESERVE
    assert deep_stack.on_a_deep_stack(divmod, 7, 2) == (3, 1)


def test_numba_compiles_on_the_deep_stack_in_any_thread():
    """If numba's compile moves away from ``Dispatcher.compile``, this fails (the wrapper
    would then no longer be on the way of a compile)."""
    assert getattr(dispatcher.Dispatcher.compile, "_ditherlab", False)
    seen = []

    class Look(event.Listener):
        def on_start(self, ev):
            frame, names = sys._getframe(), set()
            while frame is not None:
                names.add(frame.f_code.co_name)
                frame = frame.f_back
            seen.append("_on_a_deep_stack" in names)

        def on_end(self, ev):
            pass

    @numba.njit
    def twice(x):
        return 2 * x

    def call():
        assert twice(21) == 42           # from Python: _compile_for_args -> compile
        twice.compile((numba.float64,))  # explicitly, as engine.compiling.compile_once does

    with event.install_listener("numba:compile", Look()):
        thread = threading.Thread(target=call)
        thread.start()
        thread.join()
    assert seen == [True, True]
