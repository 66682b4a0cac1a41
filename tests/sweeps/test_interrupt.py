"""A Ctrl-C swallowed inside a ``__del__`` (as inside a dask weakref callback) is raised
again at the dispatch loop's next check (sweeps.run.interrupt)."""
import os
import signal
import sys

import pytest

from sweeps.run import interrupt


class _SignalledInDel:
    def __del__(self):
        # the handler runs here, inside __del__: its KeyboardInterrupt is printed as
        # "Exception ignored in ..." and dropped
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):   # a few bytecodes: the pending signal is handled here
            pass


def _swallow_a_ctrl_c(monkeypatch) -> list:
    """The exceptions Python dropped ("Exception ignored in ...") while one object died."""
    dropped = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: dropped.append(u.exc_type))
    obj = _SignalledInDel()
    del obj
    monkeypatch.undo()
    return dropped


def test_a_swallowed_ctrl_c_is_raised_at_the_next_check(monkeypatch):
    with interrupt.remembered():
        assert _swallow_a_ctrl_c(monkeypatch) == [KeyboardInterrupt]   # it was swallowed
        with pytest.raises(KeyboardInterrupt):
            interrupt.check()
        interrupt.check()   # raised once, not again


def test_without_the_guard_the_ctrl_c_is_lost(monkeypatch):
    assert _swallow_a_ctrl_c(monkeypatch) == [KeyboardInterrupt]
    interrupt.check()   # nothing remembered: this is the defect the guard closes


def test_the_guard_leaves_a_custom_handler_alone():
    seen = []
    previous = signal.signal(signal.SIGINT, lambda *a: seen.append(1))
    try:
        with interrupt.remembered():
            assert signal.getsignal(signal.SIGINT) is not interrupt._note_and_raise
    finally:
        signal.signal(signal.SIGINT, previous)
